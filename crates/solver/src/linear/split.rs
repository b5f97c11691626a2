//! The factorisation split at the top-level nested dissection: two halves factorised on two
//! threads and the separator's dense Schur complement, bit-identical for any thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::perm::PermRef;
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMat, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, Par, Side};

use super::error::FactorError;
use crate::SolverError;
use crate::ordering::inverse_permutation;

/// Factorisations below this many predicted flops are not split (whatever the thread count,
/// so that the result does not depend on it): splitting costs two extra dense products of the
/// top separator's size, a second factorisation of its block, and a thread hand-off.
pub const SPLIT_MIN_FLOPS: f64 = 2e8;

/// The factorisation split at the top-level dissection (see [`SparseCholesky::new`]): with the
/// permuted matrix split into halves `A`, `B` (uncoupled) and separator `S`, each half
/// factorises `M_A = [H_AA H_AS; H_SA H_SS]` (resp. `M_B`) with faer, whose trailing block is
/// `C_A C_Aᵀ = H_SS − L_SA L_SAᵀ`, and forms the lower triangle of `C_A C_Aᵀ` in its own
/// buffer; the Schur complement of the whole matrix, `(C_A C_Aᵀ + C_B C_Bᵀ) − H_SS` (summed
/// entry by entry in that order), is factorised densely. `H` is positive definite exactly when
/// `M_A`, `M_B` and that complement are. Every kernel runs on one thread (`Par::Seq`) and
/// every sum has a fixed order, so the result does not depend on which thread ran what.
pub(super) struct SplitFactor {
    /// `perm[new] = old` of the whole ordering.
    perm: Vec<usize>,
    /// Dofs of A, B, S.
    pub(super) sizes: [usize; 3],
    pub(super) halves: [Half; 2],
    /// Positions in `h`'s value array of the S × S lower entries and their (row, col) in S.
    s_entries: Vec<(usize, usize, usize)>,
    /// Dense s × s: half A's product `C_A C_Aᵀ`, then the Schur complement, then its
    /// Cholesky factor (lower).
    schur: Mat<f64>,
    /// Dense s × s: half B's product `C_B C_Bᵀ` (lower).
    product: Mat<f64>,
    schur_mem: MemBuffer,
    /// Permuted right-hand side / solution.
    work: Vec<f64>,
    par: Par,
}

/// One half `M = [H_XX H_XS; H_SX H_SS]` of a [`SplitFactor`].
pub(super) struct Half {
    pub(super) symbolic: SymbolicCholesky<usize>,
    matrix: SparseColMat<usize, f64>,
    /// (position in `h`'s value array, position in `matrix`'s).
    scatter: Vec<(usize, usize)>,
    l_values: Vec<f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    /// The trailing s × s block of the factor, dense lower.
    c: Mat<f64>,
    rhs: Vec<f64>,
    tmp: Vec<f64>,
}

