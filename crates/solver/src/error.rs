//! The error type of the crate.

use thinshell_energy::EnergyError;

/// Everything that can go wrong in the solver.
///
/// Dof indices refer to the objective's unknowns (`0..n_dofs`), iterations count from 0.
/// Errors of a Newton solve that made progress carry the residual history and the last accepted
/// iterate, so a caller can inspect or restart from it — never silent garbage. Their `Debug`
/// output summarises those vectors (length, first / last / largest entry) instead of printing
/// thousands of numbers.
///
/// Errors of the layers below keep their type as the [`source`](std::error::Error::source):
/// [`SolverError::Energy`] holds the energy crate's [`EnergyError`], and
/// [`SolverError::Objective`] any other objective's error (e.g. a growth update), so a caller
/// can downcast it (`err.source()?.downcast_ref::<GrowthError>()`).
#[derive(thiserror::Error)]
#[non_exhaustive]
pub enum SolverError {
    /// A setting is out of its admissible range.
    #[error("invalid setting `{name}` = {value}: {requirement}")]
    InvalidSetting {
        /// Name of the field (as in the settings struct).
        name: &'static str,
        /// The value given.
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// The rest state was computed with another second fundamental form than the model's
    /// (the form is named once: build the rest state with the model's form, or from forms).
    #[error(
        "the rest state was computed with the bending form {rest:?} but the model uses {model:?}; \
         build it with the model's form (`RestState::for_model`)"
    )]
    FormMismatch {
        /// The form the rest state's b̄ was computed with.
        rest: thinshell_energy::SffKind,
        /// The model's form.
        model: thinshell_energy::SffKind,
    },
    /// The modal eigen-solve did not converge within its Krylov basis limit
    /// (`ModalSettings::max_basis` of `thinshell-system`).
    #[error(
        "natural modes: not converged with a Krylov basis of {basis} vectors (largest relative \
         residual {worst:e}); raise max_basis or lower count"
    )]
    ModesDidNotConverge {
        /// Basis size reached.
        basis: usize,
        /// Largest relative residual of the wanted modes.
        worst: f64,
    },
    /// A vector handed to the solver has the wrong length.
    #[error("{what}: length {found}, expected {expected}")]
    DimensionMismatch {
        /// Which vector or matrix.
        what: &'static str,
        /// Expected length (number of dofs).
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// The Hessian sparsity pattern is unusable (missing diagonal, upper-triangle entry, …).
    #[error("invalid Hessian pattern at dof {dof}: {reason}")]
    InvalidPattern {
        /// Column (dof) where the problem was found.
        dof: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// The objective's force scale is not a positive finite number.
    #[error("objective force scale must be positive and finite, got {0}")]
    InvalidForceScale(f64),
    /// The objective's length scale is not a positive finite number.
    #[error("objective length scale must be positive and finite, got {0}")]
    InvalidLengthScale(f64),
    /// Per-dof coordinates for the nested-dissection ordering are not finite.
    #[error("dof {dof}: ordering coordinate is not finite")]
    NonFiniteCoordinate {
        /// Offending dof.
        dof: usize,
    },
    /// The objective value or gradient is NaN or infinite at an accepted iterate.
    #[error("non-finite {what} at Newton iteration {iteration} (dof {dof:?})")]
    NonFinite {
        /// `"value"`, `"gradient"`, `"Hessian"` or `"Newton direction"`.
        what: &'static str,
        /// Newton iteration at which it was detected.
        iteration: usize,
        /// First offending dof, if the quantity is a vector.
        dof: Option<usize>,
    },
    /// The Hessian is not positive definite and regularisation is switched off.
    #[error(
        "Hessian not positive definite at Newton iteration {iteration} (pivot {pivot} in the permuted order); enable regularisation"
    )]
    NotPositiveDefinite {
        /// Newton iteration.
        iteration: usize,
        /// Failing pivot, in faer's permuted order (a diagnostic only).
        pivot: usize,
    },
    /// Regularisation reached its largest shift without a successful factorisation (the Hessian
    /// holds NaN or is wildly indefinite).
    #[error(
        "regularisation failed at Newton iteration {iteration}: still not positive definite with mu = {mu:e} after {attempts} attempts"
    )]
    RegularizationFailed {
        /// Newton iteration.
        iteration: usize,
        /// Last relative shift tried.
        mu: f64,
        /// Number of factorisation attempts.
        attempts: usize,
    },
    /// The backtracking line search found no acceptable step.
    #[error(
        "line search failed at Newton iteration {iteration} after {backtracks} backtracks (relative residual {:e})",
        residuals.last().copied().unwrap_or(f64::NAN)
    )]
    LineSearchFailed {
        /// Newton iteration.
        iteration: usize,
        /// Backtracks tried in that iteration.
        backtracks: usize,
        /// Relative residual ‖∇f‖∞ / force scale of every accepted iterate.
        residuals: Vec<f64>,
        /// The last accepted iterate.
        last_good: Vec<f64>,
    },
    /// Newton reached `max_iterations` without meeting a convergence criterion.
    #[error(
        "Newton did not converge in {iterations} iterations: the last unshifted Newton \
         correction was {} × size, and converged means at most step_tolerance = \
         {step_tolerance:e} × size (relative residual ‖∇f‖∞/force scale {:e} → {:e}; the \
         gradient test ‖∇f‖∞ ≤ {tolerance:e} × force scale applies only where a force scale \
         was given)",
        last_correction.map_or_else(|| "not computed".to_string(), |c| format!("{c:e}")),
        residuals.first().copied().unwrap_or(f64::NAN),
        residuals.last().copied().unwrap_or(f64::NAN)
    )]
    NewtonDidNotConverge {
        /// Relative residual ‖∇f‖∞ / force scale of every accepted iterate (first = initial).
        residuals: Vec<f64>,
        /// Iterations performed, rejected and undone ones included (what `max_iterations`
        /// limits).
        iterations: usize,
        /// The gradient tolerance of the gradient test (used only with a force scale).
        tolerance: f64,
        /// `‖dx‖∞ / size` of the last unshifted Newton correction computed (the convergence
        /// test that was not met), if any.
        last_correction: Option<f64>,
        /// The limit (relative to the length scale) that correction was tested against:
        /// [`NewtonSettings::step_tolerance`](crate::NewtonSettings::step_tolerance), or the
        /// relative one of implicit steps where that is larger.
        step_tolerance: f64,
        /// The last accepted iterate (the best one found when line search is on).
        last_good: Vec<f64>,
    },
    /// The solve was cancelled through its cancel flag ([`crate::CancelFlag`], checked before
    /// every Newton iteration); `last_good` is the last accepted iterate.
    #[error(
        "cancelled after {iterations} Newton iterations (relative residual {:e})",
        residuals.last().copied().unwrap_or(f64::NAN)
    )]
    Cancelled {
        /// Iterations performed (accepted and undone).
        iterations: usize,
        /// Relative residual ‖∇f‖∞ / force scale of every accepted iterate (first = initial).
        residuals: Vec<f64>,
        /// The last accepted iterate.
        last_good: Vec<f64>,
    },
    /// A path-following step ([`PathTracer`](crate::PathTracer)) failed after all its
    /// cut-backs; the tracer's point is unchanged. Boxed: the details are large.
    #[error("{0}")]
    PathFailed(Box<PathFailure>),
    /// faer reported a failure other than a non-positive pivot (out of memory, index overflow).
    #[error("sparse linear algebra failed: {0}")]
    Linear(String),
    /// The Cholesky factor estimated by the symbolic analysis does not fit in the memory budget
    /// ([`crate::memory::memory_budget`]); refused before any numeric factorisation.
    #[error(
        "{n} unknowns: the Cholesky factor needs an estimated {} (symbolic analysis), more than the {} available ({})",
        crate::memory::human_bytes(*estimate),
        crate::memory::human_bytes(*budget),
        crate::memory::BUDGET_RULE
    )]
    InsufficientMemory {
        /// Unknowns (matrix dimension).
        n: usize,
        /// Estimated bytes of the factor and its scratch memory.
        estimate: u64,
        /// The memory budget, bytes.
        budget: u64,
    },
    /// Neither the Cholesky factor nor the iterative fallback that replaces it
    /// ([`NewtonSettings::fallback`](crate::NewtonSettings::fallback)) fits in the memory
    /// budget.
    #[error(
        "{n} unknowns: the Cholesky factor needs an estimated {} (symbolic analysis) and the iterative fallback (preconditioned CG) {}, more than the {} available ({})",
        crate::memory::human_bytes(*factor_estimate),
        crate::memory::human_bytes(*estimate),
        crate::memory::human_bytes(*budget),
        crate::memory::BUDGET_RULE
    )]
    InsufficientMemoryForIterative {
        /// Unknowns (matrix dimension).
        n: usize,
        /// Estimated bytes of the Cholesky factor and its scratch memory.
        factor_estimate: u64,
        /// Estimated bytes of the fallback's preconditioner and CG vectors.
        estimate: u64,
        /// The memory budget, bytes.
        budget: u64,
    },
    /// The energy crate failed (assembly, rest state, masses, dof map).
    #[error("objective evaluation failed: {0}")]
    Energy(#[from] EnergyError),
    /// Any other error reported by an objective or a caller's update between solves (e.g. a
    /// growth rule), kept with its type: downcast the [`source`](std::error::Error::source).
    #[error("objective evaluation failed: {0}")]
    Objective(#[source] Box<dyn std::error::Error + Send + Sync>),
}

/// Details of [`SolverError::PathFailed`].
#[derive(Clone, PartialEq, thiserror::Error)]
#[error(
    "path step {step} from load factor {load_factor:e} failed after {cutbacks} cut-backs \
     (last step size {step_length:e}): {reason}"
)]
pub struct PathFailure {
    /// The step that failed (1-based).
    pub step: usize,
    /// Load factor of the last converged point (the start of the step).
    pub load_factor: f64,
    /// Step size of the last attempt (arc length, or the controlled dof's increment).
    pub step_length: f64,
    /// Halvings tried.
    pub cutbacks: usize,
    /// Why the last attempt failed.
    pub reason: String,
    /// Relative residual ‖R‖∞ / force scale of every iterate of the last attempt.
    pub residuals: Vec<f64>,
    /// The last converged point (the start of the step), free dofs.
    pub last_good: Vec<f64>,
}

