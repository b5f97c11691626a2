//! Hard cases stay numerically stable (issue #8): time steps far above the seed's, strong and
//! discontinuous growth, inverted and folded starts, slivers and graded meshes, a crumpled start
//! with an indefinite Hessian, extreme material parameters and a long damped run.
//!
//! Every case checks the same contract: positions stay finite; within every Newton solve the
//! potential never increases (`NewtonReport::values`, up to round-off); a run either converges
//! to the stated tolerance or stops with an explicit [`SolverError`] that carries its residual
//! history and a finite last good iterate, leaving the state unchanged. Outcomes are printed
//! (`-- --nocapture`) and recorded in docs/robustness.md; heavier variants run in
//! `cargo xtask hard-cases`.
#![allow(clippy::unwrap_used)]

use nalgebra::{Matrix2, Vector2, Vector3};
use thinshell_energy::{HessianMode, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::{DirectedHeat, FaceStimulus, Growth, Isotropic, Prescribed, Region};
use thinshell_mesh::{Mesh, generators};
use thinshell_solver::{
    Boundary, ImplicitEuler, Integrator, Loads, NewtonReport, ShellSystem, SolverError, State,
    Static, StepReport,
};

const SFF: SffKind = SffKind::MidEdgeAverage;

fn model(material: Material, damping: bool) -> ShellModel {
    ShellModel {
        material,
        terms: Terms {
            stretch: true,
            bend: true,
            damping,
        },
        sff: SFF,
    }
}

/// Paper with a relaxation time η/E of 1 ms: visibly damped at the time steps used here.
fn damped_paper() -> Material {
    Material {
        viscosity: 2e9 * 1e-3,
        ..Material::paper()
    }
}

/// Asserts the potential never increases within a line-searched Newton solve (up to the
/// round-off the line search itself tolerates) and that every recorded number is finite.
fn check_newton(r: &NewtonReport) {
    assert!(r.values.iter().chain(&r.residuals).all(|v| v.is_finite()));
    for w in r.values.windows(2) {
        let noise = 64.0 * f64::EPSILON * w[0].abs().max(w[1].abs());
        assert!(w[1] <= w[0] + noise, "potential increased: {w:?}");
    }
}

/// Asserts a failure is an explicit Newton failure with a usable history.
fn check_failure(e: &SolverError) {
    match e {
        SolverError::NewtonDidNotConverge {
            residuals,
            last_good,
            ..
        }
        | SolverError::LineSearchFailed {
            residuals,
            last_good,
            ..
        } => {
            assert!(!residuals.is_empty() && residuals.iter().all(|r| r.is_finite()));
            assert!(last_good.iter().all(|v| v.is_finite()));
        }
        SolverError::NotPositiveDefinite { .. }
        | SolverError::RegularizationFailed { .. }
        | SolverError::NonFinite { .. } => {}
        other => panic!("unexpected failure kind: {other}"),
    }
    // The short Debug form: never the whole iterate.
    assert!(format!("{e:?}").len() < 400, "{e:?}");
}

/// What a run did.
#[derive(Debug, Default)]
struct Outcome {
    steps: usize,
    iterations: usize,
    max_iterations: usize,
    regularized_steps: usize,
    halvings: usize,
    fallback_steps: usize,
    backtracks: usize,
    failure: Option<SolverError>,
}

impl Outcome {
    fn record(&mut self, r: &StepReport, own: HessianMode) {
        self.steps += 1;
        self.halvings += r.halvings;
        if r.hessian != own {
            self.fallback_steps += 1;
        }
        if let Some(n) = &r.newton {
            check_newton(n);
            self.iterations += n.iterations;
            self.max_iterations = self.max_iterations.max(n.iterations);
            self.backtracks += n.backtracks;
            if !n.regularizations.is_empty() {
                self.regularized_steps += 1;
            }
        }
    }

    fn line(&self, name: &str) -> String {
        let end = match &self.failure {
            None => "converged".to_string(),
            Some(e) => format!("FAILED: {e}"),
        };
        format!(
            "{name}: {} steps, {} Newton iterations (max {}/step), {} backtracks, {} regularised \
             steps, {} halvings, {} fallback-Hessian steps; {end}",
            self.steps,
            self.iterations,
            self.max_iterations,
            self.backtracks,
            self.regularized_steps,
            self.halvings,
            self.fallback_steps
        )
    }
}

/// Runs `steps` steps, checking the contract after each; stops at the first failure, which must
/// be explicit and leave the state as it was.
fn drive(
    integrator: &mut dyn Integrator,
    sys: &mut ShellSystem,
    state: &mut State,
    steps: usize,
) -> Outcome {
    let own = sys.hessian_mode;
    let mut out = Outcome::default();
    for _ in 0..steps {
        let before = state.clone();
        match integrator.step(sys, state) {
            Ok(r) => {
                out.record(&r, own);
                assert!(r.energies.total().is_finite());
                assert!(
                    state
                        .x
                        .iter()
                        .chain(&state.v)
                        .all(|p| p.iter().all(|c| c.is_finite()))
                );
            }
            Err(e) => {
                check_failure(&e);
                assert_eq!(*state, before, "a failed step changed the state");
                out.failure = Some(e);
                break;
            }
        }
    }
    out
}

fn planar_start(mesh: &Mesh, map: Matrix2<f64>) -> Vec<Vector3<f64>> {
    mesh.positions()
        .iter()
        .map(|p| {
            let q = map * Vector2::new(p.x, p.y);
            Vector3::new(q.x, q.y, 0.0)
        })
        .collect()
}

/// The seed's map onto a cylinder of radius r about an axis ∥ y (model.md §5).
fn wrap(x: &[Vector3<f64>], r: f64) -> Vec<Vector3<f64>> {
    x.iter()
        .map(|p| {
            let th = (p.x - 0.5) / r - std::f64::consts::FRAC_PI_2;
            Vector3::new(r * th.cos(), p.y, r * th.sin())
        })
        .collect()
}

/// The seed's three square experiments (data/scenes/square_*.toml): rest forms (ā^{xy}, b̄^{xy})
/// and start.
fn square_experiment(name: &str) -> (Mesh, RestState, Vec<Vector3<f64>>) {
    let mesh = generators::seed_square().unwrap();
    let s3 = 3f64.sqrt();
    let (a, b, x0) = match name {
        "enlarged" => (
            Matrix2::identity() * 4.0,
            Matrix2::zeros(),
            planar_start(&mesh, Matrix2::identity() * 1.95),
        ),
        "rhombus" => (
            Matrix2::new(2.0, 1.0, 1.0, 2.0),
            Matrix2::zeros(),
            planar_start(
                &mesh,
                Matrix2::new(s3 + 1.0, s3 - 1.0, s3 - 1.0, s3 + 1.0) * 0.45,
            ),
        ),
        _ => (
            Matrix2::identity(),
            Matrix2::new(1.0, 0.0, 0.0, 0.0),
            wrap(mesh.positions(), 2.0),
        ),
    };
    let rest = RestState::from_planar(&mesh, a, b).unwrap();
    (mesh, rest, x0)
}

/// Kinetic energy ½ Σ λ_i |v_i|² (J).
fn kinetic(sys: &ShellSystem, s: &State) -> f64 {
    sys.mass()
        .iter()
        .zip(&s.v)
        .map(|(m, v)| 0.5 * m * v.norm_squared())
        .sum()
}

/// Elastic + kinetic energy (J) of a state (no external loads in these cases).
fn total_energy(sys: &mut ShellSystem, s: &State) -> f64 {
    let terms = Terms {
        damping: false,
        ..sys.model.terms
    };
    let mut m = sys.model;
    m.terms = terms;
    let mut probe = ShellSystem::new(
        sys.mesh.clone(),
        m,
        sys.rest.clone(),
        Boundary::default(),
        Loads::default(),
    )
    .unwrap();
    probe.energy(&s.x).unwrap().total() + kinetic(sys, s)
}

/// The solver with its fallbacks switched on: the Gauss–Newton Hessian at the same Δt after a
/// failed solve, then up to 8 halvings of Δt.
fn robust(dt: f64) -> ImplicitEuler {
    let mut ie = ImplicitEuler::new(dt);
    ie.fallback_hessian = Some(HessianMode::GaussNewton);
    ie.max_halvings = 8;
    ie
}

/// Runs a dynamic case plainly (no fallbacks), and, if that fails, again with the fallbacks;
/// returns (plain, with fallbacks) outcomes and the final state of the successful run.
fn plain_then_robust(
    name: &str,
    build: &dyn Fn() -> (ShellSystem, State),
    dt: f64,
    steps: usize,
) -> (Outcome, Option<Outcome>, ShellSystem, State) {
    let (mut sys, mut state) = build();
    let plain = drive(&mut ImplicitEuler::new(dt), &mut sys, &mut state, steps);
    println!("{}", plain.line(&format!("{name}, plain")));
    if plain.failure.is_none() {
        return (plain, None, sys, state);
    }
    let (mut sys, mut state) = build();
    let rob = drive(&mut robust(dt), &mut sys, &mut state, steps);
    println!("{}", rob.line(&format!("{name}, with fallbacks")));
    (plain, Some(rob), sys, state)
}

#[test]
fn square_experiments_at_large_time_steps() {
    for name in ["enlarged", "rhombus", "cylinder"] {
        for dt in [1e-3, 1e-2] {
            // The seed's material and (practically zero) viscosity: only implicit Euler's own
            // dissipation damps the motion.
            let build = || {
                let (mesh, rest, x0) = square_experiment(name);
                let m = model(Material::paper(), true);
                let sys = ShellSystem::new(mesh, m, rest, Boundary::default(), Loads::default());
                (sys.unwrap(), State::at_rest(x0))
            };
            let (mut sys0, state0) = build();
            let e0 = total_energy(&mut sys0, &state0);
            let label = format!("square {name}, dt = {dt:e} s, 10 steps");
            let (_, rob, mut sys, state) = plain_then_robust(&label, &build, dt, 10);
            assert!(rob.is_none_or(|o| o.failure.is_none()), "{label}");
            // Backward Euler dissipates: elastic + kinetic energy must not grow.
            let e1 = total_energy(&mut sys, &state);
            println!("  energy {e0:.3e} -> {e1:.3e} J");
            assert!(e1 <= e0 * (1.0 + 1e-9), "{label}: energy grew {e0} -> {e1}");
        }
    }
}
