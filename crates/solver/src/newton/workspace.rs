//! The reusable state of Newton solves ([`NewtonWorkspace`]: symbolic factorisation, Hessian,
//! vectors, the iterative fallback) and the stability analysis of an equilibrium ([`Stability`]).

use std::time::Instant;

use faer::sparse::SparseColMat;

use super::checks::assemble;
use super::kept::{KeptFactor, KeptRecord};
use super::report::NewtonTimings;
use super::settings::{IterationHessian, IterativeFallback, LinearSolver, NewtonSettings};
use crate::SolverError;
use crate::curvature;
use crate::iterative::{Ic0, PcgScratch};
use crate::ldlt::SparseLdlt;
use crate::linear::{FactorError, FactorStats, RegularizationKind, SparseCholesky};
use crate::objective::Objective;
use crate::ordering::Ordering;
use crate::progress::{CancelFlag, ProgressHook};

/// Reusable state of Newton solves on objectives with one Hessian pattern: the symbolic
/// factorisation, the Hessian matrix, vectors, and the remembered regularisation shift.
/// Build it once (e.g. per simulation) and pass it to every [`newton_solve`](crate::newton_solve).
pub struct NewtonWorkspace {
    /// The direct solver; `None` when its factor does not fit in memory (`fallback` is set).
    pub(super) cholesky: Option<SparseCholesky>,
    /// The iterative fallback's preconditioner and the symbolic statistics of the refused
    /// factor.
    pub(super) fallback: Option<Fallback>,
    /// Position of each diagonal entry in the Hessian's value array.
    pub(super) diag_offsets: Vec<usize>,
    /// CG work vectors (reuse and fallback).
    pub(super) pcg: PcgScratch,
    /// Kind of Hessian of the last Cholesky factor when it is unshifted and may precondition CG
    /// ([`NewtonSettings::reuse_factor`](super::NewtonSettings::reuse_factor)); `None`:
    /// refactorise.
    pub(super) reusable: Option<IterationHessian>,
    /// The input of the kept factor's factorisation (checkpoints, cancelled solves).
    pub(super) kept: KeptRecord,
    /// Statistics of the symbolic analysis (of the refused factor with the fallback).
    pub(super) stats: FactorStats,
    /// Built with [`NewtonSettings::force_iterative`](super::NewtonSettings::force_iterative).
    pub(super) forced: bool,
    pub(super) hessian: SparseColMat<usize, f64>,
    pub(super) g: Vec<f64>,
    pub(super) g_trial: Vec<f64>,
    pub(super) dx: Vec<f64>,
    pub(super) x_trial: Vec<f64>,
    /// H·dx of a trust-region step (its predicted decrease).
    pub(super) hd: Vec<f64>,
    /// The scaling diagonal S of the trust-region shift (`curvature::scaling`).
    pub(super) scale: Vec<f64>,
    pub(super) mu: f64,
    /// The settings the symbolic analysis was made with.
    pub(super) ordering: Ordering,
    pub(super) parallel: bool,
    /// Whether the direct solver was asked for mixed precision.
    mixed_precision: bool,
    /// Called after every accepted iteration of [`newton_solve`](crate::newton_solve).
    pub(super) progress: Option<ProgressHook>,
    /// Checked before every iteration of [`newton_solve`](crate::newton_solve).
    pub(super) cancel: Option<CancelFlag>,
    /// Indefinite factorisation for Newton steps to a critical point whose Hessian is
    /// indefinite (`saddle_newton`); analysed on first use.
    pub(super) ldlt: Option<SparseLdlt>,
}

impl std::fmt::Debug for NewtonWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NewtonWorkspace")
            .field("cholesky", &self.cholesky)
            .field("fallback", &self.fallback.as_ref().map(|f| f.kind))
            .field("reusable", &self.reusable)
            .field("n_dofs", &self.g.len())
            .field("mu", &self.mu)
            .field("ordering", &self.ordering)
            .field("parallel", &self.parallel)
            .field("progress", &self.progress.is_some())
            .finish_non_exhaustive()
    }
}

