//! Newton directions: by a (possibly shifted) factorisation, by CG with a reused or slightly
//! shifted factor, the iterative fallback, and the trust-region shift search.

use std::time::Instant;

use faer::sparse::SparseColMat;

use super::report::Record;
use super::settings::{IterationHessian, NewtonSettings};
use super::solve::{SMALL_SHIFT, TR_MAX_SHIFT};
use super::workspace::NewtonWorkspace;
use crate::SolverError;
use crate::curvature::{self, SHIFT_GROWTH};
use crate::iterative::pcg;
use crate::linear::{FactorError, FactorOutcome, RegularizationKind, RegularizationParams};

/// Shifted attempts of `params` that stay at or below [`SMALL_SHIFT`].
pub(super) fn small_shift_attempts(params: &RegularizationParams) -> usize {
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

/// The relative residual a CG direction must reach: `min(cg_forcing, ‖∇f‖∞ / ‖∇f₀‖∞)`, at
/// least 1e-12 (Eisenstat–Walker-like: loose far from the solution, tight near it, so that
/// inexact Newton keeps its quadratic convergence).
pub(super) fn forcing(limit: f64, g: f64, g0: f64) -> f64 {
    let ratio = if g0 > 0.0 { g / g0 } else { 1.0 };
    limit.min(ratio).max(1e-12)
}

/// Levenberg–Marquardt damping of the PSD Hessian: shortens and turns the step towards the
/// gradient where the quadratic model overshoots (large rotations of a thin shell, whose
/// Gauss–Newton model sees no membrane cost of bending out of plane from flat).
pub(super) fn apply_damping(ws: &mut NewtonWorkspace, damping: f64) {
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
pub(super) fn try_reuse(
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

/// Computes `ws.dx = −(H + shift)⁻¹ ∇f` for the Hessian in `ws` (of `kind`), with the shift search
/// of `params` (see
/// [`SparseCholesky::factorize_regularized`](crate::SparseCholesky::factorize_regularized)): by a
/// Cholesky factorisation, or by the iterative fallback, where non-positive curvature met by CG
/// plays the part of a failed factorisation. Returns the shift and whether dx is exact (Cholesky,
/// or CG converged to the forcing term `eta`).
pub(super) fn solve_direction(
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
pub(super) const ESTIMATE_TOLERANCE: f64 = 1e-6;

/// `ws.dx` = the solution of `(H − obj_shift·I) dx = −∇f` by CG (at most `max_iterations`, to
/// relative residual `eta`) preconditioned with the Cholesky factor the workspace holds, for
/// the Hessian H in `ws` (its values are restored). `None` without a Cholesky factor.
pub(super) fn pcg_with_factor(
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
        |r| cholesky.precondition_in_place(r),
    );
    shift_diagonal(hessian, obj_shift);
    Ok(Some(o?))
}

/// CG iterations [`refine_direction`] may take. The preconditioned matrix `(H + s)⁻¹ H` has
/// its eigenvalues in (0, 1], all near 1 but those of the few soft modes whose curvature is
/// near the shift s, so CG needs about as many iterations as there are such modes.
pub(super) const REFINE_MAX_ITERATIONS: usize = 40;

/// Relative residual `‖H dx + ∇f‖₂ / ‖∇f‖₂` of a refined direction: far below what changes
/// Newton's path, and reachable where ∇f is at round-off (a tighter, forcing-term tolerance
/// there stalls on the components of ∇f's round-off along rigid motions, which H cannot
/// reduce).
pub(super) const REFINE_TOLERANCE: f64 = 1e-6;

/// Turns `ws.dx = −(H + s)⁻¹∇f`, solved with the factor of the Hessian `H` in `ws` plus a
/// small shift s (the objective's constant diagonal shift `obj_shift`, and/or a regularisation
/// shift of at most [`SMALL_SHIFT`]), into the direction of the unshifted system
/// `(H − obj_shift·I) dx = −∇f`, by CG preconditioned with that factor to relative residual
/// `eta`. With the shifted direction Newton converges only linearly (ratio s/(λ + s)) on soft
/// modes of curvature λ near s — the long bending modes of slender and thin shells — and the
/// correction used by the step test underestimates the distance to the equilibrium there.
///
/// Returns whether CG met non-positive curvature of the unshifted system. Unless CG converged
/// (non-positive curvature along a CG direction — an indefinite Hessian near a saddle, or a
/// rigid motion of an unheld shell — or the iteration limit) `ws.dx` is the shifted direction
/// again, which then serves as before: the shift is far below the stiffness of every mode but
/// the softest.
pub(super) fn refine_direction(
    ws: &mut NewtonWorkspace,
    obj_shift: f64,
    eta: f64,
    rec: &mut Record,
) -> Result<bool, SolverError> {
    let t = Instant::now();
    let Some(o) = pcg_with_factor(ws, obj_shift, eta, REFINE_MAX_ITERATIONS)? else {
        return Ok(false);
    };
    let negative = o.negative_curvature;
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
    Ok(negative)
}

/// Estimates the Newton correction at the new iterate with the last factor (or, with the
/// iterative fallback, by CG on the last Hessian): `ws.dx = −H⁻¹∇f`. Returns whether the
/// estimate is usable (CG converged).
pub(super) fn estimate_correction(
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

/// The direction of a trust-region step on the own Hessian in `ws` (assembled at the iterate):
/// `ws.dx = −(H + σS)⁻¹∇f` with σ ≤ [`TR_MAX_SHIFT`]. With `sigma0 = None` (the own Hessian
/// was just found indefinite) the smallest usable σ is estimated: `H + TR_MAX_SHIFT·S` is
/// factorised, inverse iteration on it estimates the most negative eigenvalue λ of `(H, S)`,
/// and σ = max(2|λ|, 4·SMALL_SHIFT) is tried; with `Some(σ₀)` (memory of earlier steps) the
/// search starts at σ₀. Failed attempts multiply σ by 4. `None`: the own Hessian needs more
/// than `TR_MAX_SHIFT` (strongly indefinite: far from a minimum, where PSD steps do better).
pub(super) fn shifted_direction(
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
