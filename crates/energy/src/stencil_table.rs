//! Per-face stencils (face vertices + flap vertices, and the face's edges with their
//! orientation signs for edge-director unknowns) from the mesh topology, built once.

use crate::EnergyError;
use crate::face_stencil::{EdgeAngles, EdgeClamp, FaceStencil, edge_signs};
use crate::sff::{fit_quality, fitted_edge_angle};
use nalgebra::Vector3;
use thinshell_mesh::{EdgeId, FaceId, Mesh, VertexId};

/// Below this [`fit_quality`] of the best choice of outer vertices, a face's free edges keep a
/// free director angle instead of the fit (too few or nearly degenerate candidates: an isolated
/// triangle, a sliver).
const MIN_FIT_QUALITY: f64 = 1e-3;

/// Candidates per face for the free-edge fit, nearest first (bounds the search at corners).
const MAX_CANDIDATES: usize = 12;

/// The six stencil vertices of every face: `[i, j, k, s_0, s_1, s_2]`, slot `3 + e` holding
/// the flap vertex across local edge `e` (opposite local vertex `e`), or on a free edge the
/// vertex of the free-edge fit (model.md §1.2), or else the opposite face vertex.
#[derive(Clone, Debug)]
pub struct Stencils {
    vertices: Vec<[VertexId; 6]>,
    flap: Vec<[bool; 3]>,
    /// `ghost[f][e]`: free edge e of f uses the fit, slot `3 + e` holding its outer vertex.
    ghost: Vec<[bool; 3]>,
    /// `clamp[f][e]`: the prescribed unit director of clamped edge e of f (model.md §1.3).
    clamp: Vec<[Option<Vector3<f64>>; 3]>,
    /// `mirror[f][e]`: the unit normal of the symmetry plane of mirror edge e of f (§1.4).
    mirror: Vec<[Option<Vector3<f64>>; 3]>,
    /// Whether any `mirror` entry is set (read on every evaluation: not a scan of every face).
    any_mirror: bool,
    /// Edge of each local edge (opposite local vertex e).
    edges: Vec<[EdgeId; 3]>,
    /// σ per local edge ([`edge_signs`]).
    signs: Vec<[f64; 3]>,
    /// Vertex and edge counts of the mesh.
    n_vertices: usize,
    n_edges: usize,
}

impl Stencils {
    /// Reads the stencils of all faces of `mesh` from its topology; the outer vertices of the
    /// free-edge fits are chosen on the mesh's positions (see [`Stencils::ghost`]).
    pub fn new(mesh: &Mesh) -> Stencils {
        let topo = mesh.topology();
        let mut vertices = Vec::with_capacity(mesh.n_faces());
        let mut flap = Vec::with_capacity(mesh.n_faces());
        let mut ghost = Vec::with_capacity(mesh.n_faces());
        for (f, face) in mesh.faces().iter().enumerate() {
            let flaps = topo.flap_vertices(FaceId::new(f));
            let mut v = [face[0], face[1], face[2], face[0], face[1], face[2]];
            let mut has = [false; 3];
            for e in 0..3 {
                if let Some(w) = flaps[e] {
                    v[3 + e] = w;
                    has[e] = true;
                }
            }
            let mut g = [false; 3];
            if has != [true; 3]
                && let Some(choice) = choose_outer(mesh, &v, has)
            {
                for e in (0..3).filter(|&e| !has[e]) {
                    v[3 + e] = choice[e];
                    g[e] = true;
                }
            }
            vertices.push(v);
            flap.push(has);
            ghost.push(g);
        }
        let edges = (0..mesh.n_faces())
            .map(|f| topo.face_edges(FaceId::new(f)))
            .collect();
        Stencils {
            clamp: vec![[None; 3]; vertices.len()],
            mirror: vec![[None; 3]; vertices.len()],
            any_mirror: false,
            vertices,
            flap,
            ghost,
            edges,
            signs: edge_signs(mesh),
            n_vertices: mesh.n_vertices(),
            n_edges: mesh.n_edges(),
        }
    }

    /// Number of vertices of the mesh.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// Number of edges of the mesh.
    pub fn n_edges(&self) -> usize {
        self.n_edges
    }

