//! Squared distances of the two contact pair kinds, classified by their closest features, with
//! exact gradients and Hessians.
//!
//! A pair is four points, `x = [x0, x1, x2, x3]`, flat as 12 coordinates (vertex-major):
//! point–triangle `[p, t0, t1, t2]`, edge–edge `[a0, a1, b0, b1]`. The squared distance of a
//! pair is realised by one [`DistanceType`] (its closest features); within a type it is a smooth
//! rational function of the 12 coordinates, and across type boundaries it is C¹ (values and
//! gradients agree on the boundary, Hessians jump).

use nalgebra::{SMatrix, SVector, Vector3};
use thinshell_energy::material::dual::DualN;

/// The four points of a contact pair (point–triangle `[p, t0, t1, t2]`, edge–edge
/// `[a0, a1, b0, b1]`), in metres.
pub type PairPoints = [Vector3<f64>; 4];

/// The closest features that realise a pair's distance, as local indices into its four points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DistanceType {
    /// Two points `[i, j]`: |xi − xj|².
    PointPoint([usize; 2]),
    /// A point and a segment interior `[p, e0, e1]`: |(xp − xe0) × (xe1 − xe0)|² / |xe1 − xe0|².
    PointEdge([usize; 3]),
    /// Point 0 and the interior of triangle 1–2–3: ((x0 − x1)·n)² / |n|², n = (x2 − x1) × (x3 − x1).
    PointTriangle,
    /// The interiors of segments 0–1 and 2–3: ((x0 − x2)·n)² / |n|², n = (x1 − x0) × (x3 − x2).
    EdgeEdge,
}

/// A scalar of a pair with its gradient and Hessian in the pair's 12 coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairDerivatives {
    /// The value.
    pub value: f64,
    /// ∂/∂x, vertex-major over the four points.
    pub gradient: SVector<f64, 12>,
    /// ∂²/∂x² (symmetric).
    pub hessian: SMatrix<f64, 12, 12>,
}

/// The closest features of a point and a segment (`u` = the foot's parameter along it).
fn point_segment_type(x: &PairPoints, p: usize, a: usize, b: usize) -> DistanceType {
    let e = x[b] - x[a];
    let ee = e.norm_squared();
    if ee == 0.0 {
        return DistanceType::PointPoint([p, a]);
    }
    let u = (x[p] - x[a]).dot(&e) / ee;
    if u <= 0.0 {
        DistanceType::PointPoint([p, a])
    } else if u >= 1.0 {
        DistanceType::PointPoint([p, b])
    } else {
        DistanceType::PointEdge([p, a, b])
    }
}

/// The closest features of point `[p, t0, t1, t2][0]` and the triangle: its interior when the
/// point projects inside, else the nearest of the three edges (or their end points).
pub fn point_triangle_type(x: &PairPoints) -> DistanceType {
    let e1 = x[2] - x[1];
    let e2 = x[3] - x[1];
    let w = x[0] - x[1];
    let n = e1.cross(&e2);
    let nn = n.norm_squared();
    if nn > 0.0 {
        // Barycentric coordinates of the projection: w = β1 e1 + β2 e2 + γ n.
        let b1 = w.cross(&e2).dot(&n) / nn;
        let b2 = e1.cross(&w).dot(&n) / nn;
        if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 {
            return DistanceType::PointTriangle;
        }
    }
    nearest_of(
        x,
        [
            point_segment_type(x, 0, 1, 2),
            point_segment_type(x, 0, 2, 3),
            point_segment_type(x, 0, 3, 1),
        ],
    )
}

/// The relative threshold on sin²θ of the angle between two edges below which they are treated
/// as parallel (their distance is then realised on the boundary: an end point against the
/// other edge). The interior formula loses accuracy as 1/sin θ; the edge–edge mollifier makes the
/// barrier vanish well above this threshold, so the switch does not show in the energy.
pub const PARALLEL_SIN2: f64 = 1e-10;

