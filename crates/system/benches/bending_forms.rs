//! What the edge-director bending forms cost (docs/performance.md, "Edge-director bending"): for
//! the mid-edge average and the two director variants, on icospheres of 1 280 and 20 480 faces,
//! - whole-mesh assembly of energy + gradient + exact Hessian (`assembly/<form>/<faces>`), and
//! - one implicit Euler step (Δt = 1e-3 s, line search on, exact Hessian) of the sphere shrinking
//!   under ā = 0.9 a⁰ (`implicit_step/<form>/<faces>`), the workspace reused as in a running
//!   simulation.
//!
//! Run: `cargo bench -p thinshell-solver --bench bending_forms`
//! Besides criterion's medians it prints, per form and size, the unknowns, the Hessian's stored
//! entries, the Newton iterations of the step and its time split.
#![allow(clippy::unwrap_used, missing_docs)]

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use thinshell_energy::{Assembler, EvalOutput, HessianMode, SffKind};
use thinshell_solver::{ImplicitEuler, Integrator};
use thinshell_testkit::fixtures::shrinking_sphere;

fn bench(c: &mut Criterion) {
    let mut asm_group = c.benchmark_group("assembly");
    asm_group.sample_size(10);
    for level in [3usize, 5] {
        for sff in SffKind::ALL {
            let (sys, state) = shrinking_sphere(level, sff);
            let faces = sys.mesh().n_faces();
            let mut asm = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model()).unwrap();
            let mut g = vec![0.0; sys.dofs().n_coordinates()];
            let mut h = asm.hessian_template();
            // A rippled configuration and small angles, so that nothing is trivially zero.
            let x: Vec<_> = state
                .x
                .iter()
                .enumerate()
                .map(|(i, p)| p * (1.0 + 0.01 * (i as f64 * 0.37).sin()))
                .collect();
            let phi: Vec<f64> = (0..sys.n_edge_angles())
                .map(|e| 0.01 * (e as f64 * 0.51).cos())
                .collect();
            eprintln!(
                "{:>18} {faces:>6} faces: {:>7} unknowns, {:>9} Hessian entries (lower)",
                sff.name(),
                asm.n_free(),
                asm.nnz()
            );
            asm_group.bench_function(format!("{}/{faces}", sff.name()), |b| {
                b.iter(|| {
                    black_box(
                        asm.evaluate_with_angles(
                            sys.model(),
                            &x,
                            &phi,
                            sys.rest(),
                            None,
                            EvalOutput {
                                gradient: Some(&mut g),
                                hessian: Some((&mut h, HessianMode::Exact)),
                            },
                        )
                        .unwrap(),
                    )
                })
            });
        }
    }
    asm_group.finish();

    let mut group = c.benchmark_group("implicit_step");
    group.sample_size(10);
    for level in [3usize, 5] {
        for sff in SffKind::ALL {
            let (mut sys, state0) = shrinking_sphere(level, sff);
            let faces = sys.mesh().n_faces();
            let mut ie = ImplicitEuler::new(1e-3);
            let mut s = state0.clone();
            let t = Instant::now();
            let r = ie.step(&mut sys, &mut s).unwrap();
            let wall = t.elapsed().as_secs_f64();
            let n = r.newton.unwrap();
            let tm = n.timings;
            eprintln!(
                "{:>18} {faces:>6} faces: first step {wall:.3} s (incl. symbolic analysis), {} Newton iterations, assembly {:.3} s, factorisation {:.3} s, solve {:.3} s",
                sff.name(),
                n.iterations,
                tm.assembly.as_secs_f64(),
                tm.factorization.as_secs_f64(),
                tm.solve.as_secs_f64()
            );
            group.bench_function(format!("{}/{faces}", sff.name()), |b| {
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
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