impl NewtonWorkspace {
    /// Analyses `objective`'s Hessian pattern with `settings.ordering` (using the objective's dof
    /// coordinates for nested dissection when it has them).
    pub fn new<O: Objective + ?Sized>(
        objective: &O,
        settings: &NewtonSettings,
    ) -> Result<NewtonWorkspace, SolverError> {
        settings.validate()?;
        let n = objective.n_dofs();
        let hessian = objective.hessian_template();
        if hessian.ncols() != n || hessian.nrows() != n {
            return Err(SolverError::DimensionMismatch {
                what: "Hessian template",
                expected: n,
                found: hessian.ncols(),
            });
        }
        let coords = objective.dof_coordinates();
        let diag_offsets = crate::linear::diagonal_offsets(hessian.symbolic())?;
        let direct = if settings.force_iterative {
            // No numeric factor: the refusal's fields stand for "iterative by request".
            Err(SolverError::InsufficientMemory {
                n,
                estimate: 0,
                budget: u64::MAX,
            })
        } else {
            SparseCholesky::new(
                hessian.symbolic(),
                settings.ordering,
                coords.as_deref(),
                settings.par(),
            )
        };
        let (cholesky, fallback) = match direct {
            Ok(mut c) => {
                c.set_mixed_precision(settings.mixed_precision)?;
                (Some(c), None)
            }
            Err(SolverError::InsufficientMemory {
                n: dim,
                estimate,
                budget,
            }) => {
                let refused = SolverError::InsufficientMemory {
                    n: dim,
                    estimate,
                    budget,
                };
                let nnz = hessian.val().len();
                let kind = match settings.fallback {
                    IterativeFallback::Off if settings.force_iterative => IterativeFallback::Ic0,
                    k => k,
                };
                let iterative = match kind {
                    IterativeFallback::Off => return Err(refused),
                    IterativeFallback::Ic0 => Ic0::memory_estimate(n, nnz),
                    IterativeFallback::Jacobi => (7 * n * 8) as u64,
                };
                if iterative > budget {
                    return Err(SolverError::InsufficientMemoryForIterative {
                        n,
                        factor_estimate: estimate,
                        estimate: iterative,
                        budget,
                    });
                }
                let start = Instant::now();
                let (symbolic, used, _) = crate::linear::analyse(
                    hessian.symbolic(),
                    settings.ordering,
                    coords.as_deref(),
                )?;
                let factor_len = symbolic.len_val();
                let stats = FactorStats {
                    n,
                    nnz_lower: nnz,
                    factor_len: symbolic.len_val(),
                    flops: crate::linear::factor_flops(&symbolic),
                    ordering: used,
                    supernodal: matches!(
                        symbolic.raw(),
                        faer::sparse::linalg::cholesky::SymbolicCholeskyRaw::Supernodal(_)
                    ),
                    symbolic_time: start.elapsed(),
                    // By request: the factor's values (its scratch is not sized).
                    memory_estimate: if settings.force_iterative {
                        (factor_len * 8) as u64
                    } else {
                        estimate
                    },
                };
                drop(symbolic);
                let precond = match kind {
                    IterativeFallback::Jacobi => Precond::Jacobi(vec![0.0; n]),
                    _ => Precond::Ic0(Ic0::new(hessian.as_ref())?),
                };
                (
                    None,
                    Some(Fallback {
                        kind,
                        precond,
                        stats,
                        iterative_estimate: iterative,
                    }),
                )
            }
            Err(e) => return Err(e),
        };
        let stats = match (&cholesky, &fallback) {
            (Some(c), _) => *c.stats(),
            (None, Some(f)) => f.stats,
            (None, None) => {
                return Err(SolverError::Linear(
                    "neither a direct nor an iterative solver was set up".into(),
                ));
            }
        };
        Ok(NewtonWorkspace {
            forced: settings.force_iterative,
            stats,
            cholesky,
            fallback,
            diag_offsets,
            pcg: PcgScratch::new(n),
            reusable: None,
            kept: KeptRecord::default(),
            hessian,
            g: vec![0.0; n],
            g_trial: vec![0.0; n],
            dx: vec![0.0; n],
            x_trial: vec![0.0; n],
            hd: vec![0.0; n],
            scale: vec![0.0; n],
            mu: 0.0,
            ordering: settings.ordering,
            parallel: settings.parallel,
            mixed_precision: settings.mixed_precision,
            progress: None,
            cancel: None,
            ldlt: None,
        })
    }

