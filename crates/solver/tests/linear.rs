//! Sparse Cholesky with reused symbolic analysis, regularisation and pattern checks.
#![allow(clippy::unwrap_used)]

use faer::Par;
use faer::sparse::{SparseColMat, Triplet};
use thinshell_solver::linear::{FactorError, RegularizationKind, RegularizationParams};
use thinshell_solver::{Ordering, SolverError, SparseCholesky};

/// Lower triangle of `shift·I + Laplacian` of an `m × m` grid with 8-neighbour stencil
/// (eigenvalues of the Laplacian in [0, 16)), plus the grid coordinates.
fn grid(m: usize, shift: f64) -> (SparseColMat<usize, f64>, Vec<[f64; 3]>) {
    let id = |i: usize, j: usize| i * m + j;
    let mut t = Vec::new();
    let mut deg = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            for (di, dj) in [(0i64, 1i64), (1, -1), (1, 0), (1, 1)] {
                let (ii, jj) = (i as i64 + di, j as i64 + dj);
                if ii < m as i64 && jj >= 0 && jj < m as i64 {
                    let (a, b) = (id(i, j), id(ii as usize, jj as usize));
                    t.push(Triplet::new(a.max(b), a.min(b), -1.0));
                    deg[a] += 1.0;
                    deg[b] += 1.0;
                }
            }
        }
    }
    for (v, d) in deg.iter().enumerate() {
        t.push(Triplet::new(v, v, d + shift));
    }
    let coords = (0..m * m)
        .map(|v| [(v / m) as f64, (v % m) as f64, 0.0])
        .collect();
    (
        SparseColMat::try_new_from_triplets(m * m, m * m, &t).unwrap(),
        coords,
    )
}

/// y = A x for A given by its lower triangle.
fn sym_mul(a: &SparseColMat<usize, f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; x.len()];
    for j in 0..a.ncols() {
        let range = a.symbolic().col_range(j);
        for p in range {
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

#[test]
fn solves_spd_systems_with_every_ordering_and_refactorises() {
    let (a, coords) = grid(20, 0.5);
    let n = a.ncols();
    let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 13) as f64 - 6.0).collect();
    for ordering in [
        Ordering::Amd,
        Ordering::NestedDissection,
        Ordering::Metis,
        Ordering::Auto,
    ] {
        for c in [Some(coords.as_slice()), None] {
            for par in [Par::Seq, Par::rayon(2)] {
                let mut chol = SparseCholesky::new(a.symbolic(), ordering, c, par).unwrap();
                chol.factorize(a.as_ref()).unwrap();
                let mut x = b.clone();
                chol.solve_in_place(&mut x).unwrap();
                let r: Vec<f64> = sym_mul(&a, &x).iter().zip(&b).map(|(p, q)| p - q).collect();
                // Condition number ≤ 16.5/0.5: residual at round-off.
                assert!(
                    max_abs(&r) < 1e-12 * max_abs(&b),
                    "{ordering:?}: residual {}",
                    max_abs(&r)
                );
                // Same pattern, new values (2A): the solution halves.
                let mut a2 = a.clone();
                a2.val_mut().iter_mut().for_each(|v| *v *= 2.0);
                chol.factorize(a2.as_ref()).unwrap();
                let mut x2 = b.clone();
                chol.solve_in_place(&mut x2).unwrap();
                for (p, q) in x2.iter().zip(&x) {
                    assert!((2.0 * p - q).abs() < 1e-12 * max_abs(&x));
                }
            }
        }
    }
}

#[test]
fn orderings_beat_the_natural_band() {
    // A 40 × 40 grid, 8-neighbour stencil: the natural (banded, half-bandwidth 41) order costs
    // about n·41² flops; fill-reducing orderings must do clearly better, and the geometric
    // nested dissection must be close to AMD already at this small size (it wins at large n,
    // see the `ordering` bench).
    let (a, coords) = grid(40, 0.5);
    let nd = SparseCholesky::new(
        a.symbolic(),
        Ordering::NestedDissection,
        Some(&coords),
        Par::Seq,
    )
    .unwrap();
    let nd_graph =
        SparseCholesky::new(a.symbolic(), Ordering::NestedDissection, None, Par::Seq).unwrap();
    let amd = SparseCholesky::new(a.symbolic(), Ordering::Amd, None, Par::Seq).unwrap();
    let natural_flops = 1600.0 * 41.0 * 41.0;
    for s in [amd.stats(), nd_graph.stats(), nd.stats()] {
        assert!(s.flops < 0.7 * natural_flops, "{s:?}");
        assert!(s.factor_len >= a.val().len());
    }
    assert!(
        nd.stats().flops < 1.25 * amd.stats().flops,
        "{:?} vs {:?}",
        nd.stats(),
        amd.stats()
    );
}

