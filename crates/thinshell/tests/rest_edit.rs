//! Changing rest forms and stimulus between steps (`sim::rest_edit`).
#![allow(clippy::unwrap_used)]

use nalgebra::Matrix2;
use thinshell::scene::Scene;
use thinshell::sim::{RestEditError, Simulation};
use thinshell_energy::{RestState, SffKind};
use thinshell_growth::FaceStimulus;
use thinshell_testkit::fixtures::data_path;

fn scene(name: &str, overrides: &[&str]) -> Scene {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Scene::load_with_overrides(&data_path(&format!("scenes/{name}")), &o).unwrap()
}

#[test]
fn rest_forms_of_the_current_state_make_it_an_equilibrium() {
    let mut sim = Simulation::build(&scene(
        "square_enlarged.toml",
        &["integrator.steps=2", "integrator.dt=1e-5"],
    ))
    .unwrap();
    assert!(
        sim.energy().stretch > 0.0,
        "starts stretched against ā = 4I"
    );
    let x0 = sim.positions().to_vec();
    let rest = RestState::from_mesh(sim.mesh(), &x0, SffKind::MidEdgeAverage).unwrap();
    sim.set_rest_forms(rest.clone()).unwrap();
    assert_eq!(sim.rest(), &rest);
    // a = ā and b = b̄ on every face: exactly zero energy, total and per face.
    assert_eq!(sim.energy().stretch + sim.energy().bend, 0.0);
    assert!(
        sim.face_energies()
            .unwrap()
            .iter()
            .all(|e| e.stretch == 0.0 && e.bend == 0.0)
    );
    sim.step().unwrap();
    let moved = sim
        .positions()
        .iter()
        .zip(&x0)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(
        moved < 1e-12,
        "an unloaded shell at rest stays put: {moved:e} m"
    );
}

#[test]
fn face_energies_sum_to_the_total() {
    let sim = Simulation::build(&scene("square_rhombus.toml", &[])).unwrap();
    let faces = sim.face_energies().unwrap();
    assert_eq!(faces.len(), sim.mesh().n_faces());
    let total: f64 = faces.iter().map(|e| e.stretch + e.bend).sum();
    let e = sim.energy();
    let elastic = e.stretch + e.bend;
    assert!(
        ((total - elastic) / elastic).abs() < 1e-12,
        "{total} vs {elastic}"
    );
}

#[test]
fn a_stimulus_set_before_the_first_step_equals_the_scene_s() {
    let s = -0.05268025782891314;
    let mut given =
        Simulation::build(&scene("sphere_uniform_heat.toml", &["integrator.steps=2"])).unwrap();
    let mut set = Simulation::build(&scene(
        "sphere_uniform_heat.toml",
        &["integrator.steps=2", "growth.stimulus.value=0.0"],
    ))
    .unwrap();
    let n = set.mesh().n_faces();
    set.set_stimulus(vec![FaceStimulus::uniform(s); n]).unwrap();
    assert_eq!(set.stimulus().unwrap(), given.stimulus().unwrap());
    for _ in 0..2 {
        given.step().unwrap();
        set.step().unwrap();
    }
    assert_eq!(given.positions(), set.positions(), "bit for bit");
    assert_eq!(given.rest(), set.rest());
}

#[test]
fn bad_edits_are_errors_and_change_nothing() {
    let mut sim = Simulation::build(&scene("square_rhombus.toml", &[])).unwrap();
    let err = sim.set_stimulus(vec![]).unwrap_err();
    assert!(matches!(err, RestEditError::NoGrowth), "{err}");
    let before = sim.rest().clone();
    let mut bad = before.clone();
    bad.a_bar[3] = Matrix2::new(-1.0, 0.0, 0.0, 1.0);
    let err = sim.set_rest_forms(bad).unwrap_err().to_string();
    assert!(err.contains("face f3") && err.contains("a_bar"), "{err}");
    assert_eq!(sim.rest(), &before);

    let mut g = Simulation::build(&scene("sphere_uniform_heat.toml", &[])).unwrap();
    let err = g
        .set_stimulus(vec![FaceStimulus::uniform(0.0); 3])
        .unwrap_err();
    assert!(err.to_string().contains("expected 320"), "{err}");
    let mut nan = vec![FaceStimulus::uniform(0.0); 320];
    nan[7].top = f64::NAN;
    let err = g.set_stimulus(nan).unwrap_err();
    assert!(err.to_string().contains("f7"), "{err}");
}