    /// Whether the workspace was built with `settings`' ordering and parallelism. A cached
    /// workspace must be rebuilt when they change (or when the objective's number of unknowns
    /// or Hessian pattern does): [`newton_solve`](crate::newton_solve) rejects a wrong size but
    /// otherwise factorises with the ordering and parallelism the workspace was built with.
    pub fn matches(&self, settings: &NewtonSettings) -> bool {
        self.ordering == settings.ordering
            && self.parallel == settings.parallel
            && self.mixed_precision == settings.mixed_precision
            && self.forced == settings.force_iterative
            && self
                .fallback
                .as_ref()
                .is_none_or(|f| f.kind == settings.fallback || self.forced)
    }

    /// What the direct solver's factorisations and solves did in each precision over this
    /// workspace's life ([`NewtonSettings::mixed_precision`](super::NewtonSettings::mixed_precision));
    /// `None` with the iterative fallback.
    pub fn precision(&self) -> Option<crate::linear::PrecisionStats> {
        self.cholesky.as_ref().map(|c| c.precision())
    }

    /// How this workspace solves: [`LinearSolver::Direct`], or the iterative fallback chosen
    /// because the Cholesky factor did not fit in the memory budget.
    pub fn linear_solver(&self) -> LinearSolver {
        match &self.fallback {
            None => LinearSolver::Direct,
            Some(f) => LinearSolver::Iterative(f.kind),
        }
    }

    /// Estimated bytes of the iterative fallback's preconditioner and CG vectors (`None` for
    /// a direct workspace, whose estimate is [`FactorStats::memory_estimate`]).
    pub fn iterative_memory_estimate(&self) -> Option<u64> {
        self.fallback.as_ref().map(|f| f.iterative_estimate)
    }

    /// Forgets the factor kept for reuse
    /// ([`NewtonSettings::reuse_factor`](super::NewtonSettings::reuse_factor)): the next iteration
    /// factorises afresh (e.g. after the objective changed discontinuously).
    pub fn invalidate_factor(&mut self) {
        self.reusable = None;
    }

    /// The Hessian matrix the workspace was analysed for (its pattern; values of the last
    /// evaluation).
    pub fn hessian(&self) -> &SparseColMat<usize, f64> {
        &self.hessian
    }

    /// Number of stored entries of the Hessian pattern (lower triangle).
    pub fn nnz(&self) -> usize {
        self.hessian.val().len()
    }

    /// The ordering the workspace was built with (as requested; [`FactorStats::ordering`] is
    /// the one `Ordering::Auto` chose).
    pub fn ordering(&self) -> Ordering {
        self.ordering
    }

    /// Whether the factorisation runs on the rayon pool (as built).
    pub fn parallel(&self) -> bool {
        self.parallel
    }

    /// Number of unknowns the workspace was built for.
    pub fn n_dofs(&self) -> usize {
        self.g.len()
    }

    /// Statistics of the symbolic factorisation (ordering, fill, flops); with the iterative
    /// fallback, those of the factor that was refused.
    pub fn factor_stats(&self) -> &FactorStats {
        &self.stats
    }

    /// The remembered relative regularisation shift (0 when the last factorisation needed none).
    pub fn regularization_memory(&self) -> f64 {
        self.mu
    }

    /// Sets the remembered relative regularisation shift (a restored checkpoint: the next
    /// solve starts from the shift the interrupted run would have used). Non-finite or
    /// negative values count as 0.
    pub fn set_regularization_memory(&mut self, mu: f64) {
        self.mu = if mu.is_finite() && mu > 0.0 { mu } else { 0.0 };
    }

    /// Sets (or clears) the observer called after every accepted Newton iteration.
    pub fn set_progress(&mut self, hook: Option<ProgressHook>) {
        self.progress = hook;
    }

