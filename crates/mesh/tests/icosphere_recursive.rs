//! The standard recursive icosphere against closed-form values, and the mesh queries
//! (bounding box, nearest vertex).
#![allow(clippy::unwrap_used)]

use std::f64::consts::PI;

use thinshell_mesh::nalgebra::Vector3;
use thinshell_mesh::{BoundingBox, Mesh, VertexId, face_areas, generators};

fn edge_lengths(mesh: &Mesh) -> Vec<f64> {
    let x = mesh.positions();
    mesh.topology()
        .edges()
        .iter()
        .map(|e| (x[e.vertices[1].idx()] - x[e.vertices[0].idx()]).norm())
        .collect()
}

fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &l| {
        (lo.min(l), hi.max(l))
    })
}

#[test]
fn counts_radius_and_closed_surface() {
    let r = 1.7;
    for level in 0..=5 {
        let m = generators::icosphere_recursive(r, level).unwrap();
        let k = 4usize.pow(level as u32);
        assert_eq!(m.n_vertices(), 10 * k + 2, "level {level}");
        assert_eq!(m.n_faces(), 20 * k, "level {level}");
        assert_eq!(m.n_edges(), 30 * k, "level {level}");
        assert_eq!(m.euler_characteristic(), 2);
        assert!(m.topology().boundary_vertices().is_empty());
        assert_eq!(m.build_report().n_flipped(), 0);
        for p in m.positions() {
            assert!(
                (p.norm() - r).abs() < 1e-13 * r,
                "level {level}: |p| = {}",
                p.norm()
            );
        }
        // Outward normals: every face's normal points away from the centre.
        let x = m.positions();
        for f in m.faces() {
            let [a, b, c] = f.map(|v| x[v.idx()]);
            assert!((b - a).cross(&(c - a)).dot(&(a + b + c)) > 0.0);
        }
    }
}

/// Level 0 is the regular icosahedron: circumradius r = s·sin(2π/5) for edge length s, and
/// surface area 5√3·s².
#[test]
fn level_zero_is_the_regular_icosahedron() {
    let r = 2.5;
    let m = generators::icosphere_recursive(r, 0).unwrap();
    let s = r / (2.0 * PI / 5.0).sin();
    for l in edge_lengths(&m) {
        assert!((l - s).abs() < 1e-13 * s, "edge {l} vs {s}");
    }
    let area: f64 = face_areas(&m, m.positions()).iter().sum();
    let exact = 5.0 * 3f64.sqrt() * s * s;
    assert!(
        (area - exact).abs() < 1e-13 * exact,
        "area {area} vs {exact}"
    );
}

/// Level 1: a corner-to-midpoint edge spans half an icosahedron edge's arc θ (cos θ = 1/√5),
/// chord 2 sin(θ/4); a midpoint-to-midpoint edge subtends 36°, chord 2 sin(π/10).
#[test]
fn level_one_edge_length_ratio_is_closed_form() {
    let m = generators::icosphere_recursive(1.0, 1).unwrap();
    let theta = (1.0 / 5f64.sqrt()).acos();
    let (short, long) = (2.0 * (theta / 4.0).sin(), 2.0 * (PI / 10.0).sin());
    let (lo, hi) = min_max(&edge_lengths(&m));
    assert!((lo - short).abs() < 1e-14, "{lo} vs {short}");
    assert!((hi - long).abs() < 1e-14, "{hi} vs {long}");
    // (√5 − 1) / (4 sin(θ/4)) = 1.130 826 36…
    assert!((hi / lo - 1.130_826_36).abs() < 1e-8, "ratio {}", hi / lo);
}

/// The triangles stay well shaped under refinement: the longest edge is less than 1.25 times
/// the shortest at every level up to 5 (a quality bound, not a closed form).
#[test]
fn edge_length_ratio_stays_bounded() {
    for level in 1..=5 {
        let m = generators::icosphere_recursive(1.0, level).unwrap();
        let (lo, hi) = min_max(&edge_lengths(&m));
        assert!(hi / lo < 1.25, "level {level}: ratio {}", hi / lo);
    }
}

/// Up to level 1 both icosphere generators give the same points; from level 2 on they differ.
#[test]
fn agrees_with_one_step_icosphere_up_to_level_one() {
    let max_offset = |level| {
        let a = generators::icosphere_recursive(1.0, level).unwrap();
        let b = generators::icosphere(1.0, level).unwrap();
        a.positions()
            .iter()
            .map(|p| {
                b.positions()
                    .iter()
                    .map(|q| (p - q).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0f64, f64::max)
    };
    assert!(max_offset(0) < 1e-14);
    assert!(max_offset(1) < 1e-14);
    assert!(max_offset(2) > 1e-3, "level 2 offset {}", max_offset(2));
}

#[test]
fn invalid_parameters_are_errors() {
    assert!(generators::icosphere_recursive(0.0, 1).is_err());
    assert!(generators::icosphere_recursive(f64::NAN, 1).is_err());
    assert!(generators::icosphere_recursive(1.0, 11).is_err());
}

#[test]
fn bounding_box_of_mesh_and_points() {
    let m = generators::rectangle(3.0, 2.0, 3, 2).unwrap();
    let bb = m.bounding_box();
    assert_eq!(bb.min, Vector3::zeros());
    assert_eq!(bb.max, Vector3::new(3.0, 2.0, 0.0));
    assert_eq!(bb.extent(), Vector3::new(3.0, 2.0, 0.0));
    assert_eq!(bb.center(), Vector3::new(1.5, 1.0, 0.0));
    assert!((bb.diagonal() - 13f64.sqrt()).abs() < 1e-15);
    let pts = [Vector3::new(1.0, -2.0, 3.0), Vector3::new(-1.0, 4.0, 0.5)];
    let bb = BoundingBox::from_points(&pts).unwrap();
    assert_eq!(bb.min, Vector3::new(-1.0, -2.0, 0.5));
    assert_eq!(bb.max, Vector3::new(1.0, 4.0, 3.0));
    assert_eq!(BoundingBox::from_points(&[]), None);
    // A unit sphere's box is [-1, 1]³ up to the vertices' positions: diagonal 2√3 at most.
    let s = generators::icosphere_recursive(1.0, 3)
        .unwrap()
        .bounding_box();
    assert!(s.diagonal() <= 2.0 * 3f64.sqrt() + 1e-12);
}

#[test]
fn nearest_vertex_and_ties() {
    // 4 × 2 cells of 0.5 m: vertex (i, j) at index 5 j + i.
    let m = generators::rectangle(2.0, 1.0, 4, 2).unwrap();
    assert_eq!(
        m.nearest_vertex(&Vector3::new(1.4, 0.6, -3.0)),
        VertexId(5 + 3)
    );
    assert_eq!(
        m.nearest_vertex(&Vector3::new(10.0, 10.0, 0.0)),
        VertexId(14)
    );
    // Exactly between (1, 0) and (2, 0), and the centre of cell (0, 0): lowest index wins.
    assert_eq!(m.nearest_vertex(&Vector3::new(0.75, 0.0, 0.0)), VertexId(1));
    assert_eq!(
        m.nearest_vertex(&Vector3::new(0.25, 0.25, 0.0)),
        VertexId(0)
    );
    // Every vertex is its own nearest vertex.
    for (v, p) in m.positions().iter().enumerate() {
        assert_eq!(m.nearest_vertex(p), VertexId::new(v));
    }
}
