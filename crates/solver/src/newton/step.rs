//! Taking a step along the Newton direction: the backtracking line search with its watchdog,
//! and the ratio test of trust-region (shifted) steps.

use std::time::Instant;

use super::checks::{first_non_finite, norm_inf};
use super::escape::{SaddleStep, extrapolate, saddle_newton};
use super::policy::{Policy, TR_ACCEPT};
use super::report::Convergence;
use super::settings::{IterationHessian, NewtonSettings};
use super::solve::{Solve, WATCHDOG_MIN_DECREASE};
use crate::SolverError;
use crate::iterative::sym_lower_matvec;
use crate::objective::Objective;

/// The point before a watchdog step (see [`NewtonSettings::watchdog`]).
pub(super) struct Watch {
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

/// The watchdog of one solve: the point before a non-monotone full step, and whether the next
/// iteration may take one (not right after a return to such a point).
pub(super) struct Watchdog {
    watch: Option<Watch>,
    allowed: bool,
}

impl Watchdog {
    pub(super) fn new() -> Self {
        Self {
            watch: None,
            allowed: true,
        }
    }

    /// Whether a watched step is pending (its point is not yet known to be good).
    pub(super) fn watching(&self) -> bool {
        self.watch.is_some()
    }

    /// Forgets the watched point (the objective changed under it).
    pub(super) fn forget(&mut self) {
        self.watch = None;
    }

    /// Puts the best point back into `x` before the solve ends without converging: the one
    /// before a watched step (the record is cut back to it).
    pub(super) fn restore_best<O: ?Sized>(&mut self, s: &mut Solve<'_, O>) {
        if let Some(w) = self.watch.take() {
            s.x.copy_from_slice(&w.x);
            s.rec.residuals.truncate(w.len);
        }
    }

    /// Whether the step just accepted was the watched one (call before [`Self::after_step`]).
    pub(super) fn just_watched(&self, settings: &NewtonSettings) -> bool {
        matches!(&self.watch, Some(w) if w.left == settings.watchdog)
    }

