//! Directors of boundary edges. Free edges (model.md §1.2): the quadratic height function over
//! the face plane through the six stencil points — the face vertices and, across each edge, its
//! flap vertex or, on a free edge, a nearby mesh vertex chosen once by [`crate::Stencils`] —
//! gives the second moments II_i of the three edges; a free edge uses its II_i in place of the
//! director angle it no longer has. Clamped edges (§1.3): the director is a prescribed unit
//! vector, the tilt its angle from the face normal about the edge. Mirror edges (§1.4): the
//! same with the director in the symmetry plane, perpendicular to the edge.
//!
//! Written once over [`Scalar`], evaluated in f64 for values and in second-order dual numbers
//! for the exact gradient and Hessian.

use crate::material::dual::Scalar;

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

/// The 3×3 system of the fit: row r holds the three edge bubbles λ_{l+1}λ_{l+2} (l = 0, 1, 2)
/// at outer point r (stencil slot 3 + r) in the face's affine coordinates, and `z[r]` its
/// height above the face plane times |e1 × e2|. Also returns det(a) = |e1 × e2|².
fn system<T: Scalar>(x: &[V<T>; 6]) -> ([[T; 3]; 3], [T; 3], T) {
    let e1 = sub(&x[1], &x[0]);
    let e2 = sub(&x[2], &x[0]);
    let (g11, g12, g22) = (dot(&e1, &e1), dot(&e1, &e2), dot(&e2, &e2));
    let det = g11 * g22 - g12 * g12;
    let inv = det.recip();
    let n = cross(&e1, &e2);
    let one = T::cst(1.0);
    let mut m = [[T::cst(0.0); 3]; 3];
    let mut z = [T::cst(0.0); 3];
    for r in 0..3 {
        let p = sub(&x[3 + r], &x[0]);
        let (u, v) = (dot(&e1, &p), dot(&e2, &p));
        let xi = (g22 * u - g12 * v) * inv;
        let eta = (g11 * v - g12 * u) * inv;
        let l0 = one - xi - eta;
        m[r] = [xi * eta, eta * l0, xi * l0];
        z[r] = dot(&n, &p);
    }
    (m, z, det)
}

