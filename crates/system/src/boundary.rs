//! Boundary conditions: pinned vertices and coordinates, clamped edges, prescribed motion.

use nalgebra::Vector3;
use thinshell_energy::DofMap;
use thinshell_mesh::{EdgeId, Mesh, VertexId};

use thinshell_solver::SolverError;

/// A vertex whose position is a given function of time `t` (s) → position (m). The vertex is
/// removed from the unknowns; its position is set at the end time of every step.
pub struct Prescribed {
    /// The driven vertex.
    pub vertex: VertexId,
    /// Its position as a function of time.
    pub position: Box<dyn Fn(f64) -> Vector3<f64> + Send + Sync>,
}

impl std::fmt::Debug for Prescribed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Prescribed")
            .field("vertex", &self.vertex)
            .finish_non_exhaustive()
    }
}

/// Which vertex coordinates are held. Pinned coordinates are removed from the unknowns and
/// stay exactly at their initial value.
#[derive(Debug, Default)]
pub struct Boundary {
    /// Vertices fixed in all three coordinates.
    pub pinned_vertices: Vec<VertexId>,
    /// Single coordinates `(vertex, axis)` fixed (axis 0, 1, 2 = x, y, z), e.g. a support that
    /// only blocks z.
    pub pinned_coordinates: Vec<(VertexId, usize)>,
    /// Clamped edges (boundary edges). With edge-director bending (the default form) the clamp
    /// holds the edges' own vertices and their directors, which stay where they are at the
    /// mesh's positions (model.md §1.3): position and tangent plane fixed along the clamp line,
    /// second order. Without edge directors (the mid-edge average, or bending off) it holds two
    /// rows of vertices, the edges' own and every vertex of every face that touches one of them
    /// (the one-ring of the clamped vertices), which fixes the tangent plane over the first row
    /// of cells on any triangulation — first order, the clamp line sits half a cell in; at the
    /// ends of a clamp that covers only part of a boundary loop this also holds the next
    /// boundary vertex beyond each end. See [`Boundary::held_coordinates`].
    pub clamped_edges: Vec<EdgeId>,
    /// Mirror edges `(edge, axis)`: boundary edges on a symmetry plane normal to axis 0, 1, 2
    /// (x, y, z), for a model of a symmetric shell cut along its symmetry planes under loads
    /// with the same symmetry (a load on a plane carries the share of the modelled part, e.g.
    /// half of a point force on one plane). Their vertices keep that coordinate (as
    /// [`Boundary::pinned_coordinates`]), and the bending form sees the mirrored shell across
    /// the edge (model.md §1.4) instead of a free edge: with edge directors the edge's director
    /// lies in the plane, perpendicular to the edge (no angle unknown there); the mid-edge
    /// average's edge normal is the face normal projected into the plane. The rest forms of
    /// such a model come from `RestState::from_mesh_with_mirrors` ([`Boundary::mirror_normals`]).
    /// [`Boundary::symmetry_plane`] selects the edges.
    pub mirror_edges: Vec<(EdgeId, usize)>,
    /// Vertices moved along a prescribed path.
    pub prescribed: Vec<Prescribed>,
}

impl Boundary {
    /// All held `(vertex, axis)` pairs. `second_row`: clamps also hold the one-ring of the
    /// clamped vertices — for a model without edge directors, whose clamp has no other hold on
    /// the tangent plane (see [`Boundary::clamped_edges`]).
    pub fn held_coordinates(
        &self,
        mesh: &Mesh,
        second_row: bool,
    ) -> Result<Vec<(VertexId, usize)>, SolverError> {
        let mut held: Vec<(VertexId, usize)> = self.pinned_coordinates.clone();
        for &(e, axis) in &self.mirror_edges {
            let edge = mesh
                .topology()
                .edges()
                .get(e.idx())
                .ok_or(SolverError::InvalidSetting {
                    name: "mirror_edges",
                    value: e.idx() as f64,
                    requirement: "edge id out of range",
                })?;
            check_axis("mirror_edges axis", axis)?;
            held.extend(edge.vertices.map(|v| (v, axis)));
        }
        let mut whole: Vec<VertexId> = self.pinned_vertices.clone();
        whole.extend(self.prescribed.iter().map(|p| p.vertex));
        let topo = mesh.topology();
        let edges = topo.edges();
        let mut clamped = vec![false; mesh.n_vertices()];
        for &e in &self.clamped_edges {
            let edge = edges.get(e.idx()).ok_or(SolverError::InvalidSetting {
                name: "clamped_edges",
                value: e.idx() as f64,
                requirement: "edge id out of range",
            })?;
            for v in edge.vertices {
                clamped[v.idx()] = true;
            }
        }
        // The second row: every vertex of a face at a clamped vertex. Taking only the face of
        // each clamped edge misses every other second-row vertex on a grid with alternating
        // diagonals, and the strip between the rows then hinges.
        let mut held_vertex = clamped.clone();
        for (v, _) in clamped
            .iter()
            .enumerate()
            .filter(|(_, c)| **c && second_row)
        {
            for &f in topo.vertex_faces(VertexId::new(v)) {
                for w in mesh.faces()[f.idx()] {
                    held_vertex[w.idx()] = true;
                }
            }
        }
        whole.extend(
            held_vertex
                .iter()
                .enumerate()
                .filter(|(_, h)| **h)
                .map(|(v, _)| VertexId::new(v)),
        );
        for v in whole {
            held.extend((0..3).map(|a| (v, a)));
        }
        Ok(held)
    }

