//! Sparse Cholesky factorisation with a reused symbolic analysis and regularisation.
//!
//! [`SparseCholesky::new`] does the symbolic analysis (ordering, elimination tree, supernodes)
//! once per sparsity pattern and allocates the factor values and faer's scratch memory; every
//! later [`factorize`](SparseCholesky::factorize) / [`solve_in_place`](SparseCholesky::solve_in_place)
//! reuses them and allocates nothing. [`factorize_regularized`](SparseCholesky::factorize_regularized)
//! retries a matrix that is not positive definite with a growing diagonal shift
//! `H + μ·s·I` (or `H + μ·diag(|H|)`), written through precomputed diagonal offsets.
//!
//! The numeric factorisation of a supernodal analysis is the project's multifrontal driver on
//! faer's dense kernels (`multifrontal`: one symmetric product per supernode instead of faer's
//! one per pair of supernodes); solves are faer's. With
//! [`set_mixed_precision`](SparseCholesky::set_mixed_precision) the factor is computed in f32
//! and solves are refined to f64 accuracy (`mixed`).
//!
//! Module layout: `error` (a failed factorisation), `symbolic` (diagonal offsets, ordering,
//! faer's symbolic analysis, predicted flops), `regularise` (the shift's parameters and the retry
//! loop), `multifrontal` (the numeric driver), `engine` (the numeric factorisation in one
//! precision, unsplit or split), `split` (the two-thread factorisation at the top-level
//! dissection), `dense` (its separator's blocked dense Cholesky), `mixed` (mixed precision); the
//! type is here.

mod dense;
mod engine;
mod error;
mod mixed;
mod multifrontal;
mod regularise;
mod split;
mod symbolic;

use std::time::{Duration, Instant};

use faer::Par;
use faer::dyn_stack::MemBuffer;
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};

use crate::SolverError;
use crate::ordering::Ordering;
use engine::Engine;
use mixed::Mixed;

pub use error::FactorError;
#[doc(hidden)]
pub use multifrontal::{ClassProfile, FactorProfile};

pub use mixed::{PrecisionFallback, PrecisionStats};
pub use regularise::{FactorOutcome, RegularizationKind, RegularizationParams};
pub use split::SPLIT_MIN_FLOPS;
pub(crate) use symbolic::analyse;
pub use symbolic::{diagonal_offsets, factor_flops};

/// Statistics of the symbolic analysis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorStats {
    /// Matrix dimension.
    pub n: usize,
    /// Stored entries of the lower triangle of A.
    pub nnz_lower: usize,
    /// Stored values of the factor L (supernodal blocks included).
    pub factor_len: usize,
    /// Predicted flops of the numeric factorisation, Σ over columns of (column count)².
    pub flops: f64,
    /// Ordering actually used (never `Auto`).
    pub ordering: Ordering,
    /// Whether faer chose the supernodal (blocked) factorisation.
    pub supernodal: bool,
    /// Wall time of the ordering and symbolic analysis.
    pub symbolic_time: Duration,
    /// Bytes the numeric factorisation will hold, estimated from the symbolic analysis: the
    /// factor's values (`factor_len` f64) plus faer's factorisation and solve scratch.
    pub memory_estimate: u64,
}

/// Bytes of a factor with `len_val` values of `bytes` each and the given scratch sizes.
fn factor_memory_estimate(
    len_val: usize,
    bytes: usize,
    factor_scratch: usize,
    solve_scratch: usize,
) -> u64 {
    (len_val * bytes + factor_scratch + solve_scratch) as u64
}

/// A sparse LLᵀ factorisation whose symbolic part, factor storage and scratch memory are reused
/// for every matrix with the same pattern.
pub struct SparseCholesky {
    engine: Engine<f64>,
    /// Mixed precision: the single-precision engine when enabled, and what it did.
    mixed: Mixed,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    diag_offsets: Vec<usize>,
    diag_backup: Vec<f64>,
    par: Par,
    stats: FactorStats,
    factorized: bool,
}

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("stats", &self.stats)
            .field("par", &self.par)
            .field("factorized", &self.factorized)
            .finish_non_exhaustive()
    }
}