    /// After an accepted iterate with value `f`: ends the watch when f came below the watched
    /// step's bound, or returns to the point before it when the watched iterates never
    /// recovered (then `true`: x, `ws.g`, f, the iteration count and the record are set back,
    /// and the caller goes on from there).
    pub(super) fn after_step<O: ?Sized>(&mut self, s: &mut Solve<'_, O>) -> bool {
        self.allowed = true;
        let Some(w) = self.watch.as_mut() else {
            return false;
        };
        if s.f <= w.bound {
            self.watch = None;
        } else if w.left == 0 {
            // The watched iterates never recovered: back to the point before the
            // non-monotone step, which the next iteration leaves by the usual line search.
            let rec = &mut s.rec;
            s.x.copy_from_slice(&w.x);
            s.ws.g.copy_from_slice(&w.g);
            s.f = w.f;
            rec.watchdog_returns += 1;
            // The undone iterations leave the record (the record is the accepted path);
            // they still count against the iteration limit.
            rec.watchdog_undone += s.iteration - (w.len - 1);
            s.iteration = w.len - 1;
            let iteration = s.iteration;
            rec.values.truncate(w.len);
            rec.residuals.truncate(w.len);
            rec.hessians.truncate(iteration);
            rec.regularizations.retain(|e| e.iteration < iteration);
            self.watch = None;
            self.allowed = false;
            return true;
        } else {
            w.left -= 1;
        }
        false
    }
}

/// What trying a step along `ws.dx` gave.
pub(super) enum Step {
    /// A trial point to accept: `ws.x_trial`, its value, the step length taken, the
    /// backtracks, whether `ws.g_trial` holds its gradient, the trust-region ratio (shifted
    /// steps; NaN otherwise) and the Hessian the step came from.
    Taken {
        f: f64,
        alpha: f64,
        backtracks: usize,
        has_gradient: bool,
        rho: f64,
        kind: IterationHessian,
    },
    /// No step: the iteration is redone at the same x (the policy has changed).
    Retry,
    /// x moved along negative curvature (the solve's value and gradient are the new point's).
    Escaped,
    /// x is converged.
    Converged(Convergence),
}

/// What the step needs to know of the direction in `ws.dx`.
pub(super) struct Direction {
    /// The Hessian it was solved with.
    pub(super) kind: IterationHessian,
    /// `∇fᵀdx`.
    pub(super) slope: f64,
    /// Whether it may stand for the unshifted Newton correction.
    pub(super) unshifted: bool,
    /// Whether CG met negative curvature of the unshifted own Hessian while refining it.
    pub(super) negative_curvature: bool,
    /// The step-convergence limit at x (m).
    pub(super) step_limit: f64,
}

/// A trust-region step along the shifted direction in `ws.dx` of length `alpha` (the
/// objective's limit): taken in full when its actual decrease is at least [`TR_ACCEPT`] of the
/// decrease the exact quadratic model predicts, otherwise redone with a larger shift. Where the
/// model promises nothing f can resolve, x is near a critical point of an indefinite Hessian:
/// it is left along negative curvature, or the unshifted Newton step converges to it.
pub(super) fn trust_region_step<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    policy: &mut Policy,
    d: &Direction,
    alpha: f64,
) -> Result<Step, SolverError> {
    let ws = &mut *s.ws;
    sym_lower_matvec(ws.hessian.as_ref(), 0.0, &ws.dx, &mut ws.hd);
    let dhd: f64 = ws.dx.iter().zip(&ws.hd).map(|(a, b)| a * b).sum();
    let pred = -(alpha * d.slope + 0.5 * alpha * alpha * dhd);
    // (NaN included: no usable prediction.)
    if pred.is_nan() || pred <= WATCHDOG_MIN_DECREASE * s.rec.noise(s.f) {
        if policy.leave_saddle(s, false)? {
            return Ok(Step::Escaped);
        }
        // No lower point that way (or saddles are answers here): the unshifted Newton step,
        // which converges to the critical point quadratically, and whose length is the
        // convergence test.
        return Ok(match saddle_newton(s, d.step_limit)? {
            SaddleStep::Converged => Step::Converged(Convergence::Step),
            SaddleStep::Taken(f_t) => {
                policy.shifted_accepted();
                Step::Taken {
                    f: f_t,
                    alpha: 1.0,
                    backtracks: 0,
                    has_gradient: true,
                    rho: f64::NAN,
                    kind: IterationHessian::Own,
                }
            }
            SaddleStep::Unavailable => {
                // Let the PSD Hessian (and then the convergence tests) decide.
                s.rec.rejected_steps += 1;
                policy.psd_instead();
                Step::Retry
            }
        });
    }
    let ws = &mut *s.ws;
    for ((xt, &xi), &dx) in ws.x_trial.iter_mut().zip(s.x.iter()).zip(&ws.dx) {
        *xt = xi + alpha * dx;
    }
    let t = Instant::now();
    let f_t = s.objective.gradient(&ws.x_trial, &mut ws.g_trial)?;
    s.rec.timings.assembly += t.elapsed();
    let rho = (s.f - f_t) / pred;
    if !(f_t.is_finite() && rho >= TR_ACCEPT && first_non_finite(&ws.g_trial).is_none()) {
        s.rec.rejected_steps += 1;
        policy.shifted_rejected(s.frame.settings.line_search);
        return Ok(Step::Retry);
    }
    policy.shifted_accepted();
    Ok(Step::Taken {
        f: f_t,
        alpha,
        backtracks: 0,
        has_gradient: true,
        rho,
        kind: IterationHessian::Shifted,
    })
}

