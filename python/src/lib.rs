//! `thinshell._thinshell`: the Python extension module of thinshell (PyO3 + numpy).
//!
//! Thin wrappers only: meshes are `thinshell_mesh::Mesh`, scenes `thinshell::scene::Scene`,
//! simulations `thinshell::sim::Simulation`, the energy layer `thinshell_energy::Assembler`.
//! Arrays cross as numpy arrays (f64, SI units); errors become the Python exceptions of
//! `errors` with the message the `thinshell` CLI prints. The GIL is released while Rust works.
//! The public Python API (with docstrings and stubs) is the `thinshell` package in
//! `python/thinshell/`, which re-exports these classes.

use pyo3::prelude::*;

mod convert;
mod energy;
mod errors;
mod mesh;
mod scene;
mod simulation;
mod state_energy;

/// The extension module.
#[pymodule]
fn _thinshell(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<mesh::PyMesh>()?;
    m.add_class::<scene::PyScene>()?;
    m.add_class::<simulation::PySimulation>()?;
    m.add_function(wrap_pyfunction!(energy::energy_parts, m)?)?;
    m.add_function(wrap_pyfunction!(energy::reference_hessian, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
