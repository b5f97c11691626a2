//! Probe of issue #26: a flat annulus (radii 0.1, 1 m) grown conformally (ā = r^{2c} a⁰, b̄ = 0)
//! into a cone with sin(half-angle) = 1 + c, solved statically with default settings.
//!
//! `cargo run --release -p thinshell-solver --example cone_probe -- C H RINGS AROUND [sin|avg] [-v]`
//! (defaults −0.3, 1e-2, 16, 64, the default form); `VERBOSE=1` prints every Newton iteration,
//! `POLICY=adaptive_psd` solves with the adaptive policy as it was before issue #26.
#![allow(clippy::unwrap_used, missing_docs)]
use std::time::Instant;

use nalgebra::Vector3;
use thinshell_energy::{Material, MaterialModel, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::generators;
use thinshell_solver::{Boundary, Integrator, IterationHessian, Loads, ShellSystem, State, Static};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let c: f64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(-0.3);
    let h: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(1e-2);
    let rings: usize = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(16);
    let around: usize = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(64);
    let sff = match args.get(5).map(String::as_str) {
        Some("sin") => SffKind::EdgeDirector(thinshell_energy::DirectorVariant::Sin),
        Some("avg") => SffKind::MidEdgeAverage,
        _ => SffKind::default(),
    };
    let mesh = generators::annulus(0.1, 1.0, rings, around).unwrap();
    let x0: Vec<Vector3<f64>> = mesh.positions().to_vec();
    let mut rest = RestState::from_mesh(&mesh, &x0, sff).unwrap();
    for (f, a) in rest.a_bar.iter_mut().enumerate() {
        let [i, j, k] = mesh.faces()[f];
        let cen = (x0[i.idx()] + x0[j.idx()] + x0[k.idx()]) / 3.0;
        let r = (cen.x * cen.x + cen.y * cen.y).sqrt();
        let s = c * (r / 1.0).ln();
        *a *= (2.0 * s).exp();
    }
    for b in rest.b_bar.iter_mut() {
        *b *= 0.0;
    }
    let material = Material {
        thickness: h,
        young: 1e6,
        poisson: 0.3,
        density: 1000.0,
        viscosity: 0.0,
        model: MaterialModel::StVK,
    };
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff,
    };
    let mut sys =
        ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default()).unwrap();
    // Slight perturbation out of plane.
    let start: Vec<Vector3<f64>> = x0
        .iter()
        .map(|p| {
            let r = (p.x * p.x + p.y * p.y).sqrt();
            p + Vector3::new(0.0, 0.0, 1e-3 * r * r + 1e-4 * (3.0 * p.x).sin() * r)
        })
        .collect();
    let mut state = State::at_rest(start);
    let mut solver = Static::default();
    // POLICY=adaptive_psd: the adaptive policy before issue #26, for comparison.
    if std::env::var("POLICY").is_ok_and(|p| p == "adaptive_psd") {
        solver.newton.hessian = thinshell_solver::HessianPolicy::AdaptivePsd;
    }
    if std::env::var("VERBOSE").is_ok() {
        solver.set_progress(Some(std::sync::Arc::new(
            |p: &thinshell_solver::NewtonProgress| {
                println!(
                    "  it {:3} {:?} res {:.3e} alpha {:.3e}",
                    p.iteration, p.hessian, p.residual, p.step_length
                );
            },
        )));
    }
    let t = Instant::now();
    let r = solver.step(&mut sys, &mut state);
    let wall = t.elapsed().as_secs_f64();
    match &r {
        Ok(rep) => {
            let n = rep.newton.as_ref().unwrap();
            println!(
                "c={c} h={h} {rings}x{around} {sff:?}: {} iterations ({} Gauss-Newton, {} shifted, \
                 {} negative curvature; {} rejected, {} undone) {:?} stable={:?} E={:.7e} \
                 {} factorisations, wall {wall:.2} s",
                n.iterations,
                n.count(IterationHessian::Psd),
                n.count(IterationHessian::Shifted),
                n.count(IterationHessian::NegativeCurvature),
                n.rejected_steps,
                n.watchdog_undone,
                n.convergence,
                rep.stable,
                rep.energies.total(),
                n.factorizations,
            );
        }
        Err(e) => println!("c={c} h={h} {:?}: FAILED {e} wall {wall:.2}s", sff),
    }
    // Ring geometry: radius about ring centroid, and slant angle between rings.
    let x = &state.x;
    let mut stats = Vec::new();
    for k in 0..=rings {
        let ids: Vec<usize> = (k * around..(k + 1) * around).collect();
        let cen = ids.iter().map(|&i| x[i]).sum::<Vector3<f64>>() / around as f64;
        let radii: Vec<f64> = ids.iter().map(|&i| (x[i] - cen).norm()).collect();
        let mean = radii.iter().sum::<f64>() / around as f64;
        let oor = radii.iter().fold(0.0f64, |m, r| m.max((r - mean).abs())) / mean;
        stats.push((cen, mean, oor));
    }
    let mut worst = 0.0f64;
    let mut oor_max = 0.0f64;
    for k in 1..=rings {
        let (c0, r0, _) = stats[k - 1];
        let (c1, r1, o1) = stats[k];
        let dr = r1 - r0;
        let dc = (c1 - c0).norm();
        let sin_a = dr / (dr * dr + dc * dc).sqrt();
        let err = (sin_a - (1.0 + c)) / (1.0 + c);
        if k > 2 && k < rings - 1 {
            worst = worst.max(err.abs());
        }
        oor_max = oor_max.max(o1);
        if args.iter().any(|a| a == "-v") {
            println!(
                "ring {k}: sin {sin_a:.5} err {:+.3}% oor {:.3}%",
                100.0 * err,
                100.0 * o1
            );
        }
    }
    println!(
        "interior sin error max {:.3}%, out-of-round max {:.3}%",
        100.0 * worst,
        100.0 * oor_max
    );
}
