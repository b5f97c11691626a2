//! Predicted factorisation flops (and optionally the measured sequential factorisation time,
//! best of 3) of every ordering on the Hessian pattern of the shrinking-sphere benchmark, for
//! the mid-edge average and the edge-director form. The numbers in the `ordering` module docs
//! and docs/performance.md come from here.
//!
//! Run: `cargo run --release -p thinshell-solver --example ordering_flops -- 3,4,5,6 [1]`
//! (icosphere levels; a second argument `1` also times the numeric factorisation, `threads`
//! compares one and two threads, `one` / `two` only factorise 10 times on one / two threads,
//! for `perf stat`; `sheet` prints the flops of the METIS orderings and geometric nested
//! dissection on the flat 101 × 101 sheet of the `ordering` bench instead; `supernodes` how the
//! default ordering's predicted flops spread over the supernode widths; `relax` times faer's
//! default supernode amalgamation against coarser ones, interleaved).
#![allow(clippy::unwrap_used, clippy::type_complexity, missing_docs)]
mod common;
use std::time::Instant;

use common::spd;
use faer::Par;
use faer::Side;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky,
};
use thinshell_energy::{Assembler, SffKind};
use thinshell_solver::linear::factor_flops;
use thinshell_solver::ordering::{
    DEFAULT_LEAF_SIZE, METIS_LEAF_SIZE, inverse_permutation, metis_nested_dissection,
    metis_node_nd, nested_dissection,
};
use thinshell_testkit::fixtures::shrinking_sphere;

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
    if mode == "relax" {
        return relax(&levels);
    }
    if mode == "supernodes" {
        return supernodes(&levels);
    }
    if mode == "sheet" {
        return sheet();
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
            cases.push((
                "node_nd".into(),
                Box::new(move || Some(metis_node_nd(hh.symbolic()).unwrap())),
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

/// Predicted flops on the flat 101 × 101 sheet of the `ordering` bench (3 dofs per vertex):
/// METIS's NodeND, the METIS-bisection dissection and geometric nested dissection.
fn sheet() {
    use thinshell_energy::{DofMap, Terms};
    let mesh = thinshell_mesh::generators::rectangle(100.0, 100.0, 100, 100).unwrap();
    let dofs = DofMap::all_free(mesh.n_vertices());
    let h = Assembler::new(&mesh, &dofs, Terms::ELASTIC)
        .unwrap()
        .hessian_template();
    let n = h.ncols();
    let x = mesh.positions();
    let coords: Vec<[f64; 3]> = (0..n)
        .map(|d| [x[d / 3].x, x[d / 3].y, x[d / 3].z])
        .collect();
    let flops = |fwd: &[usize]| {
        let inv = inverse_permutation(fwd);
        let sym = factorize_symbolic_cholesky(
            h.symbolic(),
            Side::Lower,
            SymmetricOrdering::Custom(PermRef::new_checked(fwd, &inv, n)),
            CholeskySymbolicParams::default(),
        )
        .unwrap();
        factor_flops(&sym)
    };
    let p = h.symbolic();
    println!(
        "sheet101 n {n}: node_nd {:.3e}, metis bisections {:.3e}, nd_geo {:.3e}",
        flops(&metis_node_nd(p).unwrap()),
        flops(&metis_nested_dissection(p, METIS_LEAF_SIZE).unwrap()),
        flops(&nested_dissection(p, Some(&coords), DEFAULT_LEAF_SIZE).unwrap()),
    );
}

/// The default (METIS NodeND) factor's supernodes by width: count, share of the columns and of
/// the predicted flops (Σ over columns of the squared column counts), mid-edge average.
fn supernodes(levels: &[usize]) {
    use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
    use thinshell_solver::ordering::metis_node_nd;
    for &level in levels {
        let (sys, _) = shrinking_sphere(level, SffKind::MidEdgeAverage);
        let asm = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model()).unwrap();
        let h = asm.hessian_template();
        let n = h.ncols();
        let fwd = metis_node_nd(h.symbolic()).unwrap();
        let inv = inverse_permutation(&fwd);
        let sym = factorize_symbolic_cholesky(
            h.symbolic(),
            Side::Lower,
            SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, n)),
            CholeskySymbolicParams::default(),
        )
        .unwrap();
        let SymbolicCholeskyRaw::Supernodal(sn) = sym.raw() else {
            println!("L{level}: simplicial");
            continue;
        };
        let bounds = [1usize, 4, 16, 64, 256, 1024, usize::MAX];
        let mut count = vec![0usize; bounds.len() - 1];
        let mut cols = vec![0usize; bounds.len() - 1];
        let mut fl = vec![0f64; bounds.len() - 1];
        let (begin, end) = (sn.supernode_begin(), sn.supernode_end());
        let mut total = 0.0;
        for k in 0..sn.n_supernodes() {
            let w = end[k] - begin[k];
            let below = sn.supernode(k).pattern().len();
            let f: f64 = (1..=w).map(|c| ((c + below) as f64).powi(2)).sum();
            let b = bounds
                .windows(2)
                .position(|p| w >= p[0] && w < p[1])
                .unwrap();
            count[b] += 1;
            cols[b] += w;
            fl[b] += f;
            total += f;
        }
        println!(
            "L{level} n {n}: {} supernodes, flops {total:.3e}",
            sn.n_supernodes()
        );
        for b in 0..count.len() {
            println!(
                "  width [{}, {}): {:>6} supernodes, {:>5.1} % of columns, {:>5.1} % of flops",
                bounds[b],
                if bounds[b + 1] == usize::MAX {
                    "∞".to_string()
                } else {
                    bounds[b + 1].to_string()
                },
                count[b],
                100.0 * cols[b] as f64 / n as f64,
                100.0 * fl[b] / total
            );
        }
    }
}

