//! Contact as an energy term of a shell (`thinshell-system`'s `ShellSystem`, model.md §7): IPC
//! barriers on the shell's own vertex–face and edge–edge pairs and on its vertices against
//! rigid obstacles, and the step limit by continuous collision detection so that no Newton
//! step lets a pair cross.
//!
//! The maths (distances, barrier, mollifier, CCD, broad phase) is in
//! [this crate](crate); this module gathers the pairs of a mesh and adds their energy,
//! gradient and Hessian to the shell objective.

use std::sync::{Arc, Mutex};

use crate::{
    Aabb, BarrierGeometry, CandidatePairs, CcdSettings, CrossPairs, PairBarrier, PairKind,
    PairPoints, StaticMesh, additive_ccd, barrier, candidate_pairs, candidate_pairs_against,
    distance2_derivatives, edge_edge_distance2, filter_candidate_pairs, filter_cross_pairs,
    mollifier_threshold, overlapping_pairs, pair_barrier, pair_energy, pair_gap,
    point_triangle_distance2, segment_crosses_triangle,
};
use faer::sparse::SparseColMat;
use nalgebra::{Matrix3, Vector3};
use thinshell_energy::DofMap;
use thinshell_energy::project_psd;
use thinshell_mesh::Mesh;

pub use crate::obstacle::Obstacle;
use crate::pattern::{PATTERN_REACH, entry};
use crate::stiffness::AdaptiveStiffness;

type V = Vector3<f64>;

/// What the contact term holds apart and how.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactSettings {
    /// Rigid obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Whether the shell is kept from passing through itself.
    pub self_contact: bool,
    /// d̂ (m): gaps below it are active. Default: 0.1 × the mean edge length of the mesh.
    pub distance: Option<f64>,
    /// κ (J/m² = N/m): a fixed barrier stiffness. Default (`None`): adaptive, starting at E·h
    /// (the membrane stiffness) and set at the first solve that starts with pairs pressed
    /// together, then doubled while gaps collapse (`contact_stiffness.rs`, model.md §7);
    /// `ShellSystem::set_contact` with an unchanged d̂
    /// keeps the κ the replaced term learned.
    pub stiffness: Option<f64>,
    /// Whether gaps are measured between the shell's faces (distance minus h between two
    /// sheets, minus h/2 against an obstacle) rather than between mid-surfaces. Default true.
    pub thickness_offset: bool,
}

impl Default for ContactSettings {
    fn default() -> Self {
        ContactSettings {
            obstacles: Vec::new(),
            self_contact: true,
            distance: None,
            stiffness: None,
            thickness_offset: true,
        }
    }
}

/// What a contact term learns as a run goes, for checkpoints: with it a restored run continues
/// bit for bit (`ShellSystem::contact_run_state`).
#[derive(Clone, Debug, PartialEq)]
pub struct ContactRunState {
    /// κ (J/m²).
    pub stiffness: f64,
    /// Whether the adaptive stiffness has set κ₀ (false for a fixed stiffness).
    pub adaptive_initialised: bool,
    /// The adaptive stiffness's smallest gap at the previous solve's start (m; +∞ before).
    pub adaptive_last_gap: f64,
    /// [`ContactStats::approximated_pairs`].
    pub approximated_pairs: usize,
    /// [`ContactStats::pattern_rebuilds`].
    pub pattern_rebuilds: usize,
    /// The vertex couplings `[a, b]` (a < b) of the widened Hessian pattern, if built.
    pub pattern_couplings: Option<Vec<[usize; 2]>>,
}

/// An invalid contact setting or an intersecting state.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ContactError {
    /// A setting out of range.
    #[error("contact: {0}")]
    Invalid(String),
    /// The configuration intersects (or is within the minimum separation).
    #[error("contact: the initial state intersects: {0}")]
    Intersecting(String),
}

/// The resolved contact term of a mesh.
#[derive(Clone, Debug)]
pub struct Contact {
    /// The analytic obstacles (plane, sphere, box).
    obstacles: Vec<Obstacle>,
    /// The mesh obstacles, merged into one fixed mesh.
    meshes: ObstacleMeshes,
    self_contact: bool,
    /// d̂ (m).
    pub activation: f64,
    /// κ (J/m²): fixed, or the current value of the adaptive stiffness.
    pub stiffness: f64,
    /// The adaptive stiffness's state (`None`: κ fixed by the settings).
    pub adaptive: Option<AdaptiveStiffness>,
    /// Offset of self pairs (m): h, or 0.
    offset_self: f64,
    /// Offset against obstacles (m): h/2, or 0.
    offset_obstacle: f64,
    /// CCD's minimum separation beyond the offsets (m): 10⁻³ d̂.
    separation: f64,
    faces: Vec<[usize; 3]>,
    edges: Vec<[usize; 2]>,
    /// Reference positions for the edge–edge mollifier thresholds.
    rest: Vec<V>,
    /// How far beyond the offsets the cached broad phase's boxes are grown (m): (1 +
    /// [`PATTERN_REACH`])·d̂, so that one broad phase serves the barrier (d̂) with a slack of d̂
    /// per vertex and a rebuild of the Hessian pattern (its reach).
    cache_reach: f64,
    /// The last broad phase of [`Contact::candidates_for`].
    cache: CandidateCache,
    /// [`Obstacle::describe`] of every obstacle, in the settings' order.
    descriptions: Vec<String>,
}

/// The mesh obstacles of a contact term merged into one fixed mesh.
#[derive(Clone, Debug, Default)]
struct ObstacleMeshes {
    /// Vertex positions (m).
    points: Vec<V>,
    faces: Vec<[usize; 3]>,
    /// Every edge of the faces once.
    edges: Vec<[usize; 2]>,
    /// Per vertex, the index of its obstacle in [`ContactSettings::obstacles`].
    owner: Vec<usize>,
}

impl ObstacleMeshes {
    fn add(&mut self, index: usize, vertices: &[V], faces: &[[usize; 3]]) {
        let base = self.points.len();
        self.points.extend_from_slice(vertices);
        self.owner
            .extend(std::iter::repeat_n(index, vertices.len()));
        let mut edges: Vec<[usize; 2]> = faces
            .iter()
            .flat_map(|f| {
                [[f[0], f[1]], [f[1], f[2]], [f[2], f[0]]].map(|[a, b]| [a.min(b), a.max(b)])
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        self.faces.extend(faces.iter().map(|f| f.map(|v| v + base)));
        self.edges.extend(edges.iter().map(|e| e.map(|v| v + base)));
    }

    fn view(&self) -> StaticMesh<'_> {
        StaticMesh {
            points: &self.points,
            faces: &self.faces,
            edges: &self.edges,
        }
    }

    fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }
}

