//! The command implementations behind the `thinshell` binary, as library functions so that they
//! can be tested without spawning processes.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use crate::mesh_info::mesh_info;

/// Why a command failed; decides the exit code.
#[derive(Debug)]
pub enum Failure {
    /// Bad input: scene, mesh, arguments (exit code 2).
    BadInput(String),
    /// The simulation failed after starting (exit code 1); the last good state was written.
    Simulation(String),
}

/// `thinshell info MESH`: prints statistics and problems of an OBJ mesh.
pub fn info(path: &Path) -> Result<(), Failure> {
    let mesh = thinshell_mesh::io::load_obj(path)
        .map_err(|e| Failure::BadInput(format!("{}: {e}", path.display())))?;
    println!("{}", path.display());
    println!("{}", mesh_info(&mesh));
    Ok(())
}

/// `thinshell check SCENE`: validates a scene and prints what would be simulated.
pub fn check(_scene: &Path, _overrides: &[String]) -> Result<(), Failure> {
    Err(Failure::BadInput("check: not yet available".into()))
}

/// `thinshell run SCENE`.
pub fn run(
    _scene: &Path,
    _out: Option<&Path>,
    _overrides: &[String],
    _quiet: bool,
    _stop: &AtomicBool,
) -> Result<(), Failure> {
    Err(Failure::BadInput("run: not yet available".into()))
}