    /// Clamps the boundary edges `edges` (model.md §1.3): each keeps, fixed in space, the
    /// director it has at the reference positions `x_ref` (m, one per vertex) — the face normal
    /// turned about the edge by the fitted angle atan(II_fit / (2d)) where the edge has a fit,
    /// the face normal otherwise — so that at `x_ref` the clamped and the free-edge forms agree
    /// (rest forms built from `x_ref` stay stress-free). Replaces earlier clamps; interior
    /// edges in `edges` are ignored here (their angle is fixed by the dof map). Errors on an
    /// edge out of range or a wrong length of `x_ref`.
    pub fn set_clamped_edges(
        &mut self,
        edges: &[EdgeId],
        x_ref: &[Vector3<f64>],
    ) -> Result<(), EnergyError> {
        let (n_vertices, n_edges) = (self.n_vertices, self.n_edges);
        if x_ref.len() != n_vertices {
            return Err(EnergyError::LengthMismatch {
                what: "clamp reference positions",
                expected: n_vertices,
                got: x_ref.len(),
            });
        }
        let mut clamped = vec![false; n_edges];
        for &e in edges {
            *clamped
                .get_mut(e.idx())
                .ok_or(EnergyError::InvalidEdge { edge: e, n_edges })? = true;
        }
        // Built aside, so that an error leaves the previous clamps in place.
        let mut clamp = vec![[None; 3]; self.n_faces()];
        for (f, slot) in clamp.iter_mut().enumerate() {
            let s = self.stencil(f, x_ref);
            let x = &s.x;
            for e in 0..3 {
                if s.flap[e] || !clamped[self.edges[f][e].idx()] {
                    continue;
                }
                let normal = (x[1] - x[0]).cross(&(x[2] - x[0]));
                let edge = x[(e + 2) % 3] - x[(e + 1) % 3];
                let (n, axis) = (normal.normalize(), edge.normalize());
                let alpha = if s.ghost[e] {
                    fitted_edge_angle(&x.map(|v| [v.x, v.y, v.z]), e).1
                } else {
                    0.0
                };
                let director = n * alpha.cos() + axis.cross(&n) * alpha.sin();
                if !director.iter().all(|c| c.is_finite()) {
                    return Err(EnergyError::NonFiniteVertex {
                        vertex: self.vertices[f][(e + 1) % 3],
                    });
                }
                slot[e] = Some(director);
            }
        }
        self.clamp = clamp;
        Ok(())
    }

    /// Makes the boundary edges of `edges` mirror edges (model.md §1.4), each on the symmetry
    /// plane with the given normal (any length; normalised here): the director of such an edge
    /// lies in the plane, perpendicular to the edge, as the shell mirrored across the plane
    /// would share it. Their vertices must be held on the plane by the caller (a coordinate
    /// pin), and their edge angles are not unknowns (like a clamp's). The mid-edge average
    /// reads them too (its edge normal there is the face normal projected into the plane).
    /// Replaces earlier mirror
    /// edges; takes precedence over a clamp of the same edge. Errors on an edge out of range,
    /// an interior edge, or a zero or non-finite normal.
    pub fn set_mirror_edges(
        &mut self,
        edges: &[(EdgeId, Vector3<f64>)],
    ) -> Result<(), EnergyError> {
        let n_edges = self.n_edges;
        let mut normal: Vec<Option<Vector3<f64>>> = vec![None; n_edges];
        for &(e, p) in edges {
            let slot = normal
                .get_mut(e.idx())
                .ok_or(EnergyError::InvalidEdge { edge: e, n_edges })?;
            let len = p.norm();
            if !(len > 0.0 && len.is_finite()) {
                return Err(EnergyError::InvalidParameter {
                    name: "symmetry plane normal",
                    value: len,
                    reason: "must be non-zero and finite",
                });
            }
            *slot = Some(p / len);
        }
        let mut mirror = vec![[None; 3]; self.n_faces()];
        let mut on_boundary = vec![false; n_edges];
        for (f, slot) in mirror.iter_mut().enumerate() {
            for e in (0..3).filter(|&e| !self.flap[f][e]) {
                let id = self.edges[f][e].idx();
                on_boundary[id] = true;
                slot[e] = normal[id];
            }
        }
        if let Some(&(edge, _)) = edges.iter().find(|(e, _)| !on_boundary[e.idx()]) {
            return Err(EnergyError::InvalidParameter {
                name: "mirror edge",
                value: edge.idx() as f64,
                reason: "must be a boundary edge (a symmetry plane cuts the shell along its boundary)",
            });
        }
        self.any_mirror = mirror.iter().any(|m| m.iter().any(Option::is_some));
        self.mirror = mirror;
        Ok(())
    }

    /// Which free edges of face `f` use the free-edge fit (model.md §1.2): their director is
    /// extrapolated from the quadratic through the six stencil vertices, and their edge angle
    /// is not an unknown. The outer vertex of such an edge is the mesh vertex near the face
    /// (sharing a face with one of its vertices) that makes the fit best determined on the
    /// mesh's positions; a face without a well-determined choice keeps free angles.
    pub fn ghost(&self, f: usize) -> [bool; 3] {
        self.ghost[f]
    }

    /// Free edges whose director comes from the free-edge fit ([`Stencils::ghost`]), sorted:
    /// their angles are fixed at 0 ([`crate::DofMap::with_edges`]).
    pub fn fitted_edges(&self) -> Vec<EdgeId> {
        let mut out: Vec<EdgeId> = (0..self.n_faces())
            .flat_map(|f| {
                (0..3)
                    .filter(move |&e| self.ghost[f][e])
                    .map(move |e| (f, e))
            })
            .map(|(f, e)| self.edges[f][e])
            .collect();
        out.sort_unstable_by_key(|e| e.idx());
        out.dedup();
        out
    }

