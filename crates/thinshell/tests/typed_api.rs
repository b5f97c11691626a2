#![allow(clippy::unwrap_used)]
//! The typed entry point as a downstream crate uses it (only `thinshell`'s root items and the
//! shell crates' public API): simulations built from Rust values with default settings step to
//! known answers, and step exactly as the same simulation built from a scene file.

use std::path::Path;

use nalgebra::{Matrix2, Vector3};
use thinshell::{Scene, Simulation, SimulationBuilder};
use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::{FaceStimulus, Prescribed, Swelling};
use thinshell_mesh::generators;
use thinshell_system::{Boundary, Loads};

fn model(material: Material, terms: Terms) -> ShellModel {
    ShellModel {
        material,
        terms,
        sff: SffKind::default(),
    }
}

/// Static, default settings: the seed's rhombus (rest metric ā = [[2, 1], [1, 2]] in xy on a
/// flat square) relaxes to the rhombus with that metric, so an edge along x grows by √2
/// (analytic; 1e-6 m is the Newton tolerance's reach on a 0.25 m edge). The same problem from
/// TOML gives the same positions bit for bit.
#[test]
fn static_rhombus_from_rust_values() {
    let mesh = generators::rectangle(1.0, 1.0, 4, 4).unwrap();
    let rest =
        RestState::from_planar(&mesh, Matrix2::new(2.0, 1.0, 1.0, 2.0), Matrix2::zeros()).unwrap();
    let mut sim = SimulationBuilder::new(mesh, model(Material::paper(), Terms::ELASTIC))
        .rest(rest)
        .build()
        .unwrap();
    assert_eq!(sim.steps_total(), 1);
    sim.step().unwrap();
    let x = sim.positions();
    let stretched = (x[1] - x[0]).norm();
    assert!((stretched - 0.25 * 2f64.sqrt()).abs() < 1e-6, "{stretched}");

    let text = r#"
        effects = ["stretching", "bending"]
        [mesh]
        generator = "rectangle"
        nx = 4
        ny = 4
        [rest]
        from = "planar"
        a_xy = [[2.0, 1.0], [1.0, 2.0]]
        [integrator]
        kind = "static"
    "#;
    let scene = Scene::from_toml(text, "rhombus.toml", Path::new(".")).unwrap();
    let mut from_scene = Simulation::build(&scene).unwrap();
    from_scene.step().unwrap();
    assert_eq!(from_scene.positions(), sim.positions());
}

/// Implicit Euler, default Newton settings: a free sheet falling under gravity moves rigidly,
/// and implicit Euler's discrete free fall is z_n = −g Δt² n(n+1)/2 exactly (v_n = −g n Δt,
/// x_n = x_{n−1} + Δt v_n); the elastic forces of a rigid translation vanish, so every vertex
/// follows it to Newton's round-off (1e-9 of the distance fallen).
#[test]
fn implicit_free_fall_from_rust_values() {
    let mesh = generators::rectangle(0.1, 0.1, 6, 6).unwrap();
    let x0 = mesh.positions().to_vec();
    let g = 9.81;
    let dt = 1e-3;
    let steps = 5;
    let mut sim = SimulationBuilder::new(mesh, model(Material::paper(), Terms::ELASTIC))
        .loads(Loads {
            gravity: Vector3::new(0.0, 0.0, -g),
            ..Loads::default()
        })
        .implicit(dt)
        .steps(steps)
        .build()
        .unwrap();
    let summary = sim
        .run(
            &mut thinshell::NoObserver,
            &std::sync::atomic::AtomicBool::new(false),
        )
        .unwrap();
    assert_eq!(summary.steps, steps);
    let n = steps as f64;
    let fallen = g * dt * dt * n * (n + 1.0) / 2.0;
    for (x, x0) in sim.positions().iter().zip(&x0) {
        let d = x - x0;
        assert!(
            (d.z + fallen).abs() <= 1e-9 * fallen && d.x.abs() + d.y.abs() <= 1e-9 * fallen,
            "{d:?} vs {fallen:e}"
        );
    }
    assert!((sim.time() - n * dt).abs() <= 1e-15);
    assert_eq!(sim.load_factor(), 1.0);
}

