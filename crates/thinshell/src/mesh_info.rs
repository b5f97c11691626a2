//! Mesh statistics and the problems found in a mesh (`thinshell info MESH`).

use std::fmt;

use nalgebra::Vector3;
use serde::Serialize;
use thinshell_mesh::Mesh;

/// Faces whose smallest angle is below this (degrees) are reported as slivers.
pub const SLIVER_ANGLE_DEG: f64 = 10.0;

/// Statistics of a mesh at given positions.
#[derive(Clone, Debug, Serialize)]
pub struct MeshInfo {
    /// Vertex count (after dropping unreferenced vertices).
    pub vertices: usize,
    /// Face count.
    pub faces: usize,
    /// Edge count.
    pub edges: usize,
    /// Edges with one incident face.
    pub boundary_edges: usize,
    /// Vertices on the boundary.
    pub boundary_vertices: usize,
    /// Connected components.
    pub components: usize,
    /// V − E + F.
    pub euler_characteristic: i64,
    /// Faces that were flipped to make the orientation consistent.
    pub flipped_faces: usize,
    /// Unreferenced vertices that were dropped.
    pub dropped_vertices: usize,
    /// Axis-aligned bounding box (min, max), m.
    pub bounding_box: ([f64; 3], [f64; 3]),
    /// Total area, m².
    pub area: f64,
    /// Shortest, mean and longest edge, m.
    pub edge_length: [f64; 3],
    /// Smallest angle of any face, degrees.
    pub min_angle_deg: f64,
    /// Largest ratio longest edge / shortest altitude over the faces (√3/2·… = 1.15 for equilateral).
    pub max_aspect_ratio: f64,
    /// Faces with an angle below [`SLIVER_ANGLE_DEG`].
    pub slivers: usize,
    /// Human-readable problems found (empty when none).
    pub problems: Vec<String>,
}

/// Computes the statistics of `mesh` at its own positions.
pub fn mesh_info(mesh: &Mesh) -> MeshInfo {
    let x = mesh.positions();
    let topo = mesh.topology();
    let report = mesh.build_report();
    let bb = mesh.bounding_box();
    let (mut lmin, mut lmax) = (f64::INFINITY, 0.0f64);
    for e in topo.edges() {
        let l = (x[e.vertices[1].idx()] - x[e.vertices[0].idx()]).norm();
        lmin = lmin.min(l);
        lmax = lmax.max(l);
    }
    let (mut area, mut min_angle, mut max_aspect, mut slivers) = (0.0, 180.0f64, 0.0f64, 0);
    for f in mesh.faces() {
        let p: [Vector3<f64>; 3] = [x[f[0].idx()], x[f[1].idx()], x[f[2].idx()]];
        let a2 = (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
        area += 0.5 * a2;
        let mut face_min = 180.0f64;
        let mut longest = 0.0f64;
        for k in 0..3 {
            let u = p[(k + 1) % 3] - p[k];
            let v = p[(k + 2) % 3] - p[k];
            let ang = u.angle(&v).to_degrees();
            face_min = face_min.min(ang);
            longest = longest.max((p[(k + 1) % 3] - p[(k + 2) % 3]).norm());
        }
        min_angle = min_angle.min(face_min);
        if face_min < SLIVER_ANGLE_DEG {
            slivers += 1;
        }
        // Shortest altitude = 2·area / longest edge.
        if a2 > 0.0 {
            max_aspect = max_aspect.max(longest * longest / a2);
        } else {
            max_aspect = f64::INFINITY;
        }
    }
    let n_edges = topo.edges().len();
    let mut problems = Vec::new();
    if report.n_flipped() > 0 {
        problems.push(format!(
            "{} face(s) had the opposite orientation of their neighbours and were flipped",
            report.n_flipped()
        ));
    }
    let dropped = report.n_dropped_vertices;
    if dropped > 0 {
        problems.push(format!("{dropped} unreferenced vertex/vertices dropped"));
    }
    if slivers > 0 {
        problems.push(format!(
            "{slivers} sliver face(s) with an angle below {SLIVER_ANGLE_DEG}° (smallest {min_angle:.3}°)"
        ));
    }
    if topo.n_components() > 1 {
        problems.push(format!(
            "{} connected components (each moves freely unless pinned)",
            topo.n_components()
        ));
    }
    MeshInfo {
        vertices: mesh.n_vertices(),
        faces: mesh.n_faces(),
        edges: n_edges,
        boundary_edges: topo.boundary_edges().len(),
        boundary_vertices: topo.boundary_vertices().len(),
        components: topo.n_components(),
        euler_characteristic: mesh.euler_characteristic(),
        flipped_faces: report.n_flipped(),
        dropped_vertices: dropped,
        bounding_box: (bb.min.into(), bb.max.into()),
        area,
        edge_length: [lmin, thinshell_mesh::mean_edge_length(mesh, x), lmax],
        min_angle_deg: min_angle,
        max_aspect_ratio: max_aspect,
        slivers,
        problems,
    }
}

impl fmt::Display for MeshInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "vertices {}  faces {}  edges {}  components {}  Euler characteristic {}",
            self.vertices, self.faces, self.edges, self.components, self.euler_characteristic
        )?;
        writeln!(
            f,
            "boundary: {} edges, {} vertices{}",
            self.boundary_edges,
            self.boundary_vertices,
            if self.boundary_edges == 0 {
                " (closed)"
            } else {
                ""
            }
        )?;
        let (lo, hi) = self.bounding_box;
        writeln!(
            f,
            "bounding box [{:.4}, {:.4}, {:.4}] – [{:.4}, {:.4}, {:.4}] m, area {:.6} m²",
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], self.area
        )?;
        writeln!(
            f,
            "edge length min {:.4e} mean {:.4e} max {:.4e} m; smallest angle {:.2}°; max aspect ratio {:.2}",
            self.edge_length[0],
            self.edge_length[1],
            self.edge_length[2],
            self.min_angle_deg,
            self.max_aspect_ratio
        )?;
        if self.problems.is_empty() {
            write!(f, "problems: none")
        } else {
            write!(f, "problems:")?;
            for p in &self.problems {
                write!(f, "\n  - {p}")?;
            }
            Ok(())
        }
    }
}
