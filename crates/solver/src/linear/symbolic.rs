//! The symbolic analysis: the pattern's diagonal, the ordering (one or the best of several),
//! faer's elimination tree and supernodes, and the predicted flops.

use faer::Side;
use faer::perm::PermRef;
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};

use crate::SolverError;
use crate::ordering::{
    DEFAULT_LEAF_SIZE, Ordering, inverse_permutation, nested_dissection, node_nd_with_split,
    square_order,
};

/// Position of (d, d) in the value array for each column d; checks the pattern is square and
/// holds the lower triangle only.
pub fn diagonal_offsets(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<Vec<usize>, SolverError> {
    let n = square_order(pattern)?;
    if pattern.col_nnz().is_some() {
        return Err(SolverError::InvalidPattern {
            dof: 0,
            reason: "pattern must be compressed (no per-column nnz)",
        });
    }
    let col_ptr = pattern.col_ptr();
    let row_idx = pattern.row_idx();
    let mut offsets = Vec::with_capacity(n);
    for j in 0..n {
        let mut diag = None;
        for (p, &i) in row_idx
            .iter()
            .enumerate()
            .take(col_ptr[j + 1])
            .skip(col_ptr[j])
        {
            if i < j {
                return Err(SolverError::InvalidPattern {
                    dof: j,
                    reason: "entry above the diagonal (only the lower triangle may be stored)",
                });
            }
            if i == j {
                diag = Some(p);
            }
        }
        match diag {
            Some(p) => offsets.push(p),
            None => {
                return Err(SolverError::InvalidPattern {
                    dof: j,
                    reason: "diagonal entry missing",
                });
            }
        }
    }
    Ok(offsets)
}

/// The symbolic analysis of a lower-triangle `pattern` under `ordering`, and the ordering used:
/// `Auto` tries AMD, graph nested dissection, METIS nested dissection and (with `coordinates`,
/// m per dof) geometric nested dissection, and keeps the one with the fewest factorisation
/// flops. Shared by the
/// Cholesky and LDLᵀ factorisations.
pub(crate) fn analyse(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    ordering: Ordering,
    coordinates: Option<&[[f64; 3]]>,
) -> Result<(SymbolicCholesky<usize>, Ordering, Option<TopSplit>), SolverError> {
    Ok(match ordering {
        Ordering::Amd => (symbolic_amd(pattern)?, Ordering::Amd, None),
        Ordering::NestedDissection => (
            symbolic_nd(pattern, coordinates)?,
            Ordering::NestedDissection,
            None,
        ),
        Ordering::Metis => {
            let (symbolic, split) = symbolic_metis(pattern)?;
            (symbolic, Ordering::Metis, split)
        }
        Ordering::Auto => {
            let mut best = (symbolic_amd(pattern)?, Ordering::Amd, None);
            let mut candidates = vec![(
                symbolic_nd(pattern, None)?,
                Ordering::NestedDissection,
                None,
            )];
            if coordinates.is_some() {
                candidates.push((
                    symbolic_nd(pattern, coordinates)?,
                    Ordering::NestedDissection,
                    None,
                ));
            }
            // METIS can only fail on input it rejects or out of memory: the other candidates
            // still stand then.
            if let Ok((m, split)) = symbolic_metis(pattern) {
                candidates.push((m, Ordering::Metis, split));
            }
            for candidate in candidates {
                if factor_flops(&candidate.0) < factor_flops(&best.0) {
                    best = candidate;
                }
            }
            best
        }
    })
}

pub(crate) fn symbolic_amd(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<SymbolicCholesky<usize>, SolverError> {
    factorize_symbolic_cholesky(
        pattern,
        Side::Lower,
        SymmetricOrdering::Amd,
        CholeskySymbolicParams::default(),
    )
    .map_err(|e| SolverError::Linear(format!("{e:?}")))
}

pub(crate) fn symbolic_nd(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    coordinates: Option<&[[f64; 3]]>,
) -> Result<SymbolicCholesky<usize>, SolverError> {
    let fwd = nested_dissection(pattern, coordinates, DEFAULT_LEAF_SIZE)?;
    symbolic_custom(pattern, &fwd)
}

/// The permutation of a nested dissection and the dof counts `[a, b, s]` of its top-level
/// halves and separator (numbered in that order; the halves are uncoupled).
pub(crate) type TopSplit = (Vec<usize>, [usize; 3]);

pub(crate) fn symbolic_metis(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<(SymbolicCholesky<usize>, Option<TopSplit>), SolverError> {
    let (fwd, split) = node_nd_with_split(pattern)?;
    let symbolic = symbolic_custom(pattern, &fwd)?;
    Ok((symbolic, split.map(|sizes| (fwd, sizes))))
}

/// Symbolic analysis with the permutation `fwd` (`fwd[new] = old`).
pub(crate) fn symbolic_custom(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    fwd: &[usize],
) -> Result<SymbolicCholesky<usize>, SolverError> {
    let inv = inverse_permutation(fwd);
    let perm = PermRef::new_checked(fwd, &inv, fwd.len());
    factorize_symbolic_cholesky(
        pattern,
        Side::Lower,
        SymmetricOrdering::Custom(perm),
        CholeskySymbolicParams::default(),
    )
    .map_err(|e| SolverError::Linear(format!("{e:?}")))
}

/// Predicted flops of the numeric factorisation: Σ over the columns of L of (entries in the
/// column)², counting the supernodal blocks as stored.
pub fn factor_flops(symbolic: &SymbolicCholesky<usize>) -> f64 {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => s
            .col_ptr()
            .windows(2)
            .map(|w| {
                let c = (w[1] - w[0]) as f64;
                c * c
            })
            .sum(),
        SymbolicCholeskyRaw::Supernodal(s) => {
            let begin = s.supernode_begin();
            let end = s.supernode_end();
            (0..s.n_supernodes())
                .map(|k| {
                    let width = end[k] - begin[k];
                    let below = s.supernode(k).pattern().len();
                    (1..=width)
                        .map(|c| {
                            let c = (c + below) as f64;
                            c * c
                        })
                        .sum::<f64>()
                })
                .sum()
        }
    }
}
