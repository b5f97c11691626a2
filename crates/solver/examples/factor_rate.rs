//! The one-thread factorisation rate on the shrinking sphere's Hessian pattern (both forms):
//! the library's default unsplit driver (multifrontal), faer's left-looking supernodal driver
//! and the split factorisation on a one-thread pool, interleaved rounds, medians, with the
//! predicted flops and GFlop/s, and faer's dense matrix product on one core as the limit.
//!
//! Run: `cargo run --release -p thinshell-solver --example factor_rate -- 5 [rounds] [forms]`
//! (icosphere levels, comma-separated; rounds, default 5; forms `both` (default), `average`,
//! `tan`); a fourth argument `profile` prints instead the multifrontal driver's time per
//! stage and supernode width class (medians over the rounds). `-- gemm` prints only the dense
//! product's rate.
#![allow(clippy::unwrap_used, missing_docs)]
mod common;
use std::time::Instant;

use common::spd;
use faer::sparse::SparseColMat;
use faer::{Mat, Par};
use thinshell_energy::{Assembler, SffKind};
use thinshell_solver::{Ordering, SparseCholesky};
use thinshell_testkit::fixtures::shrinking_sphere;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// faer's one-thread dense product `C += A B` of n × n matrices, best of 5, GFlop/s.
fn gemm_rate(n: usize) -> f64 {
    let a = Mat::<f64>::from_fn(n, n, |i, j| ((i + 3 * j) % 7) as f64);
    let b = a.clone();
    let mut c = Mat::<f64>::zeros(n, n);
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        faer::linalg::matmul::matmul(
            c.as_mut(),
            faer::Accum::Add,
            a.as_ref(),
            b.as_ref(),
            1.0,
            Par::Seq,
        );
        best = best.min(t.elapsed().as_secs_f64());
    }
    2.0 * (n as f64).powi(3) / best / 1e9
}