/// The candidate pairs of one broad phase: the shell's own and those against the mesh
/// obstacles.
#[derive(Debug, Default)]
struct Candidates {
    /// Self pairs whose boxes overlap (the broad phase's answer, for the CCD and the Hessian
    /// pattern, which filter it to their own box growth).
    own: CandidatePairs,
    /// Pairs against the mesh obstacles whose boxes overlap.
    mesh: CrossPairs,
    /// The pairs of `own` that can be active wherever the cache qualifies for the barrier
    /// ([`Contact::near_pairs`]): the barrier's loops visit only these.
    near: CandidatePairs,
    /// The mollifier threshold of each of `near.edge_edge` (m⁴, from the reference positions).
    near_threshold: Vec<f64>,
    /// The pairs of `mesh` that can be active, likewise.
    mesh_near: CrossPairs,
}

/// The motion and candidate pairs of the last broad phase (a clone starts empty).
#[derive(Default)]
struct CandidateCache(Mutex<Option<CacheEntry>>);

/// A broad phase of the motion `start` → `end` (`None`: at `start`) with boxes grown by offset
/// + [`Contact::cache_reach`].
struct CacheEntry {
    start: Vec<V>,
    end: Option<Vec<V>>,
    pairs: Arc<Candidates>,
}

impl Clone for CandidateCache {
    fn clone(&self) -> Self {
        CandidateCache::default()
    }
}

impl std::fmt::Debug for CandidateCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("CandidateCache")
    }
}

/// Counts, gap and energy of the contact term at one configuration, and how its Hessian was
/// assembled.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// Active pairs (self, mesh-obstacle and vertex–obstacle pairs with gap < d̂).
    pub active_pairs: usize,
    /// The smallest gap (m) over the active self and mesh-obstacle pairs and every vertex pair
    /// with an analytic obstacle (+∞ if none).
    pub min_gap: f64,
    /// The barrier energy κ Σ m_k b(g_k, d̂) (J).
    pub energy: f64,
    /// Self pairs of the last Newton Hessian whose vertex couplings were outside its pattern
    /// and so entered as per-vertex diagonal blocks only (0: that Hessian was exact; see
    /// [`Contact::add_hessian`]). Filled in by `ShellSystem::contact_stats`;
    /// 0 from [`Contact::stats`].
    pub approximated_pairs: usize,
    /// Rebuilds of the self-contact Hessian pattern (new symbolic factorisations) since contact
    /// was set. Filled in like `approximated_pairs`.
    pub pattern_rebuilds: usize,
}

impl Contact {
    /// The contact term of `mesh` (its positions are the reference for the mollifier) with
    /// shell thickness `thickness` (m) and Young's modulus `young` (Pa) for the defaults.
    pub fn new(
        mesh: &Mesh,
        thickness: f64,
        young: f64,
        settings: &ContactSettings,
    ) -> Result<Contact, ContactError> {
        let p = mesh.positions();
        let edges: Vec<[usize; 2]> = mesh
            .topology()
            .edges()
            .iter()
            .map(|e| e.vertices.map(|v| v.idx()))
            .collect();
        let mean_edge = thinshell_mesh::mean_edge_length(mesh, p);
        let activation = settings.distance.unwrap_or(0.1 * mean_edge);
        if !(activation > 0.0 && activation.is_finite()) {
            return Err(ContactError::Invalid(format!(
                "distance must be positive and finite, got {activation}"
            )));
        }
        let stiffness = settings.stiffness.unwrap_or(young * thickness);
        if !(stiffness > 0.0 && stiffness.is_finite()) {
            return Err(ContactError::Invalid(format!(
                "stiffness must be positive and finite, got {stiffness}"
            )));
        }
        let mut obstacles = Vec::new();
        let mut meshes = ObstacleMeshes::default();
        for (k, o) in settings.obstacles.iter().enumerate() {
            match o.validated() {
                Ok(Obstacle::Mesh { vertices, faces }) => meshes.add(k, &vertices, &faces),
                Ok(o) => obstacles.push(o),
                Err(e) => return Err(ContactError::Invalid(format!("obstacle {k}: {e}"))),
            }
        }
        let h = if settings.thickness_offset {
            thickness
        } else {
            0.0
        };
        Ok(Contact {
            obstacles,
            meshes,
            self_contact: settings.self_contact,
            activation,
            stiffness,
            adaptive: settings
                .stiffness
                .is_none()
                .then(|| AdaptiveStiffness::new(young * thickness)),
            offset_self: h,
            offset_obstacle: 0.5 * h,
            separation: 1e-3 * activation,
            faces: mesh.faces().iter().map(|f| f.map(|v| v.idx())).collect(),
            edges,
            rest: p.to_vec(),
            cache_reach: (1.0 + PATTERN_REACH) * activation,
            cache: CandidateCache::default(),
            descriptions: settings.obstacles.iter().map(Obstacle::describe).collect(),
        })
    }

    /// Takes over the adaptive stiffness κ and what it has learned (whether κ₀ is set, the
    /// smallest gap at the last solve's start) from `previous`, the term this one replaces,
    /// where that is sound: both adaptive, with the same d̂, thickness offsets and bounds (the
    /// same E·h). κ scales the run's contact forces at the gaps d̂ sets (κ₀ carries the load on
    /// the active pairs at d̂/2, and the raises within and between solves keep adapting it as
    /// the pairs change), so moving an obstacle leaves it meaningful; a new d̂ or offset changes
    /// the gaps the barrier acts at, and κ restarts at E·h.
    pub fn keep_stiffness_of(&mut self, previous: &Contact) {
        let same_geometry = self.activation == previous.activation
            && self.offset_self == previous.offset_self
            && self.offset_obstacle == previous.offset_obstacle;
        match (&mut self.adaptive, previous.adaptive) {
            (Some(a), Some(p)) if same_geometry && a.min == p.min && a.max == p.max => {
                *a = p;
                self.stiffness = previous.stiffness;
            }
            _ => {}
        }
    }

    fn pt_points(&self, x: &[V], v: usize, f: usize) -> PairPoints {
        let t = self.faces[f];
        [x[v], x[t[0]], x[t[1]], x[t[2]]]
    }

    fn ee_points(&self, x: &[V], i: usize, j: usize) -> PairPoints {
        let (a, b) = (self.edges[i], self.edges[j]);
        [x[a[0]], x[a[1]], x[b[0]], x[b[1]]]
    }

    fn ee_kind(&self, i: usize, j: usize) -> PairKind {
        PairKind::EdgeEdge {
            mollifier_threshold: mollifier_threshold(&self.ee_points(&self.rest, i, j)),
        }
    }

    fn geometry(&self) -> BarrierGeometry {
        BarrierGeometry {
            activation: self.activation,
            offset: self.offset_self,
        }
    }

    /// The barrier geometry of pairs against the mesh obstacles (offset h/2 or 0).
    fn mesh_geometry(&self) -> BarrierGeometry {
        BarrierGeometry {
            activation: self.activation,
            offset: self.offset_obstacle,
        }
    }

