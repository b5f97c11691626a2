//! Directors of boundary edges. Free edges (model.md §1.2): the quadratic height function over
//! the face plane through the six stencil points — the face vertices and, across each edge, its
//! flap vertex or, on a free edge, a nearby mesh vertex chosen once by [`crate::Stencils`] —
//! gives the second moments II_i of the three edges; a free edge uses its II_i in place of the
//! director angle it no longer has. Clamped edges (§1.3): the director is a prescribed unit
//! vector, the tilt its angle from the face normal about the edge. Mirror edges (§1.4): the
//! same with the director in the symmetry plane, perpendicular to the edge.
//!
//! Written once over [`Scalar`], evaluated in f64 for values and in dual numbers (first order
//! for gradients, second order for Hessians) over the 15 coordinates of x_1 … x_5 relative to
//! x_0 for the exact derivatives.

use crate::material::dual::{DualN, Scalar};
use nalgebra::{SMatrix, SVector};

type V<T> = [T; 3];

#[inline]
fn sub<T: Scalar>(a: &V<T>, b: &V<T>) -> V<T> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn dot<T: Scalar>(a: &V<T>, b: &V<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn cross<T: Scalar>(a: &V<T>, b: &V<T>) -> V<T> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// What the fit needs of the face alone, from e1 = x_1 − x_0 and e2 = x_2 − x_0: the metric
/// (g11, g12, g22), 1/det(a) = 1/|e1 × e2|² and n = e1 × e2.
struct FaceTerms<T> {
    g: [T; 3],
    inv: T,
    n: V<T>,
}

fn face_terms<T: Scalar>(e1: &V<T>, e2: &V<T>) -> FaceTerms<T> {
    let (g11, g12, g22) = (dot(e1, e1), dot(e1, e2), dot(e2, e2));
    let det = g11 * g22 - g12 * g12;
    FaceTerms {
        g: [g11, g12, g22],
        inv: det.recip(),
        n: cross(e1, e2),
    }
}

/// (ξ, η, z) of an outer point at `p` relative to x_0: its affine coordinates over the face
/// (x_0 + ξ e1 + η e2 is its foot on the face plane) and its height above the plane times
/// |e1 × e2|.
fn outer_point<T: Scalar>(f: &FaceTerms<T>, e1: &V<T>, e2: &V<T>, p: &V<T>) -> [T; 3] {
    let [g11, g12, g22] = f.g;
    let (u, v) = (dot(e1, p), dot(e2, p));
    let xi = (g22 * u - g12 * v) * f.inv;
    let eta = (g11 * v - g12 * u) * f.inv;
    [xi, eta, dot(&f.n, p)]
}

/// Row r of the fit's 3×3 system: the three edge bubbles λ_{l+1}λ_{l+2} (l = 0, 1, 2) at an
/// outer point with affine coordinates (ξ, η).
fn bubbles<T: Scalar>(xi: T, eta: T) -> [T; 3] {
    let l0 = T::cst(1.0) - xi - eta;
    [xi * eta, eta * l0, xi * l0]
}

/// II_i^fit · |e1 × e2| (m³) of the quadratic height function through the face vertices and the
/// three outer points `q` = (ξ, η, z) of [`outer_point`].
///
/// Over the face plane, in the affine coordinates of the face, the quadratics vanishing at the
/// three vertices are z = Σ_l c_l λ_{l+1}λ_{l+2}; the three outer heights fix c (M c = z/|e1 ×
/// e2|, M the bubbles), and b = ∇²z = −[[II_0 + II_1, II_0], [II_0, II_0 + II_2]] gives II_i =
/// c_{i+1} + c_{i+2} − c_i. By Cramer's rule c_l det M = Σ_r z_r C_rl with C the cofactors of M.
/// Exact for a quadratic height function; for a smooth surface the error is O(h³), a relative
/// O(h) in b. Non-finite when the outer points are degenerate for the fit (on a conic through
/// the face vertices).
fn fit_times_area<T: Scalar>(q: &[[T; 3]; 3], i: usize) -> T {
    let m: [[T; 3]; 3] = std::array::from_fn(|r| bubbles(q[r][0], q[r][1]));
    let cof = |r: usize, l: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (l1, l2) = ((l + 1) % 3, (l + 2) % 3);
        m[r1][l1] * m[r2][l2] - m[r1][l2] * m[r2][l1]
    };
    let c: [[T; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|l| cof(r, l)));
    let det = m[0][0] * c[0][0] + m[1][0] * c[1][0] + m[2][0] * c[2][0];
    // Σ_l s_l c_l det M with s = +1 on l ≠ i, −1 on l = i.
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let row = |r: usize| c[r][j] + c[r][k] - c[r][i];
    (q[0][2] * row(0) + q[1][2] * row(1) + q[2][2] * row(2)) * det.recip()
}

