//! Derivatives of triangle normals, shared by the bending forms: the cross product
//! c = (p1 − p0) × (p2 − p0) with its Jacobian and its constant contracted Hessian, and the
//! normalisation u ↦ u/|u| with its Jacobian and contracted Hessian. A unit normal n = c/|c|
//! and its derivatives follow by the chain rule through these.

use crate::real::{Real, Vec3, cross, dot, scale, sub};
use nalgebra::{Matrix3, SMatrix, Vector3};

// The values, written once over [`Real`] for the per-face forms (f64) and the batched pass
// (one SIMD lane per face): unit vectors, the pull-back through a normalisation and through a
// cross product.

/// (u/|u|, |u|): one reciprocal, then a product per entry.
#[inline(always)]
pub(crate) fn unit_of<T: Real>(u: &Vec3<T>) -> (Vec3<T>, T) {
    let len = dot(u, u).sqrt();
    (scale(u, len.recip()), len)
}

/// [`unit_of`] of a nalgebra vector.
#[inline]
pub(crate) fn unit(u: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let (m, len) = unit_of(&(*u).into());
    (m.into(), len)
}

/// v pulled back through u ↦ m = u/|u| (m and `len` = |u| given): (I − m mᵀ) v / |u|.
#[inline(always)]
pub(crate) fn pull_of<T: Real>(m: &Vec3<T>, len: T, v: &Vec3<T>) -> Vec3<T> {
    scale(&sub(v, &scale(m, dot(m, v))), len.recip())
}

/// The gradient of ν·((q1 − q0) × (q2 − q0)) w.r.t. q0, q1, q2:
/// ((q1 − q2) × ν, (q2 − q0) × ν, ν × (q1 − q0)).
#[inline(always)]
pub(crate) fn cross_pullback_of<T: Real>(q: [&Vec3<T>; 3], nu: &Vec3<T>) -> [Vec3<T>; 3] {
    [
        cross(&sub(q[1], q[2]), nu),
        cross(&sub(q[2], q[0]), nu),
        cross(nu, &sub(q[1], q[0])),
    ]
}

/// The cross-product matrix [v]×: [v]× w = v × w.
#[inline]
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Unnormalised normal c = (p1 − p0) × (p2 − p0) and its Jacobian blocks w.r.t. p0, p1, p2:
/// dc = [p2 − p1]× dp0 − [p2 − p0]× dp1 + [p1 − p0]× dp2.
#[inline]
pub(crate) fn cross_normal(p: [&Vector3<f64>; 3]) -> (Vector3<f64>, [Matrix3<f64>; 3]) {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    (e1.cross(&e2), [skew(&(p[2] - p[1])), -skew(&e2), skew(&e1)])
}

/// Adds the constant contracted Hessian of ν·((p1 − p0) × (p2 − p0)) on the 3×3 blocks `idx`
/// (of p0, p1, p2) of `h`: block (a, b) = K_ab [ν]×, K = [[0, −1, 1], [1, 0, −1], [−1, 1, 0]].
#[inline]
pub(crate) fn add_cross_hess<const N: usize>(
    h: &mut SMatrix<f64, N, N>,
    idx: [usize; 3],
    nu: &Vector3<f64>,
) {
    const K: [[f64; 3]; 3] = [[0.0, -1.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 1.0, 0.0]];
    let s = skew(nu);
    for (a, &ba) in idx.iter().enumerate() {
        for (b, &bb) in idx.iter().enumerate() {
            if K[a][b] != 0.0 {
                let mut v = h.fixed_view_mut::<3, 3>(3 * ba, 3 * bb);
                v += s * K[a][b];
            }
        }
    }
}

/// Unit vector m = u/|u|, and P/|u| with P = I − m mᵀ (Jacobian of u ↦ u/|u|), and |u|.
#[inline]
pub(crate) fn normalize_jac(u: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>, f64) {
    let len = u.norm();
    let m = u / len;
    let p = (Matrix3::identity() - m * m.transpose()) / len;
    (m, p, len)
}

/// Contracted Hessian ∇²_u (w·u/|u|) = −(m (Pw)ᵀ + (Pw) mᵀ + (m·w) P)/|u|², P = I − m mᵀ.
#[inline]
pub(crate) fn normalize_hess(m: &Vector3<f64>, len: f64, w: &Vector3<f64>) -> Matrix3<f64> {
    let p = Matrix3::identity() - m * m.transpose();
    let pw = p * w;
    let mpw = m * pw.transpose();
    -(mpw + mpw.transpose() + p * m.dot(w)) / (len * len)
}
