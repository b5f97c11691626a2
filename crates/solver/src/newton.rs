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
//! the membrane; a monotone line search instead cuts every such step to a sliver (measured in
//! `docs/robustness.md`, "The default Newton").
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
//! **Indefinite own Hessians near critical points** ([`HessianPolicy::Adaptive`] with a direct
//! solver; the cases and their iteration counts are in `docs/robustness.md`, "Indefinite
//! Hessians near critical points"): PSD steps converge only linearly towards a point where the own
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
//! [`HessianPolicy::AdaptivePsd`] leaves indefinite own Hessians to PSD steps, for comparison.
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
//!
//! **Layout.** This file holds the iteration itself ([`newton_solve`]: checks, the choice of
//! direction, the convergence tests, accepting a step); `policy.rs` the adaptive policy's
//! state and rules, `step.rs` the line search with its watchdog and the trust-region ratio
//! test, `direction.rs` how a direction is solved for (factorisation, reuse, CG refinement, the
//! trust-region shift), `escape.rs` the steps along negative curvature, `settings.rs` the
//! settings, `report.rs` the report and the record kept while solving, `workspace.rs` the
//! reusable workspace and the stability analysis, `kept.rs` the factor kept for reuse,
//! `solve.rs` the state of one solve in progress that these phases share (objective, iterate,
//! record, fixed settings), `checks.rs` the checks they apply to what the objective returns.

use std::time::Instant;

use crate::SolverError;
use crate::linear::{FactorError, FactorOutcome, RegularizationParams};
use crate::objective::Objective;
use crate::progress::NewtonProgress;

mod adjoint;
mod checks;
mod direction;
mod escape;
mod kept;
mod policy;
mod report;
mod settings;
mod solve;
mod step;
mod workspace;

pub use kept::KeptFactor;
pub use report::*;
pub use settings::*;
pub use workspace::*;