/// d_i = |e1 × e2| / |x_{i+2} − x_{i+1}| (m) and w_i = 1/(2 d_i |e1 × e2|) (m⁻³), from e1, e2.
fn edge_scale<T: Scalar>(e1: &V<T>, e2: &V<T>, i: usize) -> (T, T) {
    let n = cross(e1, e2);
    let e = match i {
        0 => sub(e2, e1),
        1 => e2.map(|c| T::cst(0.0) - c),
        _ => *e1,
    };
    let area2 = dot(&n, &n);
    let len_n = area2.sqrt();
    let len_e = dot(&e, &e).sqrt();
    (len_n * len_e.recip(), len_e * (area2 * T::cst(2.0)).recip())
}

/// The altitude d_i (m) and the half-angle β_i (rad) of fitted free edge i: d_i =
/// |e1 × e2| / |x_{i+2} − x_{i+1}| and β_i = atan(II_i^fit / (2 d_i)), which takes the place of
/// θ_i/2 in α_i = β_i + σ_i φ_i ([`edge_moment`]).
///
/// Uses the positions only through differences, so its derivatives sum to zero over the six
/// points (the caller takes x_0 as a constant and recovers its derivatives from that).
pub(crate) fn fitted_edge_angle<T: Scalar>(x: &[V<T>; 6], i: usize) -> (T, T) {
    let (e1, e2) = (sub(&x[1], &x[0]), sub(&x[2], &x[0]));
    let f = face_terms(&e1, &e2);
    let q = std::array::from_fn(|r| outer_point(&f, &e1, &e2, &sub(&x[3 + r], &x[0])));
    let (d, w) = edge_scale(&e1, &e2, i);
    (d, atan(fit_times_area(&q, i) * w))
}

