//! Newton's method with an adaptive Hessian, backtracking line search and regularisation.
//!
//! Each iteration solves `H dx = −∇f` with the sparse Cholesky factorisation of
//! [`linear`](crate::linear) (symbolic analysis done once in [`NewtonWorkspace::new`]), then
//! backtracks along `dx` until the Armijo condition `f(x + α dx) ≤ f(x) + c₁ α ∇fᵀdx` holds.
//!
//! **Watchdog** ([`NewtonSettings::watchdog`], a non-monotone line search): a full step that
//! fails the Armijo test is taken anyway, and the next few iterations (with the usual line
//! search) must bring f below that step's Armijo bound; if they do not, the solve returns to
//! the point before it and backtracks from there. Thin shells need it: from flat, a full
//! Newton step bends the sheet with about the right curvature but stretches its membrane
//! (second order in the deflection, invisible to the linearisation), and the next step relaxes
//! the membrane; a monotone line search instead cuts every such step to a sliver (a paper
//! sheet rolling into a cylinder: 258 iterations with it, 11 without).
//!
//! **Which H** ([`HessianPolicy`]): by default ([`HessianPolicy::Adaptive`]) the objective's own
//! (exact) Hessian while it factorises with at most a tiny shift (≤ 1e-8 of the mean |H_dd|,
//! far below bending stiffness) and its full steps pass the Armijo test, and the objective's
//! positive semi-definite Hessian ([`Objective::psd_hessian`], Gauss–Newton for shells)
//! otherwise:
//! - an own Hessian that does not factorise switches to the PSD one in the same iteration (the
//!   wasted factorisation is counted in [`NewtonReport::failed_factorizations`]);
//! - an own step whose full length fails the Armijo test is discarded and the iteration redone
//!   with the PSD Hessian ([`NewtonReport::rejected_steps`]): a short step along the direction
//!   of a quadratic model that does not hold may lead towards a saddle or a poor minimum;
//! - after a full PSD step whose actual decrease is at least half the predicted one (the
//!   iterate is where a quadratic model holds), and after a PSD step that backtracked (its model
//!   overshoots too, e.g. a membrane sagging from flat), the own Hessian is tried again — after
//!   1, 2, 4, … such steps once it has failed or been rejected;
//! - PSD steps that need ≥ 3 backtracks raise a Levenberg–Marquardt damping `λ·mean|H_dd|` on
//!   the diagonal (from 1e-6, ×10), good full steps lower it (÷100): a Gauss–Newton model sees
//!   no membrane cost of bending a flat or folded sheet out of plane and overshoots there.
//!
//! **Indefinite own Hessians near critical points** (issue #26; [`HessianPolicy::Adaptive`]
//! with a direct solver): PSD steps converge only linearly towards a point where the own
//! Hessian is indefinite, and towards a saddle as readily as towards a minimum. So when the own
//! Hessian does not factorise with the small shift, the solve first checks how indefinite it
//! is (`solver/src/curvature.rs`): if `H + σS` with σ ≤ 1e-2 of each unknown's own stiffness is
//! positive definite (mildly indefinite: a saddle or a buckling region is near), it
//! - steps along the most negative curvature direction as far as f keeps decreasing
//!   ([`IterationHessian::NegativeCurvature`]), then
//! - takes trust-region steps `−(H + σS)⁻¹∇f` ([`IterationHessian::Shifted`]), accepted when
//!   the actual decrease is at least 0.1 of the exact quadratic model's, σ lowered ×16 after
//!   very good steps and raised ×4 after poor or rejected ones, never below what keeps
//!   `H + σS` positive definite (when that bound and not the model limits the step, the next
//!   iteration moves along the negative curvature again);
//! - six rejected shifted steps in a row, or an own Hessian needing more than that shift
//!   (strongly indefinite: a compressed membrane far from equilibrium), hand over to PSD steps
//!   as before.
//!
//! A converged point reached after an indefinite Hessian was met is checked: if its own
//! Hessian is indefinite (a saddle), the solve leaves it along the negative curvature and goes
//! on ([`NewtonSettings::escape_saddles`], default on; implicit steps keep it off). Every
//! iteration records what it used ([`NewtonReport::hessians`], [`NewtonReport::count`]).
//! [`HessianPolicy::AdaptivePsd`] is the policy before issue #26, for comparison.
//!
//! Far from a solution the PSD Hessian keeps the curvature of the forms without the shift a
//! regularised indefinite Hessian needs (which turns Newton into a slow gradient method and can
//! lead into a wrong local minimum); close to it the exact Hessian gives quadratic convergence.
//! Every iteration records which one it used ([`NewtonReport::hessians`]).
//! [`HessianPolicy::Fixed`] always uses the objective's own Hessian, shifted as much as needed
//! when it is not positive definite (as is the PSD Hessian, should it be singular).
//!
//! **When converged** (one definition, scale-free): the unshifted Newton correction is short,
//! `‖dx‖∞ ≤ step_tolerance · length_scale` ([`Convergence::Step`]; after a full step it is
//! estimated from the current factorisation, `‖H⁻¹∇f(x + dx)‖∞`, which costs one triangular
//! solve instead of a factorisation); or its predicted decrease `−½∇fᵀdx` is below the
//! round-off of f, `16 ε |f|`, and the last step did not halve the gradient
//! ([`Convergence::RoundOff`]: neither f nor ∇f shows further progress); or,
//! only for objectives whose force scale is a meaningful size of their forces
//! ([`Objective::gradient_test`]), `‖∇f‖∞ ≤ gradient_tolerance · force_scale`
//! ([`Convergence::Gradient`]). The correction measures the distance to the equilibrium in the
//! unknowns' own units whatever the stiffness (membrane, bending or edge-director angles), so no
//! force scale can declare an unoptimised configuration converged.

use std::time::{Duration, Instant};

use faer::Par;
use faer::sparse::SparseColMat;

use crate::SolverError;
use crate::curvature::{self, SHIFT_GROWTH};
use crate::iterative::{Ic0, PcgScratch, pcg, sym_lower_matvec};
use crate::ldlt::SparseLdlt;
use crate::linear::{
    FactorError, FactorOutcome, FactorStats, RegularizationKind, RegularizationParams,
    SparseCholesky,
};
use crate::objective::Objective;
use crate::ordering::Ordering;
use crate::progress::{CancelFlag, NewtonProgress, ProgressHook};

mod kept;
pub use kept::KeptFactor;

/// Which Hessian each Newton iteration factorises.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum HessianPolicy {
    /// The objective's own Hessian ([`Objective::hessian`]) where it is positive definite and
    /// its steps are taken in full, the PSD one ([`Objective::psd_hessian`]) elsewhere (see the
    /// [module docs](self)). Objectives without a PSD Hessian behave as with `Fixed`.
    #[default]
    Adaptive,
    /// The adaptive policy as it was before issue #26: an own Hessian that is indefinite
    /// beyond a tiny shift is replaced by the PSD Hessian at once (no trust-region steps on the
    /// shifted own Hessian, no saddle escape). Kept for comparison (`cargo xtask hard-cases`).
    AdaptivePsd,
    /// Always the objective's own Hessian, diagonally shifted when not positive definite.
    Fixed,
}

/// The Hessian a Newton iteration used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IterationHessian {
    /// The objective's own Hessian ([`Objective::hessian`]; exact for shells unless the system
    /// is set to another mode).
    Own,
    /// The positive semi-definite Hessian ([`Objective::psd_hessian`]; Gauss–Newton for shells).
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
    /// Which Hessian each iteration uses.
    pub hessian: HessianPolicy,
    /// Converged when `‖∇f‖∞ ≤ gradient_tolerance · force_scale` (dimensionless, > 0), for
    /// objectives with [`Objective::gradient_test`] only.
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
    /// See the [module docs](self).
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
    /// and its two halves run concurrently when the pool has ≥ 2 threads (1.13–1.30× faster
    /// than one thread at 20 480 faces, 1.51–1.68× at 81 920, on an idle 2-core VM:
    /// `cargo xtask perf`), one after the other on one thread. The same floating-point
    /// operations run in the same order for every pool size
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
    fn regularization_params(&self) -> RegularizationParams {
        self.regularization.unwrap_or(RegularizationParams {
            max_attempts: 0,
            ..RegularizationParams::default()
        })
    }

    fn par(&self) -> Par {
        if self.parallel {
            Par::rayon(0)
        } else {
            Par::Seq
        }
    }
}

/// Which criterion ended a converged solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convergence {
    /// `‖∇f‖∞ ≤ gradient_tolerance · force_scale`.
    Gradient,
    /// An unshifted Newton correction (computed, or estimated from the last factorisation after
    /// a full step) shorter than `step_tolerance · length_scale`; a computed one is not taken.
    Step,
    /// The predicted decrease of the unshifted Newton step below the round-off of f (not taken).
    RoundOff,
}

/// A factorisation that needed a diagonal shift.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularizationEvent {
    /// Newton iteration (0-based).
    pub iteration: usize,
    /// Relative shift μ of the factorisation that succeeded (> 0).
    pub mu: f64,
    /// Largest absolute diagonal entry added.
    pub max_shift: f64,
    /// Factorisation attempts in that iteration.
    pub attempts: usize,
}

/// Wall time spent per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NewtonTimings {
    /// Objective evaluations: values with gradients, Hessians (including the first, full-step
    /// trial of each line search, which evaluates the gradient too).
    pub assembly: Duration,
    /// Numeric Cholesky factorisations (including failed attempts).
    pub factorization: Duration,
    /// Triangular solves and CG iterations.
    pub solve: Duration,
    /// Energy-only evaluations of the line search (backtracked trials; not in `assembly`).
    pub line_search: Duration,
    /// Number of those energy-only evaluations.
    pub line_search_evaluations: usize,
}

/// What a converged Newton solve did.
#[derive(Clone, Debug, PartialEq)]
pub struct NewtonReport {
    /// Newton iterations (Hessian factorisations with a step taken).
    pub iterations: usize,
    /// The Hessian of every iteration (length `iterations`).
    pub hessians: Vec<IterationHessian>,
    /// `‖dx‖∞ / length_scale` of every unshifted Newton correction, in order (one per
    /// unshifted iteration, plus the estimate or the untaken correction that ended the solve);
    /// quadratic convergence shows as each entry about the square of the previous one.
    pub corrections: Vec<f64>,
    /// Unshifted factorisations of the objective's own Hessian that failed and made the
    /// adaptive policy switch to the PSD Hessian.
    pub failed_factorizations: usize,
    /// Steps tried and rejected (not counted in `iterations`, counted against
    /// `max_iterations`): own-Hessian steps that failed the Armijo test at full length and were
    /// redone with the PSD Hessian, and trust-region steps whose actual decrease fell short of
    /// the model's (redone with a larger shift).
    pub rejected_steps: usize,
    /// Full steps taken by the watchdog although they failed the Armijo test.
    pub watchdog_steps: usize,
    /// Watchdog steps whose iterates never came below the Armijo bound of the step: the solve
    /// returned to the point before them.
    pub watchdog_returns: usize,
    /// Newton iterations undone by those returns (not in `iterations`, which counts the
    /// accepted path, but counted against `max_iterations`).
    pub watchdog_undone: usize,
    /// The criterion that stopped the solve.
    pub convergence: Convergence,
    /// Relative residual `‖∇f‖∞ / force_scale` of every accepted iterate (first = initial).
    pub residuals: Vec<f64>,
    /// Objective value of every accepted iterate (first = initial); with line search
    /// non-increasing except right after a watchdog step ([`NewtonReport::descent_violation`]
    /// checks it), up to round-off once the predicted decrease is below it.
    pub values: Vec<f64>,
    /// Line-search backtracks over the whole solve.
    pub backtracks: usize,
    /// Factorisations that needed a diagonal shift.
    pub regularizations: Vec<RegularizationEvent>,
    /// Time per stage.
    pub timings: NewtonTimings,
    /// Numeric factorisations (Cholesky attempts, successful or not; with the iterative
    /// fallback, IC(0) preconditioners built).
    pub factorizations: usize,
    /// Iterations whose direction came from CG preconditioned with a reused factor
    /// ([`NewtonSettings::reuse_factor`]).
    pub reused_steps: usize,
    /// Directions solved with the factor of a slightly shifted Hessian (the objective's
    /// [`Objective::hessian_diagonal_shift`] or a regularisation of at most 1e-8 of the mean
    /// diagonal) and refined by CG into those of the unshifted Hessian.
    pub refined_steps: usize,
    /// Largest difference seen between [`Objective::value`] and [`Objective::gradient`]'s
    /// value at the same point (units of f; 0 when never compared): the evaluation round-off
    /// of f, far above `16 ε |f|` for shells whose strains are small against 1. The round-off
    /// tests use the larger of the two, and so does [`NewtonReport::descent_violation`].
    pub value_noise: f64,
    /// CG iterations over the whole solve (reuse, refinement and fallback).
    pub cg_iterations: usize,
    /// Direct, or the iterative fallback (the factor did not fit in memory).
    pub linear_solver: LinearSolver,
}

