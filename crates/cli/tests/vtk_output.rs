//! VTK frames and the .pvd index: parsed back with an XML parser and compared with the inputs.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

use nalgebra::Vector3;
use thinshell::vtk::{Frame, Series, VtkError, vtu_string};
use thinshell_mesh::generators;
use thinshell_testkit::fixtures::fresh_temp_dir;

fn numbers(doc: &roxmltree::Document, name: Option<&str>, parent: &str) -> Vec<f64> {
    let node = doc
        .descendants()
        .find(|n| {
            n.has_tag_name("DataArray")
                && n.parent().is_some_and(|p| p.has_tag_name(parent))
                && n.attribute("Name") == name
        })
        .unwrap();
    node.text()
        .unwrap_or("")
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect()
}

fn temp(name: &str) -> PathBuf {
    fresh_temp_dir(&format!("vtk-{name}"))
}

#[test]
fn vtu_round_trips_points_cells_and_arrays() {
    let mesh = generators::icosphere(1.0, 1).unwrap();
    let x: Vec<Vector3<f64>> = mesh.positions().iter().map(|p| p * 1.0 / 3.0).collect();
    let v: Vec<Vector3<f64>> = (0..x.len())
        .map(|i| Vector3::new(i as f64, -0.1, 1e-300))
        .collect();
    let text = vtu_string(&Frame {
        mesh: &mesh,
        points: &x,
        point_vectors: vec![("velocity", &v)],
        cell_scalars: vec![("s", (0..mesh.n_faces()).map(|f| f as f64 * 0.1).collect())],
        point_scalars: vec![],
        cell_vectors: vec![],
    })
    .unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let pts = numbers(&doc, None, "Points");
    assert_eq!(pts.len(), 3 * x.len());
    for (i, p) in x.iter().enumerate() {
        for k in 0..3 {
            assert_eq!(pts[3 * i + k], p[k], "bit-exact round trip");
        }
    }
    let conn = numbers(&doc, Some("connectivity"), "Cells");
    let faces = mesh.faces_usize();
    assert_eq!(conn.len(), 3 * faces.len());
    assert!(
        faces
            .iter()
            .flatten()
            .zip(&conn)
            .all(|(a, b)| *a as f64 == *b)
    );
    let offsets = numbers(&doc, Some("offsets"), "Cells");
    assert_eq!(offsets.last().copied(), Some(3.0 * faces.len() as f64));
    assert!(
        numbers(&doc, Some("types"), "Cells")
            .iter()
            .all(|&t| t == 5.0)
    );
    assert_eq!(numbers(&doc, Some("velocity"), "PointData")[3 * 7], 7.0);
    assert_eq!(numbers(&doc, Some("s"), "CellData")[10], 1.0);

    let mut bad = x.clone();
    bad[4].y = f64::NAN;
    let e = vtu_string(&Frame {
        mesh: &mesh,
        points: &bad,
        point_vectors: vec![],
        cell_scalars: vec![],
        point_scalars: vec![],
        cell_vectors: vec![],
    })
    .unwrap_err();
    assert!(matches!(e, VtkError::NonFinite { index: 4, .. }), "{e}");
}

#[test]
fn pvd_lists_exactly_the_frames_written() {
    let dir = temp("series");
    let mesh = generators::rectangle(1.0, 1.0, 2, 2).unwrap();
    let mut series = Series::new(&dir, "frames");
    let frame = |x: &'static [Vector3<f64>]| Frame {
        mesh: &mesh,
        points: x,
        point_vectors: vec![],
        cell_scalars: vec![],
        point_scalars: vec![],
        cell_vectors: vec![],
    };
    let x: &'static [Vector3<f64>] = Box::leak(mesh.positions().to_vec().into_boxed_slice());
    series.write("a.vtu", 0.0, &frame(x)).unwrap();
    series.write("b.vtu", 0.5, &frame(x)).unwrap();
    series.write("b.vtu", 0.5, &frame(x)).unwrap(); // rewritten: one entry
    let mut nan = x.to_vec();
    nan[0].x = f64::INFINITY;
    let nan: &'static [Vector3<f64>] = Box::leak(nan.into_boxed_slice());
    assert!(series.write("c.vtu", 1.0, &frame(nan)).is_err());
    let text = std::fs::read_to_string(series.index_path()).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let sets: Vec<(f64, String)> = doc
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            (
                n.attribute("timestep").unwrap().parse().unwrap(),
                n.attribute("file").unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(sets, vec![(0.0, "a.vtu".into()), (0.5, "b.vtu".into())]);
    assert!(!dir.join("c.vtu").exists());
}

#[test]
fn cli_writes_a_vtk_series_matching_the_obj_frames() {
    let dir = temp("cli");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/moisture_curl.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .args(["run", "--quiet"])
        .arg(&scene)
        .arg("--out")
        .arg(&dir)
        .args([
            "--set",
            "integrator.steps=8",
            "--set",
            r#"output.formats=["obj","vtk"]"#,
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let pvd = std::fs::read_to_string(dir.join("frames.pvd")).unwrap();
    let doc = roxmltree::Document::parse(&pvd).unwrap();
    let files: Vec<String> = doc
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| n.attribute("file").unwrap().to_string())
        .collect();
    // Output every 4 steps: the start, steps 4 and 8.
    assert_eq!(
        files,
        ["frame_000000.vtu", "frame_000004.vtu", "frame_000008.vtu"]
    );
    for f in &files {
        let vtu = std::fs::read_to_string(dir.join(f)).unwrap();
        let doc = roxmltree::Document::parse(&vtu).unwrap();
        let pts = numbers(&doc, None, "Points");
        let obj = thinshell_mesh::io::load_obj(dir.join(f.replace(".vtu", ".obj"))).unwrap();
        assert_eq!(pts.len(), 3 * obj.n_vertices());
        for (i, p) in obj.positions().iter().enumerate() {
            for k in 0..3 {
                assert!(
                    (pts[3 * i + k] - p[k]).abs() <= 1e-12 * p.norm().max(1.0),
                    "{f} vertex {i}"
                );
            }
        }
        // The growth scene carries the stimulus per face.
        assert_eq!(
            numbers(&doc, Some("stimulus_top"), "CellData").len(),
            obj.n_faces()
        );
    }
}
