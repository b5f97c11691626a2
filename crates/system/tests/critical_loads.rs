//! Critical loads from the stability report — the smallest eigenvalue of the exact,
//! unshifted Hessian at the pre-buckling equilibrium ([`Static::stability`]) crosses zero at the
//! critical load — with the default form and default settings, against analytic values.
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use thinshell_solver::{Integrator, Stability, State, Static};
use thinshell_system::ShellSystem;
use thinshell_testkit::fixtures::{compressed_plate, pressurised_tube};

const LENGTH: f64 = 1.0;
const WIDTH: f64 = 0.05;
const THICKNESS: f64 = 0.002;
const YOUNG: f64 = 1e9;

/// Euler's load of the pinned–pinned strut, π²EI/L² with I = b h³/12 (ν = 0, so that the
/// strip's bending stiffness D·b equals EI whatever its width).
fn euler_load() -> f64 {
    std::f64::consts::PI.powi(2) * YOUNG * WIDTH * THICKNESS.powi(3) / 12.0 / LENGTH.powi(2)
}

/// A flat rectangle `length × width` along x (`nx × ny` cells) under the axial end load `p`
/// (N, compressive, on the x = `length` edge), both ends held in z (free to rotate about
/// them), the x = 0 end also in x, one corner in y; `sides`: the long edges held in z too
/// (a plate simply supported on all four edges). Returns the stability of its flat
/// equilibrium.
fn compressed_stability(
    length: f64,
    width: f64,
    nx: usize,
    ny: usize,
    poisson: f64,
    sides: bool,
    p: f64,
) -> Stability {
    let (sys, x0) = compressed_plate(
        length, width, nx, ny, THICKNESS, YOUNG, poisson, sides, p, 0.0,
    );
    flat_stability(sys, x0)
}

/// The stability of the flat equilibrium of `sys` (asserted flat and fully supported).
fn flat_stability(sys: ShellSystem, x0: Vec<Vector3<f64>>) -> Stability {
    fundamental_stability(sys, x0, |x: &[Vector3<f64>]| {
        let lateral = x.iter().fold(0.0f64, |m, x| m.max(x.z.abs()));
        assert!(lateral < 1e-9, "the plate left the flat state: {lateral} m");
    })
}

/// The stability of the fundamental equilibrium of `sys` reached from `x0` with saddles kept
/// (`check` asserts the solution is still on the fundamental path).
fn fundamental_stability(
    mut sys: ShellSystem,
    x0: Vec<Vector3<f64>>,
    check: impl Fn(&[Vector3<f64>]),
) -> Stability {
    let mut state = State::at_rest(x0);
    // The flat (fundamental) equilibrium also past the critical load: that is the state
    // whose stability brackets the critical load, so it is kept even where it is a saddle.
    let mut solver = Static::default();
    solver.newton.escape_saddles = false;
    let report = solver.step(&mut sys, &mut state).unwrap();
    check(&state.x);
    let stability = report.stability.unwrap();
    assert_eq!(
        stability.rigid_modes, 0,
        "the supports hold every rigid motion"
    );
    assert_eq!(report.stable, Some(stability.stable));
    stability
}

/// The strut: a strip 1 m × 5 cm, ν = 0, pinned–pinned.
fn strut_stability(nx: usize, ny: usize, p: f64) -> Stability {
    compressed_stability(LENGTH, WIDTH, nx, ny, 0.0, false, p)
}

/// The load where the smallest eigenvalue crosses zero, interpolated between `lo` and `hi`
/// times Euler's load.
fn critical_load(stability: impl Fn(f64) -> Stability, p_ref: f64, lo: f64, hi: f64) -> f64 {
    let a = stability(lo * p_ref).min_eigenvalue;
    let b = stability(hi * p_ref).min_eigenvalue;
    assert!(
        a > 0.0 && b < 0.0,
        "no sign change: {a:e} at {lo}, {b:e} at {hi}"
    );
    p_ref * (lo + (hi - lo) * a / (a - b))
}

/// Asserts refinement errors (absolute, four levels halving h) that fall at every level, end
/// below `finest` and have a mean observed order `log2(e0/e3)/3` above `order`.
fn assert_converges(errors: &[f64], finest: f64, order: f64) {
    let orders: Vec<f64> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
    let mean_order = (errors[0] / errors[3]).log2() / 3.0;
    println!("observed orders {orders:.2?}, mean {mean_order:.2}");
    assert!(errors.windows(2).all(|e| e[1] < e[0]), "{errors:?}");
    assert!(errors[3] < finest, "{errors:?}");
    assert!(mean_order > order, "{orders:?}, mean {mean_order}");
}

