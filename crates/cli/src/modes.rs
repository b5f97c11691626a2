//! `thinshell modes`: the natural modes of a scene (the library's `thinshell::modes`) written
//! to a directory and printed.

use std::path::{Path, PathBuf};

use thinshell::modes::{simulation_modes, write_modes};
use thinshell::output::Failure;
use thinshell::{Scene, Simulation};

/// `thinshell modes SCENE --count N --out DIR`: builds the scene, computes its `count`
/// lowest modes about the start state ([`thinshell::modes::simulation_modes`]), writes them ([`thinshell::modes::write_modes`];
/// default directory `out/<scene name>-modes`) and prints the frequencies.
pub fn modes_command(
    scene: &Path,
    count: usize,
    out: Option<&Path>,
    overrides: &[String],
) -> Result<(), Failure> {
    let scene = Scene::load_with_overrides(scene, overrides)
        .map_err(|e| Failure::BadInput(e.to_string()))?;
    let mut sim = Simulation::build(&scene).map_err(|e| Failure::BadInput(e.to_string()))?;
    let modes =
        simulation_modes(&mut sim, count).map_err(|e| Failure::Simulation(e.to_string()))?;
    let dir = out.map_or_else(
        || PathBuf::from("out").join(format!("{}-modes", sim.name())),
        Path::to_path_buf,
    );
    write_modes(&dir, &sim, &modes).map_err(Failure::Simulation)?;
    println!("{}: {} modes (Hz):", sim.name(), modes.frequencies.len());
    for (k, f) in modes.frequencies.iter().enumerate() {
        println!("  {:>3}  {f:.6e}", k + 1);
    }
    println!("wrote {}/modes.json and frames.pvd", dir.display());
    Ok(())
}
