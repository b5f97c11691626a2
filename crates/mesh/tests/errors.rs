//! Every `MeshError` variant from a minimal bad input, with the offending index checked.
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use thinshell_mesh::{Mesh, MeshError, generators, geometry, io};

fn p(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

/// Unit square split into two triangles.
fn square() -> Vec<Vector3<f64>> {
    vec![p(0., 0., 0.), p(1., 0., 0.), p(1., 1., 0.), p(0., 1., 0.)]
}

#[test]
fn empty() {
    assert!(matches!(Mesh::new(square(), vec![]), Err(MeshError::Empty)));
    assert!(matches!(Mesh::new(vec![], vec![]), Err(MeshError::Empty)));
}

#[test]
fn index_out_of_range() {
    let e = Mesh::new(square(), vec![[0, 1, 2], [0, 2, 4]]).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::IndexOutOfRange {
                face: 1,
                corner: 2,
                index: 4,
                n_vertices: 4
            }
        ),
        "{e}"
    );
}

#[test]
fn repeated_vertex() {
    let e = Mesh::new(square(), vec![[0, 1, 2], [3, 2, 3]]).unwrap_err();
    assert!(
        matches!(e, MeshError::RepeatedVertex { face: 1, vertex: 3 }),
        "{e}"
    );
    let e = Mesh::new(square(), vec![[1, 1, 2]]).unwrap_err();
    assert!(
        matches!(e, MeshError::RepeatedVertex { face: 0, vertex: 1 }),
        "{e}"
    );
}

#[test]
fn duplicate_face_any_order_and_orientation() {
    for dup in [[0, 1, 2], [1, 2, 0], [2, 1, 0], [0, 2, 1]] {
        let e = Mesh::new(square(), vec![[0, 1, 2], [0, 2, 3], dup]).unwrap_err();
        assert!(
            matches!(
                e,
                MeshError::DuplicateFace {
                    face: 2,
                    first: 0,
                    vertices: [0, 1, 2]
                }
            ),
            "{e}"
        );
    }
}

#[test]
fn duplicate_face_without_other_neighbours() {
    // A two-triangle "pillow" (each edge used twice, so edge-manifold) and a lone copy pair.
    let e = Mesh::new(square(), vec![[0, 1, 2], [0, 2, 1]]).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::DuplicateFace {
                face: 1,
                first: 0,
                vertices: [0, 1, 2]
            }
        ),
        "{e}"
    );
    let e = Mesh::new(square(), vec![[0, 2, 3], [1, 2, 0], [2, 0, 1]]).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::DuplicateFace {
                face: 2,
                first: 1,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn degenerate_face() {
    // Collinear vertices: exactly zero area.
    let mut x = square();
    x.push(p(2., 0., 0.));
    let e = Mesh::new(x.clone(), vec![[0, 2, 3], [0, 1, 4]]).unwrap_err();
    assert!(
        matches!(e, MeshError::DegenerateFace { face: 1, .. }),
        "{e}"
    );
    // Coincident vertices.
    x.push(p(1., 1., 0.));
    let e = Mesh::new(x.clone(), vec![[0, 1, 2], [1, 2, 5]]).unwrap_err();
    assert!(
        matches!(e, MeshError::DegenerateFace { face: 1, relative_area } if relative_area == 0.0),
        "{e}"
    );
    // A sliver just below the relative threshold (1e-12 · ℓ²) is rejected, one well above is
    // accepted: the test is scale invariant, so use a tiny mesh.
    let s = 1e-6;
    let sliver = |h: f64| vec![p(0., 0., 0.), p(s, 0., 0.), p(0.5 * s, h * s, 0.)];
    let e = Mesh::new(sliver(1e-13), vec![[0, 1, 2]]).unwrap_err();
    assert!(
        matches!(e, MeshError::DegenerateFace { face: 0, .. }),
        "{e}"
    );
    assert!(Mesh::new(sliver(1e-9), vec![[0, 1, 2]]).is_ok());
}

#[test]
fn non_manifold_edge() {
    // Three triangles hinged on edge (0, 1).
    let x = vec![
        p(0., 0., 0.),
        p(1., 0., 0.),
        p(0., 1., 0.),
        p(0., -1., 0.),
        p(0., 0., 1.),
    ];
    let e = Mesh::new(x, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]).unwrap_err();
    match e {
        MeshError::NonManifoldEdge { vertices, faces } => {
            assert_eq!(vertices, [0, 1]);
            assert_eq!(faces, vec![0, 1, 2]);
        }
        other => panic!("unexpected {other}"),
    }
}

#[test]
fn non_manifold_edge_reports_input_vertex_numbers() {
    // Vertex 0 is unreferenced and gets dropped; the error still names input indices.
    let x = vec![
        p(9., 9., 9.),
        p(0., 0., 0.),
        p(1., 0., 0.),
        p(0., 1., 0.),
        p(0., -1., 0.),
        p(0., 0., 1.),
    ];
    let e = Mesh::new(x, vec![[1, 2, 3], [2, 1, 4], [1, 2, 5]]).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::NonManifoldEdge {
                vertices: [1, 2],
                ..
            }
        ),
        "{e}"
    );
}

