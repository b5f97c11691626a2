//! The data endpoints of `thinshell view` (no browser): what the page receives for a real run,
//! and the messages for missing or malformed frames and for directories that are not runs.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, OnceLock};

use thinshell_cli::view::Viewer;
use thinshell_cli::view::run::Location;

const SCENE: &str = r#"
name = "small strip"
effects = ["stretching", "bending", "inertia", "gravity"]

[mesh]
generator = "rectangle"
width = 0.1
height = 0.04
nx = 5
ny = 2

[material]
thickness = 1e-3
young = 1e6

[[boundary.clamps]]
region = { box = { min = [-1.0, -1.0, -1.0], max = [1e-6, 1.0, 1.0] } }

[integrator]
kind = "implicit"
dt = 0.01
steps = 4

[output]
every = 2
formats = ["vtk", "obj"]
"#;

fn root() -> &'static PathBuf {
    static ROOT: OnceLock<PathBuf> = OnceLock::new();
    ROOT.get_or_init(|| {
        let root =
            std::env::temp_dir().join(format!("thinshell-view-endpoints-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).expect("temp dir");
        std::fs::write(root.join("strip.toml"), SCENE).expect("scene");
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        for (name, set) in [
            ("vtk", vec![]),
            ("obj", vec!["output.formats=[\"obj\"]".to_string()]),
        ] {
            thinshell_cli::run(
                &root.join("strip.toml"),
                Some(&root.join(name)),
                &set,
                true,
                &stop,
            )
            .unwrap_or_else(|e| panic!("run: {e:?}"));
        }
        root
    })
}

/// A fresh copy of a run directory, to break.
fn copy(name: &str, to: &str) -> PathBuf {
    let (from, dest) = (root().join(name), root().join(to));
    let _ = std::fs::remove_dir_all(&dest);
    std::fs::create_dir_all(&dest).expect("dir");
    for e in std::fs::read_dir(&from).expect("read dir").flatten() {
        std::fs::copy(e.path(), dest.join(e.file_name())).expect("copy");
    }
    dest
}

fn json(body: &[u8]) -> serde_json::Value {
    serde_json::from_slice(body).expect("JSON body")
}

fn f32s(body: &[u8]) -> Vec<f32> {
    body.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn run_list_frames_and_fields() {
    let viewer = Viewer::load(&[&root().join("vtk")]).expect("load");
    let r = viewer.respond("/api/runs");
    assert_eq!((r.status, r.content_type), (200, "application/json"));
    let runs = json(&r.body);
    let run = &runs[0];
    assert_eq!(run["name"], "small strip");
    assert_eq!(
        (run["n_vertices"].as_u64(), run["n_faces"].as_u64()),
        (Some(18), Some(20))
    );
    // Frames at steps 0, 2, 4 with the integrator's times.
    let frames = run["frames"].as_array().expect("frames");
    let steps: Vec<u64> = frames.iter().filter_map(|f| f["step"].as_u64()).collect();
    assert_eq!(steps, [0, 2, 4]);
    assert!((frames[2]["time"].as_f64().unwrap_or(0.0) - 0.04).abs() < 1e-12);
    let keys: Vec<&str> = run["fields"]
        .as_array()
        .expect("fields")
        .iter()
        .filter_map(|f| f["key"].as_str())
        .collect();
    assert_eq!(
        keys,
        [
            "displacement",
            "mean_curvature",
            "gaussian_curvature",
            "stretch_density",
            "bend_density",
            "principal_curvature_1",
            "principal_curvature_2",
            "face_mean_curvature",
            "face_gaussian_curvature",
            "membrane_strain_1",
            "membrane_strain_2",
            "stress_resultant_1",
            "stress_resultant_2",
            "bending_moment_1",
            "bending_moment_2"
        ]
    );
    assert_eq!(run["fields"][4]["unit"], "J/m²");
}

#[test]
fn frame_bytes_hold_the_positions_and_fields_of_the_frame() {
    let dir = root().join("vtk");
    let viewer = Viewer::load(&[&dir]).expect("load");
    let run = &viewer.runs()[0];
    let r = viewer.respond("/api/run/0/frame/2");
    assert_eq!(
        (r.status, r.content_type),
        (200, "application/octet-stream")
    );
    let v = f32s(&r.body);
    let (nv, nf) = (18, 20);
    // Positions, then displacement, H and K per vertex, then 12 face fields.
    assert_eq!(v.len(), 3 * nv + 3 * nv + 12 * nf);
    // Positions: those of the OBJ written at the same step (an independent writer).
    let text = std::fs::read(dir.join("frame_000004.obj")).expect("obj");
    let (x, _) = thinshell_mesh::io::read_obj_raw(&text[..]).expect("obj parse");
    for (k, p) in x.iter().enumerate() {
        for c in 0..3 {
            assert!((v[3 * k + c] as f64 - p[c]).abs() <= 1e-6 * (1.0 + p[c].abs()));
        }
    }
    // Displacement magnitude from the reference (flat) mesh: the clamped vertices stay put and
    // the free end has sagged.
    let disp = &v[3 * nv..4 * nv];
    let reference = thinshell_mesh::generators::rectangle(0.1, 0.04, 5, 2).expect("mesh");
    for (k, p0) in reference.positions().iter().enumerate() {
        assert!((disp[k] as f64 - (x[k] - p0).norm()).abs() <= 1e-6 * (1e-6 + (x[k] - p0).norm()));
    }
    // Vertex mean curvature is the frame's own array (the viewer computes no curvature).
    let frame = thinshell_cli::view::frame::read(&dir.join("frame_000004.vtu")).expect("vtu");
    let h = &frame
        .vertex_fields
        .iter()
        .find(|(k, _)| k == "mean_curvature")
        .expect("mean_curvature")
        .1;
    for (k, h) in h.iter().enumerate() {
        assert_eq!(v[4 * nv + k], *h as f32);
    }
    // Energy densities: the bent strip has positive bending energy density; density × rest area
    // sums to the step's bending energy in steps.csv (5 significant digits at f32).
    let bend = &v[6 * nv + nf..6 * nv + 2 * nf];
    assert!(bend.iter().all(|b| *b >= 0.0) && bend.iter().any(|b| *b > 0.0));
    let area = 0.1 * 0.04 / nf as f64;
    let total: f64 = bend.iter().map(|b| *b as f64 * area).sum();
    let steps = run.steps.column("bend_J").expect("bend_J");
    let step4 = steps[3].expect("row of step 4");
    assert!((total - step4).abs() <= 1e-5 * step4, "{total} vs {step4}");
    // Mesh: 3 u32 per face, the rectangle's triangles.
    let m = viewer.respond("/api/run/0/mesh");
    assert_eq!(m.body.len(), 4 * 3 * nf);
}

#[test]
fn steps_are_read_by_column_name_and_extra_columns_are_kept() {
    let dir = copy("vtk", "extra_columns");
    let text = std::fs::read_to_string(dir.join("steps.csv")).expect("csv");
    // A future writer with more columns, in another order.
    let mut out = String::new();
    for (k, line) in text.lines().enumerate() {
        out += &if k == 0 {
            format!("checkpoint_s,{line}\n")
        } else {
            format!("0.5,{line}\n")
        };
    }
    std::fs::write(dir.join("steps.csv"), out).expect("csv");
    let viewer = Viewer::load(&[&dir]).expect("load");
    let s = json(&viewer.respond("/api/run/0/steps").body);
    let columns: Vec<&str> = s["columns"]
        .as_array()
        .expect("columns")
        .iter()
        .filter_map(|c| c.as_str())
        .collect();
    assert_eq!(columns[0], "checkpoint_s");
    let k = columns.iter().position(|c| *c == "time_s").expect("time_s");
    assert!((s["values"][k][3].as_f64().unwrap_or(0.0) - 0.04).abs() < 1e-12);
    assert!(s["error"].is_null());
}

#[test]
fn obj_only_runs_have_the_displacement_and_times_from_steps_csv() {
    let viewer = Viewer::load(&[&root().join("obj")]).expect("load");
    let run = &viewer.runs()[0];
    let keys: Vec<&str> = run.fields.iter().map(|f| f.key).collect();
    // OBJ frames carry no arrays: the displacement (from the first frame) is the one field.
    assert_eq!(keys, ["displacement"]);
    assert!(run.fields.iter().all(|f| f.location == Location::Vertex));
    let times: Vec<f64> = run.frames.iter().map(|f| f.time).collect();
    assert!(
        (times[1] - 0.02).abs() < 1e-12 && (times[2] - 0.04).abs() < 1e-12,
        "{times:?}"
    );
    let r = viewer.respond("/api/run/0/frame/1");
    assert_eq!(r.status, 200);
    assert_eq!(r.body.len(), 4 * (3 * 18 + 18));
}

#[test]
fn missing_and_malformed_frames_are_named() {
    let dir = copy("vtk", "broken");
    std::fs::write(dir.join("frame_000002.vtu"), "<VTKFile><Piece").expect("corrupt");
    std::fs::remove_file(dir.join("frame_000004.vtu")).expect("remove");
    let viewer = Viewer::load(&[&dir]).expect("the first frame is fine");
    let bad = viewer.respond("/api/run/0/frame/1");
    assert_eq!(bad.status, 422);
    let e = json(&bad.body)["error"].as_str().unwrap_or("").to_string();
    assert!(
        e.contains("frame 1 (step 2")
            && e.contains("frame_000002.vtu")
            && e.contains("not valid XML"),
        "{e}"
    );
    let gone = json(&viewer.respond("/api/run/0/frame/2").body)["error"]
        .as_str()
        .unwrap_or("")
        .to_string();
    assert!(
        gone.contains("frame 2 (step 4") && gone.contains("No such file"),
        "{gone}"
    );
    let past = viewer.respond("/api/run/0/frame/9");
    assert_eq!(past.status, 404);
    assert!(
        json(&past.body)["error"]
            .as_str()
            .unwrap_or("")
            .contains("the run has 3")
    );
    assert_eq!(viewer.respond("/api/run/5/mesh").status, 404);
    assert_eq!(viewer.respond("/nothing").status, 404);
    // A frame from another mesh.
    let other = copy("vtk", "other_mesh");
    let small = thinshell_mesh::generators::rectangle(0.1, 0.04, 2, 2).expect("mesh");
    let frame = thinshell::vtk::Frame {
        mesh: &small,
        points: small.positions(),
        point_vectors: vec![],
        cell_scalars: vec![],
        point_scalars: vec![],
        cell_vectors: vec![],
    };
    std::fs::write(
        other.join("frame_000002.vtu"),
        thinshell::vtk::vtu_string(&frame).expect("vtu"),
    )
    .expect("write");
    let e = json(
        &Viewer::load(&[&other])
            .expect("load")
            .respond("/api/run/0/frame/1")
            .body,
    );
    assert!(
        e["error"]
            .as_str()
            .unwrap_or("")
            .contains("9 vertices, the first frame has 18"),
        "{e}"
    );
}

#[test]
fn a_directory_that_is_not_a_run_is_refused() {
    let empty = root().join("empty");
    std::fs::create_dir_all(&empty).expect("dir");
    let e = Viewer::load(&[&empty]).err().expect("refused");
    assert!(e.contains("not a thinshell run output"), "{e}");
    let e = Viewer::load(&[Path::new("/nonexistent/run")])
        .err()
        .expect("refused");
    assert!(e.contains("not a directory"), "{e}");
    // The command exits 2 with the message.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .args(["view", &empty.display().to_string(), "--port", "0"])
        .output()
        .expect("run thinshell");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a thinshell run output"));
}

/// The server over a real socket: the page, a JSON endpoint, a frame and a 404.
#[test]
fn served_over_http_on_loopback() {
    use std::io::{Read, Write};
    let viewer = Arc::new(Viewer::load(&[&root().join("vtk")]).expect("load"));
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr");
    std::thread::spawn(move || thinshell_cli::view::server::serve(listener, viewer));
    let get = |path: &str| {
        let mut s = std::net::TcpStream::connect(addr).expect("connect");
        write!(s, "GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").expect("send");
        let mut out = Vec::new();
        s.read_to_end(&mut out).expect("read");
        out
    };
    let page = String::from_utf8(get("/")).expect("utf8");
    assert!(page.starts_with("HTTP/1.1 200 OK") && page.contains("<canvas id=\"chart\">"));
    // The script is inlined and no data embedded: the page loads nothing else but the API.
    assert!(page.contains("webgl2") && page.contains("type=\"application/json\">null</script>"));
    let frame = get("/api/run/0/frame/0");
    let head_end = frame
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("headers")
        + 4;
    let head = String::from_utf8_lossy(&frame[..head_end]);
    assert!(
        head.contains(&format!("Content-Length: {}", 4 * (6 * 18 + 12 * 20))),
        "{head}"
    );
    assert!(String::from_utf8_lossy(&get("/api/run/0/frame/x")).starts_with("HTTP/1.1 404"));
}

/// The self-contained page embeds the same bytes the server sends.
#[test]
fn html_embeds_every_frame() {
    use base64::Engine as _;
    let viewer = Viewer::load(&[&root().join("vtk")]).expect("load");
    let page = thinshell_cli::view::html::page(&viewer);
    let start =
        page.find("type=\"application/json\">").expect("data") + "type=\"application/json\">".len();
    let end = start + page[start..].find("</script>").expect("end");
    let data = json(&page.as_bytes()[start..end]);
    let frame1 = base64::engine::general_purpose::STANDARD
        .decode(data["runs"][0]["frames"][1].as_str().expect("frame"))
        .expect("base64");
    assert_eq!(&frame1[..], &viewer.respond("/api/run/0/frame/1").body[..]);
    assert!(
        !page.contains("http://") && !page.contains("https://"),
        "the page refers to the network"
    );
}
