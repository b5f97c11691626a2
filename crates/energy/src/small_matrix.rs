//! Small dense helpers shared by the kernels: symmetric 2×2 entries and inverse, and the PSD
//! projection of a face Hessian.

use nalgebra::{Matrix2, SMatrix, SymmetricEigen, Vector3};

/// Independent entries (m11, m12, m22) of a symmetric 2×2 matrix.
#[inline]
pub fn sym_entries(m: &Matrix2<f64>) -> Vector3<f64> {
    Vector3::new(m[(0, 0)], 0.5 * (m[(0, 1)] + m[(1, 0)]), m[(1, 1)])
}

/// The symmetric 2×2 matrix with entries (m11, m12, m22).
#[inline]
pub fn sym_matrix(v: &Vector3<f64>) -> Matrix2<f64> {
    Matrix2::new(v[0], v[1], v[1], v[2])
}

/// Inverse of a symmetric 2×2 matrix (no check: callers guarantee positive definiteness;
/// a singular input gives non-finite entries, which `eval_face` callers detect).
#[inline]
pub fn inv2(m: &Matrix2<f64>) -> Matrix2<f64> {
    let det = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
    // One division, four products (a division per entry costs more than the rounding saves).
    Matrix2::new(m[(1, 1)], -m[(0, 1)], -m[(1, 0)], m[(0, 0)]) * (1.0 / det)
}

/// Replaces a symmetric matrix by its PSD projection V max(Λ, 0) Vᵀ (symmetric
/// eigen-decomposition, negative eigenvalues clamped to 0). Implemented for the face and contact pair Hessian
/// sizes (nalgebra's fixed-size eigen-decomposition needs a concrete size).
pub trait ProjectPsd {
    /// Projects `self` in place.
    fn project_psd(&mut self);
}

macro_rules! project_psd_impl {
    ($($n:literal),*) => {$(
        impl ProjectPsd for SMatrix<f64, $n, $n> {
            fn project_psd(&mut self) {
                let sym = (*self + self.transpose()) * 0.5;
                let eig = SymmetricEigen::new(sym);
                if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
                    *self = sym;
                    return;
                }
                let lam = eig.eigenvalues.map(|l| l.max(0.0));
                let v = &eig.eigenvectors;
                *self = v * SMatrix::<f64, $n, $n>::from_diagonal(&lam) * v.transpose();
            }
        }
    )*};
}
project_psd_impl!(3, 12, 18, 21);

/// Replaces a symmetric matrix by its PSD projection ([`ProjectPsd`]).
pub fn project_psd<const N: usize>(h: &mut SMatrix<f64, N, N>)
where
    SMatrix<f64, N, N>: ProjectPsd,
{
    h.project_psd();
}