    /// Sets (or clears) the flag that cancels a running solve before its next iteration
    /// ([`SolverError::Cancelled`]).
    pub fn set_cancel(&mut self, flag: Option<CancelFlag>) {
        self.cancel = flag;
    }

    /// The gradient at the last accepted iterate of the last solve.
    pub fn gradient(&self) -> &[f64] {
        &self.g
    }
}

impl NewtonWorkspace {
    /// Errors unless `x` and `objective` fit the workspace and it has the direct solver, which
    /// `what` needs.
    pub(super) fn check_direct<O: Objective + ?Sized>(
        &self,
        objective: &O,
        x: &[f64],
        what: &str,
    ) -> Result<(), SolverError> {
        if x.len() != self.n_dofs() || objective.n_dofs() != self.n_dofs() {
            return Err(SolverError::DimensionMismatch {
                what: "x",
                expected: self.n_dofs(),
                found: x.len(),
            });
        }
        if self.cholesky.is_none() {
            return Err(SolverError::Linear(format!(
                "{what} needs a Cholesky factorisation, which does not fit in the memory budget \
                 (the solve used the iterative fallback)"
            )));
        }
        Ok(())
    }

    /// Whether the objective's own Hessian at `x` is positive definite: its unshifted Cholesky
    /// factorisation succeeds (e.g. the stability test of an equilibrium; a shift the objective
    /// itself adds, like a static solve's `hessian_shift`, is part of its Hessian).
    pub fn is_positive_definite<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        x: &[f64],
    ) -> Result<bool, SolverError> {
        self.check_direct(objective, x, "the positive-definiteness test")?;
        let Some(cholesky) = self.cholesky.as_mut() else {
            return Err(SolverError::Linear("no Cholesky factorisation".into()));
        };
        let mut timings = NewtonTimings::default();
        assemble(objective, x, &mut self.hessian, false, 0, &mut timings)?;
        self.reusable = None;
        match cholesky.factorize(self.hessian.as_ref()) {
            Ok(()) => {
                // An unshifted factor of the own Hessian: the next solve may reuse it.
                self.reusable = Some(IterationHessian::Own);
                let h = self.hessian.val();
                self.kept
                    .record(IterationHessian::Own, h, 0.0, RegularizationKind::Identity);
                Ok(true)
            }
            Err(FactorError::NotPositiveDefinite { .. }) => Ok(false),
            Err(FactorError::Other(e)) => Err(e),
        }
    }
}

/// The stability of an equilibrium ([`NewtonWorkspace::stability`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Stability {
    /// Smallest eigenvalue λ of `H v = λ S v`: the objective's own Hessian H without its
    /// diagonal shift
    /// ([`Objective::hessian_diagonal_shift`](crate::Objective::hessian_diagonal_shift)), measured
    /// against each unknown's own stiffness `S = diag(max(|H_dd|, 1e-6·mean|H_dd|))`
    /// (dimensionless), over the unknowns' space less the objective's
    /// [`Objective::rigid_modes`](crate::Objective::rigid_modes). Negative: the equilibrium is
    /// unstable (a saddle or maximum); near 0: near a critical load. NaN when H is so indefinite
    /// that `H + 10³·S` is not positive definite (`stable` is then false).
    pub min_eigenvalue: f64,
    /// Its mode in the free unknowns, scaled to `‖v‖∞ = 1` (the buckling mode at a critical
    /// load).
    pub mode: Vec<f64>,
    /// Relative residual `‖H v − λ S v‖₂ / ‖S v‖₂` of the estimate.
    pub residual: f64,
    /// Rigid modes left out.
    pub rigid_modes: usize,
    /// `min_eigenvalue > 0`.
    pub stable: bool,
}

