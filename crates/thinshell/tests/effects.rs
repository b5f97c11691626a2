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

#[test]
fn disabled_bending_is_never_evaluated() {
    let mut sim = square(r#""stretching", "inertia""#, "");
    // Bending alone reads b̄; poison it.
    for b in &mut sim.system_mut().rest.b_bar {
        *b = Matrix2::repeat(f64::NAN);
    }
    for _ in 0..3 {
        let r = sim.step().unwrap();
        assert_eq!(r.energy.bend, 0.0);
        assert!(r.energy.stretch > 0.0 && r.energy.stretch.is_finite());
    }
    assert!(
        sim.positions()
            .iter()
            .all(|p| p.iter().all(|c| c.is_finite()))
    );

    // Control: with bending on, the same poison is caught at once.
    let mut on = square(r#""stretching", "bending", "inertia""#, "");
    for b in &mut on.system_mut().rest.b_bar {
        *b = Matrix2::repeat(f64::NAN);
    }
    assert!(on.step().is_err());
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
    assert!(off.system().contact.is_none());
    assert!(off.step().unwrap().contact.is_none());
    // Control: named, it is built and reported.
    let mut on = square(r#""stretching", "inertia", "contact""#, "");
    assert!(on.system().contact.is_some());
    assert!(on.step().unwrap().contact.is_some());
}