impl std::fmt::Debug for PathFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PathFailure")
            .field("step", &self.step)
            .field("load_factor", &self.load_factor)
            .field("reason", &self.reason)
            .field("residuals", &Summary(&self.residuals))
            .field("last_good", &Summary(&self.last_good))
            .finish_non_exhaustive()
    }
}

impl SolverError {
    /// [`SolverError::InvalidSetting`] for the field `name` with the bad `value` and the
    /// requirement it breaks.
    pub(crate) fn invalid_setting(
        name: &'static str,
        value: f64,
        requirement: &'static str,
    ) -> SolverError {
        SolverError::InvalidSetting {
            name,
            value,
            requirement,
        }
    }

    /// Wraps an objective's own error (its type stays reachable through
    /// [`source`](std::error::Error::source)).
    pub fn objective(e: impl std::error::Error + Send + Sync + 'static) -> SolverError {
        SolverError::Objective(Box::new(e))
    }

    /// Newton iterations the failed solve spent (the iteration it failed at, or the count it
    /// ran out at); 0 for errors raised before iterating.
    pub fn newton_iterations(&self) -> usize {
        match self {
            SolverError::NonFinite { iteration, .. }
            | SolverError::NotPositiveDefinite { iteration, .. }
            | SolverError::RegularizationFailed { iteration, .. }
            | SolverError::LineSearchFailed { iteration, .. } => *iteration,
            SolverError::NewtonDidNotConverge { iterations, .. }
            | SolverError::Cancelled { iterations, .. } => *iterations,
            _ => 0,
        }
    }
}