/// [`fitted_edge_angle`] with the gradient and Hessian of d and β over the 15 coordinates of
/// x_1 … x_5 relative to x_0 (x_k − x_0 for k = 1 … 5, three each), in two levels of dual
/// numbers: each outer point's (ξ, η, z) depends on e1, e2 and its own position only (9
/// variables) and (d, w) on e1, e2 (6); β is a function of those ten, whose Hessian
/// Σ_kl β_kl ∇q_k ∇q_lᵀ + Σ_k β_k ∇²q_k is chained from them. The values are those of
/// [`fitted_edge_angle`] to the last bit (the same operations on the same numbers).
#[allow(clippy::type_complexity)]
pub(crate) fn fitted_edge_angle_hessian(
    x: &[V<f64>; 6],
    i: usize,
) -> (
    f64,
    SVector<f64, 15>,
    SMatrix<f64, 15, 15>,
    f64,
    SVector<f64, 15>,
    SMatrix<f64, 15, 15>,
) {
    let rel = |v: usize| sub(&x[v], &x[0]);
    // Level one: e1, e2 as variables 0..6, the outer point as 6..9.
    type D9 = DualN<9>;
    let var9 =
        |p: V<f64>, at: usize| -> V<D9> { std::array::from_fn(|c| D9::variable(p[c], at + c)) };
    let (e1, e2) = (var9(rel(1), 0), var9(rel(2), 3));
    let f = face_terms(&e1, &e2);
    let q: [[D9; 3]; 3] = std::array::from_fn(|r| outer_point(&f, &e1, &e2, &var9(rel(3 + r), 6)));
    type D6 = DualN<6>;
    let var6 =
        |p: V<f64>, at: usize| -> V<D6> { std::array::from_fn(|c| D6::variable(p[c], at + c)) };
    let (e1, e2) = (var6(rel(1), 0), var6(rel(2), 3));
    {
        let (d, w) = edge_scale(&e1, &e2, i);
        // Level two: β over (ξ, η, z) of the three outer points (0..9) and w (9).
        type D10 = DualN<10>;
        let q2: [[D10; 3]; 3] =
            std::array::from_fn(|r| std::array::from_fn(|c| D10::variable(q[r][c].v, 3 * r + c)));
        let beta = atan(fit_times_area(&q2, i) * D10::variable(w.v, 9));
        // ∇q_k over the 15 relative coordinates (e1, e2 at 0..6, outer point r at 6 + 3r).
        let mut jac = SMatrix::<f64, 10, 15>::zeros();
        for r in 0..3 {
            for c in 0..3 {
                let k = 3 * r + c;
                for a in 0..6 {
                    jac[(k, a)] = q[r][c].g[a];
                }
                for a in 0..3 {
                    jac[(k, 6 + 3 * r + a)] = q[r][c].g[6 + a];
                }
            }
        }
        for a in 0..6 {
            jac[(9, a)] = w.g[a];
        }
        let gb = jac.transpose() * beta.g;
        let mut hb = jac.transpose() * beta.h * jac;
        let idx = |r: usize, a: usize| if a < 6 { a } else { 6 + 3 * r + a - 6 };
        for r in 0..3 {
            for c in 0..3 {
                let bk = beta.g[3 * r + c];
                let h = &q[r][c].h;
                for b in 0..9 {
                    for a in 0..9 {
                        hb[(idx(r, a), idx(r, b))] += bk * h[(a, b)];
                    }
                }
            }
        }
        let mut hd = SMatrix::<f64, 15, 15>::zeros();
        let mut gd = SVector::<f64, 15>::zeros();
        for b in 0..6 {
            gd[b] = d.g[b];
            for a in 0..6 {
                hb[(a, b)] += beta.g[9] * w.h[(a, b)];
                hd[(a, b)] = d.h[(a, b)];
            }
        }
        (d.v, gd, hd, beta.v, gb, hb)
    }
}

/// The altitude d_i (m) and the half-angle β_i (rad) of clamped edge i with prescribed unit
/// director `nc` (model.md §1.3): β_i = atan(t), t the tangent of the signed angle from the face
/// normal to `nc` about ê = (x_{i+2} − x_{i+1})/|·| — the dihedral angle of §1.1 with the clamp's
/// director in place of the neighbour's normal: t = ((n × nc)·ê) / (n·nc), n = e1 × e2. Needs
/// the face within 90° of the clamp (n·nc > 0), as any clamp that holds. Uses the positions
/// only through differences, as [`fitted_edge_angle`].
pub(crate) fn clamped_edge_angle<T: Scalar>(x: &[V<T>; 6], i: usize, nc: [f64; 3]) -> (T, T) {
    director_edge_angle(x, i, |_| nc.map(T::cst))
}

/// (d_i, β_i) of mirror edge i on the symmetry plane with unit normal `p` (model.md §1.4): the
/// clamp of [`clamped_edge_angle`] with the director c = p × e, which lies in the plane and is
/// perpendicular to the edge e = x_{i+2} − x_{i+1} (the mirrored shell's face across the edge
/// has the mirrored normal, and c bisects the two). t is unchanged by the scale and sign of c,
/// so c need not be normalised or turned towards the face: t is the tangent of the angle from
/// n to whichever of ±c lies within 90° of it, and moves with the edge. Depends on the face's
/// vertices only, through differences.
pub(crate) fn mirrored_edge_angle<T: Scalar>(x: &[V<T>; 6], i: usize, p: [f64; 3]) -> (T, T) {
    director_edge_angle(x, i, |e| cross(&p.map(T::cst), e))
}

