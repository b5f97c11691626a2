//! Newton settings: which Hessian, tolerances, line search, linear solver (one plain struct,
//! [`Default`] robust), and the per-iteration Hessian kind.

use faer::Par;
use thinshell_energy::HessianMode;

use crate::SolverError;
use crate::linear::RegularizationParams;
use crate::ordering::Ordering;

/// Which Hessian each Newton iteration factorises.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum HessianPolicy {
    /// The objective's own Hessian ([`Objective::hessian`](crate::Objective::hessian)) where it is
    /// positive definite and its steps are taken in full, the PSD one
    /// ([`Objective::psd_hessian`](crate::Objective::psd_hessian)) elsewhere (see the [module
    /// docs](super)). Objectives without a PSD Hessian behave as with `Fixed`.
    #[default]
    Adaptive,
    /// The adaptive policy without trust-region steps (the solver's earlier default): an own
    /// Hessian that is indefinite
    /// beyond a tiny shift is replaced by the PSD Hessian at once (no trust-region steps on the
    /// shifted own Hessian, no saddle escape). Kept for comparison (`cargo xtask hard-cases`).
    AdaptivePsd,
    /// Always the objective's own Hessian, diagonally shifted when not positive definite.
    Fixed,
}

/// The Hessian a Newton iteration used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IterationHessian {
    /// The objective's own Hessian ([`Objective::hessian`](crate::Objective::hessian); exact for
    /// shells unless the system is set to another mode).
    Own,
    /// The positive semi-definite Hessian
    /// ([`Objective::psd_hessian`](crate::Objective::psd_hessian); Gauss–Newton for shells).
    Psd,
    /// The own Hessian where it is indefinite, plus the scaled diagonal shift `σ·S` of a
    /// trust-region (Levenberg–Marquardt) step: σ at least what makes it positive definite,
    /// raised after steps whose actual decrease falls short of the exact quadratic model's and
    /// lowered after good ones (`solver/src/curvature.rs`).
    Shifted,
    /// A step along the most negative curvature direction of the own Hessian, leaving a saddle
    /// (or a point where the shifted steps no longer decrease f).
    NegativeCurvature,
}

