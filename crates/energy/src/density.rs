//! Quadratic SV-norm densities c·‖A⁻¹(M − B)‖²_SV in the three form entries (m11, m12, m22).

pub use crate::linalg::{inv2, sym_entries};
use nalgebra::{Matrix2, Matrix3, Vector3};

/// Matrix K of the quadratic form d ↦ c·‖A⁻¹D‖²_SV = dᵀ K d, with D = [[d11, d12], [d12, d22]].
///
/// With g = (Ai11, 2 Ai12, Ai22) (so tr(A⁻¹D) = g·d) and
/// Q = [[a², 2ab, b²], [2ab, 2b² + 2ac, 2bc], [b², 2bc, c²]] for A⁻¹ = [[a, b], [b, c]]
/// (so tr(A⁻¹D A⁻¹D) = dᵀQd): K = c·(α/2 g gᵀ + β Q). K is positive semidefinite for
/// α, β ≥ 0 and A positive definite, so the energy's Hessian in the form, 2K, is PSD.
pub fn sv_quadratic(a_inv: &Matrix2<f64>, alpha: f64, beta: f64, c: f64) -> Matrix3<f64> {
    let (a, b, cc) = (
        a_inv[(0, 0)],
        0.5 * (a_inv[(0, 1)] + a_inv[(1, 0)]),
        a_inv[(1, 1)],
    );
    let g = Vector3::new(a, 2.0 * b, cc);
    let q = Matrix3::new(
        a * a,
        2.0 * a * b,
        b * b,
        2.0 * a * b,
        2.0 * (b * b + a * cc),
        2.0 * b * cc,
        b * b,
        2.0 * b * cc,
        cc * cc,
    );
    (g * g.transpose()) * (c * 0.5 * alpha) + q * (c * beta)
}

/// Reference SV norm ‖M‖²_SV = α/2 tr(M)² + β tr(M²) of a general 2×2 matrix (for tests).
pub fn sv_norm_sq(m: &Matrix2<f64>, alpha: f64, beta: f64) -> f64 {
    let t = m.trace();
    0.5 * alpha * t * t + beta * (m * m).trace()
}
