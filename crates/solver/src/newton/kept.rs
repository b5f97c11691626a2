//! The Cholesky factor kept for reuse across Newton solves ([`NewtonSettings::reuse_factor`]),
//! recorded so that it can be rebuilt bit for bit: from a checkpoint (a resumed run then takes
//! the same reuse decisions, and so the same steps, as the run that wrote it) and after a
//! cancelled solve (which may have overwritten the factor).
//!
//! The factor itself (tens of times the Hessian's size) is not stored: what is stored is the
//! input of the factorisation that made it — the Hessian's values, and the small regularisation
//! shift the factorisation succeeded with. Refactorising that input with the same symbolic
//! analysis (rebuilt identically from the scene) gives the same factor: the numeric
//! factorisation is a fixed sequence of floating-point operations whatever the thread count
//! ([`SparseCholesky::new`]).
//!
//! [`NewtonSettings::reuse_factor`]: super::NewtonSettings::reuse_factor

use faer::sparse::SparseColMat;

use super::settings::IterationHessian;
use crate::SolverError;
use crate::linear::{RegularizationKind, RegularizationParams, SparseCholesky};

/// The input of the factorisation whose factor a Newton workspace keeps for reuse
/// ([`NewtonWorkspace::kept_factor`](super::NewtonWorkspace::kept_factor)): enough to rebuild
/// that factor bit for bit
/// ([`NewtonWorkspace::restore_kept_factor`](super::NewtonWorkspace::restore_kept_factor)),
/// e.g. from a checkpoint.
#[derive(Clone, Debug, PartialEq)]
pub struct KeptFactor {
    /// The kind of Hessian factorised; the next solve reuses the factor for iterations that
    /// use this kind.
    pub kind: IterationHessian,
    /// The Hessian's stored values (lower triangle, in the order of the workspace's pattern,
    /// [`NewtonWorkspace::hessian`](super::NewtonWorkspace::hessian)) as they were factorised,
    /// without the regularisation shift.
    pub values: Vec<f64>,
    /// The relative regularisation shift μ the factorisation succeeded with (0: unshifted; a
    /// reused factor has μ ≤ 1e-8), see [`SparseCholesky::factorize_regularized`].
    pub shift: f64,
    /// The shape of that shift.
    pub shift_kind: RegularizationKind,
}

/// A workspace's record of its kept factor.
#[derive(Debug, Default)]
pub(super) struct KeptRecord {
    /// The input of the last factorisation made reusable while reuse was on.
    current: Option<KeptFactor>,
    /// `Some(state)` once the running solve replaced `current`: the state at its start,
    /// restored when the solve is cancelled.
    at_start: Option<Option<KeptFactor>>,
    /// The workspace's `reusable` when the running solve started.
    reusable_at_start: Option<IterationHessian>,
    /// The Cholesky factor the workspace holds is not the one of `current` (after a restore or
    /// a cancelled solve): refactorise `current` before reusing it.
    stale: bool,
}

impl KeptRecord {
    /// Records the input of a factorisation that was just made reusable.
    pub(super) fn record(
        &mut self,
        kind: IterationHessian,
        values: &[f64],
        shift: f64,
        shift_kind: RegularizationKind,
    ) {
        if self.at_start.is_none() {
            self.at_start = Some(self.current.take());
        }
        match &mut self.current {
            Some(k) if k.values.len() == values.len() => {
                k.values.copy_from_slice(values);
                k.kind = kind;
                k.shift = shift;
                k.shift_kind = shift_kind;
            }
            slot => {
                *slot = Some(KeptFactor {
                    kind,
                    values: values.to_vec(),
                    shift,
                    shift_kind,
                })
            }
        }
        self.stale = false;
    }

    /// Marks the start of a Newton solve, whose workspace keeps a factor of `reusable`.
    pub(super) fn begin_solve(&mut self, reusable: Option<IterationHessian>) {
        self.at_start = None;
        self.reusable_at_start = reusable;
    }

