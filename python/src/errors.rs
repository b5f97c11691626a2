//! The exception hierarchy: `ThinshellError` and one subclass per kind of failure. Messages are
//! the `Display` of the Rust error, which is what the `thinshell` CLI prints after
//! `thinshell: error: ` (bad input) or `thinshell: simulation failed: ` (a failed step).

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    thinshell,
    ThinshellError,
    PyException,
    "Base class of every error thinshell raises."
);
create_exception!(
    thinshell,
    MeshError,
    ThinshellError,
    "A mesh that is not a valid shell mesh (thinshell-mesh's checks), or an OBJ file that cannot be read."
);
create_exception!(
    thinshell,
    SceneError,
    ThinshellError,
    "A scene that cannot be loaded or built: TOML syntax, unknown keys, wrong types or values (with the key path and position)."
);
create_exception!(
    thinshell,
    SimulationError,
    ThinshellError,
    "A step that failed (the simulation keeps its last good state), or a rest-shape edit that was rejected."
);
create_exception!(
    thinshell,
    Cancelled,
    ThinshellError,
    "A step stopped by `Simulation.cancel()` (the simulation keeps the state of its last completed step and can go on)."
);
create_exception!(
    thinshell,
    EnergyError,
    ThinshellError,
    "Energy evaluation rejected its input (rest forms, material, lengths) or produced non-finite values."
);

/// Adds the exception classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ThinshellError", py.get_type::<ThinshellError>())?;
    m.add("MeshError", py.get_type::<MeshError>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("EnergyError", py.get_type::<EnergyError>())?;
    m.add("Cancelled", py.get_type::<Cancelled>())?;
    Ok(())
}

/// A `MeshError` carrying `e`'s message.
pub fn mesh(e: impl std::fmt::Display) -> PyErr {
    MeshError::new_err(e.to_string())
}
/// A `SceneError` carrying `e`'s message.
pub fn scene(e: impl std::fmt::Display) -> PyErr {
    SceneError::new_err(e.to_string())
}
/// A `SimulationError` carrying `e`'s message.
pub fn simulation(e: impl std::fmt::Display) -> PyErr {
    SimulationError::new_err(e.to_string())
}
/// An `EnergyError` carrying `e`'s message.
pub fn energy(e: impl std::fmt::Display) -> PyErr {
    EnergyError::new_err(e.to_string())
}
/// A `Cancelled` error: the step was stopped by `Simulation.cancel()`.
pub fn cancelled() -> PyErr {
    Cancelled::new_err(
        "the step was cancelled (Simulation.cancel()); the state is that of the last completed step",
    )
}
