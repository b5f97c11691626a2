//! Predicted factorisation flops (and optionally the measured sequential factorisation time,
//! best of 3) of every ordering on the Hessian pattern of the shrinking-sphere benchmark, for
//! the mid-edge average and the edge-director form. The numbers in the `ordering` module docs
//! and docs/performance.md come from here.
//!
//! Run: `cargo run --release -p thinshell-solver --example ordering_flops -- 3,4,5,6 [1]`
//! (icosphere levels; a second argument `1` also times the numeric factorisation, `threads`
//! compares one and two threads, `one` / `two` only factorise 10 times on one / two threads,
//! for `perf stat`).
#![allow(clippy::unwrap_used, clippy::type_complexity, missing_docs)]
use std::time::Instant;

use faer::Par;
use faer::Side;
use faer::perm::PermRef;
use faer::sparse::SparseColMat;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky,
};
use thinshell_energy::{Assembler, SffKind};
use thinshell_solver::linear::factor_flops;
use thinshell_solver::ordering::{
    DEFAULT_LEAF_SIZE, METIS_LEAF_SIZE, inverse_permutation, metis_nested_dissection,
    nested_dissection,
};
use thinshell_testkit::fixtures::shrinking_sphere;

fn spd(h: &mut SparseColMat<usize, f64>) {
    let n = h.ncols();
    let (cp, rows) = (
        h.symbolic().col_ptr().to_vec(),
        h.symbolic().row_idx().to_vec(),
    );
    let mut off = vec![0.0; n];
    for j in 0..n {
        for &i in &rows[cp[j]..cp[j + 1]] {
            if i != j {
                off[i] += 1.0;
                off[j] += 1.0;
            }
        }
    }
    let val = h.val_mut();
    for j in 0..n {
        for (k, &i) in rows[cp[j]..cp[j + 1]].iter().enumerate() {
            val[cp[j] + k] = if i == j { off[j] + 1.0 } else { -1.0 };
        }
    }
}

fn main() {
    let levels: Vec<usize> = std::env::args()
        .nth(1)
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![3, 4, 5]);
    let mode = std::env::args().nth(2).unwrap_or_default();
    let numeric = mode == "1";
    if mode == "threads" {
        return threads(&levels);
    }
    if mode == "one" || mode == "two" {
        return repeat(&levels, mode == "two");
    }
    for level in levels {
        for sff in [SffKind::MidEdgeAverage, SffKind::default()] {
            let (sys, _) = shrinking_sphere(level, sff);
            let asm = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model()).unwrap();
            let mut h = asm.hessian_template();
            spd(&mut h);
            let n = h.ncols();
            let p = sys.mesh().positions();
            let edges = sys.mesh().topology().edges();
            let n3 = 3 * p.len();
            let coords: Vec<[f64; 3]> = sys
                .dofs()
                .free_coordinates()
                .iter()
                .map(|&c| {
                    let q = if c < n3 {
                        p[c / 3]
                    } else {
                        let e = &edges[c - n3];
                        (p[e.vertices[0].idx()] + p[e.vertices[1].idx()]) * 0.5
                    };
                    [q.x, q.y, q.z]
                })
                .collect();
            let mut cases: Vec<(String, Box<dyn Fn() -> Option<Vec<usize>>>)> = vec![
                ("amd".into(), Box::new(|| None)),
                (
                    "nd_geo".into(),
                    Box::new(|| {
                        Some(
                            nested_dissection(h.symbolic(), Some(&coords), DEFAULT_LEAF_SIZE)
                                .unwrap(),
                        )
                    }),
                ),
                (
                    "nd_graph".into(),
                    Box::new(|| {
                        Some(nested_dissection(h.symbolic(), None, DEFAULT_LEAF_SIZE).unwrap())
                    }),
                ),
            ];
            let hh = &h;
            cases.push((
                "metis".into(),
                Box::new(move || {
                    Some(metis_nested_dissection(hh.symbolic(), METIS_LEAF_SIZE).unwrap())
                }),
            ));
            for (name, f) in &cases {
                let t = Instant::now();
                let fwd = f();
                let t_ord = t.elapsed().as_secs_f64();
                let sym = match &fwd {
                    None => factorize_symbolic_cholesky(
                        h.symbolic(),
                        Side::Lower,
                        SymmetricOrdering::Amd,
                        CholeskySymbolicParams::default(),
                    )
                    .unwrap(),
                    Some(fwd) => {
                        let inv = inverse_permutation(fwd);
                        factorize_symbolic_cholesky(
                            h.symbolic(),
                            Side::Lower,
                            SymmetricOrdering::Custom(PermRef::new_checked(fwd, &inv, n)),
                            CholeskySymbolicParams::default(),
                        )
                        .unwrap()
                    }
                };
                let mut tnum = f64::NAN;
                if numeric {
                    let mut l = vec![0.0; sym.len_val()];
                    let mut mem = faer::dyn_stack::MemBuffer::new(
                        sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
                    );
                    let mut best = f64::INFINITY;
                    for _ in 0..3 {
                        let t = Instant::now();
                        sym.factorize_numeric_llt(
                            &mut l,
                            h.as_ref(),
                            Side::Lower,
                            Default::default(),
                            Par::Seq,
                            faer::dyn_stack::MemStack::new(&mut mem),
                            Default::default(),
                        )
                        .unwrap();
                        best = best.min(t.elapsed().as_secs_f64());
                    }
                    tnum = best;
                }
                println!(
                    "L{level} {:>18} faces {:>6} n {:>7} {:>9}: flops {:.3e} len {:>10} order {:.3}s num {:.3}s",
                    sff.name(),
                    sys.mesh().n_faces(),
                    n,
                    name,
                    factor_flops(&sym),
                    sym.len_val(),
                    t_ord,
                    tnum
                );
            }
        }
    }
}

