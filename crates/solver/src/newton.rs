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
//! reusable workspace and the stability analysis, `kept.rs` the factor kept for reuse.

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
mod policy;
mod report;
mod settings;
mod step;
mod workspace;

use direction::*;
use escape::*;
pub use kept::KeptFactor;
use policy::*;
pub use report::*;
pub use settings::*;
use step::*;
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

/// What stays fixed during one solve.
struct Frame<'a> {
    settings: &'a NewtonSettings,
    /// [`Objective::length_scale`] (m) and [`Objective::force_scale`] (N).
    length_scale: f64,
    force_scale: f64,
    /// [`Objective::gradient_test`].
    gradient_test: bool,
    reg_params: RegularizationParams,
    started: Instant,
    /// The start of the solve, kept for [`NewtonSettings::relative_step_tolerance`].
    x_start: Option<Vec<f64>>,
    /// The initial gradient's norm, the reference of the CG forcing term.
    g0: f64,
}

impl Frame<'_> {
    /// The step-convergence limit at `x` (m): the absolute one, or the relative one of
    /// [`NewtonSettings::relative_step_tolerance`] when that is larger.
    fn step_limit(&self, x: &[f64]) -> f64 {
        let absolute = self.settings.step_tolerance * self.length_scale;
        match &self.x_start {
            Some(x0) => {
                let moved = x
                    .iter()
                    .zip(x0)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                absolute.max(self.settings.relative_step_tolerance * moved)
            }
            None => absolute,
        }
    }
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
    if settings.regularization.is_none() {
        // A shift remembered from an earlier solve must not leak into an unregularised one.
        ws.mu = 0.0;
    }
    let mu_at_start = ws.mu;
    ws.kept.begin_solve(ws.reusable);
    let mut rec = Record::new(ws.linear_solver());

    let t = Instant::now();
    let mut f = objective.gradient(x, &mut ws.g)?;
    rec.timings.assembly += t.elapsed();
    check_finite(f, &ws.g, 0)?;
    rec.residuals.push(norm_inf(&ws.g) / force_scale);
    rec.values.push(f);
    let mut iteration = 0;
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
    let mut watchdog = Watchdog::new();
    // A converged point: where an indefinite own Hessian was met on the way, first make sure
    // it is not a saddle (leave it along negative curvature and go on if it is).
    macro_rules! converged {
        ($c:expr) => {{
            if policy.met_indefinite {
                if let Some(fe) = policy.leave_saddle(
                    objective,
                    x,
                    f,
                    ws,
                    &mut rec,
                    &frame,
                    &mut iteration,
                    false,
                )? {
                    f = fe;
                    continue;
                }
            }
            return Ok(rec.report(iteration, $c));
        }};
    }

    loop {
        // The objective's own update at this iterate (`Objective::begin_iteration`).
        if begin_iteration(objective, x, iteration, settings, ws, &mut f, &mut rec)? {
            watchdog.forget();
        }
        if !watchdog.watching()
            && frame.gradient_test
            && rec.residuals[rec.residuals.len() - 1] <= settings.gradient_tolerance
        {
            converged!(Convergence::Gradient);
        }
        if ws
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::SeqCst))
        {
            watchdog.restore_best(x, &mut rec);
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
            // The failure carries the best point: the one before a watched step.
            watchdog.restore_best(x, &mut rec);
            return Err(SolverError::NewtonDidNotConverge {
                residuals: rec.residuals,
                iterations: iteration + rec.watchdog_undone + rec.rejected_steps,
                tolerance: settings.gradient_tolerance,
                last_correction: rec.corrections.last().copied(),
                step_tolerance: settings.step_tolerance,
                last_good: x.to_vec(),
            });
        }

        let chosen = match choose_direction(
            objective,
            x,
            f,
            ws,
            &mut rec,
            &mut policy,
            &frame,
            &mut iteration,
        )? {
            Choice::Direction(c) => c,
            Choice::Escaped(fe) => {
                f = fe;
                continue;
            }
        };
        let (kind, outcome) = (chosen.kind, chosen.outcome);
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
        let unshifted = outcome.mu <= SMALL_SHIFT && chosen.exact;
        let obj_shift = objective.hessian_diagonal_shift();
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
            negative_curvature = refine_direction(ws, obj_shift, REFINE_TOLERANCE, &mut rec)?;
        }

        let step_limit = frame.step_limit(x);
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
        if unshifted && !watchdog.watching() {
            let dx_max = norm_inf(&ws.dx);
            rec.corrections.push(dx_max / length_scale);
            if dx_max <= step_limit {
                converged!(Convergence::Step);
            }
            // Round-off: f cannot resolve the predicted decrease and the last step no longer
            // halved the gradient (while it does, Newton still makes progress on it).
            let n = rec.residuals.len();
            if -0.5 * slope <= rec.noise(f)
                && n >= 2
                && rec.residuals[n - 1] > 0.5 * rec.residuals[n - 2]
            {
                converged!(Convergence::RoundOff);
            }
        }

        let alpha = step_limit_of(objective, x, &ws.dx)?;
        let direction = Direction {
            kind,
            slope,
            unshifted,
            negative_curvature,
            step_limit,
        };
        let step = if kind == IterationHessian::Shifted {
            trust_region_step(
                objective,
                x,
                f,
                ws,
                &mut rec,
                &mut policy,
                &frame,
                &mut iteration,
                &direction,
                alpha,
            )?
        } else {
            line_search(
                objective,
                x,
                f,
                ws,
                &mut rec,
                &mut policy,
                &mut watchdog,
                &frame,
                iteration,
                &direction,
                alpha,
            )?
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
            Step::Retry => continue,
            Step::Escaped(fe) => {
                f = fe;
                continue;
            }
            Step::Converged(c) => converged!(c),
        };

        // Accept the trial point.
        let f_old = f;
        x.copy_from_slice(&ws.x_trial);
        if has_gradient {
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
        let watched_step = watchdog.just_watched(settings);
        if watchdog.after_step(x, ws, &mut f, &mut iteration, &mut rec) {
            continue;
        }
        policy.after_step(kind, backtracks, rho, slope, (f_old, f), &rec.residuals);

        // After a full unshifted step, estimate the next correction with the same
        // factorisation (one triangular solve): a short one ends the solve here.
        if unshifted && backtracks == 0 && !watchdog.watching() && !watched_step {
            if frame.gradient_test
                && rec.residuals[rec.residuals.len() - 1] <= settings.gradient_tolerance
            {
                converged!(Convergence::Gradient);
            }
            let reused_or_shifted = chosen.reused || outcome.mu > 0.0 || obj_shift > 0.0;
            if let Some(est) =
                estimated_correction(ws, &mut rec, &frame, x, reused_or_shifted, obj_shift)?
            {
                rec.corrections.push(est / length_scale);
                converged!(Convergence::Step);
            }
        }
    }
}

