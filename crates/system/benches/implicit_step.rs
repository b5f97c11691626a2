//! One implicit Euler step (Δt = 1e-3 s, line search on, exact Hessian) of a unit sphere
//! shrinking under uniform isotropic growth ā = 0.9 a⁰ (the seed's uniform heat), at 1 280,
//! 20 480 and 81 920 faces. Every sample starts from the same rest sphere; the Newton workspace
//! (symbolic factorisation) is reused, as in a running simulation.
//!
//! Run: `cargo bench -p thinshell-solver --bench implicit_step`
//! Besides criterion's medians it prints, per size, the Newton iterations of the step and the
//! time split assembly / factorisation / solve.
#![allow(clippy::unwrap_used, missing_docs)]

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use thinshell_energy::SffKind;
use thinshell_solver::{ImplicitEuler, Integrator};
use thinshell_testkit::fixtures::shrinking_sphere;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("implicit_step_shrinking_sphere");
    group.sample_size(10);
    for level in [3usize, 5, 6] {
        let (mut sys, state0) = shrinking_sphere(level, SffKind::MidEdgeAverage);
        let faces = sys.mesh().n_faces();
        let mut ie = ImplicitEuler::new(1e-3);
        // One reported step (also builds the workspace).
        let mut s = state0.clone();
        let t = Instant::now();
        let r = ie.step(&mut sys, &mut s).unwrap();
        let wall = t.elapsed().as_secs_f64();
        let n = r.newton.unwrap();
        let tm = n.timings;
        eprintln!(
            "{faces} faces, {} unknowns: first step {wall:.3} s (incl. symbolic analysis), {} Newton iterations, assembly {:.3} s, factorisation {:.3} s, solve {:.3} s",
            sys.dofs().n_free(),
            n.iterations,
            tm.assembly.as_secs_f64(),
            tm.factorization.as_secs_f64(),
            tm.solve.as_secs_f64()
        );
        group.bench_function(format!("{faces}_faces"), |b| {
            b.iter(|| {
                let mut s = state0.clone();
                black_box(
                    ie.step(&mut sys, &mut s)
                        .unwrap()
                        .newton
                        .map(|n| n.iterations),
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
