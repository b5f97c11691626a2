//! METIS's own nested-dissection ordering (`METIS_NodeNDP`, `METIS_NodeND`) through the raw
//! `metis-sys` binding: the only `unsafe` code of the workspace.
//!
//! The safe `metis` crate wraps the partitioners but not the orderings. Both C functions read
//! a graph in CSR form (`xadj`, `adjncy`) and write two permutations of its length; they
//! trust their input (METIS checks it only in debug builds), so everything they rely on is
//! checked here first ([`MetisGraph::new`]): the arrays' lengths, the offsets, the indices'
//! range, no self loops or repeated neighbours, symmetry, and 32-bit sizes. Their outputs are
//! checked to be permutations before use.
//!
//! `METIS_NodeNDP` with two parts is `METIS_NodeND` (the same multilevel node bisections, the
//! same compression, the same random stream from the same seed) that also reports the dof
//! counts of the top-level halves and separator, which the two-thread split factorisation
//! needs. It does not set up METIS's error trap, so a failed allocation inside METIS aborts the
//! process (as a failed allocation in Rust does); invalid input cannot reach it.
#![allow(unsafe_code)]

use metis_sys as ffi;

use super::graph::{Compressed, Graph};
use super::metis::METIS_LOCK;
use crate::SolverError;

/// Below this fraction of the dofs METIS compresses the graph (its `COMPRESSION_FRACTION`).
const COMPRESSION_FRACTION: f64 = 0.85;

/// A graph in METIS's CSR form whose every property the C code relies on has been checked.
pub(super) struct MetisGraph {
    xadj: Vec<ffi::idx_t>,
    adjncy: Vec<ffi::idx_t>,
    /// Node separators per bisection, as `METIS_NodeND` chooses it: 2 when the graph
    /// compresses by more than 1.5 (the three dofs of a vertex), else 1.
    nseps: ffi::idx_t,
}

/// A METIS ordering: `perm[new] = old`, and for `METIS_NodeNDP` the dof counts `[a, b, s]` of
/// the top-level halves and separator (numbered in that order).
pub(super) struct NodeNdOrder {
    pub(super) perm: Vec<usize>,
    pub(super) top: Option<[usize; 3]>,
}

fn error(msg: impl std::fmt::Display) -> SolverError {
    SolverError::Linear(format!("METIS node nested dissection: {msg}"))
}

impl MetisGraph {
    /// Converts `graph` (symmetric, no self loops; repeated neighbours are merged) and checks
    /// it.
    pub(super) fn from_graph(graph: &Graph) -> Result<MetisGraph, SolverError> {
        let n = graph.ptr.len() - 1;
        let mut xadj = Vec::with_capacity(n + 1);
        xadj.push(0);
        let mut adjncy: Vec<ffi::idx_t> = Vec::with_capacity(graph.adj.len());
        let too_large = || error(format!("{n} dofs exceed METIS's 32-bit indices"));
        for v in 0..n {
            let start = adjncy.len();
            for &u in graph.neighbors(v) {
                adjncy.push(ffi::idx_t::try_from(u).map_err(|_| too_large())?);
            }
            adjncy[start..].sort_unstable();
            let mut kept = start;
            for k in start..adjncy.len() {
                if k == start || adjncy[k] != adjncy[kept - 1] {
                    adjncy[kept] = adjncy[k];
                    kept += 1;
                }
            }
            adjncy.truncate(kept);
            xadj.push(ffi::idx_t::try_from(adjncy.len()).map_err(|_| too_large())?);
        }
        let m = Compressed::new(graph).weight.len();
        let nseps = if (m as f64) < COMPRESSION_FRACTION * n as f64 && n as f64 / m as f64 > 1.5 {
            2
        } else {
            1
        };
        MetisGraph::new(xadj, adjncy, nseps)
    }

    /// Checks what METIS assumes of its input: `xadj` has `n + 1` non-decreasing offsets from
    /// 0 to `adjncy.len()`, every neighbour lies in `0..n`, differs from its vertex and
    /// appears once (increasing), every edge is listed both ways, `n ≥ 1` and all sizes fit
    /// METIS's 32-bit indices.
    fn new(
        xadj: Vec<ffi::idx_t>,
        adjncy: Vec<ffi::idx_t>,
        nseps: ffi::idx_t,
    ) -> Result<MetisGraph, SolverError> {
        let n = xadj
            .len()
            .checked_sub(1)
            .ok_or_else(|| error("empty offsets"))?;
        if n == 0 {
            return Err(error("empty graph"));
        }
        ffi::idx_t::try_from(n).map_err(|_| error("too many vertices"))?;
        ffi::idx_t::try_from(adjncy.len()).map_err(|_| error("too many edges"))?;
        if xadj[0] != 0 || usize::try_from(xadj[n]).ok() != Some(adjncy.len()) {
            return Err(error("offsets do not span the adjacency"));
        }
        let row = |v: usize| -> Result<&[ffi::idx_t], SolverError> {
            let (s, e) = (xadj[v], xadj[v + 1]);
            if s < 0 || e < s {
                return Err(error(format!("decreasing offsets at vertex {v}")));
            }
            Ok(&adjncy[s as usize..e as usize])
        };
        for v in 0..n {
            let r = row(v)?;
            for (k, &u) in r.iter().enumerate() {
                if u < 0 || u as usize >= n || u as usize == v {
                    return Err(error(format!("vertex {v} has neighbour {u}")));
                }
                if k > 0 && r[k - 1] >= u {
                    return Err(error(format!(
                        "unsorted or repeated neighbours of vertex {v}"
                    )));
                }
            }
        }
        for v in 0..n {
            for &u in row(v)? {
                if row(u as usize)?.binary_search(&(v as ffi::idx_t)).is_err() {
                    return Err(error(format!("edge {v}–{u} is listed one way only")));
                }
            }
        }
        Ok(MetisGraph {
            xadj,
            adjncy,
            nseps,
        })
    }

