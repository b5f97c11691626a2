//! Only the effects a scene lists are built and evaluated.
//!
//! The proof for the energy terms is by poisoning: the data only a disabled term would read is
//! set to NaN, and the run must stay finite (the assembler reports any non-finite face energy
//! as an error, so an evaluated poisoned term cannot go unnoticed).
#![allow(clippy::unwrap_used)]

use std::path::Path;

use nalgebra::Matrix2;
use thinshell::scene::Scene;
use thinshell::sim::Simulation;

fn square(effects: &str, extra: &str) -> Simulation {
    let text = format!(
        r#"
name = "effects"
effects = [{effects}]
[mesh]
generator = "seed_square"
[initial]
scale = 1.02
wrap_cylinder = {{ radius = 1.5 }}
[integrator]
kind = "implicit"
dt = 1e-4
steps = 3
{extra}
"#
    );
    Simulation::build(&Scene::from_toml(&text, "effects.toml", Path::new(".")).unwrap()).unwrap()
}

/// The energy with the simulation's own assembler and rest forms whose b̄ is poisoned.
fn energy_with_poisoned_b_bar(
    sim: &Simulation,
) -> Result<thinshell_energy::EnergyTerms, thinshell_energy::EnergyError> {
    let mut rest = sim.rest().clone();
    for b in &mut rest.b_bar {
        *b = Matrix2::repeat(f64::NAN);
    }
    let model = *sim.model();
    let mut assembler = sim.system().assembler_for(&model)?;
    let phi = vec![0.0; sim.system().n_edge_angles()];
    let mut g = vec![0.0; sim.system().dofs().n_coordinates()];
    assembler.evaluate_with_angles(
        &model,
        sim.positions(),
        &phi,
        &rest,
        None,
        thinshell_energy::EvalOutput {
            gradient: Some(&mut g),
            hessian: None,
        },
    )
}

#[test]
fn disabled_bending_is_never_evaluated() {
    let mut sim = square(r#""stretching", "inertia""#, "");
    // Bending alone reads b̄; poison it (the system itself refuses such forms).
    let r = energy_with_poisoned_b_bar(&sim).unwrap();
    assert_eq!(r.bend, 0.0);
    assert!(r.stretch > 0.0 && r.stretch.is_finite());
    let mut poisoned = sim.rest().clone();
    poisoned.b_bar[0] = Matrix2::repeat(f64::NAN);
    assert!(sim.system_mut().set_rest(poisoned).is_err());
    for _ in 0..3 {
        let r = sim.step().unwrap();
        assert_eq!(r.energy.bend, 0.0);
        assert!(r.energy.stretch > 0.0 && r.energy.stretch.is_finite());
    }

    // Control: with bending on, the same poison is caught at once.
    let on = square(r#""stretching", "bending", "inertia""#, "");
    assert!(energy_with_poisoned_b_bar(&on).is_err());
}

#[test]
fn disabled_terms_and_loads_contribute_nothing() {
    // A stretched and bent start: every term would be non-zero if it were evaluated.
    let mut sim = square(r#""bending", "inertia""#, "");
    let r = sim.step().unwrap();
    assert_eq!((r.energy.stretch, r.energy.damping), (0.0, 0.0));
    assert!(r.energy.bend > 0.0);
    assert!(
        sim.system().external_forces().iter().all(|&f| f == 0.0),
        "no gravity"
    );
    assert!(sim.growth().is_none(), "no growth built");
    assert!(!sim.model().terms.stretch && !sim.model().terms.damping);

    let mut damped = square(r#""stretching", "bending", "inertia", "damping""#, "");
    assert!(
        damped.step().unwrap().energy.damping > 0.0,
        "control: damping on"
    );
}

#[test]
fn a_prescribed_stimulus_builds_no_diffusion_solver() {
    let growth = r#"
[growth]
model = "linear"
coefficient = 0.01
[growth.stimulus]
kind = "uniform"
top = 1.0
bottom = 0.0
"#;
    let mut sim = square(r#""stretching", "bending", "inertia", "growth""#, growth);
    for _ in 0..3 {
        sim.step().unwrap();
    }
    let g = sim.growth().unwrap();
    assert_eq!(g.field_name(), "prescribed");
    assert_eq!(g.rest_updates(), 1, "a constant stimulus is applied once");
}

#[test]
fn contact_is_built_only_when_named() {
    let mut off = square(r#""stretching", "inertia""#, "");
    assert!(off.system().contact().is_none());
    assert!(off.step().unwrap().contact.is_none());
    // Control: named, it is built and reported.
    let mut on = square(r#""stretching", "inertia", "contact""#, "");
    assert!(on.system().contact().is_some());
    assert!(on.step().unwrap().contact.is_some());
}
