//! `thinshell run` / `check` end to end on small scenes in a temporary directory: the outputs
//! parse and agree with the library; bad scenes give one line and exit code 2.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::Command;
use std::sync::atomic::AtomicBool;

use thinshell::scene::Scene;
use thinshell::sim::{NoObserver, Simulation};
use thinshell_testkit::fixtures::temp_dir;

const SCENE: &str = r#"
name = "tiny rhombus"
effects = ["stretching", "bending", "inertia"]
[mesh]
generator = "rectangle"
nx = 4
ny = 4
[initial]
scale = 0.95
[rest]
from = "planar"
a_xy = [[2.0, 1.0], [1.0, 2.0]]
[integrator]
kind = "implicit"
dt = 1e-4
steps = 6
[output]
every = 3
formats = ["obj"]
"#;

fn dir() -> PathBuf {
    temp_dir("cli-run")
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_thinshell"))
}

#[test]
fn run_writes_outputs_that_agree_with_the_library() {
    let d = dir();
    let scene_path = d.join("tiny.toml");
    std::fs::write(&scene_path, SCENE).unwrap();
    let out_dir = d.join("out");
    let out = bin()
        .args(["run", "--quiet", "--out"])
        .arg(&out_dir)
        .arg(&scene_path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // summary.json
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["status"], "completed");
    assert_eq!(summary["steps"], 6);
    // steps.csv: header + one row per step
    let csv = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 7);
    assert!(rows[0].starts_with("step,time_s,stretch_J"));
    // frames 0, 3, 6
    for k in [0, 3, 6] {
        let f = out_dir.join(format!("frame_{k:06}.obj"));
        let mesh = thinshell_mesh::io::load_obj(&f).unwrap();
        assert_eq!(mesh.n_faces(), 32);
    }

    // The library gives the same final state, bit for bit.
    let scene = Scene::load(&scene_path).unwrap();
    let mut sim = Simulation::build(&scene).unwrap();
    let s = sim.run(&mut NoObserver, &AtomicBool::new(false)).unwrap();
    let stretch = summary["energy"]["stretch"].as_f64().unwrap();
    assert_eq!(stretch, s.final_energy.stretch);
    let last = thinshell_mesh::io::load_obj(out_dir.join("frame_000006.obj")).unwrap();
    for (a, b) in last.positions().iter().zip(sim.positions()) {
        assert_eq!(a, b);
    }
    // And it moved towards the rhombus: the stretch energy dropped from the start.
    let first: f64 = rows[1].split(',').nth(2).unwrap().parse().unwrap();
    assert!(stretch < first, "{stretch} !< {first}");
}

#[test]
fn a_failed_run_with_vtk_output_leaves_a_valid_pvd_listing_the_frames_written() {
    let d = dir().join("vtk-fail");
    std::fs::create_dir_all(&d).unwrap();
    let scene_path = d.join("tiny.toml");
    std::fs::write(&scene_path, SCENE).unwrap();
    let out_dir = d.join("out");
    let _ = std::fs::remove_dir_all(&out_dir);
    // One Newton iteration cannot reach the tolerance: step 1 fails.
    let out = bin()
        .args(["run", "--quiet", "--out"])
        .arg(&out_dir)
        .arg(&scene_path)
        .args(["--set", r#"output.formats=["vtk"]"#])
        .args(["--set", "integrator.newton.max_iterations=1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.starts_with("thinshell: simulation failed: step 1"),
        "{err}"
    );
    let pvd = std::fs::read_to_string(out_dir.join("frames.pvd")).unwrap();
    let pvd = roxmltree::Document::parse(&pvd).unwrap();
    let files: Vec<&str> = pvd
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| n.attribute("file").unwrap())
        .collect();
    // The initial frame, listed once although the failure path writes the last good state
    // (step 0) again, and as OBJ too.
    assert_eq!(files, ["frame_000000.vtu"]);
    let vtu = std::fs::read_to_string(out_dir.join("frame_000000.vtu")).unwrap();
    roxmltree::Document::parse(&vtu).unwrap();
    let last_good = thinshell_mesh::io::load_obj(out_dir.join("frame_000000.obj")).unwrap();
    assert_eq!(last_good.n_faces(), 32);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["status"], "failed");
    assert_eq!(summary["steps"], 0);
    assert!(
        summary["error"].as_str().unwrap().contains("step 1"),
        "{summary}"
    );
    // One state was written (step 0), once.
    assert_eq!(summary["frames"], 1);
}

#[test]
fn check_prints_what_would_be_simulated() {
    let d = dir();
    let p = d.join("check.toml");
    std::fs::write(&p, SCENE).unwrap();
    let out = bin().arg("check").arg(&p).output().unwrap();
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("effects: stretching, bending, inertia"), "{s}");
    // The default bending form: 25 vertices, plus one director angle per edge (56) except on
    // the 16 free edges, whose directors are extrapolated (model.md §1.2).
    assert!(s.contains("bending (edge director tan)"), "{s}");
    assert!(
        s.contains("unknowns: 115 (of 131 coordinates; 16 held), including 40 edge-director angles (the other 16 edges are free or clamped"),
        "{s}"
    );
    // Damping is not listed, so it is not among the evaluated terms.
    assert!(!s.contains("damping"), "{s}");
}

#[test]
fn every_shipped_scene_passes_check() {
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes");
    for entry in std::fs::read_dir(scenes).unwrap() {
        let p = entry.unwrap().path();
        let out = bin().arg("check").arg(&p).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        assert!(out.status.success(), "{name}: {err}");
    }
}

#[test]
fn bad_scenes_exit_2_with_one_line() {
    let d = dir();
    for (name, text) in [
        ("unknown.toml", SCENE.replace("nx = 4", "nx = 4\nnz = 3")),
        ("dt.toml", SCENE.replace("dt = 1e-4", "dt = 0.0")),
        (
            "pin.toml",
            format!("{SCENE}\n[[boundary.pins]]\nregion = {{ vertices = [999] }}\n"),
        ),
        (
            "all_pinned.toml",
            format!(
                "{SCENE}\n[[boundary.pins]]\nregion = {{ box = {{ min = [-9.0, -9.0, -9.0], max = [9.0, 9.0, 9.0] }} }}\n"
            ),
        ),
    ] {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        for args in [&["check"][..], &["run", "--quiet"][..]] {
            let cmd = args[0];
            let out = bin().args(args).arg(&p).output().unwrap();
            assert_eq!(out.status.code(), Some(2), "{cmd} {name}");
            let err = String::from_utf8(out.stderr).unwrap();
            assert_eq!(err.trim_end().lines().count(), 1, "{cmd} {name}: {err}");
        }
    }
}
