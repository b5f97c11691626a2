//! Checks of contact runs shared by the solver's contact tests: a mesh's faces and edges as
//! plain vertex indices (what `exact::first_meeting_faces` takes), and the smallest distance
//! between non-adjacent primitives by brute force over all pairs.

use nalgebra::Vector3;
use thinshell_contact::{edge_edge_distance2, point_triangle_distance2};
use thinshell_mesh::Mesh;

type V = Vector3<f64>;

/// The faces and the edges of `mesh` as vertex indices.
pub fn face_edge_indices(mesh: &Mesh) -> (Vec<[usize; 3]>, Vec<[usize; 2]>) {
    let faces = mesh.faces().iter().map(|f| f.map(|v| v.idx())).collect();
    let edges = mesh
        .topology()
        .edges()
        .iter()
        .map(|e| e.vertices.map(|v| v.idx()))
        .collect();
    (faces, edges)
}

/// The smallest distance (m) of every vertex–face and edge–edge pair sharing no vertex, by
/// brute force over all pairs; pairs whose bounding spheres are farther apart than `reach` (m)
/// are skipped (their distance exceeds it), so the result is exact below `reach`.
pub fn brute_force_distance(
    x: &[V],
    faces: &[[usize; 3]],
    edges: &[[usize; 2]],
    reach: f64,
) -> f64 {
    let sphere_of = |pts: &[V]| {
        let c = pts.iter().sum::<V>() / pts.len() as f64;
        let r = pts.iter().map(|p| (p - c).norm()).fold(0.0, f64::max);
        (c, r)
    };
    let face_spheres: Vec<(V, f64)> = faces.iter().map(|f| sphere_of(&f.map(|v| x[v]))).collect();
    let edge_spheres: Vec<(V, f64)> = edges.iter().map(|e| sphere_of(&e.map(|v| x[v]))).collect();
    let mut d = f64::INFINITY;
    for (v, p) in x.iter().enumerate() {
        for (t, &(c, r)) in faces.iter().zip(&face_spheres) {
            if t.contains(&v) || (p - c).norm() - r > reach {
                continue;
            }
            let q = [*p, x[t[0]], x[t[1]], x[t[2]]];
            d = d.min(point_triangle_distance2(&q).0.sqrt());
        }
    }
    for (i, a) in edges.iter().enumerate() {
        for (b, &(c, r)) in edges.iter().zip(&edge_spheres).skip(i + 1) {
            let (ca, ra) = edge_spheres[i];
            if b.contains(&a[0]) || b.contains(&a[1]) || (ca - c).norm() - ra - r > reach {
                continue;
            }
            let q = [x[a[0]], x[a[1]], x[b[0]], x[b[1]]];
            d = d.min(edge_edge_distance2(&q).0.sqrt());
        }
    }
    d
}
