//! Central finite differences and the comparisons the derivative tests make with them.
//!
//! A Hessian is checked as the Jacobian of the analytic gradient ([`fd_jacobian`] of the
//! gradient function); its entries are compared with [`rel_err_scaled`] after
//! [`dense_symmetric`] has expanded an assembled lower triangle.

use faer::sparse::SparseColMat;
use nalgebra::DMatrix;

/// Central-difference gradient of `f` at `x` with step `h` (error O(h²)).
pub fn fd_gradient(f: impl Fn(&[f64]) -> f64, x: &[f64], h: f64) -> Vec<f64> {
    // The one-row Jacobian: the same (f(x + h eᵢ) − f(x − h eᵢ)) / 2h per entry; no rows
    // (and no entries) for an empty x.
    fd_jacobian(|y| vec![f(y)], x, h)
        .pop()
        .unwrap_or_else(|| vec![0.0; x.len()])
}

/// Central-difference Jacobian of `f: R^n → R^m`; result row-major, `m` rows of length `n`.
pub fn fd_jacobian(f: impl Fn(&[f64]) -> Vec<f64>, x: &[f64], h: f64) -> Vec<Vec<f64>> {
    let mut y = x.to_vec();
    let cols: Vec<Vec<f64>> = (0..x.len())
        .map(|i| {
            y[i] = x[i] + h;
            let fp = f(&y);
            y[i] = x[i] - h;
            let fm = f(&y);
            y[i] = x[i];
            fp.iter()
                .zip(&fm)
                .map(|(p, m)| (p - m) / (2.0 * h))
                .collect()
        })
        .collect();
    let m = cols.first().map_or(0, Vec::len);
    (0..m)
        .map(|r| cols.iter().map(|c| c[r]).collect())
        .collect()
}

/// max |a − b| / max(max |b|, floor): the error of `a` relative to the largest entry of the
/// reference `b`, with `floor` (≥ 1e-300) guarding a reference that is all (near) zero.
pub fn rel_err_scaled(a: &[f64], b: &[f64], floor: f64) -> f64 {
    let scale = b.iter().fold(floor.max(1e-300), |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// The dense symmetric matrix of an assembled Hessian stored as its lower triangle (the
/// assembler's convention). Panics on an entry above the diagonal.
pub fn dense_symmetric(h: &SparseColMat<usize, f64>) -> DMatrix<f64> {
    let n = h.nrows();
    let mut d = DMatrix::zeros(n, n);
    let s = h.symbolic();
    for c in 0..n {
        for k in s.col_ptr()[c]..s.col_ptr()[c + 1] {
            let r = s.row_idx()[k];
            assert!(r >= c, "entry above the diagonal");
            d[(r, c)] += h.val()[k];
            if r != c {
                d[(c, r)] += h.val()[k];
            }
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn central_differences_of_a_cubic() {
        // f = x0³ + x0·x1: ∇f = (3x0² + x1, x0); the O(h²) error of the x0 derivative is h².
        let f = |x: &[f64]| x[0].powi(3) + x[0] * x[1];
        let g = fd_gradient(f, &[2.0, -1.0], 1e-4);
        assert!(
            (g[0] - 11.0).abs() < 2e-8 && (g[1] - 2.0).abs() < 1e-10,
            "{g:?}"
        );
        let j = fd_jacobian(|x| vec![3.0 * x[0] * x[0] + x[1], x[0]], &[2.0, -1.0], 1e-4);
        assert!(
            (j[0][0] - 12.0).abs() < 1e-8 && (j[0][1] - 1.0).abs() < 1e-8,
            "{j:?}"
        );
        assert!(
            (j[1][0] - 1.0).abs() < 1e-8 && j[1][1].abs() < 1e-8,
            "{j:?}"
        );
        assert_eq!(rel_err_scaled(&[1.0, 2.5], &[1.0, 2.0], 1.0), 0.25);
    }
}
