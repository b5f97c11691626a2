//! Typed errors of the design crate.

use thinshell_energy::EnergyError;
use thinshell_solver::SolverError;

/// Errors of a design problem or its loop.
#[derive(thiserror::Error, Debug)]
#[non_exhaustive]
pub enum DesignError {
    /// The forward static solve failed (residual history in the solver error).
    #[error("forward static solve failed: {0}")]
    Forward(#[from] SolverError),
    /// An energy evaluation failed.
    #[error("energy: {0}")]
    Energy(#[from] EnergyError),
    /// The equilibrium is not a strict minimum (its exact Hessian is not positive definite):
    /// it has no adjoint gradient.
    #[error(
        "the equilibrium is not a strict minimum (its exact Hessian is not positive definite): \
         no adjoint gradient"
    )]
    NotAMinimum,
    /// Inputs of the problem do not fit together.
    #[error("invalid design input: {0}")]
    Invalid(String),
    /// The optimiser reported an error.
    #[error("optimiser: {0}")]
    Optimiser(String),
}