#[test]
fn indefinite_matrix_is_regularised_and_restored() {
    // Laplacian − 2 I: eigenvalues in [−2, 14), indefinite.
    let (mut a, _) = grid(12, -2.0);
    let original = a.val().to_vec();
    let mut chol = SparseCholesky::new(a.symbolic(), Ordering::Amd, None, Par::Seq).unwrap();
    assert!(matches!(
        chol.factorize(a.as_ref()),
        Err(FactorError::NotPositiveDefinite { .. })
    ));
    // The failed factorisation leaves no factor to solve with.
    assert!(matches!(
        chol.solve_in_place(&mut vec![0.0; a.ncols()]),
        Err(SolverError::Linear(_))
    ));
    let params = RegularizationParams::default();
    let mut mu = 0.0;
    let out = chol
        .factorize_regularized(&mut a, &params, &mut mu)
        .unwrap();
    assert_eq!(a.val(), original.as_slice(), "matrix not restored");
    assert!(out.mu > 0.0 && mu == out.mu);
    assert!(out.attempts >= 2);
    // μ grows by ×10 from 1e-6: the successful one is 1e-6·10^(attempts−2).
    let expected = params.initial * params.growth.powi(out.attempts as i32 - 2);
    assert!((out.mu - expected).abs() < 1e-12 * expected);
    // The shift is μ times the mean |diagonal|, and must exceed the most negative eigenvalue
    // (> 2 − 16·(1 − cos(π/13))² margin; simply: > 0 and the factor solves A + shift·I).
    let mean_diag: f64 = chol
        .diagonal_offsets()
        .iter()
        .map(|&o| original[o].abs())
        .sum::<f64>()
        / a.ncols() as f64;
    assert!((out.max_shift - out.mu * mean_diag).abs() < 1e-12 * out.max_shift);
    let b: Vec<f64> = (0..a.ncols()).map(|i| (i % 5) as f64).collect();
    let mut x = b.clone();
    chol.solve_in_place(&mut x).unwrap();
    let ax = sym_mul(&a, &x);
    let r: Vec<f64> = ax
        .iter()
        .zip(&x)
        .zip(&b)
        .map(|((ax, x), b)| ax + out.max_shift * x - b)
        .collect();
    assert!(max_abs(&r) < 1e-9 * max_abs(&b), "residual {}", max_abs(&r));

    // Memory: on a positive definite matrix the remembered shift shrinks ×0.1 per success
    // until it falls below `initial`, then factorisations are unshifted again.
    let (spd, _) = grid(12, 1.0);
    let mut spd = spd;
    let mut remembered = mu;
    loop {
        let o = chol
            .factorize_regularized(&mut spd, &params, &mut mu)
            .unwrap();
        assert_eq!(o.attempts, 1);
        let shrunk = remembered * params.shrink;
        if shrunk >= params.initial {
            assert!((o.mu - shrunk).abs() < 1e-12 * shrunk);
        } else {
            assert_eq!(o.mu, 0.0);
            break;
        }
        remembered = mu;
    }
    // The diagonal variant shifts each dof by μ·|H_dd|.
    let diag = RegularizationParams {
        kind: RegularizationKind::Diagonal,
        ..params
    };
    let mut mu = 0.0;
    let out = chol.factorize_regularized(&mut a, &diag, &mut mu).unwrap();
    let max_diag = chol
        .diagonal_offsets()
        .iter()
        .map(|&o| original[o].abs())
        .fold(0.0, f64::max);
    assert!((out.max_shift - out.mu * max_diag).abs() < 1e-12 * out.max_shift);
    // Without shifted attempts the failure is reported.
    let none = RegularizationParams {
        max_attempts: 0,
        ..params
    };
    let mut mu = 0.0;
    assert!(matches!(
        chol.factorize_regularized(&mut a, &none, &mut mu),
        Err(FactorError::NotPositiveDefinite { .. })
    ));
}

#[test]
fn nan_matrix_is_not_factorised() {
    let (mut a, _) = grid(5, 1.0);
    a.val_mut()[3] = f64::NAN;
    let mut chol = SparseCholesky::new(a.symbolic(), Ordering::Amd, None, Par::Seq).unwrap();
    let params = RegularizationParams {
        max_attempts: 3,
        ..Default::default()
    };
    let mut mu = 0.0;
    assert!(
        chol.factorize_regularized(&mut a, &params, &mut mu)
            .is_err()
    );
}

