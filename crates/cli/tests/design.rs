#![allow(clippy::unwrap_used)]
//! `thinshell design` on the shipped example (data/scenes/design_cap.toml): it reaches the cap,
//! writes its outputs, and the written scene run by the ordinary static solve reproduces the
//! achieved shape (to 1e-9 m; measured 2e-13).

use thinshell::{Scene, Simulation};
use thinshell_cli::design::{DesignOptions, design_command};
use thinshell_testkit::fixtures::{data_path, fresh_temp_dir};

#[test]
fn design_cap_example_reaches_and_reruns() {
    let out = fresh_temp_dir("design_cap");
    let options = DesignOptions {
        parametrisation: "isotropic".into(),
        tolerance: 1e-3,
        smoothness: 1e-6,
        growth_bounds: None,
    };
    design_command(
        &data_path("scenes/design_cap.toml"),
        &data_path("meshes/design_cap_target.obj"),
        &out,
        &[],
        &options,
    )
    .unwrap();
    for f in [
        "scene.toml",
        "rest_forms.csv",
        "design.json",
        "achieved.obj",
        "history.csv",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("design.json")).unwrap()).unwrap();
    assert_eq!(json["converged"], true);
    assert!(json["rms_distance"].as_f64().unwrap() <= 1e-3 * json["target_size"].as_f64().unwrap());
    let achieved = thinshell_mesh::io::load_obj(out.join("achieved.obj")).unwrap();
    let scene = Scene::load(&out.join("scene.toml")).unwrap();
    let mut sim = Simulation::build(&scene).unwrap();
    sim.step().unwrap();
    let worst = sim
        .positions()
        .iter()
        .zip(achieved.positions())
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-9, "rerun differs by {worst} m");
}

#[test]
fn design_rejects_unknown_parametrisation() {
    let out = fresh_temp_dir("design_bad");
    let options = DesignOptions {
        parametrisation: "magic".into(),
        tolerance: 1e-3,
        smoothness: 0.0,
        growth_bounds: None,
    };
    let err = design_command(
        &data_path("scenes/design_cap.toml"),
        &data_path("meshes/design_cap_target.obj"),
        &out,
        &[],
        &options,
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("unknown parametrisation `magic`"),
        "{err}"
    );
}