impl NewtonReport {
    /// Accepted iterations that used Hessian (or step) `kind`.
    pub fn count(&self, kind: IterationHessian) -> usize {
        self.hessians.iter().filter(|h| **h == kind).count()
    }

    /// Every iteration the solve paid for, the one count [`NewtonSettings::max_iterations`]
    /// limits: accepted ones, rejected steps and iterations undone by the watchdog.
    pub fn total_iterations(&self) -> usize {
        self.iterations + self.rejected_steps + self.watchdog_undone
    }

    /// Checks the line search's contract on [`values`](Self::values): f never rises, except
    /// after a watchdog step ([`NewtonSettings::watchdog`] = `window`), and then an iterate at
    /// most `window + 1` iterations later is back at or below the value before the rise (the
    /// iterate after a return to the point before the step is); the last value is not above
    /// the first. Comparisons allow 64 ε of round-off. Returns the index of the first value
    /// that breaks the contract.
    pub fn descent_violation(&self, window: usize) -> Option<usize> {
        let v = &self.values;
        let close = |a: f64, b: f64| {
            b <= a + (64.0 * f64::EPSILON * a.abs().max(b.abs())).max(2.0 * self.value_noise)
        };
        for i in 0..v.len().saturating_sub(1) {
            if !close(v[i], v[i + 1]) {
                let end = (i + window + 3).min(v.len());
                if !v[i + 1..end].iter().any(|&u| close(v[i], u)) {
                    return Some(i);
                }
            }
        }
        match (v.first(), v.last()) {
            (Some(&a), Some(&b)) if !close(a, b) => Some(v.len() - 1),
            _ => None,
        }
    }
}

/// Reusable state of Newton solves on objectives with one Hessian pattern: the symbolic
/// factorisation, the Hessian matrix, vectors, and the remembered regularisation shift.
/// Build it once (e.g. per simulation) and pass it to every [`newton_solve`].
pub struct NewtonWorkspace {
    /// The direct solver; `None` when its factor does not fit in memory (`fallback` is set).
    cholesky: Option<SparseCholesky>,
    /// The iterative fallback's preconditioner and the symbolic statistics of the refused
    /// factor.
    fallback: Option<Fallback>,
    /// Position of each diagonal entry in the Hessian's value array.
    diag_offsets: Vec<usize>,
    /// CG work vectors (reuse and fallback).
    pcg: PcgScratch,
    /// Kind of Hessian of the last Cholesky factor when it is unshifted and may precondition CG
    /// ([`NewtonSettings::reuse_factor`]); `None`: refactorise.
    reusable: Option<IterationHessian>,
    /// The input of the kept factor's factorisation (checkpoints, cancelled solves).
    kept: kept::KeptRecord,
    /// Statistics of the symbolic analysis (of the refused factor with the fallback).
    stats: FactorStats,
    /// Built with [`NewtonSettings::force_iterative`].
    forced: bool,
    hessian: SparseColMat<usize, f64>,
    g: Vec<f64>,
    g_trial: Vec<f64>,
    dx: Vec<f64>,
    x_trial: Vec<f64>,
    /// H·dx of a trust-region step (its predicted decrease).
    hd: Vec<f64>,
    /// The scaling diagonal S of the trust-region shift (`curvature::scaling`).
    scale: Vec<f64>,
    mu: f64,
    /// The settings the symbolic analysis was made with.
    ordering: Ordering,
    parallel: bool,
    /// Called after every accepted iteration of [`newton_solve`].
    progress: Option<ProgressHook>,
    /// Checked before every iteration of [`newton_solve`].
    cancel: Option<CancelFlag>,
    /// Indefinite factorisation for Newton steps to a critical point whose Hessian is
    /// indefinite (`saddle_newton`); analysed on first use.
    ldlt: Option<SparseLdlt>,
}

impl std::fmt::Debug for NewtonWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NewtonWorkspace")
            .field("cholesky", &self.cholesky)
            .field("fallback", &self.fallback.as_ref().map(|f| f.kind))
            .field("reusable", &self.reusable)
            .field("n_dofs", &self.g.len())
            .field("mu", &self.mu)
            .field("ordering", &self.ordering)
            .field("parallel", &self.parallel)
            .field("progress", &self.progress.is_some())
            .finish_non_exhaustive()
    }
}

impl NewtonWorkspace {
    /// Analyses `objective`'s Hessian pattern with `settings.ordering` (using the objective's dof
    /// coordinates for nested dissection when it has them).
    pub fn new<O: Objective + ?Sized>(
        objective: &O,
        settings: &NewtonSettings,
    ) -> Result<NewtonWorkspace, SolverError> {
        settings.validate()?;
        let n = objective.n_dofs();
        let hessian = objective.hessian_template();
        if hessian.ncols() != n || hessian.nrows() != n {
            return Err(SolverError::DimensionMismatch {
                what: "Hessian template",
                expected: n,
                found: hessian.ncols(),
            });
        }
        let coords = objective.dof_coordinates();
        let diag_offsets = crate::linear::diagonal_offsets(hessian.symbolic())?;
        let direct = if settings.force_iterative {
            // No numeric factor: the refusal's fields stand for "iterative by request".
            Err(SolverError::InsufficientMemory {
                n,
                estimate: 0,
                budget: u64::MAX,
            })
        } else {
            SparseCholesky::new(
                hessian.symbolic(),
                settings.ordering,
                coords.as_deref(),
                settings.par(),
            )
        };
        let (cholesky, fallback) = match direct {
            Ok(c) => (Some(c), None),
            Err(SolverError::InsufficientMemory {
                n: dim,
                estimate,
                budget,
            }) => {
                let refused = SolverError::InsufficientMemory {
                    n: dim,
                    estimate,
                    budget,
                };
                let nnz = hessian.val().len();
                let kind = match settings.fallback {
                    IterativeFallback::Off if settings.force_iterative => IterativeFallback::Ic0,
                    k => k,
                };
                let iterative = match kind {
                    IterativeFallback::Off => return Err(refused),
                    IterativeFallback::Ic0 => Ic0::memory_estimate(n, nnz),
                    IterativeFallback::Jacobi => (7 * n * 8) as u64,
                };
                if iterative > budget {
                    return Err(SolverError::InsufficientMemoryForIterative {
                        n,
                        factor_estimate: estimate,
                        estimate: iterative,
                        budget,
                    });
                }
                let start = Instant::now();
                let (symbolic, used, _) = crate::linear::analyse(
                    hessian.symbolic(),
                    settings.ordering,
                    coords.as_deref(),
                )?;
                let factor_len = symbolic.len_val();
                let stats = FactorStats {
                    n,
                    nnz_lower: nnz,
                    factor_len: symbolic.len_val(),
                    flops: crate::linear::factor_flops(&symbolic),
                    ordering: used,
                    supernodal: matches!(
                        symbolic.raw(),
                        faer::sparse::linalg::cholesky::SymbolicCholeskyRaw::Supernodal(_)
                    ),
                    symbolic_time: start.elapsed(),
                    // By request: the factor's values (its scratch is not sized).
                    memory_estimate: if settings.force_iterative {
                        (factor_len * 8) as u64
                    } else {
                        estimate
                    },
                };
                drop(symbolic);
                let precond = match kind {
                    IterativeFallback::Jacobi => Precond::Jacobi(vec![0.0; n]),
                    _ => Precond::Ic0(Ic0::new(hessian.as_ref())?),
                };
                (
                    None,
                    Some(Fallback {
                        kind,
                        precond,
                        stats,
                        iterative_estimate: iterative,
                    }),
                )
            }
            Err(e) => return Err(e),
        };
        let stats = match (&cholesky, &fallback) {
            (Some(c), _) => *c.stats(),
            (None, Some(f)) => f.stats,
            (None, None) => {
                return Err(SolverError::Linear(
                    "neither a direct nor an iterative solver was set up".into(),
                ));
            }
        };
        Ok(NewtonWorkspace {
            forced: settings.force_iterative,
            stats,
            cholesky,
            fallback,
            diag_offsets,
            pcg: PcgScratch::new(n),
            reusable: None,
            kept: kept::KeptRecord::default(),
            hessian,
            g: vec![0.0; n],
            g_trial: vec![0.0; n],
            dx: vec![0.0; n],
            x_trial: vec![0.0; n],
            hd: vec![0.0; n],
            scale: vec![0.0; n],
            mu: 0.0,
            ordering: settings.ordering,
            parallel: settings.parallel,
            progress: None,
            cancel: None,
            ldlt: None,
        })
    }

    /// Whether the workspace was built with `settings`' ordering and parallelism. A cached
    /// workspace must be rebuilt when they change (or when the objective's number of unknowns
    /// or Hessian pattern does): [`newton_solve`] rejects a wrong size but otherwise factorises
    /// with the ordering and parallelism the workspace was built with.
    pub fn matches(&self, settings: &NewtonSettings) -> bool {
        self.ordering == settings.ordering
            && self.parallel == settings.parallel
            && self.forced == settings.force_iterative
            && self
                .fallback
                .as_ref()
                .is_none_or(|f| f.kind == settings.fallback || self.forced)
    }

    /// How this workspace solves: [`LinearSolver::Direct`], or the iterative fallback chosen
    /// because the Cholesky factor did not fit in the memory budget.
    pub fn linear_solver(&self) -> LinearSolver {
        match &self.fallback {
            None => LinearSolver::Direct,
            Some(f) => LinearSolver::Iterative(f.kind),
        }
    }

    /// Estimated bytes of the iterative fallback's preconditioner and CG vectors (`None` for
    /// a direct workspace, whose estimate is [`FactorStats::memory_estimate`]).
    pub fn iterative_memory_estimate(&self) -> Option<u64> {
        self.fallback.as_ref().map(|f| f.iterative_estimate)
    }

    /// Forgets the factor kept for reuse ([`NewtonSettings::reuse_factor`]): the next
    /// iteration factorises afresh (e.g. after the objective changed discontinuously).
    pub fn invalidate_factor(&mut self) {
        self.reusable = None;
    }

    /// The Hessian matrix the workspace was analysed for (its pattern; values of the last
    /// evaluation).
    pub fn hessian(&self) -> &SparseColMat<usize, f64> {
        &self.hessian
    }

