//! Bad input through the command line, case by case: `check`, `run` and `info` each refuse it
//! with exactly one line on stderr that names the problem, exit code 2, no panic, nothing on
//! stdout and (for `run`) no output directory. Library-level checks of the same errors live in
//! `scene_errors.rs` and the mesh crate's `errors.rs` / `obj.rs`; the cases already covered by
//! `cli_run.rs` and `cli_info.rs` are not repeated here.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

use thinshell_testkit::fixtures::fresh_temp_dir;

/// A small valid scene that each case breaks in one place.
const BASE: &str = r#"effects = ["stretching", "bending", "inertia"]
[mesh]
generator = "rectangle"
nx = 2
ny = 2
[integrator]
kind = "implicit"
dt = 1e-4
steps = 2
"#;

/// A valid static scene on an OBJ file `mesh.obj` next to it.
const OBJ_SCENE: &str = r#"effects = ["stretching", "bending"]
[mesh]
obj = "mesh.obj"
[integrator]
kind = "static"
"#;

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

/// Möbius strip of 12 quads (two triangles each), the ends joined with a half twist.
fn mobius_obj() -> String {
    let n = 12;
    let mut s = String::new();
    for i in 0..n {
        let t = std::f64::consts::TAU * i as f64 / n as f64;
        for w in [-0.3, 0.3] {
            let r = 1.0 + w * (t / 2.0).cos();
            s += &format!(
                "v {} {} {}\n",
                r * t.cos(),
                r * t.sin(),
                w * (t / 2.0).sin()
            );
        }
    }
    for i in 0..n {
        let (a, b) = (2 * i + 1, 2 * i + 2);
        let (c, d) = if i + 1 < n {
            (2 * i + 3, 2 * i + 4)
        } else {
            (2, 1)
        };
        s += &format!("f {a} {c} {d}\nf {a} {d} {b}\n");
    }
    s
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_thinshell"))
}

fn case_dir(name: &str) -> PathBuf {
    fresh_temp_dir(&format!("bad-input-{name}"))
}

/// Runs `thinshell <args>` and checks the refusal; returns the error line.
fn refused(args: &[&str], paths: &[&Path], what: &str) -> String {
    let out = bin().args(args).args(paths).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(2), "{what}: {args:?}: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{what}: {err}");
    assert!(err.starts_with("thinshell: error: "), "{what}: {err}");
    assert!(stdout.trim().is_empty(), "{what}: stdout {stdout}");
    // Shown with --nocapture: the table in docs/robustness.md (bad input) quotes these lines.
    println!("{what}\t{}\t{}", args[0], err.trim_end());
    err
}

/// `check` and `run` both refuse `scene` (written as `scene.toml`, with `obj` as `mesh.obj`
/// when given) with a line containing every one of `expect`.
fn scene_case(name: &str, scene: &[u8], obj: Option<&[u8]>, set: &[&str], expect: &[&str]) {
    let d = case_dir(name);
    let path = d.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    if let Some(obj) = obj {
        std::fs::write(d.join("mesh.obj"), obj).unwrap();
    }
    let sets: Vec<&str> = set.iter().flat_map(|s| ["--set", s]).collect();
    let out_dir = d.join("out");
    for cmd in ["check", "run"] {
        let mut args = vec![cmd];
        if cmd == "run" {
            args.extend(["--quiet", "--out", out_dir.to_str().unwrap()]);
        }
        args.extend(&sets);
        let err = refused(&args, &[&path], name);
        for e in expect {
            assert!(err.contains(e), "{name} ({cmd}): expected `{e}` in {err}");
        }
        // Refused before anything is written.
        assert!(
            !out_dir.exists(),
            "{name}: run created {}",
            out_dir.display()
        );
    }
}

#[test]
fn malformed_and_truncated_scene_files() {
    let cases: &[(&str, &[u8], &[&str])] = &[
        ("empty", b"", &["scene.toml:1:1", "missing field `effects`"]),
        (
            "truncated",
            &BASE.as_bytes()[..BASE.find("bending").unwrap() + 3],
            &["scene.toml:1:", "unclosed"],
        ),
        (
            "truncated_table",
            b"effects = [\"bending\"]\n[mesh\n",
            &["scene.toml:2:", "unclosed table"],
        ),
        (
            "not_utf8",
            b"effects = [\"bending\xff\xfe\"]\n",
            &["cannot read scene file", "UTF-8"],
        ),
        (
            "missing_mesh",
            b"effects = [\"bending\"]\n[integrator]\nkind = \"static\"\n",
            &["missing field `mesh`"],
        ),
    ];
    for (name, text, expect) in cases {
        scene_case(name, text, None, &[], expect);
    }
}

