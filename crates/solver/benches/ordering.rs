//! AMD vs nested dissection (geometric, graph, METIS) on the shell Hessian pattern, and the
//! factorisation on one vs two threads.
//!
//! The pattern is that of the discrete-shell Hessian on a level-5 icosphere (10 242 vertices,
//! 20 480 faces, 30 726 dofs): every face couples its three vertices and its three flap
//! vertices (two rings), each coupling a dense 3×3 block. Values make the matrix diagonally
//! dominant (SPD); the cost of a Cholesky factorisation does not depend on them.
//!
//! `factorize_threads/{1_thread,1_thread_split,2_threads}`: the numeric factorisation with the
//! default (METIS) ordering at 20 480 faces with `Par::Seq` (faer, unsplit), `Par::rayon(1)`
//! (the split over the two halves of the top-level dissection, `SparseCholesky::new`, run one
//! half after the other: the default `NewtonSettings::parallel` on one thread, same bits as on
//! two) and `Par::rayon(2)` (the split, halves concurrent); the two-thread figure is meaningful
//! on an idle machine with at least two cores only.
//!
//! Run: `cargo bench -p thinshell-solver --bench ordering`
#![allow(clippy::unwrap_used, missing_docs)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use faer::Par;
use faer::sparse::SparseColMat;
use thinshell_energy::{Assembler, DofMap, Terms};
use thinshell_mesh::{Mesh, generators};
use thinshell_solver::{Ordering, SparseCholesky};

/// The energy assembler's lower-triangle Hessian pattern of `mesh` (stretching + bending: face
/// and flap vertices, 3 dofs each) with diagonally dominant SPD values, and per-dof coordinates.
fn shell_matrix(mesh: &Mesh) -> (SparseColMat<usize, f64>, Vec<[f64; 3]>) {
    let n_v = mesh.n_vertices();
    let dofs = DofMap::all_free(n_v);
    let terms = Terms::ELASTIC;
    let mut h = Assembler::new(mesh, &dofs, terms)
        .unwrap()
        .hessian_template();
    let n = h.ncols();
    let (col_ptr, rows) = (
        h.symbolic().col_ptr().to_vec(),
        h.symbolic().row_idx().to_vec(),
    );
    let mut offdiag = vec![0.0f64; n];
    for j in 0..n {
        for &i in &rows[col_ptr[j]..col_ptr[j + 1]] {
            if i != j {
                offdiag[i] += 1.0;
                offdiag[j] += 1.0;
            }
        }
    }
    let val = h.val_mut();
    for j in 0..n {
        for (k, &i) in rows[col_ptr[j]..col_ptr[j + 1]].iter().enumerate() {
            val[col_ptr[j] + k] = if i == j { offdiag[j] + 1.0 } else { -1.0 };
        }
    }
    let x = mesh.positions();
    let coords = (0..n)
        .map(|d| [x[d / 3].x, x[d / 3].y, x[d / 3].z])
        .collect();
    (h, coords)
}

fn bench_pattern(
    c: &mut Criterion,
    label: &str,
    h: &SparseColMat<usize, f64>,
    coords: &[[f64; 3]],
) {
    let n = h.ncols();
    let cases = [
        ("amd", Ordering::Amd, None),
        ("nd_geometric", Ordering::NestedDissection, Some(coords)),
        ("nd_graph", Ordering::NestedDissection, None),
        ("metis", Ordering::Metis, None),
    ];
    for (name, ordering, co) in cases {
        let chol = SparseCholesky::new(h.symbolic(), ordering, co, Par::Seq).unwrap();
        let s = chol.stats();
        eprintln!(
            "{label} {name}: n = {n}, nnz(lower A) = {}, len(L) = {}, predicted flops = {:.3e}, supernodal = {}",
            s.nnz_lower, s.factor_len, s.flops, s.supernodal
        );
    }
    let mut group = c.benchmark_group(label);
    group.sample_size(10);
    for (name, ordering, co) in cases {
        group.bench_function(format!("symbolic_{name}"), |b| {
            b.iter(|| black_box(SparseCholesky::new(h.symbolic(), ordering, co, Par::Seq).unwrap()))
        });
        let mut chol = SparseCholesky::new(h.symbolic(), ordering, co, Par::Seq).unwrap();
        group.bench_function(format!("numeric_{name}_seq"), |b| {
            b.iter(|| chol.factorize(black_box(h.as_ref())).unwrap())
        });
        let mut rhs = vec![1.0; n];
        group.bench_function(format!("solve_{name}_seq"), |b| {
            b.iter(|| chol.solve_in_place(black_box(&mut rhs)).unwrap())
        });
    }
    group.finish();
}

/// One thread (unsplit and split) vs two threads, the default ordering, 20 480 faces.
fn bench_threads(c: &mut Criterion, h: &SparseColMat<usize, f64>) {
    let mut group = c.benchmark_group("factorize_threads");
    group.sample_size(10);
    for (name, par) in [
        ("1_thread", Par::Seq),
        ("1_thread_split", Par::rayon(1)),
        ("2_threads", Par::rayon(2)),
    ] {
        let mut chol = SparseCholesky::new(h.symbolic(), Ordering::default(), None, par).unwrap();
        let s = chol.stats();
        eprintln!(
            "factorize_threads {name}: split = {}, predicted flops = {:.3e}, split parts [A, B, dense] = {:?}",
            chol.is_split(),
            s.flops,
            chol.split_flops()
        );
        group.bench_function(name, |b| {
            b.iter(|| chol.factorize(black_box(h.as_ref())).unwrap())
        });
        let mut rhs = vec![1.0; h.ncols()];
        group.bench_function(format!("solve_{name}"), |b| {
            b.iter(|| chol.solve_in_place(black_box(&mut rhs)).unwrap())
        });
    }
    group.finish();
}

fn bench_orderings(c: &mut Criterion) {
    let (h, coords) = shell_matrix(&generators::icosphere(1.0, 5).unwrap());
    bench_threads(c, &h);
    bench_pattern(c, "icosphere5", &h, &coords);
    // 101 × 101 vertices.
    let (h, coords) = shell_matrix(&generators::rectangle(100.0, 100.0, 100, 100).unwrap());
    bench_pattern(c, "sheet101", &h, &coords);
}

criterion_group!(benches, bench_orderings);
criterion_main!(benches);
