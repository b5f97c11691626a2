//! Geometric (coordinate bisection) and graph-based (breadth-first level set) nested
//! dissection.

use crate::SolverError;
use faer::sparse::SymbolicSparseColMatRef;

use super::dissector::{Dissector, Split};
use super::graph::{Graph, square_order};

/// Nested-dissection ordering of a symmetric pattern.
///
/// `pattern`: square, lower triangle (as handed to the Cholesky factorisation). `coordinates`:
/// optional per-dof positions (length `n`), used for geometric bisection; without them the
/// bisection uses breadth-first distances. `leaf_size`: parts with at most this many dofs are
/// not split further but ordered by AMD (values below 2 are treated as 2).
///
/// Returns the permutation as faer's *forward* array: `perm[new] = old` (the separator of the
/// whole graph comes last).
pub fn nested_dissection(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    coordinates: Option<&[[f64; 3]]>,
    leaf_size: usize,
) -> Result<Vec<usize>, SolverError> {
    let n = square_order(pattern)?;
    if let Some(c) = coordinates {
        if c.len() != n {
            return Err(SolverError::DimensionMismatch {
                what: "dof coordinates",
                expected: n,
                found: c.len(),
            });
        }
        if let Some(dof) = c.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(SolverError::NonFiniteCoordinate { dof });
        }
    }
    let leaf_size = leaf_size.max(2);
    let graph = Graph::from_pattern(pattern);
    let mut dissector = Dissector {
        graph: &graph,
        coordinates,
        side: vec![0; n],
        local: vec![0; n],
        dist: vec![usize::MAX; n],
        queue: Vec::new(),
        order: Vec::with_capacity(n),
    };

    // Explicit stack instead of recursion: children are pushed after their separator so that
    // the first half, then the second half, then the separator get numbered.
    enum Task {
        Dissect(Vec<usize>),
        Emit(Vec<usize>),
    }
    let mut stack = vec![Task::Dissect((0..n).collect())];
    while let Some(task) = stack.pop() {
        match task {
            Task::Emit(set) => dissector.order.extend_from_slice(&set),
            Task::Dissect(set) => {
                if set.len() <= leaf_size {
                    dissector.emit_leaf(&set);
                    continue;
                }
                match dissector.bisect(set) {
                    Split::Leaf(set) => dissector.emit_leaf(&set),
                    Split::Parts { a, b, separator } => {
                        stack.push(Task::Emit(separator));
                        stack.push(Task::Dissect(b));
                        stack.push(Task::Dissect(a));
                    }
                }
            }
        }
    }
    Ok(dissector.order)
}

