//! Mass with stimulus uptake.
#![allow(clippy::unwrap_used)]

use thinshell_energy::{Material, RestState, SffKind, lumped_mass};
use thinshell_growth::{GrowthError, mass_with_uptake};
use thinshell_mesh::generators;

#[test]
fn uptake_adds_density_times_stimulus_times_volume() {
    let mesh = generators::irregular_rectangle(0.2, 0.1, 6, 11).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let material = Material::paper();
    let dry = lumped_mass(&mesh, &rest, &material).unwrap();
    let zero = vec![0.0; mesh.n_faces()];
    let same = mass_with_uptake(&mesh, &rest, &material, 30.0, &zero).unwrap();
    for (a, b) in same.iter().zip(&dry) {
        assert!((a / b - 1.0).abs() < 1e-14, "{a} vs {b}");
    }

    let m = vec![0.5; mesh.n_faces()];
    let wet = mass_with_uptake(&mesh, &rest, &material, 30.0, &m).unwrap();
    let added: f64 = wet.iter().sum::<f64>() - dry.iter().sum::<f64>();
    // 30 kg/m³ per unit × 0.5 × h × 0.2 m × 0.1 m.
    let want = 30.0 * 0.5 * material.thickness * 0.02;
    assert!((added / want - 1.0).abs() < 1e-12, "{added} vs {want}");

    // Draining more than the dry density is refused.
    let e = mass_with_uptake(&mesh, &rest, &material, -1000.0, &m).unwrap_err();
    assert!(matches!(e, GrowthError::InvalidParameter { .. }), "{e}");
}
