#![allow(clippy::unwrap_used)]
//! The `contact` effect from a scene file: the shipped sheet-on-a-sphere scene stays outside the
//! ball and intersection-free at every step and comes to rest on it; `[contact]` errors carry
//! file positions.

use std::path::Path;

use thinshell::scene::Scene;
use thinshell::sim::Simulation;
use thinshell_system::contact::first_edge_crossing_face;
use thinshell_testkit::fixtures::data_path;

#[test]
fn sheet_on_sphere_scene_is_intersection_free_and_settles() {
    let scene = Scene::load(&data_path("scenes/sheet_on_sphere.toml")).unwrap();
    let mut sim = Simulation::build(&scene).unwrap();
    let sys = sim.system();
    assert!(sys.contact().is_some());
    let faces: Vec<[usize; 3]> = sys
        .mesh()
        .faces()
        .iter()
        .map(|f| f.map(|v| v.idx()))
        .collect();
    let edges: Vec<[usize; 2]> = sys
        .mesh()
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
    let c = sim.system().contact().unwrap();
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

/// The shipped scene with a mesh obstacle (`kind = "mesh"`, an OBJ path relative to the scene
/// file): 40 steps, each checked by brute force over all pairs of the sheet and the pyramid —
/// every sheet vertex and pyramid vertex farther than h/2 from the other's faces, no edge of
/// either through a face of the other — and the sheet is held up by the apex.
#[test]
fn sheet_on_pyramid_scene_reads_its_obj_and_stays_intersection_free() {
    use thinshell_energy::contact::{point_triangle_distance2, segment_crosses_triangle};
    let scene = Scene::load(&data_path("scenes/sheet_on_pyramid.toml")).unwrap();
    let mut sim = Simulation::build(&scene).unwrap();
    let obj = thinshell_mesh::io::load_obj(data_path("meshes/pyramid.obj")).unwrap();
    let (y, y_faces): (Vec<_>, Vec<[usize; 3]>) = (
        obj.positions().to_vec(),
        obj.faces().iter().map(|f| f.map(|v| v.idx())).collect(),
    );
    let y_edges: Vec<[usize; 2]> = obj
        .topology()
        .edges()
        .iter()
        .map(|e| e.vertices.map(|v| v.idx()))
        .collect();
    let sys = sim.system();
    let faces: Vec<[usize; 3]> = sys
        .mesh()
        .faces()
        .iter()
        .map(|f| f.map(|v| v.idx()))
        .collect();
    let edges: Vec<[usize; 2]> = sys
        .mesh()
        .topology()
        .edges()
        .iter()
        .map(|e| e.vertices.map(|v| v.idx()))
        .collect();
    let half_h = 0.5e-3;
    for step in 0..40 {
        sim.step().unwrap_or_else(|e| panic!("step {step}: {e}"));
        let x = sim.positions();
        let mut d = f64::INFINITY;
        for p in x {
            for t in &y_faces {
                d = d.min(
                    point_triangle_distance2(&[*p, y[t[0]], y[t[1]], y[t[2]]])
                        .0
                        .sqrt(),
                );
            }
        }
        for q in &y {
            for t in &faces {
                d = d.min(
                    point_triangle_distance2(&[*q, x[t[0]], x[t[1]], x[t[2]]])
                        .0
                        .sqrt(),
                );
            }
        }
        assert!(d > half_h, "step {step}: distance {d}");
        let crossed = edges.iter().any(|e| {
            y_faces
                .iter()
                .any(|t| segment_crosses_triangle(&x[e[0]], &x[e[1]], &t.map(|v| y[v])))
        }) || y_edges.iter().any(|e| {
            faces
                .iter()
                .any(|t| segment_crosses_triangle(&y[e[0]], &y[e[1]], &t.map(|v| x[v])))
        });
        assert!(!crossed, "step {step}");
    }
    let c = sim.system().contact().unwrap();
    let lift: f64 = c.forces(sim.positions()).iter().map(|f| f.z).sum();
    let s = c.stats(sim.positions());
    eprintln!("sheet on pyramid: contact force {lift:e} N, {s:?}");
    assert!(lift > 0.0 && s.active_pairs > 0 && s.min_gap > 0.0);
}

/// A mesh obstacle's file errors name the key and the file: missing, malformed (with its
/// line), and an empty path.
#[test]
fn mesh_obstacle_file_errors_name_the_key_and_file() {
    let dir = std::env::temp_dir().join(format!("thinshell_mesh_obstacle_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n").unwrap();
    let scene = |path: &str| {
        format!(
            r#"effects = ["stretching", "inertia", "contact"]
[mesh]
generator = "rectangle"
[integrator]
kind = "implicit"
dt = 1e-3
steps = 1
[contact]
[[contact.obstacles]]
kind = "mesh"
path = "{path}"
"#
        )
    };
    let build = |path: &str| {
        let s = Scene::from_toml(&scene(path), "m.toml", &dir).map_err(|e| e.to_string())?;
        Simulation::build(&s).map(|_| ()).map_err(|e| e.to_string())
    };
    let e = build("missing.obj").unwrap_err();
    assert!(
        e.contains("contact.obstacles[0].path")
            && e.contains(&dir.join("missing.obj").display().to_string()),
        "{e}"
    );
    let e = build("bad.obj").unwrap_err();
    assert!(e.contains("bad.obj") && e.contains("line 4"), "{e}");
    let e = build(" ").unwrap_err();
    assert!(
        e.contains("contact.obstacles[0].path") && e.contains("must name"),
        "{e}"
    );
    let e = scene_error("[contact]\n[[contact.obstacles]]\nkind = \"mesh\"");
    assert!(e.contains("needs `path`"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Runs `swelling_scroll.toml` (with or without contact) for `steps` steps and checks every step
/// with the test kit's exact triangle test (rational arithmetic, independent of the contact
/// code): returns the first step whose mid-surface has two faces (sharing no vertex) that meet,
/// and the most active pairs and smallest gap over the steps.
fn swelling_scroll(contact: bool, steps: usize) -> (Option<(usize, [usize; 2])>, usize, f64) {
    let effects = if contact {
        r#"effects=["stretching", "bending", "growth", "inertia", "contact"]"#
    } else {
        r#"effects=["stretching", "bending", "growth", "inertia"]"#
    };
    let set = [effects.to_string()];
    let path = data_path("scenes/swelling_scroll.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let text = if contact {
        text
    } else {
        text.replace("[contact]\nself = true\n", "")
    };
    let scene = Scene::from_toml_with_overrides(
        &text,
        "swelling_scroll.toml",
        path.parent().unwrap(),
        &set,
    )
    .unwrap();
    let mut sim = Simulation::build(&scene).unwrap();
    let faces: Vec<[usize; 3]> = sim
        .system()
        .mesh()
        .faces()
        .iter()
        .map(|f| f.map(|v| v.idx()))
        .collect();
    let (mut active, mut gap) = (0, f64::INFINITY);
    for step in 0..steps {
        let r = sim.step().unwrap_or_else(|e| panic!("step {step}: {e}"));
        if let Some(c) = r.contact {
            active = active.max(c.active_pairs);
            gap = c.min_gap.map_or(gap, |g| gap.min(g));
        }
        if let Some(pair) = thinshell_testkit::exact::first_meeting_faces(sim.positions(), &faces) {
            return (Some((step, pair)), active, gap);
        }
    }
    (None, active, gap)
}

/// A swelling strip rolls onto itself (`swelling_scroll.toml`, 240 steps: the roll touches
/// itself from about step 130 on, with up to ~400 active pairs; min gap 2.9e-5 m). With contact no step has two
/// meeting faces by the exact test, and the smallest gap stays positive; without contact the
/// roll passes through itself (so the check can fail). About 10 s on the 2-core VM.
#[test]
fn swelling_scroll_touches_itself_and_stays_intersection_free() {
    let (free, _, _) = swelling_scroll(false, 240);
    eprintln!("swelling scroll without contact: first meeting faces {free:?}");
    assert!(
        free.is_some(),
        "without contact the roll should pass through itself"
    );
    let (hit, active, gap) = swelling_scroll(true, 240);
    eprintln!("swelling scroll with contact: up to {active} active pairs, min gap {gap:e} m");
    assert_eq!(hit, None);
    assert!(active > 50 && gap > 0.0 && gap.is_finite());
}