/// Möbius strip: a band of `n` quads whose ends are joined with a half twist.
fn mobius(n: usize) -> (Vec<Vector3<f64>>, Vec<[usize; 3]>) {
    let mut x = Vec::new();
    for i in 0..n {
        let t = std::f64::consts::TAU * i as f64 / n as f64;
        for s in [-0.3, 0.3] {
            let r = 1.0 + s * (t / 2.0).cos();
            x.push(p(r * t.cos(), r * t.sin(), s * (t / 2.0).sin()));
        }
    }
    let mut f = Vec::new();
    for i in 0..n {
        let (a, b) = (2 * i, 2 * i + 1);
        // After a full turn the strip's two sides are swapped.
        let (c, d) = if i + 1 < n {
            (2 * i + 2, 2 * i + 3)
        } else {
            (1, 0)
        };
        f.push([a, c, d]);
        f.push([a, d, b]);
    }
    (x, f)
}

#[test]
fn mobius_strip_is_non_orientable() {
    let (x, f) = mobius(12);
    let e = Mesh::new(x, f.clone()).unwrap_err();
    match e {
        MeshError::NonOrientable {
            face,
            neighbor,
            edge,
        } => {
            // The named faces really share the named edge.
            for g in [face, neighbor] {
                assert!(
                    f[g].contains(&edge[0]) && f[g].contains(&edge[1]),
                    "{face} {neighbor} {edge:?}"
                );
            }
        }
        other => panic!("unexpected {other}"),
    }
    // The same band without the twist (a cylinder) is fine.
    let m = generators::cylinder_patch(1.0, std::f64::consts::TAU, 0.5, 12, 1).unwrap();
    assert_eq!(m.topology().n_components(), 1);
}

#[test]
fn non_finite_coordinate() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut x = square();
        x[2].y = bad;
        let e = Mesh::new(x, vec![[0, 1, 2], [0, 2, 3]]).unwrap_err();
        assert!(
            matches!(
                e,
                MeshError::NonFiniteCoordinate {
                    vertex: 2,
                    axis: 1,
                    ..
                }
            ),
            "{e}"
        );
    }
}

#[test]
fn with_positions_checks_length_and_finiteness() {
    let m = Mesh::new(square(), vec![[0, 1, 2], [0, 2, 3]]).unwrap();
    let e = m.with_positions(square()[..3].to_vec()).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::WrongPositionCount {
                expected: 4,
                found: 3
            }
        ),
        "{e}"
    );
    let mut x = square();
    x[3].z = f64::NAN;
    let e = m.with_positions(x).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::NonFiniteCoordinate {
                vertex: 3,
                axis: 2,
                ..
            }
        ),
        "{e}"
    );
    let moved: Vec<_> = square().iter().map(|q| q * 2.0).collect();
    let m2 = m.with_positions(moved.clone()).unwrap();
    assert_eq!(m2.positions(), &moved[..]);
    assert_eq!(m2.faces(), m.faces());
}

#[test]
fn invalid_generator_parameters() {
    let e = generators::rectangle(-1.0, 1.0, 2, 2).unwrap_err();
    assert!(
        matches!(e, MeshError::InvalidParameter { name: "width", .. }),
        "{e}"
    );
    let e = generators::rectangle(1.0, 1.0, 0, 2).unwrap_err();
    assert!(
        matches!(e, MeshError::InvalidParameter { name: "nx", .. }),
        "{e}"
    );
    let e = generators::icosphere(f64::NAN, 1).unwrap_err();
    assert!(
        matches!(e, MeshError::InvalidParameter { name: "radius", .. }),
        "{e}"
    );
    let e = generators::annulus(2.0, 1.0, 2, 8).unwrap_err();
    assert!(
        matches!(e, MeshError::InvalidParameter { name: "r_out", .. }),
        "{e}"
    );
    let e = generators::cylinder_patch(1.0, 7.0, 1.0, 8, 2).unwrap_err();
    assert!(
        matches!(e, MeshError::InvalidParameter { name: "angle", .. }),
        "{e}"
    );
}

#[test]
fn obj_and_io_errors() {
    let e = io::load_obj("/nonexistent/definitely/missing.obj").unwrap_err();
    assert!(matches!(e, MeshError::Io(_)), "{e}");
    let e = io::read_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n".as_bytes()).unwrap_err();
    assert!(matches!(e, MeshError::ObjSyntax { line: 4, .. }), "{e}");
    let e = io::read_obj("v 0 0 0\nv 1 0 0\nv 0 1 0 1 2\nf 1 2 3\n".as_bytes()).unwrap_err();
    assert!(matches!(e, MeshError::ObjSyntax { line: 3, .. }), "{e}");
}

#[test]
fn faces_too_small_or_too_large_for_f64_fail_the_scale_check() {
    // Mesh::new judges shape only, so these are valid meshes; their forms are not computable.
    for (s, overflow) in [(1e-160, false), (1e80, true)] {
        let x: Vec<_> = square().iter().map(|q| q * s).collect();
        let m = Mesh::new(x, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        let e = geometry::check_scale(&m, m.positions()).unwrap_err();
        match e {
            MeshError::OutOfScale {
                face: 0,
                twice_area,
            } => {
                assert_eq!(twice_area.is_infinite(), overflow, "{e}");
            }
            other => panic!("unexpected {other}"),
        }
        assert!(
            e.to_string().contains("out of the representable scale"),
            "{e}"
        );
    }
    // The limits are far from any physical shell: 1e-60 m and 1e60 m pass.
    for s in [1e-60, 1e60] {
        let x: Vec<_> = square().iter().map(|q| q * s).collect();
        let m = Mesh::new(x, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        geometry::check_scale(&m, m.positions()).unwrap();
    }
}

#[test]
fn irregular_rectangle_refuses_huge_vertex_counts() {
    let e = generators::irregular_rectangle(100.0, 1.0, 200, 0).unwrap_err();
    assert!(
        matches!(e, MeshError::InvalidParameter { name: "n", .. }),
        "{e}"
    );
}
