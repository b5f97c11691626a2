//! Nested-dissection orderings are valid permutations with separators numbered last.
#![allow(clippy::unwrap_used)]

use faer::sparse::{SymbolicSparseColMat, SymbolicSparseColMatRef};
use proptest::prelude::*;
use thinshell_solver::ordering::{inverse_permutation, nested_dissection};
use thinshell_testkit::strategies::cases_or;

/// Lower pattern (with diagonal) from an undirected edge list.
fn pattern(n: usize, edges: &[(usize, usize)]) -> SymbolicSparseColMat<usize> {
    let mut cols: Vec<Vec<usize>> = (0..n).map(|j| vec![j]).collect();
    for &(a, b) in edges {
        if a != b {
            cols[a.min(b)].push(a.max(b));
        }
    }
    let mut col_ptr = vec![0];
    let mut rows = Vec::new();
    for c in &mut cols {
        c.sort_unstable();
        c.dedup();
        rows.extend_from_slice(c);
        col_ptr.push(rows.len());
    }
    SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows)
}

/// Checks the top-level structure: the dofs numbered last (the root separator) disconnect the
/// dofs numbered before them into parts whose numbers do not interleave across the separator:
/// no edge joins a dof of the first half (before `split`) to one of the second half.
fn is_permutation(perm: &[usize], n: usize) -> bool {
    let mut seen = vec![false; n];
    perm.len() == n
        && perm
            .iter()
            .all(|&v| v < n && !std::mem::replace(&mut seen[v], true))
}

fn neighbours(p: SymbolicSparseColMatRef<'_, usize>, n: usize) -> Vec<Vec<usize>> {
    let mut adj = vec![Vec::new(); n];
    for j in 0..n {
        for &i in p.row_idx_of_col_raw(j) {
            if i != j {
                adj[i].push(j);
                adj[j].push(i);
            }
        }
    }
    adj
}

#[test]
fn grid_top_separator_splits_the_grid() {
    // 9 × 9 grid, 4-neighbour: the root separator is a full grid line (9 dofs) numbered last,
    // and no edge connects the two halves numbered before it.
    let m = 9;
    let id = |i: usize, j: usize| i * m + j;
    let mut edges = Vec::new();
    for i in 0..m {
        for j in 0..m {
            if i + 1 < m {
                edges.push((id(i, j), id(i + 1, j)));
            }
            if j + 1 < m {
                edges.push((id(i, j), id(i, j + 1)));
            }
        }
    }
    let n = m * m;
    let p = pattern(n, &edges);
    // Stretch the grid along x so that the first cut is across x.
    let coords: Vec<[f64; 3]> = (0..n)
        .map(|v| [2.0 * (v / m) as f64, (v % m) as f64, 0.0])
        .collect();
    let perm = nested_dissection(p.as_ref(), Some(&coords), 4).unwrap();
    assert!(is_permutation(&perm, n));
    let sep = &perm[n - m..];
    let row = sep[0] / m;
    assert!(
        sep.iter().all(|&v| v / m == row),
        "separator {sep:?} is not one grid line"
    );
    let inv = inverse_permutation(&perm);
    let side = |v: usize| (v / m).cmp(&row);
    // Parts: everything on one side of the line is numbered before everything on the other.
    let before: Vec<usize> = perm[..n - m].to_vec();
    let first_side = side(before[0]);
    let switch = before.iter().position(|&v| side(v) != first_side).unwrap();
    assert!(before[switch..].iter().all(|&v| side(v) != first_side));
    let adj = neighbours(p.as_ref(), n);
    for &v in &before[..switch] {
        for &u in &adj[v] {
            assert!(
                inv[u] < switch || inv[u] >= n - m,
                "edge {v}-{u} crosses the separator"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(32)))]
    #[test]
    fn random_graphs_give_permutations(
        n in 1usize..200,
        raw_edges in prop::collection::vec((0usize..200, 0usize..200), 0..600),
        with_coords in any::<bool>(),
        leaf in 2usize..20,
        seed in 0u64..1000,
    ) {
        let edges: Vec<(usize, usize)> = raw_edges.into_iter().map(|(a, b)| (a % n, b % n)).collect();
        let p = pattern(n, &edges);
        let coords: Vec<[f64; 3]> = (0..n)
            .map(|v| {
                let h = (v as u64).wrapping_mul(2654435761).wrapping_add(seed);
                [(h % 97) as f64, (h % 89) as f64, (h % 83) as f64]
            })
            .collect();
        let perm = nested_dissection(p.as_ref(), with_coords.then_some(coords.as_slice()), leaf).unwrap();
        prop_assert!(is_permutation(&perm, n));
        let inv = inverse_permutation(&perm);
        for (new, &old) in perm.iter().enumerate() {
            prop_assert_eq!(inv[old], new);
        }
    }
}

