//! Newton solves of synthetic mass-spring objectives.
#![allow(clippy::unwrap_used)]

mod common;

use common::{chain, chain_equilibrium_z, crumpled_start, rigid_lattice};
use thinshell_solver::{
    Convergence, HessianPolicy, IterationHessian, NewtonSettings, NewtonWorkspace, Objective,
    Ordering, RegularizationParams, SolverError, newton_solve,
};
use thinshell_testkit::rng::Lcg64;

const N: usize = 20;
const M: f64 = 0.1;
const K: f64 = 100.0;
const L: f64 = 1.0;
const G: f64 = 9.81;

/// Max distance of the solved chain from the analytic equilibrium.
fn chain_error(net: &common::SpringNet, x: &[f64]) -> f64 {
    let z = chain_equilibrium_z(N, M, K, L, G);
    net.positions(x)
        .iter()
        .zip(&z)
        .map(|(p, z)| p[0].abs().max(p[1].abs()).max((p[2] - z).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn hanging_chain_reaches_analytic_equilibrium() {
    // Nearly straight start: all springs stretched, Hessian positive definite throughout.
    let start: Vec<[f64; 3]> = (0..=N)
        .map(|i| {
            let t = i as f64;
            [0.1 * t.sin(), 0.1 * (1.0 - t.cos()), -t]
        })
        .collect();
    let mut net = chain(N, M, K, L, G, start.clone());
    let settings = NewtonSettings {
        gradient_tolerance: 1e-11,
        ..Default::default()
    };
    let mut ws = NewtonWorkspace::new(&net, &settings).unwrap();
    let mut x = net.unknowns(&start);
    let report = newton_solve(&mut net, &mut x, &settings, &mut ws).unwrap();
    // Residual 1e-11 · weight over stiffness 100 N/m: position error far below 1e-9 m.
    assert!(
        chain_error(&net, &x) < 1e-9,
        "error {}",
        chain_error(&net, &x)
    );
    assert!(report.regularizations.is_empty());
    assert!(report.iterations < 20, "{} iterations", report.iterations);
    // Quadratic convergence at the end: the last residual is far below the square of the one
    // before (relative to the initial one), i.e. not a linear rate.
    let r = &report.residuals;
    assert!(r[r.len() - 1] < 1e-3 * r[r.len() - 2]);
    assert_eq!(report.convergence, Convergence::Gradient);
}

#[test]
fn crumpled_chain_needs_regularisation_and_converges() {
    let start = crumpled_start(N, 0.3, 7);
    let mut net = chain(N, M, K, L, G, start.clone());
    // Every spring is compressed: the Hessian at the start is indefinite.
    let settings = NewtonSettings {
        max_iterations: 200,
        gradient_tolerance: 1e-10,
        // The shift memory is what this test follows; the watchdog's non-monotone steps take
        // another path to the same minimum (checked at the end).
        watchdog: 0,
        ..Default::default()
    };
    let mut ws = NewtonWorkspace::new(&net, &settings).unwrap();
    let mut x = net.unknowns(&start);
    let report = newton_solve(&mut net, &mut x, &settings, &mut ws).unwrap();
    assert!(!report.regularizations.is_empty());
    assert_eq!(report.regularizations[0].iteration, 0);
    // The first shift is found by growing μ from an unshifted failure; later iterations start
    // from the remembered (shrunk) shift.
    assert!(report.regularizations[0].attempts >= 2);
    assert!(
        report
            .regularizations
            .iter()
            .all(|e| e.mu > 0.0 && e.max_shift > 0.0)
    );
    // μ shrinks after successes: the solve ends unshifted (quadratic convergence near the
    // minimum, where the Hessian is positive definite).
    let last_reg = report.regularizations.last().unwrap().iteration;
    assert!(last_reg + 1 < report.iterations);
    assert_eq!(ws.regularization_memory(), 0.0);
    assert!(
        chain_error(&net, &x) < 1e-8,
        "error {}",
        chain_error(&net, &x)
    );
    // The same start without regularisation is rejected with a typed error.
    let plain = NewtonSettings {
        regularization: None,
        ..settings
    };
    let mut x = net.unknowns(&start);
    match newton_solve(&mut net, &mut x, &plain, &mut ws) {
        Err(SolverError::NotPositiveDefinite { iteration: 0, .. }) => {}
        other => panic!("expected NotPositiveDefinite, got {other:?}"),
    }
    // x is untouched: no step was taken.
    assert_eq!(x, net.unknowns(&start));
    // The default (with the watchdog) reaches the same minimum.
    let default = NewtonSettings {
        max_iterations: 200,
        gradient_tolerance: 1e-10,
        ..Default::default()
    };
    let mut x = net.unknowns(&start);
    newton_solve(&mut net, &mut x, &default, &mut ws).unwrap();
    assert!(chain_error(&net, &x) < 1e-8, "{}", chain_error(&net, &x));
}

#[test]
fn line_search_never_increases_the_objective() {
    for seed in [1, 2, 3, 4] {
        let start = crumpled_start(N, 0.5, seed);
        let mut net = chain(N, M, K, L, G, start.clone());
        let settings = NewtonSettings {
            max_iterations: 200,
            ..Default::default()
        };
        let mut ws = NewtonWorkspace::new(&net, &settings).unwrap();
        let mut x = net.unknowns(&start);
        let report = newton_solve(&mut net, &mut x, &settings, &mut ws).unwrap();
        assert!(
            report.backtracks > 0,
            "seed {seed}: line search never backtracked"
        );
        // Non-increasing up to round-off once the predicted decrease drops below it, except
        // right after a watchdog step, which must be recovered within its window.
        assert_eq!(
            report.descent_violation(settings.watchdog),
            None,
            "seed {seed}: values {:?}",
            report.values
        );
        assert_eq!(report.values.len(), report.iterations + 1);
        assert_eq!(report.residuals.len(), report.iterations + 1);
        // The values are the objective at the iterates: check the last one independently.
        let last = *report.values.last().unwrap();
        assert_eq!(net.value(&x).unwrap(), last);
    }
}

#[test]
fn non_convergence_returns_history_and_last_good_state() {
    let start = crumpled_start(N, 0.3, 11);
    let mut net = chain(N, M, K, L, G, start.clone());
    let settings = NewtonSettings {
        max_iterations: 1,
        ..Default::default()
    };
    let mut ws = NewtonWorkspace::new(&net, &settings).unwrap();
    let mut x = net.unknowns(&start);
    let f0 = net.value(&x).unwrap();
    match newton_solve(&mut net, &mut x, &settings, &mut ws) {
        Err(SolverError::NewtonDidNotConverge {
            residuals,
            iterations,
            tolerance,
            last_good,
            ..
        }) => {
            assert_eq!(iterations, 1);
            assert_eq!(residuals.len(), 2);
            assert!(residuals[1] > tolerance);
            assert_eq!(last_good, x);
            assert!(last_good.iter().all(|v| v.is_finite()));
            assert!(net.value(&last_good).unwrap() < f0);
            let mut g = vec![0.0; net.n_dofs()];
            net.gradient(&last_good, &mut g).unwrap();
            let r = g.iter().fold(0.0f64, |m, v| m.max(v.abs())) / net.force_scale();
            assert!((r - residuals[1]).abs() <= 1e-15 * r);
        }
        other => panic!("expected NewtonDidNotConverge, got {other:?}"),
    }
}

#[test]
fn rigid_lattice_returns_to_zero_energy_with_both_orderings() {
    let (mut net, reference) = rigid_lattice(4, 50.0);
    let mut rng = Lcg64::new(3);
    let start: Vec<[f64; 3]> = reference
        .iter()
        .map(|p| {
            [
                p[0] + 0.1 * rng.signed(),
                p[1] + 0.1 * rng.signed(),
                p[2] + 0.1 * rng.signed(),
            ]
        })
        .collect();
    let mut solutions = Vec::new();
    for ordering in [
        Ordering::Amd,
        Ordering::NestedDissection,
        Ordering::Metis,
        Ordering::Auto,
    ] {
        let settings = NewtonSettings {
            ordering,
            gradient_tolerance: 1e-12,
            ..Default::default()
        };
        let mut ws = NewtonWorkspace::new(&net, &settings).unwrap();
        assert_ne!(ws.factor_stats().ordering, Ordering::Auto);
        let mut x = net.unknowns(&start);
        newton_solve(&mut net, &mut x, &settings, &mut ws).unwrap();
        let err = net
            .positions(&x)
            .iter()
            .zip(&reference)
            .map(|(p, q)| (0..3).map(|i| (p[i] - q[i]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "{ordering:?}: distance to reference {err}");
        assert!(net.value(&x).unwrap() < 1e-20);
        solutions.push(x);
    }
    for s in &solutions[1..] {
        let d = s
            .iter()
            .zip(&solutions[0])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(d < 1e-10);
    }
}

#[test]
fn workspace_is_reused_across_solves() {
    // Solves from different starts with one workspace (one symbolic analysis, remembered
    // regularisation shift) reach the same equilibrium as with fresh workspaces.
    let settings = NewtonSettings::default();
    let starts = [crumpled_start(N, 0.3, 5), crumpled_start(N, 0.4, 6)];
    let mut net = chain(N, M, K, L, G, starts[0].clone());
    let mut shared = NewtonWorkspace::new(&net, &settings).unwrap();
    for s in &starts {
        let mut x_shared = net.unknowns(s);
        let mut x_fresh = x_shared.clone();
        let mut fresh = NewtonWorkspace::new(&net, &settings).unwrap();
        newton_solve(&mut net, &mut x_shared, &settings, &mut shared).unwrap();
        newton_solve(&mut net, &mut x_fresh, &settings, &mut fresh).unwrap();
        assert!(chain_error(&net, &x_shared) < 1e-7);
        assert!(chain_error(&net, &x_fresh) < 1e-7);
    }
}

#[test]
fn invalid_settings_are_rejected_by_name() {
    let d = NewtonSettings::default();
    let cases: Vec<(&str, NewtonSettings)> = vec![
        (
            "max_iterations",
            NewtonSettings {
                max_iterations: 0,
                ..d
            },
        ),
        (
            "gradient_tolerance",
            NewtonSettings {
                gradient_tolerance: 0.0,
                ..d
            },
        ),
        (
            "gradient_tolerance",
            NewtonSettings {
                gradient_tolerance: f64::NAN,
                ..d
            },
        ),
        (
            "step_tolerance",
            NewtonSettings {
                step_tolerance: -1.0,
                ..d
            },
        ),
        (
            "armijo_c1",
            NewtonSettings {
                armijo_c1: 1.0,
                ..d
            },
        ),
        (
            "backtrack_factor",
            NewtonSettings {
                backtrack_factor: 1.5,
                ..d
            },
        ),
        (
            "regularization_initial",
            NewtonSettings {
                regularization: Some(RegularizationParams {
                    initial: 0.0,
                    ..RegularizationParams::default()
                }),
                ..d
            },
        ),
        (
            "regularization_growth",
            NewtonSettings {
                regularization: Some(RegularizationParams {
                    growth: 1.0,
                    ..RegularizationParams::default()
                }),
                ..d
            },
        ),
        (
            "regularization_shrink",
            NewtonSettings {
                regularization: Some(RegularizationParams {
                    shrink: 1.0,
                    ..RegularizationParams::default()
                }),
                ..d
            },
        ),
        (
            "regularization_max_attempts",
            NewtonSettings {
                regularization: Some(RegularizationParams {
                    max_attempts: 0,
                    ..RegularizationParams::default()
                }),
                ..d
            },
        ),
    ];
    let start = crumpled_start(3, 0.3, 1);
    let mut net = chain(3, M, K, L, G, start.clone());
    let mut ws = NewtonWorkspace::new(&net, &d).unwrap();
    for (name, s) in cases {
        match s.validate() {
            Err(SolverError::InvalidSetting { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{name}: expected InvalidSetting, got {other:?}"),
        }
        let mut x = net.unknowns(&start);
        assert!(matches!(
            newton_solve(&mut net, &mut x, &s, &mut ws),
            Err(SolverError::InvalidSetting { .. })
        ));
        assert!(NewtonWorkspace::new(&net, &s).is_err());
    }
    assert!(d.validate().is_ok());
}

/// Wraps an objective and poisons one gradient entry.
struct Poisoned<O>(O, usize);

impl<O: Objective> Objective for Poisoned<O> {
    fn n_dofs(&self) -> usize {
        self.0.n_dofs()
    }
    fn value(&mut self, x: &[f64]) -> Result<f64, SolverError> {
        self.0.value(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        let f = self.0.gradient(x, g)?;
        g[self.1] = f64::NAN;
        Ok(f)
    }
    fn hessian(
        &mut self,
        x: &[f64],
        h: &mut faer::sparse::SparseColMat<usize, f64>,
    ) -> Result<(), SolverError> {
        self.0.hessian(x, h)
    }
    fn hessian_template(&self) -> faer::sparse::SparseColMat<usize, f64> {
        self.0.hessian_template()
    }
    fn force_scale(&self) -> f64 {
        self.0.force_scale()
    }
}

#[test]
fn non_finite_gradient_and_bad_inputs_are_typed_errors() {
    let start = crumpled_start(4, 0.3, 2);
    let net = chain(4, M, K, L, G, start.clone());
    let x0 = net.unknowns(&start);
    let mut poisoned = Poisoned(net, 5);
    let settings = NewtonSettings::default();
    let mut ws = NewtonWorkspace::new(&poisoned, &settings).unwrap();
    let mut x = x0.clone();
    assert_eq!(
        newton_solve(&mut poisoned, &mut x, &settings, &mut ws),
        Err(SolverError::NonFinite {
            what: "gradient",
            iteration: 0,
            dof: Some(5)
        })
    );
    let mut net = poisoned.0;
    let mut short = vec![0.0; x0.len() - 1];
    assert!(matches!(
        newton_solve(&mut net, &mut short, &settings, &mut ws),
        Err(SolverError::DimensionMismatch { what: "x", .. })
    ));
    net.force_scale = 0.0;
    let mut x = x0;
    assert_eq!(
        newton_solve(&mut net, &mut x, &settings, &mut ws),
        Err(SolverError::InvalidForceScale(0.0))
    );
}

#[test]
fn unreachable_gradient_tolerance_stops_on_the_step_criterion() {
    // 1e-30 · weight is far below the gradient's round-off floor: the solve must end on the
    // step criterion (Newton correction below 1e-12 · L) instead of failing.
    let start: Vec<[f64; 3]> = (0..=N)
        .map(|i| [0.05 * (i as f64).sqrt(), 0.0, -(i as f64)])
        .collect();
    let mut net = chain(N, M, K, L, G, start.clone());
    let settings = NewtonSettings {
        gradient_tolerance: 1e-30,
        ..Default::default()
    };
    let mut ws = NewtonWorkspace::new(&net, &settings).unwrap();
    let mut x = net.unknowns(&start);
    let report = newton_solve(&mut net, &mut x, &settings, &mut ws).unwrap();
    assert_eq!(report.convergence, Convergence::Step);
    assert!(
        chain_error(&net, &x) < 1e-10,
        "error {}",
        chain_error(&net, &x)
    );
}

#[test]
fn adaptive_policy_without_a_psd_hessian_is_the_fixed_one() {
    let start = crumpled_start(N, 0.3, 7);
    let settings = NewtonSettings {
        max_iterations: 200,
        gradient_tolerance: 1e-10,
        ..Default::default()
    };
    assert_eq!(settings.hessian, HessianPolicy::Adaptive);
    // Without a PSD Hessian the adaptive policy is the fixed one, step for step.
    let mut net = chain(N, M, K, L, G, start.clone());
    let mut ws = NewtonWorkspace::new(&net, &settings).unwrap();
    let mut xa = net.unknowns(&start);
    let ra = newton_solve(&mut net, &mut xa, &settings, &mut ws).unwrap();
    let fixed = NewtonSettings {
        hessian: HessianPolicy::Fixed,
        ..settings
    };
    let mut xf = net.unknowns(&start);
    let mut ws = NewtonWorkspace::new(&net, &fixed).unwrap();
    let rf = newton_solve(&mut net, &mut xf, &fixed, &mut ws).unwrap();
    assert_eq!(xa, xf);
    assert_eq!(ra.iterations, rf.iterations);
    assert!(ra.hessians.iter().all(|h| *h == IterationHessian::Own));
    assert_eq!(ra.failed_factorizations, 0);
    assert_eq!(ra.hessians.len(), ra.iterations);
    assert!(chain_error(&net, &xa) < 1e-8, "{}", chain_error(&net, &xa));
}
