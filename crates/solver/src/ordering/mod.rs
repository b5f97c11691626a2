//! Fill-reducing orderings for the sparse Cholesky factorisation.
//!
//! faer ships approximate minimum degree (AMD) but no nested dissection. The shell Hessian
//! couples two rings of vertices (the bending stencil), so its factor fills in heavily and the
//! ordering decides the cost.
//!
//! - [`metis_nested_dissection`] (the default, [`Ordering::Metis`]): nested dissection whose
//!   bisections are METIS's multilevel partitioner on the compressed graph (one node per
//!   vertex or edge angle), the separator a minimum-weight vertex cover of the cut edges.
//! - [`nested_dissection`]: a geometric nested dissection: split the dofs at the median along
//!   an axis of their bounding box, take the dofs of the smaller side that touch the other
//!   side as the vertex separator, number both halves recursively and the separator last.
//!   Without coordinates the separator is the median level of a breadth-first search from a
//!   pseudo-peripheral dof (graph-based nested dissection).
//!
//! In both, leaves (parts of at most `leaf_size` dofs) are ordered by AMD on their induced
//! subgraph, as METIS does with minimum degree.
//!
//! Predicted factorisation flops ([`factor_flops`](crate::linear::factor_flops)) on the
//! Hessian of the shrinking-sphere benchmark (`examples/ordering_flops.rs`):
//!
//! | faces | form | AMD | ND geometric | ND graph | METIS ND |
//! |---:|---|---:|---:|---:|---:|
//! | 1 280 | mid-edge average | 9.20e7 | 8.34e7 | 8.03e7 | 7.46e7 |
//! | 20 480 | mid-edge average | 9.36e9 | 8.33e9 | 7.69e9 | 7.03e9 |
//! | 81 920 | mid-edge average | 1.00e11 | 7.34e10 | 6.33e10 | 6.31e10 |
//! | 1 280 | edge director | 3.05e8 | 2.84e8 | 4.76e8 | 1.71e8 |
//! | 20 480 | edge director | 4.36e10 | 2.64e10 | 4.63e10 | 1.53e10 |
//!
//! (CHOLMOD's METIS node nested dissection: 6.4e9 at 20 480 faces and 5.65e10 at 81 920, mid-edge
//! average.)

use faer::sparse::SymbolicSparseColMatRef;

use crate::SolverError;

mod dissector;
mod geometric;
mod graph;
mod metis;
mod node_nd;
mod separator;
#[cfg(test)]
mod test_patterns;

pub use geometric::nested_dissection;
pub use metis::metis_nested_dissection;

/// METIS's own nested dissection (`METIS_NodeND` through the checked wrapper of
/// `ordering/node_nd.rs`) of a symmetric pattern.
///
/// `pattern`: square, lower triangle (upper entries, if any, are mirrored). Returns
/// `perm[new] = old` like [`nested_dissection`]. Errors: a non-square pattern, more dofs or
/// adjacencies than METIS's 32-bit indices hold, or a METIS failure ([`SolverError::Linear`]).
pub fn metis_node_nd(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<Vec<usize>, SolverError> {
    node_nd_with_split(pattern).map(|(perm, _)| perm)
}

/// [`metis_node_nd`] and the dof counts `[a, b, s]` of its top-level halves and separator
/// (numbered in that order, the halves uncoupled), from `METIS_NodeNDP` with two parts, which
/// orders exactly as `METIS_NodeND`.
pub(crate) fn node_nd_with_split(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<(Vec<usize>, Option<[usize; 3]>), SolverError> {
    let n = pattern.ncols();
    if pattern.nrows() != n {
        return Err(SolverError::DimensionMismatch {
            what: "Hessian pattern rows",
            expected: n,
            found: pattern.nrows(),
        });
    }
    if n == 0 {
        return Ok((Vec::new(), None));
    }
    let graph = graph::Graph::from_pattern(pattern);
    let order = node_nd::MetisGraph::from_graph(&graph)?.node_nd_split()?;
    Ok((order.perm, order.top))
}

/// Which fill-reducing ordering the Cholesky factorisation uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Ordering {
    /// faer's approximate minimum degree.
    Amd,
    /// Nested dissection ([`nested_dissection`]): geometric when the objective provides dof
    /// coordinates, graph-based otherwise.
    NestedDissection,
    /// Nested dissection with METIS's multilevel bisection on the compressed graph
    /// ([`metis_nested_dissection`]; deterministic: fixed seed). The default: on the shell
    /// sphere's Hessian it needs the fewest flops of the four on every size measured (1 280 to
    /// 81 920 faces), 16 % fewer than geometric nested dissection at 20 480 faces and 1.7×
    /// fewer with edge directors (module docs); on a flat 101 × 101 sheet geometric nested
    /// dissection is 5 % better (3.37e9 vs 3.55e9 flops, `ordering` bench; `Auto` finds it).
    #[default]
    Metis,
    /// Analyse with AMD, METIS, graph-based and (given coordinates) geometric nested
    /// dissection and keep the one with the fewest predicted flops (four symbolic analyses,
    /// once per pattern; a METIS failure just drops that candidate).
    Auto,
}

/// Dofs per leaf below which the dissection stops (leaves are then ordered by AMD).
pub const DEFAULT_LEAF_SIZE: usize = 64;

/// Dofs per leaf of [`metis_nested_dissection`] as used by [`Ordering::Metis`].
pub const METIS_LEAF_SIZE: usize = 64;

/// The inverse of a permutation given as `perm[new] = old`: `inv[old] = new`.
pub fn inverse_permutation(perm: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; perm.len()];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_permutation_round_trips() {
        let perm = vec![2, 0, 3, 1];
        let inv = inverse_permutation(&perm);
        for (new, &old) in perm.iter().enumerate() {
            assert_eq!(inv[old], new);
        }
    }
}
