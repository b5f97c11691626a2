//! The plain data a per-face kernel reads: stencil positions, flap flags and edge angles, and the
//! edge orientation signs σ the edge angles need from the mesh topology.

use nalgebra::Vector3;
use thinshell_mesh::{FaceId, Mesh};

/// Edge angles of a face, in local-edge order (edge e opposite vertex e), for second fundamental
/// forms with one unknown per edge (model.md §1.1); ignored by forms without.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct EdgeAngles {
    /// φ_e (rad): rotation of edge e's director about the edge, in the edge's stored direction.
    pub phi: [f64; 3],
    /// σ_e = +1 when the edge's stored direction agrees with the face's orientation, else −1
    /// (see [`edge_signs`]).
    pub sigma: [f64; 3],
}

/// A boundary edge whose director is prescribed instead of free or fitted (edge-director
/// forms only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EdgeClamp {
    /// A clamp (model.md §1.3): the unit director (dimensionless), fixed in space.
    Held(Vector3<f64>),
    /// A mirror edge on a symmetry plane (model.md §1.4) with this unit plane normal
    /// (dimensionless): the director is the unit vector in the plane perpendicular to the edge,
    /// the director the mirrored shell would share with this one. It follows the edge.
    Mirror(Vector3<f64>),
}

/// One face's stencil. `x[0..3]`: face vertices in stored order; `x[3 + e]`: flap vertex across
/// local edge e (the edge opposite local vertex e), or on a free edge (`!flap[e]`) the vertex
/// of the free-edge fit when `ghost[e]` (read only by [`crate::EdgeDirector`], model.md §1.2),
/// else ignored; `angles`: the face's edge angles (read only by forms with edge unknowns).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceStencil {
    /// Stencil positions (m).
    pub x: [Vector3<f64>; 6],
    /// `flap[e]`: edge e is interior (has a flap vertex).
    pub flap: [bool; 3],
    /// `ghost[e]` (only where `!flap[e]`): edge e is a free edge whose director is extrapolated
    /// from the quadratic through the six stencil points, `x[3 + e]` being a nearby mesh
    /// vertex; its edge angle is then not an unknown. All false: free edges keep a free
    /// director angle (the previous, first-order treatment).
    pub ghost: [bool; 3],
    /// `clamp[e]` (only where `!flap[e]`): how the director of boundary edge e is prescribed,
    /// held fixed in space (model.md §1.3) or mirrored across a symmetry plane (§1.4); takes
    /// precedence over `ghost[e]`, whose outer vertex then still serves the fit of the face's
    /// other free edges.
    pub clamp: [Option<EdgeClamp>; 3],
    /// Edge angles and orientation signs of the face's three edges.
    pub angles: EdgeAngles,
}

impl FaceStencil {
    /// A stencil with all edge angles 0 (and signs 0: the angles are not unknowns) and no
    /// free-edge fit.
    pub fn new(x: [Vector3<f64>; 6], flap: [bool; 3]) -> FaceStencil {
        FaceStencil {
            x,
            flap,
            ghost: [false; 3],
            clamp: [None; 3],
            angles: EdgeAngles::default(),
        }
    }
}

/// σ_{f,e} for every face f and local edge e (opposite local vertex e): +1 when the edge's
/// stored direction (`Edge::vertices[0] → [1]`) is the direction f runs it
/// (`f[e+1] → f[e+2]`), else −1. The two faces of an interior edge get opposite signs on a
/// consistently oriented mesh.
pub fn edge_signs(mesh: &Mesh) -> Vec<[f64; 3]> {
    let topo = mesh.topology();
    mesh.faces()
        .iter()
        .enumerate()
        .map(|(f, face)| {
            let ids = topo.face_edges(FaceId::new(f));
            std::array::from_fn(|e| {
                if topo.edge(ids[e]).vertices[0] == face[(e + 1) % 3] {
                    1.0
                } else {
                    -1.0
                }
            })
        })
        .collect()
}