    fn n(&self) -> usize {
        self.xadj.len() - 1
    }

    fn options(&self) -> [ffi::idx_t; ffi::METIS_NOPTIONS as usize] {
        // -1 selects METIS's default for every option (0-based numbering, seed -1, compression
        // on, no connected-component ordering); only the separator trials are set explicitly.
        let mut options = [-1; ffi::METIS_NOPTIONS as usize];
        options[ffi::moptions_et_METIS_OPTION_NUMBERING as usize] = 0;
        options[ffi::moptions_et_METIS_OPTION_NSEPS as usize] = self.nseps;
        options
    }

    /// `METIS_NodeNDP` with two parts: METIS's nested dissection and its top-level split.
    pub(super) fn node_nd_split(&self) -> Result<NodeNdOrder, SolverError> {
        let n = self.n();
        if self.adjncy.is_empty() {
            // No edges: nothing to dissect (METIS is not asked about edgeless graphs).
            return Ok(NodeNdOrder {
                perm: (0..n).collect(),
                top: None,
            });
        }
        let mut xadj = self.xadj.clone();
        let mut adjncy = self.adjncy.clone();
        let mut options = self.options();
        let mut perm: Vec<ffi::idx_t> = vec![0; n];
        let mut iperm: Vec<ffi::idx_t> = vec![0; n];
        let mut sizes: [ffi::idx_t; 3] = [0; 3];
        let status = {
            // METIS's random state is process-wide: one call at a time (see `METIS_LOCK`).
            let _serial = METIS_LOCK
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            // SAFETY: `xadj` (n + 1 offsets) and `adjncy` form a graph checked by
            // `MetisGraph::new` (offsets in range, neighbours in 0..n, symmetric, no self
            // loops or repeats, n and the edge count fit idx_t); `vwgt` is null (unit
            // weights); `options` has METIS_NOPTIONS entries; `perm` and `iperm` have n
            // entries; `sizes` has 2·npes − 1 = 3 entries. METIS reads the inputs through its
            // mutable pointers without writing them (0-based numbering: no renumbering) and
            // keeps no pointer after returning.
            unsafe {
                ffi::METIS_NodeNDP(
                    n as ffi::idx_t,
                    xadj.as_mut_ptr(),
                    adjncy.as_mut_ptr(),
                    std::ptr::null_mut(),
                    2,
                    options.as_mut_ptr(),
                    perm.as_mut_ptr(),
                    iperm.as_mut_ptr(),
                    sizes.as_mut_ptr(),
                )
            }
        };
        check_status(status)?;
        let perm = checked_permutation(&perm)?;
        let top = sizes
            .iter()
            .map(|&s| usize::try_from(s).ok())
            .collect::<Option<Vec<usize>>>()
            .and_then(|s| <[usize; 3]>::try_from(s).ok())
            .filter(|s| s.iter().sum::<usize>() == n && self.uncoupled(&perm, s));
        Ok(NodeNdOrder { perm, top })
    }

    /// `METIS_NodeND` with the options of [`node_nd_split`](Self::node_nd_split): the
    /// reference ordering (no split reported) that the tests compare with.
    #[cfg(test)]
    fn node_nd(&self) -> Result<Vec<usize>, SolverError> {
        let n = self.n();
        if self.adjncy.is_empty() {
            return Ok((0..n).collect());
        }
        let mut nvtxs = n as ffi::idx_t;
        let mut xadj = self.xadj.clone();
        let mut adjncy = self.adjncy.clone();
        let mut options = self.options();
        let mut perm: Vec<ffi::idx_t> = vec![0; n];
        let mut iperm: Vec<ffi::idx_t> = vec![0; n];
        let status = {
            let _serial = METIS_LOCK
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            // SAFETY: as in `node_nd_split` (same checked graph, options and output lengths);
            // `nvtxs` is read, not kept.
            unsafe {
                ffi::METIS_NodeND(
                    &mut nvtxs,
                    xadj.as_mut_ptr(),
                    adjncy.as_mut_ptr(),
                    std::ptr::null_mut(),
                    options.as_mut_ptr(),
                    perm.as_mut_ptr(),
                    iperm.as_mut_ptr(),
                )
            }
        };
        check_status(status)?;
        checked_permutation(&perm)
    }