use checks::{assemble, check_finite, first_non_finite, norm_inf};
use direction::{
    ESTIMATE_TOLERANCE, REFINE_TOLERANCE, apply_damping, estimate_correction, forcing,
    refine_direction, shifted_direction, small_shift_attempts, solve_direction, try_reuse,
};
use policy::Policy;
use report::Record;
use solve::{Frame, SMALL_SHIFT, Solve};
use step::{Direction, Step, Watchdog, line_search, trust_region_step};

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
    if settings.regularization.is_none() {
        // A shift remembered from an earlier solve must not leak into an unregularised one.
        ws.mu = 0.0;
    }
    let mu_at_start = ws.mu;
    ws.kept.begin_solve(ws.reusable);
    let mut rec = Record::new(ws.linear_solver());

    let t = Instant::now();
    let f = objective.gradient(x, &mut ws.g)?;
    rec.timings.assembly += t.elapsed();
    check_finite(f, &ws.g, 0)?;
    rec.residuals.push(norm_inf(&ws.g) / force_scale);
    rec.values.push(f);
    let frame = Frame {
        settings,
        length_scale,
        force_scale,
        gradient_test: objective.gradient_test(),
        reg_params: settings.regularization_params(),
        started,
        x_start: (settings.relative_step_tolerance > 0.0).then(|| x.to_vec()),
        g0: norm_inf(&ws.g),
    };
    let mut policy = Policy::new(settings, objective.has_psd_hessian(), ws.cholesky.is_some());
    let mut s = Solve {
        objective,
        x,
        f,
        ws,
        rec,
        frame,
        iteration: 0,
    };
    let mut watchdog = Watchdog::new();
    // A converged point: where an indefinite own Hessian was met on the way, first make sure
    // it is not a saddle (leave it along negative curvature and go on if it is).
    macro_rules! converged {
        ($c:expr) => {{
            if policy.met_indefinite && policy.leave_saddle(&mut s, false)? {
                continue;
            }
            return Ok(s.rec.report(s.iteration, $c));
        }};
    }

    loop {
        // The objective's own update at this iterate (`Objective::begin_iteration`).
        if begin_iteration(&mut s)? {
            watchdog.forget();
        }
        if !watchdog.watching()
            && s.frame.gradient_test
            && s.rec.residuals[s.rec.residuals.len() - 1] <= settings.gradient_tolerance
        {
            converged!(Convergence::Gradient);
        }
        if s.ws
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::SeqCst))
        {
            watchdog.restore_best(&mut s);
            // A cancelled solve leaves the workspace's carried state as it found it, so that a
            // run resumed from the last completed step repeats this one exactly.
            s.ws.mu = mu_at_start;
            s.ws.reusable = s.ws.kept.cancel_solve();
            return Err(SolverError::Cancelled {
                iterations: s.iteration + s.rec.watchdog_undone,
                residuals: s.rec.residuals,
                last_good: s.x.to_vec(),
            });
        }
        if s.iteration + s.rec.watchdog_undone + s.rec.rejected_steps >= settings.max_iterations {
            // The failure carries the best point: the one before a watched step.
            watchdog.restore_best(&mut s);
            // The limit the correction was tested against, relative steps included.
            let limit = s.frame.step_limit(s.x);
            let step_tolerance = if limit > settings.step_tolerance * s.frame.length_scale {
                limit / s.frame.length_scale
            } else {
                settings.step_tolerance
            };
            return Err(SolverError::NewtonDidNotConverge {
                residuals: s.rec.residuals,
                iterations: s.iteration + s.rec.watchdog_undone + s.rec.rejected_steps,
                tolerance: settings.gradient_tolerance,
                last_correction: s.rec.corrections.last().copied(),
                step_tolerance,
                last_good: s.x.to_vec(),
            });
        }

        let chosen = match choose_direction(&mut s, &mut policy)? {
            Choice::Direction(c) => c,
            Choice::Escaped => continue,
        };
        let (kind, outcome) = (chosen.kind, chosen.outcome);
        if outcome.mu > 0.0 && kind != IterationHessian::Shifted {
            s.rec.regularizations.push(RegularizationEvent {
                iteration: s.iteration,
                mu: outcome.mu,
                max_shift: outcome.max_shift,
                attempts: outcome.attempts,
            });
        }
        // A direction that may stand for the unshifted Newton correction in the tests below:
        // one solved with a slightly shifted factor is refined into it first.
        let unshifted = outcome.mu <= SMALL_SHIFT && chosen.exact;
        let obj_shift = s.objective.hessian_diagonal_shift();
        // Own-Hessian directions only: on the PSD (Gauss–Newton) Hessian the small shift
        // damps the directions its model leaves flat (e.g. folding a crease), which it sees no
        // cost for; solved without it, those steps run far beyond where the model holds.
        // Whether the unshifted own Hessian showed negative curvature along a CG direction: the
        // shifted direction then leads away from a saddle, and its step may be extrapolated.
        let mut negative_curvature = false;
        if unshifted
            && !chosen.reused
            && kind == IterationHessian::Own
            && (outcome.mu > 0.0 || obj_shift > 0.0)
        {
            negative_curvature = refine_direction(s.ws, obj_shift, REFINE_TOLERANCE, &mut s.rec)?;
        }

        let step_limit = s.frame.step_limit(s.x);
        if let Some(dof) = first_non_finite(&s.ws.dx) {
            return Err(SolverError::NonFinite {
                what: "Newton direction",
                iteration: s.iteration,
                dof: Some(dof),
            });
        }
        let slope: f64 = s.ws.dx.iter().zip(&s.ws.g).map(|(d, g)| d * g).sum();

        // An unshifted Newton correction below the step tolerance, or one whose predicted
        // decrease f cannot resolve: x is converged. The step is not taken.
        if unshifted && !watchdog.watching() {
            let dx_max = norm_inf(&s.ws.dx);
            s.rec.corrections.push(dx_max / length_scale);
            if dx_max <= step_limit {
                converged!(Convergence::Step);
            }
            // Round-off: f cannot resolve the predicted decrease and the last step no longer
            // halved the gradient (while it does, Newton still makes progress on it).
            let n = s.rec.residuals.len();
            if -0.5 * slope <= s.rec.noise(s.f)
                && n >= 2
                && s.rec.residuals[n - 1] > 0.5 * s.rec.residuals[n - 2]
            {
                converged!(Convergence::RoundOff);
            }
        }

        let alpha = s.max_step()?;
        let direction = Direction {
            kind,
            slope,
            unshifted,
            negative_curvature,
            step_limit,
        };
        let step = if kind == IterationHessian::Shifted {
            trust_region_step(&mut s, &mut policy, &direction, alpha)?
        } else {
            line_search(&mut s, &mut policy, &mut watchdog, &direction, alpha)?
        };
        let (f_trial, alpha, backtracks, has_gradient, rho, kind) = match step {
            Step::Taken {
                f,
                alpha,
                backtracks,
                has_gradient,
                rho,
                kind,
            } => (f, alpha, backtracks, has_gradient, rho, kind),
            Step::Retry | Step::Escaped => continue,
            Step::Converged(c) => converged!(c),
        };

        // Accept the trial point.
        let f_old = s.f;
        s.x.copy_from_slice(&s.ws.x_trial);
        if has_gradient {
            std::mem::swap(&mut s.ws.g, &mut s.ws.g_trial);
            s.f = f_trial;
        } else {
            let t = Instant::now();
            s.f = s.objective.gradient(s.x, &mut s.ws.g)?;
            s.rec.timings.assembly += t.elapsed();
            if s.f.is_finite() && f_trial.is_finite() {
                // Two evaluations of f at one point by different operations: their
                // difference shows its round-off.
                s.rec.value_noise = s.rec.value_noise.max((s.f - f_trial).abs());
            }
        }
        s.iteration += 1;
        s.rec.hessians.push(kind);
        check_finite(s.f, &s.ws.g, s.iteration)?;
        s.rec.residuals.push(norm_inf(&s.ws.g) / force_scale);
        s.rec.values.push(s.f);
        if let Some(hook) = &s.ws.progress {
            hook(&NewtonProgress {
                iteration: s.iteration,
                residual: norm_inf(&s.ws.g) / force_scale,
                step_length: alpha,
                hessian: kind,
                regularized: outcome.mu > 0.0,
                elapsed: started.elapsed(),
            });
        }
        let watched_step = watchdog.just_watched(settings);
        if watchdog.after_step(&mut s) {
            continue;
        }
        policy.after_step(kind, backtracks, rho, slope, (f_old, s.f), &s.rec.residuals);

        // After a full unshifted step, estimate the next correction with the same
        // factorisation (one triangular solve): a short one ends the solve here.
        if unshifted && backtracks == 0 && !watchdog.watching() && !watched_step {
            if s.frame.gradient_test
                && s.rec.residuals[s.rec.residuals.len() - 1] <= settings.gradient_tolerance
            {
                converged!(Convergence::Gradient);
            }
            let reused_or_shifted = chosen.reused || outcome.mu > 0.0 || obj_shift > 0.0;
            if let Some(est) = estimated_correction(&mut s, reused_or_shifted, obj_shift)? {
                s.rec.corrections.push(est / length_scale);
                converged!(Convergence::Step);
            }
        }
    }
}

