//! Sparse Cholesky factorisation with a reused symbolic analysis and regularisation.
//!
//! [`SparseCholesky::new`] does the symbolic analysis (ordering, elimination tree, supernodes)
//! once per sparsity pattern and allocates the factor values and faer's scratch memory; every
//! later [`factorize`](SparseCholesky::factorize) / [`solve_in_place`](SparseCholesky::solve_in_place)
//! reuses them and allocates nothing. [`factorize_regularized`](SparseCholesky::factorize_regularized)
//! retries a matrix that is not positive definite with a growing diagonal shift
//! `H + μ·s·I` (or `H + μ·diag(|H|)`), written through precomputed diagonal offsets.

use std::time::{Duration, Instant};

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
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, Par, Side};

use crate::SolverError;
use crate::ordering::{
    DEFAULT_LEAF_SIZE, METIS_LEAF_SIZE, Ordering, inverse_permutation, metis_dissection_with_split,
    nested_dissection,
};

/// How the diagonal shift of a regularised factorisation is shaped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum RegularizationKind {
    /// `H + μ·s·I`, `s` = mean |H_dd| (so μ is relative to the Hessian's scale).
    #[default]
    Identity,
    /// `H + μ·diag(max(|H_dd|, 1e-6·s))`: shifts each dof in proportion to its own stiffness
    /// (mass-weighted problems with very different dof scales).
    Diagonal,
}

/// Parameters of the shift search in [`SparseCholesky::factorize_regularized`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularizationParams {
    /// Shape of the shift.
    pub kind: RegularizationKind,
    /// First relative shift μ tried after a failed unshifted factorisation (default 1e-10:
    /// below the bending stiffness of thin shells, whose bending entries are a fraction
    /// ~(h/ℓ)² of the membrane ones that dominate the mean |H_dd|; a first shift of 1e-6 of the
    /// mean already swamped the bending of paper, h/ℓ ≈ 1e-3, and turned Newton into a slow
    /// gradient method there).
    pub initial: f64,
    /// Factor μ grows by after each failure (> 1).
    pub growth: f64,
    /// Factor the remembered μ is multiplied by before the next factorisation (in (0, 1));
    /// once it falls below `initial` the next factorisation is tried unshifted again.
    pub shrink: f64,
    /// Maximum number of shifted attempts per factorisation.
    pub max_attempts: usize,
}

impl RegularizationParams {
    /// Checks every parameter; the error names the first bad one (as the flat names
    /// `regularization_initial`, … of the scene and of earlier versions).
    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = SolverError::invalid_setting;
        if !(self.initial.is_finite() && self.initial > 0.0) {
            return Err(bad(
                "regularization_initial",
                self.initial,
                "must be positive and finite",
            ));
        }
        if !(self.growth.is_finite() && self.growth > 1.0) {
            return Err(bad(
                "regularization_growth",
                self.growth,
                "must be finite and greater than 1",
            ));
        }
        if !(self.shrink > 0.0 && self.shrink < 1.0) {
            return Err(bad(
                "regularization_shrink",
                self.shrink,
                "must lie in (0, 1)",
            ));
        }
        if self.max_attempts == 0 {
            return Err(bad(
                "regularization_max_attempts",
                0.0,
                "must be at least 1",
            ));
        }
        Ok(())
    }
}

impl Default for RegularizationParams {
    fn default() -> Self {
        Self {
            kind: RegularizationKind::Identity,
            initial: 1e-10,
            growth: 10.0,
            shrink: 0.1,
            max_attempts: 24,
        }
    }
}

/// Result of one (possibly regularised) factorisation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FactorOutcome {
    /// Relative shift μ of the factorisation that succeeded (0: unshifted).
    pub mu: f64,
    /// Largest absolute diagonal entry added (same units as H).
    pub max_shift: f64,
    /// Factorisation attempts, including the successful one.
    pub attempts: usize,
}

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

/// Bytes of a factor with `len_val` values and the given scratch sizes.
fn factor_memory_estimate(len_val: usize, factor_scratch: usize, solve_scratch: usize) -> u64 {
    (len_val * std::mem::size_of::<f64>() + factor_scratch + solve_scratch) as u64
}

/// Failure of one numeric factorisation attempt.
#[derive(Debug)]
pub enum FactorError {
    /// faer met a non-positive pivot (index in the permuted order; a diagnostic only).
    NotPositiveDefinite {
        /// Failing pivot.
        pivot: usize,
    },
    /// Anything else (pattern mismatch, faer failure).
    Other(SolverError),
}

/// A sparse LLᵀ factorisation whose symbolic part, factor storage and scratch memory are reused
/// for every matrix with the same pattern.
pub struct SparseCholesky {
    engine: Engine,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    diag_offsets: Vec<usize>,
    diag_backup: Vec<f64>,
    par: Par,
    stats: FactorStats,
    factorized: bool,
}

