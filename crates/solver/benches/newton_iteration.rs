//! One Newton iteration of an implicit Euler step — assembly (energy, gradient, exact Hessian,
//! plus the inertia diagonal Λ/Δt²), numeric Cholesky factorisation, triangular solves — on the
//! shrinking unit sphere of `implicit_step` (ā = 0.9 a⁰, Δt = 1e-3 s) at 1 280, 20 480 and
//! 81 920 faces, with one thread and with all threads.
//!
//! Run: `cargo bench -p thinshell-solver --bench newton_iteration`
//!
//! Configurations: `1_thread` (assembly and faer sequential), `all_threads` (assembly on the
//! rayon pool, factorisation sequential: the solver's default, `NewtonSettings::parallel =
//! false`) and `all_threads_parallel_faer` (faer on the pool too). Besides criterion's medians it
//! prints, per configuration and size, the median stage times of 5 timed iterations, their
//! shares, and a least-squares fit of iteration time ∝ faces^p over the three sizes.
#![allow(clippy::unwrap_used, missing_docs)]

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use faer::Par;
use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{
    Assembler, DofMap, EvalOutput, HessianMode, Material, RestState, SffKind, ShellModel, Terms,
    lumped_mass,
};
use thinshell_mesh::generators;
use thinshell_solver::{Ordering, SparseCholesky};

const DT: f64 = 1e-3;
const LEVELS: [usize; 3] = [3, 5, 6];

/// Everything one iteration touches, built once per size (pattern, symbolic analysis).
struct Problem {
    faces: usize,
    model: ShellModel,
    rest: RestState,
    x: Vec<Vector3<f64>>,
    assembler: Assembler,
    hessian: SparseColMat<usize, f64>,
    diag: Vec<usize>,
    m_over_dt2: Vec<f64>,
    gradient: Vec<f64>,
    cholesky: SparseCholesky,
}

fn setup(level: usize, par: Par) -> Problem {
    let mesh = generators::icosphere(1.0, level).unwrap();
    let x = mesh.positions().to_vec();
    let sff = SffKind::MidEdgeAverage;
    let mut rest = RestState::from_mesh(&mesh, &x, sff).unwrap();
    rest.a_bar.iter_mut().for_each(|a| *a *= 0.9);
    let terms = Terms::ELASTIC;
    let model = ShellModel {
        material: Material::paper(),
        terms,
        sff,
    };
    let n = mesh.n_vertices();
    let dofs = DofMap::all_free(n);
    let assembler = Assembler::new(&mesh, &dofs, terms).unwrap();
    let hessian = assembler.hessian_template();
    let diag = assembler.diagonal_offsets().to_vec();
    let mass = lumped_mass(&mesh, &rest, &model.material).unwrap();
    let m_over_dt2 = (0..3 * n).map(|c| mass[c / 3] / (DT * DT)).collect();
    let coords: Vec<[f64; 3]> = (0..3 * n).map(|c| x[c / 3].into()).collect();
    let cholesky =
        SparseCholesky::new(hessian.symbolic(), Ordering::default(), Some(&coords), par).unwrap();
    Problem {
        faces: mesh.n_faces(),
        model,
        rest,
        x,
        assembler,
        hessian,
        diag,
        m_over_dt2,
        gradient: vec![0.0; 3 * n],
        cholesky,
    }
}

/// One iteration at the rest sphere (x = x̃, so the inertia gradient vanishes); returns the
/// three stage times in seconds.
fn iteration(p: &mut Problem) -> [f64; 3] {
    let t0 = Instant::now();
    p.assembler
        .evaluate(
            &p.model,
            &p.x,
            &p.rest,
            None,
            EvalOutput {
                gradient: Some(&mut p.gradient),
                hessian: Some((&mut p.hessian, HessianMode::Exact)),
            },
        )
        .unwrap();
    let vals = p.hessian.val_mut();
    for (&d, m) in p.diag.iter().zip(&p.m_over_dt2) {
        vals[d] += m;
    }
    let t1 = Instant::now();
    p.cholesky.factorize(p.hessian.as_ref()).unwrap();
    let t2 = Instant::now();
    let mut rhs: Vec<f64> = p.gradient.iter().map(|g| -g).collect();
    p.cholesky.solve_in_place(&mut rhs).unwrap();
    black_box(&rhs);
    let t3 = Instant::now();
    [
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        (t3 - t2).as_secs_f64(),
    ]
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Least-squares slope of ln y against ln x.
fn fit(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|(x, y)| (x.ln(), y.ln())).unzip();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    sxy / sxx
}

fn bench(c: &mut Criterion) {
    let all = rayon::current_num_threads();
    let configs: [(&str, usize, Par); 3] = [
        ("1_thread", 1, Par::Seq),
        ("all_threads", all, Par::Seq),
        ("all_threads_parallel_faer", all, Par::rayon(all)),
    ];
    let mut group = c.benchmark_group("newton_iteration_shrinking_sphere");
    group.sample_size(10);
    for (name, threads, par) in configs {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut totals = Vec::new();
        for level in LEVELS {
            let mut p = pool.install(|| setup(level, par));
            let faces = p.faces;
            let samples: Vec<[f64; 3]> =
                (0..5).map(|_| pool.install(|| iteration(&mut p))).collect();
            let stage = |k: usize| median(samples.iter().map(|s| s[k]).collect());
            let (a, f, s) = (stage(0), stage(1), stage(2));
            let total = a + f + s;
            totals.push((faces as f64, total));
            eprintln!(
                "{name} ({threads} threads), {faces} faces: {:.1} ms per iteration = assembly {:.1} ms ({:.0} %) + factorisation {:.1} ms ({:.0} %) + solve {:.1} ms ({:.0} %)",
                1e3 * total,
                1e3 * a,
                100.0 * a / total,
                1e3 * f,
                100.0 * f / total,
                1e3 * s,
                100.0 * s / total
            );
            group.bench_function(format!("{name}/{faces}_faces"), |b| {
                b.iter(|| pool.install(|| black_box(iteration(&mut p))))
            });
        }
        eprintln!(
            "{name}: iteration time ∝ faces^{:.2} (least-squares fit over {} sizes)",
            fit(&totals),
            totals.len()
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
