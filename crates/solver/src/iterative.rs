//! Preconditioned conjugate gradients (PCG) on a symmetric matrix stored as its lower triangle,
//! with the preconditioners the Newton solve uses instead of a fresh Cholesky factorisation:
//!
//! - an **old Cholesky factor** ([`SparseCholesky`](crate::SparseCholesky)) of a nearby Hessian
//!   (factorisation reuse, [`NewtonSettings::reuse_factor`](crate::NewtonSettings::reuse_factor));
//! - an **incomplete Cholesky factor IC(0)** ([`Ic0`]) on the Hessian's own pattern, with the
//!   diagonal shift `α·diag(H)` (α from 0, then 1e-4, ×10 per breakdown) that keeps it from
//!   breaking down on matrices that are positive definite but not M-matrices (Manteuffel's
//!   shifted incomplete Cholesky); the automatic fallback when the Cholesky factor does not fit
//!   in memory;
//! - the **diagonal** (Jacobi), the cheapest, kept for comparison.
//!
//! PCG stops at the relative residual `‖H x − b‖₂ ≤ tol · ‖b‖₂`, after `max_iterations`, or at
//! the first search direction of non-positive curvature `pᵀ H p ≤ 0` (H is not positive
//! definite along it; the iterate so far, if any, is a descent direction of the quadratic
//! model, as in truncated Newton–CG).
//!
//! No crate with these preconditioners was taken: `faer-precond` (0.2, IC(0) on faer 0.24)
//! enables faer's default features (`rand`, `npy`) and thus rebuilds faer for the whole
//! workspace, and is a months-old single-author crate; IC(0) here is 60 lines on faer's CSC
//! arrays.

use faer::sparse::SparseColMatRef;

use crate::SolverError;

/// Applies `H + shift·I` (H symmetric, lower triangle stored, rows sorted in each column) to
/// `x`, into `y`.
pub fn sym_lower_matvec(h: SparseColMatRef<'_, usize, f64>, shift: f64, x: &[f64], y: &mut [f64]) {
    let col_ptr = h.symbolic().col_ptr();
    let row_idx = h.symbolic().row_idx();
    let val = h.val();
    for (yi, &xi) in y.iter_mut().zip(x) {
        *yi = shift * xi;
    }
    for j in 0..h.ncols() {
        let xj = x[j];
        let mut acc = 0.0;
        for p in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[p];
            let v = val[p];
            y[i] += v * xj;
            if i != j {
                acc += v * x[i];
            }
        }
        y[j] += acc;
    }
}

/// Zero-fill incomplete Cholesky factor `L Lᵀ ≈ H + α·diag(H)` on the lower-triangle pattern of
/// H (compressed columns, rows sorted, diagonal first in each column).
#[derive(Clone, Debug)]
pub struct Ic0 {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// Scatter map of one column's rows to value offsets (`usize::MAX`: not in the pattern).
    map: Vec<usize>,
    /// Relative diagonal shift α of the last successful factorisation.
    pub alpha: f64,
}

/// First relative shift α tried after an IC(0) breakdown.
const IC_ALPHA_INITIAL: f64 = 1e-4;
/// Shifted IC(0) attempts before giving up (α up to 1e-4·10⁹ — diagonal dominance long before).
const IC_MAX_ATTEMPTS: usize = 10;

impl Ic0 {
    /// Storage for the pattern of `h` (checked: square, diagonal first in each column).
    pub fn new(h: SparseColMatRef<'_, usize, f64>) -> Result<Ic0, SolverError> {
        let n = h.ncols();
        let col_ptr = h.symbolic().col_ptr().to_vec();
        let row_idx = h.symbolic().row_idx().to_vec();
        for j in 0..n {
            if col_ptr[j] == col_ptr[j + 1] || row_idx[col_ptr[j]] != j {
                return Err(SolverError::InvalidPattern {
                    dof: j,
                    reason: "IC(0) needs the diagonal first in each column of the lower triangle",
                });
            }
        }
        Ok(Ic0 {
            values: vec![0.0; row_idx.len()],
            col_ptr,
            row_idx,
            map: vec![usize::MAX; n],
            alpha: 0.0,
        })
    }

    /// Bytes IC(0) and the PCG vectors take for `n` unknowns and `nnz` stored entries: factor
    /// values and indices, the scatter map and six vectors of PCG (x, r, z, p, Hp and the
    /// right-hand side).
    pub fn memory_estimate(n: usize, nnz: usize) -> u64 {
        (nnz * (8 + 8) + (n + 1) * 8 + n * 8 + 6 * n * 8) as u64
    }

