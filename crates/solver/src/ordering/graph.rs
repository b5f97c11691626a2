//! The dof graph of a Hessian pattern and its compression (the dofs of a vertex merged into one
//! weighted node).

use faer::sparse::SymbolicSparseColMatRef;

use crate::SolverError;

/// The order n of a square pattern; an error naming the row count otherwise.
pub(crate) fn square_order(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<usize, SolverError> {
    let n = pattern.ncols();
    if pattern.nrows() != n {
        return Err(SolverError::DimensionMismatch {
            what: "Hessian pattern rows",
            expected: n,
            found: pattern.nrows(),
        });
    }
    Ok(n)
}

/// Symmetric adjacency (CSR, no self loops) of a pattern holding the lower triangle (entries
/// of the upper triangle, if any, are mirrored too).
#[derive(Clone, Debug)]
pub(super) struct Graph {
    pub(super) ptr: Vec<usize>,
    pub(super) adj: Vec<usize>,
}

impl Graph {
    pub(super) fn from_pattern(pattern: SymbolicSparseColMatRef<'_, usize>) -> Graph {
        let n = pattern.ncols();
        let mut degree = vec![0usize; n];
        for j in 0..n {
            for &i in pattern.row_idx_of_col_raw(j) {
                if i != j {
                    degree[i] += 1;
                    degree[j] += 1;
                }
            }
        }
        let mut ptr = Vec::with_capacity(n + 1);
        ptr.push(0);
        for d in &degree {
            let last = ptr[ptr.len() - 1];
            ptr.push(last + d);
        }
        let mut fill = ptr[..n].to_vec();
        let mut adj = vec![0usize; ptr[n]];
        for j in 0..n {
            for &i in pattern.row_idx_of_col_raw(j) {
                if i != j {
                    adj[fill[i]] = j;
                    fill[i] += 1;
                    adj[fill[j]] = i;
                    fill[j] += 1;
                }
            }
        }
        Graph { ptr, adj }
    }

    pub(super) fn neighbors(&self, v: usize) -> &[usize] {
        &self.adj[self.ptr[v]..self.ptr[v + 1]]
    }
}

/// The dof graph with indistinguishable dofs (identical closed adjacency) merged into one
/// weighted node.
pub(super) struct Compressed {
    pub(super) graph: Graph,
    /// Dofs per node.
    pub(super) weight: Vec<::metis::Idx>,
    /// Dofs of node `v`: `members[members_ptr[v]..members_ptr[v + 1]]`, increasing.
    members_ptr: Vec<usize>,
    members: Vec<usize>,
}

impl Compressed {
    pub(super) fn new(g: &Graph) -> Compressed {
        let n = g.ptr.len() - 1;
        // Sorted closed neighbourhoods and a hash of each, to compare candidates cheaply.
        let mut closed = Vec::with_capacity(g.adj.len() + n);
        let mut closed_ptr = Vec::with_capacity(n + 1);
        closed_ptr.push(0);
        let mut hash = Vec::with_capacity(n);
        for v in 0..n {
            let start = closed.len();
            closed.extend_from_slice(g.neighbors(v));
            closed.push(v);
            closed[start..].sort_unstable();
            dedup_tail(&mut closed, start);
            let h = closed[start..]
                .iter()
                .fold(0xcbf2_9ce4_8422_2325u64, |h, &u| {
                    (h ^ u as u64).wrapping_mul(0x0000_0100_0000_01b3)
                });
            hash.push(h);
            closed_ptr.push(closed.len());
        }
        let closed_of = |v: usize| &closed[closed_ptr[v]..closed_ptr[v + 1]];
        // Dofs with equal closed neighbourhoods are adjacent, so each dof only needs to be
        // compared with the groups of its earlier neighbours (by their first member).
        let mut group = vec![usize::MAX; n];
        let mut reps: Vec<usize> = Vec::new();
        for v in 0..n {
            for &u in g.neighbors(v) {
                if u < v {
                    let r = reps[group[u]];
                    if hash[r] == hash[v] && closed_of(r) == closed_of(v) {
                        group[v] = group[u];
                        break;
                    }
                }
            }
            if group[v] == usize::MAX {
                group[v] = reps.len();
                reps.push(v);
            }
        }
        let m = reps.len();
        let mut weight = vec![0 as ::metis::Idx; m];
        for &gid in &group {
            weight[gid] += 1;
        }
        let mut members_ptr = Vec::with_capacity(m + 1);
        members_ptr.push(0);
        for &w in &weight {
            let last = members_ptr[members_ptr.len() - 1];
            members_ptr.push(last + w as usize);
        }
        let mut fill = members_ptr[..m].to_vec();
        let mut members = vec![0; n];
        for (v, &gid) in group.iter().enumerate() {
            members[fill[gid]] = v;
            fill[gid] += 1;
        }
        // Node adjacency from each representative's neighbours (all members share them).
        let mut ptr = Vec::with_capacity(m + 1);
        ptr.push(0);
        let mut adj = Vec::new();
        for (gid, &r) in reps.iter().enumerate() {
            let start = adj.len();
            adj.extend(
                g.neighbors(r)
                    .iter()
                    .map(|&u| group[u])
                    .filter(|&h| h != gid),
            );
            adj[start..].sort_unstable();
            dedup_tail(&mut adj, start);
            ptr.push(adj.len());
        }
        Compressed {
            graph: Graph { ptr, adj },
            weight,
            members_ptr,
            members,
        }
    }

    pub(super) fn members_of(&self, v: usize) -> &[usize] {
        &self.members[self.members_ptr[v]..self.members_ptr[v + 1]]
    }
}

/// Removes repeated values from the sorted `v[start..]`.
fn dedup_tail(v: &mut Vec<usize>, start: usize) {
    let mut kept = start;
    for k in start..v.len() {
        if k == start || v[k] != v[kept - 1] {
            v[kept] = v[k];
            kept += 1;
        }
    }
    v.truncate(kept);
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::ordering::test_patterns::block_grid;

    #[test]
    fn compression_merges_the_dofs_of_a_vertex() {
        let p = block_grid(6);
        let c = Compressed::new(&Graph::from_pattern(p.as_ref()));
        assert_eq!(c.weight.len(), 36);
        for v in 0..36 {
            assert_eq!(c.members_of(v), &[3 * v, 3 * v + 1, 3 * v + 2]);
        }
        // A corner vertex has 3 neighbouring vertices, an interior one 8.
        assert_eq!(c.graph.neighbors(0).len(), 3);
        assert_eq!(c.graph.neighbors(7).len(), 8);
    }
}
