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
    let e = scene_error(
        "[contact]\n[[contact.obstacles]]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [1, 0, 1]",
    );
    assert!(
        e.contains("contact.obstacles[0].max") && e.contains("must exceed `min`"),
        "{e}"
    );
    let e = scene_error("[contact]\n[[contact.obstacles]]\nkind = \"box\"\nmin = [0, 0, 0]");
    assert!(e.contains("needs `max`"), "{e}");
    let e = scene_error(
        "[contact]\n[[contact.obstacles]]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nradius = 1",
    );
    assert!(
        e.contains("contact.obstacles[0].radius") && e.contains("not a key"),
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

/// A contact scene continues bit for bit from a checkpoint taken after the adaptive stiffness
/// was set and the Hessian pattern widened (both are in the checkpoint).
#[test]
fn contact_scene_resumes_bit_for_bit() {
    let scene = Scene::load(&data_path("scenes/sheet_on_sphere.toml")).unwrap();
    let hash = thinshell::sim::scene_hash(&scene);
    let (split, total) = (25, 40);
    let mut straight = Simulation::build(&scene).unwrap();
    for _ in 0..total {
        straight.step().unwrap();
    }
    let mut first = Simulation::build(&scene).unwrap();
    for _ in 0..split {
        first.step().unwrap();
    }
    let state = first.system().contact_run_state().unwrap();
    let young_h = 1e6 * 1e-3;
    assert!(
        state.adaptive_initialised
            && state.stiffness != young_h
            && state.pattern_couplings.is_some(),
        "{state:?}"
    );
    let bytes = first.checkpoint_bytes(hash, &[]);
    let mut resumed = Simulation::build(&scene).unwrap();
    resumed
        .restore_bytes(&bytes, hash, Path::new("memory"))
        .unwrap();
    assert_eq!(resumed.system().contact_run_state(), Some(state));
    for _ in split..total {
        resumed.step().unwrap();
    }
    let bits = |s: &Simulation| -> Vec<u64> {
        s.positions()
            .iter()
            .flat_map(|p| p.iter().map(|c| c.to_bits()).collect::<Vec<_>>())
            .collect()
    };
    assert!(bits(&straight) == bits(&resumed), "positions differ");
    assert_eq!(
        straight.system().contact_run_state(),
        resumed.system().contact_run_state()
    );
}