    /// Visits every pair of `c` between the shell at `x` and the mesh obstacles: per point the
    /// shell vertex it is (`None`: an obstacle vertex), the four points and the pair's kind
    /// (edge pairs with the mollifier threshold of the shell edge's reference positions).
    fn for_mesh_pairs(
        &self,
        x: &[V],
        c: &CrossPairs,
        mut f: impl FnMut([Option<usize>; 4], PairPoints, PairKind),
    ) {
        let o = &self.meshes;
        for &[v, k] in &c.vertex_face {
            let t = o.faces[k];
            f(
                [Some(v), None, None, None],
                [x[v], o.points[t[0]], o.points[t[1]], o.points[t[2]]],
                PairKind::PointTriangle,
            );
        }
        for &[w, k] in &c.face_vertex {
            let t = self.faces[k];
            f(
                [None, Some(t[0]), Some(t[1]), Some(t[2])],
                [o.points[w], x[t[0]], x[t[1]], x[t[2]]],
                PairKind::PointTriangle,
            );
        }
        for &[i, j] in &c.edge_edge {
            let (a, b) = (self.edges[i], o.edges[j]);
            let (p, q) = (o.points[b[0]], o.points[b[1]]);
            f(
                [Some(a[0]), Some(a[1]), None, None],
                [x[a[0]], x[a[1]], p, q],
                PairKind::EdgeEdge {
                    mollifier_threshold: mollifier_threshold(&[
                        self.rest[a[0]],
                        self.rest[a[1]],
                        p,
                        q,
                    ]),
                },
            );
        }
    }

    /// The obstacle index of mesh-obstacle vertex `w` (for messages).
    fn mesh_owner(&self, w: usize) -> usize {
        self.meshes.owner[w]
    }

    /// The self and mesh-obstacle pairs that may be active at `x`: a superset of those whose
    /// boxes, grown by offset + d̂, overlap (inactive extras add exactly 0 to every sum, so the
    /// results do not depend on it); see [`Contact::candidates_for`].
    fn candidates(&self, x: &[V]) -> Arc<Candidates> {
        self.candidates_for(x, None, self.activation)
    }

    /// A superset of the pairs the broad phase finds for the motion `x0` → `x1` (`None`: at
    /// `x0`) with boxes grown by offset + `reach` (m; at most [`Contact::cache_reach`]): the
    /// cached candidates when they qualify ([`Contact::cached_for`]), else a new broad phase of
    /// this motion with boxes grown by offset + `cache_reach`, kept for the next calls. One
    /// broad phase of a Newton step's motion serves the CCD, every line-search trial on it and
    /// the next iterates' barrier, as in IPC.
    fn candidates_for(&self, x0: &[V], x1: Option<&[V]>, reach: f64) -> Arc<Candidates> {
        if !self.self_contact && self.meshes.is_empty() {
            return Arc::default();
        }
        if let Some(c) = self.cached_for(x0, x1, reach) {
            return c;
        }
        let dx: Option<Vec<V>> = x1.map(|e| e.iter().zip(x0).map(|(b, a)| b - a).collect());
        let own = if self.self_contact {
            candidate_pairs(
                x0,
                dx.as_deref(),
                &self.faces,
                &self.edges,
                self.offset_self + self.cache_reach,
            )
        } else {
            CandidatePairs::default()
        };
        let mesh = if self.meshes.is_empty() {
            CrossPairs::default()
        } else {
            candidate_pairs_against(
                x0,
                dx.as_deref(),
                &self.faces,
                &self.edges,
                self.meshes.view(),
                self.offset_obstacle + self.cache_reach,
            )
        };
        let (near, mesh_near) = self.near_pairs(x0, x1, &own, &mesh);
        let near_threshold = near
            .edge_edge
            .iter()
            .map(|&[i, j]| mollifier_threshold(&self.ee_points(&self.rest, i, j)))
            .collect();
        let pairs = Arc::new(Candidates {
            own,
            mesh,
            near,
            near_threshold,
            mesh_near,
        });
        if reach <= self.cache_reach {
            let mut cache = self.cache.0.lock().unwrap_or_else(|e| e.into_inner());
            *cache = Some(CacheEntry {
                start: x0.to_vec(),
                end: x1.map(<[V]>::to_vec),
                pairs: Arc::clone(&pairs),
            });
        }
        pairs
    }

    /// The pairs of `own` and `mesh` (found for the motion `x0` → `x1`) that can be active at
    /// any configuration the cache serves the barrier at: each vertex within δ of its segment,
    /// d̂ + 2δ ≤ `cache_reach` ([`Contact::cached_for`]). A pair's distance changes by at most
    /// the displacement of its point plus the largest of its triangle's (or the sum of the two
    /// edges' largest), so with d₀, d₁ its distances at the ends and M the largest displacement
    /// of its vertices along the motion, its distance there is at least max(d₀, d₁) − 2M − 2δ:
    /// a pair is kept unless max(d₀, d₁) − 2M − offset exceeds `cache_reach` (with a margin
    /// of 10⁻⁶ for rounding; a NaN distance keeps it).
    fn near_pairs(
        &self,
        x0: &[V],
        x1: Option<&[V]>,
        own: &CandidatePairs,
        mesh: &CrossPairs,
    ) -> (CandidatePairs, CrossPairs) {
        let limit = (1.0 + 1e-6) * self.cache_reach;
        let moved = |ids: &[usize]| {
            x1.map_or(0.0, |e| {
                ids.iter()
                    .map(|&v| (e[v] - x0[v]).norm())
                    .fold(0.0, f64::max)
            })
        };
        // `dist(x)`: the pair's distance at positions x.
        let keep = |ids: &[usize], offset: f64, dist: &dyn Fn(&[V]) -> f64| {
            let d = match x1 {
                Some(e) => dist(x0).max(dist(e)),
                None => dist(x0),
            };
            let bound = d - 2.0 * moved(ids) - offset;
            bound.is_nan() || bound <= limit
        };
        let pt = |x: &[V], v: usize, f: usize| {
            point_triangle_distance2(&self.pt_points(x, v, f)).0.sqrt()
        };
        let ee =
            |x: &[V], i: usize, j: usize| edge_edge_distance2(&self.ee_points(x, i, j)).0.sqrt();
        let near = CandidatePairs {
            point_triangle: own
                .point_triangle
                .iter()
                .copied()
                .filter(|&[v, f]| {
                    let t = self.faces[f];
                    keep(&[v, t[0], t[1], t[2]], self.offset_self, &|x| pt(x, v, f))
                })
                .collect(),
            edge_edge: own
                .edge_edge
                .iter()
                .copied()
                .filter(|&[i, j]| {
                    let (a, b) = (self.edges[i], self.edges[j]);
                    keep(&[a[0], a[1], b[0], b[1]], self.offset_self, &|x| {
                        ee(x, i, j)
                    })
                })
                .collect(),
        };
        let o = &self.meshes;
        let off = self.offset_obstacle;
        let mesh_near = CrossPairs {
            vertex_face: mesh
                .vertex_face
                .iter()
                .copied()
                .filter(|&[v, k]| {
                    let t = o.faces[k].map(|w| o.points[w]);
                    keep(&[v], off, &|x| {
                        point_triangle_distance2(&[x[v], t[0], t[1], t[2]]).0.sqrt()
                    })
                })
                .collect(),
            face_vertex: mesh
                .face_vertex
                .iter()
                .copied()
                .filter(|&[w, k]| {
                    let t = self.faces[k];
                    keep(&t, off, &|x| {
                        point_triangle_distance2(&[o.points[w], x[t[0]], x[t[1]], x[t[2]]])
                            .0
                            .sqrt()
                    })
                })
                .collect(),
            edge_edge: mesh
                .edge_edge
                .iter()
                .copied()
                .filter(|&[i, j]| {
                    let (a, b) = (self.edges[i], o.edges[j]);
                    keep(&a, off, &|x| {
                        edge_edge_distance2(&[x[a[0]], x[a[1]], o.points[b[0]], o.points[b[1]]])
                            .0
                            .sqrt()
                    })
                })
                .collect(),
        };
        (near, mesh_near)
    }