    /// Whether a free edge of face `f` takes its edge-director from the free-edge fit, a clamp
    /// or a mirror (model.md §1.2–1.4) rather than from its edge angle.
    pub(crate) fn has_boundary_director(&self, f: usize) -> bool {
        (0..3).any(|e| {
            !self.flap[f][e]
                && (self.ghost[f][e] || self.clamp[f][e].is_some() || self.mirror[f][e].is_some())
        })
    }

    /// Whether any edge is a mirror edge ([`Stencils::set_mirror_edges`]).
    pub(crate) fn has_mirror_edges(&self) -> bool {
        self.any_mirror
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

    /// Whether stencil slot `s` (0..6) of face `f` is a real vertex for a form that reads
    /// flaps only (the mid-edge average).
    pub fn slot_present(&self, f: usize, s: usize) -> bool {
        s < 3 || self.flap[f][s - 3]
    }

    /// Whether stencil slot `s` (0..6) of face `f` is read by the edge-director form: a flap
    /// or the outer vertex of a free-edge fit.
    pub fn slot_present_director(&self, f: usize, s: usize) -> bool {
        s < 3 || self.flap[f][s - 3] || self.ghost[f][s - 3]
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
            ghost: self.ghost[f],
            clamp: std::array::from_fn(|e| {
                let mirror = self.mirror[f][e].map(EdgeClamp::Mirror);
                mirror.or(self.clamp[f][e].map(EdgeClamp::Held))
            }),
            angles,
        }
    }
}

/// Free edges of `mesh` whose edge-director angle is not an unknown: their director comes from
/// the free-edge fit (model.md §1.2, [`Stencils::ghost`]). A solver passes them as fixed to
/// [`crate::DofMap::with_edges`] (a free angle there would not enter the energy: a zero row of
/// the Hessian). Sorted by id.
pub fn fitted_free_edges(mesh: &Mesh) -> Vec<EdgeId> {
    Stencils::new(mesh).fitted_edges()
}

/// The outer vertices (per missing flap slot) of the free-edge fit of a face with stencil
/// vertices `v` and flaps `has`: among the vertices sharing a face with a face vertex (not in
/// the stencil), the combination of maximal [`fit_quality`] on the mesh's positions, if that
/// reaches [`MIN_FIT_QUALITY`].
fn choose_outer(mesh: &Mesh, v: &[VertexId; 6], has: [bool; 3]) -> Option<[VertexId; 3]> {
    let topo = mesh.topology();
    let x = mesh.positions();
    let in_stencil = |w: VertexId| v[..3].contains(&w) || (0..3).any(|e| has[e] && v[3 + e] == w);
    let mut cand: Vec<VertexId> = Vec::new();
    for &c in &v[..3] {
        for &g in topo.vertex_faces(c) {
            for w in mesh.faces()[g.idx()] {
                if !in_stencil(w) && !cand.contains(&w) {
                    cand.push(w);
                }
            }
        }
    }
    let centre = (x[v[0].idx()] + x[v[1].idx()] + x[v[2].idx()]) / 3.0;
    cand.sort_by(|a, b| {
        let (da, db) = ((x[a.idx()] - centre).norm(), (x[b.idx()] - centre).norm());
        da.total_cmp(&db).then(a.idx().cmp(&b.idx()))
    });
    cand.truncate(MAX_CANDIDATES);
    let missing: Vec<usize> = (0..3).filter(|&e| !has[e]).collect();
    let mut best: Option<(f64, [VertexId; 3])> = None;
    let mut pick = [0usize, 1, 2];
    // Every order-free choice of distinct candidates for the missing slots (the fit does not
    // depend on which slot holds which outer point).
    let k = missing.len();
    let n = cand.len();
    if n < k {
        return None;
    }
    loop {
        let mut slots = *v;
        for (m, &e) in missing.iter().enumerate() {
            slots[3 + e] = cand[pick[m]];
        }
        let pts: [[f64; 3]; 6] = std::array::from_fn(|s| {
            let p = x[slots[s].idx()];
            [p.x, p.y, p.z]
        });
        let q = fit_quality(&pts);
        if q > best.map_or(MIN_FIT_QUALITY, |b| b.0) {
            best = Some((q, std::array::from_fn(|s| slots[3 + s])));
        }
        // Next strictly increasing index tuple.
        let mut m = k;
        loop {
            if m == 0 {
                return best.map(|b| b.1);
            }
            m -= 1;
            if pick[m] + (k - m) < n {
                break;
            }
        }
        pick[m] += 1;
        for j in m + 1..k {
            pick[j] = pick[j - 1] + 1;
        }
    }
}
