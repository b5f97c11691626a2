//! Broad phase: the candidate contact pairs of a triangle mesh from a uniform spatial hash of
//! axis-aligned bounding boxes: an O(n log n) sort of the boxes' cell keys, then per query a
//! binary search per cell and an O(k log k) sort of its k hits.

use nalgebra::Vector3;

/// An axis-aligned bounding box (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// The lower corner.
    pub min: Vector3<f64>,
    /// The upper corner.
    pub max: Vector3<f64>,
}

impl Aabb {
    /// The box of a set of points, grown by `inflate` (m) on every side.
    pub fn of_points(points: impl IntoIterator<Item = Vector3<f64>>, inflate: f64) -> Aabb {
        let mut min = Vector3::repeat(f64::INFINITY);
        let mut max = Vector3::repeat(f64::NEG_INFINITY);
        for p in points {
            min = min.inf(&p);
            max = max.sup(&p);
        }
        Aabb {
            min: min.add_scalar(-inflate),
            max: max.add_scalar(inflate),
        }
    }

    /// Whether the two closed boxes intersect.
    pub fn overlaps(&self, other: &Aabb) -> bool {
        (0..3).all(|k| self.min[k] <= other.max[k] && other.min[k] <= self.max[k])
    }

    fn extent(&self) -> f64 {
        (self.max - self.min).max()
    }
}

/// Candidate contact pairs: their bounding boxes overlap, and they share no vertex.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CandidatePairs {
    /// `[vertex, face]` pairs, sorted.
    pub point_triangle: Vec<[usize; 2]>,
    /// `[edge i, edge j]` pairs with i < j, sorted.
    pub edge_edge: Vec<[usize; 2]>,
}

/// A uniform grid of cells of side `cell`: the `(cell key, box id)` of every cell each box
/// touches, sorted by key, so that a query looks its cells up by binary search (no hash map and
/// no allocation per cell; keys of distinct cells may collide, which only adds candidates that
/// the exact overlap test then drops).
struct SpatialHash {
    cell: f64,
    keys: Vec<u64>,
    ids: Vec<u32>,
}

/// A cell's key: its integer coordinates mixed by large odd multipliers.
fn cell_key(c: [i64; 3]) -> u64 {
    (c[0] as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (c[1] as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (c[2] as u64).wrapping_mul(0x1656_67B1_9E37_79F9)
}

impl SpatialHash {
    fn new(boxes: &[Aabb]) -> SpatialHash {
        let n = boxes.len().max(1) as f64;
        let mean = boxes.iter().map(Aabb::extent).sum::<f64>() / n;
        let max = boxes.iter().map(Aabb::extent).fold(0.0, f64::max);
        // The mean size keeps a cell to a few boxes; the max / 8 bound keeps a large (fast
        // moving) box to at most 9³ cells.
        let mut cell = mean.max(max / 8.0);
        if !(cell > 0.0 && cell.is_finite()) {
            cell = 1.0;
        }
        let mut hash = SpatialHash {
            cell,
            keys: Vec::new(),
            ids: Vec::new(),
        };
        let mut entries: Vec<(u64, u32)> = Vec::with_capacity(2 * boxes.len());
        for (i, b) in boxes.iter().enumerate() {
            hash.for_cells(b, |key| entries.push((key, i as u32)));
        }
        entries.sort_unstable();
        (hash.keys, hash.ids) = entries.into_iter().unzip();
        hash
    }

    fn range(&self, b: &Aabb) -> ([i64; 3], [i64; 3]) {
        let lo = std::array::from_fn(|k| (b.min[k] / self.cell).floor() as i64);
        let hi = std::array::from_fn(|k| (b.max[k] / self.cell).floor() as i64);
        (lo, hi)
    }

    fn for_cells(&self, b: &Aabb, mut f: impl FnMut(u64)) {
        let (lo, hi) = self.range(b);
        for i in lo[0]..=hi[0] {
            for j in lo[1]..=hi[1] {
                for k in lo[2]..=hi[2] {
                    f(cell_key([i, j, k]));
                }
            }
        }
    }

    /// The ids of boxes sharing a cell key with `b` (sorted, no repeats), into `out`. `seen`
    /// (one entry per box, never equal to `stamp` before this call) marks the ids found, and
    /// `stamp` must differ between calls.
    fn query(&self, b: &Aabb, out: &mut Vec<u32>, seen: &mut [u32], stamp: u32) {
        out.clear();
        self.for_cells(b, |key| {
            let mut p = self.keys.partition_point(|&k| k < key);
            while p < self.keys.len() && self.keys[p] == key {
                let id = self.ids[p];
                if seen[id as usize] != stamp {
                    seen[id as usize] = stamp;
                    out.push(id);
                }
                p += 1;
            }
        });
        out.sort_unstable();
    }
}

/// Per-box marks for [`SpatialHash::query`]: `u32::MAX` is never a stamp (stamps are query
/// indices below the number of queries, which fit in `u32` like the box ids).
fn marks(n: usize) -> Vec<u32> {
    vec![u32::MAX; n]
}

/// All `[i, j]` with `queries[i]` overlapping `boxes[j]`, sorted (the spatial hash is built
/// over `boxes`).
pub fn overlapping_pairs(queries: &[Aabb], boxes: &[Aabb]) -> Vec<[usize; 2]> {
    let hash = SpatialHash::new(boxes);
    let mut hits = Vec::new();
    let mut seen = marks(boxes.len());
    let mut out = Vec::new();
    for (i, q) in queries.iter().enumerate() {
        hash.query(q, &mut hits, &mut seen, i as u32);
        out.extend(
            hits.iter()
                .map(|&j| j as usize)
                .filter(|&j| boxes[j].overlaps(q))
                .map(|j| [i, j]),
        );
    }
    out
}

/// The boxes [`candidate_pairs`] tests: every primitive's box over the motion x → x + dx,
/// a vertex's grown by `inflate`, an edge's by `inflate / 2`, a face's not at all.
struct SweptBoxes<'a> {
    x: &'a [Vector3<f64>],
    dx: Option<&'a [Vector3<f64>]>,
    inflate: f64,
}

impl SweptBoxes<'_> {
    fn of(&self, ids: &[usize], grow: f64) -> Aabb {
        Aabb::of_points(
            ids.iter().flat_map(|&v| {
                let end = self.dx.map_or(self.x[v], |d| self.x[v] + d[v]);
                [self.x[v], end]
            }),
            grow,
        )
    }

    fn vertex(&self, v: usize) -> Aabb {
        self.of(&[v], self.inflate)
    }

    fn face(&self, f: &[usize; 3]) -> Aabb {
        self.of(f, 0.0)
    }

    fn edge(&self, e: &[usize; 2]) -> Aabb {
        self.of(e, 0.5 * self.inflate)
    }
}

