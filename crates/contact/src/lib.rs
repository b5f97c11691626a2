//! Contact (model.md §7), every line of it: the maths of one pair, the candidates of a mesh, the
//! contact term of a shell and its step limit, start checks and statistics.
//!
//! Pure functions on the four points of a contact pair:
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
//!
//! The contact term of a shell built on them:
//!
//! - [`term`]: [`Contact`] — self-contact and obstacles as an IPC barrier energy with exact
//!   gradient and Hessian, the collision-free step limit (CCD), the start check, statistics;
//! - [`obstacle`]: rigid [`Obstacle`]s (planes, spheres, triangle meshes);
//! - [`stiffness`]: the adaptive barrier stiffness κ;
//! - [`pattern`]: the Hessian pattern widened by the couplings of nearby self-contact pairs.
//!
//! Units: positions and distances in m; the barrier in m² (an energy once multiplied by a
//! stiffness in J/m²).

pub mod barrier;
pub mod broad_phase;
pub mod ccd;
pub mod distance;
pub mod intersection;
pub mod mollifier;
pub mod obstacle;
pub mod pair;
pub mod pattern;
pub mod stiffness;
pub mod term;

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
pub use obstacle::Obstacle;
pub use pair::{BarrierGeometry, PairBarrier, PairKind, pair_barrier, pair_energy, pair_gap};
pub use term::{Contact, ContactError, ContactRunState, ContactSettings, ContactStats};
