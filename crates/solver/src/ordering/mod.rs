//! Fill-reducing orderings for the sparse Cholesky factorisation.
//!
//! faer ships approximate minimum degree (AMD) but no nested dissection. The shell Hessian
//! couples two rings of vertices (the bending stencil), so its factor fills in heavily and the
//! ordering decides the cost.
//!
//! - [`metis_node_nd`] (the default, [`Ordering::Metis`]): METIS's own nested dissection
//!   (`METIS_NodeND`, node separators refined by METIS), called through the checked `unsafe`
//!   wrapper of `node_nd.rs`, the workspace's only `unsafe` code.
//! - [`metis_nested_dissection`]: nested dissection whose bisections are METIS's multilevel
//!   partitioner on the compressed graph (one node per vertex or edge angle), the separator a
//!   minimum-weight vertex cover of the cut edges (the default before NodeND).
//! - [`nested_dissection`]: a geometric nested dissection: split the dofs at the median along
//!   an axis of their bounding box, take the dofs of the smaller side that touch the other
//!   side as the vertex separator, number both halves recursively and the separator last.
//!   Without coordinates the separator is the median level of a breadth-first search from a
//!   pseudo-peripheral dof (graph-based nested dissection).
//!
//! In our two dissections, leaves (parts of at most `leaf_size` dofs) are ordered by AMD on
//! their induced subgraph, as METIS does with minimum degree.
//!
//! Module layout: `graph` (the dof graph and its compression), `dissector` (the order being
//! built, AMD leaves), `geometric`, `metis` (METIS bisections), `separator` (the max flow that
//! turns a cut into a vertex separator), `node_nd` (METIS's own ordering).
//!
//! The predicted flops of every ordering on the shell Hessian (1 280 to 81 920 faces, both
//! bending forms, a flat sheet) are in docs/performance.md ("Sparse Cholesky orderings" and
//! "METIS's own nested dissection"); `examples/ordering_flops.rs` reproduces them.

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

pub(crate) use graph::square_order;

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
    let n = square_order(pattern)?;
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
    /// METIS's own nested dissection ([`metis_node_nd`], `METIS_NodeND`; deterministic: fixed
    /// seed, one METIS call at a time). The default: the fewest predicted flops of all
    /// orderings on every shell Hessian measured (docs/performance.md). Its top-level split
    /// feeds the two-thread factorisation ([`SparseCholesky::new`](crate::SparseCholesky::new)).
    #[default]
    Metis,
    /// Analyse with AMD, METIS, graph-based and (given coordinates) geometric nested
    /// dissection and keep the one with the fewest predicted flops (four symbolic analyses,
    /// once per pattern; a METIS failure just drops that candidate).
    Auto,
}

/// Dofs per leaf below which the dissection stops (leaves are then ordered by AMD).
pub const DEFAULT_LEAF_SIZE: usize = 64;

/// Dofs per leaf of [`metis_nested_dissection`] (METIS_NodeND, [`Ordering::Metis`], chooses its
/// own).
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
