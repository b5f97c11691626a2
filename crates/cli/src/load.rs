//! Loading a scene file with `--set` overrides and building it (`run`, `check`, `resume`).

use std::path::Path;

use thinshell::{Failure, Scene, Simulation};

/// Loads a scene with overrides and builds it; any problem is bad input.
pub(crate) fn load(scene: &Path, overrides: &[String]) -> Result<(Scene, Simulation), Failure> {
    let scene = Scene::load_with_overrides(scene, overrides)
        .map_err(|e| Failure::BadInput(e.to_string()))?;
    let sim = Simulation::build(&scene).map_err(|e| Failure::BadInput(e.to_string()))?;
    Ok((scene, sim))
}
