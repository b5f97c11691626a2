//! Path following (arc length, displacement control) on a two-bar (von Mises) truss whose
//! apex is loaded through a soft spring: a 2-dof problem with a closed-form equilibrium path
//! that has a load limit point (snap-through) and, in the loaded point's displacement, a
//! snap-back. Every traced point must lie on the closed-form path within 1e-6.

use faer::sparse::{SparseColMat, Triplet};
use thinshell_solver::{
    LoadedObjective, Objective, PathControl, PathSettings, PathTracer, SolverError,
};

/// Two bars from (±A, 0) to the apex (0, H − v), Green strain ε = (L² − L₀²)/(2L₀²), energy
/// `EA·L₀·ε²` for the pair; a spring of stiffness K from the apex to the loaded point w; load
/// λ·P downwards at w. Unknowns u = (v, w) (m, downwards).
struct SpringTruss {
    lambda: f64,
}

const A: f64 = 1.0;
const H: f64 = 0.2;
const EA: f64 = 1.0;
const K: f64 = 0.01;
const P: f64 = 1e-3;

fn l0() -> f64 {
    (A * A + H * H).sqrt()
}
fn strain(v: f64) -> f64 {
    (v * v - 2.0 * H * v) / (2.0 * l0() * l0())
}
/// dε/dv.
fn strain_d(v: f64) -> f64 {
    (v - H) / (l0() * l0())
}
/// Truss force on the apex (N, downwards positive resists): dE_truss/dv.
fn truss_force(v: f64) -> f64 {
    2.0 * EA * l0() * strain(v) * strain_d(v)
}
/// d²E_truss/dv².
fn truss_stiffness(v: f64) -> f64 {
    2.0 * EA * l0() * (strain_d(v).powi(2) + strain(v) / (l0() * l0()))
}

/// The closed-form path parametrised by the apex deflection v: (w, λ).
fn exact(v: f64) -> (f64, f64) {
    let f = truss_force(v);
    (v + f / K, f / P)
}

impl Objective for SpringTruss {
    fn n_dofs(&self) -> usize {
        2
    }
    fn value(&mut self, u: &[f64]) -> Result<f64, SolverError> {
        let (v, w) = (u[0], u[1]);
        Ok(EA * l0() * strain(v).powi(2) + 0.5 * K * (w - v).powi(2) - self.lambda * P * w)
    }
    fn gradient(&mut self, u: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        let (v, w) = (u[0], u[1]);
        g[0] = truss_force(v) - K * (w - v);
        g[1] = K * (w - v) - self.lambda * P;
        self.value(u)
    }
    fn hessian(&mut self, u: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
        // Column-major lower triangle: (0,0), (1,0), (1,1).
        let val = h.val_mut();
        val[0] = truss_stiffness(u[0]) + K;
        val[1] = -K;
        val[2] = K;
        Ok(())
    }
    fn hessian_template(&self) -> SparseColMat<usize, f64> {
        let t = [
            Triplet::new(0, 0, 0.0),
            Triplet::new(1, 0, 0.0),
            Triplet::new(1, 1, 0.0),
        ];
        SparseColMat::try_new_from_triplets(2, 2, &t).expect("valid 2x2 pattern")
    }
    fn force_scale(&self) -> f64 {
        P
    }
    fn length_scale(&self) -> f64 {
        H
    }
}

impl LoadedObjective for SpringTruss {
    fn load_factor(&self) -> f64 {
        self.lambda
    }
    fn set_load_factor(&mut self, lambda: f64) -> Result<(), SolverError> {
        self.lambda = lambda;
        Ok(())
    }
    fn load_vector(&mut self, _u: &[f64], q: &mut [f64]) -> Result<(), SolverError> {
        q[0] = 0.0;
        q[1] = P;
        Ok(())
    }
}

/// Traced points (v, w, λ, negative eigenvalues) until the apex passes `v_end`.
fn trace(settings: PathSettings, v_end: f64) -> Vec<(f64, f64, f64, Option<usize>)> {
    let mut truss = SpringTruss { lambda: 0.0 };
    let mut u = vec![0.0, 0.0];
    let mut tracer = PathTracer::new(settings);
    let mut points = Vec::new();
    for _ in 0..2000 {
        let p = tracer.step(&mut truss, &mut u).expect("path step");
        assert_eq!(p.load_factor, truss.lambda);
        points.push((u[0], u[1], p.load_factor, p.negative_eigenvalues));
        if u[0] > v_end {
            return points;
        }
    }
    panic!("path did not reach v = {v_end} in 2000 steps");
}

