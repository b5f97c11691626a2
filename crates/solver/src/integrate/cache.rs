//! The Newton workspace an integrator keeps from one solve to the next.

use super::model::StepObjective;
use crate::{CancelFlag, KeptFactor, NewtonSettings, NewtonWorkspace, ProgressHook, SolverError};

/// An integrator's cached Newton workspace (symbolic factorisation, Hessian storage),
/// rebuilt when anything it was built from changed: the number of unknowns, the Hessian
/// pattern (another system), [`NewtonSettings::ordering`] or
/// [`NewtonSettings::parallel`]. [`Default`] is empty (built at the first solve).
#[derive(Default)]
pub struct NewtonCache {
    ws: Option<NewtonWorkspace>,
    /// Handed to every workspace built.
    progress: Option<ProgressHook>,
    /// Handed to every workspace built.
    cancel: Option<CancelFlag>,
    /// A restored regularisation memory waiting for the workspace of the next solve.
    pending_mu: Option<f64>,
    /// A restored kept factor waiting for the workspace of the next solve.
    pending_kept: Option<KeptFactor>,
}

impl std::fmt::Debug for NewtonCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NewtonCache")
            .field("ws", &self.ws)
            .field("progress", &self.progress.is_some())
            .field("cancel", &self.cancel.is_some())
            .field("pending_mu", &self.pending_mu)
            .field("pending_kept", &self.pending_kept.as_ref().map(|k| k.kind))
            .finish()
    }
}

impl NewtonCache {
    /// The workspace of the last solve, `None` before the first.
    pub fn get(&self) -> Option<&NewtonWorkspace> {
        self.ws.as_ref()
    }

    /// Sets (or clears) the observer of Newton iterations, for this and future workspaces.
    pub fn set_progress(&mut self, hook: Option<ProgressHook>) {
        if let Some(ws) = &mut self.ws {
            ws.set_progress(hook.clone());
        }
        self.progress = hook;
    }

    /// Sets (or clears) the cancel flag, for this and future workspaces.
    pub fn set_cancel(&mut self, flag: Option<CancelFlag>) {
        if let Some(ws) = &mut self.ws {
            ws.set_cancel(flag.clone());
        }
        self.cancel = flag;
    }

    /// The regularisation memory the next solve starts from (0 before the first solve).
    pub fn regularization_memory(&self) -> f64 {
        match (&self.ws, self.pending_mu) {
            (_, Some(mu)) => mu,
            (Some(ws), None) => ws.regularization_memory(),
            (None, None) => 0.0,
        }
    }

    /// Sets the regularisation memory of the next solve (a restored checkpoint).
    pub fn set_regularization_memory(&mut self, mu: f64) {
        match &mut self.ws {
            Some(ws) => ws.set_regularization_memory(mu),
            None => self.pending_mu = Some(mu),
        }
    }

    /// The input of the factor the next solve may reuse ([`NewtonWorkspace::kept_factor`]).
    pub fn kept_factor(&self) -> Option<KeptFactor> {
        match (&self.ws, &self.pending_kept) {
            (_, Some(k)) => Some(k.clone()),
            (Some(ws), None) => ws.kept_factor(),
            (None, None) => None,
        }
    }

    /// Sets the kept factor of the next solve (a restored checkpoint): applied to the current
    /// workspace when it fits, else to the next one built (whose solve fails with
    /// [`SolverError::DimensionMismatch`] if the factor does not fit it either).
    pub fn set_kept_factor(&mut self, kept: Option<KeptFactor>) {
        self.pending_kept = None;
        match (&mut self.ws, kept) {
            (Some(ws), None) => {
                // Cannot fail: `None` forgets.
                let _ = ws.restore_kept_factor(None);
            }
            (Some(ws), Some(k)) => {
                if k.values.len() == ws.nnz() {
                    let _ = ws.restore_kept_factor(Some(k));
                } else {
                    // Another pattern: the next workspace is built afresh and takes it.
                    self.pending_mu = Some(ws.regularization_memory());
                    self.ws = None;
                    self.pending_kept = Some(k);
                }
            }
            (None, k) => self.pending_kept = k,
        }
    }

    /// The workspace for `objective` and `settings`, rebuilt if it does not fit them.
    pub(crate) fn fit(
        &mut self,
        objective: &impl StepObjective,
        settings: &NewtonSettings,
    ) -> Result<&mut NewtonWorkspace, SolverError> {
        if self.ws.as_ref().is_some_and(|ws| {
            ws.n_dofs() != objective.n_dofs()
                || !objective.has_hessian_pattern(ws.hessian())
                || !ws.matches(settings)
        }) {
            self.ws = None;
        }
        match &mut self.ws {
            Some(ws) => Ok(ws),
            slot => {
                let mut ws = NewtonWorkspace::new(objective, settings)?;
                ws.set_progress(self.progress.clone());
                ws.set_cancel(self.cancel.clone());
                if let Some(mu) = self.pending_mu.take() {
                    ws.set_regularization_memory(mu);
                }
                ws.restore_kept_factor(self.pending_kept.take())?;
                Ok(slot.insert(ws))
            }
        }
    }
}
