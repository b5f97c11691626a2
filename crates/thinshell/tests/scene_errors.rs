//! Bad scene files give one clear error naming the file position and the key.
#![allow(clippy::unwrap_used)]

use std::path::Path;

use thinshell::scene::{Scene, SceneError};
use thinshell_testkit::fixtures::temp_dir;

const OK: &str = r#"
effects = ["stretching", "bending", "inertia"]
[mesh]
generator = "seed_square"
[integrator]
kind = "implicit"
dt = 1e-4
steps = 3
"#;

fn err(text: &str) -> String {
    match Scene::from_toml(text, "bad.toml", Path::new(".")) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_base_scene_is_valid() {
    let s = Scene::from_toml(OK, "ok.toml", Path::new(".")).unwrap();
    assert_eq!(s.file.integrator.steps, Some(3));
    assert_eq!(s.name(), "ok");
}

#[test]
fn every_shipped_scene_parses_and_validates() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(
        n >= 6,
        "expected the seed's five experiments and the moisture sheet, found {n}"
    );
}

#[test]
fn unknown_key_names_line_and_key() {
    let e = err(&OK.replace(
        "generator = \"seed_square\"",
        "generator = \"seed_square\"\nlevle = 2",
    ));
    assert!(e.starts_with("bad.toml:5:1:"), "{e}");
    assert!(e.contains("unknown field `levle`"), "{e}");
}

#[test]
fn wrong_type_names_position() {
    let e = err(&OK.replace("dt = 1e-4", "dt = \"small\""));
    assert!(e.starts_with("bad.toml:7:"), "{e}");
    assert!(e.contains("expected f64"), "{e}");
}

#[test]
fn out_of_range_values_name_the_key() {
    for (from, to, key, line) in [
        ("dt = 1e-4", "dt = -1e-4", "integrator.dt", 7),
        ("dt = 1e-4", "dt = nan", "integrator.dt", 7),
        ("steps = 3", "steps = 0", "integrator.steps", 8),
        (
            "[integrator]",
            "[material]\npoisson = 0.5\n[integrator]",
            "material.poisson",
            6,
        ),
        (
            "[integrator]",
            "[material]\nthickness = -1e-4\n[integrator]",
            "material.thickness",
            6,
        ),
        (
            "[integrator]",
            "[material]\nyoung = inf\n[integrator]",
            "material.young",
            6,
        ),
        (
            "\"inertia\"]",
            "\"inertia\", \"pressure\"]\n[pressure]\nvalue = 1.0\naxis = [0.0, 0.0, 0.0]",
            "pressure.axis",
            5,
        ),
    ] {
        let e = err(&OK.replace(from, to));
        assert!(e.contains(&format!("`{key}`")), "{e}");
        assert!(e.starts_with(&format!("bad.toml:{line}:")), "{e}");
    }
}

#[test]
fn impossible_step_settings_are_refused() {
    // A step count that would run for ever, directly or through end_time.
    let e = err(&OK.replace("steps = 3", "steps = 1000000001"));
    assert!(e.contains("`integrator.steps` must be ≤ 1e9"), "{e}");
    assert!(e.starts_with("bad.toml:8:"), "{e}");
    Scene::from_toml(
        &OK.replace("steps = 3", "steps = 1000000000"),
        "ok.toml",
        Path::new("."),
    )
    .unwrap();
    let e = err(&OK.replace("steps = 3", "end_time = 1e6"));
    assert!(e.contains("more than 1e9"), "{e}");
    // Positive but so small that the inertia term 1/Δt² overflows.
    let e = err(&OK.replace("dt = 1e-4", "dt = 1e-160"));
    assert!(e.contains("`integrator.dt` is too small"), "{e}");
    Scene::from_toml(
        &OK.replace("dt = 1e-4", "dt = 1e-150"),
        "ok.toml",
        Path::new("."),
    )
    .unwrap();
}

