//! Probe of the conformal cone (docs/robustness.md, "Indefinite Hessians near critical
//! points"): a flat annulus (radii 0.1, 1 m) grown conformally (ā = r^{2c} a⁰, b̄ = 0)
//! into a cone with sin(half-angle) = 1 + c, solved statically with default settings
//! (`thinshell_testkit::fixtures::conformal_cone`).
//!
//! `cargo run --release -p thinshell-solver --example cone_probe -- C H RINGS AROUND [sin|avg]`
//! (defaults −0.3, 1e-2, 16, 64, the default form). Environment: `VERBOSE=1` prints every Newton
//! iteration; `POLICY=adaptive_psd` solves with `HessianPolicy::AdaptivePsd`;
//! `MAXIT=N` sets `max_iterations`; `START=cone` starts from the round cone instead of the
//! lifted flat annulus; `CONTINUATION=0` turns off the static step's rest-state continuation.
#![allow(clippy::unwrap_used, missing_docs)]
use std::time::Instant;

use thinshell_energy::SffKind;
use thinshell_solver::{Integrator, IterationHessian, State, Static, StepControl};
use thinshell_testkit::fixtures::conformal_cone;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, default: f64| args.get(i).map_or(default, |s| s.parse().unwrap());
    let (c, h) = (arg(1, -0.3), arg(2, 1e-2));
    let (rings, around) = (arg(3, 16.0) as usize, arg(4, 64.0) as usize);
    let sff = match args.get(5).map(String::as_str) {
        Some("sin") => SffKind::EdgeDirector(thinshell_energy::DirectorVariant::Sin),
        Some("avg") => SffKind::MidEdgeAverage,
        _ => SffKind::default(),
    };
    let env = |k: &str| std::env::var(k).ok();
    let mut cone = conformal_cone(c, h, rings, around, sff);
    let start = if env("START").is_some_and(|v| v == "cone") {
        cone.round_cone()
    } else {
        cone.start.clone()
    };
    let mut state = State::at_rest(start);
    let mut solver = Static::default();
    if let Some(n) = env("MAXIT").and_then(|v| v.parse().ok()) {
        solver.newton.max_iterations = n;
    }
    solver.continuation = env("CONTINUATION").is_none_or(|v| v != "0");
    if env("POLICY").is_some_and(|p| p == "adaptive_psd") {
        solver.newton.hessian = thinshell_solver::HessianPolicy::AdaptivePsd;
    }
    if env("VERBOSE").is_some() {
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
    let r = solver.step(&mut cone.system, &mut state);
    let wall = t.elapsed().as_secs_f64();
    match &r {
        Ok(rep) => {
            let n = rep.newton.as_ref().unwrap();
            println!(
                "c={c} h={h} {rings}x{around} {sff:?}: {} iterations ({} Gauss-Newton, {} shifted, \
                 {} negative curvature; {} rejected, {} undone) {:?} stable={:?} E={:.7e} \
                 {} factorisations, {} continuation stages, wall {wall:.2} s",
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
                rep.continuation_stages,
            );
        }
        Err(e) => println!("c={c} h={h} {sff:?}: FAILED {e} wall {wall:.2}s"),
    }
    println!(
        "sin(half-angle) error max {:.3}% (flat r in [0.3, 0.8] m), out-of-round max {:.3}%",
        100.0 * cone.sin_error(&state.x),
        100.0 * cone.out_of_round(&state.x)
    );
}