/// Structural equality; the wrapped errors of other crates ([`SolverError::Energy`],
/// [`SolverError::Objective`]), which need not implement `PartialEq`, compare by message.
impl PartialEq for SolverError {
    fn eq(&self, other: &Self) -> bool {
        use SolverError::*;
        match (self, other) {
            (
                InvalidSetting {
                    name: a,
                    value: b,
                    requirement: c,
                },
                InvalidSetting {
                    name: x,
                    value: y,
                    requirement: z,
                },
            ) => a == x && b == y && c == z,
            (
                DimensionMismatch {
                    what: a,
                    expected: b,
                    found: c,
                },
                DimensionMismatch {
                    what: x,
                    expected: y,
                    found: z,
                },
            ) => a == x && b == y && c == z,
            (InvalidPattern { dof: a, reason: b }, InvalidPattern { dof: x, reason: y }) => {
                a == x && b == y
            }
            (InvalidForceScale(a), InvalidForceScale(x))
            | (InvalidLengthScale(a), InvalidLengthScale(x)) => a == x,
            (NonFiniteCoordinate { dof: a }, NonFiniteCoordinate { dof: x }) => a == x,
            (
                NonFinite {
                    what: a,
                    iteration: b,
                    dof: c,
                },
                NonFinite {
                    what: x,
                    iteration: y,
                    dof: z,
                },
            ) => a == x && b == y && c == z,
            (
                NotPositiveDefinite {
                    iteration: a,
                    pivot: b,
                },
                NotPositiveDefinite {
                    iteration: x,
                    pivot: y,
                },
            ) => a == x && b == y,
            (
                RegularizationFailed {
                    iteration: a,
                    mu: b,
                    attempts: c,
                },
                RegularizationFailed {
                    iteration: x,
                    mu: y,
                    attempts: z,
                },
            ) => a == x && b == y && c == z,
            (
                LineSearchFailed {
                    iteration: a,
                    backtracks: b,
                    residuals: c,
                    last_good: d,
                },
                LineSearchFailed {
                    iteration: w,
                    backtracks: x,
                    residuals: y,
                    last_good: z,
                },
            ) => a == w && b == x && c == y && d == z,
            (
                NewtonDidNotConverge {
                    residuals: a,
                    iterations: b,
                    tolerance: c,
                    last_correction: e,
                    step_tolerance: s,
                    last_good: d,
                },
                NewtonDidNotConverge {
                    residuals: w,
                    iterations: x,
                    tolerance: y,
                    last_correction: e2,
                    step_tolerance: s2,
                    last_good: z,
                },
            ) => a == w && b == x && c == y && d == z && e == e2 && s == s2,
            (
                Cancelled {
                    iterations: a,
                    residuals: b,
                    last_good: c,
                },
                Cancelled {
                    iterations: x,
                    residuals: y,
                    last_good: z,
                },
            ) => a == x && b == y && c == z,
            (PathFailed(a), PathFailed(x)) => a == x,
            (Linear(a), Linear(x)) => a == x,
            (
                InsufficientMemory {
                    n: a,
                    estimate: b,
                    budget: c,
                },
                InsufficientMemory {
                    n: x,
                    estimate: y,
                    budget: z,
                },
            ) => a == x && b == y && c == z,
            (
                InsufficientMemoryForIterative {
                    n: a,
                    factor_estimate: b,
                    estimate: c,
                    budget: d,
                },
                InsufficientMemoryForIterative {
                    n: w,
                    factor_estimate: x,
                    estimate: y,
                    budget: z,
                },
            ) => a == w && b == x && c == y && d == z,
            (Energy(a), Energy(x)) => a.to_string() == x.to_string(),
            (Objective(a), Objective(x)) => a.to_string() == x.to_string(),
            _ => false,
        }
    }
}

