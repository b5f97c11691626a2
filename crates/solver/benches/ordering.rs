//! AMD vs geometric nested dissection on the shell Hessian pattern.
//!
//! The pattern is that of the discrete-shell Hessian on a level-5 icosphere (10 242 vertices,
//! 20 480 faces, 30 726 dofs): every face couples its three vertices and its three flap
//! vertices (two rings), each coupling a dense 3×3 block. Values make the matrix diagonally
//! dominant (SPD); the cost of a Cholesky factorisation does not depend on them.
//!
//! Run: `cargo bench -p thinshell-solver --bench ordering`
#![allow(clippy::unwrap_used, missing_docs)]

use std::collections::{BTreeSet, HashMap};
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use faer::Par;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use thinshell_solver::{Ordering, SparseCholesky};

/// Icosphere (unit radius) by `level` midpoint subdivisions of an icosahedron.
fn icosphere(level: usize) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let normalize = |p: [f64; 3]| {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        [p[0] / r, p[1] / r, p[2] / r]
    };
    v.iter_mut().for_each(|p| *p = normalize(*p));
    for _ in 0..level {
        let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
        let mut nf = Vec::with_capacity(4 * f.len());
        for &[a, b, c] in &f {
            let mut m = |i: usize, j: usize| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    let p = [
                        (v[i][0] + v[j][0]) / 2.0,
                        (v[i][1] + v[j][1]) / 2.0,
                        (v[i][2] + v[j][2]) / 2.0,
                    ];
                    v.push(normalize(p));
                    v.len() - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            nf.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    (v, f)
}

/// Flat square sheet of `m × m` vertices, each grid cell split along alternating diagonals.
fn sheet(m: usize) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let v = (0..m * m)
        .map(|k| [(k / m) as f64, (k % m) as f64, 0.0])
        .collect();
    let mut f = Vec::new();
    for i in 0..m - 1 {
        for j in 0..m - 1 {
            let (a, b, c, d) = (
                i * m + j,
                (i + 1) * m + j,
                (i + 1) * m + j + 1,
                i * m + j + 1,
            );
            if (i + j) % 2 == 0 {
                f.extend_from_slice(&[[a, b, c], [a, c, d]]);
            } else {
                f.extend_from_slice(&[[a, b, d], [b, c, d]]);
            }
        }
    }
    (v, f)
}

/// Lower-triangle shell Hessian pattern (3 dofs per vertex) with SPD values, and per-dof
/// coordinates.
fn shell_matrix(v: &[[f64; 3]], f: &[[usize; 3]]) -> (SparseColMat<usize, f64>, Vec<[f64; 3]>) {
    let nv = v.len();
    let mut edge_faces: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (fi, t) in f.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[(e + 1) % 3], t[(e + 2) % 3]);
            edge_faces.entry((a.min(b), a.max(b))).or_default().push(fi);
        }
    }
    let mut vadj: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); nv];
    for (fi, t) in f.iter().enumerate() {
        let mut stencil = t.to_vec();
        for e in 0..3 {
            let (a, b) = (t[(e + 1) % 3], t[(e + 2) % 3]);
            for &g in &edge_faces[&(a.min(b), a.max(b))] {
                if g != fi {
                    stencil.extend(f[g].iter().copied().filter(|&x| x != a && x != b));
                }
            }
        }
        for &p in &stencil {
            for &q in &stencil {
                vadj[p].insert(q);
            }
        }
    }
    let n = 3 * nv;
    let mut col_ptr = vec![0usize];
    let mut rows = Vec::new();
    for j in 0..n {
        let vj = j / 3;
        for &vi in vadj[vj].range(vj..) {
            for a in 0..3 {
                let i = 3 * vi + a;
                if i >= j {
                    rows.push(i);
                }
            }
        }
        col_ptr.push(rows.len());
    }
    let mut offdiag = vec![0.0f64; n];
    for j in 0..n {
        for &i in &rows[col_ptr[j]..col_ptr[j + 1]] {
            if i != j {
                offdiag[i] += 1.0;
                offdiag[j] += 1.0;
            }
        }
    }
    let mut val = Vec::with_capacity(rows.len());
    for j in 0..n {
        for &i in &rows[col_ptr[j]..col_ptr[j + 1]] {
            val.push(if i == j { offdiag[j] + 1.0 } else { -1.0 });
        }
    }
    let sym = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
    let coords = (0..n).map(|d| v[d / 3]).collect();
    (SparseColMat::new(sym, val), coords)
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
        let mut pars = vec![("seq", Par::Seq)];
        if name == "nd_geometric" {
            pars.push(("rayon2", Par::rayon(2)));
        }
        for (pname, par) in pars {
            let mut chol = SparseCholesky::new(h.symbolic(), ordering, co, par).unwrap();
            group.bench_function(format!("numeric_{name}_{pname}"), |b| {
                b.iter(|| chol.factorize(black_box(h.as_ref())).unwrap())
            });
            let mut rhs = vec![1.0; n];
            group.bench_function(format!("solve_{name}_{pname}"), |b| {
                b.iter(|| chol.solve_in_place(black_box(&mut rhs)).unwrap())
            });
        }
    }
    group.finish();
}

fn bench_orderings(c: &mut Criterion) {
    let (v, f) = icosphere(5);
    let (h, coords) = shell_matrix(&v, &f);
    bench_pattern(c, "icosphere5", &h, &coords);
    let (v, f) = sheet(101);
    let (h, coords) = shell_matrix(&v, &f);
    bench_pattern(c, "sheet101", &h, &coords);
}

criterion_group!(benches, bench_orderings);
criterion_main!(benches);