    /// Number of stored entries of the Hessian pattern (lower triangle).
    pub fn nnz(&self) -> usize {
        self.hessian.val().len()
    }

    /// The ordering the workspace was built with (as requested; [`FactorStats::ordering`] is
    /// the one `Ordering::Auto` chose).
    pub fn ordering(&self) -> Ordering {
        self.ordering
    }

    /// Whether the factorisation runs on the rayon pool (as built).
    pub fn parallel(&self) -> bool {
        self.parallel
    }

    /// Number of unknowns the workspace was built for.
    pub fn n_dofs(&self) -> usize {
        self.g.len()
    }

    /// Statistics of the symbolic factorisation (ordering, fill, flops); with the iterative
    /// fallback, those of the factor that was refused.
    pub fn factor_stats(&self) -> &FactorStats {
        &self.stats
    }

    /// The remembered relative regularisation shift (0 when the last factorisation needed none).
    pub fn regularization_memory(&self) -> f64 {
        self.mu
    }

    /// Sets the remembered relative regularisation shift (a restored checkpoint: the next
    /// solve starts from the shift the interrupted run would have used). Non-finite or
    /// negative values count as 0.
    pub fn set_regularization_memory(&mut self, mu: f64) {
        self.mu = if mu.is_finite() && mu > 0.0 { mu } else { 0.0 };
    }

    /// Sets (or clears) the observer called after every accepted Newton iteration.
    pub fn set_progress(&mut self, hook: Option<ProgressHook>) {
        self.progress = hook;
    }

    /// Sets (or clears) the flag that cancels a running solve before its next iteration
    /// ([`SolverError::Cancelled`]).
    pub fn set_cancel(&mut self, flag: Option<CancelFlag>) {
        self.cancel = flag;
    }

    /// The gradient at the last accepted iterate of the last solve.
    pub fn gradient(&self) -> &[f64] {
        &self.g
    }
}

fn norm_inf(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// A non-finite value `f` or gradient `g` at an iterate, as the error of iteration
/// `iteration`.
fn check_finite(f: f64, g: &[f64], iteration: usize) -> Result<(), SolverError> {
    if !f.is_finite() {
        return Err(SolverError::NonFinite {
            what: "value",
            iteration,
            dof: None,
        });
    }
    if let Some(dof) = first_non_finite(g) {
        return Err(SolverError::NonFinite {
            what: "gradient",
            iteration,
            dof: Some(dof),
        });
    }
    Ok(())
}

fn first_non_finite(v: &[f64]) -> Option<usize> {
    v.iter().position(|x| !x.is_finite())
}

/// Everything a solve has recorded so far, turned into a report.
struct Record {
    residuals: Vec<f64>,
    values: Vec<f64>,
    hessians: Vec<IterationHessian>,
    corrections: Vec<f64>,
    failed_factorizations: usize,
    rejected_steps: usize,
    watchdog_steps: usize,
    watchdog_returns: usize,
    watchdog_undone: usize,
    backtracks: usize,
    regularizations: Vec<RegularizationEvent>,
    timings: NewtonTimings,
    factorizations: usize,
    reused_steps: usize,
    refined_steps: usize,
    cg_iterations: usize,
    linear_solver: LinearSolver,
    value_noise: f64,
}

impl Record {
    /// Round-off of an objective value f: `16 ε |f|`, or the evaluation noise seen so far.
    fn noise(&self, f: f64) -> f64 {
        value_noise(f).max(self.value_noise)
    }

    fn report(self, iterations: usize, convergence: Convergence) -> NewtonReport {
        NewtonReport {
            iterations,
            hessians: self.hessians,
            corrections: self.corrections,
            failed_factorizations: self.failed_factorizations,
            rejected_steps: self.rejected_steps,
            watchdog_steps: self.watchdog_steps,
            watchdog_returns: self.watchdog_returns,
            watchdog_undone: self.watchdog_undone,
            convergence,
            residuals: self.residuals,
            values: self.values,
            backtracks: self.backtracks,
            regularizations: self.regularizations,
            timings: self.timings,
            factorizations: self.factorizations,
            reused_steps: self.reused_steps,
            refined_steps: self.refined_steps,
            value_noise: self.value_noise,
            cg_iterations: self.cg_iterations,
            linear_solver: self.linear_solver,
        }
    }
}

/// Largest relative shift (of the mean |H_dd|) the adaptive policy applies to the own Hessian
/// before it switches to the PSD one; also the largest shift with which a Newton correction
/// still counts for the convergence test.
const SMALL_SHIFT: f64 = 1e-8;

/// First Levenberg–Marquardt damping of PSD steps (relative to the mean |H_dd|) after a
/// backtracked PSD step; below it the damping is switched off.
const DAMPING_MIN: f64 = 1e-6;
/// Backtracks of a PSD step (its full step was at least 2³ times too long) that raise the
/// damping.
const DAMPING_BACKTRACKS: usize = 3;
/// Factor the damping grows by after a backtracked PSD step and shrinks by after a good one.
const DAMPING_GROWTH: f64 = 10.0;

/// Shifted attempts of `params` that stay at or below [`SMALL_SHIFT`].
fn small_shift_attempts(params: &RegularizationParams) -> usize {
    if params.max_attempts == 0 || params.initial > SMALL_SHIFT {
        return 0;
    }
    let mut attempts = 1;
    let mut mu = params.initial;
    while mu * params.growth <= SMALL_SHIFT * (1.0 + 1e-12) && attempts < params.max_attempts {
        mu *= params.growth;
        attempts += 1;
    }
    attempts
}

/// The point before a watchdog step (see [`NewtonSettings::watchdog`]).
struct Watch {
    x: Vec<f64>,
    g: Vec<f64>,
    f: f64,
    /// Armijo bound `f + c₁ ∇fᵀdx` of the watched step.
    bound: f64,
    /// Length of the value record with the point before the step as its last entry.
    len: usize,
    /// Iterations left to come below `bound`.
    left: usize,
}

/// A watchdog step needs a predicted decrease this many times the round-off of f: near
/// round-off, values cannot tell a good step from a bad one and the usual rules apply.
const WATCHDOG_MIN_DECREASE: f64 = 1e4;

/// Round-off of an objective value f: changes below it are invisible.
fn value_noise(f: f64) -> f64 {
    16.0 * f64::EPSILON * f.abs()
}

/// Assembles the PSD Hessian when `psd`, else the own Hessian.
fn assemble<O: Objective + ?Sized>(
    objective: &mut O,
    x: &[f64],
    h: &mut SparseColMat<usize, f64>,
    psd: bool,
    iteration: usize,
    timings: &mut NewtonTimings,
) -> Result<IterationHessian, SolverError> {
    let t = Instant::now();
    let kind = if psd {
        objective.psd_hessian(x, h)?;
        IterationHessian::Psd
    } else {
        objective.hessian(x, h)?;
        IterationHessian::Own
    };
    timings.assembly += t.elapsed();
    if h.val().iter().any(|v| !v.is_finite()) {
        return Err(SolverError::NonFinite {
            what: "Hessian",
            iteration,
            dof: None,
        });
    }
    Ok(kind)
}

impl NewtonWorkspace {
    /// Errors unless `x` and `objective` fit the workspace and it has the direct solver, which
    /// `what` needs.
    fn check_direct<O: Objective + ?Sized>(
        &self,
        objective: &O,
        x: &[f64],
        what: &str,
    ) -> Result<(), SolverError> {
        if x.len() != self.n_dofs() || objective.n_dofs() != self.n_dofs() {
            return Err(SolverError::DimensionMismatch {
                what: "x",
                expected: self.n_dofs(),
                found: x.len(),
            });
        }
        if self.cholesky.is_none() {
            return Err(SolverError::Linear(format!(
                "{what} needs a Cholesky factorisation, which does not fit in the memory budget \
                 (the solve used the iterative fallback)"
            )));
        }
        Ok(())
    }

    /// Whether the objective's own Hessian at `x` is positive definite: its unshifted Cholesky
    /// factorisation succeeds (e.g. the stability test of an equilibrium; a shift the objective
    /// itself adds, like a static solve's `hessian_shift`, is part of its Hessian).
    pub fn is_positive_definite<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        x: &[f64],
    ) -> Result<bool, SolverError> {
        self.check_direct(objective, x, "the positive-definiteness test")?;
        let Some(cholesky) = self.cholesky.as_mut() else {
            return Err(SolverError::Linear("no Cholesky factorisation".into()));
        };
        let mut timings = NewtonTimings::default();
        assemble(objective, x, &mut self.hessian, false, 0, &mut timings)?;
        self.reusable = None;
        match cholesky.factorize(self.hessian.as_ref()) {
            Ok(()) => {
                // An unshifted factor of the own Hessian: the next solve may reuse it.
                self.reusable = Some(IterationHessian::Own);
                let h = self.hessian.val();
                self.kept
                    .record(IterationHessian::Own, h, 0.0, RegularizationKind::Identity);
                Ok(true)
            }
            Err(FactorError::NotPositiveDefinite { .. }) => Ok(false),
            Err(FactorError::Other(e)) => Err(e),
        }
    }
}

/// The stability of an equilibrium ([`NewtonWorkspace::stability`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Stability {
    /// Smallest eigenvalue λ of `H v = λ S v`: the objective's own Hessian H without its
    /// diagonal shift ([`Objective::hessian_diagonal_shift`]), measured against each unknown's
    /// own stiffness `S = diag(max(|H_dd|, 1e-6·mean|H_dd|))` (dimensionless), over the
    /// unknowns' space less the objective's [`Objective::rigid_modes`]. Negative: the
    /// equilibrium is unstable (a saddle or maximum); near 0: near a critical load. NaN when H
    /// is so indefinite that `H + 10³·S` is not positive definite (`stable` is then false).
    pub min_eigenvalue: f64,
    /// Its mode in the free unknowns, scaled to `‖v‖∞ = 1` (the buckling mode at a critical
    /// load).
    pub mode: Vec<f64>,
    /// Relative residual `‖H v − λ S v‖₂ / ‖S v‖₂` of the estimate.
    pub residual: f64,
    /// Rigid modes left out.
    pub rigid_modes: usize,
    /// `min_eigenvalue > 0`.
    pub stable: bool,
}

impl NewtonWorkspace {
    /// The smallest eigenvalue and mode of the objective's own, unshifted Hessian at `x`
    /// (see [`Stability`]): inverse iteration on a Cholesky factor (two to a few
    /// factorisations, up to 60 triangular solves). Needs the direct solver.
    pub fn stability<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        x: &[f64],
    ) -> Result<Stability, SolverError> {
        self.check_direct(objective, x, "the stability analysis")?;
        let mut timings = NewtonTimings::default();
        assemble(objective, x, &mut self.hessian, false, 0, &mut timings)?;
        self.reusable = None;
        let shift = objective.hessian_diagonal_shift();
        if shift != 0.0 {
            let val = self.hessian.val_mut();
            self.diag_offsets.iter().for_each(|&o| val[o] -= shift);
        }
        curvature::scaling(&self.hessian, &self.diag_offsets, &mut self.scale);
        let modes = objective.rigid_modes(x);
        let Some(cholesky) = self.cholesky.as_mut() else {
            return Err(SolverError::Linear("no Cholesky factorisation".into()));
        };
        let (pair, _) = curvature::smallest_eigenpair(
            cholesky,
            &mut self.hessian,
            &self.diag_offsets,
            &self.scale,
            &modes,
        )?;
        Ok(Stability {
            stable: pair.value > 0.0,
            min_eigenvalue: pair.value,
            mode: pair.vector,
            residual: pair.residual,
            rigid_modes: modes.len(),
        })
    }
}

