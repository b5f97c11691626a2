//! Negative curvature of a Hessian: the scaled diagonal shift that makes it positive definite,
//! and its most negative (or smallest) eigenpair by inverse iteration on the shifted factor.
//!
//! Both measure the Hessian `H` against the positive diagonal `S = diag(max(|H_dd|, 1e-6·s))`
//! (`s` the mean |H_dd|): a shift `σ·S` lifts each unknown in proportion to its own stiffness,
//! so membrane, bending and edge-angle unknowns (whose stiffnesses differ by (h/ℓ)² and more in
//! a thin shell) are treated alike, and the eigenvalues reported are those of the pencil
//! `H v = λ S v` — dimensionless, relative to each unknown's own stiffness. The Newton solve
//! uses the shift as its trust-region (Levenberg–Marquardt) parameter and the eigenvector as the
//! direction that leaves a saddle ([`crate::newton`] module docs).

use faer::sparse::SparseColMat;

use crate::SolverError;
use crate::iterative::sym_lower_matvec;
use crate::linear::{FactorError, SparseCholesky};

/// The scaling diagonal `S` of `h` (see the [module docs](self)), written into `s`.
pub(crate) fn scaling(h: &SparseColMat<usize, f64>, diag_offsets: &[usize], s: &mut [f64]) {
    let val = h.val();
    let n = diag_offsets.len().max(1);
    let mean = diag_offsets.iter().map(|&o| val[o].abs()).sum::<f64>() / n as f64;
    let mean = if mean.is_finite() && mean > 0.0 {
        mean
    } else {
        1.0
    };
    for (si, &o) in s.iter_mut().zip(diag_offsets) {
        *si = val[o].abs().max(1e-6 * mean);
    }
}

/// Factorises `h + σ·S` (values of `h` restored afterwards). `Ok(false)`: not positive definite.
pub(crate) fn factorize_shifted(
    cholesky: &mut SparseCholesky,
    h: &mut SparseColMat<usize, f64>,
    diag_offsets: &[usize],
    s: &[f64],
    sigma: f64,
) -> Result<bool, SolverError> {
    {
        let val = h.val_mut();
        for (&o, &si) in diag_offsets.iter().zip(s) {
            val[o] += sigma * si;
        }
    }
    let r = cholesky.factorize(h.as_ref());
    {
        let val = h.val_mut();
        for (&o, &si) in diag_offsets.iter().zip(s) {
            val[o] -= sigma * si;
        }
    }
    match r {
        Ok(()) => Ok(true),
        Err(FactorError::NotPositiveDefinite { .. }) => Ok(false),
        Err(FactorError::Other(e)) => Err(e),
    }
}

/// What [`probe_shift`] found.
pub(crate) struct Probe {
    /// The shift whose factor `cholesky` now holds; `None`: `h + cap·S` is not positive
    /// definite.
    pub shift: Option<f64>,
    /// Factorisations made.
    pub attempts: usize,
}

/// A shift just above the one that makes `h + σS` positive definite, at most `cap`: factorises
/// at `cap` (failure: `shift = None`), estimates the most negative eigenvalue λ of `(H, S)` by
/// inverse iteration on that factor, then tries σ = max(2|λ|, `floor`), growing ×4 up to `cap`.
/// The factor of the returned shift is left in `cholesky`.
pub(crate) fn probe_shift(
    cholesky: &mut SparseCholesky,
    h: &mut SparseColMat<usize, f64>,
    diag_offsets: &[usize],
    s: &[f64],
    floor: f64,
    cap: f64,
) -> Result<Probe, SolverError> {
    let mut attempts = 1;
    if !factorize_shifted(cholesky, h, diag_offsets, s, cap)? {
        return Ok(Probe {
            shift: None,
            attempts,
        });
    }
    let pair = inverse_iteration(cholesky, h, s, &[], 12)?;
    let mut sigma = (-2.0 * pair.value).max(floor);
    while sigma < cap {
        attempts += 1;
        if factorize_shifted(cholesky, h, diag_offsets, s, sigma)? {
            return Ok(Probe {
                shift: Some(sigma),
                attempts,
            });
        }
        sigma *= SHIFT_GROWTH;
    }
    attempts += 1;
    let ok = factorize_shifted(cholesky, h, diag_offsets, s, cap)?;
    Ok(Probe {
        shift: ok.then_some(cap),
        attempts,
    })
}

/// Growth of a shift per failed attempt.
pub(crate) const SHIFT_GROWTH: f64 = 4.0;

/// An eigenpair estimate of the pencil `H v = λ S v`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Eigenpair {
    /// Rayleigh quotient `vᵀHv / vᵀSv` (dimensionless: relative to each unknown's own
    /// stiffness, see the [module docs](self)).
    pub value: f64,
    /// The mode, scaled to `‖v‖∞ = 1`.
    pub vector: Vec<f64>,
    /// Relative residual `‖H v − λ S v‖₂ / ‖S v‖₂` of the estimate.
    pub residual: f64,
}