impl Half {
    /// `range`: the half's dofs in the permuted numbering; the separator follows it.
    fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        inv: &[usize],
        range: std::ops::Range<usize>,
        sep_start: usize,
    ) -> Result<Half, SolverError> {
        let n = pattern.ncols();
        let nx = range.len();
        let s = n - sep_start;
        let m = nx + s;
        let local = |new: usize| -> Option<usize> {
            if range.contains(&new) {
                Some(new - range.start)
            } else if new >= sep_start {
                Some(nx + new - sep_start)
            } else {
                None
            }
        };
        // (col, row, source position), lower triangle of M.
        let mut entries = Vec::new();
        for j in 0..n {
            for p in pattern.col_ptr()[j]..pattern.col_ptr()[j + 1] {
                let i = pattern.row_idx()[p];
                if let (Some(a), Some(b)) = (local(inv[i]), local(inv[j])) {
                    entries.push((a.min(b), a.max(b), p));
                }
            }
        }
        entries.sort_unstable();
        let mut col_ptr = vec![0usize; m + 1];
        for &(c, _, _) in &entries {
            col_ptr[c + 1] += 1;
        }
        for c in 0..m {
            col_ptr[c + 1] += col_ptr[c];
        }
        let row_idx: Vec<usize> = entries.iter().map(|e| e.1).collect();
        let scatter = entries.iter().enumerate().map(|(q, e)| (e.2, q)).collect();
        let structure = SymbolicSparseColMat::new_checked(m, m, col_ptr, None, row_idx);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        // An explicit identity: faer's `SymmetricOrdering::Identity` reads the pattern as the
        // upper triangle whatever the side.
        let identity: Vec<usize> = (0..m).collect();
        let symbolic = factorize_symbolic_cholesky(
            structure.as_ref(),
            Side::Lower,
            SymmetricOrdering::Custom(PermRef::new_checked(&identity, &identity, m)),
            params,
        )
        .map_err(|e| SolverError::Linear(format!("{e:?}")))?;
        let factor_mem = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        )
        .map_err(|_| SolverError::Linear("out of memory for factorisation scratch".into()))?;
        let solve_mem = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
            .map_err(|_| SolverError::Linear("out of memory for solve scratch".into()))?;
        let nnz = structure.row_idx().len();
        Ok(Half {
            l_values: vec![0.0; symbolic.len_val()],
            symbolic,
            matrix: SparseColMat::new(structure, vec![0.0; nnz]),
            scatter,
            factor_mem,
            solve_mem,
            c: Mat::zeros(s, s),
            rhs: vec![0.0; m],
            tmp: vec![0.0; s],
        })
    }

    fn supernodal(&self) -> Option<&SymbolicSupernodalCholesky<usize>> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Some(s),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        }
    }

    /// Factorises `M` (values from `h`), copies the trailing block into `c` and writes the lower
    /// triangle of `c cᵀ` into `product`. Errors with the failing pivot in `M`'s numbering.
    fn factorize(&mut self, h: &[f64], product: MatMut<'_, f64>) -> Result<(), usize> {
        let val = self.matrix.val_mut();
        for &(src, dst) in &self.scatter {
            val[dst] = h[src];
        }
        let stack = MemStack::new(&mut self.factor_mem);
        self.symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                self.matrix.as_ref(),
                Side::Lower,
                Default::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .map_err(|DenseLltError::NonPositivePivot { index }| index)?;
        let Some(sn) = (match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Some(s),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        }) else {
            return Err(0);
        };
        let m = self.rhs.len();
        let s = self.c.nrows();
        let first = m - s;
        self.c.as_mut().fill(0.0);
        let (begin, end, ptr) = (
            sn.supernode_begin(),
            sn.supernode_end(),
            sn.col_ptr_for_val(),
        );
        for k in 0..sn.n_supernodes() {
            if end[k] <= first {
                continue;
            }
            let width = end[k] - begin[k];
            let pattern = sn.supernode(k).pattern();
            let rows = width + pattern.len();
            for col in begin[k].max(first)..end[k] {
                let base = ptr[k] + (col - begin[k]) * rows;
                for r in (col - begin[k])..width {
                    self.c[(begin[k] + r - first, col - first)] = self.l_values[base + r];
                }
                for (q, &row) in pattern.iter().enumerate() {
                    self.c[(row - first, col - first)] = self.l_values[base + width + q];
                }
            }
        }
        triangular::matmul(
            product,
            BlockStructure::TriangularLower,
            Accum::Replace,
            self.c.as_ref(),
            BlockStructure::TriangularLower,
            self.c.as_ref().transpose(),
            BlockStructure::TriangularUpper,
            1.0,
            Par::Seq,
        );
        Ok(())
    }

    /// Forward substitution with `L_M` on `[b_X; 0]` (`b_X` already in `rhs`); leaves `y_X` in
    /// `rhs` and returns `C·t = −L_SX y_X` in `tmp`.
    fn forward(&mut self) {
        let m = self.rhs.len();
        let s = self.c.nrows();
        let first = m - s;
        self.rhs[first..].fill(0.0);
        if let SymbolicCholeskyRaw::Supernodal(sn) = self.symbolic.raw() {
            let l = SupernodalLltRef::new(sn, &self.l_values);
            let stack = MemStack::new(&mut self.solve_mem);
            l.l_solve_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut self.rhs, m, 1),
                Par::Seq,
                stack,
            );
        }
        let t = &self.rhs[first..];
        for i in 0..s {
            self.tmp[i] = (0..=i).map(|j| self.c[(i, j)] * t[j]).sum();
        }
    }

    /// Back substitution with `L_Mᵀ` on `[y_X; C_ᵀ x_S]`: leaves `x_X` in `rhs[..first]`.
    fn backward(&mut self, x_s: &[f64]) {
        let m = self.rhs.len();
        let s = self.c.nrows();
        let first = m - s;
        for j in 0..s {
            self.rhs[first + j] = (j..s).map(|i| self.c[(i, j)] * x_s[i]).sum();
        }
        if let SymbolicCholeskyRaw::Supernodal(sn) = self.symbolic.raw() {
            let l = SupernodalLltRef::new(sn, &self.l_values);
            let stack = MemStack::new(&mut self.solve_mem);
            l.l_transpose_solve_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut self.rhs, m, 1),
                Par::Seq,
                stack,
            );
        }
    }
}

