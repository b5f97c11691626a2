//! The shell system: a mesh with its material, rest state, boundary conditions, loads and
//! contact ([`ShellSystem`]), as a [`Model`](thinshell_solver::Model) the solver's integrators
//! ([`Static`](thinshell_solver::Static), [`ImplicitEuler`](thinshell_solver::ImplicitEuler),
//! [`ExplicitEuler`](thinshell_solver::ExplicitEuler)) step; its modal analysis ([`Modes`]) and
//! path following ([`ShellPath`]).
//!
//! Module dependencies point one way (no circles): `boundary`, `loads`, `angles` → `system`
//! (with the contact term of `thinshell-contact`) → `objective` → `model` (the solver's trait)
//! → `shell_path`, `modes`.
//!
//! A paper sheet pinned on its boundary, one implicit step under gravity, then the static sag:
//!
//! ```
//! use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
//! use thinshell_mesh::generators;
//! use thinshell_solver::nalgebra::Vector3;
//! use thinshell_solver::{ImplicitEuler, Integrator, State, Static};
//! use thinshell_system::{Boundary, Loads, ShellSystem};
//!
//! let mesh = generators::rectangle(1.0, 1.0, 6, 6)?;
//! let sff = SffKind::MidEdgeAverage;
//! let rest = RestState::from_mesh(&mesh, mesh.positions(), sff)?;
//! let model = ShellModel {
//!     material: Material::paper(),
//!     terms: Terms::ELASTIC,
//!     sff,
//! };
//! let boundary = Boundary {
//!     pinned_vertices: mesh.topology().boundary_vertices().to_vec(),
//!     ..Default::default()
//! };
//! let loads = Loads { gravity: Vector3::new(0.0, 0.0, -9.81), ..Default::default() };
//! let x0 = mesh.positions().to_vec();
//! let mut system = ShellSystem::new(mesh, model, rest, boundary, loads)?;
//! let weight = system.mass().iter().sum::<f64>() * 9.81;
//!
//! let mut state = State::at_rest(x0.clone());
//! let mut implicit = ImplicitEuler::new(1e-3);
//! implicit.force_scale = Some(weight); // loads far below E·h·L: measure residuals against them
//! let report = implicit.step(&mut system, &mut state)?;
//! assert!(report.newton.unwrap().iterations >= 1 && state.t == 1e-3);
//!
//! let mut statics = Static { force_scale: Some(weight), ..Static::default() };
//! let mut x = x0.clone();
//! statics.solve(&mut system, &mut x)?;
//! assert!(x.iter().all(|p| p.z <= 0.0)); // sags along gravity, pins stay at z = 0
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod adjoint;
pub mod angles;
pub mod boundary;
pub mod loads;
mod model;
pub mod modes;
mod objective;
mod rigid;
pub mod shell_path;
pub mod system;

pub use angles::{AngleReport, AngleSettings};
pub use boundary::{Boundary, Prescribed};
pub use loads::Loads;
pub use model::ShellProblem;
pub use modes::{ModalSettings, Modes};
pub use shell_path::ShellPath;
pub use system::ShellSystem;
pub use thinshell_contact::{
    Contact, ContactError, ContactRunState, ContactSettings, ContactStats, Obstacle,
};

/// What one step of a [`ShellSystem`] did: the solver's report with the shell's energy terms
/// and contact statistics.
pub type StepReport = thinshell_solver::StepReport<thinshell_energy::EnergyTerms, ContactStats>;

/// An integrator of a [`ShellSystem`] (boxed by callers that choose it at run time).
pub type ShellIntegrator = dyn thinshell_solver::Integrator<ShellSystem> + Send;

/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
