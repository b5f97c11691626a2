//! The shell layer: boundary conditions, loads, the shell objectives and the time integrators,
//! on top of the energy crate's [`Assembler`](thinshell_energy::Assembler).
//!
//! Module dependencies point one way (no circles): `bc`, `loads`, `angles`, `contact_pattern`,
//! `contact_stiffness`, `obstacle` → `contact` → `system` → `objective` → `integrator` → `statics` (with `homotopy`), `implicit`, `explicit`; `objective` → `path` (with
//! the crate's [`path`](crate::path) tracer).

mod adjoint;
pub mod angles;
pub mod bc;
pub mod contact;
mod contact_pattern;
pub mod contact_stiffness;
pub mod explicit;
mod homotopy;
pub mod implicit;
pub mod integrator;
pub mod loads;
pub mod modes;
mod objective;
pub mod obstacle;
pub mod path;
mod rigid;
pub mod statics;
pub mod system;

pub use angles::{AngleReport, AngleSettings};
pub use bc::{Boundary, Prescribed};
pub use contact::{
    Contact, ContactError, ContactRunState, ContactSettings, ContactStats, Obstacle,
};
pub use explicit::ExplicitEuler;
pub use implicit::ImplicitEuler;
pub use integrator::{Integrator, NewtonCache, StepKind, StepReport};
pub use loads::Loads;
pub use modes::{ModalSettings, Modes};
pub use path::ShellPath;
pub use statics::Static;
pub use system::{ShellSystem, State};