#[test]
fn unknown_keys_and_wrong_types() {
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "unknown_effect",
            BASE.replace("\"inertia\"]", "\"inertia\", \"magnetism\"]"),
            vec!["scene.toml:1:", "unknown variant `magnetism`"],
        ),
        (
            "unknown_section",
            format!("{BASE}[solver]\nthreads = 2\n"),
            vec!["scene.toml:10:", "unknown field `solver`"],
        ),
        (
            "unknown_integrator",
            BASE.replace("\"implicit\"", "\"rk4\""),
            vec!["scene.toml:7:", "unknown variant `rk4`"],
        ),
        (
            "steps_float",
            BASE.replace("steps = 2", "steps = 2.5"),
            vec!["scene.toml:9:", "expected usize"],
        ),
        (
            "steps_negative",
            BASE.replace("steps = 2", "steps = -2"),
            vec!["scene.toml:9:", "`-2`", "expected usize"],
        ),
        (
            "unknown_load_ramp",
            format!("{BASE}load_ramp = \"quadratic\"\n"),
            vec![
                "scene.toml:10:13:",
                "unknown variant `quadratic`, expected `linear` or `none`",
            ],
        ),
        (
            "effects_not_array",
            BASE.replace(
                "effects = [\"stretching\", \"bending\", \"inertia\"]",
                "effects = \"bending\"",
            ),
            vec!["scene.toml:1:", "expected a sequence"],
        ),
    ];
    for (name, text, expect) in cases {
        scene_case(name, text.as_bytes(), None, &[], &expect);
    }
}

#[test]
fn non_finite_negative_and_impossible_parameters() {
    let with = |extra: &str| format!("{BASE}{extra}");
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "young_nan",
            with("[material]\nyoung = nan\n"),
            vec!["scene.toml:11:", "`material.young` must be a finite number, got NaN"],
        ),
        (
            "density_zero",
            with("[material]\ndensity = 0.0\n"),
            vec!["`material.density` must be > 0"],
        ),
        (
            "viscosity_negative",
            with("[material]\nviscosity = -1.0\n"),
            vec!["`material.viscosity` must be ≥ 0, got -1"],
        ),
        (
            "dt_inf",
            BASE.replace("dt = 1e-4", "dt = inf"),
            vec!["scene.toml:8:", "`integrator.dt` must be a finite number, got inf"],
        ),
        (
            "dt_negative",
            BASE.replace("dt = 1e-4", "dt = -1e-4"),
            vec!["`integrator.dt` must be > 0"],
        ),
        (
            // Positive, but 1/dt² overflows: every step would be inf.
            "dt_subnormal",
            BASE.replace("dt = 1e-4", "dt = 1e-320"),
            vec!["`integrator.dt` is too small", "1/dt² overflows"],
        ),
        (
            // Would run for ever rather than fail.
            "steps_huge",
            BASE.replace("steps = 2", "steps = 9223372036854775807"),
            vec!["`integrator.steps` must be ≤ 1e9"],
        ),
        (
            "end_time_huge",
            BASE.replace("steps = 2", "end_time = 1e300"),
            vec!["`integrator.end_time` needs", "more than 1e9"],
        ),
        (
            "scale_huge",
            with("[initial]\nscale = 1e300\n"),
            vec!["`initial` maps the mesh out of range", "representable scale"],
        ),
        (
            "linear_xy_singular",
            with("[initial]\nlinear_xy = [[1.0, 1.0], [1.0, 1.0]]\n"),
            vec!["`initial.linear_xy` must have a positive determinant"],
        ),
        (
            "gravity_nan",
            BASE.replace("\"inertia\"]", "\"inertia\", \"gravity\"]")
                + "[gravity]\nacceleration = [0.0, nan, -9.81]\n",
            vec!["`gravity.acceleration[1]` must be a finite number"],
        ),
        (
            "pressure_inf",
            BASE.replace("\"inertia\"]", "\"inertia\", \"pressure\"]")
                + "[pressure]\nvalue = -inf\n",
            vec!["`pressure.value` must be a finite number, got -inf"],
        ),
        (
            "newton_tolerance_zero",
            with("[integrator.newton]\ntolerance = 0.0\n"),
            vec!["`integrator.newton.tolerance` must be > 0"],
        ),
        (
            "newton_iterations_zero",
            with("[integrator.newton]\nmax_iterations = 0\n"),
            vec!["`integrator.newton.max_iterations` must be ≥ 1"],
        ),
        ("every_zero", with("[output]\nevery = 0\n"), vec!["`output.every` must be ≥ 1"]),
        (
            "mesh_level_huge",
            "effects = [\"bending\"]\n[mesh]\ngenerator = \"icosphere\"\nlevel = 12\n[integrator]\nkind = \"static\"\n".into(),
            vec!["`mesh.level` must be ≤ 8"],
        ),
        (
            // The default outer radius (1) counts: the generator would refuse it later under
            // another name.
            "annulus_inner_beyond_default_outer",
            "effects = [\"bending\"]\n[mesh]\ngenerator = \"annulus\"\ninner_radius = 2.0\n[integrator]\nkind = \"static\"\n".into(),
            vec!["scene.toml:4:", "`mesh.inner_radius` must be smaller than outer_radius = 1"],
        ),
    ];
    for (name, text, expect) in cases {
        scene_case(name, text.as_bytes(), None, &[], &expect);
    }
}

