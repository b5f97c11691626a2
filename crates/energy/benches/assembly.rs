//! Whole-mesh assembly on icospheres (1 280, 20 480, 81 920 faces), one thread and all
//! threads: energy; energy + gradient; energy + gradient + Hessian (exact and Gauss–Newton;
//! projected to PSD on the smallest mesh only); the Hessian gather ("fill") alone; and, on the
//! 20 480-face mesh, the per-face kernel alone in a sequential loop ("kernel_only"); per-face
//! 9×9 load blocks (pressure) added in one call or in one call per face ("face_blocks").
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
    Assembler, DofMap, EvalOutput, FaceEval, FaceRest, HessianMode, Material, RestState, SffKind,
    ShellModel, Stencils, Terms, Want, eval_face,
};
use thinshell_mesh::{Mesh, generators};

fn bench(c: &mut Criterion) {
    let terms = Terms::ELASTIC;
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
            if level == 3 {
                // Per-face 18×18 eigen-decomposition: measured on the small mesh only.
                group.bench_function(id("energy_gradient_hessian_psd"), |b| {
                    pool.install(|| {
                        b.iter(|| {
                            let out = EvalOutput {
                                gradient: Some(&mut g),
                                hessian: Some((&mut h, HessianMode::ProjectedPsd)),
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
        // Per-face 9×9 load blocks (a pressure Hessian): all faces in one call, which checks the
        // pattern once, against one call per face (the pattern checked every time; issue #15).
        // Sequential, so no thread count.
        let block = nalgebra::SMatrix::<f64, 9, 9>::from_fn(|i, j| 1.0 / (1.0 + (i + j) as f64));
        let asm = Assembler::new(&mesh, &dofs, terms).unwrap();
        let mut h = asm.hessian_template();
        group.bench_function("face_blocks/all_at_once", |b| {
            b.iter(|| asm.add_face_blocks(|_| block, black_box(&mut h)).unwrap())
        });
        // The old way costs faces × nonzeros (10.7 s at 20 480 faces): the smallest mesh only.
        if level == 3 {
            group.bench_function("face_blocks/one_call_per_face", |b| {
                b.iter(|| {
                    for f in 0..n_faces {
                        asm.add_face_block(
                            thinshell_mesh::FaceId::new(f),
                            &block,
                            black_box(&mut h),
                        )
                        .unwrap();
                    }
                })
            });
        }
        group.finish();
        if level == 5 {
            kernel_only(c, &mesh, &x, &rest, &model);
        }
    }
}

/// The per-face kernel alone in a sequential loop (stencil construction included, no
/// buffers, no gather): shows how much of the assembly time is the kernel's.
fn kernel_only(
    c: &mut Criterion,
    mesh: &Mesh,
    x: &[Vector3<f64>],
    rest: &RestState,
    model: &ShellModel,
) {
    let stencils = Stencils::new(mesh);
    let sff = &thinshell_energy::MidEdgeAverage;
    let mut group = c.benchmark_group(format!("kernel_only/{}", mesh.n_faces()));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sampling_mode(SamplingMode::Flat)
        .throughput(Throughput::Elements(mesh.n_faces() as u64));
    let wants = [
        (
            "energy",
            Want {
                gradient: false,
                hessian: None,
            },
        ),
        (
            "energy_gradient",
            Want {
                gradient: true,
                hessian: None,
            },
        ),
        (
            "energy_gradient_hessian_exact",
            Want {
                gradient: true,
                hessian: Some(HessianMode::Exact),
            },
        ),
    ];
    for (name, want) in wants {
        let mut out = FaceEval::default();
        group.bench_function(BenchmarkId::new(name, "1t"), |b| {
            b.iter(|| {
                let mut sum = 0.0;
                for f in 0..mesh.n_faces() {
                    let face_rest = FaceRest {
                        a_bar: rest.a_bar[f],
                        b_bar: rest.b_bar[f],
                    };
                    let stencil = stencils.stencil(f, x);
                    eval_face(
                        sff,
                        &model.material,
                        &stencil,
                        &face_rest,
                        None,
                        model.terms,
                        want,
                        &mut out,
                    );
                    sum += out.energy.total() + out.gradient[0] + out.hessian[(0, 0)];
                }
                black_box(sum)
            })
        });
    }
    group.finish();
}

/// Whole-mesh assembly with the edge-director form (tan, 21 dofs per face: positions and the
/// three edge angles) on the 20 480-face icosphere, one thread.
fn director(c: &mut Criterion) {
    let sff = SffKind::EdgeDirector(thinshell_energy::DirectorVariant::Tan);
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let mesh = generators::icosphere(1.0, 5).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let x: Vec<Vector3<f64>> = mesh
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x, p.y * 0.9, p.z * (1.0 + 0.05 * (7.0 * p.x).sin())))
        .collect();
    let phi: Vec<f64> = (0..mesh.n_edges())
        .map(|e| 0.01 * (e as f64).sin())
        .collect();
    let dofs = DofMap::all_free(mesh.n_vertices())
        .with_edges(mesh.n_edges(), [])
        .unwrap();
    let mut asm = Assembler::for_model(&mesh, &dofs, &model).unwrap();
    let mut g = vec![0.0; asm.n_coordinates()];
    let mut h = asm.hessian_template();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut group = c.benchmark_group(format!("assembly_director/{}", mesh.n_faces()));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sampling_mode(SamplingMode::Flat)
        .throughput(Throughput::Elements(mesh.n_faces() as u64));
    let wants: [(&str, bool, Option<HessianMode>); 3] = [
        ("energy", false, None),
        ("energy_gradient", true, None),
        (
            "energy_gradient_hessian_exact",
            true,
            Some(HessianMode::Exact),
        ),
    ];
    for (name, gradient, mode) in wants {
        group.bench_function(BenchmarkId::new(name, "1t"), |b| {
            pool.install(|| {
                b.iter(|| {
                    let out = EvalOutput {
                        gradient: gradient.then_some(&mut g[..]),
                        hessian: mode.map(|m| (&mut h, m)),
                    };
                    asm.evaluate_with_angles(&model, black_box(&x), &phi, &rest, None, out)
                        .unwrap()
                })
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench, director);
criterion_main!(benches);
