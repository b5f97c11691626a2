//! The barrier energy of one contact pair: b(d − offset, d̂) on its closest-feature distance d,
//! times the mollifier for edge pairs, with exact gradient and Hessian.

use super::barrier::barrier;
use super::distance::{
    DistanceType, PairDerivatives, PairPoints, distance2_dual, distance2_of_type, edge_edge_type,
    point_triangle_type,
};
use super::mollifier::mollifier;
use thinshell_energy::material::dual::DualN;
use thinshell_energy::project_psd;

/// The kind of a contact pair, which fixes the meaning of its four points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairKind {
    /// `[p, t0, t1, t2]`: a vertex and a triangle.
    PointTriangle,
    /// `[a0, a1, b0, b1]`: two edges, with their mollifier threshold e× (m⁴,
    /// [`super::mollifier_threshold`]; 0 switches the mollifier off).
    EdgeEdge {
        /// e× of the pair, m⁴.
        mollifier_threshold: f64,
    },
}

/// The barrier's geometry: activation distance and thickness offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarrierGeometry {
    /// d̂ (m, > 0): pairs whose gap is below it are active.
    pub activation: f64,
    /// The offset (m, ≥ 0) subtracted from the mid-surface distance, so that the gap is measured
    /// between the faces' surfaces: half the sum of the two thicknesses for shells in contact with
    /// each other, half the thickness against an obstacle, 0 for mid-surface contact.
    pub offset: f64,
}

/// The barrier of a pair at one configuration.
// Returned by value per pair in the assembly loop: boxing the active case would allocate per pair.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairBarrier {
    /// Gap ≥ d̂: no energy, no force.
    Inactive,
    /// 0 < gap < d̂: energy (m², times the stiffness κ in J/m² for joules), gradient and Hessian.
    Active(PairDerivatives),
    /// Gap ≤ 0: the pair touches or interpenetrates (infinite energy).
    Penetrated,
}

fn closest_type(x: &PairPoints, kind: PairKind) -> DistanceType {
    match kind {
        PairKind::PointTriangle => point_triangle_type(x),
        PairKind::EdgeEdge { .. } => edge_edge_type(x),
    }
}

/// The gap of a pair (m): its closest-feature distance minus the offset.
pub fn pair_gap(x: &PairPoints, kind: PairKind, offset: f64) -> f64 {
    distance2_of_type(x, closest_type(x, kind)).sqrt() - offset
}

/// The squared cross product of an edge pair's directions, c = |(a1 − a0) × (b1 − b0)|² (m⁴).
fn edge_cross2(x: &PairPoints) -> f64 {
    (x[1] - x[0]).cross(&(x[3] - x[2])).norm_squared()
}

/// The pair's barrier energy (m², per unit stiffness): m(c)·b(gap, d̂); +∞ when penetrated.
pub fn pair_energy(x: &PairPoints, kind: PairKind, geometry: BarrierGeometry) -> f64 {
    let gap = pair_gap(x, kind, geometry.offset);
    let (b, _, _) = barrier(gap, geometry.activation);
    if b == 0.0 || b.is_infinite() {
        return b;
    }
    match kind {
        PairKind::PointTriangle => b,
        PairKind::EdgeEdge {
            mollifier_threshold,
        } => mollifier(edge_cross2(x), mollifier_threshold).0 * b,
    }
}

/// The pair's barrier energy with its exact gradient and Hessian in the 12 coordinates (the
/// Hessian projected to PSD when `project` is set, as Newton's method needs).
pub fn pair_barrier(
    x: &PairPoints,
    kind: PairKind,
    geometry: BarrierGeometry,
    project: bool,
) -> PairBarrier {
    let ty = closest_type(x, kind);
    let gap = distance2_of_type(x, ty).sqrt() - geometry.offset;
    if gap >= geometry.activation {
        return PairBarrier::Inactive;
    }
    if gap <= 0.0 || gap.is_nan() {
        return PairBarrier::Penetrated;
    }
    let d2 = distance2_dual(x, ty);
    let gap = d2.sqrt() - DualN::constant(geometry.offset);
    let (b, db, ddb) = barrier(gap.v, geometry.activation);
    let mut e = gap.chain(b, db, ddb);
    if let PairKind::EdgeEdge {
        mollifier_threshold,
    } = kind
        && edge_cross2(x) < mollifier_threshold
    {
        let v: [[DualN<12>; 3]; 4] =
            std::array::from_fn(|i| std::array::from_fn(|k| DualN::variable(x[i][k], 3 * i + k)));
        let u: [DualN<12>; 3] = std::array::from_fn(|k| v[1][k] - v[0][k]);
        let w: [DualN<12>; 3] = std::array::from_fn(|k| v[3][k] - v[2][k]);
        let n = [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ];
        let c = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        let (m, dm, ddm) = mollifier(c.v, mollifier_threshold);
        e = c.chain(m, dm, ddm) * e;
    }
    let mut hessian = e.h;
    if project {
        project_psd(&mut hessian);
    }
    PairBarrier::Active(PairDerivatives {
        value: e.v,
        gradient: e.g,
        hessian,
    })
}