/// After a full unshifted step, the next Newton correction estimated with the same
/// factorisation (one triangular solve), when it is within the step limit at the new iterate
/// `x` (m): the solve is then converged.
fn estimated_correction(
    ws: &mut NewtonWorkspace,
    rec: &mut Record,
    frame: &Frame,
    x: &[f64],
    reused_or_shifted: bool,
    obj_shift: f64,
) -> Result<Option<f64>, SolverError> {
    // The limit at the new iterate: a relative one grows with the move just made (the one of
    // the iteration's start, before any move, left the estimate unable to end an implicit
    // step, which then assembled one more Hessian only to stop there).
    let step_limit = frame.step_limit(x);
    let t = Instant::now();
    let solved = estimate_correction(ws, frame.settings, rec)?;
    rec.timings.solve += t.elapsed();
    if solved && ws.cholesky.is_some() && norm_inf(&ws.dx) <= step_limit && reused_or_shifted {
        // A shifted (or old) factor underestimates the correction along soft modes (the
        // refined one is larger there): an estimate that would end the solve solves the
        // unshifted system where CG can.
        refine_direction(ws, obj_shift, ESTIMATE_TOLERANCE, rec)?;
    }
    let est = if solved {
        norm_inf(&ws.dx)
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
    /// x moved along negative curvature to a point of this value instead.
    Escaped(f64),
}

/// The Hessian, then the Newton direction `ws.dx = −H⁻¹∇f`: by CG preconditioned with the kept
/// factor (reuse), or by a (possibly shifted) factorisation, or by the iterative fallback —
/// with the Hessian the policy chooses (see the module documentation).
#[allow(clippy::too_many_arguments)]
fn choose_direction<O: Objective + ?Sized>(
    objective: &mut O,
    x: &mut [f64],
    f: f64,
    ws: &mut NewtonWorkspace,
    rec: &mut Record,
    policy: &mut Policy,
    frame: &Frame,
    iteration: &mut usize,
) -> Result<Choice, SolverError> {
    let settings = frame.settings;
    let eta = forcing(settings.cg_forcing, norm_inf(&ws.g), frame.g0);
    let eta_reuse = forcing(settings.reuse_tolerance, norm_inf(&ws.g), frame.g0);
    let mut kind = assemble(
        objective,
        x,
        &mut ws.hessian,
        policy.adaptive && !policy.try_own,
        *iteration,
        &mut rec.timings,
    )?;
    if kind == IterationHessian::Psd {
        apply_damping(ws, policy.damping);
    }
    let reuse_shift = objective.hessian_diagonal_shift();
    let mut reused = try_reuse(ws, kind, eta_reuse, reuse_shift, settings, rec)?;
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
            if let Some(fe) =
                policy.leave_saddle(objective, x, f, ws, rec, frame, iteration, true)?
            {
                return Ok(Choice::Escaped(fe));
            }
        }
        direction = shifted_direction(ws, Some(shift_start), rec)?;
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
            max_attempts: small_shift_attempts(&frame.reg_params),
            ..frame.reg_params
        };
        match solve_direction(ws, kind, &small, eta, settings, rec) {
            Ok(d) => direction = Some(d),
            Err(FactorError::NotPositiveDefinite { .. }) if policy.trust && policy.psd_stalled => {
                // Indefinite: a trust-region step on the shifted own Hessian.
                rec.failed_factorizations += 1;
                ws.mu = 0.0;
                policy.met_indefinite = true;
                // First leave along negative curvature (a saddle or an indefinite region is
                // near: shifted steps would only creep along that direction).
                if let Some(fe) =
                    policy.leave_saddle(objective, x, f, ws, rec, frame, iteration, true)?
                {
                    return Ok(Choice::Escaped(fe));
                }
                direction = shifted_direction(ws, None, rec)?;
                if let Some((o, _)) = direction {
                    kind = IterationHessian::Shifted;
                    policy.shifted(o.mu);
                }
            }
            Err(FactorError::NotPositiveDefinite { .. }) => {
                rec.failed_factorizations += 1;
                policy.met_indefinite = true;
                ws.mu = 0.0;
                policy.own_failed();
                kind = assemble_psd(objective, x, ws, rec, policy, *iteration)?;
                reused = try_reuse(ws, kind, eta_reuse, reuse_shift, settings, rec)?;
                direction = reused.then(|| (FactorOutcome::default(), true));
            }
            Err(FactorError::Other(e)) => return Err(e),
        }
    }
    if direction.is_none() && policy.trust && own(kind, policy) {
        // No shift the search tried made the own Hessian positive definite: the PSD one.
        policy.psd_instead();
        kind = assemble_psd(objective, x, ws, rec, policy, *iteration)?;
        reused = try_reuse(ws, kind, eta_reuse, reuse_shift, settings, rec)?;
        direction = reused.then(|| (FactorOutcome::default(), true));
    }
    let (outcome, exact) = match direction {
        Some(d) => d,
        None => match solve_direction(ws, kind, &frame.reg_params, eta, settings, rec) {
            Ok(d) => d,
            Err(FactorError::NotPositiveDefinite { pivot }) => {
                return Err(if settings.regularization.is_some() {
                    SolverError::RegularizationFailed {
                        iteration: *iteration,
                        mu: ws.mu,
                        attempts: frame.reg_params.max_attempts + 1,
                    }
                } else {
                    SolverError::NotPositiveDefinite {
                        iteration: *iteration,
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
    objective: &mut O,
    x: &[f64],
    ws: &mut NewtonWorkspace,
    rec: &mut Record,
    policy: &Policy,
    iteration: usize,
) -> Result<IterationHessian, SolverError> {
    let kind = assemble(
        objective,
        x,
        &mut ws.hessian,
        true,
        iteration,
        &mut rec.timings,
    )?;
    apply_damping(ws, policy.damping);
    Ok(kind)
}

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