/// Candidate point–triangle and edge–edge pairs of a mesh for positions `x` (m) and, when
/// given, the step `dx` (the boxes then cover the swept volume x → x + dx).
///
/// A vertex's box is grown by `inflate` (m): pass the activation distance plus offsets for
/// barrier pairs, the CCD's minimum separation for a step. Edge boxes are grown by
/// `inflate / 2` on each of the two edges. Pairs that share a vertex are excluded.
pub fn candidate_pairs(
    x: &[Vector3<f64>],
    dx: Option<&[Vector3<f64>]>,
    faces: &[[usize; 3]],
    edges: &[[usize; 2]],
    inflate: f64,
) -> CandidatePairs {
    let boxes = SweptBoxes { x, dx, inflate };
    let face_boxes: Vec<Aabb> = faces.iter().map(|f| boxes.face(f)).collect();
    let edge_boxes: Vec<Aabb> = edges.iter().map(|e| boxes.edge(e)).collect();
    let mut out = CandidatePairs::default();
    let mut hits = Vec::new();

    let hash = SpatialHash::new(&face_boxes);
    let mut seen = marks(face_boxes.len());
    for v in 0..x.len() {
        let b = boxes.vertex(v);
        hash.query(&b, &mut hits, &mut seen, v as u32);
        for &f in &hits {
            let f = f as usize;
            if !faces[f].contains(&v) && face_boxes[f].overlaps(&b) {
                out.point_triangle.push([v, f]);
            }
        }
    }

    let hash = SpatialHash::new(&edge_boxes);
    let mut seen = marks(edge_boxes.len());
    for (i, e) in edges.iter().enumerate() {
        hash.query(&edge_boxes[i], &mut hits, &mut seen, i as u32);
        for &j in &hits {
            let j = j as usize;
            if j > i
                && !edges[j].contains(&e[0])
                && !edges[j].contains(&e[1])
                && edge_boxes[j].overlaps(&edge_boxes[i])
            {
                out.edge_edge.push([i, j]);
            }
        }
    }
    out
}

/// The pairs of `superset` (sorted, as [`candidate_pairs`] returns them) that
/// [`candidate_pairs`] with the same arguments would return, in the same order, by the same box
/// tests: equal to it whenever `superset` contains its result (e.g. the candidates of a larger
/// inflation at nearby positions), without a broad phase.
pub fn filter_candidate_pairs(
    superset: &CandidatePairs,
    x: &[Vector3<f64>],
    dx: Option<&[Vector3<f64>]>,
    faces: &[[usize; 3]],
    edges: &[[usize; 2]],
    inflate: f64,
) -> CandidatePairs {
    let boxes = SweptBoxes { x, dx, inflate };
    CandidatePairs {
        point_triangle: superset
            .point_triangle
            .iter()
            .copied()
            .filter(|&[v, f]| boxes.face(&faces[f]).overlaps(&boxes.vertex(v)))
            .collect(),
        edge_edge: superset
            .edge_edge
            .iter()
            .copied()
            .filter(|&[i, j]| boxes.edge(&edges[j]).overlaps(&boxes.edge(&edges[i])))
            .collect(),
    }
}