/// Inverse iteration with the factor of `h + σ·S` held by `cholesky`: converges to the
/// eigenvector of the pencil `(H, S)` whose eigenvalue is nearest `−σ` — the most negative one
/// when σ is just above the shift that makes `H + σS` positive definite, the smallest one with
/// σ = 0 and a positive definite H. `deflate` holds S-orthonormal vectors the iteration is
/// kept orthogonal to (e.g. rigid motions). Stops after `max_iterations` or when the Rayleigh
/// quotient changes by less than `1e-8` relative.
pub(crate) fn inverse_iteration(
    cholesky: &mut SparseCholesky,
    h: &SparseColMat<usize, f64>,
    s: &[f64],
    deflate: &[Vec<f64>],
    max_iterations: usize,
) -> Result<Eigenpair, SolverError> {
    let n = s.len();
    // A deterministic start that excites every mode (no symmetry of a regular mesh is
    // preserved by an irrational phase).
    let mut v: Vec<f64> = (0..n)
        .map(|i| (1.0 + 0.5 * (0.754_877_666 * i as f64).sin()) / s[i].sqrt())
        .collect();
    let mut w = vec![0.0; n];
    let mut hv = vec![0.0; n];
    let mut value = f64::NAN;
    let mut residual = f64::NAN;
    for _ in 0..max_iterations.max(1) {
        project_out(&mut v, deflate, s);
        normalise_s(&mut v, s);
        for ((wi, vi), si) in w.iter_mut().zip(&v).zip(s) {
            *wi = vi * si;
        }
        cholesky.solve_in_place(&mut w)?;
        std::mem::swap(&mut v, &mut w);
        project_out(&mut v, deflate, s);
        normalise_s(&mut v, s);
        sym_lower_matvec(h.as_ref(), 0.0, &v, &mut hv);
        let rq: f64 = v.iter().zip(&hv).map(|(a, b)| a * b).sum();
        // ‖Hv − λSv‖ with vᵀSv = 1.
        let (mut r2, mut sv2) = (0.0, 0.0);
        for ((hvi, vi), si) in hv.iter().zip(&v).zip(s) {
            r2 += (hvi - rq * si * vi).powi(2);
            sv2 += (si * vi).powi(2);
        }
        residual = (r2 / sv2.max(f64::MIN_POSITIVE)).sqrt();
        let done = value.is_finite() && (rq - value).abs() <= 1e-8 * rq.abs().max(1e-300);
        value = rq;
        if done {
            break;
        }
    }
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if m > 0.0 {
        v.iter_mut().for_each(|x| *x /= m);
    }
    Ok(Eigenpair {
        value,
        vector: v,
        residual,
    })
}

/// `√(vᵀ S v)`.
fn s_norm(v: &[f64], s: &[f64]) -> f64 {
    v.iter()
        .zip(s)
        .map(|(a, si)| a * a * si)
        .sum::<f64>()
        .sqrt()
}

fn normalise_s(v: &mut [f64], s: &[f64]) {
    let norm = s_norm(v, s);
    if norm > 0.0 && norm.is_finite() {
        v.iter_mut().for_each(|x| *x /= norm);
    }
}

fn project_out(v: &mut [f64], basis: &[Vec<f64>], s: &[f64]) {
    for b in basis {
        let c: f64 = v
            .iter()
            .zip(b)
            .zip(s)
            .map(|((a, bi), si)| a * bi * si)
            .sum();
        v.iter_mut().zip(b).for_each(|(a, bi)| *a -= c * bi);
    }
}

/// The relative shift `σ₀·S` of the first factorisation of [`smallest_eigenpair`]: it keeps the
/// factor of a singular H (rigid motions) finite without amplifying round-off along them much.
const STABILITY_SHIFT: f64 = 1e-8;

/// Largest shift [`smallest_eigenpair`] tries to make `H + σS` positive definite.
const STABILITY_MAX_SHIFT: f64 = 1e3;

/// Inverse iterations of [`smallest_eigenpair`].
const STABILITY_ITERATIONS: usize = 60;

/// The smallest eigenpair of the pencil `H v = λ S v` on the S-orthogonal complement of
/// `deflate` (any independent vectors, e.g. rigid motions), for the **unshifted** `h`: inverse
/// iteration on the factor of `H + σS` with σ = 1e-8 when that is positive definite (it then
/// finds the eigenvalue nearest −σ, the smallest, however small or slightly negative — the
/// shift blurs nothing, the Rayleigh quotient is of H itself), else with σ just above the
/// shift that makes it positive definite (the most negative eigenvalue). Returns the pair and
/// the factorisations made. `value` is NaN when even `H + 1e3·S` is not positive definite.
pub(crate) fn smallest_eigenpair(
    cholesky: &mut SparseCholesky,
    h: &mut SparseColMat<usize, f64>,
    diag_offsets: &[usize],
    s: &[f64],
    deflate: &[Vec<f64>],
) -> Result<(Eigenpair, usize), SolverError> {
    // S-orthonormal deflation basis (Gram–Schmidt in the S inner product).
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for d in deflate {
        let mut v = d.clone();
        project_out(&mut v, &basis, s);
        let norm = s_norm(&v, s);
        if norm > 1e-10 * s_norm(d, s) && norm.is_finite() {
            v.iter_mut().for_each(|x| *x /= norm);
            basis.push(v);
        }
    }
    let mut attempts = 1;
    if !factorize_shifted(cholesky, h, diag_offsets, s, STABILITY_SHIFT)? {
        let probe = probe_shift(
            cholesky,
            h,
            diag_offsets,
            s,
            SHIFT_GROWTH * STABILITY_SHIFT,
            STABILITY_MAX_SHIFT,
        )?;
        attempts += probe.attempts;
        if probe.shift.is_none() {
            return Ok((
                Eigenpair {
                    value: f64::NAN,
                    vector: vec![0.0; s.len()],
                    residual: f64::NAN,
                },
                attempts,
            ));
        }
    }
    let pair = inverse_iteration(cholesky, h, s, &basis, STABILITY_ITERATIONS)?;
    Ok((pair, attempts))
}
