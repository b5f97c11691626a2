//! OBJ reading and writing.
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use thinshell_mesh::{Mesh, MeshError, generators, io};

fn round_trip(m: &Mesh, x: &[Vector3<f64>]) -> Mesh {
    let mut buf = Vec::new();
    io::write_obj(m, x, &mut buf).unwrap();
    io::read_obj(buf.as_slice()).unwrap()
}

#[test]
fn round_trip_is_exact() {
    for m in [
        generators::seed_square().unwrap(),
        generators::icosphere(0.37, 2).unwrap(),
        generators::irregular_rectangle(3.0, 1.0, 5, 9).unwrap(),
    ] {
        // Awkward values: tiny, huge and irrational-looking coordinates must survive bit for bit.
        for scale in [std::f64::consts::PI, 1e-300, 1e300, -1.0 / 3.0] {
            let x: Vec<Vector3<f64>> = m
                .positions()
                .iter()
                .map(|p| (p + Vector3::new(0.1, 0.2, 0.3)) * scale)
                .collect();
            let back = round_trip(&m, &x);
            assert_eq!(back.positions(), &x[..]);
            assert_eq!(back.faces(), m.faces());
            assert_eq!(back.build_report().n_flipped(), 0);
        }
    }
}

#[test]
fn save_and_load_through_a_file() {
    let m = generators::disc(1.0, 3).unwrap();
    let dir = std::env::temp_dir().join(format!("thinshell-mesh-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("disc.obj");
    io::save_obj(&path, &m, m.positions()).unwrap();
    let back = io::load_obj(&path).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(back.positions(), m.positions());
    assert_eq!(back.faces(), m.faces());
}

#[test]
fn quads_are_triangulated_and_seams_do_not_split_vertices() {
    // Two quads sharing an edge whose texture coordinates differ across the edge (a seam).
    let obj = "\
        v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n\
        vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\n\
        f 1/1/1 2/2/1 5/4/1 4/3/1\n\
        f 2/1/1 3/2/1 6/4/1 5/3/1\n";
    let m = io::read_obj(obj.as_bytes()).unwrap();
    assert_eq!(m.n_vertices(), 6);
    assert_eq!(m.n_faces(), 4);
    assert_eq!(m.n_edges(), 9);
    assert_eq!(m.topology().n_components(), 1);
}

#[test]
fn objects_and_groups_are_merged_into_one_mesh() {
    let obj = "\
        o left\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\n\
        o right\nf 2 4 3\n\
        g extra\nl 1 2\np 3\n";
    let m = io::read_obj(obj.as_bytes()).unwrap();
    assert_eq!(m.n_vertices(), 4);
    assert_eq!(m.n_faces(), 2);
    assert_eq!(m.topology().n_components(), 1);
    assert_eq!(m.topology().boundary_edges().len(), 4);
}

#[test]
fn unreferenced_vertices_in_the_file_are_dropped() {
    let obj = "v 5 5 5\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 2 3 4\n";
    let m = io::read_obj(obj.as_bytes()).unwrap();
    assert_eq!(m.n_vertices(), 3);
    assert_eq!(m.positions()[0], Vector3::zeros());
}

#[test]
fn malformed_input_is_an_error_not_a_panic() {
    let cases: &[&str] = &[
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", // index out of range
        "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", // bad number
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", // bad face index
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",   // face with two corners
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2", // truncated last line
        "v 0 0\n",                              // truncated vertex
        "",                                     // empty file
        "# only a comment\nv 1 2 3\n",          // no faces
        "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", // NaN coordinate
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", // zero area
        "\u{0}\u{1}\u{2}garbage\n",             // binary junk
    ];
    let e = io::read_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2".as_bytes()).unwrap_err();
    assert!(matches!(e, MeshError::ObjSyntax { line: 5, .. }), "{e}");
    let e = io::read_obj(&[b'v', b' ', 0xff, 0xfe, b'\n'][..]).unwrap_err();
    assert!(matches!(e, MeshError::Io(_)), "{e}");
    for (i, text) in cases.iter().enumerate() {
        let r = std::panic::catch_unwind(|| io::read_obj(text.as_bytes()));
        let r = r.unwrap_or_else(|_| panic!("case {i} panicked"));
        let e = r.err().unwrap_or_else(|| panic!("case {i} was accepted"));
        println!("case {i}: {e}");
        assert!(
            matches!(
                e,
                MeshError::ObjSyntax { .. }
                    | MeshError::InObj { .. }
                    | MeshError::Empty
                    | MeshError::NonFiniteCoordinate { .. }
                    | MeshError::DegenerateFace { .. }
                    | MeshError::IndexOutOfRange { .. }
            ),
            "case {i}: {e}"
        );
    }
}

#[test]
fn bad_face_indices_name_their_line() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (face, ok) in [
        ("f 0 1 2", false),                              // OBJ indices start at 1
        ("f 1 2 4", false),                              // beyond the last `v` line
        ("f 1 2 99999999999999999", false),              // far beyond
        ("f -1 -2 -4", false),                           // relative, before the first `v` line
        ("f -1 -2 -3", true),                            // relative, in range
        ("f 1/1/1 2/1/1 3/1/1\nvt 0 0\nvn 0 0 1", true), // texture/normal parts are ignored
    ] {
        let text = format!("{head}# comment\n{face}\n");
        let r = io::read_obj(text.as_bytes());
        if ok {
            assert_eq!(r.unwrap().n_faces(), 1, "{face}");
        } else {
            let e = r.unwrap_err();
            assert!(
                matches!(e, MeshError::ObjSyntax { line: 5, .. }),
                "{face}: {e}"
            );
            assert!(e.to_string().contains("index out of range"), "{e}");
        }
    }
    // A positive index may refer to a `v` line further down (tobj resolves it per object).
    let m = io::read_obj("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n".as_bytes()).unwrap();
    assert_eq!(m.n_faces(), 1);
}

#[test]
fn write_rejects_wrong_positions() {
    let m = generators::rectangle(1.0, 1.0, 1, 1).unwrap();
    let e = io::write_obj(&m, &m.positions()[..3], Vec::new()).unwrap_err();
    assert!(matches!(
        e,
        MeshError::WrongPositionCount {
            expected: 4,
            found: 3
        }
    ));
    let mut x = m.positions().to_vec();
    x[1].x = f64::INFINITY;
    let e = io::write_obj(&m, &x, Vec::new()).unwrap_err();
    assert!(matches!(
        e,
        MeshError::NonFiniteCoordinate {
            vertex: 1,
            axis: 0,
            ..
        }
    ));
}

/// Every OBJ error names its 1-based line: a malformed line its own, a mesh problem the `f`
/// lines of the faces involved (polygons keep their line through the fan triangulation).
#[test]
fn errors_name_obj_lines() {
    let e = io::read_obj("v 0 0 0\n# c\nv 1 x 0\nv 0 1 0\nf 1 2 3\n".as_bytes()).unwrap_err();
    assert!(matches!(e, MeshError::ObjSyntax { line: 3, .. }), "{e}");
    assert!(e.to_string().starts_with("OBJ line 3: "), "{e}");
    let e = io::read_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x3\n".as_bytes()).unwrap_err();
    assert!(matches!(e, MeshError::ObjSyntax { line: 4, .. }), "{e}");
    // Degenerate: the third face (line 7) has collinear corners.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\n\nf 1 2 4\n";
    let e = io::read_obj(obj.as_bytes()).unwrap_err();
    assert!(
        matches!(&e, MeshError::InObj { lines, source }
            if lines == &[7] && matches!(**source, MeshError::DegenerateFace { face: 1, .. })),
        "{e}"
    );
    assert!(
        e.to_string()
            .starts_with("OBJ line 7: face 1 is degenerate"),
        "{e}"
    );
    // Non-manifold: three faces on edge 1–2; the third is a quad on line 8 (two triangles).
    let obj =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 1 1 1\nf 1 2 3\nf 2 1 4\nf 1 2 6 5\n";
    let e = io::read_obj(obj.as_bytes()).unwrap_err();
    assert!(
        matches!(&e, MeshError::InObj { lines, source }
            if lines == &[7, 8, 9] && matches!(**source, MeshError::NonManifoldEdge { .. })),
        "{e}"
    );
    assert!(
        e.to_string().starts_with("OBJ lines 7, 8, 9: edge (0, 1)"),
        "{e}"
    );
    // A coordinate that is not finite names its `v` line.
    let e = io::read_obj("v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n".as_bytes()).unwrap_err();
    assert!(e.to_string().starts_with("OBJ line 3: vertex 2"), "{e}");
}