fn main() {
    let arg = std::env::args().nth(1).unwrap_or_else(|| "5".into());
    if arg == "gemm" {
        for n in [256, 512, 1024, 2048] {
            println!("dense product n = {n}: {:.1} GFlop/s", gemm_rate(n));
        }
        for (r, w) in [(300, 100), (600, 200), (150, 30), (60, 8)] {
            kernels(r, w);
        }
        return;
    }
    let levels: Vec<usize> = arg.split(',').map(|x| x.parse().unwrap()).collect();
    let rounds: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(5);
    let profile = std::env::args().nth(4).as_deref() == Some("profile");
    let forms = match std::env::args().nth(3).as_deref() {
        Some("average") => vec![SffKind::MidEdgeAverage],
        Some("tan") => vec![SffKind::default()],
        _ => vec![SffKind::MidEdgeAverage, SffKind::default()],
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    println!(
        "dense product n = 1024, one thread: {:.1} GFlop/s",
        gemm_rate(1024)
    );
    for &level in &levels {
        for &sff in &forms {
            let (sys, _) = shrinking_sphere(level, sff);
            let asm = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model()).unwrap();
            let mut h = asm.hessian_template();
            spd(&mut h);
            let mut mf =
                SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
            let mut faer_driver =
                SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
            faer_driver.use_faer_driver();
            let mut split = pool
                .install(|| SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::rayon(1)))
                .unwrap();
            let mut mixed =
                SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
            assert!(mixed.set_mixed_precision(true).unwrap());
            let flops = mf.stats().flops;
            if profile {
                print_profile(&mut mf, &h, rounds, level, sff);
                continue;
            }
            let mut times = [
                Vec::new(),
                Vec::new(),
                Vec::new(),
                Vec::new(),
                Vec::new(),
                Vec::new(),
            ];
            let n = h.ncols();
            let b: Vec<f64> = (0..n).map(|i| (i % 11) as f64 - 5.0).collect();
            // Warm-up, then interleaved rounds.
            for round in 0..=rounds {
                let t = Instant::now();
                mf.factorize(h.as_ref()).unwrap();
                let a = t.elapsed().as_secs_f64();
                let t = Instant::now();
                faer_driver.factorize(h.as_ref()).unwrap();
                let b2 = t.elapsed().as_secs_f64();
                let t = Instant::now();
                pool.install(|| split.factorize(h.as_ref())).unwrap();
                let c = t.elapsed().as_secs_f64();
                let t = Instant::now();
                mixed.factorize(h.as_ref()).unwrap();
                let d = t.elapsed().as_secs_f64();
                let mut x = b.clone();
                let t = Instant::now();
                mf.solve_in_place(&mut x).unwrap();
                let e = t.elapsed().as_secs_f64();
                x.copy_from_slice(&b);
                let t = Instant::now();
                mixed.solve_in_place(&mut x).unwrap();
                let f = t.elapsed().as_secs_f64();
                if round > 0 {
                    for (v, t) in times.iter_mut().zip([a, b2, c, d, e, f]) {
                        v.push(t);
                    }
                }
            }
            // Same solution from both drivers.
            let (mut x1, mut x2, mut x3, mut x4) = (b.clone(), b.clone(), b.clone(), b.clone());
            mixed.solve_in_place(&mut x4).unwrap();
            mf.solve_in_place(&mut x1).unwrap();
            faer_driver.solve_in_place(&mut x2).unwrap();
            pool.install(|| split.solve_in_place(&mut x3)).unwrap();
            let diff = |x: &[f64], y: &[f64]| {
                x.iter()
                    .zip(y)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
                    / y.iter().map(|a| a.abs()).fold(0.0, f64::max)
            };
            let [t_mf, t_faer, t_split, t_mixed, t_solve, t_refined] = times.map(median);
            println!(
                "L{level} {:>18} faces {:>6} n {:>7} flops {flops:.3e} split {}: multifrontal {:.1} ms ({:.1} GFlop/s), faer {:.1} ms ({:.1}), split 1t {:.1} ms ({:.1}); |x_mf − x_faer| {:.1e}, |x_split − x_faer| {:.1e}",
                sff.name(),
                sys.mesh().n_faces(),
                n,
                split.is_split(),
                t_mf * 1e3,
                flops / t_mf / 1e9,
                t_faer * 1e3,
                flops / t_faer / 1e9,
                t_split * 1e3,
                flops / t_split / 1e9,
                diff(&x1, &x2),
                diff(&x3, &x2),
            );
            let p = mixed.precision();
            println!(
                "    mixed precision: f32 factorisation {:.1} ms ({:.1} GFlop/s), refined solve {:.2} ms ({} f32 solves max, fallback {:?}) against the f64 solve {:.2} ms; |x_mixed − x_mf| {:.1e}",
                t_mixed * 1e3,
                flops / t_mixed / 1e9,
                t_refined * 1e3,
                p.max_refinement_steps,
                p.fallback,
                t_solve * 1e3,
                diff(&x4, &x1),
            );
        }
    }
}

/// Medians over `rounds` profiled factorisations, per width class and stage.
fn print_profile(
    mf: &mut SparseCholesky,
    h: &SparseColMat<usize, f64>,
    rounds: usize,
    level: usize,
    sff: SffKind,
) {
    let mut runs = Vec::new();
    for _ in 0..rounds.max(1) {
        runs.push(mf.factorize_profiled(h.as_ref()).unwrap().unwrap());
    }
    println!(
        "L{level} {}: class, supernodes, flops share, extend-add / cholesky / solve / update / other ms, GFlop/s",
        sff.name()
    );
    let total_flops: f64 = runs[0].classes.iter().map(|c| c.flops).sum();
    let names = ["1-3", "4-15", "16-63", "64-255", "256-1023", ">=1024"];
    let mut total = [0.0; 5];
    for (k, name) in names.iter().enumerate() {
        let med = |f: &dyn Fn(&thinshell_solver::linear::ClassProfile) -> f64| {
            median(runs.iter().map(|r| f(&r.classes[k])).collect())
        };
        let c = runs[0].classes[k];
        let t = [
            med(&|c| c.extend_add),
            med(&|c| c.cholesky),
            med(&|c| c.solve),
            med(&|c| c.update),
            med(&|c| c.other),
        ];
        for (a, b) in total.iter_mut().zip(t) {
            *a += b;
        }
        let sum: f64 = t.iter().sum();
        println!(
            "  {name:>9} {:>6} {:>5.1} % | {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>6.2} ms | {:>5.1} GFlop/s",
            c.supernodes,
            100.0 * c.flops / total_flops,
            t[0] * 1e3,
            t[1] * 1e3,
            t[2] * 1e3,
            t[3] * 1e3,
            t[4] * 1e3,
            c.flops / sum / 1e9
        );
    }
    let sum: f64 = total.iter().sum();
    println!(
        "  {:>9} {:>6} {:>5.1} % | {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>6.2} ms | {:>5.1} GFlop/s",
        "all",
        runs[0].classes.iter().map(|c| c.supernodes).sum::<usize>(),
        100.0,
        total[0] * 1e3,
        total[1] * 1e3,
        total[2] * 1e3,
        total[3] * 1e3,
        total[4] * 1e3,
        total_flops / sum / 1e9
    );
}