    /// Factorises `h` (same pattern as [`new`](Self::new)), shifting its diagonal by `α·H_dd`
    /// with α from 0, then `IC_ALPHA_INITIAL` growing ×10 until no pivot breaks down.
    /// Returns the attempts; errors if every attempt breaks down (a non-positive or non-finite
    /// diagonal entry, which no relative shift lifts).
    pub fn factorize(&mut self, h: SparseColMatRef<'_, usize, f64>) -> Result<usize, SolverError> {
        let mut alpha = 0.0;
        for attempt in 1..=IC_MAX_ATTEMPTS + 1 {
            if self.try_factorize(h, alpha) {
                self.alpha = alpha;
                return Ok(attempt);
            }
            alpha = if alpha == 0.0 {
                IC_ALPHA_INITIAL
            } else {
                alpha * 10.0
            };
        }
        Err(SolverError::Linear(
            "incomplete Cholesky IC(0) broke down at every diagonal shift (a diagonal entry of \
             the Hessian is not positive)"
                .into(),
        ))
    }

    fn try_factorize(&mut self, h: SparseColMatRef<'_, usize, f64>, alpha: f64) -> bool {
        let n = self.col_ptr.len() - 1;
        let (cp, ri, map) = (&self.col_ptr, &self.row_idx, &mut self.map);
        let l = &mut self.values;
        l.copy_from_slice(h.val());
        for j in 0..n {
            l[cp[j]] *= 1.0 + alpha;
        }
        // Right-looking: column k, once final, updates the later columns it touches, only at
        // positions already in the pattern (zero fill).
        for k in 0..n {
            let d = l[cp[k]];
            if !(d > 0.0 && d.is_finite()) {
                return false;
            }
            let d = d.sqrt();
            l[cp[k]] = d;
            for v in &mut l[cp[k] + 1..cp[k + 1]] {
                *v /= d;
            }
            for pj in cp[k] + 1..cp[k + 1] {
                let j = ri[pj];
                let ljk = l[pj];
                for (q, &i) in ri.iter().enumerate().take(cp[j + 1]).skip(cp[j]) {
                    map[i] = q;
                }
                for pi in pj..cp[k + 1] {
                    let q = map[ri[pi]];
                    if q != usize::MAX {
                        l[q] -= l[pi] * ljk;
                    }
                }
                for &i in &ri[cp[j]..cp[j + 1]] {
                    map[i] = usize::MAX;
                }
            }
        }
        true
    }

    /// `r ← (L Lᵀ)⁻¹ r`.
    pub fn apply(&self, r: &mut [f64]) {
        let n = self.col_ptr.len() - 1;
        let (cp, ri, l) = (&self.col_ptr, &self.row_idx, &self.values);
        for j in 0..n {
            let y = r[j] / l[cp[j]];
            r[j] = y;
            for p in cp[j] + 1..cp[j + 1] {
                r[ri[p]] -= l[p] * y;
            }
        }
        for j in (0..n).rev() {
            let mut s = r[j];
            for p in cp[j] + 1..cp[j + 1] {
                s -= l[p] * r[ri[p]];
            }
            r[j] = s / l[cp[j]];
        }
    }
}

/// How a PCG solve ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgOutcome {
    /// Iterations (matrix–vector products).
    pub iterations: usize,
    /// `‖H x − b‖₂ / ‖b‖₂` of the returned x (the recursively updated residual).
    pub relative_residual: f64,
    /// The tolerance was met.
    pub converged: bool,
    /// A search direction had `pᵀ H p ≤ 0`: H is not positive definite.
    pub negative_curvature: bool,
}

/// PCG work vectors (allocated once per workspace).
#[derive(Clone, Debug, Default)]
pub struct PcgScratch {
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    hp: Vec<f64>,
}