    /// Whether no edge joins the first `a` dofs of `perm` to the next `b` (the halves of a
    /// split must be uncoupled for the split factorisation).
    fn uncoupled(&self, perm: &[usize], [a, b, _]: &[usize; 3]) -> bool {
        let mut half = vec![0u8; perm.len()];
        for (new, &old) in perm.iter().enumerate() {
            half[old] = if new < *a {
                1
            } else if new < a + b {
                2
            } else {
                0
            };
        }
        (0..perm.len()).all(|v| {
            half[v] == 0
                || self.adjncy[self.xadj[v] as usize..self.xadj[v + 1] as usize]
                    .iter()
                    .all(|&u| half[u as usize] == 0 || half[u as usize] == half[v])
        })
    }
}

fn check_status(status: std::os::raw::c_int) -> Result<(), SolverError> {
    match status {
        ffi::rstatus_et_METIS_OK => Ok(()),
        ffi::rstatus_et_METIS_ERROR_INPUT => Err(error("input rejected")),
        ffi::rstatus_et_METIS_ERROR_MEMORY => Err(error("out of memory")),
        other => Err(error(format!("failed (status {other})"))),
    }
}

/// `perm` as `usize`, or an error unless it is a permutation of `0..perm.len()`.
fn checked_permutation(perm: &[ffi::idx_t]) -> Result<Vec<usize>, SolverError> {
    let n = perm.len();
    let mut seen = vec![false; n];
    perm.iter()
        .map(|&p| match usize::try_from(p) {
            Ok(p) if p < n && !std::mem::replace(&mut seen[p], true) => Ok(p),
            _ => Err(error("returned an invalid permutation")),
        })
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::ordering::test_patterns::block_grid;

    fn graph(k: usize) -> MetisGraph {
        MetisGraph::from_graph(&Graph::from_pattern(block_grid(k).as_ref())).unwrap()
    }

    #[test]
    fn malformed_graphs_are_rejected_before_metis() {
        let cases: [(Vec<i32>, Vec<i32>, &str); 7] = [
            (vec![], vec![], "empty offsets"),
            (vec![0], vec![], "empty graph"),
            (vec![0, 1, 2], vec![1], "span"),
            (vec![0, 1, 2], vec![1, 2], "neighbour 2"),
            (vec![0, 1, 1], vec![0], "neighbour 0"),
            (vec![0, 1, 1], vec![1], "one way"),
            (vec![0, 2, 3, 4], vec![2, 1, 0, 0], "unsorted"),
        ];
        for (xadj, adjncy, what) in cases {
            let e = MetisGraph::new(xadj.clone(), adjncy.clone(), 1)
                .err()
                .unwrap_or_else(|| panic!("{xadj:?} {adjncy:?} accepted"));
            assert!(e.to_string().contains(what), "{e} lacks {what:?}");
        }
        let e = MetisGraph::new(vec![0, 2, 2, 3], vec![1, 2, 0], 1)
            .err()
            .unwrap();
        assert!(e.to_string().contains("one way"), "{e}");
    }

    /// `METIS_NodeNDP` with two parts orders exactly as `METIS_NodeND` does, and its reported
    /// split numbers two uncoupled halves before the separator.
    #[test]
    fn node_ndp_equals_node_nd_and_reports_the_top_split() {
        let k = 20;
        let g = graph(k);
        assert_eq!(g.nseps, 2, "3 dofs per vertex compress by 3");
        let split = g.node_nd_split().unwrap();
        assert_eq!(split.perm, g.node_nd().unwrap());
        let [a, b, s] = split.top.unwrap();
        assert_eq!(a + b + s, 3 * k * k);
        // Whole vertices, a separator of about one to two grid lines of a king's-move grid.
        assert!(a % 3 == 0 && b % 3 == 0 && s % 3 == 0);
        assert!((3 * k..=3 * (2 * k + 2)).contains(&s), "separator {s}");
        assert!(a.min(b) * 2 > a.max(b), "unbalanced halves {a} {b}");
        // `top` is only reported for uncoupled halves; check the predicate itself fails on a
        // split that cuts through the grid without a separator.
        assert!(
            !g.uncoupled(&split.perm, &[a + 3, b - 3, s])
                || !g.uncoupled(&split.perm, &[a - 3, b + 3, s])
        );
    }

    #[test]
    fn edgeless_graphs_keep_the_natural_order() {
        let g = MetisGraph::new(vec![0, 0, 0, 0], vec![], 1).unwrap();
        let o = g.node_nd_split().unwrap();
        assert_eq!(o.perm, vec![0, 1, 2]);
        assert!(o.top.is_none());
    }
}
