#![allow(clippy::unwrap_used)]
//! The `contact` effect from a scene file: the shipped sheet-on-a-sphere scene stays outside the
//! ball and intersection-free at every step and comes to rest on it; `[contact]` errors carry
//! file positions.

use std::path::Path;

use thinshell::scene::Scene;
use thinshell::sim::Simulation;
use thinshell_solver::shell::contact::first_edge_crossing_face;
use thinshell_testkit::fixtures::data_path;

#[test]
fn sheet_on_sphere_scene_is_intersection_free_and_settles() {
    let scene = Scene::load(&data_path("scenes/sheet_on_sphere.toml")).unwrap();
    let mut sim = Simulation::build(&scene).unwrap();
    let sys = sim.system();
    assert!(sys.contact.is_some());
    let faces: Vec<[usize; 3]> = sys
        .mesh
        .faces()
        .iter()
        .map(|f| f.map(|v| v.idx()))
        .collect();
    let edges: Vec<[usize; 2]> = sys
        .mesh
        .topology()
        .edges()
        .iter()
        .map(|e| e.vertices.map(|v| v.idx()))
        .collect();
    let centre = nalgebra::Vector3::new(0.05, 0.05, -0.0315);
    let gap = |sim: &Simulation| {
        sim.positions()
            .iter()
            .map(|p| (p - centre).norm() - 0.03 - 0.5e-3)
            .fold(f64::INFINITY, f64::min)
    };
    // 60 of the scene's 150 steps: landing and draping.
    for step in 0..60 {
        sim.step().unwrap_or_else(|e| panic!("step {step}: {e}"));
        let g = gap(&sim);
        assert!(g > 0.0, "step {step}: gap {g}");
        assert_eq!(
            first_edge_crossing_face(sim.positions(), &faces, &edges),
            None,
            "step {step}"
        );
    }
    let c = sim.system().contact.as_ref().unwrap();
    let stats = c.stats(sim.positions());
    assert!(
        stats.active_pairs > 0 && stats.min_gap > 0.0 && stats.min_gap < c.activation,
        "{stats:?}"
    );
}

fn scene_error(contact: &str) -> String {
    let text = format!(
        r#"effects = ["stretching", "inertia"{}]
[mesh]
generator = "rectangle"
[integrator]
kind = "implicit"
dt = 1e-3
steps = 1
{contact}
"#,
        if contact.contains("#no-effect") {
            ""
        } else {
            ", \"contact\""
        }
    );
    Scene::from_toml(&text, "c.toml", Path::new("."))
        .unwrap_err()
        .to_string()
}

#[test]
fn contact_section_errors_have_positions() {
    let e = scene_error("[contact] #no-effect\ndistance = 0.01");
    assert!(
        e.contains("c.toml:") && e.contains("effect `contact` is not in `effects`"),
        "{e}"
    );
    let e = scene_error("[contact]\ndistance = -0.01");
    assert!(
        e.contains("c.toml:9:1") && e.contains("contact.distance"),
        "{e}"
    );
    let e = scene_error("[contact]\n[[contact.obstacles]]\nkind = \"sphere\"\ncenter = [0, 0, 0]");
    assert!(e.contains("needs `radius`"), "{e}");
    let e = scene_error(
        "[contact]\n[[contact.obstacles]]\nkind = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 0, 0]",
    );
    assert!(
        e.contains("contact.obstacles[0].normal") && e.contains("zero"),
        "{e}"
    );
    let e = scene_error("[contact]\nself = false");
    assert!(e.contains("nothing to keep apart"), "{e}");
    let e = scene_error("[contact]\nfriction = 0.3");
    assert!(e.contains("friction"), "{e}");
    // Explicit Euler takes no Newton step to limit: refused.
    let text = r#"effects = ["stretching", "inertia", "contact"]
[mesh]
generator = "rectangle"
[integrator]
kind = "explicit"
dt = 1e-5
steps = 1
"#;
    let e = Scene::from_toml(text, "c.toml", Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("c.toml:5:") && e.contains("`implicit` or `static`"),
        "{e}"
    );
}