    /// A 3-2-1 pin set: six pinned coordinates that remove exactly the six rigid motions of a
    /// free shell (three translations, three rotations) and nothing else, so that under
    /// self-balanced loads (pressure on a closed surface, opposite point forces) the pins carry
    /// no force in the linear response. Under large displacements they do: the deformation
    /// moves the pinned points against each other, the pins turn the deformed shell, and dead
    /// loads that balanced in the reference no longer balance about the pins (up to half a load
    /// point's force on a hemisphere under alternating forces, docs/verification.md). There, hold
    /// coordinates that vanish on the problem's symmetry planes instead. Which coordinates:
    /// - all three of `anchor` (a): the translations;
    /// - two of the vertex b farthest from a: the rotations about the two axes across ab;
    /// - one of the vertex c farthest from the line ab: the rotation about ab.
    ///
    /// The axes of b and c are the ones that make the six constraints best conditioned (the
    /// largest determinant of the rotation block). Use the result as
    /// [`Boundary::pinned_coordinates`]. Errors when all vertices lie on one line (or `anchor`
    /// is out of range).
    pub fn rigid_motion_pins(
        mesh: &Mesh,
        anchor: VertexId,
    ) -> Result<Vec<(VertexId, usize)>, SolverError> {
        let p = mesh.positions();
        let a = *p.get(anchor.idx()).ok_or(SolverError::InvalidSetting {
            name: "anchor",
            value: anchor.idx() as f64,
            requirement: "vertex out of range",
        })?;
        let farthest = |key: &dyn Fn(&Vector3<f64>) -> f64| {
            (0..p.len())
                .map(|i| (i, key(&p[i])))
                .fold(
                    (anchor.idx(), 0.0f64),
                    |best, c| {
                        if c.1 > best.1 { c } else { best }
                    },
                )
        };
        let (b, _) = farthest(&|q| (q - a).norm());
        let ab = p[b] - a;
        let ab_len = ab.norm();
        let (c, off_line) = farthest(&|q| {
            if ab_len > 0.0 {
                ab.cross(&(q - a)).norm() / ab_len
            } else {
                0.0
            }
        });
        // Under a small rotation ω about a, vertex q moves by ω × (q − a); pinning axis i of q
        // imposes ω · ((q − a) × e_i) = 0. The three rows must be independent.
        let row = |q: usize, i: usize| (p[q] - a).cross(&Vector3::ith(i, 1.0));
        let mut best = (0.0f64, 0, 0);
        for b_free in 0..3 {
            let [i, j] = [(b_free + 1) % 3, (b_free + 2) % 3];
            for k in 0..3 {
                let m = nalgebra::Matrix3::from_rows(&[
                    row(b, i).transpose(),
                    row(b, j).transpose(),
                    row(c, k).transpose(),
                ]);
                let det = m.determinant().abs();
                if det > best.0 {
                    best = (det, b_free, k);
                }
            }
        }
        // Relative to |ab|²·distance of c from ab (the determinant's scale): round-off only
        // when the vertices are collinear.
        let scale = ab_len * ab_len * off_line;
        if !(scale > 0.0 && best.0 > 1e-12 * scale * ab_len) {
            return Err(SolverError::InvalidSetting {
                name: "rigid_motion_pins",
                value: off_line,
                requirement: "needs three vertices that are not on one line",
            });
        }
        let (_, b_free, k) = best;
        let (b, c) = (VertexId::new(b), VertexId::new(c));
        Ok(vec![
            (anchor, 0),
            (anchor, 1),
            (anchor, 2),
            (b, (b_free + 1) % 3),
            (b, (b_free + 2) % 3),
            (c, k),
        ])
    }

