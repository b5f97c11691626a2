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
//!
//! **Layout.** This file holds the iteration itself ([`newton_solve`]) and its constants;
//! `settings.rs` the settings, `report.rs` the report and the record kept while solving,
//! `workspace.rs` the reusable workspace and the stability analysis, `direction.rs` how a
//! direction is solved for (factorisation, reuse, CG refinement, the trust-region shift),
//! `escape.rs` the steps along negative curvature, `kept.rs` the factor kept for reuse.

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

mod direction;
mod escape;
mod kept;
mod report;
mod settings;
mod workspace;

use direction::*;
use escape::*;
pub use kept::KeptFactor;
pub use report::*;
pub use settings::*;
pub use workspace::*;

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
        extrapolated_steps: 0,
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
        // Whether the unshifted own Hessian showed negative curvature along a CG direction: the
        // shifted direction then leads away from a saddle, and its step may be extrapolated.
        let mut negative_curvature = false;
        if unshifted
            && !reused
            && kind == IterationHessian::Own
            && (outcome.mu > 0.0 || obj_shift > 0.0)
        {
            negative_curvature = refine_direction(ws, obj_shift, REFINE_TOLERANCE, &mut rec)?;
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
                        if negative_curvature && backtracks == 0 && escape {
                            if let Some((a, fa)) =
                                extrapolate(objective, x, ws, alpha, f_t, length_scale, &mut rec)?
                            {
                                alpha = a;
                                trial_has_gradient = false;
                                rec.extrapolated_steps += 1;
                                break fa;
                            }
                        }
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
