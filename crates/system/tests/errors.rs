//! Errors of the layers below the solver keep their type: energy errors as
//! `SolverError::Energy`, any other objective error (here a growth error) as
//! `SolverError::Objective`, both reachable through `source()` for a downcast, with the same
//! message text as before (`objective evaluation failed: …`).
#![allow(clippy::unwrap_used)]

use std::error::Error;

use thinshell_energy::{EnergyError, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::GrowthError;
use thinshell_mesh::generators;
use thinshell_solver::SolverError;
use thinshell_system::{Boundary, Loads, ShellSystem};

#[test]
fn energy_errors_keep_their_type() {
    let mesh = generators::rectangle(1.0, 1.0, 3, 3).unwrap();
    // Rest forms of another mesh: one per face of a 2×2 grid, not of the 3×3 one.
    let other = generators::rectangle(1.0, 1.0, 2, 2).unwrap();
    let sff = SffKind::MidEdgeAverage;
    let rest = RestState::from_mesh(&other, other.positions(), sff).unwrap();
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let err =
        ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default()).unwrap_err();
    assert!(matches!(err, SolverError::Energy(_)), "{err:?}");
    let source = err.source().unwrap();
    let energy = source.downcast_ref::<EnergyError>().unwrap();
    assert_eq!(
        err.to_string(),
        format!("objective evaluation failed: {energy}")
    );
}

#[test]
fn objective_errors_keep_their_type() {
    let growth = GrowthError::InvalidParameter {
        name: "thickness",
        value: -1.0,
        reason: "must be positive",
    };
    let message = growth.to_string();
    let err = SolverError::objective(growth);
    assert_eq!(
        err.to_string(),
        format!("objective evaluation failed: {message}")
    );
    let back = err.source().unwrap().downcast_ref::<GrowthError>().unwrap();
    assert!(matches!(
        back,
        GrowthError::InvalidParameter {
            name: "thickness",
            ..
        }
    ));
}