/// `Debug` of a long vector: its length and a few telling entries.
struct Summary<'a>(&'a [f64]);

impl std::fmt::Debug for Summary<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        let max_abs = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        match (v.first(), v.last()) {
            (Some(first), Some(last)) => write!(
                f,
                "[{} values: first {first:e}, last {last:e}, max |.| {max_abs:e}]",
                v.len()
            ),
            _ => f.write_str("[]"),
        }
    }
}

impl std::fmt::Debug for SolverError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use SolverError::*;
        match self {
            InvalidSetting {
                name,
                value,
                requirement,
            } => f
                .debug_struct("InvalidSetting")
                .field("name", name)
                .field("value", value)
                .field("requirement", requirement)
                .finish(),
            ModesDidNotConverge { basis, worst } => f
                .debug_struct("ModesDidNotConverge")
                .field("basis", basis)
                .field("worst", worst)
                .finish(),
            FormMismatch { rest, model } => f
                .debug_struct("FormMismatch")
                .field("rest", rest)
                .field("model", model)
                .finish(),
            DimensionMismatch {
                what,
                expected,
                found,
            } => f
                .debug_struct("DimensionMismatch")
                .field("what", what)
                .field("expected", expected)
                .field("found", found)
                .finish(),
            InvalidPattern { dof, reason } => f
                .debug_struct("InvalidPattern")
                .field("dof", dof)
                .field("reason", reason)
                .finish(),
            InvalidForceScale(v) => f.debug_tuple("InvalidForceScale").field(v).finish(),
            InvalidLengthScale(v) => f.debug_tuple("InvalidLengthScale").field(v).finish(),
            NonFiniteCoordinate { dof } => f
                .debug_struct("NonFiniteCoordinate")
                .field("dof", dof)
                .finish(),
            NonFinite {
                what,
                iteration,
                dof,
            } => f
                .debug_struct("NonFinite")
                .field("what", what)
                .field("iteration", iteration)
                .field("dof", dof)
                .finish(),
            NotPositiveDefinite { iteration, pivot } => f
                .debug_struct("NotPositiveDefinite")
                .field("iteration", iteration)
                .field("pivot", pivot)
                .finish(),
            RegularizationFailed {
                iteration,
                mu,
                attempts,
            } => f
                .debug_struct("RegularizationFailed")
                .field("iteration", iteration)
                .field("mu", mu)
                .field("attempts", attempts)
                .finish(),
            LineSearchFailed {
                iteration,
                backtracks,
                residuals,
                last_good,
            } => f
                .debug_struct("LineSearchFailed")
                .field("iteration", iteration)
                .field("backtracks", backtracks)
                .field("residuals", &Summary(residuals))
                .field("last_good", &Summary(last_good))
                .finish(),
            NewtonDidNotConverge {
                residuals,
                iterations,
                tolerance,
                last_correction,
                step_tolerance,
                last_good,
            } => f
                .debug_struct("NewtonDidNotConverge")
                .field("iterations", iterations)
                .field("tolerance", tolerance)
                .field("last_correction", last_correction)
                .field("step_tolerance", step_tolerance)
                .field("residuals", &Summary(residuals))
                .field("last_good", &Summary(last_good))
                .finish(),
            Cancelled {
                iterations,
                residuals,
                last_good,
            } => f
                .debug_struct("Cancelled")
                .field("iterations", iterations)
                .field("residuals", &Summary(residuals))
                .field("last_good", &Summary(last_good))
                .finish(),
            PathFailed(p) => f
                .debug_struct("PathFailed")
                .field("step", &p.step)
                .field("load_factor", &p.load_factor)
                .field("step_length", &p.step_length)
                .field("cutbacks", &p.cutbacks)
                .field("reason", &p.reason)
                .field("residuals", &Summary(&p.residuals))
                .field("last_good", &Summary(&p.last_good))
                .finish(),
            Linear(msg) => f.debug_tuple("Linear").field(msg).finish(),
            InsufficientMemory {
                n,
                estimate,
                budget,
            } => f
                .debug_struct("InsufficientMemory")
                .field("n", n)
                .field("estimate", estimate)
                .field("budget", budget)
                .finish(),
            InsufficientMemoryForIterative {
                n,
                factor_estimate,
                estimate,
                budget,
            } => f
                .debug_struct("InsufficientMemoryForIterative")
                .field("n", n)
                .field("factor_estimate", factor_estimate)
                .field("estimate", estimate)
                .field("budget", budget)
                .finish(),
            Energy(e) => f.debug_tuple("Energy").field(e).finish(),
            Objective(e) => f.debug_tuple("Objective").field(e).finish(),
        }
    }
}
