//! Normals, areas and mid-edge normals against analytic values.
#![allow(clippy::unwrap_used)]

use nalgebra::{Rotation3, Vector3};
use thinshell_mesh::{FaceId, Mesh, VertexId, generators, geometry};

#[test]
fn single_triangle_normal_and_area() {
    let x = vec![
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.0, 2.0, 0.0),
        Vector3::new(0.0, 0.0, 3.0),
    ];
    let m = Mesh::new(x.clone(), vec![[0, 1, 2]]).unwrap();
    // Plane x + y/2 + z/3 = 1: normal ∝ (6, 3, 2) / 7; area = |(−1,2,0) × (−1,0,3)| / 2 = 7/2.
    let n = geometry::face_normal(&x, [VertexId(0), VertexId(1), VertexId(2)]);
    assert!((n - Vector3::new(6.0, 3.0, 2.0) / 7.0).norm() < 1e-15);
    assert!((geometry::face_areas(&m, &x)[0] - 3.5).abs() < 1e-15);
    // All three edges are boundary edges: their mid-edge normal is the face normal.
    for me in geometry::mid_edge_normals(&m, &x) {
        assert!((me - n).norm() < 1e-15);
    }
    let flat = vec![x[0], x[0], x[1]];
    assert!(
        geometry::checked_face_normal(&flat, [VertexId(0), VertexId(1), VertexId(2)]).is_none()
    );
}

#[test]
fn flat_mesh_mid_edge_normals_equal_the_face_normal() {
    // An irregular sheet rotated to an arbitrary plane.
    let m = generators::irregular_rectangle(1.0, 0.7, 8, 5).unwrap();
    let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    let x: Vec<Vector3<f64>> = m.positions().iter().map(|p| rot * p).collect();
    let n = rot * Vector3::z();
    for fnrm in geometry::face_normals(&m, &x) {
        assert!((fnrm - n).norm() < 1e-13);
    }
    let me = geometry::mid_edge_normals(&m, &x);
    assert_eq!(me.len(), m.n_edges());
    for v in me {
        assert!((v - n).norm() < 1e-13, "{v} vs {n}");
    }
}

#[test]
fn hinge_mid_edge_normal_is_the_bisector() {
    // Two faces folded by 90° about the x axis: the mid-edge normal bisects the face normals.
    let x = vec![
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.5, 1.0, 0.0),
        Vector3::new(0.5, 0.0, 1.0),
    ];
    let m = Mesh::new(x.clone(), vec![[0, 1, 2], [1, 0, 3]]).unwrap();
    let nf = geometry::face_normals(&m, &x);
    assert!((nf[0] - Vector3::z()).norm() < 1e-15);
    assert!((nf[1] - Vector3::y()).norm() < 1e-15);
    let e = m.topology().face_edges(FaceId(0))[2]; // edge (0, 1), opposite local vertex 2
    let me = geometry::mid_edge_normals(&m, &x)[e.idx()];
    let expect = Vector3::new(0.0, 1.0, 1.0) / 2f64.sqrt();
    assert!((me - expect).norm() < 1e-15, "{me}");
}

#[test]
fn sphere_area_and_icosphere_mid_edge_normals_converge_quadratically() {
    // The largest angle between a mid-edge normal and the radial direction at the edge's
    // midpoint, over all edges, against the longest edge h, on levels 2..=6.
    let mut errors = Vec::new();
    let mut spacing = Vec::new();
    for level in 2..=6 {
        let m = generators::icosphere(1.0, level).unwrap();
        let x = m.positions();
        let me = geometry::mid_edge_normals(&m, x);
        let mut worst = 0.0f64;
        let mut h = 0.0f64;
        for (edge, n) in m.topology().edges().iter().zip(&me) {
            let [a, b] = edge.vertices.map(|v| x[v.idx()]);
            let radial = ((a + b) * 0.5).normalize();
            let err = n.cross(&radial).norm().asin();
            worst = worst.max(err);
            h = h.max((a - b).norm());
        }
        let area: f64 = geometry::face_areas(&m, x).iter().sum();
        let rel = (4.0 * std::f64::consts::PI - area) / (4.0 * std::f64::consts::PI);
        assert!(
            rel > 0.0 && rel < 2.0 * h * h,
            "inscribed area error {rel} at h = {h}"
        );
        errors.push(worst);
        spacing.push(h);
    }
    for l in 1..errors.len() {
        let order = (errors[l - 1] / errors[l]).ln() / (spacing[l - 1] / spacing[l]).ln();
        println!(
            "level {}: h = {:.4e}, max angle(mid-edge normal, radial) = {:.4e} rad, order {:.3}",
            l + 2,
            spacing[l],
            errors[l],
            order
        );
        assert!(order >= 1.8, "observed order {order}");
    }
}
