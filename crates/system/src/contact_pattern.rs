//! The Hessian pattern of a shell with self-contact: the assembler's (face stencils) widened by
//! the vertex couplings of nearby contact pairs, so that each pair's full 12×12 Hessian fits.
//!
//! The pattern is a property of the current neighbourhoods, which change as the shell moves: it
//! is built from the pairs within [`PATTERN_REACH`]·d̂ of their gap threshold over the
//! first part of a solve (start and predicted positions), and rebuilt — a new symbolic
//! factorisation, see [`NewtonCache`](super::NewtonCache) — only when a pair that can become
//! active is not covered. The slack of the reach keeps rebuilds to one every few steps while a
//! shell slides along itself.

use faer::sparse::{SparseColMat, SymbolicSparseColMat, SymbolicSparseColMatRef};
use thinshell_energy::DofMap;

/// Reach of a built pattern beyond the activation threshold, in units of d̂: a pair is
/// coupled when its (swept) gap is below `(1 + PATTERN_REACH)·d̂`.
pub(crate) const PATTERN_REACH: f64 = 2.0;

/// The assembler's pattern plus contact couplings, with the map from the assembler's values.
#[derive(Clone, Debug)]
pub(crate) struct ContactPattern {
    symbolic: SymbolicSparseColMat<usize>,
    /// Index into the widened values of every stored entry of the assembler's pattern.
    shell_map: Vec<usize>,
    /// The assembler-pattern matrix the shell terms are assembled into before the copy
    /// (taken out while in use).
    pub(crate) scratch: Option<SparseColMat<usize, f64>>,
    /// The vertex couplings it was built from (checkpoints rebuild it from them).
    pub(crate) couplings: Vec<[usize; 2]>,
}

impl ContactPattern {
    /// `base` (the assembler's lower-triangle pattern over `dofs`' free dofs) plus every entry
    /// coupling the free coordinates of the vertices of each `[a, b]` in `couplings`.
    pub(crate) fn new(
        base: &SparseColMat<usize, f64>,
        dofs: &DofMap,
        couplings: &[[usize; 2]],
    ) -> ContactPattern {
        let b = base.symbolic();
        let n = b.ncols();
        // Extra (column, row) entries, row > column (lower triangle).
        let mut extra: Vec<(usize, usize)> = Vec::with_capacity(9 * couplings.len());
        for &[u, v] in couplings {
            for i in 0..3 {
                let Some(p) = dofs.coordinate_dof(3 * u + i) else {
                    continue;
                };
                for j in 0..3 {
                    let Some(q) = dofs.coordinate_dof(3 * v + j) else {
                        continue;
                    };
                    if p != q {
                        extra.push((p.min(q), p.max(q)));
                    }
                }
            }
        }
        extra.sort_unstable();
        extra.dedup();
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::with_capacity(b.row_idx().len() + extra.len());
        let mut shell_map = Vec::with_capacity(b.row_idx().len());
        let mut e = 0;
        for j in 0..n {
            col_ptr.push(row_idx.len());
            let rows = &b.row_idx()[b.col_range(j)];
            let mut k = 0;
            // Merge two sorted row lists; an extra entry already in the base is kept once.
            loop {
                let x = (e < extra.len() && extra[e].0 == j).then(|| extra[e].1);
                match (rows.get(k).copied(), x) {
                    (None, None) => break,
                    (Some(r), Some(x)) if x < r => {
                        row_idx.push(x);
                        e += 1;
                    }
                    (Some(r), x) => {
                        if x == Some(r) {
                            e += 1;
                        }
                        shell_map.push(row_idx.len());
                        row_idx.push(r);
                        k += 1;
                    }
                    (None, Some(x)) => {
                        row_idx.push(x);
                        e += 1;
                    }
                }
            }
        }
        col_ptr.push(row_idx.len());
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        ContactPattern {
            symbolic,
            shell_map,
            scratch: Some(base.clone()),
            couplings: couplings.to_vec(),
        }
    }

    /// Whether every coupling of `couplings` has its entries in the pattern.
    pub(crate) fn covers(&self, dofs: &DofMap, couplings: &[[usize; 2]]) -> bool {
        couplings.iter().all(|&[u, v]| {
            (0..3).all(|i| {
                (0..3).all(|j| {
                    match (
                        dofs.coordinate_dof(3 * u + i),
                        dofs.coordinate_dof(3 * v + j),
                    ) {
                        (Some(p), Some(q)) => entry(self.symbolic.as_ref(), p, q).is_some(),
                        _ => true,
                    }
                })
            })
        })
    }

    /// A matrix with the widened pattern, all values 0.
    pub(crate) fn template(&self) -> SparseColMat<usize, f64> {
        SparseColMat::new(
            self.symbolic.clone(),
            vec![0.0; self.symbolic.row_idx().len()],
        )
    }

    /// Whether `h` has exactly the widened pattern.
    pub(crate) fn has_pattern(&self, h: &SparseColMat<usize, f64>) -> bool {
        let (mine, theirs) = (self.symbolic.as_ref(), h.symbolic());
        theirs.ncols() == mine.ncols()
            && theirs.nrows() == mine.nrows()
            && theirs.col_nnz().is_none()
            && theirs.col_ptr() == mine.col_ptr()
            && theirs.row_idx() == mine.row_idx()
    }

    /// Overwrites `h` (widened pattern) with `shell` (assembler pattern), 0 elsewhere.
    pub(crate) fn widen(&self, shell: &SparseColMat<usize, f64>, h: &mut SparseColMat<usize, f64>) {
        let val = h.val_mut();
        val.fill(0.0);
        for (&o, &v) in self.shell_map.iter().zip(shell.val()) {
            val[o] += v;
        }
    }

    /// Entries beyond the assembler's.
    #[cfg(test)]
    pub(crate) fn extra_entries(&self) -> usize {
        self.symbolic.row_idx().len() - self.shell_map.len()
    }
}

/// The value index of entry (max(p, q), min(p, q)) of a lower-triangle pattern, if stored.
pub(crate) fn entry(s: SymbolicSparseColMatRef<'_, usize>, p: usize, q: usize) -> Option<usize> {
    let (row, col) = if p >= q { (p, q) } else { (q, p) };
    let range = s.col_range(col);
    let start = range.start;
    s.row_idx()[range]
        .binary_search(&row)
        .ok()
        .map(|k| start + k)
}