/// How the numeric factorisation runs (one per factorisation: the size difference of the
/// variants does not matter).
#[allow(clippy::large_enum_variant)]
enum Engine {
    /// One faer supernodal factorisation, sequential.
    Whole {
        symbolic: SymbolicCholesky<usize>,
        l_values: Vec<f64>,
        factor_mem: MemBuffer,
        solve_mem: MemBuffer,
    },
    /// The two halves of the top nested-dissection split on two threads ([`SplitFactor`]).
    Split(Box<SplitFactor>),
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
    /// `par`: with [`Par::Seq`] faer factorises the whole matrix sequentially (the fewest
    /// flops on one thread). With [`Par::Rayon`] of any thread count, an [`Ordering::Metis`]
    /// ordering (chosen or picked by `Auto`) and predicted flops of at least
    /// [`SPLIT_MIN_FLOPS`], the factorisation is split at the top-level dissection
    /// ([`is_split`](Self::is_split)): each half is factorised by faer on one thread, with the
    /// product of its separator block, and the separator's Schur complement densely on one
    /// thread; the two halves (and the halves of each solve) run concurrently (`rayon::join`)
    /// when the pool has ≥ 2 threads, one after the other otherwise. The same floating-point
    /// operations run in the same order either way, so factors and solutions are bit-identical
    /// for any `Par::Rayon` thread count (they differ from [`Par::Seq`]'s in the last bits;
    /// the split does about s³ more flops, s the separator's size: 21 % at 20 480 faces).
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
        let (engine, estimate) = match split {
            Some((perm, sizes))
                if matches!(par, Par::Rayon(_))
                    && flops >= SPLIT_MIN_FLOPS
                    && sizes.iter().all(|&k| k > 0) =>
            {
                // The split holds about the whole factor plus four dense separator blocks:
                // refuse it before allocating.
                let [_, _, sep] = sizes;
                let estimate = factor_memory_estimate(factor_len + 4 * sep * sep, 0, 0);
                check_budget(symbolic.nrows(), estimate)?;
                drop(symbolic);
                let f = SplitFactor::new(pattern, perm, sizes, par)?;
                let estimate = f.memory();
                (Engine::Split(Box::new(f)), estimate)
            }
            _ => {
                let factor_req =
                    symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
                let solve_req = symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
                let (factor_mem, solve_mem, estimate) = scratch(&symbolic, factor_req, solve_req)?;
                (
                    Engine::Whole {
                        l_values: vec![0.0; factor_len],
                        symbolic,
                        factor_mem,
                        solve_mem,
                    },
                    estimate,
                )
            }
        };
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
        self.factorized = false;
        same_pattern(h, &self.col_ptr, &self.row_idx).map_err(FactorError::Other)?;
        match &mut self.engine {
            Engine::Whole {
                symbolic,
                l_values,
                factor_mem,
                ..
            } => {
                let stack = MemStack::new(factor_mem);
                symbolic
                    .factorize_numeric_llt(
                        l_values,
                        h,
                        Side::Lower,
                        Default::default(),
                        Par::Seq,
                        stack,
                        Default::default(),
                    )
                    // The low-level API reports the dense error type directly (not wrapped in
                    // `sparse::linalg::LltError::Numeric` as the high-level `Llt` does).
                    .map_err(|DenseLltError::NonPositivePivot { index }| {
                        FactorError::NotPositiveDefinite { pivot: index }
                    })?;
            }
            Engine::Split(f) => f.factorize(h.val())?,
        }
        self.factorized = true;
        Ok(())
    }

    /// Whether the factorisation is split at the top-level dissection (described at
    /// [`new`](Self::new)); its halves run concurrently when the pool has ≥ 2 threads.
    pub fn is_split(&self) -> bool {
        matches!(self.engine, Engine::Split(_))
    }

    /// Predicted flops of the split factorisation's parts, `[half A, half B, dense]` (halves as
    /// [`factor_flops`], each including its copy of the separator block and its Schur
    /// product, s³/3; dense: the separator's Cholesky, s³/3), `None` when not split. With two
    /// threads the halves run concurrently, so the critical path is `max(A, B) + dense`,
    /// against [`FactorStats::flops`] on one thread.
    pub fn split_flops(&self) -> Option<[f64; 3]> {
        match &self.engine {
            Engine::Whole { .. } => None,
            Engine::Split(f) => {
                let s = f.sizes[2] as f64;
                let product = s * s * s / 3.0;
                Some([
                    factor_flops(&f.halves[0].symbolic) + product,
                    factor_flops(&f.halves[1].symbolic) + product,
                    product,
                ])
            }
        }
    }

    /// Factorises `h`, retrying with a growing diagonal shift while it is not positive definite.
    ///
    /// `mu` is the caller's memory of the last successful shift: the first attempt uses
    /// `mu·shrink` (or no shift once that falls below `params.initial`), failures multiply it by
    /// `params.growth`, and the successful value is written back. `h` is restored to its input
    /// values before returning. With `params.max_attempts == 0` no shift is tried.
    pub fn factorize_regularized(
        &mut self,
        h: &mut SparseColMat<usize, f64>,
        params: &RegularizationParams,
        mu: &mut f64,
    ) -> Result<FactorOutcome, FactorError> {
        let mut trial = if *mu > 0.0 && *mu * params.shrink >= params.initial {
            *mu * params.shrink
        } else {
            0.0
        };
        {
            let val = h.val_mut();
            for (b, &o) in self.diag_backup.iter_mut().zip(&self.diag_offsets) {
                *b = val[o];
            }
        }
        let n = self.diag_offsets.len().max(1);
        let scale = {
            let s = self.diag_backup.iter().map(|d| d.abs()).sum::<f64>() / n as f64;
            if s.is_finite() && s > 0.0 { s } else { 1.0 }
        };
        let mut attempts = 0;
        let mut shifted_attempts = 0;
        let result = loop {
            attempts += 1;
            let mut max_shift = 0.0f64;
            {
                let val = h.val_mut();
                for (&o, &d) in self.diag_offsets.iter().zip(&self.diag_backup) {
                    let shift = match params.kind {
                        RegularizationKind::Identity => trial * scale,
                        RegularizationKind::Diagonal => trial * d.abs().max(1e-6 * scale),
                    };
                    max_shift = max_shift.max(shift);
                    val[o] = d + shift;
                }
            }
            match self.factorize(h.as_ref()) {
                Ok(()) => {
                    *mu = trial;
                    break Ok(FactorOutcome {
                        mu: trial,
                        max_shift,
                        attempts,
                    });
                }
                Err(FactorError::NotPositiveDefinite { pivot }) => {
                    if shifted_attempts >= params.max_attempts {
                        break Err(FactorError::NotPositiveDefinite { pivot });
                    }
                    shifted_attempts += 1;
                    trial = if trial == 0.0 {
                        params.initial
                    } else {
                        trial * params.growth
                    };
                }
                Err(e) => break Err(e),
            }
        };
        let val = h.val_mut();
        for (&o, &d) in self.diag_offsets.iter().zip(&self.diag_backup) {
            val[o] = d;
        }
        result
    }

    /// Solves `H x = rhs` in place with the last successful factorisation. Allocates nothing.
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolverError> {
        let n = self.stats.n;
        ready_to_solve(self.factorized, n, rhs)?;
        match &mut self.engine {
            Engine::Whole {
                symbolic,
                l_values,
                solve_mem,
                ..
            } => {
                let llt = LltRef::new(symbolic, l_values);
                let stack = MemStack::new(solve_mem);
                llt.solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(rhs, n, 1),
                    Par::Seq,
                    stack,
                );
            }
            Engine::Split(f) => f.solve_in_place(rhs),
        }
        Ok(())
    }
}