#[test]
fn bad_patterns_are_rejected() {
    // Missing diagonal in column 1.
    let t = [
        Triplet::new(0, 0, 1.0),
        Triplet::new(2, 1, 1.0),
        Triplet::new(2, 2, 1.0),
    ];
    let a = SparseColMat::try_new_from_triplets(3, 3, &t).unwrap();
    assert_eq!(
        SparseCholesky::new(a.symbolic(), Ordering::Amd, None, Par::Seq).unwrap_err(),
        SolverError::InvalidPattern {
            dof: 1,
            reason: "diagonal entry missing"
        }
    );
    // Upper-triangle entry in column 2.
    let t = [
        Triplet::new(0, 0, 1.0),
        Triplet::new(1, 1, 1.0),
        Triplet::new(2, 2, 1.0),
        Triplet::new(0, 2, 1.0),
    ];
    let a = SparseColMat::try_new_from_triplets(3, 3, &t).unwrap();
    assert!(matches!(
        SparseCholesky::new(a.symbolic(), Ordering::Amd, None, Par::Seq),
        Err(SolverError::InvalidPattern { dof: 2, .. })
    ));
    // A matrix with another pattern is refused by factorize.
    let (g, _) = grid(3, 1.0);
    let (h, _) = grid(3, 1.0);
    let mut chol = SparseCholesky::new(g.symbolic(), Ordering::Amd, None, Par::Seq).unwrap();
    let other = SparseColMat::try_new_from_triplets(
        9,
        9,
        &(0..9).map(|i| Triplet::new(i, i, 1.0)).collect::<Vec<_>>(),
    )
    .unwrap();
    assert!(matches!(
        chol.factorize(other.as_ref()),
        Err(FactorError::Other(_))
    ));
    assert!(chol.factorize(h.as_ref()).is_ok());
    // Coordinates must match and be finite.
    let mut coords = vec![[0.0; 3]; 9];
    coords[4][1] = f64::INFINITY;
    assert_eq!(
        SparseCholesky::new(
            g.symbolic(),
            Ordering::NestedDissection,
            Some(&coords),
            Par::Seq
        )
        .unwrap_err(),
        SolverError::NonFiniteCoordinate { dof: 4 }
    );
    assert!(matches!(
        SparseCholesky::new(
            g.symbolic(),
            Ordering::NestedDissection,
            Some(&coords[..5]),
            Par::Seq
        ),
        Err(SolverError::DimensionMismatch { .. })
    ));
}

/// The Hessian pattern of the level-4 shrinking sphere (7 686 dofs, the shell's two-ring
/// stencil) with the values of `shift·I + graph Laplacian` (eigenvalues ≥ shift when positive;
/// a negative shift makes it indefinite).
fn shell_laplacian(shift: f64) -> SparseColMat<usize, f64> {
    use thinshell_energy::{Assembler, SffKind};
    let (sys, _) = thinshell_testkit::fixtures::shrinking_sphere(4, SffKind::MidEdgeAverage);
    let mut h = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model())
        .unwrap()
        .hessian_template();
    let n = h.ncols();
    let col_ptr = h.symbolic().col_ptr().to_vec();
    let rows = h.symbolic().row_idx().to_vec();
    let mut degree = vec![0.0; n];
    for j in 0..n {
        for &i in &rows[col_ptr[j]..col_ptr[j + 1]] {
            if i != j {
                degree[i] += 1.0;
                degree[j] += 1.0;
            }
        }
    }
    let val = h.val_mut();
    for j in 0..n {
        for p in col_ptr[j]..col_ptr[j + 1] {
            val[p] = if rows[p] == j {
                degree[j] + shift
            } else {
                -1.0
            };
        }
    }
    h
}

/// With the METIS ordering and enough flops the factorisation is split over the two halves of
/// the top-level dissection (on two threads here; not with `Par::Seq`): same solution as the
/// unsplit sequential factorisation (to round-off), deterministic, and an indefinite matrix is
/// still refused. (Independence of the thread count: `tests/thread_independence.rs`.)
#[test]
fn two_thread_split_factorisation_matches_the_sequential_one() {
    let h = shell_laplacian(0.5);
    let n = h.ncols();
    let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 13) as f64 - 6.0).collect();
    let mut seq = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
    let mut par = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::rayon(2)).unwrap();
    assert!(!seq.is_split());
    assert!(par.is_split(), "{:?}", par.stats());
    seq.factorize(h.as_ref()).unwrap();
    let mut x_seq = b.clone();
    seq.solve_in_place(&mut x_seq).unwrap();
    let mut runs = Vec::new();
    for _ in 0..2 {
        par.factorize(h.as_ref()).unwrap();
        let mut x = b.clone();
        par.solve_in_place(&mut x).unwrap();
        let r: Vec<f64> = sym_mul(&h, &x).iter().zip(&b).map(|(p, q)| p - q).collect();
        assert!(max_abs(&r) < 1e-9 * max_abs(&b), "residual {}", max_abs(&r));
        let diff: Vec<f64> = x.iter().zip(&x_seq).map(|(p, q)| p - q).collect();
        assert!(
            max_abs(&diff) < 1e-10 * max_abs(&x_seq),
            "split vs sequential: {}",
            max_abs(&diff)
        );
        runs.push(x);
    }
    assert_eq!(runs[0], runs[1], "not deterministic");
    // The Laplacian has a zero eigenvalue: any negative shift makes it indefinite.
    let bad = shell_laplacian(-0.5);
    assert!(matches!(
        par.factorize(bad.as_ref()),
        Err(FactorError::NotPositiveDefinite { .. })
    ));
    let mut x = b.clone();
    assert!(par.solve_in_place(&mut x).is_err());
}

