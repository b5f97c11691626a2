//! thinshell: scenes and the run loop over the shell crates.
//!
//! A scene file (`docs/scenes.md`) is loaded and validated by [`scene`], turned into exactly the
//! energy terms, loads and stimulus it asks for, and run with an observer that reports progress
//! and writes output ([`output`]). The command-line tool (crate `thinshell-cli`), the Python
//! package and `cargo xtask` are thin layers over this library.
//!
//! Two ways in, to the same [`Simulation`]: a scene file ([`Scene`], `docs/scenes.md`) through
//! [`Simulation::build`], or Rust values (a mesh, a shell model, loads, boundary, growth, an
//! integrator) through [`SimulationBuilder`]. Either steps the same way ([`Simulation::step`],
//! [`Simulation::run`] with an [`Observer`]): continuation of large rest-form changes, static
//! load ramps, growth with mass uptake.

//!
//! `thinshell` is the one dependency a Rust program needs: the crates whose types the builder
//! takes are re-exported ([`mesh`], [`energy`], [`system`], [`solver`], [`growth`],
//! [`nalgebra`]), and
//! [`prelude`] brings the common ones into scope. Boundary conditions by region, as a scene's
//! `region = { box = … }`, come from [`Supports`].
//!
//! A cantilever strip under gravity from Rust values, run to its end with an [`Observer`] that
//! sees every step (a `stop` flag set from another thread, e.g. by Ctrl-C, ends the run cleanly
//! after the current step):
//!
//! ```
//! use std::sync::atomic::AtomicBool;
//! use thinshell::prelude::*;
//!
//! let mesh = generators::rectangle(0.1, 0.02, 10, 2)?; // m
//! let model = ShellModel {
//!     material: Material::paper(),
//!     terms: Terms::ELASTIC,
//!     sff: SffKind::default(),
//! };
//! let end = Region::Box {
//!     min: Vector3::new(-1e-9, -1.0, -1.0),
//!     max: Vector3::new(1e-9, 1.0, 1.0),
//! };
//! let boundary = Supports::new(&mesh).pin(&end, "xyz")?.clamp(&end)?.build();
//! let loads = Loads {
//!     gravity: Vector3::new(0.0, 0.0, -9.81), // m/s²
//!     ..Loads::default()
//! };
//! let mut sim = SimulationBuilder::new(mesh, model)
//!     .boundary(boundary)
//!     .loads(loads)
//!     .static_solve()
//!     .build()?;
//!
//! /// Records the elastic energy after every step.
//! struct Energies(Vec<f64>);
//! impl Observer for Energies {
//!     fn step(&mut self, _sim: &Simulation, record: &StepRecord) {
//!         self.0.push(record.energy.elastic());
//!     }
//! }
//! let mut seen = Energies(Vec::new());
//! let summary = sim.run(&mut seen, &AtomicBool::new(false))?;
//! assert_eq!(summary.steps, 1);
//! assert_eq!(seen.0.len(), 1);
//! // The free end hangs below the clamped one.
//! let tip = sim.positions().iter().map(|x| x.z).fold(f64::INFINITY, f64::min);
//! assert!(tip < 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Debug builds of a program using thinshell are very slow (the sparse Cholesky factorisation
//! is about 250× slower unoptimised); optimise the dependencies even in debug builds with
//! `[profile.dev.package."*"] opt-level = 3` in the program's `Cargo.toml`.

pub mod atomic;
pub mod design;
pub mod fields;
pub mod mesh_info;
pub mod modes;
pub mod output;
pub mod reference;
pub mod scene;
pub mod sim;
mod supports;
pub mod vtk;

/// Linear algebra of the public API (positions are `nalgebra::Vector3<f64>`, forms
/// `nalgebra::Matrix2<f64>`), the same version as thinshell's.
pub use nalgebra;
/// The shell model: material, energy terms, bending forms, rest state, energies.
pub use thinshell_energy as energy;
/// Growth models, stimulus fields and regions.
pub use thinshell_growth as growth;
/// Triangle meshes: [`mesh::Mesh`], OBJ I/O ([`mesh::io`]), generators ([`mesh::generators`]).
pub use thinshell_mesh as mesh;
/// Newton's method, the integrators, path following.
pub use thinshell_solver as solver;
/// The shell system: boundary conditions, loads, contact, modes, the shell path.
pub use thinshell_system as system;

pub use output::{Failure, OutputWriter};
pub use scene::{Scene, SceneError};
pub use sim::{
    BuildError, EnergyTerms, NoObserver, Observer, RunSummary, Simulation, SimulationBuilder,
    StepError, StepFailure, StepRecord,
};
pub use supports::{SupportError, Supports};

/// The types a program building a simulation from Rust values uses: `use thinshell::prelude::*;`.
pub mod prelude {
    pub use crate::energy::{Material, RestState, SffKind, ShellModel, Terms};
    pub use crate::growth::{
        DirectedHeat, GrowthModel, Isotropic, Prescribed as PrescribedStimulus, Region,
        StimulusField, Swelling,
    };
    pub use crate::mesh::{FaceId, Mesh, VertexId, generators, io};
    pub use crate::nalgebra::{Matrix2, Vector3};
    pub use crate::solver::NewtonSettings;
    pub use crate::system::{Boundary, Loads};
    pub use crate::{
        NoObserver, Observer, RunSummary, Scene, Simulation, SimulationBuilder, StepRecord,
        Supports,
    };
}

/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