/// The same clamped strip with growth (linear swelling, uniform stimulus, mass uptake), gravity
/// and implicit Euler, from Rust values and from a scene: the step sequence (grown rest forms,
/// masses with uptake, the initial grown energy) is the same, to the bit.
#[test]
fn growth_with_mass_uptake_steps_as_the_scene_does() {
    let text = r#"
        name = "typed"
        effects = ["stretching", "bending", "inertia", "gravity", "growth"]
        [mesh]
        generator = "rectangle"
        width = 0.1
        height = 0.02
        nx = 10
        ny = 2
        [material]
        thickness = 1e-3
        young = 1e7
        poisson = 0.3
        density = 500.0
        viscosity = 0.0
        [growth]
        model = "linear"
        coefficient = 0.01
        mass_uptake = 50.0
        [growth.stimulus]
        kind = "uniform"
        top = 1.0
        bottom = 0.0
        [[boundary.clamps]]
        region = { box = { min = [-1.0, -1.0, -1.0], max = [1e-6, 1.0, 1.0] } }
        [integrator]
        kind = "implicit"
        dt = 1e-3
        steps = 3
    "#;
    let scene = Scene::from_toml(text, "typed.toml", Path::new(".")).unwrap();
    let mut from_scene = Simulation::build(&scene).unwrap();

    let mesh = generators::rectangle(0.1, 0.02, 10, 2).unwrap();
    let topo = mesh.topology();
    let clamped = topo
        .boundary_edges()
        .iter()
        .copied()
        .filter(|&e| {
            topo.edge(e)
                .vertices
                .iter()
                .all(|v| mesh.positions()[v.idx()].x <= 1e-6)
        })
        .collect();
    let material = Material {
        thickness: 1e-3,
        young: 1e7,
        poisson: 0.3,
        density: 500.0,
        viscosity: 0.0,
        ..Material::paper()
    };
    let n_faces = mesh.n_faces();
    let stimulus = FaceStimulus {
        top: 1.0,
        bottom: 0.0,
    };
    let mut typed = SimulationBuilder::new(mesh, model(material, Terms::ELASTIC))
        .boundary(Boundary {
            clamped_edges: clamped,
            ..Boundary::default()
        })
        .loads(Loads {
            gravity: Vector3::new(0.0, 0.0, -9.81),
            ..Loads::default()
        })
        .growth(
            Box::new(Swelling::linear(0.01)),
            Box::new(Prescribed::uniform(n_faces, stimulus).unwrap()),
            Some(50.0),
        )
        .implicit(1e-3)
        .steps(3)
        .build()
        .unwrap();

    assert_eq!(
        typed.initial_energy_grown(),
        from_scene.initial_energy_grown()
    );
    assert!(typed.initial_energy_grown().unwrap().bend > 0.0);
    for _ in 0..3 {
        let a = typed.step().unwrap();
        let b = from_scene.step().unwrap();
        assert_eq!(a.energy, b.energy);
    }
    assert_eq!(typed.positions(), from_scene.positions());
    assert_eq!(typed.system().mass(), from_scene.system().mass());
    // The clamp held its edge and the strip moved.
    assert!(typed.positions().iter().any(|p| p.z.abs() > 1e-6));
}

/// Errors name the simulation and the problem.
#[test]
fn builder_errors_name_the_problem() {
    let mesh = generators::rectangle(1.0, 1.0, 2, 2).unwrap();
    let n = mesh.n_vertices();
    let e = SimulationBuilder::new(mesh, model(Material::paper(), Terms::ELASTIC))
        .name("plate")
        .start(vec![Vector3::zeros(); n - 1], vec![Vector3::zeros(); n - 1])
        .build()
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("plate") && e.contains("start"), "{e}");
}
