//! The factorisation split at the top-level nested dissection: two halves factorised on two
//! threads and the separator's dense Schur complement, bit-identical for any thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::perm::PermRef;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, Par, Side};

use super::dense::{self, cholesky_blocked};
use super::error::FactorError;
use super::multifrontal::{self, Plan, Real};
use crate::SolverError;
use crate::ordering::inverse_permutation;

/// Factorisations below this many predicted flops are not split (whatever the thread count,
/// so that the result does not depend on it): splitting costs the scatter of the matrix into
/// the halves, the dense assembly of the separator's Schur complement and thread hand-offs.
pub const SPLIT_MIN_FLOPS: f64 = 2e8;

/// The factorisation split at the top-level dissection (see [`SparseCholesky::new`]).
///
/// With the permuted matrix split into halves `A`, `B` (uncoupled) and separator `S`, half `X`
/// (`A` or `B`) eliminates its own dofs from `M_X = [H_XX H_XS; H_SX 0]` and stops there: it
/// computes `L_XX`, `L_SX` and `T_X = −L_SX L_SXᵀ` (lower) but never factorises anything in
/// `S`. The Schur complement of the whole matrix, `(T_A + T_B) + H_SS` (summed entry by entry
/// in that order), is factorised densely. `H` is positive definite exactly when `H_AA`, `H_BB`
/// and that complement are. Every kernel runs on one thread (`Par::Seq`), every sum has a
/// fixed order and the separator's blocked Cholesky ([`cholesky_blocked`]) cuts its work into
/// fixed tasks, so the result does not depend on which thread ran what.
///
/// How a half stops at `S`: in the half's symbolic analysis the separator's columns all lie in
/// the last supernode (checked by [`Half::new`]; it also holds the last columns of the half,
/// those whose pattern is the whole separator), the *tail*. The multifrontal driver
/// ([`multifrontal::factorize`] with `stop` at the tail) factorises every supernode before the
/// tail and adds their updates into it (`−Σ L Lᵀ`) without factorising it. The half adds the
/// tail's matrix entries itself, eliminates the tail's own columns of `X` densely and leaves
/// `T_X` in the separator block, which it then overwrites with the identity: the half's
/// stored factor is `[L_XX 0; L_SX I]`, so its supernodal solves (faer's) give `−L_SX y_X` and
/// take `x_S` directly. So the split does the unsplit factorisation's flops (`split_flops`).
/// `T` is the precision the factor is computed and stored in (f64, or f32 for mixed
/// precision); the matrix and the solves' right-hand sides are f64.
pub(super) struct SplitFactor<T: Real> {
    /// `perm[new] = old` of the whole ordering.
    perm: Vec<usize>,
    /// Dofs of A, B, S.
    sizes: [usize; 3],
    halves: [Half<T>; 2],
    /// Positions in `h`'s value array of the S × S lower entries and their (row, col) in S.
    s_entries: Vec<(usize, usize, usize)>,
    /// Dense s × s: half A's `T_A`, then the Schur complement, then its Cholesky factor
    /// (lower).
    schur: Mat<T>,
    /// Dense s × s: half B's `T_B` (lower).
    product: Mat<T>,
    schur_mem: MemBuffer,
    /// Permuted right-hand side / solution.
    work: Vec<T>,
    par: Par,
}

/// One half `M = [H_XX H_XS; H_SX 0]` of a [`SplitFactor`], partially factorised (its dofs
/// only).
struct Half<T: Real> {
    symbolic: SymbolicCholesky<usize>,
    /// The multifrontal schedule of `symbolic`.
    plan: Plan,
    /// The multifrontal update stack.
    stack: Vec<T>,
    /// (position in `h`'s value array, position in `l_values`), columns before the tail.
    scatter: Vec<(usize, usize)>,
    /// (position in `h`'s value array, row, column in the tail block): the entries of the
    /// tail's columns of `X` (those of `S × S` are added once, to the Schur complement).
    tail_scatter: Vec<(usize, usize, usize)>,
    /// First column of the tail, the last supernode (≤ the separator's first column).
    tail: usize,
    /// Offset of the tail's dense block (w × w, w = m − tail, column-major) in `l_values`.
    tail_offset: usize,
    l_values: Vec<T>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    /// Right-hand side / solution of `M`'s solves (m values).
    rhs: Vec<T>,
    /// The separator's size s.
    s: usize,
}