#[test]
fn generator_defaults_take_part_in_range_checks() {
    let annulus = |keys: &str| {
        OK.replace(
            "generator = \"seed_square\"",
            &format!("generator = \"annulus\"\n{keys}"),
        )
    };
    let e = err(&annulus("inner_radius = 1.5"));
    assert!(
        e.contains("`mesh.inner_radius` must be smaller than outer_radius = 1"),
        "{e}"
    );
    let e = err(&annulus("outer_radius = 0.25"));
    assert!(
        e.contains("`mesh.inner_radius` must be smaller than outer_radius = 0.25"),
        "{e}"
    );
    Scene::from_toml(&annulus("outer_radius = 0.75"), "ok.toml", Path::new(".")).unwrap();
}

#[test]
fn build_errors_name_the_mesh_file_and_the_problem() {
    use thinshell::sim::{BuildError, Simulation};
    use thinshell_mesh::MeshError;
    let dir = tempdir().join("build-errors");
    std::fs::create_dir_all(&dir).unwrap();
    let obj_scene = OK.replace("generator = \"seed_square\"", "obj = \"m.obj\"");
    let scene = Scene::from_toml(&obj_scene, "s.toml", &dir).unwrap();
    let build = |obj: Option<&str>| {
        let path = dir.join("m.obj");
        match obj {
            Some(text) => std::fs::write(&path, text).unwrap(),
            None => {
                let _ = std::fs::remove_file(&path);
            }
        }
        match Simulation::build(&scene) {
            Ok(_) => panic!("accepted {obj:?}"),
            Err(e) => e,
        }
    };
    let e = build(None);
    assert!(
        matches!(&e, BuildError::MeshFile { path, source: MeshError::Io(_), .. } if *path == dir.join("m.obj")),
        "{e}"
    );
    assert!(e.to_string().contains("m.obj"), "{e}");
    // Valid connectivity whose forms overflow f64.
    let e = build(Some("v 0 0 0\nv 1e100 0 0\nv 0 1e100 0\nf 1 2 3\n"));
    assert!(
        matches!(
            &e,
            BuildError::MeshFile {
                source: MeshError::OutOfScale { face: 0, .. },
                ..
            }
        ),
        "{e}"
    );
    // A start state mapped out of range by [initial].
    let huge = OK.replace("[integrator]", "[initial]\nscale = 1e200\n[integrator]");
    let scene = Scene::from_toml(&huge, "s.toml", &dir).unwrap();
    let e = Simulation::build(&scene).err().unwrap();
    assert!(
        matches!(&e, BuildError::Invalid { key, .. } if key == "initial"),
        "{e}"
    );
}

#[test]
fn contradictions_are_errors() {
    // Static solve with inertia.
    let e = err(&OK.replace("kind = \"implicit\"", "kind = \"static\""));
    assert!(e.contains("inertia"), "{e}");
    // Both steps and end_time.
    let e = err(&OK.replace("steps = 3", "steps = 3\nend_time = 1.0"));
    assert!(e.contains("exactly one of `steps` and `end_time`"), "{e}");
    // A section for an effect that is not on.
    let e = err(&format!(
        "{OK}\n[gravity]\nacceleration = [0.0, 0.0, -9.81]\n"
    ));
    assert!(
        e.contains("`gravity`") && e.contains("not in `effects`"),
        "{e}"
    );
    // An effect without its section.
    let e = err(&OK.replace("\"inertia\"]", "\"inertia\", \"pressure\"]"));
    assert!(e.contains("`pressure`"), "{e}");
    // Growth without [growth].
    let e = err(&OK.replace("\"inertia\"]", "\"inertia\", \"growth\"]"));
    assert!(e.contains("`growth`"), "{e}");
    // A generator key that does not apply.
    let e = err(&OK.replace(
        "generator = \"seed_square\"",
        "generator = \"seed_square\"\nlevel = 3",
    ));
    assert!(e.contains("`mesh.level` does not apply"), "{e}");
    // No elastic term at all.
    let e = err(&OK.replace("\"stretching\", \"bending\", ", ""));
    assert!(e.contains("elastic"), "{e}");
    // Planar rest without a_xy, and a non-SPD a_xy.
    let e = err(&format!("{OK}\n[rest]\nfrom = \"planar\"\n"));
    assert!(e.contains("`rest.a_xy` is required"), "{e}");
    let e = err(&format!(
        "{OK}\n[rest]\nfrom = \"planar\"\na_xy = [[1.0, 2.0], [2.0, 1.0]]\n"
    ));
    assert!(e.contains("positive definite"), "{e}");
    // Pins with a bad axis string.
    let e = err(&format!(
        "{OK}\n[[boundary.pins]]\nregion = {{ vertices = [0] }}\naxes = \"xw\"\n"
    ));
    assert!(e.contains("`boundary.pins[0].axes`"), "{e}");
}

