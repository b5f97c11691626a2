//! What a Newton solve reports ([`NewtonReport`], [`Convergence`], timings) and the record it keeps
//! while it runs.

use std::time::Duration;

use super::settings::{IterationHessian, LinearSolver};

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

/// Iterations of a successful solve that did not step with the exact Hessian (its
/// Gauss–Newton, shifted or negative-curvature steps) from which it counts as having wandered
/// ([`NewtonReport::wandered`]). A solve from inside the basin of its minimum needs none or a
/// few; for the thick cone of `solver/tests/conformal_cone.rs` round-off decides between a
/// failure and 55 Gauss–Newton steps into a stable minimum 50 % out of round with 22 % more
/// energy than the round cone the rest-state continuation finds.
pub const WANDERING_STEPS: usize = 10;

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
    /// ([`NewtonSettings::reuse_factor`](super::NewtonSettings::reuse_factor)).
    pub reused_steps: usize,
    /// Directions solved with the factor of a slightly shifted Hessian (the objective's
    /// [`Objective::hessian_diagonal_shift`](crate::Objective::hessian_diagonal_shift) or a
    /// regularisation of at most 1e-8 of the mean diagonal) and refined by CG into those of the
    /// unshifted Hessian.
    pub refined_steps: usize,
    /// Accepted steps of the own Hessian along which CG had met negative curvature, taken
    /// beyond the full Newton step (doubled while f kept decreasing by more than its
    /// round-off): leaving a saddle or an indefinite region geometrically fast instead of by
    /// the factor σ/(σ − |λ|) per iteration that the slightly shifted factor allows.
    pub extrapolated_steps: usize,
    /// Largest difference seen between [`Objective::value`](crate::Objective::value) and
    /// [`Objective::gradient`](crate::Objective::gradient)'s value at the same point (units of f; 0
    /// when never compared): the evaluation round-off of f, far above `16 ε |f|` for shells whose
    /// strains are small against 1. The round-off tests use the larger of the two, and so does
    /// [`NewtonReport::descent_violation`].
    pub value_noise: f64,
    /// CG iterations over the whole solve (reuse, refinement and fallback).
    pub cg_iterations: usize,
    /// Direct, or the iterative fallback (the factor did not fit in memory).
    pub linear_solver: LinearSolver,
}

impl NewtonReport {
    /// This solve, then a step along negative curvature away from where it ended (a saddle;
    /// one [`IterationHessian::NegativeCurvature`] iteration), then the solve `next` from
    /// there: one report with every count summed and the records joined in order.
    pub(crate) fn then_escape(mut self, next: NewtonReport) -> NewtonReport {
        let offset = self.iterations + 1;
        self.iterations = offset + next.iterations;
        self.hessians.push(IterationHessian::NegativeCurvature);
        self.hessians.extend(next.hessians);
        self.corrections.extend(next.corrections);
        self.failed_factorizations += next.failed_factorizations;
        self.rejected_steps += next.rejected_steps;
        self.watchdog_steps += next.watchdog_steps;
        self.watchdog_returns += next.watchdog_returns;
        self.watchdog_undone += next.watchdog_undone;
        self.convergence = next.convergence;
        self.residuals.extend(next.residuals);
        self.values.extend(next.values);
        self.backtracks += next.backtracks;
        self.regularizations
            .extend(
                next.regularizations
                    .into_iter()
                    .map(|e| RegularizationEvent {
                        iteration: e.iteration + offset,
                        ..e
                    }),
            );
        let (a, b) = (&mut self.timings, next.timings);
        a.assembly += b.assembly;
        a.factorization += b.factorization;
        a.solve += b.solve;
        a.line_search += b.line_search;
        a.line_search_evaluations += b.line_search_evaluations;
        self.factorizations += next.factorizations;
        self.reused_steps += next.reused_steps;
        self.refined_steps += next.refined_steps;
        self.extrapolated_steps += next.extrapolated_steps;
        self.value_noise = self.value_noise.max(next.value_noise);
        self.cg_iterations += next.cg_iterations;
        self.linear_solver = next.linear_solver;
        self
    }

    /// Accepted iterations that used Hessian (or step) `kind`.
    pub fn count(&self, kind: IterationHessian) -> usize {
        self.hessians.iter().filter(|h| **h == kind).count()
    }

    /// Whether this (successful) solve took at least [`WANDERING_STEPS`] steps without the
    /// exact Hessian: it crossed strongly indefinite regions, so which minimum it reached was
    /// decided by its path ([`Static::continuation`](crate::Static::continuation) then checks
    /// it).
    pub fn wandered(&self) -> bool {
        self.iterations
            .saturating_sub(self.count(IterationHessian::Own))
            >= WANDERING_STEPS
    }

    /// Every iteration the solve paid for, the one count
    /// [`NewtonSettings::max_iterations`](super::NewtonSettings::max_iterations) limits: accepted
    /// ones, rejected steps and iterations undone by the watchdog.
    pub fn total_iterations(&self) -> usize {
        self.iterations + self.rejected_steps + self.watchdog_undone
    }

    /// Checks the line search's contract on [`values`](Self::values): f never rises, except
    /// after a watchdog step ([`NewtonSettings::watchdog`](super::NewtonSettings::watchdog) =
    /// `window`), and then an iterate at most `window + 1` iterations later is back at or below the
    /// value before the rise (the iterate after a return to the point before the step is); the last
    /// value is not above the first. Comparisons allow 64 ε of round-off. Returns the index of the
    /// first value that breaks the contract.
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

/// Everything a solve has recorded so far, turned into a report.
pub(super) struct Record {
    pub(super) residuals: Vec<f64>,
    pub(super) values: Vec<f64>,
    pub(super) hessians: Vec<IterationHessian>,
    pub(super) corrections: Vec<f64>,
    pub(super) failed_factorizations: usize,
    pub(super) rejected_steps: usize,
    pub(super) watchdog_steps: usize,
    pub(super) watchdog_returns: usize,
    pub(super) watchdog_undone: usize,
    pub(super) backtracks: usize,
    pub(super) regularizations: Vec<RegularizationEvent>,
    pub(super) timings: NewtonTimings,
    pub(super) factorizations: usize,
    pub(super) reused_steps: usize,
    pub(super) refined_steps: usize,
    pub(super) extrapolated_steps: usize,
    pub(super) cg_iterations: usize,
    pub(super) linear_solver: LinearSolver,
    pub(super) value_noise: f64,
}

impl Record {
    pub(super) fn new(linear_solver: LinearSolver) -> Self {
        Self {
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
            extrapolated_steps: 0,
            value_noise: 0.0,
            cg_iterations: 0,
            linear_solver,
        }
    }

    /// Round-off of an objective value f: `16 ε |f|`, or the evaluation noise seen so far.
    pub(super) fn noise(&self, f: f64) -> f64 {
        value_noise(f).max(self.value_noise)
    }

    pub(super) fn report(self, iterations: usize, convergence: Convergence) -> NewtonReport {
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
            extrapolated_steps: self.extrapolated_steps,
            value_noise: self.value_noise,
            cg_iterations: self.cg_iterations,
            linear_solver: self.linear_solver,
        }
    }
}

/// Round-off of an objective value f: changes below it are invisible.
pub(super) fn value_noise(f: f64) -> f64 {
    16.0 * f64::EPSILON * f.abs()
}