#[test]
fn euler_strut_critical_load_converges_under_refinement() {
    let p_e = euler_load();
    let mut errors = Vec::new();
    for (nx, ny) in [(16, 1), (32, 2), (64, 4), (128, 8)] {
        let p = critical_load(|p| strut_stability(nx, ny, p), p_e, 0.98, 1.02);
        let err = p / p_e - 1.0;
        println!("strut {nx} x {ny}: P_cr = {p:.6e} N (Euler {p_e:.6e} N), error {err:+.3e}");
        errors.push(err.abs());
    }
    // With the fitted free edges (model.md §1.2) the error does not fall at a steady rate:
    // observed (2026-12-02) −6.27e-3, −8.43e-4, −2.62e-4, −7.43e-5 (orders 2.89, 1.69, 1.82;
    // mean 2.13). The assertions: the error falls at every refinement, the finest is
    // below 1e-3, and the mean order over the four levels, log2(e0/e3)/3, is above 1.8.
    assert_converges(&errors, 1e-3, 1.8);
    // Bracketed within 1 %: stable just below Euler's load, unstable just above.
    let below = strut_stability(32, 2, 0.99 * p_e);
    let above = strut_stability(32, 2, 1.01 * p_e);
    assert!(
        below.stable && !above.stable,
        "{} {}",
        below.min_eigenvalue,
        above.min_eigenvalue
    );
}

#[test]
fn simply_supported_plate_critical_compression_converges_under_refinement() {
    // A square plate a = 0.2 m, h = 2 mm, ν = 0.3, simply supported on its four edges, the
    // loaded edge free to move in x and the sides free in plane: uniaxial N_x = P/a until it
    // buckles into one half wave each way at N_cr = 4π²D/a² (Timoshenko & Gere §9.2).
    let a = 0.2;
    let nu = 0.3;
    let d = YOUNG * THICKNESS.powi(3) / (12.0 * (1.0 - nu * nu));
    let p_ref = 4.0 * std::f64::consts::PI.powi(2) * d / (a * a) * a;
    let mut errors = Vec::new();
    for n in [8, 16, 32, 64] {
        let p = critical_load(
            |p| compressed_stability(a, a, n, n, nu, true, p),
            p_ref,
            0.9,
            1.1,
        );
        let err = p / p_ref - 1.0;
        println!("plate {n} x {n}: P_cr = {p:.6e} N (4π²D/a²·a = {p_ref:.6e} N), error {err:+.3e}");
        errors.push(err.abs());
    }
    // With the fitted boundary edges (model.md §1.2: a simply supported edge, free to
    // rotate, is fitted like a free one) the rate is irregular: observed (2026-12-02)
    // −3.75e-2, −1.45e-2, −3.96e-3, −1.35e-3 (orders 1.38, 1.87, 1.56; mean 1.60). The
    // assertions: the error falls at every refinement, the finest is below 3e-3, and the mean
    // order over the four levels, log2(e0/e3)/3, is above 1.5.
    assert_converges(&errors, 3e-3, 1.5);
}

#[test]
fn deflection_near_the_critical_load_is_linear_in_a_tiny_imperfection() {
    // Issue #26: the simply supported plate of the test above (32 × 32) at 0.9 and 0.96 of
    // N_cr with a centre force of 1e-9 N and 1e-6 N. Below the critical load the response is
    // linear in the force, so the two deflections differ by the factor 1000; a solve that
    // stopped on a round-off test before it had converged along the soft buckling mode
    // returned a deflection 4× and 14× too small at 1e-9 N. Tolerance 3 %: the solve's step
    // tolerance, 1e-12 of the plate's size (2e-13 m), is 1.3 % of the 1.5e-11 m deflection at
    // 1e-9 N (measured 2026-12-02: ratios 1005 and 1016).
    let (a, nu, n) = (0.2, 0.3, 32);
    let d = YOUNG * THICKNESS.powi(3) / (12.0 * (1.0 - nu * nu));
    let p_cr = 4.0 * std::f64::consts::PI.powi(2) * d / (a * a) * a;
    for ratio in [0.9, 0.96] {
        let deflection = |f: f64| {
            let (mut sys, x0) =
                compressed_plate(a, a, n, n, THICKNESS, YOUNG, nu, true, ratio * p_cr, f);
            let mut state = State::at_rest(x0);
            let report = Static::default().step(&mut sys, &mut state).unwrap();
            assert_eq!(report.stable, Some(true));
            state.x.iter().fold(0.0f64, |m, x| m.max(x.z.abs()))
        };
        let (small, large) = (deflection(1e-9), deflection(1e-6));
        let scale = large / small;
        println!(
            "P = {ratio} P_cr: w(1e-9 N) = {small:.4e} m, w(1e-6 N) = {large:.4e} m, ratio {scale:.2}"
        );
        assert!((scale / 1000.0 - 1.0).abs() < 0.03, "{scale}");
    }
}