/// The supernodal structure of `symbolic` (`None`: simplicial).
fn supernodal(symbolic: &SymbolicCholesky<usize>) -> Option<&SymbolicSupernodalCholesky<usize>> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(s) => Some(s),
        SymbolicCholeskyRaw::Simplicial(_) => None,
    }
}

impl<T: Real> Half<T> {
    /// `range`: the half's dofs in the permuted numbering; the separator follows it. `None`
    /// when the half's symbolic analysis does not put the whole separator in its last
    /// supernode (the split then does not apply).
    fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        inv: &[usize],
        range: std::ops::Range<usize>,
        sep_start: usize,
    ) -> Result<Option<Half<T>>, SolverError> {
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
        let Some(sn) = supernodal(&symbolic) else {
            return Ok(None);
        };
        let last = sn.n_supernodes() - 1;
        let tail = sn.supernode_begin()[last];
        let first = m - s;
        if tail > first {
            return Ok(None);
        }
        let Some(plan) = Plan::new(sn) else {
            return Ok(None);
        };
        let mut scatter = Vec::new();
        let mut tail_scatter = Vec::new();
        for &(col, row, p) in &entries {
            if col < tail {
                let Some(q) = plan.position(row, col) else {
                    return Ok(None);
                };
                scatter.push((p, q));
            } else if col < first {
                tail_scatter.push((p, row - tail, col - tail));
            }
        }
        let factor_mem = MemBuffer::try_new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<T>(
                plan.max_width().max(m),
                Par::Seq,
                Default::default(),
            ),
        )
        .map_err(|_| SolverError::Linear("out of memory for factorisation scratch".into()))?;
        let solve_mem = MemBuffer::try_new(symbolic.solve_in_place_scratch::<T>(1, Par::Seq))
            .map_err(|_| SolverError::Linear("out of memory for solve scratch".into()))?;
        let tail_offset = sn.col_ptr_for_val()[last];
        Ok(Some(Half {
            l_values: vec![T::of(0.0); symbolic.len_val()],
            symbolic,
            stack: vec![T::of(0.0); plan.stack_len()],
            plan,
            scatter,
            tail_scatter,
            tail,
            tail_offset,
            factor_mem,
            solve_mem,
            rhs: vec![T::of(0.0); m],
            s,
        }))
    }

    /// Predicted flops of the half ([`factor_flops`](super::factor_flops)'s count over the
    /// half's own columns: the separator's are not factorised here).
    fn flops(&self) -> f64 {
        let Some(sn) = supernodal(&self.symbolic) else {
            return 0.0;
        };
        let first = self.rhs.len() - self.s;
        let (begin, end) = (sn.supernode_begin(), sn.supernode_end());
        (0..sn.n_supernodes())
            .map(|k| {
                let below = sn.supernode(k).pattern().len();
                (begin[k]..end[k].min(first))
                    .map(|c| ((end[k] - c + below) as f64).powi(2))
                    .sum::<f64>()
            })
            .sum()
    }

    /// Eliminates the half's dofs from `M` (values from `h`) and writes the lower triangle of
    /// `T_X = −L_SX L_SXᵀ` into `product` (see [`SplitFactor`]). Errors with the failing pivot
    /// in `M`'s numbering.
    fn factorize(&mut self, h: &[f64], product: &mut Mat<T>) -> Result<(), usize> {
        self.l_values.fill(T::of(0.0));
        for &(src, dst) in &self.scatter {
            self.l_values[dst] = T::of(h[src]);
        }
        // Every supernode but the tail, whose columns then hold −Σ L Lᵀ of the others.
        let last = self.plan.len() - 1;
        multifrontal::factorize(
            &self.plan,
            &mut self.l_values,
            &mut self.stack,
            last,
            MemStack::new(&mut self.factor_mem),
            multifrontal::flush_threshold(super::engine::max_abs(h)),
            None,
        )?;
        let m = self.rhs.len();
        let s = self.s;
        let (w, k) = (m - self.tail, m - s - self.tail);
        let tail = &mut self.l_values[self.tail_offset..self.tail_offset + w * w];
        for &(src, i, j) in &self.tail_scatter {
            tail[i + j * w] += T::of(h[src]);
        }
        // The tail is w × w column-major: the separator block's column j, from its diagonal
        // down, is `tail[separator(j)]`.
        let separator = |j: usize| (k + j) * w + k + j..(k + j + 1) * w;
        for j in 0..s {
            product.col_as_slice_mut(j)[j..].copy_from_slice(&tail[separator(j)]);
        }
        // The tail's columns of X, densely: L11 L11ᵀ = W11, L21 = W21 L11⁻ᵀ, then
        // T_X = W22 − L21 L21ᵀ.
        let block = MatMut::from_column_major_slice_mut(tail, w, w);
        let (mut w11, _, mut w21, _) = block.split_at_mut(k, k);
        faer::linalg::cholesky::llt::factor::cholesky_in_place(
            w11.rb_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut self.factor_mem),
            Default::default(),
        )
        .map_err(|DenseLltError::NonPositivePivot { index }| self.tail + index)?;
        solve_lower_triangular_in_place(w11.rb(), w21.rb_mut().transpose_mut(), Par::Seq);
        triangular::matmul(
            product.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Add,
            w21.rb(),
            BlockStructure::Rectangular,
            w21.rb().transpose(),
            BlockStructure::Rectangular,
            T::of(-1.0),
            Par::Seq,
        );
        // The stored factor's separator block becomes the identity (see `SplitFactor`).
        let tail = &mut self.l_values[self.tail_offset..self.tail_offset + w * w];
        for j in 0..s {
            let col = &mut tail[separator(j)];
            col.fill(T::of(0.0));
            col[0] = T::of(1.0);
        }
        Ok(())
    }

    /// Forward substitution with the stored factor `[L_XX 0; L_SX I]` on `[b_X; 0]` (`b_X`
    /// already in `rhs`): leaves `y_X` and then `−L_SX y_X` in `rhs`.
    fn forward(&mut self) {
        let m = self.rhs.len();
        self.rhs[m - self.s..].fill(T::of(0.0));
        if let Some(sn) = supernodal(&self.symbolic) {
            let l = SupernodalLltRef::new(sn, &self.l_values);
            l.l_solve_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut self.rhs, m, 1),
                Par::Seq,
                MemStack::new(&mut self.solve_mem),
            );
        }
    }

    /// Back substitution with the stored factor's transpose on `[y_X; x_S]`: leaves `x_X` in
    /// `rhs[..m − s]`.
    fn backward(&mut self, x_s: &[T]) {
        let m = self.rhs.len();
        self.rhs[m - self.s..].copy_from_slice(x_s);
        if let Some(sn) = supernodal(&self.symbolic) {
            let l = SupernodalLltRef::new(sn, &self.l_values);
            l.l_transpose_solve_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut self.rhs, m, 1),
                Par::Seq,
                MemStack::new(&mut self.solve_mem),
            );
        }
    }

    /// `−L_SX y_X` after [`forward`](Self::forward).
    fn separator_part(&self) -> &[T] {
        &self.rhs[self.rhs.len() - self.s..]
    }
}

