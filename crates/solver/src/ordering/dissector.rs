//! The state of a nested dissection (the order built so far and per-dof scratch) and the
//! ordering of its leaves by AMD.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::amd;

use super::graph::Graph;

/// Result of one bisection of a set of dofs.
pub(super) enum Split {
    Leaf(Vec<usize>),
    Parts {
        a: Vec<usize>,
        b: Vec<usize>,
        separator: Vec<usize>,
    },
}

pub(super) struct Dissector<'a> {
    pub(super) graph: &'a Graph,
    pub(super) coordinates: Option<&'a [[f64; 3]]>,
    /// 0 outside the current set, 1 / 2 for its two halves, 3 for members during BFS.
    pub(super) side: Vec<u8>,
    /// Local index of a dof inside the leaf being ordered.
    pub(super) local: Vec<usize>,
    pub(super) dist: Vec<usize>,
    pub(super) queue: Vec<usize>,
    pub(super) order: Vec<usize>,
}

impl Dissector<'_> {
    /// Appends `set` ordered by AMD on its induced subgraph (natural order if AMD fails).
    pub(super) fn emit_leaf(&mut self, set: &[usize]) {
        let k = set.len();
        if k <= 2 {
            self.order.extend_from_slice(set);
            return;
        }
        for (l, &v) in set.iter().enumerate() {
            self.local[v] = l;
            self.side[v] = 5;
        }
        let mut col_ptr = Vec::with_capacity(k + 1);
        col_ptr.push(0);
        let mut rows = Vec::new();
        for (l, &v) in set.iter().enumerate() {
            let start = rows.len();
            rows.push(l);
            for &u in self.graph.neighbors(v) {
                if self.side[u] == 5 && self.local[u] > l {
                    rows.push(self.local[u]);
                }
            }
            rows[start..].sort_unstable();
            col_ptr.push(rows.len());
        }
        for &v in set {
            self.side[v] = 0;
        }
        let mut perm = vec![0usize; k];
        let mut perm_inv = vec![0usize; k];
        let ok = match (
            SymbolicSparseColMatRef::new_unsorted_checked(k, k, &col_ptr, None, &rows),
            MemBuffer::try_new(amd::order_maybe_unsorted_scratch::<usize>(k, rows.len())),
        ) {
            (a, Ok(mut mem)) => amd::order_maybe_unsorted(
                &mut perm,
                &mut perm_inv,
                a,
                amd::Control::default(),
                MemStack::new(&mut mem),
            )
            .is_ok(),
            _ => false,
        };
        if ok {
            self.order.extend(perm.iter().map(|&l| set[l]));
        } else {
            self.order.extend_from_slice(set);
        }
    }
}