#[test]
fn tube_critical_pressure_converges_under_refinement() {
    // A tube, R = 0.1 m, h = 1 mm, in plane strain (every vertex held along the axis) under
    // external pressure that stays normal to the surface: the ring buckles into two lobes at
    // p_cr = 3D/R³ (a long tube's value). ν = 0, as for the strut: with ν ≠ 0 the free ends of a
    // short tube carry an anticlastic boundary layer (~√(Rh) wide) that lowers the buckling
    // pressure towards E h³/(4R³) — physics of a short tube, not the long tube's number.
    let (r, h): (f64, f64) = (0.1, 1e-3);
    let d = YOUNG * h.powi(3) / 12.0;
    let p_ref = 3.0 * d / r.powi(3);
    let stability = |n: usize, p: f64| {
        let (sys, x0) = pressurised_tube(r, n, 2, h, YOUNG, 0.0, p, 0.0);
        fundamental_stability(sys, x0, |x: &[Vector3<f64>]| {
            // Still round: every radius within 1e-4 R of the mean (the uniform compression is
            // 2.75e-5 R at p_cr; two lobes would differ by a good part of R).
            let radii: Vec<f64> = x.iter().map(|x| x.x.hypot(x.y)).collect();
            let mean = radii.iter().sum::<f64>() / radii.len() as f64;
            let spread = radii.iter().fold(0.0f64, |m, q| m.max((q - mean).abs()));
            assert!(
                spread < 1e-4 * r,
                "the tube left the round state: {spread} m"
            );
        })
    };
    let mut errors = Vec::new();
    for n in [16, 32, 64, 128] {
        let p = critical_load(|p| stability(n, p), p_ref, 0.97, 1.01);
        let err = p / p_ref - 1.0;
        println!("tube {n} around: p_cr = {p:.6e} Pa (3D/R³ = {p_ref:.6e} Pa), error {err:+.3e}");
        errors.push(err.abs());
    }
    // Observed (2026-12-02): −3.6e-3, −1.5e-3, −4.3e-4, −1.3e-4 from below (orders about 1.3,
    // 1.8, 1.7). The assertions: the error falls at every refinement, the finest is below 1e-3,
    // and the mean order over the four levels is above 1.3.
    assert_converges(&errors, 1e-3, 1.3);
    // Bracketed within 3 % on the finer mesh: stable below, unstable above.
    let (below, above) = (stability(64, 0.97 * p_ref), stability(64, 1.03 * p_ref));
    assert!(
        below.stable && !above.stable,
        "{} {}",
        below.min_eigenvalue,
        above.min_eigenvalue
    );
}

#[test]
fn static_solves_just_past_critical_loads_leave_the_saddle_by_default() {
    use thinshell_solver::IterationHessian;
    // Issue #26 item 3: from the perfect, unbuckled start just past the critical load the
    // Newton iterates stay on the fundamental state (the gradient has no component along the
    // buckling mode), which is a saddle there. `Static::default()` leaves it along the
    // stability report's mode and ends on the buckled, stable branch.
    let leaves = |mut sys: ShellSystem, x0: Vec<Vector3<f64>>| {
        let mut state = State::at_rest(x0);
        let report = Static::default().step(&mut sys, &mut state).unwrap();
        let newton = report.newton.as_ref().unwrap();
        assert_eq!(report.stable, Some(true), "{:?}", report.stability);
        let escape = newton
            .hessians
            .iter()
            .position(|h| *h == IterationHessian::NegativeCurvature)
            .expect("left the fundamental state along negative curvature");
        // The potential is lower than at the saddle it left (values[i] is the iterate before
        // iteration i).
        let (saddle, end) = (newton.values[escape], *newton.values.last().unwrap());
        assert!(end < saddle, "{end} vs {saddle}");
        state.x
    };
    // The strut at 1.05 Euler loads (200 × 2 cells): the elastica's midspan deflection is
    // δ/L = k/K(k) with (2K(k)/π)² = 1.05, k = 0.305805, δ/L = 0.189990. Measured
    // (2026-12-02): 0.1913 (+0.7 %) here, 0.1902 at 1000 × 10 cells (`cargo xtask hard-cases
    // --only critical`). Asserted within 1.5 %.
    let p = 1.05 * euler_load();
    let (sys, x0) = compressed_plate(LENGTH, WIDTH, 200, 2, THICKNESS, YOUNG, 0.0, false, p, 0.0);
    let x = leaves(sys, x0);
    let deflection = x.iter().fold(0.0f64, |m, x| m.max(x.z.abs()));
    println!("strut: δ/L = {:.6}", deflection / LENGTH);
    assert!(
        (deflection / LENGTH / 0.189990 - 1.0).abs() < 0.015,
        "{deflection}"
    );
    // The tube at 1.05 p_cr (64 cells around): two lobes, radii differing by several % of R.
    let (r, h): (f64, f64) = (0.1, 1e-3);
    let p = 1.05 * 3.0 * YOUNG * h.powi(3) / 12.0 / r.powi(3);
    let (sys, x0) = pressurised_tube(r, 64, 2, h, YOUNG, 0.0, p, 0.0);
    let x = leaves(sys, x0);
    let radii: Vec<f64> = x.iter().map(|x| x.x.hypot(x.y)).collect();
    let (lo, hi) = radii
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), q| (a.min(*q), b.max(*q)));
    println!("tube: radii {lo:.5} to {hi:.5} m");
    assert!(hi - lo > 0.05 * r, "{lo} {hi}");
}