impl Dissector<'_> {
    fn bisect(&mut self, mut set: Vec<usize>) -> Split {
        let Some(coords) = self.coordinates else {
            // Level-set bisection: the BFS level holding the median dof separates the levels
            // before it from those after it (edges only join adjacent levels).
            let mid = set.len() / 2;
            self.bfs_distances(&set);
            let dist = &self.dist;
            set.select_nth_unstable_by(mid, |&p, &q| dist[p].cmp(&dist[q]).then(p.cmp(&q)));
            let level = dist[set[mid]];
            let a = set.iter().copied().filter(|&v| dist[v] < level).collect();
            let b = set.iter().copied().filter(|&v| dist[v] > level).collect();
            let separator = set.iter().copied().filter(|&v| dist[v] == level).collect();
            for &v in &set {
                self.dist[v] = usize::MAX;
            }
            return Split::Parts { a, b, separator };
        };
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &v in &set {
            for k in 0..3 {
                lo[k] = lo[k].min(coords[v][k]);
                hi[k] = hi[k].max(coords[v][k]);
            }
        }
        // Cut across each axis with a non-zero extent and keep the smallest separator (ties:
        // the longest axis, the classic choice).
        let mut axes: Vec<usize> = (0..3).filter(|&k| hi[k] > lo[k]).collect();
        axes.sort_by(|&p, &q| (hi[q] - lo[q]).total_cmp(&(hi[p] - lo[p])));
        let mut best: Option<(Vec<usize>, Vec<usize>, Vec<usize>)> = None;
        for axis in axes {
            set.sort_unstable_by(|&p, &q| coords[p][axis].total_cmp(&coords[q][axis]));
            // Split at the median *value* so that dofs with equal coordinates (the three dofs
            // of a vertex, a grid line) stay on one side: cleaner separators.
            let median = coords[set[set.len() / 2]][axis];
            let mid = if median > lo[axis] {
                set.partition_point(|&v| coords[v][axis] < median)
            } else {
                set.partition_point(|&v| coords[v][axis] <= median)
            };
            let parts = self.separate(&set[..mid], &set[mid..]);
            if best.as_ref().is_none_or(|b| parts.2.len() < b.2.len()) {
                best = Some(parts);
            }
        }
        match best {
            Some((a, b, separator)) => Split::Parts { a, b, separator },
            // All dofs at one point: nothing geometric to split.
            None => Split::Leaf(set),
        }
    }

    /// Vertex separator between two halves: the smaller one-sided boundary. Returns the halves
    /// without it and the separator.
    fn separate(
        &mut self,
        a_half: &[usize],
        b_half: &[usize],
    ) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
        for &v in a_half {
            self.side[v] = 1;
        }
        for &v in b_half {
            self.side[v] = 2;
        }
        let graph = self.graph;
        let side = &self.side;
        let touches = |v: usize, other: u8| graph.neighbors(v).iter().any(|&u| side[u] == other);
        let boundary_a: Vec<usize> = a_half.iter().copied().filter(|&v| touches(v, 2)).collect();
        let boundary_b: Vec<usize> = b_half.iter().copied().filter(|&v| touches(v, 1)).collect();
        let (separator, sep_side) = if boundary_a.len() <= boundary_b.len() {
            (boundary_a, 1)
        } else {
            (boundary_b, 2)
        };
        for &v in &separator {
            self.side[v] = 4;
        }
        let a: Vec<usize> = a_half
            .iter()
            .copied()
            .filter(|&v| self.side[v] == 1)
            .collect();
        let b: Vec<usize> = b_half
            .iter()
            .copied()
            .filter(|&v| self.side[v] == 2)
            .collect();
        debug_assert!(sep_side == 1 || b.len() + separator.len() == b_half.len());
        for &v in a_half.iter().chain(b_half) {
            self.side[v] = 0;
        }
        (a, b, separator)
    }

    /// Breadth-first distances inside `set` from a pseudo-peripheral dof (two sweeps); dofs of
    /// other components of `set` get distances continuing after the first component's.
    fn bfs_distances(&mut self, set: &[usize]) {
        for &v in set {
            self.side[v] = 3;
        }
        let far = self.sweep(set[0], 0);
        for &v in set {
            self.dist[v] = usize::MAX;
        }
        let mut offset = 0;
        let mut start = far;
        loop {
            let last = self.sweep(start, offset);
            offset = self.dist[last] + 1;
            match set.iter().find(|&&v| self.dist[v] == usize::MAX) {
                Some(&v) => start = v,
                None => break,
            }
        }
        for &v in set {
            self.side[v] = 0;
        }
    }

    /// One BFS from `start` over unvisited members (side 3); returns the last dof reached.
    fn sweep(&mut self, start: usize, offset: usize) -> usize {
        self.queue.clear();
        self.queue.push(start);
        self.dist[start] = offset;
        let mut head = 0;
        while head < self.queue.len() {
            let v = self.queue[head];
            head += 1;
            for &u in self.graph.neighbors(v) {
                if self.side[u] == 3 && self.dist[u] == usize::MAX {
                    self.dist[u] = self.dist[v] + 1;
                    self.queue.push(u);
                }
            }
        }
        self.queue[self.queue.len() - 1]
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::ordering::test_patterns::path;

    #[test]
    fn path_separator_is_numbered_last_and_splits_the_path() {
        let n = 9;
        let p = path(n);
        let coords: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, 0.0, 0.0]).collect();
        for c in [Some(coords.as_slice()), None] {
            let perm = nested_dissection(p.as_ref(), c, 2).unwrap();
            let mut sorted = perm.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>());
            // The last dof separates the path into two parts numbered before it.
            let last = perm[n - 1];
            assert!(
                last > 0 && last < n - 1,
                "separator {last} is an end of the path"
            );
        }
    }
}