/// All parameters of a Newton solve (one plain struct; [`Default`] gives robust values).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonSettings {
    /// Maximum number of Newton iterations (≥ 1).
    pub max_iterations: usize,
    /// Which Hessian each iteration uses: the objective's own or its PSD one (the policy).
    /// With [`own_hessian`](Self::own_hessian) and [`fallback_hessian`](Self::fallback_hessian)
    /// the one place a solve's Hessian is chosen (passed per solve, not stored on the system).
    pub hessian: HessianPolicy,
    /// What a shell objective's own Hessian is: exact (default), Gauss–Newton or projected per
    /// face (the shell objectives read it per solve; other objectives ignore it).
    pub own_hessian: HessianMode,
    /// Shell integrators ([`Static`](crate::Static), [`ImplicitEuler`](crate::ImplicitEuler)):
    /// the own-Hessian mode a failed solve is retried with, from the last good iterate, before
    /// any other fallback (`None`, the default: no retry; scenes turn it on, see
    /// docs/robustness.md).
    pub fallback_hessian: Option<HessianMode>,
    /// Converged when `‖∇f‖∞ ≤ gradient_tolerance · force_scale` (dimensionless, > 0), for
    /// objectives with [`Objective::gradient_test`](crate::Objective::gradient_test) only.
    pub gradient_tolerance: f64,
    /// Converged when the unshifted Newton correction has `‖dx‖∞ ≤ step_tolerance ·
    /// length_scale` (dimensionless, ≥ 0; 0 disables the criterion).
    pub step_tolerance: f64,
    /// Backtracking Armijo line search on the objective (otherwise full steps).
    pub line_search: bool,
    /// Armijo sufficient-decrease constant c₁ ∈ (0, 1).
    pub armijo_c1: f64,
    /// Step-length factor per backtrack, in (0, 1).
    pub backtrack_factor: f64,
    /// Maximum number of backtracks per iteration.
    pub max_backtracks: usize,
    /// Watchdog (non-monotone line search): a full step that fails the Armijo test is taken
    /// anyway, and the solve returns to the point before it, to backtrack as usual, unless
    /// one of the next `watchdog` iterates satisfies the Armijo test of that step (0: off).
    /// See the [module docs](super).
    pub watchdog: usize,
    /// Diagonal shift of a Hessian that is not positive definite: its shape, first size,
    /// growth and attempts ([`RegularizationParams`], the one definition shared with the
    /// edge-angle relaxation). `None`: no shift, a typed error instead
    /// ([`SolverError::NotPositiveDefinite`]).
    pub regularization: Option<RegularizationParams>,
    /// Fill-reducing ordering of the factorisation (used when the workspace is built).
    pub ordering: Ordering,
    /// Factorise on the rayon thread pool (default `true`): with the METIS ordering and a
    /// factor of ≥ 2e8 flops, the factorisation is split at the top nested-dissection level
    /// and its two halves run concurrently when the pool has ≥ 2 threads (speed-ups in
    /// docs/performance.md, `cargo xtask perf`), one after the other on one thread. The same
    /// floating-point operations run in the same order for every pool size
    /// ([`SparseCholesky::new`](crate::SparseCholesky::new)), so results are bit-identical
    /// whatever the thread count. `false`: faer on the whole matrix, one thread (fewer flops
    /// on one core; results differ from `true`'s in the last bits).
    pub parallel: bool,
    /// Factorisation reuse: while the last Cholesky factor is of an unshifted Hessian of the
    /// same kind ([`IterationHessian`]), solve `H dx = −∇f` by CG preconditioned with it
    /// (inexact Newton, tolerance [`reuse_tolerance`](Self::reuse_tolerance)) instead of
    /// refactorising; refactorise when CG needs more than
    /// [`reuse_max_iterations`](Self::reuse_max_iterations) or meets non-positive curvature.
    /// The factor is kept across solves (implicit steps). The convergence tests and the line
    /// search are unchanged, so the equilibria are the same (to the step tolerance).
    pub reuse_factor: bool,
    /// Mixed precision ([`SparseCholesky::set_mixed_precision`](crate::SparseCholesky::set_mixed_precision)):
    /// factorise in f32 and refine every solve to f64 accuracy, falling back to f64 for good
    /// (reported by [`NewtonWorkspace::precision`](crate::NewtonWorkspace::precision)) where
    /// refinement does not converge within a few steps. Off by default; implicit steps turn it
    /// on (their `M/Δt²` keeps the matrix well conditioned).
    pub mixed_precision: bool,
    /// CG iterations a reused factor may take (≥ 1); a solve that needs more refactorises, and
    /// one that needs more than half of them refactorises at the next iteration.
    pub reuse_max_iterations: usize,
    /// Relative residual `‖H dx + ∇f‖₂ / ‖∇f‖₂` a direction from a reused factor must reach, in
    /// (0, 1) (default 1e-8: the direction is the Newton direction to about that relative
    /// accuracy, so the Newton path, the adaptive policy's and the watchdog's decisions are
    /// those of the direct solve; looser values took more Newton iterations and different
    /// paths on the static cylinder, and with 1e-6 the error of the first direction of an
    /// implicit step of the edge-director sphere, the residual amplified by the angle
    /// unknowns' conditioning, reached the step tolerance, so that 165 of its 200 seed steps
    /// took a second iteration; see docs/performance.md).
    pub reuse_tolerance: f64,
    /// Largest relative residual `‖H dx + ∇f‖₂ / ‖∇f‖₂` of a CG direction of the iterative
    /// fallback, in (0, 1): the
    /// forcing term is `min(cg_forcing, ‖∇f‖∞ / ‖∇f₀‖∞)` (∇f₀ at the start of the solve, floor
    /// 1e-12), so the inexact Newton iteration keeps its quadratic convergence.
    pub cg_forcing: f64,
    /// What the solve does when the Cholesky factor estimated by the symbolic analysis does not
    /// fit in the memory budget ([`crate::memory::memory_budget`]).
    pub fallback: IterativeFallback,
    /// Iteration limit of one CG solve of the iterative fallback (≥ 1); a truncated CG
    /// direction is still a descent direction (used with the line search, never for the
    /// convergence test).
    pub cg_max_iterations: usize,
    /// Use the iterative solver ([`fallback`](Self::fallback), IC(0) when `Off`) even when the
    /// Cholesky factor fits: for measuring the crossover between the two, and for meshes where
    /// CG is the faster.
    pub force_iterative: bool,
    /// A converged point where the own Hessian is indefinite (a saddle) is left along its most
    /// negative curvature direction and the solve continues to a minimum (default `true`;
    /// adaptive policy with a direct solver). `false` keeps saddles, e.g. to trace unstable
    /// equilibria on purpose.
    pub escape_saddles: bool,
    /// Converged also when the Newton correction is below this fraction of the distance the
    /// solve has moved from its start, `‖dx‖∞ ≤ relative_step_tolerance · ‖x − x₀‖∞` (≥ 0; 0
    /// disables it, the default for static solves). `ImplicitEuler::new` sets 1e-3: the move
    /// of a step from its inertial prediction is of the order of its time discretisation
    /// error, so a correction a thousand times smaller is far below that error.
    pub relative_step_tolerance: f64,
}