/// After a full unshifted step, the next Newton correction estimated with the same
/// factorisation (one triangular solve), when it is within the step limit at the new iterate
/// `x` (m): the solve is then converged.
fn estimated_correction<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    reused_or_shifted: bool,
    obj_shift: f64,
) -> Result<Option<f64>, SolverError> {
    // The limit at the new iterate: a relative one grows with the move just made (the one of
    // the iteration's start, before any move, left the estimate unable to end an implicit
    // step, which then assembled one more Hessian only to stop there).
    let step_limit = s.frame.step_limit(s.x);
    let t = Instant::now();
    let solved = estimate_correction(s.ws, s.frame.settings, &mut s.rec)?;
    s.rec.timings.solve += t.elapsed();
    if solved && s.ws.cholesky.is_some() && norm_inf(&s.ws.dx) <= step_limit && reused_or_shifted {
        // A shifted (or old) factor underestimates the correction along soft modes (the
        // refined one is larger there): an estimate that would end the solve solves the
        // unshifted system where CG can.
        refine_direction(s.ws, obj_shift, ESTIMATE_TOLERANCE, &mut s.rec)?;
    }
    let est = if solved {
        norm_inf(&s.ws.dx)
    } else {
        f64::INFINITY
    };
    Ok((est.is_finite() && est <= step_limit).then_some(est))
}

