//! Derivatives of triangle normals, shared by the bending forms: the cross product
//! c = (p1 − p0) × (p2 − p0) with its Jacobian and its constant contracted Hessian, and the
//! normalisation u ↦ u/|u| with its Jacobian and contracted Hessian. A unit normal n = c/|c|
//! and its derivatives follow by the chain rule through these.

use nalgebra::{Matrix3, SMatrix, Vector3};

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