    /// The cached candidates when they contain every pair the broad phase finds for the motion
    /// `x0` → `x1` with boxes grown by offset + `reach` (m). With δ the largest distance of a
    /// vertex's positions at `x0` and `x1` from its cached segment (start → end), every box of
    /// the new motion lies within δ (per axis) of its cached swept box — the δ-neighbourhood of
    /// a segment is convex —, so two boxes grown by offset + `reach` that overlap now overlapped
    /// in the cache once its growth covers `reach` + 2δ: `reach` + 2δ ≤ `cache_reach`.
    fn cached_for(&self, x0: &[V], x1: Option<&[V]>, reach: f64) -> Option<Arc<Candidates>> {
        let cache = self.cache.0.lock().unwrap_or_else(|e| e.into_inner());
        let entry = cache.as_ref()?;
        if entry.start.len() != x0.len() || x1.is_some_and(|e| e.len() != x0.len()) {
            return None;
        }
        let room = 0.5 * (self.cache_reach - reach);
        if room.is_nan() || room < 0.0 {
            return None;
        }
        let room2 = room * room;
        let end = entry.end.as_deref().unwrap_or(&entry.start);
        let within = |k: usize, y: &V| segment_distance2(&entry.start[k], &end[k], y) <= room2;
        let ok = match x1 {
            Some(x1) => (0..x0.len()).all(|k| within(k, &x0[k]) && within(k, &x1[k])),
            None => (0..x0.len()).all(|k| within(k, &x0[k])),
        };
        ok.then(|| Arc::clone(&entry.pairs))
    }

    /// Gap (m) of vertex position `y` to obstacle `o`, and its unit gradient direction.
    fn obstacle_gap(&self, o: &Obstacle, y: &V) -> (f64, V) {
        let d = o.distance(y);
        (d.distance - self.offset_obstacle, d.normal)
    }

    /// The contact energy (J) at positions `x`; +∞ when a pair is within the CCD's minimum
    /// separation (offset + 10⁻³ d̂) or crosses. The barrier is finite down to a gap of 0, but
    /// a state the CCD would refuse to start from must not be accepted by a step that the CCD
    /// did not limit (Newton's unshifted step at a saddle, for one): +∞ makes it fail the
    /// finiteness checks instead.
    pub fn energy(&self, x: &[V]) -> f64 {
        let all = self.candidates(x);
        let c = &all.near;
        let g = self.geometry();
        let gm = self.mesh_geometry();
        let xi = self.separation;
        let mut e = 0.0;
        let mut add = |pts: &PairPoints, kind: PairKind, geometry: BarrierGeometry| {
            let gap = pair_gap(pts, kind, geometry.offset);
            if gap.is_nan() || gap <= xi {
                e = f64::INFINITY;
            } else {
                e += pair_energy(pts, kind, geometry);
            }
        };
        for &[v, f] in &c.point_triangle {
            add(&self.pt_points(x, v, f), PairKind::PointTriangle, g);
        }
        for (&[i, j], &t) in c.edge_edge.iter().zip(&all.near_threshold) {
            add(&self.ee_points(x, i, j), ee_kind(t), g);
        }
        self.for_mesh_pairs(x, &all.mesh_near, |_, pts, kind| add(&pts, kind, gm));
        for o in &self.obstacles {
            for y in x {
                let gap = self.obstacle_gap(o, y).0;
                if gap.is_nan() || gap <= xi {
                    e = f64::INFINITY;
                } else {
                    e += barrier(gap, self.activation).0;
                }
            }
        }
        self.stiffness * e
    }

    /// [`ContactStats::min_gap`] at positions `x` (m) without the energy: the smallest gap of
    /// the active self and mesh-obstacle pairs and of every vertex against an analytic
    /// obstacle (+∞ if none).
    pub fn min_gap(&self, x: &[V]) -> f64 {
        let all = self.candidates(x);
        let mut gap = f64::INFINITY;
        let mut see = |g: f64, obstacle: bool| {
            if obstacle || g < self.activation {
                gap = gap.min(g);
            }
        };
        for &[v, f] in &all.near.point_triangle {
            see(
                point_triangle_distance2(&self.pt_points(x, v, f)).0.sqrt() - self.offset_self,
                false,
            );
        }
        for &[i, j] in &all.near.edge_edge {
            see(
                edge_edge_distance2(&self.ee_points(x, i, j)).0.sqrt() - self.offset_self,
                false,
            );
        }
        self.for_mesh_pairs(x, &all.mesh_near, |_, pts, kind| {
            see(pair_gap(&pts, kind, self.offset_obstacle), false);
        });
        for o in &self.obstacles {
            for y in x {
                see(self.obstacle_gap(o, y).0, true);
            }
        }
        gap
    }

    /// Active pairs, the smallest gap and the energy at positions `x` (the Hessian counters
    /// are left 0).
    pub fn stats(&self, x: &[V]) -> ContactStats {
        let all = self.candidates(x);
        let c = &all.near;
        let g = self.geometry();
        let mut s = ContactStats {
            min_gap: f64::INFINITY,
            ..ContactStats::default()
        };
        let mut b_sum = 0.0;
        let mut see = |gap: f64, b: f64, obstacle: bool| {
            // Self pairs enter the smallest gap only when active: the candidate set is a
            // superset whose extent depends on the cache (model.md §7).
            if obstacle || gap < self.activation {
                s.min_gap = s.min_gap.min(gap);
            }
            if gap < self.activation {
                s.active_pairs += 1;
            }
            b_sum += b;
        };
        for &[v, f] in &c.point_triangle {
            let pts = self.pt_points(x, v, f);
            see(
                point_triangle_distance2(&pts).0.sqrt() - self.offset_self,
                pair_energy(&pts, PairKind::PointTriangle, g),
                false,
            );
        }
        for (&[i, j], &t) in c.edge_edge.iter().zip(&all.near_threshold) {
            let pts = self.ee_points(x, i, j);
            see(
                edge_edge_distance2(&pts).0.sqrt() - self.offset_self,
                pair_energy(&pts, ee_kind(t), g),
                false,
            );
        }
        let gm = self.mesh_geometry();
        self.for_mesh_pairs(x, &all.mesh_near, |_, pts, kind| {
            // Like self pairs, mesh-obstacle pairs enter the smallest gap only when active.
            see(
                pair_gap(&pts, kind, self.offset_obstacle),
                pair_energy(&pts, kind, gm),
                false,
            );
        });
        for o in &self.obstacles {
            for y in x {
                let gap = self.obstacle_gap(o, y).0;
                see(gap, barrier(gap, self.activation).0, true);
            }
        }
        s.energy = self.stiffness * b_sum;
        s
    }

