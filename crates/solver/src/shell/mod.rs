//! The shell layer: boundary conditions, loads, the shell objectives and the time integrators,
//! on top of the energy crate's [`Assembler`](thinshell_energy::Assembler).

pub mod angles;
pub mod bc;
pub mod integrators;
pub mod loads;
pub mod system;

pub use angles::{AngleReport, AngleSettings};
pub use bc::{Boundary, Prescribed};
pub use integrators::{ExplicitEuler, ImplicitEuler, Integrator, Static, StepReport};
pub use loads::Loads;
pub use system::{ShellSystem, State};