/// The iterative fallback of a workspace whose Cholesky factor does not fit in memory.
struct Fallback {
    kind: IterativeFallback,
    precond: Precond,
    /// Symbolic statistics of the refused factor.
    stats: FactorStats,
    /// Estimated bytes of the preconditioner and the CG vectors.
    iterative_estimate: u64,
}

/// The fallback's preconditioner.
enum Precond {
    Ic0(Ic0),
    /// Inverse diagonal.
    Jacobi(Vec<f64>),
}

impl Precond {
    /// Builds the preconditioner of `h`; `false` when it cannot (a non-positive diagonal
    /// entry: h is not positive definite).
    fn build(&mut self, h: &SparseColMat<usize, f64>, diag_offsets: &[usize]) -> bool {
        match self {
            Precond::Ic0(ic) => ic.factorize(h.as_ref()).is_ok(),
            Precond::Jacobi(inv) => {
                let val = h.val();
                for (i, &o) in inv.iter_mut().zip(diag_offsets) {
                    if val[o].is_nan() || val[o] <= 0.0 {
                        return false;
                    }
                    *i = 1.0 / val[o];
                }
                true
            }
        }
    }

    fn apply(&self, r: &mut [f64]) {
        match self {
            Precond::Ic0(ic) => ic.apply(r),
            Precond::Jacobi(inv) => r.iter_mut().zip(inv).for_each(|(r, d)| *r *= d),
        }
    }
}

/// The relative residual a CG direction must reach: `min(cg_forcing, ‖∇f‖∞ / ‖∇f₀‖∞)`, at
/// least 1e-12 (Eisenstat–Walker-like: loose far from the solution, tight near it, so that
/// inexact Newton keeps its quadratic convergence).
fn forcing(limit: f64, g: f64, g0: f64) -> f64 {
    let ratio = if g0 > 0.0 { g / g0 } else { 1.0 };
    limit.min(ratio).max(1e-12)
}

/// Levenberg–Marquardt damping of the PSD Hessian: shortens and turns the step towards the
/// gradient where the quadratic model overshoots (large rotations of a thin shell, whose
/// Gauss–Newton model sees no membrane cost of bending out of plane from flat).
fn apply_damping(ws: &mut NewtonWorkspace, damping: f64) {
    if damping <= 0.0 {
        return;
    }
    let val = ws.hessian.val_mut();
    let mean = ws.diag_offsets.iter().map(|&o| val[o].abs()).sum::<f64>()
        / ws.diag_offsets.len().max(1) as f64;
    for &o in &ws.diag_offsets {
        val[o] += damping * mean;
    }
}

/// Factorisation reuse: when allowed and the kept factor is of an unshifted Hessian of this
/// `kind`, solves `H dx = −∇f` by CG preconditioned with it. Returns whether `ws.dx` holds the
/// direction; a failed attempt (too many iterations, non-positive curvature) leaves the
/// caller to factorise.
fn try_reuse(
    ws: &mut NewtonWorkspace,
    kind: IterationHessian,
    eta: f64,
    obj_shift: f64,
    settings: &NewtonSettings,
    rec: &mut Record,
) -> Result<bool, SolverError> {
    if !settings.reuse_factor || ws.reusable != Some(kind) {
        return Ok(false);
    }
    // After a restore or a cancelled solve the kept factor is rebuilt from its recorded input.
    if !ws
        .kept
        .ensure_factor(ws.cholesky.as_mut(), &mut ws.hessian)?
    {
        ws.reusable = None;
        return Ok(false);
    }
    // The own Hessian's unshifted system (see `refine_direction`; PSD ones keep their shift).
    let obj_shift = if kind == IterationHessian::Own {
        obj_shift
    } else {
        0.0
    };
    let t = Instant::now();
    let Some(o) = pcg_with_factor(ws, obj_shift, eta, settings.reuse_max_iterations)? else {
        return Ok(false);
    };
    rec.timings.solve += t.elapsed();
    rec.cg_iterations += o.iterations;
    if o.converged && !o.negative_curvature {
        rec.reused_steps += 1;
        if 2 * o.iterations > settings.reuse_max_iterations {
            // The factor is drifting away from the Hessian: refactorise at the next iteration
            // rather than pay more CG iterations there.
            ws.reusable = None;
        }
        Ok(true)
    } else {
        Ok(false)
    }
}

/// Computes `ws.dx = −(H + shift)⁻¹ ∇f` for the Hessian in `ws` (of `kind`), with the shift
/// search of `params` (see [`SparseCholesky::factorize_regularized`]): by a Cholesky
/// factorisation, or by the iterative fallback, where non-positive curvature met by CG plays
/// the part of a failed factorisation. Returns the shift and whether dx is exact (Cholesky, or
/// CG converged to the forcing term `eta`).
fn solve_direction(
    ws: &mut NewtonWorkspace,
    kind: IterationHessian,
    params: &RegularizationParams,
    eta: f64,
    settings: &NewtonSettings,
    rec: &mut Record,
) -> Result<(FactorOutcome, bool), FactorError> {
    ws.reusable = None;
    if let Some(cholesky) = ws.cholesky.as_mut() {
        let t = Instant::now();
        let r = cholesky.factorize_regularized(&mut ws.hessian, params, &mut ws.mu);
        rec.timings.factorization += t.elapsed();
        let outcome = match r {
            Ok(o) => {
                rec.factorizations += o.attempts;
                o
            }
            Err(e) => {
                if matches!(e, FactorError::NotPositiveDefinite { .. }) {
                    rec.factorizations += params.max_attempts + 1;
                }
                return Err(e);
            }
        };
        for (d, g) in ws.dx.iter_mut().zip(&ws.g) {
            *d = -g;
        }
        let t = Instant::now();
        cholesky
            .solve_in_place(&mut ws.dx)
            .map_err(FactorError::Other)?;
        rec.timings.solve += t.elapsed();
        if outcome.mu <= SMALL_SHIFT {
            ws.reusable = Some(kind);
            if settings.reuse_factor {
                ws.kept
                    .record(kind, ws.hessian.val(), outcome.mu, params.kind);
            }
        }
        return Ok((outcome, true));
    }
    let NewtonWorkspace {
        fallback: Some(fallback),
        hessian,
        g,
        dx,
        x_trial,
        pcg: scratch,
        diag_offsets,
        mu,
        ..
    } = ws
    else {
        return Err(FactorError::Other(SolverError::Linear(
            "a Newton workspace without a linear solver".into(),
        )));
    };
    // The shift search of `factorize_regularized`, with CG's curvature test in place of the
    // factorisation's pivots.
    let mut trial = if *mu > 0.0 && *mu * params.shrink >= params.initial {
        *mu * params.shrink
    } else {
        0.0
    };
    let backup: Vec<f64> = diag_offsets.iter().map(|&o| hessian.val()[o]).collect();
    let scale = {
        let s = backup.iter().map(|d| d.abs()).sum::<f64>() / backup.len().max(1) as f64;
        if s.is_finite() && s > 0.0 { s } else { 1.0 }
    };
    for (b, g) in x_trial.iter_mut().zip(g.iter()) {
        *b = -g;
    }
    let mut attempts = 0;
    let mut shifted_attempts = 0;
    let result = loop {
        attempts += 1;
        let mut max_shift = 0.0f64;
        {
            let val = hessian.val_mut();
            for (&o, &d) in diag_offsets.iter().zip(&backup) {
                let shift = match params.kind {
                    RegularizationKind::Identity => trial * scale,
                    RegularizationKind::Diagonal => trial * d.abs().max(1e-6 * scale),
                };
                max_shift = max_shift.max(shift);
                val[o] = d + shift;
            }
        }
        let t = Instant::now();
        let built = fallback.precond.build(hessian, diag_offsets);
        rec.timings.factorization += t.elapsed();
        rec.factorizations += 1;
        let mut positive = built;
        let mut converged = false;
        if built {
            let t = Instant::now();
            let o = pcg(
                hessian.as_ref(),
                x_trial,
                dx,
                eta,
                settings.cg_max_iterations,
                scratch,
                |r| {
                    fallback.precond.apply(r);
                    Ok(())
                },
            )
            .map_err(FactorError::Other)?;
            rec.timings.solve += t.elapsed();
            rec.cg_iterations += o.iterations;
            positive = !o.negative_curvature;
            converged = o.converged;
        }
        if positive {
            *mu = trial;
            break Ok((
                FactorOutcome {
                    mu: trial,
                    max_shift,
                    attempts,
                },
                converged,
            ));
        }
        if shifted_attempts >= params.max_attempts {
            break Err(FactorError::NotPositiveDefinite { pivot: 0 });
        }
        shifted_attempts += 1;
        trial = if trial == 0.0 {
            params.initial
        } else {
            trial * params.growth
        };
    };
    let val = hessian.val_mut();
    for (&o, &d) in diag_offsets.iter().zip(&backup) {
        val[o] = d;
    }
    result
}

/// Relative residual of the correction estimate that may end a solve (see
/// [`estimate_correction`]).
const ESTIMATE_TOLERANCE: f64 = 1e-6;

/// `ws.dx` = the solution of `(H − obj_shift·I) dx = −∇f` by CG (at most `max_iterations`, to
/// relative residual `eta`) preconditioned with the Cholesky factor the workspace holds, for
/// the Hessian H in `ws` (its values are restored). `None` without a Cholesky factor.
fn pcg_with_factor(
    ws: &mut NewtonWorkspace,
    obj_shift: f64,
    eta: f64,
    max_iterations: usize,
) -> Result<Option<crate::iterative::PcgOutcome>, SolverError> {
    let NewtonWorkspace {
        cholesky: Some(cholesky),
        hessian,
        g,
        dx,
        x_trial,
        pcg: scratch,
        diag_offsets,
        ..
    } = ws
    else {
        return Ok(None);
    };
    // x_trial is free until the line search: it holds the right-hand side.
    for (b, g) in x_trial.iter_mut().zip(g.iter()) {
        *b = -g;
    }
    let shift_diagonal = |hessian: &mut SparseColMat<usize, f64>, by: f64| {
        if by != 0.0 {
            let val = hessian.val_mut();
            diag_offsets.iter().for_each(|&o| val[o] += by);
        }
    };
    shift_diagonal(hessian, -obj_shift);
    let o = pcg(
        hessian.as_ref(),
        x_trial,
        dx,
        eta,
        max_iterations,
        scratch,
        |r| cholesky.solve_in_place(r),
    );
    shift_diagonal(hessian, obj_shift);
    Ok(Some(o?))
}

/// CG iterations [`refine_direction`] may take. The preconditioned matrix `(H + s)⁻¹ H` has
/// its eigenvalues in (0, 1], all near 1 but those of the few soft modes whose curvature is
/// near the shift s, so CG needs about as many iterations as there are such modes.
const REFINE_MAX_ITERATIONS: usize = 40;

/// Relative residual `‖H dx + ∇f‖₂ / ‖∇f‖₂` of a refined direction: far below what changes
/// Newton's path, and reachable where ∇f is at round-off (a tighter, forcing-term tolerance
/// there stalls on the components of ∇f's round-off along rigid motions, which H cannot
/// reduce).
const REFINE_TOLERANCE: f64 = 1e-6;