#[inline]
fn det3<T: Scalar>(m: &[[T; 3]; 3]) -> T {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Second moments II_i (m) of the three local edges of the quadratic height function through
/// the six stencil points `x` (face vertices, then the outer point across each edge).
///
/// Over the face plane, in the affine coordinates of the face, the quadratics vanishing at the
/// three vertices are z = Σ_l c_l λ_{l+1}λ_{l+2}; the three outer heights fix c, and
/// b = ∇²z = −[[II_0 + II_1, II_0], [II_0, II_0 + II_2]] gives II_i = c_{i+1} + c_{i+2} − c_i.
/// Exact for a quadratic height function; for a smooth surface the error is O(h³), a relative
/// O(h) in b. Non-finite when the outer points are degenerate for the fit (on a conic through
/// the face vertices).
pub(crate) fn fitted_moments<T: Scalar>(x: &[V<T>; 6]) -> [T; 3] {
    let (m, z, det) = system(x);
    let inv = det3(&m).recip() * det.sqrt().recip();
    // Cramer's rule, column l replaced by z.
    let c: [T; 3] = std::array::from_fn(|l| {
        let mut ml = m;
        for r in 0..3 {
            ml[r][l] = z[r];
        }
        det3(&ml) * inv
    });
    std::array::from_fn(|i| c[(i + 1) % 3] + c[(i + 2) % 3] - c[i])
}

/// II_i (m) of fitted free edge i: 2 d_i f(α_i) with α_i = atan(II_i^fit / (2 d_i)) + σ_i φ_i
/// (`sigma_phi`), d_i = |e1 × e2| / |x_{i+2} − x_{i+1}| and f = `angle_fn`, which returns
/// (f, f′, f″) at α. One sequence of operations for values and dual numbers, so that both
/// give the same value to the last bit.
pub(crate) fn fitted_edge_moment<T: Scalar>(
    x: &[V<T>; 6],
    i: usize,
    sigma_phi: T,
    angle_fn: impl Fn(f64) -> (f64, f64, f64),
) -> T {
    let fit = fitted_moments(x)[i];
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let n = cross(&sub(&x[1], &x[0]), &sub(&x[2], &x[0]));
    let e = sub(&x[k], &x[j]);
    let d = dot(&n, &n).sqrt() * dot(&e, &e).sqrt().recip();
    let t = fit * d.recip() * T::cst(0.5);
    let tv = t.value();
    let t2 = 1.0 + tv * tv;
    let alpha = t.apply(tv.atan(), 1.0 / t2, -2.0 * tv / (t2 * t2)) + sigma_phi;
    let (f0, f1, f2) = angle_fn(alpha.value());
    d * alpha.apply(f0, f1, f2) * T::cst(2.0)
}

/// II_i (m) of clamped edge i with prescribed unit director `nc` (model.md §1.3):
/// 2 d_i f(α_i), α_i = atan(t) + σ_i φ_i, where t = tan of the signed angle from the face normal
/// to `nc` about ê = (x_{i+2} − x_{i+1})/|·| — the dihedral angle of §1.1 with the clamp's
/// director in place of the neighbour's normal: t = ((n × nc)·ê) / (n·nc), n = e1 × e2. Needs
/// the face within 90° of the clamp (n·nc > 0), as any clamp that holds.
pub(crate) fn clamped_edge_moment<T: Scalar>(
    x: &[V<T>; 6],
    i: usize,
    nc: [f64; 3],
    sigma_phi: T,
    angle_fn: impl Fn(f64) -> (f64, f64, f64),
) -> T {
    director_edge_moment(x, i, |_| nc.map(T::cst), sigma_phi, angle_fn)
}

/// II_i (m) of mirror edge i on the symmetry plane with unit normal `p` (model.md §1.4): the
/// clamp of [`clamped_edge_moment`] with the director c = p × e, which lies in the plane and is
/// perpendicular to the edge e = x_{i+2} − x_{i+1} (the mirrored shell's face across the edge
/// has the mirrored normal, and c bisects the two). t is unchanged by the scale and sign of c,
/// so c need not be normalised or turned towards the face: t is the tangent of the angle from
/// n to whichever of ±c lies within 90° of it, and moves with the edge.
pub(crate) fn mirrored_edge_moment<T: Scalar>(
    x: &[V<T>; 6],
    i: usize,
    p: [f64; 3],
    sigma_phi: T,
    angle_fn: impl Fn(f64) -> (f64, f64, f64),
) -> T {
    director_edge_moment(x, i, |e| cross(&p.map(T::cst), e), sigma_phi, angle_fn)
}

/// 2 d_i f(atan(t) + σ_i φ_i) with t = ((n × c)·ê) / (n·c) for the director direction
/// c = `director(e)` (any positive multiple of the unit director; e = x_{i+2} − x_{i+1}).
fn director_edge_moment<T: Scalar>(
    x: &[V<T>; 6],
    i: usize,
    director: impl Fn(&V<T>) -> V<T>,
    sigma_phi: T,
    angle_fn: impl Fn(f64) -> (f64, f64, f64),
) -> T {
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let n = cross(&sub(&x[1], &x[0]), &sub(&x[2], &x[0]));
    let e = sub(&x[k], &x[j]);
    let nc = director(&e);
    let len_e = dot(&e, &e).sqrt();
    let d = dot(&n, &n).sqrt() * len_e.recip();
    let t = dot(&cross(&n, &nc), &e) * (dot(&n, &nc) * len_e).recip();
    let tv = t.value();
    let t2 = 1.0 + tv * tv;
    let alpha = t.apply(tv.atan(), 1.0 / t2, -2.0 * tv / (t2 * t2)) + sigma_phi;
    let (f0, f1, f2) = angle_fn(alpha.value());
    d * alpha.apply(f0, f1, f2) * T::cst(2.0)
}

/// How well the outer points of `x` determine the fit (dimensionless, 0 when they cannot):
/// |det| of the bubble matrix with each row scaled by 1/(1 + |λ|²) of its point, so that far
/// points (larger extrapolation error) are not preferred for their larger bubble values.
pub(crate) fn fit_quality(x: &[V<f64>; 6]) -> f64 {
    let (mut m, _, det) = system(x);
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
