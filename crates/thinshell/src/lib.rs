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

pub mod atomic;
pub mod design;
mod face_fields;
pub mod mesh_info;
pub mod modes;
pub mod output;
pub mod reference;
pub mod scene;
pub mod sim;
pub mod vtk;

pub use output::{Failure, OutputWriter};
pub use scene::{Scene, SceneError};
pub use sim::{
    BuildError, EnergyTerms, NoObserver, Observer, RunSummary, Simulation, SimulationBuilder,
    StepError, StepFailure, StepRecord,
};

/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