/// The linear solver used when the Cholesky factor does not fit in memory.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum IterativeFallback {
    /// CG preconditioned by the zero-fill incomplete Cholesky factor IC(0) of the Hessian
    /// (diagonally shifted where it would break down; [`crate::iterative::Ic0`]).
    #[default]
    Ic0,
    /// CG preconditioned by the Hessian's diagonal (Jacobi): least memory, most iterations.
    Jacobi,
    /// No fallback: [`SolverError::InsufficientMemory`].
    Off,
}

/// How the Newton directions of a solve were computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LinearSolver {
    /// Sparse Cholesky factorisations (possibly reused as CG preconditioners).
    #[default]
    Direct,
    /// The iterative fallback: the Cholesky factor did not fit in the memory budget.
    Iterative(IterativeFallback),
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            hessian: HessianPolicy::Adaptive,
            own_hessian: HessianMode::Exact,
            fallback_hessian: None,
            gradient_tolerance: 1e-8,
            // Positions to 1e-12 of the body's size (angles to about 1e-12 × its size in edge
            // lengths): far below discretisation error; where round-off is above it, the
            // round-off criterion ends the solve.
            step_tolerance: 1e-12,
            line_search: true,
            armijo_c1: 1e-4,
            backtrack_factor: 0.5,
            max_backtracks: 40,
            watchdog: 4,
            regularization: Some(RegularizationParams::default()),
            ordering: Ordering::default(),
            parallel: true,
            reuse_factor: false,
            mixed_precision: false,
            reuse_max_iterations: 20,
            reuse_tolerance: 1e-8,
            cg_forcing: 1e-2,
            fallback: IterativeFallback::Ic0,
            cg_max_iterations: 5000,
            force_iterative: false,
            escape_saddles: true,
            relative_step_tolerance: 0.0,
        }
    }
}

impl NewtonSettings {
    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = SolverError::invalid_setting;
        if self.max_iterations == 0 {
            return Err(bad("max_iterations", 0.0, "must be at least 1"));
        }
        if !(self.gradient_tolerance.is_finite() && self.gradient_tolerance > 0.0) {
            return Err(bad(
                "gradient_tolerance",
                self.gradient_tolerance,
                "must be positive and finite",
            ));
        }
        if !(self.step_tolerance.is_finite() && self.step_tolerance >= 0.0) {
            return Err(bad(
                "step_tolerance",
                self.step_tolerance,
                "must be non-negative and finite",
            ));
        }
        if !(self.armijo_c1 > 0.0 && self.armijo_c1 < 1.0) {
            return Err(bad("armijo_c1", self.armijo_c1, "must lie in (0, 1)"));
        }
        if !(self.backtrack_factor > 0.0 && self.backtrack_factor < 1.0) {
            return Err(bad(
                "backtrack_factor",
                self.backtrack_factor,
                "must lie in (0, 1)",
            ));
        }
        if let Some(r) = &self.regularization {
            r.validate()?;
        }
        if self.reuse_max_iterations == 0 {
            return Err(bad("reuse_max_iterations", 0.0, "must be at least 1"));
        }
        if !(self.reuse_tolerance > 0.0 && self.reuse_tolerance < 1.0) {
            return Err(bad(
                "reuse_tolerance",
                self.reuse_tolerance,
                "must lie in (0, 1)",
            ));
        }
        if !(self.cg_forcing > 0.0 && self.cg_forcing < 1.0) {
            return Err(bad("cg_forcing", self.cg_forcing, "must lie in (0, 1)"));
        }
        if self.cg_max_iterations == 0 {
            return Err(bad("cg_max_iterations", 0.0, "must be at least 1"));
        }
        if !(self.relative_step_tolerance.is_finite() && self.relative_step_tolerance >= 0.0) {
            return Err(bad(
                "relative_step_tolerance",
                self.relative_step_tolerance,
                "must be non-negative and finite",
            ));
        }
        Ok(())
    }

    /// The regularisation parameters as the linear solver takes them: no shifted attempt when
    /// regularisation is off.
    pub(super) fn regularization_params(&self) -> RegularizationParams {
        self.regularization.unwrap_or(RegularizationParams {
            max_attempts: 0,
            ..RegularizationParams::default()
        })
    }

    pub(super) fn par(&self) -> Par {
        if self.parallel {
            Par::rayon(0)
        } else {
            Par::Seq
        }
    }
}