/// (d_i, atan(t)) with t = ((n × c)·ê) / (n·c) for the director direction c = `director(e)`
/// (any positive multiple of the unit director; e = x_{i+2} − x_{i+1}).
fn director_edge_angle<T: Scalar>(
    x: &[V<T>; 6],
    i: usize,
    director: impl Fn(&V<T>) -> V<T>,
) -> (T, T) {
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let n = cross(&sub(&x[1], &x[0]), &sub(&x[2], &x[0]));
    let e = sub(&x[k], &x[j]);
    let nc = director(&e);
    let len_e = dot(&e, &e).sqrt();
    let d = dot(&n, &n).sqrt() * len_e.recip();
    let t = dot(&cross(&n, &nc), &e) * (dot(&n, &nc) * len_e).recip();
    (d, atan(t))
}

/// II_i = 2 d f(β + σφ) (m) with f = `angle_fn`, which returns (f, f′, f″) at its argument.
/// The f64 value of the boundary edges; their derivatives combine the same pieces in
/// `EdgeDirector::boundary_moment`, which computes 2 (d f(α)) in the same order so that both
/// give the same value to the last bit.
pub(crate) fn edge_moment(
    d: f64,
    beta: f64,
    sigma_phi: f64,
    angle_fn: impl Fn(f64) -> (f64, f64, f64),
) -> f64 {
    d * angle_fn(beta + sigma_phi).0 * 2.0
}

#[inline]
fn atan<T: Scalar>(t: T) -> T {
    let tv = t.value();
    let t2 = 1.0 + tv * tv;
    t.apply(tv.atan(), 1.0 / t2, -2.0 * tv / (t2 * t2))
}

/// The bubble matrix of the fit (rows: outer points, see [`bubbles`]) and det(a) = |e1 × e2|²,
/// for [`fit_quality`] (its own arithmetic: the stencil choice must not move with the kernel's).
fn system(x: &[V<f64>; 6]) -> ([[f64; 3]; 3], f64) {
    let e1 = sub(&x[1], &x[0]);
    let e2 = sub(&x[2], &x[0]);
    let (g11, g12, g22) = (dot(&e1, &e1), dot(&e1, &e2), dot(&e2, &e2));
    let det = g11 * g22 - g12 * g12;
    let inv = det.recip();
    let mut m = [[0.0; 3]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        let p = sub(&x[3 + r], &x[0]);
        let (u, v) = (dot(&e1, &p), dot(&e2, &p));
        let xi = (g22 * u - g12 * v) * inv;
        let eta = (g11 * v - g12 * u) * inv;
        let l0 = 1.0 - xi - eta;
        *row = [xi * eta, eta * l0, xi * l0];
    }
    (m, det)
}

fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// How well the outer points of `x` determine the fit (dimensionless, 0 when they cannot):
/// |det| of the bubble matrix with each row scaled by 1/(1 + |λ|²) of its point, so that far
/// points (larger extrapolation error) are not preferred for their larger bubble values.
pub(crate) fn fit_quality(x: &[V<f64>; 6]) -> f64 {
    let (mut m, det) = system(x);
    // A degenerate (or NaN) face cannot carry a fit.
    if det.is_nan() || det <= 0.0 {
        return 0.0;
    }
    let e1 = sub(&x[1], &x[0]);
    let e2 = sub(&x[2], &x[0]);
    let (g11, g12, g22) = (dot(&e1, &e1), dot(&e1, &e2), dot(&e2, &e2));
    for (r, row) in m.iter_mut().enumerate() {
        let p = sub(&x[3 + r], &x[0]);
        let (u, v) = (dot(&e1, &p), dot(&e2, &p));
        let xi = (g22 * u - g12 * v) / det;
        let eta = (g11 * v - g12 * u) / det;
        let l0 = 1.0 - xi - eta;
        let w = 1.0 / (1.0 + xi * xi + eta * eta + l0 * l0);
        for e in row.iter_mut() {
            *e *= w;
        }
    }
    let q = det3(&m).abs();
    if q.is_finite() { q } else { 0.0 }
}
