//! The edge angles belong to the state: with the default bending form
//! (edge directors, one massless angle per edge), every public path that reports an energy
//! after a static solve — the step report, `ShellSystem::energy(x)`, `face_energies` — gives
//! the energy at the minimising angles, checked against an independent evaluation: the angles
//! relaxed separately, by a dense Newton minimisation over the angles alone at the solved
//! positions, through the energy crate only.
#![allow(clippy::unwrap_used)]

use nalgebra::{DMatrix, DVector, Vector3};
use thinshell_energy::{
    Assembler, DofMap, EvalOutput, HessianMode, Material, RestState, SffKind, ShellModel, Terms,
    fitted_free_edges,
};
use thinshell_mesh::{Mesh, VertexId, generators};
use thinshell_solver::{Integrator, SolverError, State, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};

fn model() -> ShellModel {
    ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff: SffKind::default(),
    }
}

/// The energy (J) at positions `x` with the edge angles minimised independently of the
/// solver: dense Newton on the angle block (all vertices held), to a correction of 1e-14 rad.
fn independent_energy(
    mesh: &Mesh,
    model: &ShellModel,
    rest: &RestState,
    x: &[Vector3<f64>],
) -> f64 {
    let n = mesh.n_vertices();
    let dofs = DofMap::with_pinned_vertices(n, (0..n).map(VertexId::new))
        .and_then(|d| d.with_edges(mesh.n_edges(), fitted_free_edges(mesh)))
        .unwrap();
    let mut asm = Assembler::for_model(mesh, &dofs, model).unwrap();
    let free: Vec<usize> = dofs.free_coordinates().iter().map(|&c| c - 3 * n).collect();
    let mut phi = vec![0.0; mesh.n_edges()];
    let mut g = vec![0.0; dofs.n_coordinates()];
    let mut h = asm.hessian_template();
    for _ in 0..50 {
        asm.evaluate_with_angles(
            model,
            x,
            &phi,
            rest,
            None,
            EvalOutput {
                gradient: Some(&mut g),
                hessian: Some((&mut h, HessianMode::Exact)),
            },
        )
        .unwrap();
        let m = free.len();
        let mut dense = DMatrix::<f64>::zeros(m, m);
        let (cp, ri, v) = (h.col_ptr(), h.row_idx(), h.val());
        for j in 0..m {
            for k in cp[j]..cp[j + 1] {
                dense[(ri[k], j)] = v[k];
                dense[(j, ri[k])] = v[k];
            }
        }
        let rhs = DVector::from_iterator(m, free.iter().map(|&e| -g[3 * n + e]));
        let step = dense.lu().solve(&rhs).unwrap();
        for (&e, s) in free.iter().zip(step.iter()) {
            phi[e] += s;
        }
        if step.amax() < 1e-14 {
            break;
        }
    }
    asm.evaluate_with_angles(model, x, &phi, rest, None, EvalOutput::default())
        .unwrap()
        .total()
}

/// Solves the static problem, then compares every reported energy with the independent one;
/// returns the relative gap of the zero-angle energy (what ignoring the angles would report).
fn check(
    mesh: Mesh,
    rest_x: &[Vector3<f64>],
    start: Vec<Vector3<f64>>,
    loads: Loads,
    boundary: Boundary,
) -> f64 {
    let model = model();
    let rest = RestState::for_model(&mesh, rest_x, &model).unwrap();
    let mut sys = ShellSystem::new(mesh.clone(), model, rest.clone(), boundary, loads).unwrap();
    // Through `Static::solve` (positions only in, angles kept on the system) …
    let mut x = start.clone();
    Static::default().solve(&mut sys, &mut x).unwrap();
    assert_eq!(sys.edge_angles().len(), mesh.n_edges());
    let reference = independent_energy(&mesh, &model, &rest, &x);
    let kept = sys.edge_angles().to_vec();
    let e = sys.energy(&x).unwrap().total();
    let faces: f64 = sys
        .face_energies(&x, &[])
        .unwrap()
        .iter()
        .map(|t| t.total())
        .sum();
    // … and through a static step on a `State`.
    let mut state = State::at_rest(start);
    let report = Static::default().step(&mut sys, &mut state).unwrap();
    let e_step = report.energies.total();
    let e_state = sys.energy_at(&state.x, &state.phi).unwrap().total();
    let reference_step = independent_energy(&mesh, &model, &rest, &state.x);
    let zero = sys
        .energy_at(&x, &vec![0.0; mesh.n_edges()])
        .unwrap()
        .total();
    println!(
        "{} faces: independent {reference:.12e} J; energy(x) {e:.12e} ({:+.1e}), faces {:+.1e}, \
         step {:+.1e}, zero angles {:+.2} %",
        mesh.n_faces(),
        e / reference - 1.0,
        faces / reference - 1.0,
        e_step / reference_step - 1.0,
        100.0 * (zero / reference - 1.0)
    );
    for (what, got, want) in [
        ("energy(x)", e, reference),
        ("face_energies", faces, reference),
        ("step report", e_step, reference_step),
        ("energy_at(state)", e_state, reference_step),
    ] {
        assert!(
            (got - want).abs() <= 1e-10 * want.abs(),
            "{what}: {got:e} J vs independent {want:e} J"
        );
    }
    // The angles energy() relaxed from are those of the solve, and stay them.
    let drift = kept
        .iter()
        .zip(sys.edge_angles())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(drift < 1e-8, "relaxed angles moved by {drift} rad");
    zero / reference - 1.0
}