impl SparseCholesky {
    /// Symbolic analysis of a square pattern holding the lower triangle with every diagonal
    /// entry present. `coordinates` (per dof, m) feed the geometric nested dissection.
    ///
    /// `par`: with [`Par::Seq`] the whole matrix is factorised sequentially (the fewest
    /// flops on one thread). With [`Par::Rayon`] of any thread count, an [`Ordering::Metis`]
    /// ordering (chosen or picked by `Auto`) and predicted flops of at least
    /// [`SPLIT_MIN_FLOPS`], the factorisation is split at the top-level dissection
    /// ([`is_split`](Self::is_split)) when the halves' symbolic analyses allow it (almost
    /// always; otherwise the unsplit factorisation, as with `Par::Seq`): each half
    /// eliminates its own dofs on one thread and leaves its update of the separator
    /// block, and the separator's Schur complement is factorised densely by blocks; the two
    /// halves (and the halves of each solve) run concurrently (`rayon::join`) and so do the
    /// dense blocks' tasks when the pool has ≥ 2 threads, one after the other otherwise. The
    /// same floating-point operations run in the same order either way, so factors and
    /// solutions are bit-identical for any `Par::Rayon` thread count (they differ from
    /// [`Par::Seq`]'s in the last bits; the split does the same flops as the unsplit
    /// factorisation, `split_flops`; docs/performance.md).
    /// faer's own parallelism is not used: it only splits the dense kernels inside each
    /// supernode, which are too small on shell Hessians, and its parallel reductions depend on
    /// the thread count.
    pub fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        ordering: Ordering,
        coordinates: Option<&[[f64; 3]]>,
        par: Par,
    ) -> Result<SparseCholesky, SolverError> {
        let start = Instant::now();
        let n = pattern.ncols();
        let diag_offsets = diagonal_offsets(pattern)?;
        let (symbolic, used, split) = analyse(pattern, ordering, coordinates)?;
        let flops = factor_flops(&symbolic);
        let factor_len = symbolic.len_val();
        let supernodal = matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_));
        let split = split.filter(|(_, sizes)| {
            matches!(par, Par::Rayon(_)) && flops >= SPLIT_MIN_FLOPS && sizes.iter().all(|&k| k > 0)
        });
        // The ordering, kept to build the single-precision engine on request.
        let perm = match &split {
            Some((perm, _)) => Some(perm.clone()),
            None => symbolic.perm().map(|p| p.arrays().0.to_vec()),
        };
        let sizes = split.as_ref().map(|s| s.1);
        let (engine, estimate) = Engine::<f64>::new(pattern, symbolic, split, par)?;
        let stats = FactorStats {
            n,
            nnz_lower: pattern.row_idx().len(),
            factor_len,
            flops,
            ordering: used,
            supernodal,
            symbolic_time: start.elapsed(),
            memory_estimate: estimate,
        };
        Ok(SparseCholesky {
            engine,
            mixed: Mixed {
                perm,
                sizes,
                ..Mixed::default()
            },
            col_ptr: pattern.col_ptr().to_vec(),
            row_idx: pattern.row_idx().to_vec(),
            diag_backup: vec![0.0; n],
            diag_offsets,
            par,
            stats,
            factorized: false,
        })
    }

    /// Matrix dimension.
    pub fn n(&self) -> usize {
        self.stats.n
    }

    /// Statistics of the symbolic analysis.
    pub fn stats(&self) -> &FactorStats {
        &self.stats
    }

    /// Position of each diagonal entry (d, d) in the value array of the pattern.
    pub fn diagonal_offsets(&self) -> &[usize] {
        &self.diag_offsets
    }

    /// Numeric factorisation of `h` (same pattern as given to [`new`](Self::new), lower
    /// triangle). Allocates nothing.
    pub fn factorize(&mut self, h: SparseColMatRef<'_, usize, f64>) -> Result<(), FactorError> {
        self.factorize_with(h, None)
    }

    /// [`factorize`](Self::factorize) timing each stage of the multifrontal driver by
    /// supernode width class (a measurement aid; `None` when another driver ran).
    #[doc(hidden)]
    pub fn factorize_profiled(
        &mut self,
        h: SparseColMatRef<'_, usize, f64>,
    ) -> Result<Option<FactorProfile>, FactorError> {
        let mut profile = FactorProfile::default();
        self.factorize_with(h, Some(&mut profile))?;
        Ok((self.engine.is_multifrontal() && !self.single_active()).then_some(profile))
    }

    fn factorize_with(
        &mut self,
        h: SparseColMatRef<'_, usize, f64>,
        profile: Option<&mut FactorProfile>,
    ) -> Result<(), FactorError> {
        self.factorized = false;
        same_pattern(h, &self.col_ptr, &self.row_idx).map_err(FactorError::Other)?;
        if self.mixed.single.is_some() && !self.mixed.skip_single {
            return self.factorize_mixed(h, profile);
        }
        self.engine.factorize(h, profile)?;
        self.mixed.last_single = false;
        self.mixed.stats.double_factorizations += 1;
        self.factorized = true;
        Ok(())
    }

    /// Makes an unsplit factorisation use faer's left-looking supernodal driver instead of the
    /// multifrontal one (for measurements against it; no effect on a split factorisation).
    #[doc(hidden)]
    pub fn use_faer_driver(&mut self) {
        self.engine.use_faer_driver(self.row_idx.len());
        self.factorized = false;
    }

    /// Whether the factorisation is split at the top-level dissection (described at
    /// [`new`](Self::new)); its halves run concurrently when the pool has ≥ 2 threads.
    pub fn is_split(&self) -> bool {
        matches!(self.engine, Engine::Split(_))
    }

    /// Predicted flops of the split factorisation's parts, `[half A, half B, separator]`
    /// (halves: the elimination of their own dofs, counted as [`factor_flops`] counts their
    /// columns; separator: its dense Cholesky, s³/3), `None` when not split. With two threads
    /// the halves run concurrently, so the critical path is `max(A, B) + separator`, against
    /// [`FactorStats::flops`] (≈ A + B + separator) on one thread.
    pub fn split_flops(&self) -> Option<[f64; 3]> {
        self.engine.split_flops()
    }

    /// Solves `H x = rhs` in place with the last successful factorisation. Allocates nothing.
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolverError> {
        ready_to_solve(self.factorized, self.stats.n, rhs)?;
        if self.single_active() {
            return self.solve_refined(rhs);
        }
        self.engine.solve_in_place(rhs);
        Ok(())
    }

    /// One solve with the last factorisation as it is, without iterative refinement when it
    /// is in single precision (a preconditioner's application: CG with a kept factor).
    pub fn precondition_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolverError> {
        ready_to_solve(self.factorized, self.stats.n, rhs)?;
        match (&mut self.mixed.single, self.mixed.last_single) {
            (Some(single), true) => single.engine.solve_in_place(rhs),
            _ => self.engine.solve_in_place(rhs),
        }
        Ok(())
    }
}

