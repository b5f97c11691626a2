//! Edge-director bending in whole simulations (docs/robustness.md, "Edge-director bending"): the
//! seed's cylindrical-patch experiment (model.md §5) on irregular meshes under refinement, for the
//! mid-edge average and both director variants, and the scene key that selects the form.
#![allow(clippy::unwrap_used)]

use thinshell::reference::{SquareCase, rms_distance_modulo_rigid};
use thinshell_energy::{DirectorVariant, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{Mesh, generators};
use thinshell_solver::{ExplicitEuler, Integrator, NewtonReport, State, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};
use thinshell_testkit::fixtures::data_path;

/// Paper-like but thick enough that bending matters on the unit square.
fn material() -> Material {
    Material {
        thickness: 1e-2,
        young: 1e5,
        poisson: 0.3,
        density: 250.0,
        viscosity: 0.0,
        model: thinshell_energy::MaterialModel::StVK,
    }
}

/// Stretching and bending with `sff`, no damping.
fn elastic_model(sff: SffKind) -> ShellModel {
    ShellModel {
        material: material(),
        terms: Terms::ELASTIC,
        sff,
    }
}

/// Static equilibrium of the cylinder case from the seed's start (rolled to radius 2); returns
/// the RMS distance (m) to the radius-1 cylinder modulo rigid motion and the Newton report.
fn cylinder_error(mesh: &Mesh, sff: SffKind) -> (f64, NewtonReport, usize) {
    let (a, b) = SquareCase::Cylinder.planar_forms();
    let rest = RestState::from_planar(mesh, a, b).unwrap();
    let model = elastic_model(sff);
    let x0 = mesh.positions().to_vec();
    let mut sys = ShellSystem::new(
        mesh.clone(),
        model,
        rest,
        Boundary::default(),
        Loads::default(),
    )
    .unwrap();
    let mut solver = Static::default();
    solver.newton.gradient_tolerance = 1e-10;
    solver.newton.max_iterations = 200;
    let mut x = SquareCase::Cylinder.seed_start(&x0);
    let mut phi = vec![0.0; sys.n_edge_angles()];
    let report = solver
        .solve_with_angles(&mut sys, &mut x, &mut phi)
        .unwrap();
    assert!(x.iter().all(|p| p.iter().all(|c| c.is_finite())));
    let err = rms_distance_modulo_rigid(&x, &SquareCase::Cylinder.equilibrium(&x0)).unwrap();
    (err, report, sys.dofs().n_free())
}

/// Irregular triangulations of the unit square, `n` cells per side.
fn meshes() -> Vec<Mesh> {
    [6, 12, 24, 48]
        .iter()
        .map(|&n| generators::irregular_rectangle(1.0, 1.0, n, 7).unwrap())
        .collect()
}

/// Measured (irregular meshes, n = 6, 12, 24, 48 cells per side, 66 … ~4 000 faces): the mid-edge
/// average stalls at an RMS error of about 3·10⁻³ m (ratio ≈ 1 per refinement); both director
/// variants fall by about 5× per halving of h (order ≈ 2.3) to 7.8·10⁻⁶ (sin) / 8.2·10⁻⁶ m (tan),
/// in the same number of Newton iterations (13 vs 12).
#[test]
fn cylinder_patch_converges_with_edge_directors_on_irregular_meshes() {
    let meshes = meshes();
    let mut average_iterations = 0;
    for sff in SffKind::ALL {
        let mut errors = Vec::new();
        let mut iterations = 0;
        for mesh in &meshes {
            let (err, report, n) = cylinder_error(mesh, sff);
            eprintln!(
                "{:>18}: {:>5} faces, {:>5} unknowns, rms error {err:.3e} m, {} Newton iterations",
                sff.name(),
                mesh.n_faces(),
                n,
                report.iterations
            );
            errors.push(err);
            iterations = iterations.max(report.iterations);
        }
        let rates: Vec<f64> = errors.windows(2).map(|w| w[0] / w[1]).collect();
        eprintln!(
            "{:>18}: error ratio per halving of h {rates:.2?}",
            sff.name()
        );
        let last = *errors.last().unwrap();
        match sff {
            SffKind::MidEdgeAverage => {
                // Inconsistent: refinement stops helping at a few mm.
                assert!(last > 2e-3, "average unexpectedly converged: {errors:?}");
                assert!(rates.last().unwrap() < &1.5, "{rates:?}");
                average_iterations = iterations;
            }
            SffKind::EdgeDirector(_) => {
                assert!(
                    rates.iter().all(|&r| r > 3.0),
                    "{}: error must fall ≥ 3× per refinement: {errors:?}",
                    sff.name()
                );
                assert!(last < 2e-5, "{}: {errors:?}", sff.name());
                // Four times the unknowns of the average (per-edge angles) but no extra
                // Newton iterations worth mentioning.
                assert!(
                    iterations <= average_iterations + 5,
                    "{}: {iterations} vs {average_iterations} iterations",
                    sff.name()
                );
            }
        }
    }
}

#[test]
fn director_variants_start_with_zero_angles_and_keep_unknown_count() {
    let mesh = generators::irregular_rectangle(1.0, 1.0, 4, 3).unwrap();
    // Free edges with a fit have no angle unknown (model.md §1.2): one unknown per other edge.
    let fitted = thinshell_energy::fitted_free_edges(&mesh).len();
    assert!(fitted > 0);
    for (sff, extra, angles) in [
        (SffKind::MidEdgeAverage, 0, 0),
        (
            SffKind::EdgeDirector(DirectorVariant::Sin),
            mesh.n_edges() - fitted,
            mesh.n_edges(),
        ),
        (
            SffKind::EdgeDirector(DirectorVariant::Tan),
            mesh.n_edges() - fitted,
            mesh.n_edges(),
        ),
    ] {
        let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
        let model = elastic_model(sff);
        let mut sys = ShellSystem::new(
            mesh.clone(),
            model,
            rest,
            Boundary::default(),
            Loads::default(),
        )
        .unwrap();
        assert_eq!(sys.dofs().n_free(), 3 * mesh.n_vertices() + extra);
        assert_eq!(sys.n_edge_angles(), angles);
        // Explicit Euler relaxes the massless angles at every step (at rest they stay 0).
        let mut state = State::at_rest(mesh.positions().to_vec());
        ExplicitEuler { dt: 1e-5 }
            .step(&mut sys, &mut state)
            .unwrap();
        assert_eq!(state.phi.len(), angles);
        assert!(state.phi.iter().all(|p| p.abs() < 1e-12), "{:?}", state.phi);
    }
}

fn scene(name: &str, overrides: &[&str]) -> thinshell::scene::Scene {
    let p = data_path(&format!("scenes/{name}"));
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    thinshell::scene::Scene::load_with_overrides(&p, &o).unwrap()
}

/// The seed's cylinder scene, switched to edge directors in one place: implicit steps with
/// Kelvin–Voigt damping solve positions and angles together; the damped run, continued as a
/// static solve, reaches the cylinder closer than the mid-edge average does on the same mesh.
#[test]
fn scene_key_switches_the_form_for_dynamics_and_statics() {
    let mut errors = Vec::new();
    for form in ["mid_edge_average", "edge_director_sin", "edge_director_tan"] {
        let set = format!("bending.form=\"{form}\"");
        let s = scene(
            "square_cylinder.toml",
            &[&set, "integrator.steps=5", "integrator.dt=1e-3"],
        );
        let mut sim = thinshell::sim::Simulation::build(&s).unwrap();
        let n_edges = sim.mesh().n_edges();
        let director = form != "mid_edge_average";
        assert_eq!(
            sim.system().n_edge_angles(),
            if director { n_edges } else { 0 }
        );
        for _ in 0..5 {
            let r = sim.step().unwrap();
            assert!(
                r.newton_iterations > 0 && r.residual <= 1e-8,
                "{form}: {r:?}"
            );
        }
        assert!(
            sim.positions()
                .iter()
                .all(|p| p.iter().all(|c| c.is_finite()))
        );
        if director {
            assert_eq!(sim.edge_angles().len(), n_edges);
            assert!(sim.edge_angles().iter().any(|p| p.abs() > 1e-6), "{form}");
        } else {
            assert!(sim.edge_angles().is_empty());
        }

        let s = scene(
            "square_cylinder.toml",
            &[
                &set,
                "effects=[\"stretching\", \"bending\"]",
                "integrator.kind=\"static\"",
                "integrator.steps=1",
                "integrator.dt=1.0",
                // The seed scene switches the line search off (the seed's way); a static
                // solve from far away needs it.
                "integrator.newton.line_search=true",
                // Paper-thin (h/L = 1e-4) from radius 2: the adaptive Newton's Gauss–Newton
                // phase takes about 260 iterations to the scale-free tolerance
                // (docs/robustness.md).
                "integrator.newton.max_iterations=400",
            ],
        );
        let mut sim = thinshell::sim::Simulation::build(&s).unwrap();
        sim.step().unwrap();
        let x0 = sim.reference_positions().to_vec();
        let err =
            rms_distance_modulo_rigid(sim.positions(), &SquareCase::Cylinder.equilibrium(&x0))
                .unwrap();
        eprintln!("{form}: static rms error {err:.3e} m");
        errors.push(err);
    }
    // Seed mesh (184 faces, mildly irregular): average 2.9e-3 m, directors ≈ 3× closer.
    assert!(errors[0] > 2e-3, "{errors:?}");
    assert!(
        errors[1] < errors[0] / 2.0 && errors[2] < errors[0] / 2.0,
        "{errors:?}"
    );
}

#[test]
fn scene_errors_for_the_bending_form() {
    let p = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/scenes/square_cylinder.toml");
    let load = |o: &[&str]| {
        let o: Vec<String> = o.iter().map(|s| s.to_string()).collect();
        thinshell::scene::Scene::load_with_overrides(&p, &o)
            .unwrap_err()
            .to_string()
    };
    let e = load(&["bending.form=\"edge_director_cos\""]);
    assert!(
        e.contains("bending.form") || e.contains("edge_director_cos"),
        "{e}"
    );
    // (Explicit Euler accepts director forms: tests/default_form.rs.)
    let e = load(&[
        "bending.form=\"edge_director_tan\"",
        "effects=[\"stretching\", \"inertia\"]",
    ]);
    assert!(e.contains("bending"), "{e}");
}

/// A cantilever under gravity: the clamped edges' angles stay exactly 0 (a clamp holds the
/// director, model.md §1.3); pinned boundary edges, like free ones, take their director from
/// the fit (§1.2: angle not an unknown, the edge rotates with the sheet); interior angles move.
#[test]
fn clamps_fix_edge_angles_and_pins_do_not() {
    use thinshell_mesh::{EdgeId, VertexId};
    let mesh = generators::irregular_rectangle(1.0, 0.3, 6, 5).unwrap();
    let p = mesh.positions();
    let edges = mesh.topology().edges();
    let on = |v: VertexId, x: f64| (p[v.idx()].x - x).abs() < 1e-12;
    let clamped: Vec<EdgeId> = (0..edges.len())
        .filter(|&e| edges[e].right.is_none() && edges[e].vertices.iter().all(|&v| on(v, 0.0)))
        .map(EdgeId::new)
        .collect();
    assert!(clamped.len() >= 2);
    let pinned: Vec<VertexId> = (0..mesh.n_vertices())
        .map(VertexId::new)
        .filter(|&v| on(v, 1.0))
        .collect();
    let pinned_edges: Vec<usize> = (0..edges.len())
        .filter(|&e| edges[e].vertices.iter().all(|v| pinned.contains(v)))
        .collect();
    assert!(!pinned_edges.is_empty());
    let sff = SffKind::EdgeDirector(DirectorVariant::Tan);
    let rest = RestState::from_mesh(&mesh, p, sff).unwrap();
    let model = elastic_model(sff);
    let boundary = Boundary {
        clamped_edges: clamped.clone(),
        pinned_coordinates: pinned.iter().map(|&v| (v, 2)).collect(),
        ..Boundary::default()
    };
    let loads = Loads {
        gravity: nalgebra::Vector3::new(0.0, 0.0, -9.81),
        ..Loads::default()
    };
    let mut sys = ShellSystem::new(mesh.clone(), model, rest, boundary, loads).unwrap();
    let fitted = thinshell_energy::fitted_free_edges(&mesh);
    let fixed = (0..mesh.n_edges())
        .filter(|&e| clamped.contains(&EdgeId::new(e)) || fitted.contains(&EdgeId::new(e)))
        .count();
    assert_eq!(
        sys.dofs().n_free(),
        sys.dofs().n_free_positions() + mesh.n_edges() - fixed
    );
    assert!(
        pinned_edges
            .iter()
            .all(|&e| fitted.contains(&EdgeId::new(e)))
    );
    let mut x = p.to_vec();
    let mut phi = vec![0.0; mesh.n_edges()];
    let mut solver = Static::default();
    solver.newton.gradient_tolerance = 1e-10;
    solver
        .solve_with_angles(&mut sys, &mut x, &mut phi)
        .unwrap();
    for e in &clamped {
        assert_eq!(phi[e.idx()], 0.0, "clamped edge {e:?}");
    }
    let largest = phi.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest > 1e-4, "the free angles moved: {largest}");
    assert!(pinned_edges.iter().all(|&e| phi[e] == 0.0));
    // The sheet sags between the supports.
    assert!(x.iter().any(|q| q.z < -1e-4));
}