#[test]
fn contradictory_settings_and_nothing_to_simulate() {
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "no_elastic_effect",
            BASE.replace("\"stretching\", \"bending\", ", ""),
            vec!["`effects` needs at least one elastic effect"],
        ),
        (
            "effect_twice",
            BASE.replace("\"inertia\"]", "\"inertia\", \"bending\"]"),
            vec!["effect `bending` is listed twice"],
        ),
        (
            "damping_in_static_solve",
            "effects = [\"bending\", \"damping\"]\n[mesh]\ngenerator = \"disc\"\n[integrator]\nkind = \"static\"\n".into(),
            vec!["effect `damping` has no meaning in a static solve"],
        ),
        (
            "dynamic_without_inertia",
            BASE.replace(", \"inertia\"", ""),
            vec!["needs effect `inertia`"],
        ),
        (
            "obj_and_generator",
            BASE.replace("[mesh]\n", "[mesh]\nobj = \"m.obj\"\n"),
            vec!["`mesh` give either `obj` or `generator`, not both"],
        ),
        (
            // A static solve with every vertex clamped along a boundary and pinned.
            "static_all_pinned",
            "effects = [\"stretching\"]\n[mesh]\ngenerator = \"rectangle\"\nnx = 1\nny = 1\n[integrator]\nkind = \"static\"\n[[boundary.pins]]\nregion = { half_space = { point = [-1.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0] } }\n".into(),
            vec!["`boundary` pins every coordinate: nothing is left to simulate"],
        ),
        (
            "pin_region_empty",
            format!(
                "{BASE}[[boundary.pins]]\nregion = {{ sphere = {{ center = [5.0, 5.0, 5.0], radius = 0.1 }} }}\n"
            ),
            vec!["`boundary.pins[0].region` contains no vertex of the mesh"],
        ),
        (
            "pin_vertices_empty",
            format!("{BASE}[[boundary.pins]]\nregion = {{ vertices = [] }}\n"),
            vec!["`boundary.pins[0].region.vertices` is empty"],
        ),
        (
            "point_load_out_of_range",
            BASE.replace("\"inertia\"]", "\"inertia\", \"point_loads\"]")
                + "[[point_loads]]\nvertex = 9\nforce = [0.0, 0.0, 1.0]\n",
            vec!["`point_loads[0].vertex` vertex 9 out of range (the mesh has 9)"],
        ),
        (
            "velocity_in_static_solve",
            "effects = [\"stretching\", \"bending\"]\n[mesh]\ngenerator = \"disc\"\n[initial]\nvelocity = [0.0, 0.0, 1.0]\n[integrator]\nkind = \"static\"\n".into(),
            vec!["scene.toml:5:1:", "`initial.velocity` has no meaning in a static solve"],
        ),
        (
            "load_ramp_in_dynamic_solve",
            format!("{BASE}load_ramp = \"linear\"\n"),
            vec!["scene.toml:10:1:", "`integrator.load_ramp` does not apply to a dynamic integrator"],
        ),
        (
            "load_ramp_without_loads",
            "effects = [\"stretching\", \"bending\"]\n[mesh]\ngenerator = \"disc\"\n[integrator]\nkind = \"static\"\nsteps = 4\nload_ramp = \"linear\"\n".into(),
            vec!["scene.toml:7:1:", "`integrator.load_ramp` has nothing to ramp"],
        ),
        (
            "pressure_without_section",
            BASE.replace("\"inertia\"]", "\"inertia\", \"pressure\"]"),
            vec!["scene.toml:1:1:", "effect `pressure` needs a [pressure] section"],
        ),
    ];
    for (name, text, expect) in cases {
        scene_case(name, text.as_bytes(), None, &[], &expect);
    }
}