    /// The boundary edges of `mesh` on the plane where coordinate `axis` (0, 1, 2 = x, y, z)
    /// equals `value` (m): both vertices within `tolerance` (m) of it, paired with `axis` for
    /// [`Boundary::mirror_edges`]. Errors on an axis other than 0, 1, 2, a non-finite value, a
    /// negative or non-finite tolerance, or a plane that holds no boundary edge.
    pub fn symmetry_plane(
        mesh: &Mesh,
        axis: usize,
        value: f64,
        tolerance: f64,
    ) -> Result<Vec<(EdgeId, usize)>, SolverError> {
        check_axis("symmetry plane axis", axis)?;
        if !value.is_finite() {
            return Err(SolverError::InvalidSetting {
                name: "symmetry plane value",
                value,
                requirement: "finite",
            });
        }
        if !(tolerance >= 0.0 && tolerance.is_finite()) {
            return Err(SolverError::InvalidSetting {
                name: "symmetry plane tolerance",
                value: tolerance,
                requirement: ">= 0 and finite",
            });
        }
        let topo = mesh.topology();
        let p = mesh.positions();
        let on = |v: VertexId| (p[v.idx()][axis] - value).abs() <= tolerance;
        let edges: Vec<(EdgeId, usize)> = topo
            .boundary_edges()
            .iter()
            .filter(|&&e| topo.edge(e).vertices.iter().all(|&v| on(v)))
            .map(|&e| (e, axis))
            .collect();
        if edges.is_empty() {
            return Err(SolverError::InvalidSetting {
                name: "symmetry plane value",
                value,
                requirement: "a plane that holds boundary edges of the mesh",
            });
        }
        Ok(edges)
    }

    /// The edges without an angle unknown in an edge-director model: the clamped edges
    /// (director held, model.md §1.3), the fitted free edges (director from the fit, §1.2) and
    /// the mirror edges (director in the plane, §1.4).
    pub fn fixed_angle_edges(&self, mesh: &Mesh) -> Vec<EdgeId> {
        let fitted = thinshell_energy::fitted_free_edges(mesh);
        let mirrored = self.mirror_edges.iter().map(|m| m.0);
        self.clamped_edges
            .iter()
            .chain(&fitted)
            .copied()
            .chain(mirrored)
            .collect()
    }

    /// The mirror edges with their planes' unit normals, as the energy's stencils and
    /// `RestState::from_mesh_with_mirrors` take them.
    pub fn mirror_normals(&self) -> Vec<(EdgeId, Vector3<f64>)> {
        self.mirror_edges
            .iter()
            .map(|&(e, axis)| (e, Vector3::ith(axis.min(2), 1.0)))
            .collect()
    }

    /// The dof map of the free coordinates.
    pub fn dof_map(&self, mesh: &Mesh, second_row: bool) -> Result<DofMap, SolverError> {
        DofMap::with_pinned(mesh.n_vertices(), self.held_coordinates(mesh, second_row)?)
            .map_err(SolverError::from)
    }

    /// Sets the prescribed vertices of `x` to their positions at time `t`.
    pub fn apply_prescribed(&self, x: &mut [Vector3<f64>], t: f64) -> Result<(), SolverError> {
        for p in &self.prescribed {
            let target = (p.position)(t);
            if !target.iter().all(|c| c.is_finite()) {
                return Err(SolverError::NonFiniteCoordinate {
                    dof: 3 * p.vertex.idx(),
                });
            }
            match x.get_mut(p.vertex.idx()) {
                Some(slot) => *slot = target,
                None => {
                    return Err(SolverError::InvalidSetting {
                        name: "prescribed",
                        value: p.vertex.idx() as f64,
                        requirement: "vertex out of range",
                    });
                }
            }
        }
        Ok(())
    }
}

/// An error unless `axis` is 0, 1 or 2 (x, y, z).
fn check_axis(name: &'static str, axis: usize) -> Result<(), SolverError> {
    if axis > 2 {
        return Err(SolverError::InvalidSetting {
            name,
            value: axis as f64,
            requirement: "0, 1 or 2 (x, y, z)",
        });
    }
    Ok(())
}
