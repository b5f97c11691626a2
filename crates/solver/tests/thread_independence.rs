//! The split factorisation gives bit-identical factors and solutions whatever the thread count
//! (docs/performance.md, "results independent of the thread count"): rayon pools of 1, 2 and 3
//! threads (`NewtonSettings::parallel`, the default, factorises with `Par::rayon(0)`: the pool's
//! size).
#![allow(clippy::unwrap_used)]

use faer::Par;
use faer::sparse::SparseColMat;
use thinshell_energy::{Assembler, SffKind};
use thinshell_solver::linear::FactorError;
use thinshell_solver::{Ordering, SparseCholesky};

/// The Hessian pattern of the level-4 shrinking sphere (7 686 dofs, large enough for the split)
/// with the values of `shift·I + L_w`, `L_w` a graph Laplacian with edge weights spread over
/// [0.5, 1.5] (so that the entries are not all alike and round-off differs between operation
/// orders). Positive definite for `shift > 0`, indefinite for `shift < 0`.
fn weighted_shell_laplacian(shift: f64) -> SparseColMat<usize, f64> {
    let (sys, _) = thinshell_testkit::fixtures::shrinking_sphere(4, SffKind::MidEdgeAverage);
    let mut h = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model())
        .unwrap()
        .hessian_template();
    let n = h.ncols();
    let col_ptr = h.symbolic().col_ptr().to_vec();
    let rows = h.symbolic().row_idx().to_vec();
    let weight = |p: usize| 0.5 + ((p * 7919) % 1000) as f64 / 1000.0;
    let mut degree = vec![0.0; n];
    for j in 0..n {
        for (p, &i) in rows
            .iter()
            .enumerate()
            .take(col_ptr[j + 1])
            .skip(col_ptr[j])
        {
            if i != j {
                degree[i] += weight(p);
                degree[j] += weight(p);
            }
        }
    }
    let val = h.val_mut();
    for j in 0..n {
        for p in col_ptr[j]..col_ptr[j + 1] {
            // `val` and `rows` share the index.
            val[p] = if rows[p] == j {
                degree[j] + shift
            } else {
                -weight(p)
            };
        }
    }
    h
}

/// y = A x for A given by its lower triangle.
fn sym_mul(a: &SparseColMat<usize, f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; x.len()];
    for j in 0..a.ncols() {
        for p in a.symbolic().col_range(j) {
            let i = a.symbolic().row_idx()[p];
            let v = a.val()[p];
            y[i] += v * x[j];
            if i != j {
                y[j] += v * x[i];
            }
        }
    }
    y
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Factorises `h` with `par` inside the current pool and solves for two right-hand sides; also
/// the failing pivot of the indefinite `bad`.
fn run(
    h: &SparseColMat<usize, f64>,
    bad: &SparseColMat<usize, f64>,
    rhs: &[Vec<f64>],
    par: Par,
) -> (bool, Vec<Vec<f64>>, usize) {
    let mut chol = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, par).unwrap();
    let pivot = match chol.factorize(bad.as_ref()) {
        Err(FactorError::NotPositiveDefinite { pivot }) => pivot,
        other => panic!("indefinite matrix accepted: {other:?}"),
    };
    chol.factorize(h.as_ref()).unwrap();
    let xs = rhs
        .iter()
        .map(|b| {
            let mut x = b.clone();
            chol.solve_in_place(&mut x).unwrap();
            x
        })
        .collect();
    (chol.is_split(), xs, pivot)
}

#[test]
fn split_factorisation_is_bit_identical_for_1_2_and_3_threads() {
    let h = weighted_shell_laplacian(1e-3);
    let bad = weighted_shell_laplacian(-1e-3);
    let n = h.ncols();
    let rhs = vec![
        (0..n)
            .map(|i| ((i * 7) % 13) as f64 - 6.0)
            .collect::<Vec<_>>(),
        (0..n).map(|i| (i as f64 * 0.37).sin()).collect::<Vec<_>>(),
    ];
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (split, reference, pivot) = one.install(|| run(&h, &bad, &rhs, Par::rayon(0)));
    assert!(split, "the level-4 sphere must take the split path");
    // The split's solutions against independent factorisations (faer on the whole matrix, same
    // ordering and AMD): the condition number is about 12/1e-3, so agreement to ~1e-10
    // relative.
    for ordering in [Ordering::Metis, Ordering::Amd] {
        let mut whole = SparseCholesky::new(h.symbolic(), ordering, None, Par::Seq).unwrap();
        assert!(!whole.is_split());
        whole.factorize(h.as_ref()).unwrap();
        for (b, x) in rhs.iter().zip(&reference) {
            let mut y = b.clone();
            whole.solve_in_place(&mut y).unwrap();
            let diff: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p - q).collect();
            assert!(
                max_abs(&diff) <= 1e-9 * max_abs(&y),
                "split vs {ordering:?} unsplit: {}",
                max_abs(&diff)
            );
            let r: Vec<f64> = sym_mul(&h, x).iter().zip(b).map(|(p, q)| p - q).collect();
            assert!(max_abs(&r) < 1e-10 * max_abs(b), "residual {}", max_abs(&r));
        }
    }
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        // Par::rayon(0): the pool's thread count, as `NewtonSettings::parallel` asks.
        for par in [Par::rayon(0), Par::rayon(threads)] {
            let (split, xs, p) = pool.install(|| run(&h, &bad, &rhs, par));
            assert!(split, "{threads} threads: not split");
            assert_eq!(p, pivot, "{threads} threads: failing pivot");
            for (x, r) in xs.iter().zip(&reference) {
                assert_eq!(bits(x), bits(r), "{threads} threads: solution differs");
            }
        }
    }
}