/// How an iteration's direction `ws.dx` was found.
struct Chosen {
    /// The Hessian it was solved with.
    kind: IterationHessian,
    outcome: FactorOutcome,
    /// It solves the system to the forcing term (not truncated), so that an unshifted one may
    /// serve the convergence tests.
    exact: bool,
    /// Solved by CG preconditioned with the kept factor.
    reused: bool,
}

/// What [`choose_direction`] did.
enum Choice {
    Direction(Chosen),
    /// x moved along negative curvature instead (to a point whose value is now `f`).
    Escaped,
}

/// The Hessian, then the Newton direction `ws.dx = −H⁻¹∇f`: by CG preconditioned with the kept
/// factor (reuse), or by a (possibly shifted) factorisation, or by the iterative fallback —
/// with the Hessian the policy chooses (see the module documentation).
fn choose_direction<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    policy: &mut Policy,
) -> Result<Choice, SolverError> {
    let settings = s.frame.settings;
    let eta = forcing(settings.cg_forcing, norm_inf(&s.ws.g), s.frame.g0);
    let eta_reuse = forcing(settings.reuse_tolerance, norm_inf(&s.ws.g), s.frame.g0);
    let mut kind = assemble(
        s.objective,
        s.x,
        &mut s.ws.hessian,
        policy.adaptive && !policy.try_own,
        s.iteration,
        &mut s.rec.timings,
    )?;
    if kind == IterationHessian::Psd {
        apply_damping(s.ws, policy.damping);
    }
    let reuse_shift = s.objective.hessian_diagonal_shift();
    let mut reused = try_reuse(s.ws, kind, eta_reuse, reuse_shift, settings, &mut s.rec)?;
    let mut direction = reused.then(|| (FactorOutcome::default(), true));
    // Trust region: while the own Hessian is known to be indefinite, go straight to the
    // shifted search.
    let (shift_start, in_trust) = policy.trust_start();
    let own =
        |kind: IterationHessian, policy: &Policy| kind == IterationHessian::Own && policy.try_own;
    if direction.is_none() && in_trust && own(kind, policy) {
        if policy.want_escape {
            // The last shifted step was as good as the model (ρ > ¾) yet its length was set by
            // the shift that keeps H + σS positive definite, not by the model: move along the
            // negative curvature as far as f keeps decreasing.
            policy.want_escape = false;
            if policy.leave_saddle(s, true)? {
                return Ok(Choice::Escaped);
            }
        }
        direction = shifted_direction(s.ws, Some(shift_start), &mut s.rec)?;
        if let Some((o, _)) = direction {
            kind = IterationHessian::Shifted;
            policy.shifted(o.mu);
            policy.met_indefinite = true;
        }
    }
    if direction.is_none() && !in_trust && policy.adaptive && own(kind, policy) {
        // The own Hessian, shifted by at most SMALL_SHIFT (far below bending stiffness: it
        // only lifts the tiny negative eigenvalues of a nearly converged, slightly compressed
        // shell); anything more indefinite switches to the PSD Hessian.
        let small = RegularizationParams {
            max_attempts: small_shift_attempts(&s.frame.reg_params),
            ..s.frame.reg_params
        };
        match solve_direction(s.ws, kind, &small, eta, settings, &mut s.rec) {
            Ok(d) => direction = Some(d),
            Err(FactorError::NotPositiveDefinite { .. }) if policy.trust && policy.psd_stalled => {
                // Indefinite: a trust-region step on the shifted own Hessian.
                s.rec.failed_factorizations += 1;
                s.ws.mu = 0.0;
                policy.met_indefinite = true;
                // First leave along negative curvature (a saddle or an indefinite region is
                // near: shifted steps would only creep along that direction).
                if policy.leave_saddle(s, true)? {
                    return Ok(Choice::Escaped);
                }
                direction = shifted_direction(s.ws, None, &mut s.rec)?;
                if let Some((o, _)) = direction {
                    kind = IterationHessian::Shifted;
                    policy.shifted(o.mu);
                }
            }
            Err(FactorError::NotPositiveDefinite { .. }) => {
                s.rec.failed_factorizations += 1;
                policy.met_indefinite = true;
                s.ws.mu = 0.0;
                policy.own_failed();
                kind = assemble_psd(s, policy)?;
                reused = try_reuse(s.ws, kind, eta_reuse, reuse_shift, settings, &mut s.rec)?;
                direction = reused.then(|| (FactorOutcome::default(), true));
            }
            Err(FactorError::Other(e)) => return Err(e),
        }
    }
    if direction.is_none() && policy.trust && own(kind, policy) {
        // No shift the search tried made the own Hessian positive definite: the PSD one.
        policy.psd_instead();
        kind = assemble_psd(s, policy)?;
        reused = try_reuse(s.ws, kind, eta_reuse, reuse_shift, settings, &mut s.rec)?;
        direction = reused.then(|| (FactorOutcome::default(), true));
    }
    let (outcome, exact) = match direction {
        Some(d) => d,
        None => match solve_direction(s.ws, kind, &s.frame.reg_params, eta, settings, &mut s.rec) {
            Ok(d) => d,
            Err(FactorError::NotPositiveDefinite { pivot }) => {
                return Err(if settings.regularization.is_some() {
                    SolverError::RegularizationFailed {
                        iteration: s.iteration,
                        mu: s.ws.mu,
                        attempts: s.frame.reg_params.max_attempts + 1,
                    }
                } else {
                    SolverError::NotPositiveDefinite {
                        iteration: s.iteration,
                        pivot,
                    }
                });
            }
            Err(FactorError::Other(e)) => return Err(e),
        },
    };
    Ok(Choice::Direction(Chosen {
        kind,
        outcome,
        exact,
        reused,
    }))
}