#[test]
fn syntax_errors_name_the_line() {
    let e = err("effects = [\"bending\"\n[mesh]\n");
    assert!(e.starts_with("bad.toml:"), "{e}");
    assert!(matches!(
        Scene::from_toml("= 3", "x.toml", Path::new(".")),
        Err(SceneError::Syntax { .. })
    ));
}

#[test]
fn overrides_apply_and_are_validated() {
    let dir = tempdir();
    let path = dir.join("s.toml");
    std::fs::write(&path, OK).unwrap();
    let s = Scene::load_with_overrides(
        &path,
        &[
            "integrator.dt=2e-3".into(),
            "integrator.newton.line_search=false".into(),
        ],
    )
    .unwrap();
    assert_eq!(s.file.integrator.dt, Some(2e-3));
    assert_eq!(s.file.integrator.newton.line_search, Some(false));
    let e = Scene::load_with_overrides(&path, &["integrator.dt=0".into()]).unwrap_err();
    assert!(e.to_string().contains("`integrator.dt` must be > 0"), "{e}");
    let e = Scene::load_with_overrides(&path, &["novalue".into()]).unwrap_err();
    assert!(matches!(e, SceneError::Override { .. }), "{e}");
    let e = Scene::load(&dir.join("missing.toml")).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }), "{e}");
}

fn tempdir() -> std::path::PathBuf {
    temp_dir("scene-test")
}

/// `[[boundary.symmetry]]`: a bad axis or tolerance is refused when the scene is read, a plane
/// without boundary edges when the simulation is built (naming the plane), and a plane along
/// the mesh's side makes its boundary edges mirror edges.
#[test]
fn symmetry_planes_are_checked() {
    let with = |plane: &str| format!("{OK}\n[[boundary.symmetry]]\n{plane}\n");
    let e = err(&with("axis = \"w\""));
    assert!(e.contains("`boundary.symmetry[0].axis`"), "{e}");
    let e = err(&with("axis = \"x\"\ntolerance = -1.0"));
    assert!(e.contains("`boundary.symmetry[0].tolerance`"), "{e}");
    let e = err(&with("axis = \"x\"\nvalue = nan"));
    assert!(e.contains("`boundary.symmetry[0].value`"), "{e}");
    let dir = Path::new(".");
    let off = Scene::from_toml(&with("axis = \"x\"\nvalue = 0.5"), "s.toml", dir).unwrap();
    let e = thinshell::sim::Simulation::build(&off).err().unwrap();
    assert!(
        e.to_string().contains("x = 0.5 holds no boundary edge"),
        "{e}"
    );
    let side = Scene::from_toml(&with("axis = \"x\""), "s.toml", dir).unwrap();
    let sim = thinshell::sim::Simulation::build(&side).unwrap();
    let mirror = &sim.system().boundary().mirror_edges;
    // The seed square's side x = 0 has 7 intervals.
    assert_eq!(mirror.len(), 7);
    assert!(mirror.iter().all(|&(_, axis)| axis == 0));
}