/// Sequential factorisation with faer's default supernode amalgamation against coarser ones
/// (more explicit zeros, fewer and wider supernodes), the default ordering, mid-edge average;
/// interleaved rounds, medians.
fn relax(levels: &[usize]) {
    use faer::sparse::linalg::SymbolicSupernodalParams;
    use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
    use thinshell_solver::ordering::metis_node_nd;
    let variants: [(&str, &[(usize, f64)]); 3] = [
        (
            "default",
            &[(4, 1.0), (16, 0.8), (48, 0.1), (usize::MAX, 0.05)],
        ),
        (
            "coarser",
            &[(16, 1.0), (48, 0.4), (128, 0.15), (usize::MAX, 0.05)],
        ),
        (
            "coarsest",
            &[(32, 1.0), (96, 0.5), (256, 0.2), (usize::MAX, 0.1)],
        ),
    ];
    for &level in levels {
        let (sys, _) = shrinking_sphere(level, SffKind::MidEdgeAverage);
        let asm = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model()).unwrap();
        let mut h = asm.hessian_template();
        spd(&mut h);
        let n = h.ncols();
        let fwd = metis_node_nd(h.symbolic()).unwrap();
        let inv = inverse_permutation(&fwd);
        let mut cases: Vec<_> = variants
            .iter()
            .map(|&(name, relax)| {
                let sym = factorize_symbolic_cholesky(
                    h.symbolic(),
                    Side::Lower,
                    SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, n)),
                    CholeskySymbolicParams {
                        supernodal_params: SymbolicSupernodalParams { relax: Some(relax) },
                        ..Default::default()
                    },
                )
                .unwrap();
                let l = vec![0.0; sym.len_val()];
                let mem = faer::dyn_stack::MemBuffer::new(
                    sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
                );
                (name, sym, l, mem, Vec::new())
            })
            .collect();
        for _ in 0..5 {
            for (_, sym, l, mem, times) in cases.iter_mut() {
                let t = Instant::now();
                sym.factorize_numeric_llt(
                    l,
                    h.as_ref(),
                    Side::Lower,
                    Default::default(),
                    Par::Seq,
                    faer::dyn_stack::MemStack::new(mem),
                    Default::default(),
                )
                .unwrap();
                times.push(t.elapsed().as_secs_f64());
            }
        }
        for (name, sym, _, _, times) in cases.iter_mut() {
            times.sort_by(f64::total_cmp);
            let sn = match sym.raw() {
                SymbolicCholeskyRaw::Supernodal(s) => s.n_supernodes(),
                SymbolicCholeskyRaw::Simplicial(_) => 0,
            };
            let f = factor_flops(sym);
            println!(
                "L{level} {name:>9}: {sn:>6} supernodes, flops {f:.3e}, median {:.3}s, {:.1} GFlop/s",
                times[2],
                f / times[2] / 1e9
            );
        }
    }
}
