//! The numeric factorisation in one precision: the unsplit factor (the multifrontal driver, or
//! faer's own for a simplicial analysis) or the split one, its values, scratch and solves.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use super::multifrontal::{self, FactorProfile, Plan, Real};
use super::split::SplitFactor;
use super::symbolic::TopSplit;
use super::{FactorError, check_budget, factor_memory_estimate};
use crate::SolverError;

/// How the numeric factorisation runs, in precision `T` (one per factorisation: the size
/// difference of the variants does not matter).
#[allow(clippy::large_enum_variant)]
pub(super) enum Engine<T: Real> {
    /// One sequential factorisation of the whole matrix.
    Whole(Whole<T>),
    /// The two halves of the top nested-dissection split ([`SplitFactor`]).
    Split(Box<SplitFactor<T>>),
}

/// The unsplit factorisation.
pub(super) struct Whole<T: Real> {
    symbolic: SymbolicCholesky<usize>,
    /// The multifrontal driver's schedule and the matrix's positions in the factor; `None`:
    /// faer's driver (a simplicial analysis, or [`Engine::use_faer_driver`]).
    multifrontal: Option<Multifrontal>,
    /// The multifrontal update stack.
    stack: Vec<T>,
    l_values: Vec<T>,
    /// faer's driver only: the matrix's values in `T`.
    values: Vec<T>,
    /// The right-hand side in `T`.
    rhs: Vec<T>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
}

/// The multifrontal driver's schedule and the positions of the matrix's entries in the factor.
struct Multifrontal {
    plan: Plan,
    /// Offset in the factor's values of each stored entry of the (unpermuted) matrix.
    map: Vec<usize>,
}

impl Multifrontal {
    /// `None` for a simplicial symbolic factor (or a supernodal one the plan does not accept).
    fn new(
        symbolic: &SymbolicCholesky<usize>,
        pattern: SymbolicSparseColMatRef<'_, usize>,
    ) -> Option<Multifrontal> {
        let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
            return None;
        };
        let plan = Plan::new(sn)?;
        let identity: Vec<usize>;
        let inv = match symbolic.perm() {
            Some(p) => p.arrays().1,
            None => {
                identity = (0..pattern.ncols()).collect();
                &identity
            }
        };
        let mut map = Vec::with_capacity(pattern.row_idx().len());
        for j in 0..pattern.ncols() {
            for &i in pattern.row_idx_of_col_raw(j) {
                let (a, b) = (inv[i], inv[j]);
                map.push(plan.position(a.max(b), a.min(b))?);
            }
        }
        Some(Multifrontal { plan, map })
    }
}

