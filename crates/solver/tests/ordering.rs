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