/// Turns `ws.dx = −(H + s)⁻¹∇f`, solved with the factor of the Hessian `H` in `ws` plus a
/// small shift s (the objective's constant diagonal shift `obj_shift`, and/or a regularisation
/// shift of at most [`SMALL_SHIFT`]), into the direction of the unshifted system
/// `(H − obj_shift·I) dx = −∇f`, by CG preconditioned with that factor to relative residual
/// `eta`. With the shifted direction Newton converges only linearly (ratio s/(λ + s)) on soft
/// modes of curvature λ near s — the long bending modes of slender and thin shells — and the
/// correction used by the step test underestimates the distance to the equilibrium there.
///
/// Returns whether CG converged. Otherwise (non-positive curvature along a CG direction,
/// typically a rigid motion of an unheld shell, or the iteration limit) `ws.dx` is the shifted
/// direction again, which then serves as before: the shift is far below the stiffness of every
/// mode but the softest.
fn refine_direction(
    ws: &mut NewtonWorkspace,
    obj_shift: f64,
    eta: f64,
    rec: &mut Record,
) -> Result<bool, SolverError> {
    let t = Instant::now();
    let Some(o) = pcg_with_factor(ws, obj_shift, eta, REFINE_MAX_ITERATIONS)? else {
        return Ok(false);
    };
    rec.cg_iterations += o.iterations;
    let solved = o.converged && !o.negative_curvature;
    if solved {
        rec.refined_steps += 1;
    } else if let Some(cholesky) = ws.cholesky.as_mut() {
        for (d, g) in ws.dx.iter_mut().zip(&ws.g) {
            *d = -g;
        }
        cholesky.solve_in_place(&mut ws.dx)?;
    }
    rec.timings.solve += t.elapsed();
    Ok(solved)
}

/// Estimates the Newton correction at the new iterate with the last factor (or, with the
/// iterative fallback, by CG on the last Hessian): `ws.dx = −H⁻¹∇f`. Returns whether the
/// estimate is usable (CG converged).
fn estimate_correction(
    ws: &mut NewtonWorkspace,
    settings: &NewtonSettings,
    rec: &mut Record,
) -> Result<bool, SolverError> {
    if let Some(cholesky) = ws.cholesky.as_mut() {
        for (d, g) in ws.dx.iter_mut().zip(&ws.g) {
            *d = -g;
        }
        cholesky.solve_in_place(&mut ws.dx)?;
        return Ok(true);
    }
    let NewtonWorkspace {
        fallback: Some(fallback),
        hessian,
        g,
        dx,
        x_trial,
        pcg: scratch,
        ..
    } = ws
    else {
        return Ok(false);
    };
    for (b, g) in x_trial.iter_mut().zip(g.iter()) {
        *b = -g;
    }
    // Tight enough that the estimate decides the step test (the correction is tiny here).
    let o = pcg(
        hessian.as_ref(),
        x_trial,
        dx,
        ESTIMATE_TOLERANCE,
        settings.cg_max_iterations,
        scratch,
        |r| {
            fallback.precond.apply(r);
            Ok(())
        },
    )?;
    rec.cg_iterations += o.iterations;
    Ok(o.converged && !o.negative_curvature)
}