/// Closed-form extremes of λ(v) on [0, 2H] by bisection on dλ/dv = F'(v)/P = 0.
fn limit_points() -> (f64, f64) {
    let root = |mut a: f64, mut b: f64| {
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if truss_stiffness(a).signum() == truss_stiffness(m).signum() {
                a = m;
            } else {
                b = m;
            }
        }
        0.5 * (a + b)
    };
    (root(0.0, H), root(H, 2.0 * H))
}

fn check_on_path(points: &[(f64, f64, f64, Option<usize>)]) {
    let (v1, _) = limit_points();
    let lambda_max = exact(v1).1;
    for &(v, w, lambda, negative) in points {
        let (w_exact, l_exact) = exact(v);
        // Within 1e-6 of the closed-form path: λ relative to λ_max, w relative to H.
        assert!(
            (lambda - l_exact).abs() <= 1e-6 * lambda_max,
            "v = {v}: λ {lambda} vs exact {l_exact}"
        );
        assert!(
            (w - w_exact).abs() <= 1e-6 * H,
            "v = {v}: w {w} vs exact {w_exact}"
        );
        // Stability at fixed load: det of [[F' + K, −K], [−K, K]] is K·F'(v), so exactly one
        // negative eigenvalue where the truss is softening (F' < 0), none where F' > 0
        // (points within 1e-9 of a limit point are not classified).
        let fp = truss_stiffness(v);
        if fp.abs() > 1e-9 {
            assert_eq!(negative, Some(usize::from(fp < 0.0)), "v = {v}, F' = {fp}");
        }
    }
}

/// Count of sign changes in the increments of a sequence (turning points).
fn turns(values: impl Iterator<Item = f64>) -> usize {
    let v: Vec<f64> = values.collect();
    let d: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).collect();
    d.windows(2).filter(|w| w[0] * w[1] < 0.0).count()
}

#[test]
fn arc_length_traces_limit_points_and_snap_back_on_the_closed_form_path() {
    for psi in [None, Some(0.0)] {
        let settings = PathSettings {
            control: PathControl::ArcLength { psi },
            initial_load_increment: 0.05,
            // Small steps, to resolve the extremes of λ to 2 %.
            max_step_ratio: 1.0,
            ..PathSettings::default()
        };
        let points = trace(settings, 2.2 * H);
        check_on_path(&points);
        let (v1, v2) = limit_points();
        let (l_max, l_min) = (exact(v1).1, exact(v2).1);
        // Through the limit point and back: λ rises to λ_max, falls below 0 to λ_min (the
        // second limit point), and rises again — two turns in λ; the loaded point's
        // displacement w turns back twice (the snap-back) — while the apex moves on.
        assert_eq!(turns(points.iter().map(|p| p.2)), 2, "psi {psi:?}");
        assert_eq!(turns(points.iter().map(|p| p.1)), 2, "psi {psi:?}");
        assert_eq!(turns(points.iter().map(|p| p.0)), 0, "psi {psi:?}");
        // The largest λ before the truss has inverted (beyond v = 2H it rises without bound).
        let traced_max = points
            .iter()
            .filter(|p| p.0 < 2.0 * H)
            .map(|p| p.2)
            .fold(f64::MIN, f64::max);
        let traced_min = points.iter().map(|p| p.2).fold(f64::MAX, f64::min);
        eprintln!(
            "psi {psi:?}: {} points, max {traced_max} of {l_max}, min {traced_min} of {l_min}",
            points.len()
        );
        assert!(traced_max > 0.98 * l_max && traced_max <= l_max * (1.0 + 1e-9));
        assert!(traced_min < 0.98 * l_min && traced_min >= l_min * (1.0 + 1e-9));
        assert!(
            points.iter().any(|p| p.3 == Some(1)),
            "unstable branch reached"
        );
    }
}

#[test]
fn displacement_control_of_the_apex_traces_the_whole_path() {
    let settings = PathSettings {
        control: PathControl::Displacement { dof: 0 },
        initial_step: Some(0.01 * H),
        ..PathSettings::default()
    };
    let points = trace(settings, 2.2 * H);
    check_on_path(&points);
    // The apex is prescribed: it only moves forward, while λ passes both limit points.
    assert_eq!(turns(points.iter().map(|p| p.0)), 0);
    assert_eq!(turns(points.iter().map(|p| p.2)), 2);
}