    /// Per vertex of the shell, the smallest gap (m) of the pairs it belongs to at `x` (self,
    /// mesh-obstacle and analytic-obstacle pairs), capped at d̂: d̂ where no pair is active. A
    /// face's is the least of its vertices' (see [`Contact::face_gaps`]).
    pub fn vertex_gaps(&self, x: &[V]) -> Vec<f64> {
        let mut out = vec![self.activation; x.len()];
        let all = self.candidates(x);
        let mut see = |ids: &[usize], gap: f64| {
            for &v in ids {
                out[v] = out[v].min(gap);
            }
        };
        for &[v, f] in &all.near.point_triangle {
            let t = self.faces[f];
            let d = point_triangle_distance2(&self.pt_points(x, v, f)).0.sqrt();
            see(&[v, t[0], t[1], t[2]], d - self.offset_self);
        }
        for &[i, j] in &all.near.edge_edge {
            let (a, b) = (self.edges[i], self.edges[j]);
            let d = edge_edge_distance2(&self.ee_points(x, i, j)).0.sqrt();
            see(&[a[0], a[1], b[0], b[1]], d - self.offset_self);
        }
        self.for_mesh_pairs(x, &all.mesh_near, |ids, pts, kind| {
            let gap = pair_gap(&pts, kind, self.offset_obstacle);
            let shell: Vec<usize> = ids.iter().flatten().copied().collect();
            see(&shell, gap);
        });
        for o in &self.obstacles {
            for (v, y) in x.iter().enumerate() {
                see(&[v], self.obstacle_gap(o, y).0);
            }
        }
        out
    }

    /// Per face of the shell, the smallest gap (m) of its vertices ([`Contact::vertex_gaps`]),
    /// in (0, d̂] for an intersection-free state: the VTK cell field `contact_gap` the viewer
    /// colours by.
    pub fn face_gaps(&self, x: &[V]) -> Vec<f64> {
        let g = self.vertex_gaps(x);
        self.faces
            .iter()
            .map(|f| g[f[0]].min(g[f[1]]).min(g[f[2]]))
            .collect()
    }

    /// Visits every active pair's vertices, gradient and Hessian (unit stiffness; column-major
    /// 3n×3n for n vertices), a self pair's Hessian projected to PSD when `project` is set, a
    /// vertex–obstacle pair's always.
    fn for_active(&self, x: &[V], project: bool, mut f: impl FnMut(&[usize], &[f64], &[f64])) {
        let all = self.candidates(x);
        let c = &all.near;
        let g = self.geometry();
        let mut pair = |ids: [usize; 4], pts: PairPoints, kind: PairKind| {
            if let PairBarrier::Active(d) = pair_barrier(&pts, kind, g, project) {
                f(&ids, d.gradient.as_slice(), d.hessian.as_slice());
            }
        };
        for &[v, fc] in &c.point_triangle {
            let t = self.faces[fc];
            pair(
                [v, t[0], t[1], t[2]],
                self.pt_points(x, v, fc),
                PairKind::PointTriangle,
            );
        }
        for (&[i, j], &t) in c.edge_edge.iter().zip(&all.near_threshold) {
            let (a, b) = (self.edges[i], self.edges[j]);
            pair(
                [a[0], a[1], b[0], b[1]],
                self.ee_points(x, i, j),
                ee_kind(t),
            );
        }
        let gm = self.mesh_geometry();
        self.for_mesh_pairs(x, &all.mesh_near, |ids, pts, kind| {
            let PairBarrier::Active(d) = pair_barrier(&pts, kind, gm, false) else {
                return;
            };
            // The obstacle's coordinates are fixed: keep the rows and columns of the shell's
            // vertices (projecting the 12×12 matrix with the others zeroed projects that
            // principal block).
            let mut h = d.hessian;
            for (a, id) in ids.iter().enumerate() {
                if id.is_none() {
                    h.fixed_rows_mut::<3>(3 * a).fill(0.0);
                    h.fixed_columns_mut::<3>(3 * a).fill(0.0);
                }
            }
            if project {
                project_psd(&mut h);
            }
            let mut keep = [0usize; 4];
            let mut vs = [0usize; 4];
            let mut k = 0;
            for (a, id) in ids.iter().enumerate() {
                if let Some(v) = id {
                    keep[k] = a;
                    vs[k] = *v;
                    k += 1;
                }
            }
            let m = 3 * k;
            let mut grad = [0.0; 12];
            let mut hess = [0.0; 144];
            for i in 0..m {
                let r = 3 * keep[i / 3] + i % 3;
                grad[i] = d.gradient[r];
                for j in 0..m {
                    hess[j * m + i] = h[(r, 3 * keep[j / 3] + j % 3)];
                }
            }
            f(&vs[..k], &grad[..m], &hess[..m * m]);
        });
        for o in &self.obstacles {
            for (v, y) in x.iter().enumerate() {
                let d = o.distance(y);
                let (_, db, ddb) = barrier(d.distance - self.offset_obstacle, self.activation);
                if db == 0.0 {
                    continue;
                }
                let n = d.normal;
                let grad = n * db;
                // b″ n nᵀ + b′ ∇²d: the curvature term is negative semi-definite (b′ < 0), and
                // is projected in every mode: kept exact, a sheet resting on a sphere stalled
                // Newton at round-off along its near-free tangential (rolling) directions.
                let mut h = n * n.transpose() * ddb + d.hessian * db;
                if d.hessian != Matrix3::zeros() {
                    project_psd(&mut h);
                }
                f(&[v], grad.as_slice(), h.as_slice());
            }
        }
    }

    /// Adds the contact gradient (N) at positions `x` to `grad` (full coordinates, vertex-major
    /// positions first).
    pub fn add_gradient(&self, x: &[V], grad: &mut [f64]) {
        let k = self.stiffness;
        self.for_active(x, false, |ids, g, _| {
            for (a, &v) in ids.iter().enumerate() {
                for i in 0..3 {
                    grad[3 * v + i] += k * g[3 * a + i];
                }
            }
        });
    }

    /// The contact force on every vertex at positions `x` (N): −κ ∂B/∂x, the barrier's push
    /// (a VTK point field of the frames).
    pub fn forces(&self, x: &[V]) -> Vec<V> {
        let mut g = vec![0.0; 3 * x.len()];
        self.add_gradient(x, &mut g);
        g.chunks_exact(3)
            .map(|c| -V::new(c[0], c[1], c[2]))
            .collect()
    }

