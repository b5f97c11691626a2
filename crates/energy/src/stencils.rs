//! Per-face stencils (face vertices + flap vertices, and the face's edges with their
//! orientation signs for edge-director unknowns) from the mesh topology, built once.

use crate::stencil::{EdgeAngles, FaceStencil, edge_signs};
use nalgebra::Vector3;
use thinshell_mesh::{EdgeId, FaceId, Mesh, VertexId};

/// The six stencil vertices of every face: `[i, j, k, flap_0, flap_1, flap_2]`, flap `e`
/// across local edge `e` (opposite local vertex `e`), `None` on a boundary edge.
#[derive(Clone, Debug)]
pub struct Stencils {
    vertices: Vec<[VertexId; 6]>,
    flap: Vec<[bool; 3]>,
    /// Edge of each local edge (opposite local vertex e).
    edges: Vec<[EdgeId; 3]>,
    /// σ per local edge ([`edge_signs`]).
    signs: Vec<[f64; 3]>,
}

impl Stencils {
    /// Reads the stencils of all faces of `mesh` from its topology.
    pub fn new(mesh: &Mesh) -> Stencils {
        let topo = mesh.topology();
        let (vertices, flap) = mesh
            .faces()
            .iter()
            .enumerate()
            .map(|(f, face)| {
                let flaps = topo.flap_vertices(FaceId::new(f));
                let mut v = [face[0], face[1], face[2], face[0], face[1], face[2]];
                let mut has = [false; 3];
                for e in 0..3 {
                    if let Some(w) = flaps[e] {
                        v[3 + e] = w;
                        has[e] = true;
                    }
                }
                (v, has)
            })
            .unzip();
        let edges = (0..mesh.n_faces())
            .map(|f| topo.face_edges(FaceId::new(f)))
            .collect();
        Stencils {
            vertices,
            flap,
            edges,
            signs: edge_signs(mesh),
        }
    }

    /// The edges of face `f` in local-edge order.
    pub fn edges(&self, f: usize) -> &[EdgeId; 3] {
        &self.edges[f]
    }

    /// The edge angles of face `f` from the per-edge angles `phi` (rad, one per mesh edge,
    /// length checked by the caller), with the face's orientation signs.
    pub fn angles(&self, f: usize, phi: &[f64]) -> EdgeAngles {
        let e = &self.edges[f];
        EdgeAngles {
            phi: [phi[e[0].idx()], phi[e[1].idx()], phi[e[2].idx()]],
            sigma: self.signs[f],
        }
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.vertices.len()
    }

    /// Stencil vertex ids of face `f`; slot `3 + e` holds face vertex `e` when `!flap(f)[e]`.
    pub fn vertices(&self, f: usize) -> &[VertexId; 6] {
        &self.vertices[f]
    }

    /// Which flap vertices of face `f` exist.
    pub fn flap(&self, f: usize) -> [bool; 3] {
        self.flap[f]
    }

    /// Whether stencil slot `s` (0..6) of face `f` is a real vertex.
    pub fn slot_present(&self, f: usize, s: usize) -> bool {
        s < 3 || self.flap[f][s - 3]
    }

    /// The kernel stencil of face `f` at positions `x` (length checked by the caller; a
    /// missing flap slot repeats the opposite face vertex so that it stays finite), with all
    /// edge angles 0 and the face's orientation signs.
    pub fn stencil(&self, f: usize, x: &[Vector3<f64>]) -> FaceStencil {
        self.stencil_with(
            f,
            x,
            EdgeAngles {
                phi: [0.0; 3],
                sigma: self.signs[f],
            },
        )
    }

    /// [`Stencils::stencil`] with the edge angles `phi` (rad, one per mesh edge, length checked
    /// by the caller).
    pub fn stencil_at(&self, f: usize, x: &[Vector3<f64>], phi: &[f64]) -> FaceStencil {
        self.stencil_with(f, x, self.angles(f, phi))
    }

    fn stencil_with(&self, f: usize, x: &[Vector3<f64>], angles: EdgeAngles) -> FaceStencil {
        let v = &self.vertices[f];
        FaceStencil {
            x: [
                x[v[0].idx()],
                x[v[1].idx()],
                x[v[2].idx()],
                x[v[3].idx()],
                x[v[4].idx()],
                x[v[5].idx()],
            ],
            flap: self.flap[f],
            angles,
        }
    }
}
