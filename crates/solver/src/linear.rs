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
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::SolverError;
use crate::ordering::{
    DEFAULT_LEAF_SIZE, METIS_LEAF_SIZE, Ordering, inverse_permutation, metis_nested_dissection,
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
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
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
    /// entry present. `coordinates` (per dof, m) feed the geometric nested dissection; `par`
    /// selects faer's parallelism for factorisation and solve.
    pub fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        ordering: Ordering,
        coordinates: Option<&[[f64; 3]]>,
        par: Par,
    ) -> Result<SparseCholesky, SolverError> {
        let start = Instant::now();
        let n = pattern.ncols();
        let diag_offsets = diagonal_offsets(pattern)?;
        let (symbolic, used) = analyse(pattern, ordering, coordinates)?;
        let factor_req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let solve_req = symbolic.solve_in_place_scratch::<f64>(1, par);
        let (factor_mem, solve_mem, estimate) = scratch(&symbolic, factor_req, solve_req)?;
        let stats = FactorStats {
            n,
            nnz_lower: pattern.row_idx().len(),
            factor_len: symbolic.len_val(),
            flops: factor_flops(&symbolic),
            ordering: used,
            supernodal: matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)),
            symbolic_time: start.elapsed(),
            memory_estimate: estimate,
        };
        Ok(SparseCholesky {
            l_values: vec![0.0; symbolic.len_val()],
            symbolic,
            factor_mem,
            solve_mem,
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
        let stack = MemStack::new(&mut self.factor_mem);
        match self.symbolic.factorize_numeric_llt(
            &mut self.l_values,
            h,
            Side::Lower,
            Default::default(),
            self.par,
            stack,
            Default::default(),
        ) {
            Ok(_) => {
                self.factorized = true;
                Ok(())
            }
            // The low-level API reports the dense error type directly (not wrapped in
            // `sparse::linalg::LltError::Numeric` as the high-level `Llt` does).
            Err(DenseLltError::NonPositivePivot { index }) => {
                Err(FactorError::NotPositiveDefinite { pivot: index })
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
        let llt = LltRef::new(&self.symbolic, &self.l_values);
        let stack = MemStack::new(&mut self.solve_mem);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            self.par,
            stack,
        );
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
) -> Result<(SymbolicCholesky<usize>, Ordering), SolverError> {
    Ok(match ordering {
        Ordering::Amd => (symbolic_amd(pattern)?, Ordering::Amd),
        Ordering::NestedDissection => (
            symbolic_nd(pattern, coordinates)?,
            Ordering::NestedDissection,
        ),
        Ordering::Metis => (symbolic_metis(pattern)?, Ordering::Metis),
        Ordering::Auto => {
            let mut best = (symbolic_amd(pattern)?, Ordering::Amd);
            let mut candidates = vec![(symbolic_nd(pattern, None)?, Ordering::NestedDissection)];
            if coordinates.is_some() {
                candidates.push((
                    symbolic_nd(pattern, coordinates)?,
                    Ordering::NestedDissection,
                ));
            }
            // METIS can only fail on input it rejects or out of memory: the other candidates
            // still stand then.
            if let Ok(m) = symbolic_metis(pattern) {
                candidates.push((m, Ordering::Metis));
            }
            for (symbolic, used) in candidates {
                if factor_flops(&symbolic) < factor_flops(&best.0) {
                    best = (symbolic, used);
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
    if let Some(budget) = crate::memory::memory_budget()
        && estimate > budget
    {
        return Err(SolverError::InsufficientMemory {
            n: symbolic.nrows(),
            estimate,
            budget,
        });
    }
    let factor_mem = MemBuffer::try_new(factor_req)
        .map_err(|_| SolverError::Linear("out of memory for factorisation scratch".into()))?;
    let solve_mem = MemBuffer::try_new(solve_req)
        .map_err(|_| SolverError::Linear("out of memory for solve scratch".into()))?;
    Ok((factor_mem, solve_mem, estimate))
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

pub(crate) fn symbolic_metis(
    pattern: SymbolicSparseColMatRef<'_, usize>,
) -> Result<SymbolicCholesky<usize>, SolverError> {
    let fwd = metis_nested_dissection(pattern, METIS_LEAF_SIZE)?;
    symbolic_custom(pattern, &fwd)
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