/// Minimises `objective` from `x` (overwritten with the result).
///
/// On success `x` is the converged iterate. On failure `x` holds the last accepted iterate
/// (also carried by the error, with the residual history), never a rejected trial point.
pub fn newton_solve<O: Objective + ?Sized>(
    objective: &mut O,
    x: &mut [f64],
    settings: &NewtonSettings,
    ws: &mut NewtonWorkspace,
) -> Result<NewtonReport, SolverError> {
    let started = Instant::now();
    settings.validate()?;
    let n = objective.n_dofs();
    if x.len() != n {
        return Err(SolverError::DimensionMismatch {
            what: "x",
            expected: n,
            found: x.len(),
        });
    }
    if ws.n_dofs() != n {
        return Err(SolverError::DimensionMismatch {
            what: "Newton workspace",
            expected: n,
            found: ws.n_dofs(),
        });
    }
    let force_scale = objective.force_scale();
    if !(force_scale.is_finite() && force_scale > 0.0) {
        return Err(SolverError::InvalidForceScale(force_scale));
    }
    let length_scale = objective.length_scale();
    if !(length_scale.is_finite() && length_scale > 0.0) {
        return Err(SolverError::InvalidLengthScale(length_scale));
    }
    let gradient_test = objective.gradient_test();
    let step_limit = settings.step_tolerance * length_scale;
    let reg_params = settings.regularization_params();
    if settings.regularization.is_none() {
        // A shift remembered from an earlier solve must not leak into an unregularised one.
        ws.mu = 0.0;
    }
    let mu_at_start = ws.mu;
    ws.kept.begin_solve(ws.reusable);
    let mut rec = Record {
        residuals: Vec::new(),
        values: Vec::new(),
        hessians: Vec::new(),
        corrections: Vec::new(),
        failed_factorizations: 0,
        rejected_steps: 0,
        watchdog_steps: 0,
        watchdog_returns: 0,
        watchdog_undone: 0,
        backtracks: 0,
        regularizations: Vec::new(),
        timings: NewtonTimings::default(),
        factorizations: 0,
        reused_steps: 0,
        refined_steps: 0,
        value_noise: 0.0,
        cg_iterations: 0,
        linear_solver: ws.linear_solver(),
    };

    let t = Instant::now();
    let mut f = objective.gradient(x, &mut ws.g)?;
    rec.timings.assembly += t.elapsed();
    check_finite(f, &ws.g, 0)?;
    rec.residuals.push(norm_inf(&ws.g) / force_scale);
    rec.values.push(f);
    let mut iteration = 0;
    // The initial gradient, the reference of the CG forcing term.
    let g0 = norm_inf(&ws.g);

    // Adaptive policy state: whether the next iteration tries the own Hessian, how many good
    // PSD steps to wait before trying it again, and that wait after the next failure.
    let adaptive = matches!(
        settings.hessian,
        HessianPolicy::Adaptive | HessianPolicy::AdaptivePsd
    ) && objective.has_psd_hessian();
    // Trust-region steps on the shifted own Hessian where it is indefinite, and saddle escapes
    // (issue #26): the adaptive policy with a direct solver.
    let trust = adaptive && settings.hessian == HessianPolicy::Adaptive && ws.cholesky.is_some();
    let escape = trust && settings.escape_saddles;
    // Trust-region (Levenberg–Marquardt) parameter σ of shifted steps, relative to S, after the
    // last step's ratio test (0: none), and the last shift at which own + σS factorised.
    let mut sigma = 0.0f64;
    let mut pd_floor = 0.0f64;
    let mut tr_rejections = 0usize;
    let mut escapes = 0usize;
    // Whether an iterate of this solve met an indefinite own Hessian or used another one: only
    // then can a converged point be a saddle (an own Hessian positive definite all along ends
    // at a minimum).
    let mut met_indefinite = false;
    let mut want_escape = false;
    // Consecutive PSD iterations that reduced the residual by less than PSD_SLOW_RATIO, and
    // whether the PSD iterations have stalled: only then does an indefinite own Hessian get
    // trust-region steps (far from a solution Gauss–Newton is the faster: its model ignores
    // the compressive stresses whose negative curvature makes the shifted steps short).
    // Without line search PSD steps are taken in full, unguarded: the trust region (which has
    // its own acceptance test) is used from the start.
    let mut psd_slow = 0usize;
    let mut psd_stalled = !settings.line_search;
    let x_start = (settings.relative_step_tolerance > 0.0).then(|| x.to_vec());
    let mut try_own = true;
    // A converged point: where an indefinite own Hessian was met on the way, first make sure
    // it is not a saddle (leave it along negative curvature and go on if it is).
    // A step along the most negative curvature of the own Hessian, while escapes are allowed
    // (`escape_saddle`; `$known`: the Hessian in `ws` is the own one at x, known indefinite);
    // when it moves, the Newton loop goes on from the new point with the shift found there:
    // `continue 'newton` (the label is passed in: macro hygiene), not the innermost loop.
    // From inside the line search a bare `continue` retried the stale direction and slope of
    // the point before the escape, whose round-off test then passed at once: a false
    // convergence far from equilibrium (robustness.md, issue #26 item 6).
    macro_rules! leave_saddle {
        ($newton:lifetime, $known:expr) => {
            if escape && escapes < MAX_ESCAPES {
                escapes += 1;
                if let Some(fe) = escape_saddle(
                    objective,
                    x,
                    f,
                    ws,
                    &mut rec,
                    length_scale,
                    force_scale,
                    &mut sigma,
                    &mut iteration,
                    started,
                    $known,
                )? {
                    f = fe;
                    pd_floor = sigma;
                    try_own = true;
                    continue $newton;
                }
            }
        };
    }
    macro_rules! converged {
        ($newton:lifetime, $c:expr) => {{
            if met_indefinite {
                leave_saddle!($newton, false);
            }
            return Ok(rec.report(iteration, $c));
        }};
    }
    // Levenberg–Marquardt damping of PSD iterations (relative to the mean |H_dd|).
    let mut damping = 0.0f64;
    let mut wait = 0usize;
    let mut backoff = 1usize;
    // Watchdog state: the point before a non-monotone full step, and whether the next
    // iteration may take one (not right after a return to such a point).
    let mut watch: Option<Watch> = None;
    let mut watch_allowed = true;

    'newton: loop {
        // The objective's own update at this iterate (`Objective::begin_iteration`).
        if begin_iteration(objective, x, iteration, settings, ws, &mut f, &mut rec)? {
            watch = None;
        }
        if watch.is_none()
            && gradient_test
            && rec.residuals[rec.residuals.len() - 1] <= settings.gradient_tolerance
        {
            converged!('newton, Convergence::Gradient);
        }
        if ws
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::SeqCst))
        {
            if let Some(w) = watch.take() {
                x.copy_from_slice(&w.x);
                rec.residuals.truncate(w.len);
            }
            // A cancelled solve leaves the workspace's carried state as it found it, so that a
            // run resumed from the last completed step repeats this one exactly.
            ws.mu = mu_at_start;
            ws.reusable = ws.kept.cancel_solve();
            return Err(SolverError::Cancelled {
                iterations: iteration + rec.watchdog_undone,
                residuals: rec.residuals,
                last_good: x.to_vec(),
            });
        }
        if iteration + rec.watchdog_undone + rec.rejected_steps >= settings.max_iterations {
            if let Some(w) = watch.take() {
                // The failure carries the best point: the one before the watched step.
                x.copy_from_slice(&w.x);
                rec.residuals.truncate(w.len);
            }
            return Err(SolverError::NewtonDidNotConverge {
                residuals: rec.residuals,
                iterations: iteration + rec.watchdog_undone + rec.rejected_steps,
                tolerance: settings.gradient_tolerance,
                last_correction: rec.corrections.last().copied(),
                step_tolerance: settings.step_tolerance,
                last_good: x.to_vec(),
            });
        }

        // Hessian, then the Newton direction dx = −H⁻¹∇f: by CG preconditioned with the kept
        // factor (reuse), or by a (possibly shifted) factorisation, or by the iterative
        // fallback. `exact`: dx solves the system to the forcing term (not truncated), so
        // that an unshifted one may serve the convergence tests.
        let eta = forcing(settings.cg_forcing, norm_inf(&ws.g), g0);
        let eta_reuse = forcing(settings.reuse_tolerance, norm_inf(&ws.g), g0);
        let mut kind = assemble(
            objective,
            x,
            &mut ws.hessian,
            adaptive && !try_own,
            iteration,
            &mut rec.timings,
        )?;
        if kind == IterationHessian::Psd {
            apply_damping(ws, damping);
        }
        let mut reused = false;
        let mut direction = None;
        if try_reuse(
            ws,
            kind,
            eta_reuse,
            objective.hessian_diagonal_shift(),
            settings,
            &mut rec,
        )? {
            direction = Some((FactorOutcome::default(), true));
            reused = true;
        }
        // Trust region: while the own Hessian is known to be indefinite (σ or the last
        // positive-definite shift above the small one), go straight to the shifted search.
        let shift_start = sigma.max(pd_floor / SHIFT_GROWTH);
        let in_trust = trust && shift_start > SMALL_SHIFT;
        if direction.is_none() && in_trust && kind == IterationHessian::Own && try_own {
            if want_escape {
                // The last shifted step was as good as the model (ρ > ¾) yet its length was
                // set by the shift that keeps H + σS positive definite, not by the model:
                // move along the negative curvature as far as f keeps decreasing.
                want_escape = false;
                leave_saddle!('newton, true);
            }
            direction = shifted_direction(ws, Some(shift_start), &mut rec)?;
            if let Some((o, _)) = direction {
                kind = IterationHessian::Shifted;
                sigma = o.mu;
                pd_floor = o.mu;
                met_indefinite = true;
            }
        }
        if direction.is_none() && !in_trust && adaptive && kind == IterationHessian::Own && try_own
        {
            // The own Hessian, shifted by at most SMALL_SHIFT (far below bending stiffness:
            // it only lifts the tiny negative eigenvalues of a nearly converged, slightly
            // compressed shell); anything more indefinite switches to the PSD Hessian.
            let small = RegularizationParams {
                max_attempts: small_shift_attempts(&reg_params),
                ..reg_params
            };
            match solve_direction(ws, kind, &small, eta, settings, &mut rec) {
                Ok(d) => direction = Some(d),
                Err(FactorError::NotPositiveDefinite { .. }) if trust && psd_stalled => {
                    // Indefinite: a trust-region step on the shifted own Hessian.
                    rec.failed_factorizations += 1;
                    ws.mu = 0.0;
                    met_indefinite = true;
                    // First leave along negative curvature (a saddle or an indefinite
                    // region is near: shifted steps would only creep along that direction).
                    leave_saddle!('newton, true);
                    direction = shifted_direction(ws, None, &mut rec)?;
                    if let Some((o, _)) = direction {
                        kind = IterationHessian::Shifted;
                        sigma = o.mu;
                        pd_floor = o.mu;
                    }
                }
                Err(FactorError::NotPositiveDefinite { .. }) => {
                    rec.failed_factorizations += 1;
                    met_indefinite = true;
                    ws.mu = 0.0;
                    try_own = false;
                    wait = backoff;
                    backoff = backoff.saturating_mul(2);
                    kind = assemble(
                        objective,
                        x,
                        &mut ws.hessian,
                        true,
                        iteration,
                        &mut rec.timings,
                    )?;
                    apply_damping(ws, damping);
                    if try_reuse(
                        ws,
                        kind,
                        eta_reuse,
                        objective.hessian_diagonal_shift(),
                        settings,
                        &mut rec,
                    )? {
                        direction = Some((FactorOutcome::default(), true));
                        reused = true;
                    }
                }
                Err(FactorError::Other(e)) => return Err(e),
            }
        }
        if direction.is_none() && trust && kind == IterationHessian::Own && try_own {
            // No shift the search tried made the own Hessian positive definite: the PSD one.
            try_own = false;
            wait = backoff;
            backoff = backoff.saturating_mul(2);
            sigma = 0.0;
            pd_floor = 0.0;
            kind = assemble(
                objective,
                x,
                &mut ws.hessian,
                true,
                iteration,
                &mut rec.timings,
            )?;
            apply_damping(ws, damping);
            if try_reuse(
                ws,
                kind,
                eta_reuse,
                objective.hessian_diagonal_shift(),
                settings,
                &mut rec,
            )? {
                direction = Some((FactorOutcome::default(), true));
                reused = true;
            }
        }
        let (outcome, exact) = match direction {
            Some(d) => d,
            None => match solve_direction(ws, kind, &reg_params, eta, settings, &mut rec) {
                Ok(d) => d,
                Err(FactorError::NotPositiveDefinite { pivot }) => {
                    return Err(if settings.regularization.is_some() {
                        SolverError::RegularizationFailed {
                            iteration,
                            mu: ws.mu,
                            attempts: reg_params.max_attempts + 1,
                        }
                    } else {
                        SolverError::NotPositiveDefinite { iteration, pivot }
                    });
                }
                Err(FactorError::Other(e)) => return Err(e),
            },
        };
        if outcome.mu > 0.0 && kind != IterationHessian::Shifted {
            rec.regularizations.push(RegularizationEvent {
                iteration,
                mu: outcome.mu,
                max_shift: outcome.max_shift,
                attempts: outcome.attempts,
            });
        }
        // A direction that may stand for the unshifted Newton correction in the tests below:
        // one solved with a slightly shifted factor is refined into it first.
        let unshifted = outcome.mu <= SMALL_SHIFT && exact;
        let obj_shift = objective.hessian_diagonal_shift();
        // Own-Hessian directions only: on the PSD (Gauss–Newton) Hessian the small shift
        // damps the directions its model leaves flat (e.g. folding a crease), which it sees no
        // cost for; solved without it, those steps run far beyond where the model holds.
        if unshifted
            && !reused
            && kind == IterationHessian::Own
            && (outcome.mu > 0.0 || obj_shift > 0.0)
        {
            refine_direction(ws, obj_shift, REFINE_TOLERANCE, &mut rec)?;
        }

        let step_limit = current_step_limit(step_limit, settings, x, x_start.as_deref());
        if let Some(dof) = first_non_finite(&ws.dx) {
            return Err(SolverError::NonFinite {
                what: "Newton direction",
                iteration,
                dof: Some(dof),
            });
        }
        let slope: f64 = ws.dx.iter().zip(&ws.g).map(|(d, g)| d * g).sum();

        // An unshifted Newton correction below the step tolerance, or one whose predicted
        // decrease f cannot resolve: x is converged. The step is not taken.
        if unshifted && watch.is_none() {
            let dx_max = norm_inf(&ws.dx);
            rec.corrections.push(dx_max / length_scale);
            if dx_max <= step_limit {
                converged!('newton, Convergence::Step);
            }
            // Round-off: f cannot resolve the predicted decrease and the last step no longer
            // halved the gradient (while it does, Newton still makes progress on it).
            let n = rec.residuals.len();
            if -0.5 * slope <= rec.noise(f)
                && n >= 2
                && rec.residuals[n - 1] > 0.5 * rec.residuals[n - 2]
            {
                converged!('newton, Convergence::RoundOff);
            }
        }

        let mut alpha = step_limit_of(objective, x, &ws.dx)?;
        let mut backtracks = 0;
        let mut trial_has_gradient = true;
        // Ratio of actual to predicted decrease of a trust-region step.
        let mut rho = f64::NAN;
        let f_trial = if kind == IterationHessian::Shifted {
            // Trust-region step: taken in full when its actual decrease is at least
            // TR_ACCEPT of the decrease the exact quadratic model predicts, otherwise
            // redone with a larger shift.
            sym_lower_matvec(ws.hessian.as_ref(), 0.0, &ws.dx, &mut ws.hd);
            let dhd: f64 = ws.dx.iter().zip(&ws.hd).map(|(a, b)| a * b).sum();
            let pred = -(alpha * slope + 0.5 * alpha * alpha * dhd);
            // (NaN included: no usable prediction.)
            let mut saddle_step = None;
            if pred.is_nan() || pred <= WATCHDOG_MIN_DECREASE * rec.noise(f) {
                // The shifted model promises nothing f can resolve: x is near a critical
                // point of an indefinite Hessian. Leave it along negative curvature.
                leave_saddle!('newton, false);
                // No lower point that way (or saddles are answers here): the unshifted Newton
                // step, which converges to the critical point quadratically, and whose length
                // is the convergence test.
                match saddle_newton(objective, x, f, ws, &mut rec, step_limit)? {
                    SaddleStep::Converged => converged!('newton, Convergence::Step),
                    SaddleStep::Taken(f_t) => {
                        kind = IterationHessian::Own;
                        alpha = 1.0;
                        saddle_step = Some(f_t);
                    }
                    SaddleStep::Unavailable => {
                        // Let the PSD Hessian (and then the convergence tests) decide.
                        rec.rejected_steps += 1;
                        try_own = false;
                        wait = backoff;
                        backoff = backoff.saturating_mul(2);
                        sigma = 0.0;
                        pd_floor = 0.0;
                        continue;
                    }
                }
            }
            let f_t = match saddle_step {
                Some(f_t) => f_t,
                None => {
                    for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x.iter()).zip(&ws.dx) {
                        *xt = xi + alpha * d;
                    }
                    let t = Instant::now();
                    let f_t = objective.gradient(&ws.x_trial, &mut ws.g_trial)?;
                    rec.timings.assembly += t.elapsed();
                    rho = (f - f_t) / pred;
                    f_t
                }
            };

            if saddle_step.is_none()
                && !(f_t.is_finite() && rho >= TR_ACCEPT && first_non_finite(&ws.g_trial).is_none())
            {
                rec.rejected_steps += 1;
                tr_rejections += 1;
                sigma *= TR_GROWTH;
                if tr_rejections >= MAX_TR_REJECTIONS {
                    // The shifted model keeps failing here (far from any quadratic
                    // behaviour): PSD steps, as before issue #26, until they stall again.
                    psd_stalled = !settings.line_search;
                    psd_slow = 0;
                    try_own = false;
                    wait = backoff;
                    backoff = backoff.saturating_mul(2);
                    sigma = 0.0;
                    pd_floor = 0.0;
                    tr_rejections = 0;
                }
                continue;
            }
            tr_rejections = 0;
            f_t
        } else {
            // Backtracking line search. The first trial evaluates the gradient too (it is
            // usually accepted); later trials only the value.
            loop {
                for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x.iter()).zip(&ws.dx) {
                    *xt = xi + alpha * d;
                }
                let t = Instant::now();
                let f_t = if backtracks == 0 {
                    trial_has_gradient = true;
                    let f_t = objective.gradient(&ws.x_trial, &mut ws.g_trial)?;
                    rec.timings.assembly += t.elapsed();
                    f_t
                } else {
                    trial_has_gradient = false;
                    let f_t = objective.value(&ws.x_trial)?;
                    rec.timings.line_search += t.elapsed();
                    rec.timings.line_search_evaluations += 1;
                    f_t
                };
                if !settings.line_search {
                    if !f_t.is_finite() {
                        return Err(SolverError::NonFinite {
                            what: "value",
                            iteration: iteration + 1,
                            dof: None,
                        });
                    }
                    break f_t;
                }
                if f_t.is_finite() && slope < 0.0 {
                    if f_t <= f + settings.armijo_c1 * alpha * slope {
                        break f_t;
                    }
                    // Once the predicted decrease is below the round-off of f, values cannot
                    // discriminate: accept a full step that does not raise f beyond round-off
                    // and reduces the gradient.
                    let noise = rec.noise(f.abs().max(f_t.abs()));
                    if trial_has_gradient
                        && -slope <= noise
                        && f_t <= f + noise
                        && norm_inf(&ws.g_trial) < norm_inf(&ws.g)
                    {
                        break f_t;
                    }
                }
                if backtracks == 0
                    && settings.watchdog > 0
                    && watch.is_none()
                    && watch_allowed
                    && -slope > WATCHDOG_MIN_DECREASE * rec.noise(f)
                    && f_t.is_finite()
                    && first_non_finite(&ws.g_trial).is_none()
                {
                    // Watchdog: take the full Newton step although f rose. A thin shell bending
                    // away from flat is the typical case: the full step bends it with the right
                    // curvature but stretches its membrane (which the linearisation cannot see),
                    // and the next Newton step relaxes the membrane; a monotone line search would
                    // instead crawl along the bending mode with tiny steps.
                    watch = Some(Watch {
                        x: x.to_vec(),
                        g: ws.g.clone(),
                        f,
                        bound: f + settings.armijo_c1 * slope,
                        len: rec.values.len(),
                        left: settings.watchdog,
                    });
                    rec.watchdog_steps += 1;
                    break f_t;
                }
                if backtracks == 0 && watch.is_none() && unshifted && -0.5 * slope <= rec.noise(f) {
                    // The unshifted Newton step predicts a decrease below the round-off of f and
                    // its full step is not distinguishable from x: x is at the round-off floor
                    // (typically a solve restarted at its own equilibrium), not stuck.
                    converged!('newton, Convergence::RoundOff);
                }
                if adaptive && kind == IterationHessian::Own {
                    // The own Hessian's quadratic model does not hold here (its full step fails
                    // the Armijo test): redo the iteration with the PSD Hessian rather than take a
                    // short step along a direction that may lead towards a saddle or a poor minimum.
                    break f64::NAN;
                }
                if backtracks >= settings.max_backtracks || slope >= 0.0 {
                    if let Some(w) = watch.take() {
                        // The failure carries the best point: the one before the watched step.
                        x.copy_from_slice(&w.x);
                        rec.residuals.truncate(w.len);
                    }
                    return Err(SolverError::LineSearchFailed {
                        iteration,
                        backtracks,
                        residuals: rec.residuals,
                        last_good: x.to_vec(),
                    });
                }
                backtracks += 1;
                alpha *= settings.backtrack_factor;
            }
        };
        rec.backtracks += backtracks;
        if f_trial.is_nan() {
            rec.rejected_steps += 1;
            try_own = false;
            wait = backoff;
            backoff = backoff.saturating_mul(2);
            continue;
        }

        // Accept the trial point.
        let f_old = f;
        x.copy_from_slice(&ws.x_trial);
        if trial_has_gradient {
            std::mem::swap(&mut ws.g, &mut ws.g_trial);
            f = f_trial;
        } else {
            let t = Instant::now();
            f = objective.gradient(x, &mut ws.g)?;
            rec.timings.assembly += t.elapsed();
            if f.is_finite() && f_trial.is_finite() {
                // Two evaluations of f at one point by different operations: their
                // difference shows its round-off.
                rec.value_noise = rec.value_noise.max((f - f_trial).abs());
            }
        }
        iteration += 1;
        rec.hessians.push(kind);
        check_finite(f, &ws.g, iteration)?;
        rec.residuals.push(norm_inf(&ws.g) / force_scale);
        rec.values.push(f);
        if let Some(hook) = &ws.progress {
            hook(&NewtonProgress {
                iteration,
                residual: norm_inf(&ws.g) / force_scale,
                step_length: alpha,
                hessian: kind,
                regularized: outcome.mu > 0.0,
                elapsed: started.elapsed(),
            });
        }
        watch_allowed = true;
        let watched_step = matches!(&watch, Some(w) if w.left == settings.watchdog);
        if let Some(w) = watch.as_mut() {
            if f <= w.bound {
                watch = None;
            } else if w.left == 0 {
                // The watched iterates never recovered: back to the point before the
                // non-monotone step, which the next iteration leaves by the usual line search.
                x.copy_from_slice(&w.x);
                ws.g.copy_from_slice(&w.g);
                f = w.f;
                rec.watchdog_returns += 1;
                // The undone iterations leave the record (the record is the accepted path);
                // they still count against the iteration limit.
                rec.watchdog_undone += iteration - (w.len - 1);
                iteration = w.len - 1;
                rec.values.truncate(w.len);
                rec.residuals.truncate(w.len);
                rec.hessians.truncate(iteration);
                rec.regularizations.retain(|e| e.iteration < iteration);
                watch = None;
                watch_allowed = false;
                continue;
            } else {
                w.left -= 1;
            }
        }

        // Adaptive policy: a backtracked step of the own Hessian means its quadratic model is
        // poor here; a full PSD step that achieved at least half the predicted decrease
        // (ratio ρ = Δf / (½ ∇fᵀdx), the PSD model's prediction) means the iterate is where
        // the quadratic model holds, so the own Hessian is worth another try.
        if kind == IterationHessian::Psd {
            let n = rec.residuals.len();
            if rec.residuals[n - 1] > PSD_SLOW_RATIO * rec.residuals[n - 2] {
                psd_slow += 1;
            } else {
                psd_slow = 0;
            }
            if trust && !psd_stalled && psd_slow >= PSD_STALL_ITERATIONS {
                // Gauss–Newton converges only linearly here: the own Hessian (shifted in a
                // trust region where it is indefinite) from the next iteration on.
                psd_stalled = true;
                try_own = true;
                wait = 0;
                backoff = 1;
            }
        } else {
            psd_slow = 0;
        }
        if adaptive {
            match kind {
                IterationHessian::Shifted => {
                    // Levenberg–Marquardt update of the trust-region shift.
                    if rho > 0.75 {
                        sigma /= TR_SHRINK;
                        want_escape = sigma < pd_floor / SHIFT_GROWTH;
                    } else if rho < 0.25 {
                        sigma *= TR_GROWTH;
                    }
                    if sigma <= SMALL_SHIFT {
                        sigma = 0.0;
                    }
                }
                IterationHessian::Own if backtracks > 0 => try_own = false,
                IterationHessian::Psd if backtracks > 0 => {
                    if backtracks >= DAMPING_BACKTRACKS {
                        damping = (damping * DAMPING_GROWTH).max(DAMPING_MIN);
                    }
                    // The PSD model overshoots too: the own Hessian may do better here (a
                    // membrane sagging from flat). Rejections make it wait 1, 2, 4, … steps.
                    if wait == 0 {
                        try_own = true;
                    } else {
                        wait -= 1;
                    }
                }
                IterationHessian::Psd if backtracks == 0 && slope < 0.0 => {
                    let rho = (f - f_old) / (0.5 * slope);
                    if rho >= 0.5 {
                        damping /= DAMPING_GROWTH * DAMPING_GROWTH;
                        if damping < DAMPING_MIN {
                            damping = 0.0;
                        }
                        if wait == 0 {
                            try_own = true;
                        } else {
                            wait -= 1;
                        }
                    }
                }
                _ => {}
            }
        }

        // After a full unshifted step, estimate the next correction with the same
        // factorisation (one triangular solve): a short one ends the solve here.
        if unshifted && backtracks == 0 && watch.is_none() && !watched_step {
            if gradient_test
                && rec.residuals[rec.residuals.len() - 1] <= settings.gradient_tolerance
            {
                converged!('newton, Convergence::Gradient);
            }
            // The limit at the new iterate: a relative one grows with the move just made (the
            // one of the iteration's start, before any move, left the estimate unable to end
            // an implicit step, which then assembled one more Hessian only to stop there).
            let step_limit = current_step_limit(
                settings.step_tolerance * length_scale,
                settings,
                x,
                x_start.as_deref(),
            );
            let t = Instant::now();
            let solved = estimate_correction(ws, settings, &mut rec)?;
            rec.timings.solve += t.elapsed();
            if solved
                && ws.cholesky.is_some()
                && norm_inf(&ws.dx) <= step_limit
                && (reused || outcome.mu > 0.0 || obj_shift > 0.0)
            {
                // A shifted (or old) factor underestimates the correction along soft modes
                // (the refined one is larger there): an estimate that would end the solve
                // solves the unshifted system where CG can.
                refine_direction(ws, obj_shift, ESTIMATE_TOLERANCE, &mut rec)?;
            }
            let est = if solved {
                norm_inf(&ws.dx)
            } else {
                f64::INFINITY
            };
            if est.is_finite() && est <= step_limit {
                rec.corrections.push(est / length_scale);
                converged!('newton, Convergence::Step);
            }
        }
    }
}

/// A PSD iteration that leaves more than this fraction of the residual is slow.
const PSD_SLOW_RATIO: f64 = 0.5;
/// Consecutive slow PSD iterations after which the PSD iterations count as stalled.
const PSD_STALL_ITERATIONS: usize = 2;

/// A shifted step is taken when its actual decrease is at least this fraction of the decrease
/// the exact quadratic model predicts (the trust-region acceptance ratio).
const TR_ACCEPT: f64 = 0.1;
/// Factor the trust-region shift grows by after a rejected or poor (ρ < 0.25) step.
const TR_GROWTH: f64 = 4.0;
/// Factor the trust-region shift shrinks by after a very good (ρ > 0.75) step.
const TR_SHRINK: f64 = 16.0;
/// Consecutive rejected shifted steps after which the solve turns to the PSD Hessian for a
/// while (the shifted model does not describe f here at any shift tried so far).
const MAX_TR_REJECTIONS: usize = 6;
/// Negative-curvature escapes per solve.
const MAX_ESCAPES: usize = 50;
/// Largest shift σ the saddle escape at a converged point tries (relative to each unknown's
/// own stiffness): beyond it the Hessian is not that of a nearly stable point.
const ESCAPE_MAX_SHIFT: f64 = 1e3;
/// Largest trust-region shift σ (relative to each unknown's own stiffness, see
/// `curvature.rs`): an own Hessian that needs more is strongly indefinite — a compressed
/// membrane far from equilibrium — where the shifted steps crawl (measured: σ ≈ 10–170 on the
/// flat start of a cone-growing annulus) and PSD steps do better.
const TR_MAX_SHIFT: f64 = 1e-2;

/// Calls [`Objective::begin_iteration`] and applies its contract: re-analyses a changed
/// Hessian pattern, re-evaluates f and ∇f at `x` and replaces the iterate's recorded residual
/// and value when anything changed, and drops the factor kept for reuse. Returns whether
/// anything changed (the caller then drops its watchdog point).
fn begin_iteration<O: Objective + ?Sized>(
    objective: &mut O,
    x: &[f64],
    iteration: usize,
    settings: &NewtonSettings,
    ws: &mut NewtonWorkspace,
    f: &mut f64,
    rec: &mut Record,
) -> Result<bool, SolverError> {
    let update = objective.begin_iteration(x, iteration)?;
    if update.pattern_changed {
        let mut fresh = NewtonWorkspace::new(objective, settings)?;
        fresh.mu = ws.mu;
        fresh.progress = ws.progress.take();
        fresh.cancel = ws.cancel.take();
        *ws = fresh;
    }
    if !(update.value_changed || update.pattern_changed) {
        return Ok(false);
    }
    ws.reusable = None;
    let t = Instant::now();
    *f = objective.gradient(x, &mut ws.g)?;
    rec.timings.assembly += t.elapsed();
    check_finite(*f, &ws.g, iteration)?;
    let residual = norm_inf(&ws.g) / objective.force_scale();
    if let (Some(r), Some(v)) = (rec.residuals.last_mut(), rec.values.last_mut()) {
        *r = residual;
        *v = *f;
    }
    Ok(true)
}

/// The objective's step limit for `dx` from `x` (see [`Objective::max_step`]), checked.
fn step_limit_of<O: Objective + ?Sized>(
    objective: &mut O,
    x: &[f64],
    dx: &[f64],
) -> Result<f64, SolverError> {
    let alpha = objective.max_step(x, dx)?;
    if !(alpha.is_finite() && alpha > 0.0 && alpha <= 1.0) {
        return Err(SolverError::InvalidSetting {
            name: "Objective::max_step",
            value: alpha,
            requirement: "the objective's step limit must lie in (0, 1]",
        });
    }
    Ok(alpha)
}

/// The step-convergence limit at `x`: the absolute one, or the relative one of
/// [`NewtonSettings::relative_step_tolerance`] when that is larger.
fn current_step_limit(
    absolute: f64,
    settings: &NewtonSettings,
    x: &[f64],
    x0: Option<&[f64]>,
) -> f64 {
    match x0 {
        Some(x0) => {
            let moved = x
                .iter()
                .zip(x0)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            absolute.max(settings.relative_step_tolerance * moved)
        }
        None => absolute,
    }
}

/// The direction of a trust-region step on the own Hessian in `ws` (assembled at the iterate):
/// `ws.dx = −(H + σS)⁻¹∇f` with σ ≤ [`TR_MAX_SHIFT`]. With `sigma0 = None` (the own Hessian
/// was just found indefinite) the smallest usable σ is estimated: `H + TR_MAX_SHIFT·S` is
/// factorised, inverse iteration on it estimates the most negative eigenvalue λ of `(H, S)`,
/// and σ = max(2|λ|, 4·SMALL_SHIFT) is tried; with `Some(σ₀)` (memory of earlier steps) the
/// search starts at σ₀. Failed attempts multiply σ by 4. `None`: the own Hessian needs more
/// than `TR_MAX_SHIFT` (strongly indefinite: far from a minimum, where PSD steps do better).
fn shifted_direction(
    ws: &mut NewtonWorkspace,
    sigma0: Option<f64>,
    rec: &mut Record,
) -> Result<Option<(FactorOutcome, bool)>, SolverError> {
    ws.reusable = None;
    let Some(cholesky) = ws.cholesky.as_mut() else {
        return Ok(None);
    };
    curvature::scaling(&ws.hessian, &ws.diag_offsets, &mut ws.scale);
    let t = Instant::now();
    let mut attempts = 0;
    let start = match sigma0 {
        Some(s) => s,
        None => {
            let probe = curvature::probe_shift(
                cholesky,
                &mut ws.hessian,
                &ws.diag_offsets,
                &ws.scale,
                SHIFT_GROWTH * SMALL_SHIFT,
                TR_MAX_SHIFT,
            )?;
            rec.factorizations += probe.attempts;
            match probe.shift {
                Some(s) => s,
                None => {
                    rec.timings.factorization += t.elapsed();
                    return Ok(None);
                }
            }
        }
    };
    let mut sigma = start.max(SHIFT_GROWTH * SMALL_SHIFT);
    let found = loop {
        if sigma > TR_MAX_SHIFT * (1.0 + 1e-12) {
            break None;
        }
        attempts += 1;
        rec.factorizations += 1;
        if curvature::factorize_shifted(
            cholesky,
            &mut ws.hessian,
            &ws.diag_offsets,
            &ws.scale,
            sigma,
        )? {
            break Some(sigma);
        }
        sigma *= SHIFT_GROWTH;
    };
    rec.timings.factorization += t.elapsed();
    let Some(sigma) = found else {
        return Ok(None);
    };
    for (d, g) in ws.dx.iter_mut().zip(&ws.g) {
        *d = -g;
    }
    let t = Instant::now();
    cholesky.solve_in_place(&mut ws.dx)?;
    rec.timings.solve += t.elapsed();
    let max_shift = sigma * ws.scale.iter().fold(0.0f64, |m, &s| m.max(s));
    Ok(Some((
        FactorOutcome {
            mu: sigma,
            max_shift,
            attempts,
        },
        true,
    )))
}

/// What [`saddle_newton`] did.
enum SaddleStep {
    /// The unshifted Newton correction is below the step tolerance: x is converged.
    Converged,
    /// The step was taken to `ws.x_trial` (value returned, gradient in `ws.g_trial`).
    Taken(f64),
    /// No usable step (singular Hessian, or the step did not reduce the gradient).
    Unavailable,
}

/// The unshifted Newton step `dx = −H⁻¹∇f` of the own Hessian in `ws` (assembled at x,
/// indefinite) by a sparse LDLᵀ factorisation: near a critical point whose Hessian is
/// indefinite (a saddle that could not be left, or that the caller keeps) Newton converges to it
/// quadratically, where trust-region steps only creep. The step is taken when it reduces the
/// gradient and raises f by no more than its round-off resolves.
fn saddle_newton<O: Objective + ?Sized>(
    objective: &mut O,
    x: &[f64],
    f: f64,
    ws: &mut NewtonWorkspace,
    rec: &mut Record,
    step_limit: f64,
) -> Result<SaddleStep, SolverError> {
    if ws.cholesky.is_none() {
        return Ok(SaddleStep::Unavailable);
    }
    if ws.ldlt.is_none() {
        let par = if ws.parallel { Par::rayon(0) } else { Par::Seq };
        match SparseLdlt::new(ws.hessian.symbolic(), ws.ordering, par) {
            Ok(l) => ws.ldlt = Some(l),
            Err(_) => return Ok(SaddleStep::Unavailable),
        }
    }
    let Some(ldlt) = ws.ldlt.as_mut() else {
        return Ok(SaddleStep::Unavailable);
    };
    let t = Instant::now();
    let factored = ldlt.factorize(ws.hessian.as_ref());
    rec.timings.factorization += t.elapsed();
    rec.factorizations += 1;
    if factored.is_err() {
        return Ok(SaddleStep::Unavailable);
    }
    for (d, g) in ws.dx.iter_mut().zip(&ws.g) {
        *d = -g;
    }
    let t = Instant::now();
    ldlt.solve_in_place(&mut ws.dx)?;
    rec.timings.solve += t.elapsed();
    if first_non_finite(&ws.dx).is_some() {
        return Ok(SaddleStep::Unavailable);
    }
    let dx_max = norm_inf(&ws.dx);
    if dx_max <= step_limit {
        rec.corrections.push(dx_max / objective.length_scale());
        return Ok(SaddleStep::Converged);
    }
    for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x).zip(&ws.dx) {
        *xt = xi + d;
    }
    let t = Instant::now();
    let f_t = objective.gradient(&ws.x_trial, &mut ws.g_trial)?;
    rec.timings.assembly += t.elapsed();
    let resolvable = WATCHDOG_MIN_DECREASE * rec.noise(f);
    if f_t.is_finite()
        && f_t <= f + resolvable
        && first_non_finite(&ws.g_trial).is_none()
        && norm_inf(&ws.g_trial) < norm_inf(&ws.g)
    {
        Ok(SaddleStep::Taken(f_t))
    } else {
        Ok(SaddleStep::Unavailable)
    }
}

/// Leaves a point where the own Hessian is indefinite along its most negative curvature
/// direction (inverse iteration on the factor of `H + σS` with σ just above the shift that
/// makes it positive definite), with the step length that most decreases f along it
/// (doubling from 10⁻³ of the body's size, or quartering until f decreases). Returns the new
/// value when it moved (x, `ws.g` updated, the step recorded as an iteration); `None` when
/// the own Hessian is positive definite to [`SMALL_SHIFT`] of each unknown's stiffness, or no
/// decrease was found.
#[allow(clippy::too_many_arguments)]
fn escape_saddle<O: Objective + ?Sized>(
    objective: &mut O,
    x: &mut [f64],
    f: f64,
    ws: &mut NewtonWorkspace,
    rec: &mut Record,
    length_scale: f64,
    force_scale: f64,
    sigma: &mut f64,
    iteration: &mut usize,
    started: Instant,
    known_indefinite: bool,
) -> Result<Option<f64>, SolverError> {
    if ws.cholesky.is_none() {
        return Ok(None);
    }
    if !known_indefinite {
        assemble(
            objective,
            x,
            &mut ws.hessian,
            false,
            *iteration,
            &mut rec.timings,
        )?;
    }
    ws.reusable = None;
    curvature::scaling(&ws.hessian, &ws.diag_offsets, &mut ws.scale);
    let Some(cholesky) = ws.cholesky.as_mut() else {
        return Ok(None);
    };
    let t = Instant::now();
    if !known_indefinite {
        rec.factorizations += 1;
        if curvature::factorize_shifted(
            cholesky,
            &mut ws.hessian,
            &ws.diag_offsets,
            &ws.scale,
            SMALL_SHIFT,
        )? {
            rec.timings.factorization += t.elapsed();
            return Ok(None);
        }
    }
    // A mildly indefinite Hessian met during the solve (capped at the trust-region limit:
    // beyond it PSD steps do better), or any indefinite one at a converged point.
    let cap = if known_indefinite {
        TR_MAX_SHIFT
    } else {
        ESCAPE_MAX_SHIFT
    };
    let probe = curvature::probe_shift(
        cholesky,
        &mut ws.hessian,
        &ws.diag_offsets,
        &ws.scale,
        sigma.max(SHIFT_GROWTH * SMALL_SHIFT),
        cap,
    )?;
    rec.timings.factorization += t.elapsed();
    rec.factorizations += probe.attempts;
    let Some(shift) = probe.shift else {
        return Ok(None);
    };
    let t = Instant::now();
    let pair = curvature::inverse_iteration(cholesky, &ws.hessian, &ws.scale, &[], 30)?;
    rec.timings.solve += t.elapsed();
    if pair.value.is_nan() || pair.value >= 0.0 {
        return Ok(None);
    }
    let mut v = pair.vector;
    if v.iter().zip(&ws.g).map(|(a, b)| a * b).sum::<f64>() > 0.0 {
        v.iter_mut().for_each(|a| *a = -*a);
    }
    // Steps t·v with ‖v‖∞ = 1: at most the body's size, and within the objective's limit.
    let t_max = length_scale
        * step_limit_of(
            objective,
            x,
            &v.iter().map(|a| a * length_scale).collect::<Vec<_>>(),
        )?;
    let mut value_at =
        |t: f64, ws: &mut NewtonWorkspace, rec: &mut Record| -> Result<f64, SolverError> {
            for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x.iter()).zip(&v) {
                *xt = xi + t * d;
            }
            let s = Instant::now();
            let val = objective.value(&ws.x_trial)?;
            rec.timings.line_search += s.elapsed();
            rec.timings.line_search_evaluations += 1;
            Ok(if val.is_finite() { val } else { f64::INFINITY })
        };
    let noise = rec.noise(f);
    let mut t = (1e-3 * length_scale).min(t_max);
    let mut best = (0.0, f);
    let ft = value_at(t, ws, rec)?;
    if ft < f - noise {
        best = (t, ft);
        while 2.0 * t <= t_max {
            let f2 = value_at(2.0 * t, ws, rec)?;
            if f2 < best.1 {
                t *= 2.0;
                best = (t, f2);
            } else {
                break;
            }
        }
    } else {
        for _ in 0..30 {
            t *= 0.25;
            let f2 = value_at(t, ws, rec)?;
            if f2 < f - noise {
                best = (t, f2);
                break;
            }
        }
    }
    if best.0 == 0.0 {
        return Ok(None);
    }
    for (xi, d) in x.iter_mut().zip(&v) {
        *xi += best.0 * d;
    }
    let s = Instant::now();
    let f_new = objective.gradient(x, &mut ws.g)?;
    rec.timings.assembly += s.elapsed();
    check_finite(f_new, &ws.g, *iteration + 1)?;
    *iteration += 1;
    *sigma = shift;
    rec.hessians.push(IterationHessian::NegativeCurvature);
    rec.residuals.push(norm_inf(&ws.g) / force_scale);
    rec.values.push(f_new);
    if let Some(hook) = &ws.progress {
        hook(&NewtonProgress {
            iteration: *iteration,
            residual: norm_inf(&ws.g) / force_scale,
            step_length: best.0 / length_scale,
            hessian: IterationHessian::NegativeCurvature,
            regularized: true,
            elapsed: started.elapsed(),
        });
    }
    Ok(Some(f_new))
}