/// Mixed precision on a well-conditioned matrix (a large diagonal, like the `M/Δt²` of an
/// implicit step; condition number ≈ 7): the factorisation runs in f32, every solve is
/// refined to the f64 answer (within 1e-12 of the double-precision solve, relative) in at most
/// three single-precision solves, nothing falls back — unsplit (`Par::Seq`) and split, whose
/// mixed results are bit-identical on one- and two-thread pools.
#[test]
fn mixed_precision_refines_to_the_double_precision_answer() {
    let h = shell_laplacian(10.0);
    let n = h.ncols();
    let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 13) as f64 - 6.0).collect();
    let mut double = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
    double.factorize(h.as_ref()).unwrap();
    let mut x64 = b.clone();
    double.solve_in_place(&mut x64).unwrap();
    let mut split_bits = Vec::new();
    for (par, threads) in [(Par::Seq, 1), (Par::rayon(1), 1), (Par::rayon(2), 2)] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let x = pool.install(|| {
            let mut c = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, par).unwrap();
            assert!(c.set_mixed_precision(true).unwrap());
            assert_eq!(c.is_split(), par != Par::Seq);
            let mut x = b.clone();
            for _ in 0..2 {
                c.factorize(h.as_ref()).unwrap();
                assert!(c.single_active());
                x.copy_from_slice(&b);
                c.solve_in_place(&mut x).unwrap();
            }
            let p = c.precision();
            assert_eq!(p.single_factorizations, 2, "{p:?}");
            assert_eq!(p.double_factorizations, 0, "{p:?}");
            assert_eq!(p.fallback, None);
            assert_eq!(p.refined_solves, 2);
            assert!((1..=3).contains(&p.max_refinement_steps), "{p:?}");
            x
        });
        let diff: Vec<f64> = x.iter().zip(&x64).map(|(p, q)| p - q).collect();
        assert!(
            max_abs(&diff) < 1e-12 * max_abs(&x64),
            "{par:?}: {}",
            max_abs(&diff)
        );
        if par != Par::Seq {
            split_bits.push(x.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
        }
    }
    assert_eq!(split_bits[0], split_bits[1], "split: 1 vs 2 threads");
}

/// Mixed precision on an ill-conditioned matrix (diagonal shift 1e-7 under a Laplacian of
/// norm ≈ 60: condition number ≈ 1e9, beyond f32): the factorisation falls back to f64 for
/// good (the single-precision factor is not positive definite, or refinement stalls), says so,
/// and the answer is the double-precision one (residual ≤ 1e-9 of the right-hand side, like
/// the f64 solve's); the next factorisation is in f64 directly.
#[test]
fn mixed_precision_falls_back_to_double_on_an_ill_conditioned_matrix() {
    let h = shell_laplacian(1e-7);
    let n = h.ncols();
    let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 13) as f64 - 6.0).collect();
    let mut c = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
    assert!(c.set_mixed_precision(true).unwrap());
    c.factorize(h.as_ref()).unwrap();
    let mut x = b.clone();
    c.solve_in_place(&mut x).unwrap();
    let p = c.precision();
    assert!(p.fallback.is_some(), "{p:?}");
    assert!(!c.single_active());
    assert_eq!(p.double_factorizations, 1, "{p:?}");
    let r: Vec<f64> = sym_mul(&h, &x).iter().zip(&b).map(|(p, q)| p - q).collect();
    assert!(max_abs(&r) < 1e-9 * max_abs(&b), "residual {}", max_abs(&r));
    c.factorize(h.as_ref()).unwrap();
    assert!(!c.single_active());
    assert_eq!(c.precision().double_factorizations, 2);
    // Asking again does not bring back single precision after a fallback.
    assert!(!c.set_mixed_precision(true).unwrap());
}
