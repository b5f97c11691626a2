//! Face-based connectivity ("face-based half-edge"): built once per mesh.
//!
//! Half-edge `h = 3 f + e` is local edge `e` of face `f`, the edge **opposite** local vertex
//! `e`; it runs from vertex `f[(e + 1) % 3]` to vertex `f[(e + 2) % 3]`. Connectivity is found by
//! sorting the half-edges by their undirected key `(min, max)` (no hashing), so that building is
//! `O(n log n)` with small constants (about a second for a million faces).

use crate::ids::{EdgeId, FaceId, VertexId};

/// Marker for "no half-edge / no face" in the compact arrays.
pub(crate) const NONE: u32 = u32::MAX;

/// An undirected edge of the mesh with its one or two incident faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// The two end vertices, in the direction the edge runs in face `left`'s orientation.
    pub vertices: [VertexId; 2],
    /// The incident face with the lower index.
    pub left: FaceId,
    /// The other incident face (it runs the edge as `vertices[1] -> vertices[0]`), `None` on
    /// the boundary.
    pub right: Option<FaceId>,
}

/// Undirected half-edge pairing, independent of face orientation.
#[derive(Clone, Debug)]
pub(crate) struct Adjacency {
    /// Per half-edge: the other half-edge of the same undirected edge, or [`NONE`].
    pub twin: Vec<u32>,
    /// Per half-edge: its edge id.
    pub he_edge: Vec<u32>,
    /// Per edge: its lowest-index half-edge.
    pub edge_he: Vec<u32>,
}

/// A non-manifold edge found while pairing: its sorted vertices and all faces using it.
#[derive(Clone, Debug)]
pub(crate) struct NonManifold {
    pub vertices: [u32; 2],
    pub faces: Vec<u32>,
}

#[inline]
fn he_vertices(faces: &[[u32; 3]], h: usize) -> (u32, u32) {
    let f = faces[h / 3];
    let e = h % 3;
    (f[(e + 1) % 3], f[(e + 2) % 3])
}

/// Pairs half-edges by sorting their undirected keys `(lo, hi)`, `lo < hi`.
///
/// A counting sort by `lo` (one bucket per vertex) followed by `sort_unstable` of each small
/// bucket by `(hi, half-edge)` gives the same order as sorting all keys at once, at a fraction
/// of the cost. Assumes indices `< n_vertices` and three distinct vertices per face.
pub(crate) fn build_adjacency(
    faces: &[[u32; 3]],
    n_vertices: usize,
) -> Result<Adjacency, NonManifold> {
    let n_he = faces.len() * 3;
    let key = |h: usize| -> (u32, u32) {
        let (a, b) = he_vertices(faces, h);
        if a < b { (a, b) } else { (b, a) }
    };
    let mut offsets = vec![0usize; n_vertices + 1];
    for h in 0..n_he {
        offsets[key(h).0 as usize + 1] += 1;
    }
    for v in 0..n_vertices {
        offsets[v + 1] += offsets[v];
    }
    // (hi, half-edge) per bucket; filled in half-edge order.
    let mut entries = vec![(0u32, 0u32); n_he];
    let mut fill = offsets.clone();
    for h in 0..n_he {
        let (lo, hi) = key(h);
        entries[fill[lo as usize]] = (hi, h as u32);
        fill[lo as usize] += 1;
    }
    drop(fill);

    let mut twin = vec![NONE; n_he];
    let mut he_edge = vec![0u32; n_he];
    let mut edge_he = Vec::with_capacity(n_he / 2 + 1);
    for lo in 0..n_vertices {
        let bucket = &mut entries[offsets[lo]..offsets[lo + 1]];
        bucket.sort_unstable();
        let mut i = 0;
        while i < bucket.len() {
            let hi = bucket[i].0;
            let mut j = i + 1;
            while j < bucket.len() && bucket[j].0 == hi {
                j += 1;
            }
            match j - i {
                1 => {}
                2 => {
                    let (h0, h1) = (bucket[i].1, bucket[i + 1].1);
                    twin[h0 as usize] = h1;
                    twin[h1 as usize] = h0;
                }
                _ => {
                    return Err(NonManifold {
                        vertices: [lo as u32, hi],
                        faces: bucket[i..j].iter().map(|&(_, h)| h / 3).collect(),
                    });
                }
            }
            let id = edge_he.len() as u32;
            for &(_, h) in &bucket[i..j] {
                he_edge[h as usize] = id;
            }
            edge_he.push(bucket[i].1);
            i = j;
        }
    }
    Ok(Adjacency {
        twin,
        he_edge,
        edge_he,
    })
}

/// Face-based connectivity of a consistently oriented, edge-manifold triangle mesh.
///
/// Obtained from [`Mesh::topology`](crate::Mesh::topology). Local edge `e` of a face is the
/// edge opposite its local vertex `e`; everything per face is indexed that way.
#[derive(Clone, Debug)]
pub struct Topology {
    neighbors: Vec<[u32; 3]>,
    flaps: Vec<[u32; 3]>,
    face_edges: Vec<[EdgeId; 3]>,
    edges: Vec<Edge>,
    boundary_edges: Vec<EdgeId>,
    boundary_vertices: Vec<VertexId>,
    is_boundary: Vec<bool>,
    vf_offsets: Vec<usize>,
    vf_faces: Vec<FaceId>,
    face_component: Vec<u32>,
    n_components: usize,
}