    /// Adds the contact Hessian at positions `x` to `h` (lower triangle over `dofs`' free
    /// dofs), each pair's Hessian projected to PSD when `project` is set. A pair whose vertex
    /// couplings are all in `h`'s pattern is added exactly; one that is not (the pattern was
    /// built before the pair came near, see `contact_pattern.rs`) adds only its per-vertex 3×3
    /// diagonal blocks — principal blocks of a PSD matrix are PSD, so a projected Hessian stays
    /// PSD. Returns the number of pairs so approximated.
    pub fn add_hessian(
        &self,
        x: &[V],
        dofs: &DofMap,
        h: &mut SparseColMat<usize, f64>,
        project: bool,
    ) -> usize {
        let k = self.stiffness;
        let mut approximated = 0;
        let (symbolic, val) = h.parts_mut();
        self.for_active(x, project, |ids, _, hess| {
            let m = 3 * ids.len();
            let mut dof = [None; 12];
            for (a, &v) in ids.iter().enumerate() {
                for c in 0..3 {
                    dof[3 * a + c] = dofs.coordinate_dof(3 * v + c);
                }
            }
            // Value index of every (i, j) with dof(i) ≥ dof(j): each stored entry once.
            let mut at = [[None; 12]; 12];
            let mut exact = true;
            for i in 0..m {
                for j in 0..m {
                    if let (Some(p), Some(q)) = (dof[i], dof[j])
                        && p >= q
                    {
                        at[i][j] = entry(symbolic, p, q);
                        exact &= at[i][j].is_some();
                    }
                }
            }
            approximated += usize::from(!exact);
            for i in 0..m {
                for j in 0..m {
                    if let Some(o) = at[i][j]
                        && (exact || i / 3 == j / 3)
                    {
                        val[o] += k * hess[j * m + i];
                    }
                }
            }
        });
        approximated
    }

    /// Σ_k ∇g_k over the active pairs at `x` (full coordinates, vertex-major; unit normals of
    /// obstacle pairs, ∇d of self pairs) and the number of active pairs: the directions along
    /// which the barrier pushes, for the adaptive stiffness.
    pub fn gap_gradient_sum(&self, x: &[V]) -> (Vec<f64>, usize) {
        let mut n = vec![0.0; 3 * x.len()];
        let mut active = 0;
        let all = self.candidates(x);
        let c = &all.near;
        let mut add = |ids: [usize; 4], pts: PairPoints, (d2, ty)| {
            let d: f64 = f64::sqrt(d2);
            if d - self.offset_self < self.activation && d > 0.0 {
                active += 1;
                let g = distance2_derivatives(&pts, ty).gradient / (2.0 * d);
                for (a, &v) in ids.iter().enumerate() {
                    for k in 0..3 {
                        n[3 * v + k] += g[3 * a + k];
                    }
                }
            }
        };
        for &[v, f] in &c.point_triangle {
            let t = self.faces[f];
            let pts = self.pt_points(x, v, f);
            add([v, t[0], t[1], t[2]], pts, point_triangle_distance2(&pts));
        }
        for &[i, j] in &c.edge_edge {
            let (a, b) = (self.edges[i], self.edges[j]);
            let pts = self.ee_points(x, i, j);
            add([a[0], a[1], b[0], b[1]], pts, edge_edge_distance2(&pts));
        }
        self.for_mesh_pairs(x, &all.mesh_near, |ids, pts, kind| {
            let (d2, ty) = match kind {
                PairKind::PointTriangle => point_triangle_distance2(&pts),
                PairKind::EdgeEdge { .. } => edge_edge_distance2(&pts),
            };
            let d = d2.sqrt();
            if d - self.offset_obstacle < self.activation && d > 0.0 {
                active += 1;
                let g = distance2_derivatives(&pts, ty).gradient / (2.0 * d);
                for (a, id) in ids.iter().enumerate() {
                    if let Some(v) = id {
                        for k in 0..3 {
                            n[3 * v + k] += g[3 * a + k];
                        }
                    }
                }
            }
        });
        for o in &self.obstacles {
            for (v, y) in x.iter().enumerate() {
                let (gap, u) = self.obstacle_gap(o, y);
                if gap < self.activation {
                    active += 1;
                    for k in 0..3 {
                        n[3 * v + k] += u[k];
                    }
                }
            }
        }
        (n, active)
    }

    /// A few lines saying what the term keeps apart and how (for `thinshell check`): d̂, κ
    /// (fixed or adaptive, with its current value), self-contact, the thickness offsets and one
    /// line per obstacle.
    pub fn describe(&self) -> String {
        let kappa = match self.adaptive {
            Some(_) => format!("adaptive, now {:e} J/m²", self.stiffness),
            None => format!("{:e} J/m² (fixed)", self.stiffness),
        };
        let mut text = format!(
            "contact: d̂ = {:e} m, κ {kappa}, self-contact {}, thickness offset {:e} m between sheets, {:e} m to obstacles\n",
            self.activation,
            if self.self_contact { "on" } else { "off" },
            self.offset_self,
            self.offset_obstacle,
        );
        if self.descriptions.is_empty() {
            text += "obstacles: none\n";
        }
        for (k, d) in self.descriptions.iter().enumerate() {
            text += &format!("obstacle {k}: {d}\n");
        }
        text
    }

    /// Whether the shell is kept from passing through itself.
    pub fn self_contact(&self) -> bool {
        self.self_contact
    }

