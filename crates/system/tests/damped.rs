//! Implicit Euler with Kelvin–Voigt damping decays towards the same equilibrium a static solve
//! finds (model.md §5, the seed's enlarged square and rhombus from the seed's perturbed starts).
#![allow(clippy::unwrap_used)]

use nalgebra::{Matrix2, Vector2, Vector3};
use thinshell_energy::{SffKind, ShellModel, Terms};
use thinshell_solver::{ImplicitEuler, Integrator, State};
use thinshell_system::{Boundary, Loads, ShellSystem};
use thinshell_testkit::fixtures::{damped_paper, planar_start, seed_square};

/// RMS deviation of the pairwise squared distances from those of the analytic equilibrium
/// (x_i − x_j)ᵀ ā^{xy} (x_i − x_j), relative: zero iff x is a rigid motion of the equilibrium.
fn metric_rms(p: &[Vector3<f64>], x: &[Vector3<f64>], a: Matrix2<f64>) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d = Vector2::new(p[j].x - p[i].x, p[j].y - p[i].y);
            let target = (d.transpose() * a * d)[(0, 0)];
            let got = (x[j] - x[i]).norm_squared();
            sum += ((got - target) / target).powi(2);
            n += 1.0;
        }
    }
    (sum / n).sqrt()
}

fn decay(a_xy: Matrix2<f64>, start: Matrix2<f64>) -> (f64, f64, f64) {
    let (mesh, rest) = seed_square(a_xy, Matrix2::zeros());
    let p = mesh.positions().to_vec();
    // Relaxation time η/E = 2e-4 s: a few membrane oscillation periods (~1 ms) are damped
    // within the run.
    let material = damped_paper(2e-4);
    let model = ShellModel {
        material,
        terms: Terms {
            stretch: true,
            bend: true,
            damping: true,
        },
        sff: SffKind::MidEdgeAverage,
    };
    let x0 = planar_start(&mesh, start);
    let mut sys =
        ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default()).unwrap();
    let mut state = State::at_rest(x0);
    let mut ie = ImplicitEuler::new(1e-4);
    let e0 = metric_rms(&p, &state.x, a_xy);
    let mut mid = 0.0;
    for step in 0..200 {
        let r = ie.step(&mut sys, &mut state).unwrap();
        // Line search on: Φ never increases within a solve (but after a watchdog step, which
        // it recovers from).
        let newton = r.newton.unwrap();
        assert_eq!(
            newton.descent_violation(ie.newton.watchdog),
            None,
            "Φ rose: {:?}",
            newton.values
        );
        if step == 49 {
            mid = metric_rms(&p, &state.x, a_xy);
        }
    }
    (e0, mid, metric_rms(&p, &state.x, a_xy))
}

#[test]
fn damped_implicit_euler_decays_to_the_enlarged_square() {
    let (e0, mid, end) = decay(Matrix2::identity() * 4.0, Matrix2::identity() * 1.95);
    println!(
        "enlarged square: metric error {e0:.3e} → {mid:.3e} (t = 5 ms) → {end:.3e} (t = 20 ms)"
    );
    // Start: side 1.95 instead of 2 → squared lengths off by 1 − 0.95² ≈ 4.9 %.
    assert!((e0 - (1.0 - 0.975f64.powi(2))).abs() < 1e-9, "{e0}");
    assert!(mid < e0, "{mid} !< {e0}");
    assert!(end < 1e-3 * e0, "{end} after 20 ms from {e0}");
}

#[test]
fn damped_implicit_euler_decays_to_the_rhombus() {
    let s = 3f64.sqrt();
    let t = Matrix2::new(s + 1.0, s - 1.0, s - 1.0, s + 1.0) * 0.5;
    let (e0, mid, end) = decay(Matrix2::new(2.0, 1.0, 1.0, 2.0), t * 0.9);
    println!("rhombus: metric error {e0:.3e} → {mid:.3e} (t = 5 ms) → {end:.3e} (t = 20 ms)");
    assert!((e0 - 0.19).abs() < 1e-9, "{e0}");
    assert!(mid < e0 && end < 1e-3 * e0, "{e0} → {mid} → {end}");
}