impl NewtonWorkspace {
    /// The smallest eigenvalue and mode of the objective's own, unshifted Hessian at `x`
    /// (see [`Stability`]): inverse iteration on a Cholesky factor (two to a few
    /// factorisations, up to 60 triangular solves). Needs the direct solver.
    pub fn stability<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        x: &[f64],
    ) -> Result<Stability, SolverError> {
        self.check_direct(objective, x, "the stability analysis")?;
        let mut timings = NewtonTimings::default();
        assemble(objective, x, &mut self.hessian, false, 0, &mut timings)?;
        self.reusable = None;
        let shift = objective.hessian_diagonal_shift();
        if shift != 0.0 {
            let val = self.hessian.val_mut();
            self.diag_offsets.iter().for_each(|&o| val[o] -= shift);
        }
        curvature::scaling(&self.hessian, &self.diag_offsets, &mut self.scale);
        let modes = objective.rigid_modes(x);
        let Some(cholesky) = self.cholesky.as_mut() else {
            return Err(SolverError::Linear("no Cholesky factorisation".into()));
        };
        let (pair, _) = curvature::smallest_eigenpair(
            cholesky,
            &mut self.hessian,
            &self.diag_offsets,
            &self.scale,
            &modes,
        )?;
        Ok(Stability {
            stable: pair.value > 0.0,
            min_eigenvalue: pair.value,
            mode: pair.vector,
            residual: pair.residual,
            rigid_modes: modes.len(),
        })
    }
}

/// The iterative fallback of a workspace whose Cholesky factor does not fit in memory.
pub(super) struct Fallback {
    pub(super) kind: IterativeFallback,
    pub(super) precond: Precond,
    /// Symbolic statistics of the refused factor.
    pub(super) stats: FactorStats,
    /// Estimated bytes of the preconditioner and the CG vectors.
    pub(super) iterative_estimate: u64,
}

/// The fallback's preconditioner.
pub(super) enum Precond {
    Ic0(Ic0),
    /// Inverse diagonal.
    Jacobi(Vec<f64>),
}

impl Precond {
    /// Builds the preconditioner of `h`; `false` when it cannot (a non-positive diagonal
    /// entry: h is not positive definite).
    pub(super) fn build(&mut self, h: &SparseColMat<usize, f64>, diag_offsets: &[usize]) -> bool {
        match self {
            Precond::Ic0(ic) => ic.factorize(h.as_ref()).is_ok(),
            Precond::Jacobi(inv) => {
                let val = h.val();
                for (i, &o) in inv.iter_mut().zip(diag_offsets) {
                    if val[o].is_nan() || val[o] <= 0.0 {
                        return false;
                    }
                    *i = 1.0 / val[o];
                }
                true
            }
        }
    }

    pub(super) fn apply(&self, r: &mut [f64]) {
        match self {
            Precond::Ic0(ic) => ic.apply(r),
            Precond::Jacobi(inv) => r.iter_mut().zip(inv).for_each(|(r, d)| *r *= d),
        }
    }
}

impl NewtonWorkspace {
    /// The input of the factorisation whose factor this workspace keeps for the next solve
    /// ([`NewtonSettings::reuse_factor`](super::NewtonSettings::reuse_factor)); `None` when the
    /// next solve factorises afresh. With [`restore_kept_factor`](Self::restore_kept_factor)
    /// on a workspace built for the same objective and settings, the next solve takes the same
    /// steps bit for bit (checkpoints save it).
    pub fn kept_factor(&self) -> Option<KeptFactor> {
        self.kept.current_of(self.reusable?)
    }

    /// Keeps `kept` (from [`kept_factor`](Self::kept_factor)) as the factor for the next solve
    /// to reuse, refactorised before its first use; `None` forgets any kept factor.
    ///
    /// # Errors
    /// [`SolverError::DimensionMismatch`] when `kept` has not one value per entry of this
    /// workspace's Hessian pattern (the workspace is unchanged).
    pub fn restore_kept_factor(&mut self, kept: Option<KeptFactor>) -> Result<(), SolverError> {
        let Some(kept) = kept else {
            self.reusable = None;
            self.kept = KeptRecord::default();
            return Ok(());
        };
        if kept.values.len() != self.nnz() {
            return Err(SolverError::DimensionMismatch {
                what: "kept factor values",
                expected: self.nnz(),
                found: kept.values.len(),
            });
        }
        self.reusable = Some(kept.kind);
        self.kept = KeptRecord::restored(kept);
        Ok(())
    }
}