impl SplitFactor {
    pub(super) fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        perm: Vec<usize>,
        sizes: [usize; 3],
        par: Par,
    ) -> Result<SplitFactor, SolverError> {
        let n = pattern.ncols();
        let [a, b, s] = sizes;
        let inv = inverse_permutation(&perm);
        let sep = a + b;
        let mut s_entries = Vec::new();
        for j in 0..n {
            for p in pattern.col_ptr()[j]..pattern.col_ptr()[j + 1] {
                let (ni, nj) = (inv[pattern.row_idx()[p]], inv[j]);
                if ni >= sep && nj >= sep {
                    s_entries.push((p, ni.max(nj) - sep, ni.min(nj) - sep));
                } else if (ni < a && (a..sep).contains(&nj)) || (nj < a && (a..sep).contains(&ni)) {
                    return Err(SolverError::Linear(
                        "nested-dissection split: the two halves are coupled".into(),
                    ));
                }
            }
        }
        let halves = [
            Half::new(pattern, &inv, 0..a, sep)?,
            Half::new(pattern, &inv, a..sep, sep)?,
        ];
        if halves.iter().any(|h| h.supernodal().is_none()) {
            return Err(SolverError::Linear("split factor is not supernodal".into()));
        }
        let schur_mem = MemBuffer::try_new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                s,
                Par::Seq,
                Default::default(),
            ),
        )
        .map_err(|_| SolverError::Linear("out of memory for factorisation scratch".into()))?;
        Ok(SplitFactor {
            perm,
            sizes,
            halves,
            s_entries,
            schur: Mat::zeros(s, s),
            product: Mat::zeros(s, s),
            schur_mem,
            work: vec![0.0; n],
            par,
        })
    }

    /// Bytes held by the factors, the Schur complement and scratch.
    pub(super) fn memory(&self) -> u64 {
        let s = self.sizes[2];
        let halves: usize = self
            .halves
            .iter()
            .map(|h| 8 * (h.l_values.len() + h.matrix.val().len() + s * s))
            .sum();
        (halves + 16 * s * s) as u64
    }

    /// Whether the halves run concurrently.
    fn concurrent(&self) -> bool {
        self.par.degree() >= 2
    }

    pub(super) fn factorize(&mut self, h: &[f64]) -> Result<(), FactorError> {
        let [a, b, s] = self.sizes;
        let concurrent = self.concurrent();
        let [h0, h1] = &mut self.halves;
        let (pa, pb) = (self.schur.as_mut(), self.product.as_mut());
        let (r0, r1) = if concurrent {
            rayon::join(|| h0.factorize(h, pa), || h1.factorize(h, pb))
        } else {
            (h0.factorize(h, pa), h1.factorize(h, pb))
        };
        r0.map_err(|p| FactorError::NotPositiveDefinite {
            pivot: if p < a { p } else { p + b },
        })?;
        r1.map_err(|p| FactorError::NotPositiveDefinite { pivot: a + p })?;
        // S = (C_A C_Aᵀ + C_B C_Bᵀ) − H_SS (lower triangle; H_SS's entries are distinct).
        let mut schur = self.schur.as_mut();
        for j in 0..s {
            for i in j..s {
                schur[(i, j)] += self.product[(i, j)];
            }
        }
        for &(p, i, j) in &self.s_entries {
            schur[(i, j)] -= h[p];
        }
        let stack = MemStack::new(&mut self.schur_mem);
        faer::linalg::cholesky::llt::factor::cholesky_in_place(
            schur,
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        )
        .map_err(|DenseLltError::NonPositivePivot { index }| {
            FactorError::NotPositiveDefinite {
                pivot: a + b + index,
            }
        })?;
        Ok(())
    }

    pub(super) fn solve_in_place(&mut self, rhs: &mut [f64]) {
        let [a, b, s] = self.sizes;
        let sep = a + b;
        for (new, &old) in self.perm.iter().enumerate() {
            self.work[new] = rhs[old];
        }
        let [h0, h1] = &mut self.halves;
        h0.rhs[..a].copy_from_slice(&self.work[..a]);
        h1.rhs[..b].copy_from_slice(&self.work[a..sep]);
        let concurrent = self.par.degree() >= 2;
        if concurrent {
            rayon::join(|| h0.forward(), || h1.forward());
        } else {
            h0.forward();
            h1.forward();
        }
        // y_S = L_S⁻¹ (b_S − L_SA y_A − L_SB y_B), then x_S = L_S⁻ᵀ y_S.
        let (_, x_s) = self.work.split_at_mut(sep);
        for ((x, p), q) in x_s.iter_mut().zip(&h0.tmp).zip(&h1.tmp) {
            *x += p + q;
        }
        let mut xs = MatMut::from_column_major_slice_mut(x_s, s, 1);
        solve_lower_triangular_in_place(self.schur.as_ref(), xs.rb_mut(), Par::Seq);
        solve_upper_triangular_in_place(self.schur.as_ref().transpose(), xs.rb_mut(), Par::Seq);
        let x_s = &self.work[sep..];
        if concurrent {
            rayon::join(|| h0.backward(x_s), || h1.backward(x_s));
        } else {
            h0.backward(x_s);
            h1.backward(x_s);
        }
        self.work[..a].copy_from_slice(&h0.rhs[..a]);
        self.work[a..sep].copy_from_slice(&h1.rhs[..b]);
        for (new, &old) in self.perm.iter().enumerate() {
            rhs[old] = self.work[new];
        }
    }
}