/// Predicted factorisation flops of `perm` (`perm[new] = old`) on `pattern`.
fn flops_of(pattern: SymbolicSparseColMatRef<'_, usize>, perm: &[usize]) -> f64 {
    use faer::perm::PermRef;
    use faer::sparse::linalg::cholesky::{
        CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky,
    };
    let inv = inverse_permutation(perm);
    let symbolic = factorize_symbolic_cholesky(
        pattern,
        faer::Side::Lower,
        SymmetricOrdering::Custom(PermRef::new_checked(perm, &inv, perm.len())),
        CholeskySymbolicParams::default(),
    )
    .unwrap();
    thinshell_solver::linear::factor_flops(&symbolic)
}

/// The default ordering is METIS's own nested dissection (`METIS_NodeND`): on the shell
/// Hessian (5 120-face sphere, both bending forms) it needs fewer predicted flops than the
/// nested dissection built from METIS bisections that it replaced (6.82e8 vs 7.52e8 and 1.57e9
/// vs 1.65e9; −9 % at 20 480 faces, docs/performance.md) and than every other ordering, and
/// the split factorisation gets its top-level halves, uncoupled and balanced.
#[test]
fn metis_node_nd_beats_the_other_orderings_on_the_shell_hessian() {
    use faer::Par;
    use thinshell_energy::{Assembler, SffKind};
    use thinshell_solver::ordering::{METIS_LEAF_SIZE, metis_nested_dissection, metis_node_nd};
    use thinshell_solver::{Ordering, SparseCholesky};
    for sff in [SffKind::MidEdgeAverage, SffKind::default()] {
        let (sys, _) = thinshell_testkit::fixtures::shrinking_sphere(4, sff);
        let h = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model())
            .unwrap()
            .hessian_template();
        let p = h.symbolic();
        let n = p.ncols();
        let node_nd = metis_node_nd(p).unwrap();
        assert!(is_permutation(&node_nd, n));
        assert_eq!(
            node_nd,
            metis_node_nd(p).unwrap(),
            "a function of the pattern"
        );
        let default = SparseCholesky::new(p, Ordering::default(), None, Par::Seq).unwrap();
        assert_eq!(default.stats().ordering, Ordering::Metis);
        let f_default = default.stats().flops;
        assert_eq!(f_default, flops_of(p, &node_nd));
        let f_bisection = flops_of(p, &metis_nested_dissection(p, METIS_LEAF_SIZE).unwrap());
        assert!(
            f_default < 0.97 * f_bisection,
            "{}: NodeND {f_default:.4e} vs METIS bisections {f_bisection:.4e}",
            sff.name()
        );
        for other in [Ordering::Amd, Ordering::NestedDissection] {
            let f = SparseCholesky::new(p, other, None, Par::Seq)
                .unwrap()
                .stats()
                .flops;
            assert!(f_default < f, "{}: {other:?} {f:.4e}", sff.name());
        }
        // Two threads: split at METIS's top separator (≈ two vertex rings, whole vertices).
        let split = SparseCholesky::new(p, Ordering::Metis, None, Par::rayon(2)).unwrap();
        assert!(split.is_split(), "{}", sff.name());
        let [a, b, _] = split.split_flops().unwrap();
        assert!(
            a.min(b) > 0.5 * a.max(b),
            "unbalanced halves: {a:.3e} {b:.3e}"
        );
    }
}