/// A sphere whose rest shape is a perturbed sphere, inflated by a pressure.
#[test]
fn perturbed_sphere_energies_use_the_solved_angles() {
    let mesh = generators::icosphere(0.1, 2).unwrap();
    let rest_x: Vec<Vector3<f64>> = mesh
        .positions()
        .iter()
        .map(|p| p * (1.0 + 0.05 * (7.0 * p.x / 0.1).sin() * (5.0 * p.z / 0.1).cos()))
        .collect();
    let loads = Loads {
        pressure: 20.0,
        ..Loads::default()
    };
    let start = mesh.positions().to_vec();
    let gap = check(mesh, &rest_x, start, loads, Boundary::default());
    // Zero angles overstate the energy, by more than the tolerance by far.
    assert!(gap > 1e-3, "zero angles: {gap:+e}");
}

/// A Delaunay (irregular) half-cylinder as rest shape, one end pinned, under gravity.
#[test]
fn delaunay_half_cylinder_energies_use_the_solved_angles() {
    let flat = generators::irregular_rectangle(std::f64::consts::PI * 0.05, 0.2, 8, 3).unwrap();
    let r = 0.05;
    let rest_x: Vec<Vector3<f64>> = flat
        .positions()
        .iter()
        .map(|p| Vector3::new(r * (p.x / r).sin(), p.y, r * (1.0 - (p.x / r).cos())))
        .collect();
    let pinned: Vec<VertexId> = (0..flat.n_vertices())
        .filter(|&v| flat.positions()[v].y < 1e-9)
        .map(VertexId::new)
        .collect();
    let boundary = Boundary {
        pinned_vertices: pinned,
        ..Boundary::default()
    };
    // From the rest shape, sagging under 20 g (a strong load: the angles must move).
    let loads = Loads {
        gravity: Vector3::new(0.0, 0.0, -200.0),
        ..Loads::default()
    };
    let gap = check(flat, &rest_x, rest_x.clone(), loads, boundary);
    assert!(gap > 1e-4, "zero angles: {gap:+e}");
}

/// A rest state computed with one form and a model of another is refused at construction.
#[test]
fn a_rest_state_of_another_form_is_refused() {
    let mesh = generators::rectangle(1.0, 1.0, 4, 4).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let err =
        ShellSystem::new(mesh, model(), rest, Boundary::default(), Loads::default()).unwrap_err();
    assert!(matches!(err, SolverError::FormMismatch { .. }), "{err}");
    assert!(err.to_string().contains("RestState::for_model"), "{err}");
}

/// A system with damping reports the same elastic energy (at the minimising angles) as the
/// same system without it: `energy(x)` is the elastic energy, whatever the terms solved.
#[test]
fn energy_of_a_damped_system_is_its_elastic_energy() {
    let mesh = generators::icosphere(0.1, 2).unwrap();
    let x: Vec<Vector3<f64>> = mesh
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x * 1.1, p.y, p.z * 0.95))
        .collect();
    let elastic = model();
    let damped = ShellModel {
        terms: Terms::ALL,
        ..elastic
    };
    let rest = RestState::for_model(&mesh, mesh.positions(), &elastic).unwrap();
    let system = |m: ShellModel| {
        ShellSystem::new(
            mesh.clone(),
            m,
            rest.clone(),
            Boundary::default(),
            Loads::default(),
        )
        .unwrap()
    };
    let e = system(elastic).energy(&x).unwrap();
    let mut d = system(damped);
    let e_damped = d.energy(&x).unwrap();
    let faces: f64 = d
        .face_energies(&x, &[])
        .unwrap()
        .iter()
        .map(|t| t.total())
        .sum();
    let reference = independent_energy(&mesh, &elastic, &rest, &x);
    assert!(
        (e.total() - reference).abs() <= 1e-10 * reference,
        "{e:?} vs {reference}"
    );
    assert!(
        (e_damped.total() - e.total()).abs() <= 1e-12 * e.total(),
        "{e_damped:?} vs {e:?}"
    );
    assert_eq!(e_damped.damping, 0.0);
    assert!((faces - e.total()).abs() <= 1e-12 * e.total());
}
