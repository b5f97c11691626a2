//! The validated triangle mesh.

use std::sync::Arc;

use nalgebra::Vector3;

use crate::bounding_box::BoundingBox;
use crate::error::MeshError;
use crate::ids::{FaceId, VertexId};
use crate::orient;
use crate::topology::{self, Topology};

/// A face is rejected as degenerate (zero area) when
/// `|e1 × e2| ≤ DEGENERATE_TOLERANCE · ℓ_max²`, with `ℓ_max` its longest edge.
///
/// The measure is scale invariant (`√3/2` for an equilateral triangle, about the sine of the
/// smallest angle for a sliver), so a face is judged by its shape, not by its size relative
/// to the rest of the mesh; collinear or coincident vertices always fail.
pub const DEGENERATE_TOLERANCE: f64 = 1e-12;

/// What [`Mesh::new`] did to the input.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BuildReport {
    /// Faces whose orientation was reversed (`[i, j, k] -> [i, k, j]`), ascending.
    pub flipped_faces: Vec<FaceId>,
    /// Number of edge-connected components.
    pub n_components: usize,
    /// For every input vertex its new index, or `None` if it was dropped as unreferenced.
    pub vertex_map: Vec<Option<VertexId>>,
    /// Number of dropped (unreferenced) vertices.
    pub n_dropped_vertices: usize,
}

impl BuildReport {
    /// Number of flipped faces.
    pub fn n_flipped(&self) -> usize {
        self.flipped_faces.len()
    }
}

/// A validated, consistently oriented, edge-manifold triangle mesh with its connectivity.
///
/// Connectivity, faces and the build report are shared (reference counted), so
/// [`Mesh::with_positions`] and `clone` are cheap apart from copying positions.
#[derive(Clone, Debug)]
pub struct Mesh {
    positions: Vec<Vector3<f64>>,
    faces: Arc<[[VertexId; 3]]>,
    topology: Arc<Topology>,
    report: Arc<BuildReport>,
}

pub(crate) fn check_finite(positions: &[Vector3<f64>]) -> Result<(), MeshError> {
    for (v, p) in positions.iter().enumerate() {
        for axis in 0..3 {
            if !p[axis].is_finite() {
                return Err(MeshError::NonFiniteCoordinate {
                    vertex: v,
                    axis,
                    value: p[axis],
                });
            }
        }
    }
    Ok(())
}

