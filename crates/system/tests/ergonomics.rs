//! Downstream ergonomics: the linear-algebra crates re-exported, `Static` built by struct
//! update, per-face energies of a `ShellSystem`, and a 3-2-1 pin set against rigid motions.
#![allow(clippy::unwrap_used)]

use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{VertexId, generators};
// Through the solver: the versions its public types use.
use thinshell_solver::nalgebra::Vector3;
use thinshell_solver::{Integrator, State, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};

fn model(material: Material) -> ShellModel {
    ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff: SffKind::MidEdgeAverage,
    }
}

/// A flat sheet stretched uniformly by 1 + ε along x: every face carries the StVK membrane
/// energy of model.md, (h/8)·‖ā⁻¹a − I‖²_SV·√det ā with ā⁻¹a − I similar to
/// diag((1+ε)² − 1, 0), i.e. (h/8)·s²·(α/2 + β)·√det ā with s = 2ε + ε²; no bending.
#[test]
fn face_energies_of_a_uniform_stretch() {
    let mesh = generators::rectangle(1.0, 0.5, 5, 3).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let material = Material::paper();
    let x0 = mesh.positions().to_vec();
    let mut sys = ShellSystem::new(
        mesh,
        model(material),
        rest,
        Boundary::default(),
        Loads::default(),
    )
    .unwrap();
    let eps = 0.01;
    let x: Vec<Vector3<f64>> = x0
        .iter()
        .map(|p| Vector3::new(p.x * (1.0 + eps), p.y, p.z))
        .collect();
    let faces = sys.face_energies(&x, &[]).unwrap();
    assert_eq!(faces.len(), sys.mesh().n_faces());
    let (e, nu, h) = (material.young, material.poisson, material.thickness);
    let (alpha, beta) = (e * nu / (1.0 - nu * nu), e / (2.0 * (1.0 + nu)));
    let s = 2.0 * eps + eps * eps;
    for (f, terms) in sys.mesh().faces().iter().zip(&faces) {
        let [a, b, c] = [x0[f[0].idx()], x0[f[1].idx()], x0[f[2].idx()]];
        let sqrt_det = (b - a).cross(&(c - a)).norm();
        let expected = h / 8.0 * s * s * (alpha / 2.0 + beta) * sqrt_det;
        assert!(
            (terms.stretch - expected).abs() <= 1e-10 * expected,
            "stretch {} vs {expected}",
            terms.stretch
        );
        assert!(terms.bend.abs() <= 1e-12 * expected);
    }
    let total = sys.energy(&x).unwrap();
    let sum: f64 = faces.iter().map(|t| t.total()).sum();
    assert!((sum - total.total()).abs() <= 1e-12 * total.total());
}

/// A closed sphere (R = 1 m) under internal pressure p, held only by the 3-2-1 pins: the pins
/// remove the rigid motions (the exact Hessian, without the static solver's shift, is positive
/// definite), carry no force (pressure on a closed surface is self-balanced), and the sphere
/// inflates like a thin membrane sphere, ΔR/R = p·R·(1 − ν)/(2·E·h) (within 5 % on the
/// level-3 icosphere).
#[test]
fn rigid_motion_pins_hold_a_free_sphere_without_force() {
    let mesh = generators::icosphere(1.0, 3).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let pins = Boundary::rigid_motion_pins(&mesh, VertexId::new(0)).unwrap();
    assert_eq!(pins.len(), 6);
    assert_eq!(
        pins[..3],
        [
            (VertexId::new(0), 0),
            (VertexId::new(0), 1),
            (VertexId::new(0), 2)
        ]
    );
    let material = Material {
        young: 1e5,
        thickness: 1e-2,
        ..Material::paper()
    };
    let p = 1.0;
    let boundary = Boundary {
        pinned_coordinates: pins.clone(),
        ..Default::default()
    };
    let loads = Loads {
        pressure: p,
        ..Default::default()
    };
    let x0 = mesh.positions().to_vec();
    let mut sys = ShellSystem::new(mesh, model(material), rest, boundary, loads).unwrap();
    assert_eq!(sys.dofs().n_free(), 3 * x0.len() - 6);
    let mut st = Static {
        hessian_shift: 0.0,
        ..Static::default()
    };
    let mut state = State::at_rest(x0.clone());
    let report = st.step(&mut sys, &mut state).unwrap();
    assert_eq!(report.stable, Some(true));

    let load = p * 4.0 * std::f64::consts::PI;
    let reactions = sys.reactions(&state.x).unwrap();
    let largest = reactions.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    assert!(largest <= 1e-9 * load, "pin force {largest:e} N");

    let dr = state.x.iter().map(|q| q.norm() - 1.0).sum::<f64>() / x0.len() as f64;
    let (e, nu, h) = (material.young, material.poisson, material.thickness);
    let expected = p * (1.0 - nu) / (2.0 * e * h);
    assert!(
        (dr - expected).abs() <= 0.05 * expected,
        "ΔR {dr:e} vs {expected:e}"
    );
}

#[test]
fn rigid_motion_pins_reject_a_bad_anchor() {
    let mesh = generators::rectangle(1.0, 1.0, 2, 2).unwrap();
    let e = Boundary::rigid_motion_pins(&mesh, VertexId::new(1000)).unwrap_err();
    assert!(e.to_string().contains("anchor"), "{e}");
}