/// Candidate pairs between a moving mesh (the shell) and a fixed one (an obstacle): their
/// bounding boxes overlap. Indices are into the shell's and the obstacle's own vertex, face and
/// edge lists; no pair shares a vertex (the meshes are disjoint).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CrossPairs {
    /// `[shell vertex, obstacle face]`, sorted.
    pub vertex_face: Vec<[usize; 2]>,
    /// `[obstacle vertex, shell face]`, sorted.
    pub face_vertex: Vec<[usize; 2]>,
    /// `[shell edge, obstacle edge]`, sorted.
    pub edge_edge: Vec<[usize; 2]>,
}

impl CrossPairs {
    /// The number of pairs of all three kinds.
    pub fn len(&self) -> usize {
        self.vertex_face.len() + self.face_vertex.len() + self.edge_edge.len()
    }

    /// Whether there is no pair.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A fixed triangle mesh's primitives: vertex positions (m), faces and edges as vertex indices.
#[derive(Clone, Copy, Debug)]
pub struct StaticMesh<'a> {
    /// Vertex positions (m).
    pub points: &'a [Vector3<f64>],
    /// Triangles.
    pub faces: &'a [[usize; 3]],
    /// Edges (each once).
    pub edges: &'a [[usize; 2]],
}

/// Candidate pairs between the shell at positions `x` (m), moving by `dx` when given (swept
/// boxes), and a fixed `obstacle` mesh, with the same box growth as [`candidate_pairs`]: a
/// vertex's box (shell or obstacle) grown by `inflate`, every edge's by `inflate / 2`, faces'
/// not at all.
pub fn candidate_pairs_against(
    x: &[Vector3<f64>],
    dx: Option<&[Vector3<f64>]>,
    faces: &[[usize; 3]],
    edges: &[[usize; 2]],
    obstacle: StaticMesh<'_>,
    inflate: f64,
) -> CrossPairs {
    let boxes = SweptBoxes { x, dx, inflate };
    let fixed = SweptBoxes {
        x: obstacle.points,
        dx: None,
        inflate,
    };
    let shell_vertices: Vec<Aabb> = (0..x.len()).map(|v| boxes.vertex(v)).collect();
    let obstacle_faces: Vec<Aabb> = obstacle.faces.iter().map(|f| fixed.face(f)).collect();
    let obstacle_vertices: Vec<Aabb> = (0..obstacle.points.len())
        .map(|v| fixed.vertex(v))
        .collect();
    let shell_faces: Vec<Aabb> = faces.iter().map(|f| boxes.face(f)).collect();
    let shell_edges: Vec<Aabb> = edges.iter().map(|e| boxes.edge(e)).collect();
    let obstacle_edges: Vec<Aabb> = obstacle.edges.iter().map(|e| fixed.edge(e)).collect();
    CrossPairs {
        vertex_face: overlapping_pairs(&shell_vertices, &obstacle_faces),
        face_vertex: overlapping_pairs(&obstacle_vertices, &shell_faces),
        edge_edge: overlapping_pairs(&shell_edges, &obstacle_edges),
    }
}

/// The pairs of `superset` that [`candidate_pairs_against`] with the same arguments would
/// return, by the same box tests, in the same order (see [`filter_candidate_pairs`]).
pub fn filter_cross_pairs(
    superset: &CrossPairs,
    x: &[Vector3<f64>],
    dx: Option<&[Vector3<f64>]>,
    faces: &[[usize; 3]],
    edges: &[[usize; 2]],
    obstacle: StaticMesh<'_>,
    inflate: f64,
) -> CrossPairs {
    let boxes = SweptBoxes { x, dx, inflate };
    let fixed = SweptBoxes {
        x: obstacle.points,
        dx: None,
        inflate,
    };
    let keep = |pairs: &[[usize; 2]], test: &dyn Fn(usize, usize) -> bool| -> Vec<[usize; 2]> {
        pairs.iter().copied().filter(|&[i, j]| test(i, j)).collect()
    };
    CrossPairs {
        vertex_face: keep(&superset.vertex_face, &|v, f| {
            fixed.face(&obstacle.faces[f]).overlaps(&boxes.vertex(v))
        }),
        face_vertex: keep(&superset.face_vertex, &|v, f| {
            boxes.face(&faces[f]).overlaps(&fixed.vertex(v))
        }),
        edge_edge: keep(&superset.edge_edge, &|i, j| {
            fixed
                .edge(&obstacle.edges[j])
                .overlaps(&boxes.edge(&edges[i]))
        }),
    }
}
