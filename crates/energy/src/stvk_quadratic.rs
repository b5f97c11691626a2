//! The St. Venant–Kirchhoff quadratic c·‖A⁻¹D‖²_SV, ‖M‖²_SV = α/2 tr(M)² + β tr(M²), of a
//! symmetric D = [[d11, d12], [d12, d22]] given by its three entries d (model.md §2): the
//! stretching (D = a − ā, c = h/8 · A), bending (D = b − b̄, c = h³/24 · A), the bilayer's layers
//! and Kelvin–Voigt damping (A = a_prev) all are this quadratic. It is a quadratic form
//! dᵀKd in the entries; three ways to evaluate it, one per use:
//!
//! - [`sv_quadratic`]: the matrix K (Hessians are 2K);
//! - [`sv_quadratic_times`]: K·d without forming K (gradients are 2Kd, the energy d·Kd);
//! - [`sv_norm_sq_entries`]: the value ‖A⁻¹D‖²_SV alone (the energy-only path).
//!
//! K·d and the value are written once over `real::Real` (`*_of`), for the per-face kernels and the
//! batched pass alike. [`sv_norm_sq`] is the definition on a general 2×2 matrix (in f64 for tests, in dual numbers
//! for the neo-Hookean bending term).

use crate::material::dual::Scalar;
use crate::real::{Real, Vec3, dot};
use nalgebra::{Matrix2, Matrix3, Vector3};

/// The entries [p, q, r] of a symmetric A⁻¹ = [[p, q], [q, r]] (q averaged from both
/// off-diagonal entries).
#[inline]
pub(crate) fn inv_entries(a_inv: &Matrix2<f64>) -> Vec3<f64> {
    [
        a_inv[(0, 0)],
        0.5 * (a_inv[(0, 1)] + a_inv[(1, 0)]),
        a_inv[(1, 1)],
    ]
}

/// Matrix K of the quadratic form d ↦ c·‖A⁻¹D‖²_SV = dᵀ K d, with D = [[d11, d12], [d12, d22]].
///
/// With g = (Ai11, 2 Ai12, Ai22) (so tr(A⁻¹D) = g·d) and
/// Q = [[a², 2ab, b²], [2ab, 2b² + 2ac, 2bc], [b², 2bc, c²]] for A⁻¹ = [[a, b], [b, c]]
/// (so tr(A⁻¹D A⁻¹D) = dᵀQd): K = c·(α/2 g gᵀ + β Q). K is positive semidefinite for
/// α, β ≥ 0 and A positive definite, so the energy's Hessian in the form, 2K, is PSD.
#[inline]
pub fn sv_quadratic(a_inv: &Matrix2<f64>, alpha: f64, beta: f64, c: f64) -> Matrix3<f64> {
    let [a, b, cc] = inv_entries(a_inv);
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

/// K·d for K = [`sv_quadratic`]`(a_inv, alpha, beta, c)`, without forming K:
/// K d = c (α/2 g (g·d) + β Q d), g and Q as there.
#[inline]
pub fn sv_quadratic_times(
    a_inv: &Matrix2<f64>,
    alpha: f64,
    beta: f64,
    c: f64,
    d: &Vector3<f64>,
) -> Vector3<f64> {
    sv_quadratic_times_of(&inv_entries(a_inv), alpha, beta, c, &(*d).into()).into()
}

/// [`sv_quadratic_times`] over any [`Real`], from the entries (p, q, r) of A⁻¹.
#[inline(always)]
pub(crate) fn sv_quadratic_times_of<T: Real>(
    inv: &Vec3<T>,
    alpha: f64,
    beta: f64,
    c: T,
    d: &Vec3<T>,
) -> Vec3<T> {
    let [p, q, r] = *inv;
    let two = T::cst(2.0);
    let v = [p, two * q, r];
    let qd = [
        p * p * d[0] + two * p * q * d[1] + q * q * d[2],
        two * p * q * d[0] + two * (q * q + p * r) * d[1] + two * q * r * d[2],
        q * q * d[0] + two * q * r * d[1] + r * r * d[2],
    ];
    let s = T::cst(0.5 * alpha) * dot(&v, d);
    let beta = T::cst(beta);
    [
        (v[0] * s + qd[0] * beta) * c,
        (v[1] * s + qd[1] * beta) * c,
        (v[2] * s + qd[2] * beta) * c,
    ]
}

/// ‖A⁻¹D‖²_SV = α/2 tr(M)² + β tr(M²), M = A⁻¹D, from the entries d of D, with `half_alpha`
/// = α/2 (the quadratic form of [`sv_quadratic`] without its scale, written out: ~20 flops).
#[inline]
pub fn sv_norm_sq_entries(
    a_inv: &Matrix2<f64>,
    half_alpha: f64,
    beta: f64,
    d: &Vector3<f64>,
) -> f64 {
    sv_norm_sq_of(&inv_entries(a_inv), half_alpha, beta, &(*d).into())
}

/// [`sv_norm_sq_entries`] over any [`Real`], from the entries (p, q, r) of A⁻¹.
#[inline(always)]
pub(crate) fn sv_norm_sq_of<T: Real>(inv: &Vec3<T>, half_alpha: f64, beta: f64, d: &Vec3<T>) -> T {
    let [p, q, r] = *inv;
    let m00 = p * d[0] + q * d[1];
    let m01 = p * d[1] + q * d[2];
    let m10 = q * d[0] + r * d[1];
    let m11 = q * d[1] + r * d[2];
    let t = m00 + m11;
    T::cst(half_alpha) * t * t + T::cst(beta) * (m00 * m00 + T::cst(2.0) * m01 * m10 + m11 * m11)
}

/// ‖M‖²_SV = α/2 tr(M)² + β tr(M²) of a general 2×2 matrix M = [[m11, m12], [m21, m22]] over
/// f64 or dual numbers: the definition, used by the neo-Hookean bending term (M = a⁻¹b − ā⁻¹b̄
/// in dual numbers) and, through [`sv_norm_sq`], by tests.
#[inline]
pub(crate) fn sv_norm_sq_general<S: Scalar>(m: &[[S; 2]; 2], alpha: f64, beta: f64) -> S {
    let tr = m[0][0] + m[1][1];
    let tr_sq = m[0][0] * m[0][0] + m[0][1] * m[1][0] + m[1][0] * m[0][1] + m[1][1] * m[1][1];
    (tr * tr).scale(0.5 * alpha) + tr_sq.scale(beta)
}

/// Reference SV norm ‖M‖²_SV = α/2 tr(M)² + β tr(M²) of a general 2×2 matrix (for tests).
pub fn sv_norm_sq(m: &Matrix2<f64>, alpha: f64, beta: f64) -> f64 {
    let rows = [[m[(0, 0)], m[(0, 1)]], [m[(1, 0)], m[(1, 1)]]];
    sv_norm_sq_general(&rows, alpha, beta)
}