#[test]
fn bad_overrides() {
    for (name, set, expect) in [
        (
            "set_no_equals",
            "integrator.dt",
            vec!["--set integrator.dt: expected key=value"],
        ),
        ("set_empty_key", "=3", vec!["--set =3: empty key"]),
        (
            "set_through_a_value",
            "integrator.dt.x=1",
            vec!["--set integrator.dt.x=1", "`dt` is not a table"],
        ),
        (
            "set_invalid_value",
            "material.poisson=0.7",
            vec!["--set material.poisson=0.7: `material.poisson` must be in [0, 0.5), got 0.7"],
        ),
        (
            "set_unknown_key",
            "integrator.dtt=1e-3",
            vec!["--set integrator.dtt=1e-3: unknown field `dtt`"],
        ),
        (
            "set_wrong_type",
            "integrator.steps=\"many\"",
            vec!["--set integrator.steps=\"many\": invalid type"],
        ),
        (
            "set_unknown_table_key",
            "material.thicknes=1e-4",
            vec!["--set material.thicknes=1e-4: unknown field `thicknes`"],
        ),
    ] {
        scene_case(name, BASE.as_bytes(), None, &[set], &expect);
    }
    // A problem of the file itself, found with an unrelated override, points at its own line
    // of the file as written (the override rewrites the text; the message must not follow).
    let bad = BASE.replace("dt = 1e-4", "dt = -1e-4");
    scene_case(
        "set_elsewhere",
        bad.as_bytes(),
        None,
        &["integrator.steps=3"],
        &["scene.toml:8:1: `integrator.dt` must be > 0"],
    );
    // A missing mesh file names the key and its line, or the --set that named it.
    let d = case_dir("obj_missing_key");
    let p = d.join("scene.toml");
    std::fs::write(&p, OBJ_SCENE).unwrap();
    let err = refused(&["check"], &[&p], "obj_missing_key");
    assert!(
        err.contains("scene.toml:3:1: `mesh.obj`: mesh file"),
        "{err}"
    );
    let err = refused(
        &["check", "--set", "mesh.obj=other.obj"],
        &[&p],
        "obj_missing_set",
    );
    assert!(
        err.contains("--set mesh.obj=other.obj: `mesh.obj`: mesh file"),
        "{err}"
    );
}

#[test]
fn bad_meshes_through_a_scene() {
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "obj_mobius",
            mobius_obj().into_bytes(),
            vec!["mesh file", "mesh.obj", "mesh is not orientable"],
        ),
        (
            "obj_duplicate_face",
            format!("{TRIANGLE}v 1 1 0\nf 1 2 3\nf 2 4 3\nf 3 2 1\n").into_bytes(),
            vec!["mesh.obj", "face 2 duplicates face 0"],
        ),
        (
            "obj_zero_index",
            format!("{TRIANGLE}f 0 1 2\n").into_bytes(),
            vec!["mesh.obj", "OBJ line 4", "index out of range"],
        ),
        (
            "obj_truncated",
            format!("{TRIANGLE}f 1 2").into_bytes(),
            vec!["mesh.obj", "OBJ line 4", "fewer than 3 vertices"],
        ),
        (
            "obj_no_faces",
            TRIANGLE.as_bytes().to_vec(),
            vec!["mesh.obj", "mesh is empty"],
        ),
        (
            "obj_huge_coordinates",
            "v 0 0 0\nv 1e200 0 0\nv 0 1e200 0\nf 1 2 3\n"
                .as_bytes()
                .to_vec(),
            vec!["mesh.obj", "face 0 is out of the representable scale"],
        ),
    ];
    for (name, obj, expect) in cases {
        scene_case(name, OBJ_SCENE.as_bytes(), Some(&obj), &[], &expect);
    }
    // A missing OBJ file is named with its resolved path.
    let d = case_dir("obj_missing");
    let p = d.join("scene.toml");
    std::fs::write(&p, OBJ_SCENE).unwrap();
    let err = refused(&["check"], &[&p], "obj_missing");
    assert!(
        err.contains(&format!("mesh file {}", d.join("mesh.obj").display()))
            && err.contains("No such file"),
        "{err}"
    );
}