/// `|e1 × e2| / ℓ_max²` of a triangle: 0 for degenerate, `√3/2` for equilateral.
///
/// The edges are first divided by their largest component, so that neither tiny nor huge
/// coordinates under- or overflow.
pub(crate) fn relative_area(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> f64 {
    let (u, v) = (b - a, c - a);
    let scale = u.amax().max(v.amax());
    if !(scale > 0.0 && scale.is_finite()) {
        return 0.0;
    }
    let (u, v) = (u / scale, v / scale);
    let l2 = u
        .norm_squared()
        .max(v.norm_squared())
        .max((v - u).norm_squared());
    u.cross(&v).norm() / l2
}

impl Mesh {
    /// Validates the input, drops unreferenced vertices, orients every connected component
    /// consistently and builds the connectivity.
    ///
    /// Checks, in this order (errors name the input face / vertex indices):
    /// [`MeshError::Empty`], [`MeshError::IndexOutOfRange`], [`MeshError::RepeatedVertex`],
    /// [`MeshError::NonFiniteCoordinate`] (all vertices, referenced or not),
    /// [`MeshError::DegenerateFace`] (see [`DEGENERATE_TOLERANCE`]),
    /// then [`MeshError::DuplicateFace`] (same vertex set in any order; reported in preference
    /// to the non-manifold edge a duplicate usually creates) and
    /// [`MeshError::NonManifoldEdge`] (an edge in three or more faces), and finally
    /// [`MeshError::NonOrientable`].
    ///
    /// Vertices used by no face are **dropped**; the remaining vertices keep their relative
    /// order and [`BuildReport::vertex_map`] gives old → new indices. Face order is kept.
    /// Faces are flipped per component to the majority orientation (ties keep the orientation
    /// of the component's lowest-index face); [`BuildReport::flipped_faces`] lists them.
    /// Vertices where several fans meet only at a point are accepted (edge-manifold suffices).
    pub fn new(positions: Vec<Vector3<f64>>, faces: Vec<[usize; 3]>) -> Result<Mesh, MeshError> {
        const LIMIT: usize = (u32::MAX - 1) as usize;
        if faces.is_empty() {
            return Err(MeshError::Empty);
        }
        if positions.len() > LIMIT {
            return Err(MeshError::TooLarge {
                what: "vertices",
                count: positions.len(),
                limit: LIMIT,
            });
        }
        if faces.len() > LIMIT / 3 {
            return Err(MeshError::TooLarge {
                what: "faces",
                count: faces.len(),
                limit: LIMIT / 3,
            });
        }
        let n_in = positions.len();
        for (f, tri) in faces.iter().enumerate() {
            for (corner, &index) in tri.iter().enumerate() {
                if index >= n_in {
                    return Err(MeshError::IndexOutOfRange {
                        face: f,
                        corner,
                        index,
                        n_vertices: n_in,
                    });
                }
            }
            if tri[0] == tri[1] || tri[0] == tri[2] {
                return Err(MeshError::RepeatedVertex {
                    face: f,
                    vertex: tri[0],
                });
            }
            if tri[1] == tri[2] {
                return Err(MeshError::RepeatedVertex {
                    face: f,
                    vertex: tri[1],
                });
            }
        }
        check_finite(&positions)?;
        for (f, tri) in faces.iter().enumerate() {
            let r = relative_area(&positions[tri[0]], &positions[tri[1]], &positions[tri[2]]);
            if r <= DEGENERATE_TOLERANCE {
                return Err(MeshError::DegenerateFace {
                    face: f,
                    relative_area: r,
                });
            }
        }

        // Drop unreferenced vertices, keeping the order of the others.
        let mut used = vec![false; n_in];
        for tri in &faces {
            for &v in tri {
                used[v] = true;
            }
        }
        let mut vertex_map = vec![None; n_in];
        let mut old_of_new: Vec<usize> = Vec::with_capacity(n_in);
        let mut new_positions = Vec::with_capacity(n_in);
        for v in 0..n_in {
            if used[v] {
                vertex_map[v] = Some(VertexId::new(old_of_new.len()));
                old_of_new.push(v);
                new_positions.push(positions[v]);
            }
        }
        let n_dropped_vertices = n_in - old_of_new.len();
        let mut tris: Vec<[u32; 3]> = faces
            .iter()
            .map(|t| t.map(|v| vertex_map[v].map_or(0, |id| id.0)))
            .collect();
        drop(positions);

        let mut adj = match topology::build_adjacency(&tris, new_positions.len()) {
            Ok(adj) => adj,
            Err(nm) => {
                // Two copies of a face next to a third face look non-manifold; name the
                // duplicate, which is the more useful diagnosis.
                let fs: Vec<usize> = nm.faces.iter().map(|&f| f as usize).collect();
                for (i, &f) in fs.iter().enumerate() {
                    for &g in &fs[i + 1..] {
                        check_duplicate_pair(&faces, f.min(g), f.max(g))?;
                    }
                }
                return Err(MeshError::NonManifoldEdge {
                    vertices: nm.vertices.map(|v| old_of_new[v as usize]),
                    faces: fs,
                });
            }
        };
        // On an edge-manifold mesh a duplicated face is the neighbour across all three of its
        // copy's edges.
        for f in 0..tris.len() {
            let t = &adj.twin[3 * f..3 * f + 3];
            if t[0] != topology::NONE && t[0] / 3 == t[1] / 3 && t[1] / 3 == t[2] / 3 {
                let g = (t[0] / 3) as usize;
                check_duplicate_pair(&faces, f.min(g), f.max(g))?;
            }
        }
        let orientation = orient::orient(&tris, &adj).map_err(|c| MeshError::NonOrientable {
            face: c.face as usize,
            neighbor: c.neighbor as usize,
            edge: c.edge.map(|v| old_of_new[v as usize]),
        })?;
        orient::apply_flips(&mut tris, &mut adj, &orientation.flip);
        let flipped_faces = orientation
            .flip
            .iter()
            .enumerate()
            .filter(|&(_, &b)| b)
            .map(|(f, _)| FaceId::new(f))
            .collect();
        let n_components = orientation.n_components;
        let topology = Topology::from_parts(
            &tris,
            new_positions.len(),
            &adj,
            orientation.face_component,
            n_components,
        );
        let faces: Arc<[[VertexId; 3]]> = tris.iter().map(|t| t.map(VertexId)).collect();
        Ok(Mesh {
            positions: new_positions,
            faces,
            topology: Arc::new(topology),
            report: Arc::new(BuildReport {
                flipped_faces,
                n_components,
                vertex_map,
                n_dropped_vertices,
            }),
        })
    }

    /// Vertex positions (m).
    #[inline]
    pub fn positions(&self) -> &[Vector3<f64>] {
        &self.positions
    }

    /// Faces as vertex triples, consistently oriented within each component.
    #[inline]
    pub fn faces(&self) -> &[[VertexId; 3]] {
        &self.faces
    }

    /// Number of vertices.
    #[inline]
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    #[inline]
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// Number of (undirected) edges.
    #[inline]
    pub fn n_edges(&self) -> usize {
        self.topology.edges().len()
    }

    /// Connectivity.
    #[inline]
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// What [`Mesh::new`] changed: flipped faces, components, dropped vertices.
    #[inline]
    pub fn build_report(&self) -> &BuildReport {
        &self.report
    }

    /// Euler characteristic `V − E + F`.
    pub fn euler_characteristic(&self) -> i64 {
        self.n_vertices() as i64 - self.n_edges() as i64 + self.n_faces() as i64
    }

    /// The same connectivity with new vertex positions (m).
    ///
    /// Only the length and finiteness are checked (`WrongPositionCount`,
    /// `NonFiniteCoordinate`): deformed configurations may have degenerate faces.
    pub fn with_positions(&self, positions: Vec<Vector3<f64>>) -> Result<Mesh, MeshError> {
        if positions.len() != self.n_vertices() {
            return Err(MeshError::WrongPositionCount {
                expected: self.n_vertices(),
                found: positions.len(),
            });
        }
        check_finite(&positions)?;
        Ok(Mesh {
            positions,
            faces: Arc::clone(&self.faces),
            topology: Arc::clone(&self.topology),
            report: Arc::clone(&self.report),
        })
    }

    /// Faces as `usize` triples (for handing to other tools).
    pub fn faces_usize(&self) -> Vec<[usize; 3]> {
        self.faces.iter().map(|t| t.map(VertexId::idx)).collect()
    }

    /// Axis-aligned bounding box of the vertex positions (m); its
    /// [`diagonal`](BoundingBox::diagonal) is the mesh's length scale.
    pub fn bounding_box(&self) -> BoundingBox {
        // A mesh has at least one face, hence at least three vertices.
        BoundingBox::from_points(&*self.positions).unwrap_or(BoundingBox {
            min: Vector3::zeros(),
            max: Vector3::zeros(),
        })
    }

    /// The vertex closest to `p` (Euclidean distance, m); ties go to the lowest index.
    ///
    /// A linear scan: O(n_vertices) per call, meant for picking a few vertices (pins, probes).
    /// A non-finite `p` gives vertex 0.
    ///
    /// ```
    /// use thinshell_mesh::{generators, VertexId};
    /// use thinshell_mesh::nalgebra::Vector3;
    ///
    /// // 3 × 3 cells of 1 m: vertex (i, j) has index 4 j + i.
    /// let mesh = generators::rectangle(3.0, 3.0, 3, 3)?;
    /// assert_eq!(mesh.nearest_vertex(&Vector3::new(2.1, 0.9, 0.5)), VertexId(6));
    /// // Equidistant from vertices 0 and 1: the lower index wins.
    /// assert_eq!(mesh.nearest_vertex(&Vector3::new(0.5, 0.0, 0.0)), VertexId(0));
    /// # Ok::<(), thinshell_mesh::MeshError>(())
    /// ```
    pub fn nearest_vertex(&self, p: &Vector3<f64>) -> VertexId {
        let mut best = (0, f64::INFINITY);
        for (v, q) in self.positions.iter().enumerate() {
            let d2 = (q - p).norm_squared();
            // Strictly smaller: on a tie the earlier (lower) index stays.
            if d2 < best.1 {
                best = (v, d2);
            }
        }
        VertexId::new(best.0)
    }
}

/// `DuplicateFace` if faces `first < face` have the same vertex set.
fn check_duplicate_pair(faces: &[[usize; 3]], first: usize, face: usize) -> Result<(), MeshError> {
    let sorted = |f: usize| {
        let mut k = faces[f];
        k.sort_unstable();
        k
    };
    if sorted(first) == sorted(face) {
        return Err(MeshError::DuplicateFace {
            face,
            first,
            vertices: sorted(first),
        });
    }
    Ok(())
}