impl PcgScratch {
    /// Vectors for `n` unknowns.
    pub fn new(n: usize) -> PcgScratch {
        PcgScratch {
            r: vec![0.0; n],
            z: vec![0.0; n],
            p: vec![0.0; n],
            hp: vec![0.0; n],
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solves `H x = b` by PCG from `x = 0`, with the preconditioner
/// `precond(r) : r ← M⁻¹ r` (M symmetric positive definite). See the [module docs](self) for
/// the stopping rules; `x` holds the last iterate whatever the outcome.
pub fn pcg(
    h: SparseColMatRef<'_, usize, f64>,
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    max_iterations: usize,
    scratch: &mut PcgScratch,
    mut precond: impl FnMut(&mut [f64]) -> Result<(), SolverError>,
) -> Result<PcgOutcome, SolverError> {
    let PcgScratch { r, z, p, hp } = scratch;
    x.fill(0.0);
    r.copy_from_slice(b);
    let b_norm = dot(b, b).sqrt();
    let mut outcome = PcgOutcome {
        iterations: 0,
        relative_residual: 1.0,
        converged: false,
        negative_curvature: false,
    };
    if b_norm == 0.0 {
        outcome.relative_residual = 0.0;
        outcome.converged = true;
        return Ok(outcome);
    }
    z.copy_from_slice(r);
    precond(z)?;
    p.copy_from_slice(z);
    let mut rz = dot(r, z);
    while outcome.iterations < max_iterations {
        sym_lower_matvec(h, 0.0, p, hp);
        let php = dot(p, hp);
        outcome.iterations += 1;
        // NaN counts as non-positive curvature too.
        if php.is_nan() || php <= 0.0 {
            outcome.negative_curvature = true;
            return Ok(outcome);
        }
        let a = rz / php;
        for ((xi, ri), (pi, hpi)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(&*hp)) {
            *xi += a * pi;
            *ri -= a * hpi;
        }
        outcome.relative_residual = dot(r, r).sqrt() / b_norm;
        if outcome.relative_residual <= tol {
            outcome.converged = true;
            return Ok(outcome);
        }
        z.copy_from_slice(r);
        precond(z)?;
        let rz_new = dot(r, z);
        let beta = rz_new / rz;
        rz = rz_new;
        for (pi, zi) in p.iter_mut().zip(&*z) {
            *pi = zi + beta * *pi;
        }
    }
    Ok(outcome)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};

    /// Lower triangle of a 1-D Laplacian plus `d` on the diagonal.
    fn lap(n: usize, d: f64) -> SparseColMat<usize, f64> {
        let mut t = Vec::new();
        for i in 0..n {
            t.push(Triplet::new(i, i, 2.0 + d));
            if i + 1 < n {
                t.push(Triplet::new(i + 1, i, -1.0));
            }
        }
        SparseColMat::try_new_from_triplets(n, n, &t).expect("valid triplets")
    }

    #[test]
    fn ic0_of_a_tridiagonal_matrix_is_its_exact_cholesky_factor() {
        // No fill in a tridiagonal factor: IC(0) = Cholesky, PCG converges in one iteration.
        let h = lap(50, 0.1);
        let mut ic = Ic0::new(h.as_ref()).expect("pattern");
        assert_eq!(ic.factorize(h.as_ref()).expect("factorises"), 1);
        let b: Vec<f64> = (0..50).map(|i| (i as f64).sin()).collect();
        let mut x = vec![0.0; 50];
        let mut s = PcgScratch::new(50);
        let o = pcg(h.as_ref(), &b, &mut x, 1e-12, 10, &mut s, |r| {
            ic.apply(r);
            Ok(())
        })
        .expect("pcg");
        assert!(o.converged && o.iterations == 1, "{o:?}");
        let mut hx = vec![0.0; 50];
        sym_lower_matvec(h.as_ref(), 0.0, &x, &mut hx);
        let err = hx
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-12, "{err}");
    }

    #[test]
    fn negative_curvature_is_detected() {
        let h = lap(20, 0.0);
        let b = vec![1.0; 20];
        let mut x = vec![0.0; 20];
        let mut s = PcgScratch::new(20);
        // H − 3I is indefinite (eigenvalues of the Laplacian lie in (0, 4)).
        let shifted = lap(20, -3.0);
        let o = pcg(shifted.as_ref(), &b, &mut x, 1e-12, 100, &mut s, |_| Ok(())).expect("pcg");
        assert!(o.negative_curvature && !o.converged, "{o:?}");
        // Positive definite: unpreconditioned CG converges within n iterations.
        let o = pcg(h.as_ref(), &b, &mut x, 1e-10, 100, &mut s, |_| Ok(())).expect("pcg");
        assert!(o.converged && o.iterations <= 20, "{o:?}");
    }
}