/// Largest magnitude of `values`.
pub(super) fn max_abs(values: &[f64]) -> f64 {
    values.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

impl<T: Real> Engine<T> {
    /// The engine of `symbolic` (the analysis of `pattern`), split at `split` (the whole
    /// ordering and the sizes of the halves and separator) when given and the halves' analyses
    /// allow it. Refuses ([`SolverError::InsufficientMemory`]) a factor beyond the memory
    /// budget before allocating it. Returns the engine and its memory estimate (bytes).
    pub(super) fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        symbolic: SymbolicCholesky<usize>,
        split: Option<TopSplit>,
        par: Par,
    ) -> Result<(Engine<T>, u64), SolverError> {
        let factor_len = symbolic.len_val();
        let bytes = std::mem::size_of::<T>();
        if let Some((perm, sizes)) = split {
            // The split holds about the whole factor, a second copy of the separator block
            // (each half stores one) and two dense separator blocks: refuse it before
            // allocating.
            let [_, _, sep] = sizes;
            let estimate = factor_memory_estimate(factor_len + 3 * sep * sep, bytes, 0, 0);
            check_budget(symbolic.nrows(), estimate)?;
            if let Some(f) = SplitFactor::new(pattern, perm, sizes, par)? {
                let estimate = f.memory();
                return Ok((Engine::Split(Box::new(f)), estimate));
            }
        }
        let n = symbolic.nrows();
        let multifrontal = Multifrontal::new(&symbolic, pattern);
        let factor_req = match &multifrontal {
            Some(m) => faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<T>(
                m.plan.max_width(),
                Par::Seq,
                Default::default(),
            ),
            None => StackReq::EMPTY,
        }
        .or(symbolic.factorize_numeric_llt_scratch::<T>(Par::Seq, Default::default()));
        let solve_req = symbolic.solve_in_place_scratch::<T>(1, Par::Seq);
        let stack = multifrontal.as_ref().map_or(0, |m| m.plan.stack_len());
        let values = if multifrontal.is_some() {
            0
        } else {
            pattern.row_idx().len()
        };
        let estimate = factor_memory_estimate(
            factor_len + stack + values + n,
            bytes,
            factor_req.size_bytes(),
            solve_req.size_bytes(),
        );
        check_budget(n, estimate)?;
        let factor_mem = MemBuffer::try_new(factor_req)
            .map_err(|_| SolverError::Linear("out of memory for factorisation scratch".into()))?;
        let solve_mem = MemBuffer::try_new(solve_req)
            .map_err(|_| SolverError::Linear("out of memory for solve scratch".into()))?;
        let zero = T::of(0.0);
        Ok((
            Engine::Whole(Whole {
                l_values: vec![zero; factor_len],
                stack: vec![zero; stack],
                values: vec![zero; values],
                rhs: vec![zero; n],
                symbolic,
                multifrontal,
                factor_mem,
                solve_mem,
            }),
            estimate,
        ))
    }

    /// Makes an unsplit engine use faer's left-looking driver (measurements).
    pub(super) fn use_faer_driver(&mut self, pattern_len: usize) {
        if let Engine::Whole(w) = self
            && w.multifrontal.is_some()
        {
            w.multifrontal = None;
            w.values = vec![T::of(0.0); pattern_len];
        }
    }

    /// Whether the unsplit engine runs the multifrontal driver.
    pub(super) fn is_multifrontal(&self) -> bool {
        matches!(self, Engine::Whole(w) if w.multifrontal.is_some())
    }

    /// Numeric factorisation of `h` (its pattern already checked); `profile`: see
    /// [`multifrontal::factorize`].
    pub(super) fn factorize(
        &mut self,
        h: SparseColMatRef<'_, usize, f64>,
        profile: Option<&mut FactorProfile>,
    ) -> Result<(), FactorError> {
        let w = match self {
            Engine::Split(f) => return f.factorize(h.val()),
            Engine::Whole(w) => w,
        };
        match &w.multifrontal {
            Some(m) => {
                w.l_values.fill(T::of(0.0));
                for (&dst, &v) in m.map.iter().zip(h.val()) {
                    w.l_values[dst] = T::of(v);
                }
                multifrontal::factorize(
                    &m.plan,
                    &mut w.l_values,
                    &mut w.stack,
                    m.plan.len(),
                    MemStack::new(&mut w.factor_mem),
                    multifrontal::flush_threshold(max_abs(h.val())),
                    profile,
                )
                .map_err(|pivot| FactorError::NotPositiveDefinite { pivot })?;
            }
            None => {
                for (a, &v) in w.values.iter_mut().zip(h.val()) {
                    *a = T::of(v);
                }
                let a = SparseColMatRef::new(h.symbolic(), &w.values);
                w.symbolic
                    .factorize_numeric_llt(
                        &mut w.l_values,
                        a,
                        Side::Lower,
                        Default::default(),
                        Par::Seq,
                        MemStack::new(&mut w.factor_mem),
                        Default::default(),
                    )
                    // The low-level API reports the dense error type directly (not wrapped in
                    // `sparse::linalg::LltError::Numeric` as the high-level `Llt` does).
                    .map_err(|DenseLltError::NonPositivePivot { index }| {
                        FactorError::NotPositiveDefinite { pivot: index }
                    })?;
            }
        }
        Ok(())
    }

    /// Solves with the last successful factorisation, in `T` (`rhs` rounded to `T` and back).
    pub(super) fn solve_in_place(&mut self, rhs: &mut [f64]) {
        match self {
            Engine::Split(f) => f.solve_in_place(rhs),
            Engine::Whole(w) => {
                let n = rhs.len();
                for (a, &b) in w.rhs.iter_mut().zip(rhs.iter()) {
                    *a = T::of(b);
                }
                let llt = LltRef::new(&w.symbolic, &w.l_values);
                llt.solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(&mut w.rhs, n, 1),
                    Par::Seq,
                    MemStack::new(&mut w.solve_mem),
                );
                for (a, &b) in rhs.iter_mut().zip(&w.rhs) {
                    *a = b.wide();
                }
            }
        }
    }

    /// Predicted flops of the split's parts (see `SparseCholesky::split_flops`).
    pub(super) fn split_flops(&self) -> Option<[f64; 3]> {
        match self {
            Engine::Whole(_) => None,
            Engine::Split(f) => Some(f.flops()),
        }
    }
}
