//! `thinshell design SCENE --target TARGET.obj --parametrisation NAME --out DIR`: a thin layer
//! over [`thinshell::design`] (docs/design.md): prints the outcome; a design that does not
//! reach the target has still written its outputs and fails with its message (exit code 1).

use std::path::Path;

use thinshell::Failure;
pub use thinshell::design::{DesignOptions, PARAMETRISATIONS, parse_bounds};
use thinshell_design::Outcome;

/// Runs `thinshell design` (see [`thinshell::design::design_command`]).
pub fn design_command(
    scene: &Path,
    target: &Path,
    out: &Path,
    overrides: &[String],
    options: &DesignOptions,
) -> Result<(), Failure> {
    let result = thinshell::design::design_command(scene, target, out, overrides, options)?;
    println!("{}", result.message);
    println!("wrote {}", out.display());
    match result.outcome {
        Outcome::Reached => Ok(()),
        _ => Err(Failure::Simulation(result.message)),
    }
}
