//! Whole-mesh assembly on icospheres (1 280, 20 480, 81 920 faces), one thread and all
//! threads: energy; energy + gradient; energy + gradient + Hessian (exact and Gauss–Newton);
//! and the Hessian gather ("fill") alone.
//!
//! `cargo bench -p thinshell-energy --bench assembly`; criterion reports time per evaluation
//! and faces per second (throughput = number of faces). Results are quoted per face in
//! `docs/performance.md`.
#![allow(clippy::unwrap_used, missing_docs)]

use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Duration;
use thinshell_energy::{
    Assembler, DofMap, EvalOutput, HessianMode, Material, RestState, SffKind, ShellModel, Terms,
};
use thinshell_mesh::generators;

fn bench(c: &mut Criterion) {
    let terms = Terms {
        stretch: true,
        bend: true,
        damping: false,
    };
    let model = ShellModel {
        material: Material::paper(),
        terms,
        sff: SffKind::MidEdgeAverage,
    };
    let all = std::thread::available_parallelism().map_or(1, usize::from);
    let mut thread_counts = vec![1];
    if all > 1 {
        thread_counts.push(all);
    }
    for level in [3usize, 5, 6] {
        let mesh = generators::icosphere(1.0, level).unwrap();
        let n_faces = mesh.n_faces();
        let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
        // A deformed, non-equilibrium configuration (squashed, with a ripple).
        let x: Vec<Vector3<f64>> = mesh
            .positions()
            .iter()
            .map(|p| Vector3::new(p.x, p.y * 0.9, p.z * (1.0 + 0.05 * (7.0 * p.x).sin())))
            .collect();
        let dofs = DofMap::all_free(mesh.n_vertices());
        let mut group = c.benchmark_group(format!("assembly/{n_faces}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2))
            .sampling_mode(SamplingMode::Flat)
            .throughput(Throughput::Elements(n_faces as u64));
        for &threads in &thread_counts {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut asm = Assembler::new(&mesh, &dofs, terms).unwrap();
            let mut g = vec![0.0; 3 * mesh.n_vertices()];
            let mut h = asm.hessian_template();
            let id = |what: &str| BenchmarkId::new(what, format!("{threads}t"));
            group.bench_function(id("energy"), |b| {
                pool.install(|| {
                    b.iter(|| {
                        asm.evaluate(&model, black_box(&x), &rest, None, EvalOutput::default())
                            .unwrap()
                    })
                })
            });
            group.bench_function(id("energy_gradient"), |b| {
                pool.install(|| {
                    b.iter(|| {
                        let out = EvalOutput {
                            gradient: Some(&mut g),
                            hessian: None,
                        };
                        asm.evaluate(&model, black_box(&x), &rest, None, out)
                            .unwrap()
                    })
                })
            });
            for (name, mode) in [
                ("energy_gradient_hessian_exact", HessianMode::Exact),
                ("energy_gradient_hessian_gn", HessianMode::GaussNewton),
            ] {
                group.bench_function(id(name), |b| {
                    pool.install(|| {
                        b.iter(|| {
                            let out = EvalOutput {
                                gradient: Some(&mut g),
                                hessian: Some((&mut h, mode)),
                            };
                            asm.evaluate(&model, black_box(&x), &rest, None, out)
                                .unwrap()
                        })
                    })
                });
            }
            // The gather step alone, from the per-face blocks of the last Hessian evaluation.
            group.bench_function(id("fill"), |b| {
                pool.install(|| b.iter(|| asm.gather_hessian(black_box(&mut h)).unwrap()))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
