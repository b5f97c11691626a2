//! Membrane strain: the first fundamental form (metric) a of a face and its derivatives w.r.t.
//! the face's vertices (model.md §2). The laws measure the strain ā⁻¹a − I against the rest
//! metric ā; this file holds a itself, in the barycentric basis (e1, e2) = (x1 − x0, x2 − x0):
//! a = RᵀR with R = [e1 | e2], entries (a11, a12, a22) = (e1·e1, e1·e2, e2·e2) (m²).
//!
//! Every place that needs a face's metric (rest state, the per-face kernels, the batched pass,
//! growth's material directions) calls these functions; the metric and its gradient are
//! written once over `real::Real` (f64 here, one SIMD lane per face in `assembly::batch`).

use crate::real::{Real, Vec3, add, dot, scale};
use crate::small_matrix::sym_matrix;
use nalgebra::{Matrix2, SMatrix, Vector3};

/// The metric entries (a11, a12, a22) = (e1·e1, e1·e2, e2·e2) (m²) of the edge vectors
/// e1 = x1 − x0, e2 = x2 − x0.
#[inline]
pub fn metric(e1: &Vector3<f64>, e2: &Vector3<f64>) -> Vector3<f64> {
    metric_of(&(*e1).into(), &(*e2).into()).into()
}

/// [`metric`] over any [`Real`].
#[inline(always)]
pub(crate) fn metric_of<T: Real>(e1: &Vec3<T>, e2: &Vec3<T>) -> Vec3<T> {
    [dot(e1, e1), dot(e1, e2), dot(e2, e2)]
}

/// The edge vectors (e1, e2) = (x1 − x0, x2 − x0) (m) of a face.
#[inline]
pub fn edges(x: &[Vector3<f64>; 3]) -> (Vector3<f64>, Vector3<f64>) {
    (x[1] - x[0], x[2] - x[0])
}

/// a = RᵀR with R = [x1 − x0 | x2 − x0] (m²), in the face's barycentric basis.
#[inline]
pub fn first_fundamental_form(x: &[Vector3<f64>; 3]) -> Matrix2<f64> {
    let (e1, e2) = edges(x);
    sym_matrix(&metric(&e1, &e2))
}

/// Jacobian J_a (3×9) of (a11, a12, a22) w.r.t. (x0, x1, x2): rows
/// (−2e1, 2e1, 0), (−(e1 + e2), e2, e1), (−2e2, 0, 2e2).
#[inline]
pub fn metric_jacobian(e1: &Vector3<f64>, e2: &Vector3<f64>) -> SMatrix<f64, 3, 9> {
    let rows = [
        [-2.0 * e1, 2.0 * e1, Vector3::zeros()],
        [-(e1 + e2), *e2, *e1],
        [-2.0 * e2, Vector3::zeros(), 2.0 * e2],
    ];
    let mut ja = SMatrix::<f64, 3, 9>::zeros();
    for (k, r) in rows.iter().enumerate() {
        for (b, v) in r.iter().enumerate() {
            ja.fixed_view_mut::<1, 3>(k, 3 * b)
                .copy_from(&v.transpose());
        }
    }
    ja
}

/// J_aᵀ g for g = ∂E/∂a = (g11, g12, g22), as the three vertex blocks (x0, x1, x2): the
/// gradient of E(a(x)) without forming J_a.
#[inline]
pub fn metric_gradient(
    g: &Vector3<f64>,
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
) -> [Vector3<f64>; 3] {
    metric_gradient_of(&(*g).into(), &(*e1).into(), &(*e2).into()).map(Vector3::from)
}

/// [`metric_gradient`] over any [`Real`].
#[inline(always)]
pub(crate) fn metric_gradient_of<T: Real>(g: &Vec3<T>, e1: &Vec3<T>, e2: &Vec3<T>) -> [Vec3<T>; 3] {
    let g1 = add(&scale(e1, T::cst(2.0) * g[0]), &scale(e2, g[1]));
    let g2 = add(&scale(e1, g[1]), &scale(e2, T::cst(2.0) * g[2]));
    let s = add(&g1, &g2);
    [[-s[0], -s[1], -s[2]], g1, g2]
}

/// Adds Σ_k g_k ∇²a_k to the (x0, x1, x2) block (the first 9 rows and columns) of `h`.
/// a is quadratic in the positions, so this is constant: (Sᵀ C S) ⊗ I with
/// C = [[2g11, g12], [g12, 2g22]] and S the selector of (e1, e2) from (x0, x1, x2).
#[inline]
pub fn add_metric_hessian<const N: usize>(g: &Vector3<f64>, h: &mut SMatrix<f64, N, N>) {
    let sel = [(-1.0, -1.0), (1.0, 0.0), (0.0, 1.0)];
    for (i, si) in sel.iter().enumerate() {
        for (j, sj) in sel.iter().enumerate() {
            let c = 2.0 * g[0] * si.0 * sj.0
                + g[1] * (si.0 * sj.1 + si.1 * sj.0)
                + 2.0 * g[2] * si.1 * sj.1;
            for t in 0..3 {
                h[(3 * i + t, 3 * j + t)] += c;
            }
        }
    }
}