/// The rates of a front's three kernels for `w` columns and `r` rows below: the Cholesky of
/// the w × w block, the triangular solve of the r × w block, the r × r symmetric update.
fn kernels(r: usize, w: usize) {
    use faer::linalg::matmul::triangular::{self, BlockStructure};
    let reps = (2e9 / ((r * r * w) as f64)).max(3.0) as usize;
    let b = Mat::<f64>::from_fn(r, w, |i, j| ((i * 7 + j * 3) % 11) as f64 * 0.01);
    let mut l = Mat::<f64>::from_fn(w, w, |i, j| {
        if i == j {
            2.0
        } else if i > j {
            0.01
        } else {
            0.0
        }
    });
    for i in 0..w {
        l[(i, i)] = 2.0;
    }
    let mut x = b.clone();
    let mut u = Mat::<f64>::zeros(r, r);
    let time = |f: &mut dyn FnMut()| {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t = Instant::now();
            for _ in 0..reps {
                f();
            }
            best = best.min(t.elapsed().as_secs_f64() / reps as f64);
        }
        best
    };
    let t_solve = time(&mut || {
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            l.as_ref(),
            x.as_mut().transpose_mut(),
            Par::Seq,
        )
    });
    let t_update = time(&mut || {
        triangular::matmul(
            u.as_mut(),
            BlockStructure::TriangularLower,
            faer::Accum::Replace,
            b.as_ref(),
            BlockStructure::Rectangular,
            b.as_ref().transpose(),
            BlockStructure::Rectangular,
            -1.0,
            Par::Seq,
        )
    });
    let t_gemm = time(&mut || {
        faer::linalg::matmul::matmul(
            u.as_mut(),
            faer::Accum::Replace,
            b.as_ref(),
            b.as_ref().transpose(),
            -1.0,
            Par::Seq,
        )
    });
    let mut xt = Mat::<f64>::zeros(w, r);
    let t_copy = time(&mut || {
        xt.copy_from(x.as_ref().transpose());
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            l.as_ref(),
            xt.as_mut(),
            Par::Seq,
        );
        x.copy_from(xt.as_ref().transpose());
    });
    let mut linv = Mat::<f64>::zeros(w, w);
    let mut tmp = Mat::<f64>::zeros(r, w);
    let t_inv = time(&mut || {
        faer::linalg::triangular_inverse::invert_lower_triangular(
            linv.as_mut(),
            l.as_ref(),
            Par::Seq,
        );
        triangular::matmul(
            tmp.as_mut(),
            BlockStructure::Rectangular,
            faer::Accum::Replace,
            x.as_ref(),
            BlockStructure::Rectangular,
            linv.as_ref().transpose(),
            BlockStructure::TriangularUpper,
            1.0,
            Par::Seq,
        );
        x.copy_from(tmp.as_ref());
    });
    let (r, w) = (r as f64, w as f64);
    println!(
        "r {r} w {w}: solve {:.1} GFlop/s (transposed copy {:.1}, inverse {:.1}), lower update {:.1} GFlop/s, full product {:.1} GFlop/s",
        r * w * w / t_solve / 1e9,
        r * w * w / t_copy / 1e9,
        r * w * w / t_inv / 1e9,
        r * r * w / t_update / 1e9,
        2.0 * r * r * w / t_gemm / 1e9
    );
}
