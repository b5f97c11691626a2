//! Contact maths (model.md §7): pure functions on the four points of a contact pair.
//!
//! - [`distance`]: point–triangle and edge–edge squared distances classified by their closest
//!   features ([`DistanceType`]), with exact gradients and Hessians;
//! - [`barrier`](mod@barrier): IPC's smoothly clamped log barrier b(g, ĝ);
//! - [`mollifier`](mod@mollifier): the edge–edge mollifier for nearly parallel edges;
//! - [`pair`]: one pair's barrier energy on its gap (distance minus a thickness offset), with
//!   exact gradient and Hessian, optionally projected to PSD;
//! - [`ccd`]: conservative continuous collision detection (additive CCD) along a linear step;
//! - [`intersection`]: segment–triangle and triangle–triangle intersection tests;
//! - [`broad_phase`]: candidate pairs of a triangle mesh from a spatial hash of bounding boxes.
//!
//! Units: positions and distances in m; the barrier in m² (an energy once multiplied by a
//! stiffness in J/m²).

pub mod barrier;
pub mod broad_phase;
pub mod ccd;
pub mod distance;
pub mod intersection;
pub mod mollifier;
pub mod pair;

pub use barrier::barrier;
pub use broad_phase::{
    Aabb, CandidatePairs, CrossPairs, StaticMesh, candidate_pairs, candidate_pairs_against,
    filter_candidate_pairs, filter_cross_pairs, overlapping_pairs,
};
pub use ccd::{CcdSettings, additive_ccd};
pub use distance::{
    DistanceType, PairDerivatives, PairPoints, distance2_derivatives, distance2_of_type,
    edge_edge_distance2, edge_edge_type, point_triangle_distance2, point_triangle_type,
};
pub use intersection::{segment_crosses_triangle, triangles_intersect};
pub use mollifier::{mollifier, mollifier_threshold};
pub use pair::{BarrierGeometry, PairBarrier, PairKind, pair_barrier, pair_energy, pair_gap};
