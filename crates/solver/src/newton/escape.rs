//! Leaving saddles and indefinite regions: steps along negative curvature, extrapolated steps, and
//! Newton steps to a critical point the trust region cannot resolve.

use std::time::Instant;

use faer::Par;

use super::checks::{assemble, check_finite, first_non_finite, norm_inf, step_limit_of};
use super::report::{Record, value_noise};
use super::settings::IterationHessian;
use super::solve::{SMALL_SHIFT, Solve, TR_MAX_SHIFT, WATCHDOG_MIN_DECREASE};
use super::workspace::NewtonWorkspace;
use crate::SolverError;
use crate::curvature::{self, SHIFT_GROWTH};
use crate::descent::double_while_falling;
use crate::ldlt::SparseLdlt;
use crate::objective::Objective;
use crate::progress::NewtonProgress;

/// Largest shift σ the saddle escape at a converged point tries (relative to each unknown's
/// own stiffness): beyond it the Hessian is not that of a nearly stable point.
pub(super) const ESCAPE_MAX_SHIFT: f64 = 1e3;

/// Doubles an accepted step `alpha·dx` of the own Hessian along which CG met negative
/// curvature while f keeps decreasing by more than its round-off, within the objective's step
/// limit and a length of `length_scale` (m; the body's size). Near a saddle the slightly shifted
/// factor's direction is dominated by the unstable mode but its length grows only by the factor
/// σ/(σ − |λ|) per iteration, close to 1 on fine meshes just past a critical load, so that
/// leaving the flat state took hundreds of iterations (docs/robustness.md); here f decides how
/// far to go.
/// Returns the longer step and its value, with `ws.x_trial` set to it (`None`: the full step
/// stays, and so does `ws.x_trial`).
pub(super) fn extrapolate<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    alpha: f64,
    f_alpha: f64,
) -> Result<Option<(f64, f64)>, SolverError> {
    let (objective, x, ws, rec) = (&mut *s.objective, &*s.x, &mut *s.ws, &mut s.rec);
    let length_scale = s.frame.length_scale;
    // Far enough for any saddle this solver meets (2⁴⁰ ≈ 1e12: from round-off-sized amplitudes
    // to the body's size), each doubling costing one value evaluation.
    const MAX_DOUBLINGS: usize = 40;
    let dx_max = norm_inf(&ws.dx);
    if dx_max.is_nan() || dx_max <= 0.0 {
        return Ok(None);
    }
    let reach = length_scale / dx_max;
    if 2.0 * alpha > reach {
        return Ok(None);
    }
    // The objective's limit (e.g. contact's collision-free fraction) for the longest step.
    let scaled: Vec<f64> = ws.dx.iter().map(|d| d * reach).collect();
    let limit = reach * step_limit_of(objective, x, &scaled)?;
    let floor = rec.value_noise;
    let best = double_while_falling(
        |t| -> Result<f64, SolverError> {
            for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x).zip(&ws.dx) {
                *xt = xi + t * d;
            }
            let s = Instant::now();
            let ft = objective.value(&ws.x_trial)?;
            rec.timings.line_search += s.elapsed();
            rec.timings.line_search_evaluations += 1;
            Ok(if ft.is_finite() { ft } else { f64::INFINITY })
        },
        (alpha, f_alpha),
        limit,
        MAX_DOUBLINGS,
        |f| value_noise(f).max(floor),
    )?;
    if best.0 == alpha {
        // The trial point is still the full step's only if no doubling was evaluated.
        for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x).zip(&ws.dx) {
            *xt = xi + alpha * d;
        }
        return Ok(None);
    }
    for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x).zip(&ws.dx) {
        *xt = xi + best.0 * d;
    }
    Ok(Some(best))
}

/// What [`saddle_newton`] did.
pub(super) enum SaddleStep {
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
pub(super) fn saddle_newton<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    step_limit: f64,
) -> Result<SaddleStep, SolverError> {
    let (objective, x, f, ws, rec) = (&mut *s.objective, &*s.x, s.f, &mut *s.ws, &mut s.rec);
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
    // A step the objective limits (contact's collision-free fraction) is not the full step to
    // the critical point this is for; the PSD Hessian decides instead.
    if step_limit_of(objective, x, &ws.dx)? < 1.0 {
        return Ok(SaddleStep::Unavailable);
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
/// (doubling from 10⁻³ of the body's size, or quartering until f decreases). Returns whether
/// it moved (x, f and `ws.g` updated, the step recorded as an iteration); `false` when
/// the own Hessian is positive definite to [`SMALL_SHIFT`] of each unknown's stiffness, or no
/// decrease was found.
pub(super) fn escape_saddle<O: Objective + ?Sized>(
    s: &mut Solve<'_, O>,
    sigma: &mut f64,
    known_indefinite: bool,
) -> Result<bool, SolverError> {
    let (objective, x, f, ws, rec) = (&mut *s.objective, &mut *s.x, s.f, &mut *s.ws, &mut s.rec);
    let (length_scale, force_scale) = (s.frame.length_scale, s.frame.force_scale);
    let (iteration, started) = (&mut s.iteration, s.frame.started);
    if ws.cholesky.is_none() {
        return Ok(false);
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
        return Ok(false);
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
            return Ok(false);
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
        return Ok(false);
    };
    let t = Instant::now();
    let pair = curvature::inverse_iteration(cholesky, &ws.hessian, &ws.scale, &[], 30)?;
    rec.timings.solve += t.elapsed();
    if pair.value.is_nan() || pair.value >= 0.0 {
        return Ok(false);
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
        best = double_while_falling(
            |t| value_at(t, ws, rec),
            (t, ft),
            t_max,
            usize::MAX,
            |_| 0.0,
        )?;
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
        return Ok(false);
    }
    for (xi, d) in x.iter_mut().zip(&v) {
        *xi += best.0 * d;
    }
    let t0 = Instant::now();
    let f_new = objective.gradient(x, &mut ws.g)?;
    rec.timings.assembly += t0.elapsed();
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
    s.f = f_new;
    Ok(true)
}
