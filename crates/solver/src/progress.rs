//! Progress of a Newton solve while it runs: an optional observer called after every accepted
//! iteration, so that a caller can show a long solve moving (a progress bar, a log line)
//! without the solver knowing how it is shown.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use crate::IterationHessian;

/// One accepted Newton iteration, as reported to a [`ProgressHook`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonProgress {
    /// Iterations accepted so far in this solve (1 after the first step).
    pub iteration: usize,
    /// Relative residual ‖∇f‖∞ / force scale at the new iterate.
    pub residual: f64,
    /// Line-search step length α of the accepted step (1 = full Newton step).
    pub step_length: f64,
    /// Which Hessian the step was computed with.
    pub hessian: IterationHessian,
    /// Whether the factorisation needed a diagonal shift.
    pub regularized: bool,
    /// Wall time since the solve started.
    pub elapsed: Duration,
}

/// An observer of Newton iterations; called on the solving thread, so it should be cheap
/// (update a progress bar, print a line). Shared (`Arc`) so that integrators can keep it across
/// rebuilt workspaces.
pub type ProgressHook = Arc<dyn Fn(&NewtonProgress) + Send + Sync>;

/// A flag that cancels a running solve: set it (from any thread, e.g. a Ctrl-C handler) and the
/// solve stops before its next Newton iteration with [`SolverError::Cancelled`](crate::SolverError::Cancelled),
/// carrying its last accepted iterate. The solver never clears it; the owner does.
pub type CancelFlag = Arc<AtomicBool>;