    /// Vertex pairs `[a, b]` (a < b) of every self pair that may come within `reach` (m) of
    /// the offset over the straight motion `x` → `x_end` (bounding boxes of the swept
    /// primitives; `x_end` `None`: at `x`). Empty without self-contact.
    ///
    /// Of the pairs whose boxes overlap, only those whose distance can get that close are
    /// kept: along a straight motion a pair's distance is at least (d₀ + d₁)/2 − M, with d₀, d₁ its distances
    /// at the ends and M the largest displacement of its vertices (it changes by at most 2M·t
    /// from either end; see `Contact::near_pairs`). The box test alone also couples the
    /// in-plane neighbours of every vertex, which are an edge length apart.
    pub fn couplings(&self, x: &[V], x_end: Option<&[V]>, reach: f64) -> Vec<[usize; 2]> {
        if !self.self_contact {
            return Vec::new();
        }
        let dx: Option<Vec<V>> = x_end.map(|e| e.iter().zip(x).map(|(b, a)| b - a).collect());
        let inflate = self.offset_self + reach;
        // Exactly the broad phase's pairs either way, so the pattern does not depend on the
        // cache's history.
        let c = if reach <= self.cache_reach {
            let all = self.candidates_for(x, x_end, reach);
            filter_candidate_pairs(
                &all.own,
                x,
                dx.as_deref(),
                &self.faces,
                &self.edges,
                inflate,
            )
        } else {
            candidate_pairs(x, dx.as_deref(), &self.faces, &self.edges, inflate)
        };
        let limit = self.offset_self + reach;
        let close = |ids: [usize; 4], dist: &dyn Fn(&[V]) -> f64| {
            let (d, m) = match x_end {
                Some(e) => (
                    0.5 * (dist(x) + dist(e)),
                    ids.iter()
                        .map(|&v| (e[v] - x[v]).norm())
                        .fold(0.0, f64::max),
                ),
                None => (dist(x), 0.0),
            };
            // A margin of 10⁻⁶ for rounding; a NaN distance keeps the pair.
            let bound = d - m;
            bound.is_nan() || bound <= (1.0 + 1e-6) * limit
        };
        let mut out = Vec::with_capacity(3 * c.point_triangle.len() + 4 * c.edge_edge.len());
        let mut couple = |a: usize, b: usize| out.push([a.min(b), a.max(b)]);
        for &[v, f] in &c.point_triangle {
            let t = self.faces[f];
            let pt = |y: &[V]| point_triangle_distance2(&self.pt_points(y, v, f)).0.sqrt();
            if close([v, t[0], t[1], t[2]], &pt) {
                t.iter().for_each(|&t| couple(v, t));
            }
        }
        for &[i, j] in &c.edge_edge {
            let (a, b) = (self.edges[i], self.edges[j]);
            let ee = |y: &[V]| edge_edge_distance2(&self.ee_points(y, i, j)).0.sqrt();
            if !close([a[0], a[1], b[0], b[1]], &ee) {
                continue;
            }
            for a in self.edges[i] {
                self.edges[j].iter().for_each(|&b| couple(a, b));
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The largest fraction α ∈ (0, 1] of the step from `x0` to `x1` that keeps every pair apart
    /// (additive CCD with gap fraction 0.1 and minimum separation offset + 10⁻³ d̂); an error
    /// when a pair already starts within the minimum separation.
    pub fn max_step(&self, x0: &[V], x1: &[V]) -> Result<f64, ContactError> {
        first_non_finite(x0, "start of the step")?;
        first_non_finite(x1, "end of the step")?;
        let dx: Vec<V> = x0.iter().zip(x1).map(|(a, b)| b - a).collect();
        let mut alpha = 1.0f64;
        // A superset of the step's pairs, filtered to exactly the broad phase's (so the step
        // does not depend on the cache's history); the broad phase of a new motion is kept for
        // the line search's trials and the next iterate.
        let all = self.candidates_for(x0, Some(x1), self.separation);
        if !self.meshes.is_empty() {
            let xi = self.offset_obstacle + self.separation;
            let settings = CcdSettings {
                min_separation: xi,
                ..CcdSettings::default()
            };
            let (faces, edges, mesh) = (&self.faces, &self.edges, self.meshes.view());
            let c = filter_cross_pairs(&all.mesh, x0, Some(&dx), faces, edges, mesh, xi);
            let mut touching = None;
            self.for_mesh_pairs(x0, &c, |ids, pts, kind| {
                if touching.is_some() {
                    return;
                }
                let d = ids.map(|id| id.map_or(V::zeros(), |v| dx[v]));
                alpha = additive_ccd(&pts, &d, kind, alpha, &settings);
                if alpha == 0.0 {
                    touching = Some(ids);
                }
            });
            if let Some(ids) = touching {
                return Err(ContactError::Intersecting(format!(
                    "shell vertices {:?} of a pair are within the minimum separation of a mesh \
                     obstacle",
                    ids.iter().flatten().collect::<Vec<_>>()
                )));
            }
        }
        if self.self_contact {
            let xi = self.offset_self + self.separation;
            let settings = CcdSettings {
                min_separation: xi,
                ..CcdSettings::default()
            };
            let c = filter_candidate_pairs(&all.own, x0, Some(&dx), &self.faces, &self.edges, xi);
            for &[v, f] in &c.point_triangle {
                let t = self.faces[f];
                let d = [dx[v], dx[t[0]], dx[t[1]], dx[t[2]]];
                alpha = additive_ccd(
                    &self.pt_points(x0, v, f),
                    &d,
                    PairKind::PointTriangle,
                    alpha,
                    &settings,
                );
                if alpha == 0.0 {
                    return Err(ContactError::Intersecting(format!(
                        "vertex {v} is within the minimum separation of face {f}"
                    )));
                }
            }
            for &[i, j] in &c.edge_edge {
                let (a, b) = (self.edges[i], self.edges[j]);
                let d = [dx[a[0]], dx[a[1]], dx[b[0]], dx[b[1]]];
                alpha = additive_ccd(
                    &self.ee_points(x0, i, j),
                    &d,
                    self.ee_kind(i, j),
                    alpha,
                    &settings,
                );
                if alpha == 0.0 {
                    return Err(ContactError::Intersecting(format!(
                        "edge {i} ({}–{}) is within the minimum separation of edge {j} ({}–{})",
                        a[0], a[1], b[0], b[1]
                    )));
                }
            }
        }
        for o in &self.obstacles {
            for (v, (y, d)) in x0.iter().zip(&dx).enumerate() {
                let t = self.obstacle_toi(o, y, d, alpha);
                if t == 0.0 {
                    return Err(ContactError::Intersecting(format!(
                        "vertex {v} is within the minimum separation of obstacle {o:?}"
                    )));
                }
                alpha = alpha.min(t);
            }
        }
        Ok(alpha)
    }

    /// Additive CCD of one vertex against an obstacle: the gap is 1-Lipschitz in the vertex
    /// position, so advancing by 0.9 (gap − ξ)/|d| never crosses ξ.
    fn obstacle_toi(&self, o: &Obstacle, y: &V, d: &V, t_max: f64) -> f64 {
        let xi = self.separation;
        let gap0 = self.obstacle_gap(o, y).0 - xi;
        let speed = d.norm();
        if gap0.is_nan() || gap0 <= 0.0 {
            return 0.0;
        }
        if speed == 0.0 {
            return t_max;
        }
        let target = 0.1 * gap0;
        let (mut t, mut step) = (0.0, 0.9 * gap0 / speed);
        for _ in 0..100_000 {
            let tn = t + step;
            let gap = self.obstacle_gap(o, &(y + d * tn)).0 - xi;
            if gap.is_nan() || gap <= 0.0 || (t > 0.0 && gap < target) {
                return t;
            }
            t = tn;
            if t > t_max {
                return t_max;
            }
            step = 0.9 * gap / speed;
        }
        t.min(t_max)
    }

    /// Checks that positions `x` are intersection-free: every self pair and every vertex–obstacle
    /// gap above the minimum separation, and no edge crossing a face; the error names the first
    /// offending pair.
    pub fn check(&self, x: &[V]) -> Result<(), ContactError> {
        first_non_finite(x, "state")?;
        let xi = self.separation;
        if self.self_contact {
            let c = candidate_pairs(x, None, &self.faces, &self.edges, self.offset_self + xi);
            for &[v, f] in &c.point_triangle {
                let d = point_triangle_distance2(&self.pt_points(x, v, f)).0.sqrt();
                if d.is_nan() || d <= self.offset_self + xi {
                    return Err(ContactError::Intersecting(format!(
                        "vertex {v} and face {f} ({:?}) are {d:e} m apart (need more than {:e} m)",
                        self.faces[f],
                        self.offset_self + xi
                    )));
                }
            }
            for &[i, j] in &c.edge_edge {
                let d = edge_edge_distance2(&self.ee_points(x, i, j)).0.sqrt();
                if d.is_nan() || d <= self.offset_self + xi {
                    return Err(ContactError::Intersecting(format!(
                        "edges {i} {:?} and {j} {:?} are {d:e} m apart (need more than {:e} m)",
                        self.edges[i],
                        self.edges[j],
                        self.offset_self + xi
                    )));
                }
            }
            if let Some((e, f)) = first_edge_crossing_face(x, &self.faces, &self.edges) {
                return Err(ContactError::Intersecting(format!(
                    "edge {e} {:?} crosses face {f} {:?}",
                    self.edges[e], self.faces[f]
                )));
            }
        }
        if !self.meshes.is_empty() {
            self.check_meshes(x)?;
        }
        for o in &self.obstacles {
            for (v, y) in x.iter().enumerate() {
                let gap = self.obstacle_gap(o, y).0;
                if gap.is_nan() || gap <= xi {
                    return Err(ContactError::Intersecting(format!(
                        "vertex {v} has gap {gap:e} m to obstacle {o:?}"
                    )));
                }
            }
        }
        Ok(())
    }
}

impl Contact {
    /// [`Contact::check`] against the mesh obstacles: every pair's gap above the minimum
    /// separation, no shell edge crossing an obstacle face and no obstacle edge crossing a
    /// shell face.
    fn check_meshes(&self, x: &[V]) -> Result<(), ContactError> {
        let xi = self.offset_obstacle + self.separation;
        let o = &self.meshes;
        let c = candidate_pairs_against(x, None, &self.faces, &self.edges, o.view(), xi);
        let near = |d: f64| d.is_nan() || d <= xi;
        for &[v, k] in &c.vertex_face {
            let t = o.faces[k];
            let d =
                point_triangle_distance2(&[x[v], o.points[t[0]], o.points[t[1]], o.points[t[2]]])
                    .0
                    .sqrt();
            if near(d) {
                return Err(ContactError::Intersecting(format!(
                    "vertex {v} is {d:e} m from a face of obstacle {} (a mesh; need more than \
                     {xi:e} m)",
                    self.mesh_owner(t[0])
                )));
            }
        }
        for &[w, k] in &c.face_vertex {
            let t = self.faces[k];
            let d = point_triangle_distance2(&[o.points[w], x[t[0]], x[t[1]], x[t[2]]])
                .0
                .sqrt();
            if near(d) {
                return Err(ContactError::Intersecting(format!(
                    "face {k} {t:?} is {d:e} m from a vertex of obstacle {} (a mesh; need more \
                     than {xi:e} m)",
                    self.mesh_owner(w)
                )));
            }
        }
        for &[i, j] in &c.edge_edge {
            let (a, b) = (self.edges[i], o.edges[j]);
            let d = edge_edge_distance2(&[x[a[0]], x[a[1]], o.points[b[0]], o.points[b[1]]])
                .0
                .sqrt();
            if near(d) {
                return Err(ContactError::Intersecting(format!(
                    "edge {i} {a:?} is {d:e} m from an edge of obstacle {} (a mesh; need more \
                     than {xi:e} m)",
                    self.mesh_owner(b[0])
                )));
            }
        }
        // Crossings: shell edges through obstacle faces, obstacle edges through shell faces.
        fn boxes<const K: usize>(p: &[V], prims: &[[usize; K]]) -> Vec<Aabb> {
            prims
                .iter()
                .map(|f| Aabb::of_points(f.map(|v| p[v]), 0.0))
                .collect()
        }
        let fixed = |v: usize| o.points[v];
        let shell = |v: usize| x[v];
        let (shell_edges, shell_faces) = (boxes(x, &self.edges), boxes(x, &self.faces));
        let (fixed_edges, fixed_faces) = (boxes(&o.points, &o.edges), boxes(&o.points, &o.faces));
        for [e, f] in overlapping_pairs(&shell_edges, &fixed_faces) {
            let (a, t) = (self.edges[e], o.faces[f]);
            if segment_crosses_triangle(&x[a[0]], &x[a[1]], &t.map(fixed)) {
                return Err(ContactError::Intersecting(format!(
                    "edge {e} {a:?} crosses a face of obstacle {} (a mesh)",
                    self.mesh_owner(t[0])
                )));
            }
        }
        for [e, f] in overlapping_pairs(&fixed_edges, &shell_faces) {
            let (a, t) = (o.edges[e], self.faces[f]);
            if segment_crosses_triangle(&o.points[a[0]], &o.points[a[1]], &t.map(shell)) {
                return Err(ContactError::Intersecting(format!(
                    "an edge of obstacle {} (a mesh) crosses face {f} {t:?}",
                    self.mesh_owner(a[0])
                )));
            }
        }
        Ok(())
    }
}

/// The kind of a self edge–edge pair with mollifier threshold `t` (m⁴).
fn ee_kind(t: f64) -> PairKind {
    PairKind::EdgeEdge {
        mollifier_threshold: t,
    }
}

/// The squared distance (m²) from `y` to the segment `a` → `b`.
fn segment_distance2(a: &V, b: &V, y: &V) -> f64 {
    let d = b - a;
    let l2 = d.norm_squared();
    let t = if l2 > 0.0 {
        ((y - a).dot(&d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (y - (a + d * t)).norm_squared()
}

/// An error naming the first vertex of `x` with a non-finite coordinate (NaN bounding boxes
/// would hide it from the broad phase).
fn first_non_finite(x: &[V], what: &str) -> Result<(), ContactError> {
    match x.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(v) => Err(ContactError::Invalid(format!(
            "vertex {v} of the {what} has a non-finite position {:?}",
            x[v]
        ))),
        None => Ok(()),
    }
}

/// The first edge (sharing no vertex with the face) that crosses a face at positions `x`, as
/// `(edge, face)`: two triangles sharing no vertex intersect exactly when an edge of one crosses
/// the other (or they touch, which the distance checks see).
pub fn first_edge_crossing_face(
    x: &[V],
    faces: &[[usize; 3]],
    edges: &[[usize; 2]],
) -> Option<(usize, usize)> {
    let edge_boxes: Vec<Aabb> = edges
        .iter()
        .map(|e| Aabb::of_points(e.map(|v| x[v]), 0.0))
        .collect();
    let face_boxes: Vec<Aabb> = faces
        .iter()
        .map(|f| Aabb::of_points(f.map(|v| x[v]), 0.0))
        .collect();
    overlapping_pairs(&edge_boxes, &face_boxes)
        .into_iter()
        .find_map(|[e, f]| {
            let (ed, fc) = (edges[e], faces[f]);
            let shares = fc.contains(&ed[0]) || fc.contains(&ed[1]);
            (!shares && segment_crosses_triangle(&x[ed[0]], &x[ed[1]], &fc.map(|v| x[v])))
                .then_some((e, f))
        })
}