/// Backtracking line search along `ws.dx` from length `alpha` (the objective's limit). The
/// first trial evaluates the gradient too (it is usually accepted); later trials only the
/// value. A full step that fails the Armijo test is taken anyway as a watchdog step where the
/// settings allow; a full step of the own Hessian that fails it is rejected (the iteration is
/// redone with the PSD Hessian).
pub(super) fn line_search<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    policy: &mut Policy,
    watchdog: &mut Watchdog,
    d: &Direction,
    mut alpha: f64,
) -> Result<Step, SolverError> {
    let settings = s.frame.settings;
    let (f, iteration) = (s.f, s.iteration);
    let slope = d.slope;
    let mut backtracks = 0;
    let mut has_gradient;
    let f_trial = loop {
        for ((xt, &xi), &dx) in s.ws.x_trial.iter_mut().zip(s.x.iter()).zip(&s.ws.dx) {
            *xt = xi + alpha * dx;
        }
        let t = Instant::now();
        let f_t = if backtracks == 0 {
            has_gradient = true;
            let f_t = s.objective.gradient(&s.ws.x_trial, &mut s.ws.g_trial)?;
            s.rec.timings.assembly += t.elapsed();
            f_t
        } else {
            has_gradient = false;
            let f_t = s.objective.value(&s.ws.x_trial)?;
            s.rec.timings.line_search += t.elapsed();
            s.rec.timings.line_search_evaluations += 1;
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
                if d.negative_curvature && backtracks == 0 && policy.escapes_saddles() {
                    if let Some((a, fa)) = extrapolate(s, alpha, f_t)? {
                        alpha = a;
                        has_gradient = false;
                        s.rec.extrapolated_steps += 1;
                        break fa;
                    }
                }
                break f_t;
            }
            // Once the predicted decrease is below the round-off of f, values cannot
            // discriminate: accept a full step that does not raise f beyond round-off and
            // reduces the gradient.
            let noise = s.rec.noise(f.abs().max(f_t.abs()));
            if has_gradient
                && -slope <= noise
                && f_t <= f + noise
                && norm_inf(&s.ws.g_trial) < norm_inf(&s.ws.g)
            {
                break f_t;
            }
        }
        if backtracks == 0
            && settings.watchdog > 0
            && watchdog.watch.is_none()
            && watchdog.allowed
            && -slope > WATCHDOG_MIN_DECREASE * s.rec.noise(f)
            && f_t.is_finite()
            && first_non_finite(&s.ws.g_trial).is_none()
        {
            // Watchdog: take the full Newton step although f rose. A thin shell bending away
            // from flat is the typical case: the full step bends it with the right curvature
            // but stretches its membrane (which the linearisation cannot see), and the next
            // Newton step relaxes the membrane; a monotone line search would instead crawl
            // along the bending mode with tiny steps.
            watchdog.watch = Some(Watch {
                x: s.x.to_vec(),
                g: s.ws.g.clone(),
                f,
                bound: f + settings.armijo_c1 * slope,
                len: s.rec.values.len(),
                left: settings.watchdog,
            });
            s.rec.watchdog_steps += 1;
            break f_t;
        }
        if backtracks == 0
            && watchdog.watch.is_none()
            && d.unshifted
            && -0.5 * slope <= s.rec.noise(f)
        {
            // The unshifted Newton step predicts a decrease below the round-off of f and its
            // full step is not distinguishable from x: x is at the round-off floor (typically
            // a solve restarted at its own equilibrium), not stuck.
            return Ok(Step::Converged(Convergence::RoundOff));
        }
        if policy.adaptive && d.kind == IterationHessian::Own {
            // The own Hessian's quadratic model does not hold here (its full step fails the
            // Armijo test): redo the iteration with the PSD Hessian rather than take a short
            // step along a direction that may lead towards a saddle or a poor minimum.
            s.rec.backtracks += backtracks;
            s.rec.rejected_steps += 1;
            policy.own_failed();
            return Ok(Step::Retry);
        }
        if backtracks >= settings.max_backtracks || slope >= 0.0 {
            watchdog.restore_best(s);
            return Err(SolverError::LineSearchFailed {
                iteration,
                backtracks,
                residuals: std::mem::take(&mut s.rec.residuals),
                last_good: s.x.to_vec(),
            });
        }
        backtracks += 1;
        alpha *= settings.backtrack_factor;
    };
    s.rec.backtracks += backtracks;
    Ok(Step::Taken {
        f: f_trial,
        alpha,
        backtracks,
        has_gradient,
        rho: f64::NAN,
        kind: d.kind,
    })
}