impl Topology {
    /// Assembles the topology from oriented faces and a matching half-edge pairing.
    pub(crate) fn from_parts(
        faces: &[[u32; 3]],
        n_vertices: usize,
        adj: &Adjacency,
        face_component: Vec<u32>,
        n_components: usize,
    ) -> Topology {
        let n_faces = faces.len();
        let mut neighbors = vec![[NONE; 3]; n_faces];
        let mut flaps = vec![[NONE; 3]; n_faces];
        let mut face_edges = vec![[EdgeId(0); 3]; n_faces];
        for f in 0..n_faces {
            for e in 0..3 {
                let h = 3 * f + e;
                let t = adj.twin[h];
                if t != NONE {
                    let g = (t / 3) as usize;
                    neighbors[f][e] = g as u32;
                    flaps[f][e] = faces[g][(t % 3) as usize];
                }
                face_edges[f][e] = EdgeId(adj.he_edge[h]);
            }
        }

        let mut edges = Vec::with_capacity(adj.edge_he.len());
        let mut boundary_edges = Vec::new();
        let mut is_boundary = vec![false; n_vertices];
        for (id, &h) in adj.edge_he.iter().enumerate() {
            let (a, b) = he_vertices(faces, h as usize);
            let t = adj.twin[h as usize];
            let right = (t != NONE).then_some(FaceId(t / 3));
            if right.is_none() {
                boundary_edges.push(EdgeId(id as u32));
                is_boundary[a as usize] = true;
                is_boundary[b as usize] = true;
            }
            edges.push(Edge {
                vertices: [VertexId(a), VertexId(b)],
                left: FaceId(h / 3),
                right,
            });
        }
        let boundary_vertices = is_boundary
            .iter()
            .enumerate()
            .filter(|&(_, &b)| b)
            .map(|(v, _)| VertexId(v as u32))
            .collect();

        // vertex -> faces in compressed sparse row form; faces ascending per vertex.
        let mut vf_offsets = vec![0usize; n_vertices + 1];
        for tri in faces {
            for &v in tri {
                vf_offsets[v as usize + 1] += 1;
            }
        }
        for v in 0..n_vertices {
            vf_offsets[v + 1] += vf_offsets[v];
        }
        let mut fill = vf_offsets.clone();
        let mut vf_faces = vec![FaceId(0); 3 * n_faces];
        for (f, tri) in faces.iter().enumerate() {
            for &v in tri {
                vf_faces[fill[v as usize]] = FaceId(f as u32);
                fill[v as usize] += 1;
            }
        }

        Topology {
            neighbors,
            flaps,
            face_edges,
            edges,
            boundary_edges,
            boundary_vertices,
            is_boundary,
            vf_offsets,
            vf_faces,
            face_component,
            n_components,
        }
    }

    /// Neighbouring face across each local edge `e` (opposite local vertex `e`); `None` on the
    /// boundary.
    #[inline]
    pub fn face_neighbors(&self, f: FaceId) -> [Option<FaceId>; 3] {
        self.neighbors[f.idx()].map(|g| (g != NONE).then_some(FaceId(g)))
    }

    /// The "flap" vertex across each local edge `e`: the vertex of the neighbouring face that is
    /// not on the shared edge; `None` on the boundary.
    #[inline]
    pub fn flap_vertices(&self, f: FaceId) -> [Option<VertexId>; 3] {
        self.flaps[f.idx()].map(|v| (v != NONE).then_some(VertexId(v)))
    }

    /// Global edge id of each local edge `e` of face `f`.
    #[inline]
    pub fn face_edges(&self, f: FaceId) -> [EdgeId; 3] {
        self.face_edges[f.idx()]
    }

    /// All edges, sorted by their (smaller, larger) vertex pair.
    #[inline]
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// One edge.
    #[inline]
    pub fn edge(&self, e: EdgeId) -> &Edge {
        &self.edges[e.idx()]
    }

    /// Edges with only one incident face, ascending.
    #[inline]
    pub fn boundary_edges(&self) -> &[EdgeId] {
        &self.boundary_edges
    }

    /// Vertices on a boundary edge, ascending.
    #[inline]
    pub fn boundary_vertices(&self) -> &[VertexId] {
        &self.boundary_vertices
    }

    /// Whether `v` lies on a boundary edge.
    #[inline]
    pub fn is_boundary_vertex(&self, v: VertexId) -> bool {
        self.is_boundary[v.idx()]
    }

    /// Faces containing vertex `v` (its one-ring), ascending by index.
    #[inline]
    pub fn vertex_faces(&self, v: VertexId) -> &[FaceId] {
        &self.vf_faces[self.vf_offsets[v.idx()]..self.vf_offsets[v.idx() + 1]]
    }

    /// Number of edge-connected components.
    #[inline]
    pub fn n_components(&self) -> usize {
        self.n_components
    }

    /// Component index of face `f` (components are numbered by their lowest face index).
    #[inline]
    pub fn face_component(&self, f: FaceId) -> usize {
        self.face_component[f.idx()] as usize
    }
}

/// Vertices on an edge used by exactly one face, from a face list alone: no validation, so that
/// deformed frames (whose faces may be degenerate) and meshes read raw get their boundary too
/// (`thinshell view`). For a validated [`crate::Mesh`], [`Topology::boundary_vertices`].
pub fn boundary_vertex_mask(n_vertices: usize, faces: &[[u32; 3]]) -> Vec<bool> {
    let mut count: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    for f in faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut boundary = vec![false; n_vertices];
    for ((a, b), n) in count {
        if n == 1 {
            for v in [a, b] {
                if let Some(slot) = boundary.get_mut(v as usize) {
                    *slot = true;
                }
            }
        }
    }
    boundary
}