    /// A cancelled solve: back to the kept factor of its start (to be refactorised before its
    /// next use, since the solve may have overwritten it). Returns the workspace's `reusable`.
    pub(super) fn cancel_solve(&mut self) -> Option<IterationHessian> {
        if let Some(start) = self.at_start.take() {
            self.current = start;
        }
        if self.reusable_at_start.is_some() {
            self.stale = true;
        }
        self.reusable_at_start
    }

    /// Makes sure `cholesky` holds the factor of `current` (refactorising it after a restore or
    /// a cancelled solve; `hessian`'s values are left as they were). `false`: the refactorisation
    /// failed, which cannot happen to the input of a successful factorisation unless it was
    /// altered; the caller then factorises afresh.
    pub(super) fn ensure_factor(
        &mut self,
        cholesky: Option<&mut SparseCholesky>,
        hessian: &mut SparseColMat<usize, f64>,
    ) -> Result<bool, SolverError> {
        if !self.stale {
            return Ok(true);
        }
        let (Some(cholesky), Some(kept)) = (cholesky, self.current.as_mut()) else {
            return Ok(false);
        };
        if kept.values.len() != hessian.val().len() {
            return Ok(false);
        }
        // The same shift as the original factorisation: with `shrink` = 1 and `initial` = μ the
        // first attempt is exactly μ (0 when μ = 0), and there is no other attempt.
        let params = RegularizationParams {
            kind: kept.shift_kind,
            initial: if kept.shift > 0.0 { kept.shift } else { 1.0 },
            growth: 2.0,
            shrink: 1.0,
            max_attempts: 0,
        };
        let mut mu = kept.shift;
        hessian.val_mut().swap_with_slice(&mut kept.values);
        let r = cholesky.factorize_regularized(hessian, &params, &mut mu);
        hessian.val_mut().swap_with_slice(&mut kept.values);
        match r {
            Ok(o) if o.mu == kept.shift => {
                self.stale = false;
                Ok(true)
            }
            Ok(_) | Err(crate::linear::FactorError::NotPositiveDefinite { .. }) => Ok(false),
            Err(crate::linear::FactorError::Other(e)) => Err(e),
        }
    }
}

impl KeptRecord {
    /// The kept factor's input when it is of kind `kind`.
    pub(super) fn current_of(&self, kind: IterationHessian) -> Option<KeptFactor> {
        self.current.as_ref().filter(|k| k.kind == kind).cloned()
    }

    /// A record that holds `kept`, to be refactorised before its first use.
    pub(super) fn restored(kept: KeptFactor) -> Self {
        KeptRecord {
            current: Some(kept),
            stale: true,
            ..KeptRecord::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cancelled_solve_gets_back_the_factor_kept_at_its_start() {
        let mut k = KeptRecord::default();
        k.begin_solve(None);
        k.record(
            IterationHessian::Own,
            &[1.0, 2.0],
            0.0,
            RegularizationKind::Identity,
        );
        k.begin_solve(Some(IterationHessian::Own));
        k.record(
            IterationHessian::Psd,
            &[3.0, 4.0],
            1e-9,
            RegularizationKind::Diagonal,
        );
        k.record(
            IterationHessian::Own,
            &[5.0, 6.0],
            0.0,
            RegularizationKind::Identity,
        );
        assert!(!k.stale);
        assert_eq!(k.cancel_solve(), Some(IterationHessian::Own));
        assert!(k.stale, "the factor held is the cancelled attempt's");
        let kept = k.current.as_ref().map(|c| (c.kind, c.values.clone()));
        assert_eq!(kept, Some((IterationHessian::Own, vec![1.0, 2.0])));
        // A solve that recorded nothing keeps its start's factor, to be rebuilt all the same.
        k.stale = false;
        k.begin_solve(Some(IterationHessian::Own));
        assert_eq!(k.cancel_solve(), Some(IterationHessian::Own));
        assert!(k.stale);
        // Without a kept factor at the start there is none after the cancel.
        k.begin_solve(None);
        k.record(
            IterationHessian::Own,
            &[7.0, 8.0],
            0.0,
            RegularizationKind::Identity,
        );
        assert_eq!(k.cancel_solve(), None);
    }
}
