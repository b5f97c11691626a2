//! Triangle meshes for thin-shell simulation.
//!
//! A [`Mesh`] holds f64 vertex positions (m), consistently oriented triangles and their
//! face-based connectivity ([`Topology`]), built once by [`Mesh::new`], which validates the
//! input, drops unreferenced vertices and fixes the orientation. [`io`] reads and writes OBJ,
//! [`geometry`] computes face normals, areas and mid-edge normals, [`generators`] builds
//! deterministic test meshes.
//!
//! Conventions (shared by all thinshell crates):
//! - a face `[i, j, k]` has normal `(x_j − x_i) × (x_k − x_i)`; after [`Mesh::new`] all faces
//!   of a connected component agree (the majority orientation of the input is kept, ties keep
//!   the lowest-index face's orientation; [`BuildReport`] lists flipped faces);
//! - local edge `e ∈ {0, 1, 2}` of a face is the edge **opposite** local vertex `e`; across it
//!   lie the neighbour [`Topology::face_neighbors`] and the "flap" vertex
//!   [`Topology::flap_vertices`] (`None` on the boundary) — the bending stencil;
//! - typed indices [`VertexId`], [`FaceId`], [`EdgeId`] (`u32` inside, `.idx()` for slices).
//!
//! Errors: every fallible function returns [`MeshError`], which names the offending face,
//! vertex or edge in the caller's numbering; bad input never panics.
//!
//! Load, fix, query and write:
//!
//! ```
//! use thinshell_mesh::{geometry, io, FaceId, Mesh};
//!
//! // A unit square as two triangles, the second one wound the wrong way round.
//! let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 4 3\n";
//! let mesh: Mesh = io::read_obj(obj.as_bytes())?;
//! assert_eq!(mesh.build_report().n_flipped(), 1);
//!
//! // Query the connectivity: face 0's neighbour across its local edge 1 (opposite vertex 1).
//! let topo = mesh.topology();
//! assert_eq!(topo.face_neighbors(FaceId(0))[1], Some(FaceId(1)));
//! assert_eq!(topo.boundary_vertices().len(), 4);
//! let normals = geometry::face_normals(&mesh, mesh.positions());
//! assert!((normals[1].z - 1.0).abs() < 1e-15);
//!
//! // Write it back.
//! let mut out = Vec::new();
//! io::write_obj(&mesh, mesh.positions(), &mut out)?;
//! # Ok::<(), thinshell_mesh::MeshError>(())
//! ```

mod bounding_box;
mod delaunay;
pub mod diagnose;
pub mod error;
pub mod generators;
pub mod geometry;
pub mod ids;
pub mod io;
pub mod mesh;
mod orient;
pub mod topology;

/// The linear-algebra crate of the public API (positions are `nalgebra::Vector3<f64>`).
pub use nalgebra;

pub use diagnose::{Diagnosis, diagnose};
pub use error::MeshError;
pub use geometry::{
    BoundingBox, check_scale, face_areas, face_normal, face_normals, mean_edge_length,
    mid_edge_normals,
};
pub use ids::{EdgeId, FaceId, VertexId};
pub use mesh::{BuildReport, DEGENERATE_TOLERANCE, Mesh};
pub use topology::{Edge, Topology};

/// The README's example, compiled (not run) as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