/// Position of (d, d) in the value array for each column d; checks the pattern is square and
/// holds the lower triangle only.
pub fn diagonal_offsets(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<Vec<usize>, SolverError> {
    let n = pattern.ncols();
    if pattern.nrows() != n {
        return Err(SolverError::DimensionMismatch {
            what: "Hessian pattern rows",
            expected: n,
            found: pattern.nrows(),
        });
    }
    if pattern.col_nnz().is_some() {
        return Err(SolverError::InvalidPattern {
            dof: 0,
            reason: "pattern must be compressed (no per-column nnz)",
        });
    }
    let col_ptr = pattern.col_ptr();
    let row_idx = pattern.row_idx();
    let mut offsets = Vec::with_capacity(n);
    for j in 0..n {
        let mut diag = None;
        for (p, &i) in row_idx
            .iter()
            .enumerate()
            .take(col_ptr[j + 1])
            .skip(col_ptr[j])
        {
            if i < j {
                return Err(SolverError::InvalidPattern {
                    dof: j,
                    reason: "entry above the diagonal (only the lower triangle may be stored)",
                });
            }
            if i == j {
                diag = Some(p);
            }
        }
        match diag {
            Some(p) => offsets.push(p),
            None => {
                return Err(SolverError::InvalidPattern {
                    dof: j,
                    reason: "diagonal entry missing",
                });
            }
        }
    }
    Ok(offsets)
}

/// The symbolic analysis of a lower-triangle `pattern` under `ordering`, and the ordering used:
/// `Auto` tries AMD, graph nested dissection, METIS nested dissection and (with `coordinates`,
/// m per dof) geometric nested dissection, and keeps the one with the fewest factorisation
/// flops. Shared by the
/// Cholesky and LDLᵀ factorisations.
pub(crate) fn analyse(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    ordering: Ordering,
    coordinates: Option<&[[f64; 3]]>,
) -> Result<(SymbolicCholesky<usize>, Ordering, Option<TopSplit>), SolverError> {
    Ok(match ordering {
        Ordering::Amd => (symbolic_amd(pattern)?, Ordering::Amd, None),
        Ordering::NestedDissection => (
            symbolic_nd(pattern, coordinates)?,
            Ordering::NestedDissection,
            None,
        ),
        Ordering::Metis => {
            let (symbolic, split) = symbolic_metis(pattern)?;
            (symbolic, Ordering::Metis, split)
        }
        Ordering::Auto => {
            let mut best = (symbolic_amd(pattern)?, Ordering::Amd, None);
            let mut candidates = vec![(
                symbolic_nd(pattern, None)?,
                Ordering::NestedDissection,
                None,
            )];
            if coordinates.is_some() {
                candidates.push((
                    symbolic_nd(pattern, coordinates)?,
                    Ordering::NestedDissection,
                    None,
                ));
            }
            // METIS can only fail on input it rejects or out of memory: the other candidates
            // still stand then.
            if let Ok((m, split)) = symbolic_metis(pattern) {
                candidates.push((m, Ordering::Metis, split));
            }
            for candidate in candidates {
                if factor_flops(&candidate.0) < factor_flops(&best.0) {
                    best = candidate;
                }
            }
            best
        }
    })
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

pub(crate) fn symbolic_amd(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<SymbolicCholesky<usize>, SolverError> {
    factorize_symbolic_cholesky(
        pattern,
        Side::Lower,
        SymmetricOrdering::Amd,
        CholeskySymbolicParams::default(),
    )
    .map_err(|e| SolverError::Linear(format!("{e:?}")))
}

pub(crate) fn symbolic_nd(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    coordinates: Option<&[[f64; 3]]>,
) -> Result<SymbolicCholesky<usize>, SolverError> {
    let fwd = nested_dissection(pattern, coordinates, DEFAULT_LEAF_SIZE)?;
    symbolic_custom(pattern, &fwd)
}

/// The permutation of a nested dissection and the dof counts `[a, b, s]` of its top-level
/// halves and separator (numbered in that order; the halves are uncoupled).
pub(crate) type TopSplit = (Vec<usize>, [usize; 3]);

pub(crate) fn symbolic_metis(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<(SymbolicCholesky<usize>, Option<TopSplit>), SolverError> {
    let (fwd, split) = metis_dissection_with_split(pattern, METIS_LEAF_SIZE)?;
    let symbolic = symbolic_custom(pattern, &fwd)?;
    Ok((symbolic, split.map(|sizes| (fwd, sizes))))
}

/// Symbolic analysis with the permutation `fwd` (`fwd[new] = old`).
fn symbolic_custom(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    fwd: &[usize],
) -> Result<SymbolicCholesky<usize>, SolverError> {
    let inv = inverse_permutation(fwd);
    let perm = PermRef::new_checked(fwd, &inv, fwd.len());
    factorize_symbolic_cholesky(
        pattern,
        Side::Lower,
        SymmetricOrdering::Custom(perm),
        CholeskySymbolicParams::default(),
    )
    .map_err(|e| SolverError::Linear(format!("{e:?}")))
}

/// Predicted flops of the numeric factorisation: Σ over the columns of L of (entries in the
/// column)², counting the supernodal blocks as stored.
pub fn factor_flops(symbolic: &SymbolicCholesky<usize>) -> f64 {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => s
            .col_ptr()
            .windows(2)
            .map(|w| {
                let c = (w[1] - w[0]) as f64;
                c * c
            })
            .sum(),
        SymbolicCholeskyRaw::Supernodal(s) => {
            let begin = s.supernode_begin();
            let end = s.supernode_end();
            (0..s.n_supernodes())
                .map(|k| {
                    let width = end[k] - begin[k];
                    let below = s.supernode(k).pattern().len();
                    (1..=width)
                        .map(|c| {
                            let c = (c + below) as f64;
                            c * c
                        })
                        .sum::<f64>()
                })
                .sum()
        }
    }
}

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
struct SplitFactor {
    /// `perm[new] = old` of the whole ordering.
    perm: Vec<usize>,
    /// Dofs of A, B, S.
    sizes: [usize; 3],
    halves: [Half; 2],
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
struct Half {
    symbolic: SymbolicCholesky<usize>,
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
    fn new(
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
    fn memory(&self) -> u64 {
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

    fn factorize(&mut self, h: &[f64]) -> Result<(), FactorError> {
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

    fn solve_in_place(&mut self, rhs: &mut [f64]) {
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