#[test]
fn displacement_control_from_the_load_increment_moves_with_the_load() {
    let settings = PathSettings {
        control: PathControl::Displacement { dof: 1 },
        initial_load_increment: 0.05,
        ..PathSettings::default()
    };
    let mut truss = SpringTruss { lambda: 0.0 };
    let mut u = vec![0.0, 0.0];
    let mut tracer = PathTracer::new(settings);
    let p = tracer.step(&mut truss, &mut u).expect("first step");
    assert!(p.load_factor > 0.0 && u[1] > 0.0);
    let (w, l) = exact(u[0]);
    assert!((u[1] - w).abs() < 1e-6 * H && (p.load_factor - l).abs() < 1e-6 * l);
}

#[test]
fn bad_settings_and_failures_are_errors_not_panics() {
    let mut truss = SpringTruss { lambda: 0.0 };
    let mut u = vec![0.0, 0.0];
    for (settings, name) in [
        (
            PathSettings {
                tolerance: 0.0,
                ..PathSettings::default()
            },
            "tolerance",
        ),
        (
            PathSettings {
                control: PathControl::ArcLength { psi: Some(-1.0) },
                ..PathSettings::default()
            },
            "psi",
        ),
        (
            PathSettings {
                direction: 0.5,
                ..PathSettings::default()
            },
            "direction",
        ),
        (
            PathSettings {
                control: PathControl::Displacement { dof: 7 },
                ..PathSettings::default()
            },
            "control.dof",
        ),
    ] {
        let err = PathTracer::new(settings)
            .step(&mut truss, &mut u)
            .expect_err(name);
        assert!(
            matches!(err, SolverError::InvalidSetting { name: n, .. } if n == name),
            "{name}: {err}"
        );
    }
    let err = PathTracer::new(PathSettings::default())
        .step(&mut truss, &mut [0.0])
        .expect_err("wrong length");
    assert!(matches!(err, SolverError::DimensionMismatch { .. }));

    // One Newton correction and no cut-back allowed, with a step far into the nonlinear
    // range: the step fails with its residual history, and the point is unchanged.
    let settings = PathSettings {
        initial_step: Some(H),
        max_iterations: 1,
        max_cutbacks: 0,
        ..PathSettings::default()
    };
    let mut tracer = PathTracer::new(settings);
    let err = tracer.step(&mut truss, &mut u).expect_err("must fail");
    match err {
        SolverError::PathFailed(f) => {
            assert_eq!(f.step, 1);
            assert!(!f.residuals.is_empty() && f.residuals.iter().all(|r| r.is_finite()));
            assert_eq!(f.last_good, vec![0.0, 0.0]);
            assert!(
                f.reason.contains("no convergence in 1 iterations"),
                "{}",
                f.reason
            );
        }
        e => panic!("unexpected error {e}"),
    }
    assert_eq!(u, vec![0.0, 0.0]);
    assert_eq!(truss.lambda, 0.0);
}

/// Displacement control of the loaded point w cannot pass its snap-back: it traces the path
/// up to the turning point of w (on the closed form within 1e-6) and then fails with
/// `PathFailed` instead of jumping to the far branch.
#[test]
fn displacement_control_stops_at_a_snap_back_of_the_controlled_dof() {
    // The closed-form turning point of w(v) = v + F(v)/K: dw/dv = 1 + F'(v)/K = 0.
    let dw = |v: f64| 1.0 + truss_stiffness(v) / K;
    let (mut a, mut b) = (0.0, H);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if dw(m) > 0.0 {
            a = m;
        } else {
            b = m;
        }
    }
    let w_turn = exact(0.5 * (a + b)).0;
    let settings = PathSettings {
        control: PathControl::Displacement { dof: 1 },
        initial_step: Some(0.01 * H),
        max_step_ratio: 1.0,
        ..PathSettings::default()
    };
    let mut truss = SpringTruss { lambda: 0.0 };
    let mut u = vec![0.0, 0.0];
    let mut tracer = PathTracer::new(settings);
    let mut points = Vec::new();
    let err = loop {
        match tracer.step(&mut truss, &mut u) {
            Ok(p) => points.push((u[0], u[1], p.load_factor, p.negative_eigenvalues)),
            Err(e) => break e,
        }
        assert!(points.len() < 1000, "no failure");
    };
    check_on_path(&points);
    let SolverError::PathFailed(f) = err else {
        panic!("unexpected error {err}")
    };
    // Its last attempts either jump (refused) or find no solution near the turning point.
    assert!(
        f.reason.contains("snap-back") || f.reason.contains("no convergence"),
        "{}",
        f.reason
    );
    // It stopped just before the turning point, never beyond it.
    let w_last = points.last().map(|p| p.1).unwrap_or(0.0);
    assert!(
        w_last <= w_turn && w_last > w_turn - 1e-3 * H,
        "{w_last} vs {w_turn}"
    );
    assert_eq!(turns(points.iter().map(|p| p.0)), 0);
}