#[test]
fn bad_meshes_through_info() {
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "mobius",
            mobius_obj().into_bytes(),
            vec!["mesh is not orientable", "edge ("],
        ),
        (
            "duplicate_face",
            format!("{TRIANGLE}f 1 2 3\nf 3 2 1\n").into_bytes(),
            vec!["face 1 duplicates face 0"],
        ),
        (
            "repeated_vertex",
            format!("{TRIANGLE}f 1 2 2\n").into_bytes(),
            vec!["face 0 uses vertex 1 more than once"],
        ),
        (
            "relative_index_out_of_range",
            format!("{TRIANGLE}f -1 -2 -4\n").into_bytes(),
            vec!["OBJ line 4", "index out of range"],
        ),
        (
            "truncated_vertex",
            "v 0 0 0\nv 1 0 0\nv 0 1\nf 1 2 3\n".as_bytes().to_vec(),
            vec!["OBJ line 3", "vertex with 2 numbers"],
        ),
        (
            "not_utf8",
            b"v 0 0 0\nv 1 \xff 0\n".to_vec(),
            vec!["I/O error", "UTF-8"],
        ),
        (
            "w_zero",
            "v 0 0 0 0\nv 1 0 0 0\nv 0 1 0 0\nf 1 2 3\n"
                .as_bytes()
                .to_vec(),
            vec!["OBJ line 1", "weight w is 0"],
        ),
        (
            "infinite_coordinate",
            "v 0 0 inf\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".as_bytes().to_vec(),
            vec!["vertex 0: coordinate 2 is not finite (inf)"],
        ),
        (
            // Valid connectivity, but areas overflow: statistics would print inf.
            "huge_coordinates",
            "v 0 0 0\nv 1e200 0 0\nv 0 1e200 0\nf 1 2 3\n"
                .as_bytes()
                .to_vec(),
            vec![
                "face 0 is out of the representable scale",
                "twice its area is inf",
            ],
        ),
        (
            "tiny_coordinates",
            "v 0 0 0\nv 1e-200 0 0\nv 0 1e-200 0\nf 1 2 3\n"
                .as_bytes()
                .to_vec(),
            vec!["face 0 is out of the representable scale"],
        ),
    ];
    for (name, obj, expect) in cases {
        let d = case_dir(&format!("info-{name}"));
        let p = d.join("mesh.obj");
        std::fs::write(&p, obj).unwrap();
        // Problems of the mesh (not of the file's syntax) are listed on stdout with the
        // statistics `info` can give; stderr names the first, on one line.
        let out = bin().arg("info").arg(&p).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{name}: {err}");
        assert!(err.starts_with("thinshell: error: "), "{name}: {err}");
        println!("{name}\tinfo\t{}", err.trim_end());
        assert!(err.contains(&p.display().to_string()), "{name}: {err}");
        for e in expect {
            assert!(err.contains(e), "{name}: expected `{e}` in {err}");
        }
    }
    // A directory is not a mesh.
    let d = case_dir("info-directory");
    let err = refused(&["info"], &[&d], "directory");
    assert!(err.contains("I/O error"), "{err}");
}

#[test]
fn run_refuses_an_output_path_that_is_a_file() {
    let d = case_dir("out-is-file");
    let scene = d.join("scene.toml");
    std::fs::write(&scene, BASE).unwrap();
    let out = d.join("taken");
    std::fs::write(&out, "not a directory").unwrap();
    let err = refused(
        &["run", "--quiet", "--out", out.to_str().unwrap()],
        &[&scene],
        "out-is-file",
    );
    assert!(err.contains(&out.display().to_string()), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "not a directory");
}