/// The closest features of segments `[a0, a1]` and `[b0, b1]`: both interiors when the closest
/// points of the two lines lie inside both segments (and they are not parallel), else the nearest
/// of the four end-point–segment pairs.
pub fn edge_edge_type(x: &PairPoints) -> DistanceType {
    let d1 = x[1] - x[0];
    let d2 = x[3] - x[2];
    let r = x[0] - x[2];
    let a = d1.norm_squared();
    let b = d1.dot(&d2);
    let e = d2.norm_squared();
    let c = d1.dot(&r);
    let f = d2.dot(&r);
    let denom = d1.cross(&d2).norm_squared();
    if denom > PARALLEL_SIN2 * a * e {
        let s = (b * f - c * e) / denom;
        let t = (a * f - b * c) / denom;
        if s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0 {
            return DistanceType::EdgeEdge;
        }
    }
    nearest_of(
        x,
        [
            point_segment_type(x, 0, 2, 3),
            point_segment_type(x, 1, 2, 3),
            point_segment_type(x, 2, 0, 1),
            point_segment_type(x, 3, 0, 1),
        ],
    )
}

fn nearest_of<const K: usize>(x: &PairPoints, types: [DistanceType; K]) -> DistanceType {
    let mut best = types[0];
    let mut best_d = distance2_of_type(x, best);
    for &t in &types[1..] {
        let d = distance2_of_type(x, t);
        if d < best_d {
            best = t;
            best_d = d;
        }
    }
    best
}

/// The squared distance of `x` for the given closest features, in m².
pub fn distance2_of_type(x: &PairPoints, ty: DistanceType) -> f64 {
    match ty {
        DistanceType::PointPoint([i, j]) => (x[i] - x[j]).norm_squared(),
        DistanceType::PointEdge([p, a, b]) => {
            let e = x[b] - x[a];
            (x[p] - x[a]).cross(&e).norm_squared() / e.norm_squared()
        }
        DistanceType::PointTriangle => {
            let n = (x[2] - x[1]).cross(&(x[3] - x[1]));
            let s = (x[0] - x[1]).dot(&n);
            s * s / n.norm_squared()
        }
        DistanceType::EdgeEdge => {
            let n = (x[1] - x[0]).cross(&(x[3] - x[2]));
            let s = (x[0] - x[2]).dot(&n);
            s * s / n.norm_squared()
        }
    }
}

/// Squared point–triangle distance of `[p, t0, t1, t2]` and its closest features.
pub fn point_triangle_distance2(x: &PairPoints) -> (f64, DistanceType) {
    let ty = point_triangle_type(x);
    (distance2_of_type(x, ty), ty)
}

/// Squared segment–segment distance of `[a0, a1, b0, b1]` and its closest features.
pub fn edge_edge_distance2(x: &PairPoints) -> (f64, DistanceType) {
    let ty = edge_edge_type(x);
    (distance2_of_type(x, ty), ty)
}

type D12 = DualN<12>;

fn dual_points(x: &PairPoints) -> [[D12; 3]; 4] {
    std::array::from_fn(|i| std::array::from_fn(|k| D12::variable(x[i][k], 3 * i + k)))
}

fn sub(a: &[D12; 3], b: &[D12; 3]) -> [D12; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: &[D12; 3], b: &[D12; 3]) -> D12 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: &[D12; 3], b: &[D12; 3]) -> [D12; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The squared distance for the given closest features as a second-order dual number.
pub(crate) fn distance2_dual(x: &PairPoints, ty: DistanceType) -> D12 {
    let v = dual_points(x);
    match ty {
        DistanceType::PointPoint([i, j]) => {
            let d = sub(&v[i], &v[j]);
            dot(&d, &d)
        }
        DistanceType::PointEdge([p, a, b]) => {
            let e = sub(&v[b], &v[a]);
            let c = cross(&sub(&v[p], &v[a]), &e);
            dot(&c, &c) * dot(&e, &e).recip()
        }
        DistanceType::PointTriangle => {
            let n = cross(&sub(&v[2], &v[1]), &sub(&v[3], &v[1]));
            let s = dot(&sub(&v[0], &v[1]), &n);
            s * s * dot(&n, &n).recip()
        }
        DistanceType::EdgeEdge => {
            let n = cross(&sub(&v[1], &v[0]), &sub(&v[3], &v[2]));
            let s = dot(&sub(&v[0], &v[2]), &n);
            s * s * dot(&n, &n).recip()
        }
    }
}

/// The squared distance for the given closest features with its exact gradient and Hessian in
/// the 12 coordinates (m², m, dimensionless).
pub fn distance2_derivatives(x: &PairPoints, ty: DistanceType) -> PairDerivatives {
    let d = distance2_dual(x, ty);
    PairDerivatives {
        value: d.v,
        gradient: d.g,
        hessian: d.h,
    }
}