/// Allocates the factorisation and solve scratch of `symbolic`, after refusing
/// ([`SolverError::InsufficientMemory`]) a factor whose estimated memory — values plus both
/// scratch buffers — exceeds [`memory_budget`](crate::memory::memory_budget). Returns the
/// buffers and the estimate (bytes).
pub(crate) fn scratch(
    symbolic: &SymbolicCholesky<usize>,
    factor_req: faer::dyn_stack::StackReq,
    solve_req: faer::dyn_stack::StackReq,
) -> Result<(MemBuffer, MemBuffer, u64), SolverError> {
    let estimate = factor_memory_estimate(
        symbolic.len_val(),
        std::mem::size_of::<f64>(),
        factor_req.size_bytes(),
        solve_req.size_bytes(),
    );
    check_budget(symbolic.nrows(), estimate)?;
    let factor_mem = MemBuffer::try_new(factor_req)
        .map_err(|_| SolverError::Linear("out of memory for factorisation scratch".into()))?;
    let solve_mem = MemBuffer::try_new(solve_req)
        .map_err(|_| SolverError::Linear("out of memory for solve scratch".into()))?;
    Ok((factor_mem, solve_mem, estimate))
}

/// Refuses ([`SolverError::InsufficientMemory`]) an `n`-dof factor needing `estimate` bytes
/// beyond [`memory_budget`](crate::memory::memory_budget).
fn check_budget(n: usize, estimate: u64) -> Result<(), SolverError> {
    if let Some(budget) = crate::memory::memory_budget()
        && estimate > budget
    {
        return Err(SolverError::InsufficientMemory {
            n,
            estimate,
            budget,
        });
    }
    Ok(())
}

/// Errors unless `a` has exactly the analysed pattern (`col_ptr`, `row_idx`).
pub(crate) fn same_pattern(
    a: SparseColMatRef<'_, usize, f64>,
    col_ptr: &[usize],
    row_idx: &[usize],
) -> Result<(), SolverError> {
    if a.symbolic().col_ptr() != col_ptr || a.symbolic().row_idx() != row_idx {
        return Err(SolverError::InvalidPattern {
            dof: 0,
            reason: "matrix pattern differs from the analysed pattern",
        });
    }
    Ok(())
}

/// Errors unless a factorisation succeeded and `rhs` has its dimension `n`.
pub(crate) fn ready_to_solve(factorized: bool, n: usize, rhs: &[f64]) -> Result<(), SolverError> {
    if !factorized {
        return Err(SolverError::Linear(
            "solve called without a successful factorisation".into(),
        ));
    }
    if rhs.len() != n {
        return Err(SolverError::DimensionMismatch {
            what: "right-hand side",
            expected: n,
            found: rhs.len(),
        });
    }
    Ok(())
}