/// Sequential vs two-thread (split) factorisation with the METIS ordering, interleaved rounds;
/// prints the medians.
fn threads(levels: &[usize]) {
    use thinshell_solver::{Ordering, SparseCholesky};
    for &level in levels {
        for sff in [SffKind::MidEdgeAverage, SffKind::default()] {
            let (sys, _) = shrinking_sphere(level, sff);
            let asm = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model()).unwrap();
            let mut h = asm.hessian_template();
            spd(&mut h);
            let mut seq =
                SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
            let mut two =
                SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::rayon(2)).unwrap();
            let (mut ts, mut tp) = (Vec::new(), Vec::new());
            for _ in 0..7 {
                let t = Instant::now();
                seq.factorize(h.as_ref()).unwrap();
                ts.push(t.elapsed().as_secs_f64());
                let t = Instant::now();
                two.factorize(h.as_ref()).unwrap();
                tp.push(t.elapsed().as_secs_f64());
            }
            ts.sort_by(f64::total_cmp);
            tp.sort_by(f64::total_cmp);
            let total = seq.stats().flops;
            let [a, b, d] = two.split_flops().unwrap_or([total, 0.0, 0.0]);
            println!(
                "L{level} {:>18} n {:>7}: flops 1 thread {total:.3e}, split halves {a:.3e} + {b:.3e}, dense {d:.3e}: critical path / sequential {:.2} (dense on 1 thread) {:.2} (on 2)",
                sff.name(),
                h.ncols(),
                (a.max(b) + d) / total,
                (a.max(b) + d / 2.0) / total,
            );
            println!(
                "   split {} 1 thread {:.3}s, 2 threads {:.3}s, ratio {:.2}",
                two.is_split(),
                ts[3],
                tp[3],
                ts[3] / tp[3]
            );
        }
    }
}

/// Ten factorisations with the METIS ordering on one or two threads (mid-edge average), for
/// `perf stat -e task-clock`: CPUs utilised shows whether the second thread works.
fn repeat(levels: &[usize], two: bool) {
    use thinshell_solver::{Ordering, SparseCholesky};
    for &level in levels {
        let (sys, _) = shrinking_sphere(level, SffKind::MidEdgeAverage);
        let asm = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model()).unwrap();
        let mut h = asm.hessian_template();
        spd(&mut h);
        let par = if two { Par::rayon(2) } else { Par::Seq };
        let mut chol = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, par).unwrap();
        let t = Instant::now();
        for _ in 0..10 {
            chol.factorize(h.as_ref()).unwrap();
        }
        println!(
            "L{level}: split {}, 10 factorisations {:.3}s",
            chol.is_split(),
            t.elapsed().as_secs_f64()
        );
    }
}
