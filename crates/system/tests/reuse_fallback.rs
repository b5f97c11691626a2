//! Factorisation reuse (CG preconditioned with the last Cholesky factor) and the
//! iterative fallback (CG with IC(0) or Jacobi) give the direct solver's answers, with fewer
//! factorisations for reuse; bad settings are typed errors.
#![allow(clippy::unwrap_used)]

use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::generators;
use thinshell_solver::nalgebra::Vector3;
use thinshell_solver::{
    ImplicitEuler, Integrator, IterativeFallback, LinearSolver, NewtonSettings, SolverError, State,
    Static,
};
use thinshell_system::{Boundary, Loads, ShellSystem};

/// A paper sheet pinned on its boundary under gravity, and its weight (N).
fn sheet(n: usize) -> (ShellSystem, Vec<Vector3<f64>>, f64) {
    let mesh = generators::rectangle(1.0, 1.0, n, n).unwrap();
    let sff = SffKind::MidEdgeAverage;
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let boundary = Boundary {
        pinned_vertices: mesh.topology().boundary_vertices().to_vec(),
        ..Default::default()
    };
    let loads = Loads {
        gravity: Vector3::new(0.0, 0.0, -9.81),
        ..Default::default()
    };
    let x0 = mesh.positions().to_vec();
    let system = ShellSystem::new(mesh, model, rest, boundary, loads).unwrap();
    let weight = system.mass().iter().sum::<f64>() * 9.81;
    (system, x0, weight)
}

fn max_distance(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
}

/// Runs `steps` implicit steps; returns the final positions, factorisations, reused steps.
fn implicit_run(settings: NewtonSettings, steps: usize) -> (Vec<Vector3<f64>>, usize, usize) {
    let (mut system, x0, _) = sheet(8);
    let mut ie = ImplicitEuler::new(1e-3);
    ie.newton = settings;
    let mut state = State::at_rest(x0);
    let (mut factorizations, mut reused) = (0, 0);
    for _ in 0..steps {
        let r = ie.step(&mut system, &mut state).unwrap();
        let n = r.newton.unwrap();
        factorizations += n.factorizations;
        reused += n.reused_steps;
    }
    (state.x, factorizations, reused)
}

#[test]
fn reusing_the_factor_gives_the_same_steps_with_fewer_factorisations() {
    let direct = implicit_run(NewtonSettings::default(), 10);
    let reuse = implicit_run(
        NewtonSettings {
            reuse_factor: true,
            ..NewtonSettings::default()
        },
        10,
    );
    // The sheet is 1 m wide: positions agree to 1e-8 of its size.
    let d = max_distance(&direct.0, &reuse.0);
    assert!(d <= 1e-8, "reuse moved the result by {d} m");
    assert!(reuse.2 > 0, "no step reused the factor");
    assert!(
        reuse.1 < direct.1,
        "factorisations: {} with reuse, {} without",
        reuse.1,
        direct.1
    );
}

fn static_sag(settings: NewtonSettings) -> (Vec<Vector3<f64>>, LinearSolver, usize, usize) {
    let (mut system, x0, weight) = sheet(8);
    let mut statics = Static {
        force_scale: Some(weight),
        newton: settings,
        ..Static::default()
    };
    let mut x = x0;
    let r = statics.solve(&mut system, &mut x).unwrap();
    (x, r.linear_solver, r.cg_iterations, r.refined_steps)
}

#[test]
fn the_iterative_solver_finds_the_direct_solvers_equilibrium() {
    let (direct, kind, cg, refined) = static_sag(NewtonSettings::default());
    assert_eq!(kind, LinearSolver::Direct);
    // The direct solve runs CG only to refine directions solved with the factor of the
    // static solve's slightly shifted Hessian (a few iterations each).
    assert!(
        cg <= 5 * refined.max(1),
        "{cg} CG iterations for {refined} refinements"
    );
    for fallback in [IterativeFallback::Ic0, IterativeFallback::Jacobi] {
        let (x, kind, cg, _) = static_sag(NewtonSettings {
            force_iterative: true,
            fallback,
            ..NewtonSettings::default()
        });
        assert_eq!(kind, LinearSolver::Iterative(fallback));
        assert!(cg > 0);
        let d = max_distance(&direct, &x);
        assert!(d <= 1e-8, "{fallback:?}: {d} m from the direct equilibrium");
        // The sag itself is far larger than that.
        assert!(direct.iter().map(|p| -p.z).fold(0.0, f64::max) > 1e-6);
    }
}

#[test]
fn bad_reuse_and_cg_settings_are_named() {
    for (settings, name) in [
        (
            NewtonSettings {
                reuse_max_iterations: 0,
                ..NewtonSettings::default()
            },
            "reuse_max_iterations",
        ),
        (
            NewtonSettings {
                reuse_tolerance: 1.0,
                ..NewtonSettings::default()
            },
            "reuse_tolerance",
        ),
        (
            NewtonSettings {
                cg_forcing: 0.0,
                ..NewtonSettings::default()
            },
            "cg_forcing",
        ),
        (
            NewtonSettings {
                cg_max_iterations: 0,
                ..NewtonSettings::default()
            },
            "cg_max_iterations",
        ),
    ] {
        match settings.validate() {
            Err(SolverError::InvalidSetting { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{name}: {other:?}"),
        }
    }
}