/// The PSD Hessian at x into `ws.hessian`, with the policy's damping.
fn assemble_psd<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    policy: &Policy,
) -> Result<IterationHessian, SolverError> {
    let kind = assemble(
        s.objective,
        s.x,
        &mut s.ws.hessian,
        true,
        s.iteration,
        &mut s.rec.timings,
    )?;
    apply_damping(s.ws, policy.damping);
    Ok(kind)
}

/// Calls [`Objective::begin_iteration`] and applies its contract: re-analyses a changed
/// Hessian pattern, re-evaluates f and ∇f at `x` and replaces the iterate's recorded residual
/// and value when anything changed, and drops the factor kept for reuse. Returns whether
/// anything changed (the caller then drops its watchdog point).
fn begin_iteration<O: Objective + ?Sized>(s: &mut Solve<'_, O>) -> Result<bool, SolverError> {
    let update = s.objective.begin_iteration(s.x, s.iteration)?;
    if update.pattern_changed {
        let mut fresh = NewtonWorkspace::new(s.objective, s.frame.settings)?;
        fresh.mu = s.ws.mu;
        fresh.progress = s.ws.progress.take();
        fresh.cancel = s.ws.cancel.take();
        *s.ws = fresh;
    }
    if !(update.value_changed || update.pattern_changed) {
        return Ok(false);
    }
    s.ws.reusable = None;
    let t = Instant::now();
    s.f = s.objective.gradient(s.x, &mut s.ws.g)?;
    s.rec.timings.assembly += t.elapsed();
    check_finite(s.f, &s.ws.g, s.iteration)?;
    let residual = norm_inf(&s.ws.g) / s.objective.force_scale();
    if let (Some(r), Some(v)) = (s.rec.residuals.last_mut(), s.rec.values.last_mut()) {
        *r = residual;
        *v = s.f;
    }
    Ok(true)
}