impl<T: Real> SplitFactor<T> {
    /// The split of `pattern` at the top-level dissection `perm` (`sizes`: dofs of A, B, S);
    /// `None` when a half's symbolic analysis does not suit it ([`Half::new`]), a property of
    /// the pattern alone, so the choice does not depend on the thread count.
    pub(super) fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        perm: Vec<usize>,
        sizes: [usize; 3],
        par: Par,
    ) -> Result<Option<SplitFactor<T>>, SolverError> {
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
        let (Some(h0), Some(h1)) = (
            Half::new(pattern, &inv, 0..a, sep)?,
            Half::new(pattern, &inv, a..sep, sep)?,
        ) else {
            return Ok(None);
        };
        let schur_mem = MemBuffer::try_new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<T>(
                dense::BLOCK.min(s),
                Par::Seq,
                Default::default(),
            ),
        )
        .map_err(|_| SolverError::Linear("out of memory for factorisation scratch".into()))?;
        Ok(Some(SplitFactor {
            perm,
            sizes,
            halves: [h0, h1],
            s_entries,
            schur: Mat::zeros(s, s),
            product: Mat::zeros(s, s),
            schur_mem,
            work: vec![T::of(0.0); n],
            par,
        }))
    }

    /// Bytes held by the factors, the Schur complement and scratch.
    pub(super) fn memory(&self) -> u64 {
        let s = self.sizes[2];
        let halves: usize = self
            .halves
            .iter()
            .map(|h| std::mem::size_of::<T>() * (h.l_values.len() + h.stack.len()))
            .sum();
        (halves + 2 * std::mem::size_of::<T>() * s * s) as u64
    }

    /// Predicted flops `[half A, half B, separator]` (halves: their own columns, as
    /// [`factor_flops`](super::factor_flops) counts them; separator: its dense Cholesky,
    /// s³/3).
    pub(super) fn flops(&self) -> [f64; 3] {
        let s = self.sizes[2] as f64;
        [
            self.halves[0].flops(),
            self.halves[1].flops(),
            s * s * s / 3.0,
        ]
    }

    /// Whether the halves run concurrently.
    fn concurrent(&self) -> bool {
        self.par.degree() >= 2
    }

    pub(super) fn factorize(&mut self, h: &[f64]) -> Result<(), FactorError> {
        let [a, b, s] = self.sizes;
        let concurrent = self.concurrent();
        let [h0, h1] = &mut self.halves;
        let (pa, pb) = (&mut self.schur, &mut self.product);
        let (r0, r1) = if concurrent {
            rayon::join(|| h0.factorize(h, pa), || h1.factorize(h, pb))
        } else {
            (h0.factorize(h, pa), h1.factorize(h, pb))
        };
        r0.map_err(|p| FactorError::NotPositiveDefinite {
            pivot: if p < a { p } else { p + b },
        })?;
        r1.map_err(|p| FactorError::NotPositiveDefinite { pivot: a + p })?;
        // S = (T_A + T_B) + H_SS (lower triangle; H_SS's entries are distinct).
        for j in 0..s {
            let t_b = &self.product.col_as_slice(j)[j..];
            for (t, u) in self.schur.col_as_slice_mut(j)[j..].iter_mut().zip(t_b) {
                *t += u;
            }
        }
        for &(p, i, j) in &self.s_entries {
            self.schur[(i, j)] += T::of(h[p]);
        }
        let schur = self.schur.as_mut();
        cholesky_blocked(schur, concurrent, MemStack::new(&mut self.schur_mem)).map_err(
            |index| FactorError::NotPositiveDefinite {
                pivot: a + b + index,
            },
        )?;
        Ok(())
    }

    pub(super) fn solve_in_place(&mut self, rhs: &mut [f64]) {
        let [a, b, s] = self.sizes;
        let sep = a + b;
        for (new, &old) in self.perm.iter().enumerate() {
            self.work[new] = T::of(rhs[old]);
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
        for ((x, p), q) in x_s
            .iter_mut()
            .zip(h0.separator_part())
            .zip(h1.separator_part())
        {
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
            rhs[old] = self.work[new].wide();
        }
    }
}
