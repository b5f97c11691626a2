//! What the integrators share: the [`Integrator`] trait and its [`StepReport`], the checks of
//! a step's inputs, the cached Newton workspace, and the retry rules after a failed solve.
//!
//! The integrators themselves live one per file: [`Static`](super::Static) (`statics.rs`),
//! [`ImplicitEuler`](super::ImplicitEuler) (`implicit.rs`), [`ExplicitEuler`](super::ExplicitEuler)
//! (`explicit.rs`).

use thinshell_energy::{EnergyTerms, HessianMode};

use super::objective::ShellObjective;
use super::system::{ShellSystem, State};
use crate::{
    CancelFlag, KeptFactor, NewtonReport, NewtonSettings, NewtonWorkspace, Objective, ProgressHook,
    SolverError,
};

/// What one step did.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// Time at the end of the step (s).
    pub t: f64,
    /// Step length actually taken (s; smaller than requested after adaptive halving).
    pub dt: f64,
    /// The Newton solve (iterations, residuals, backtracks, regularisations, timings);
    /// `None` for explicit steps.
    pub newton: Option<NewtonReport>,
    /// Halvings of Δt before the step succeeded.
    pub halvings: usize,
    /// Own-Hessian mode of the solve that succeeded: the settings' own
    /// ([`NewtonSettings::own_hessian`](crate::NewtonSettings::own_hessian)), or their fallback
    /// when the first solve failed (exact for explicit steps, which have none); per iteration,
    /// [`NewtonReport::hessians`](crate::NewtonReport::hessians) says which Hessian was used.
    pub hessian: HessianMode,
    /// Energy terms (J) at the end of the step (implicit, static) or its start (explicit).
    pub energies: EnergyTerms,
    /// Static steps: whether the equilibrium is a minimum, i.e. the smallest eigenvalue of the
    /// exact, unshifted Hessian there (rigid motions the boundary leaves free left out) is
    /// positive; `Some(false)` is a saddle or maximum (unstable: a perturbation leaves it).
    /// `None` for dynamic steps, and where the Cholesky factor does not fit in memory.
    pub stable: Option<bool>,
    /// With contact: the contact term at the end of the step (active pairs, smallest gap,
    /// barrier energy, Hessian counters; [`ShellSystem::contact_stats`]). `None` without.
    pub contact: Option<super::contact::ContactStats>,
    /// Static steps: that smallest eigenvalue and its mode ([`crate::Stability`]); `None` as
    /// for `stable`.
    pub stability: Option<crate::Stability>,
    /// Static steps: sub-steps of the rest-state continuation ([`crate::Static::continuation`])
    /// whose result the step returns: after the one-shot solve failed, or when the check of
    /// a wandering one-shot solve (`continuation_checked`) found a better equilibrium; 0 when
    /// the one-shot solve's result is returned, and for dynamic steps.
    pub continuation_stages: usize,
    /// Static steps: whether the one-shot solve succeeded only after many steps without the
    /// exact Hessian ([`crate::WANDERING_STEPS`]), so that the rest-state continuation was run
    /// as well and the better of the two equilibria kept (stable over unstable, then the lower
    /// static potential). `false` for dynamic steps.
    pub continuation_checked: bool,
    /// Static steps: the static potential `E − F_extᵀx − p·V` (J) at the equilibrium, what
    /// two equilibria of one problem are compared by ([`StepReport::is_better_equilibrium_than`]);
    /// `None` for dynamic steps.
    pub potential: Option<f64>,
}

impl StepReport {
    /// Whether this static step's equilibrium is a better answer than `other`'s, of the same
    /// problem: a stable one beats an unstable one, otherwise the lower
    /// [`potential`](Self::potential) wins (ties, and reports without a potential, keep
    /// `other`). The rule [`crate::Static`]'s wandering check keeps its result by.
    pub fn is_better_equilibrium_than(&self, other: &StepReport) -> bool {
        match (self.potential, other.potential) {
            (Some(a), Some(b)) => super::statics::better((self.stable, a), (other.stable, b)),
            _ => false,
        }
    }
}

/// What kind of step an [`Integrator`] takes: callers that treat equilibrium and dynamic steps
/// differently (load ramps, pseudo-time) ask the integrator instead of keeping a kind beside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StepKind {
    /// Static equilibrium: no inertia; the state's time is only read (prescribed motion).
    Static,
    /// Implicit time step (a Newton solve per step).
    Implicit,
    /// Explicit time step (no solve).
    Explicit,
}

/// Advances a [`State`] of a [`ShellSystem`] by one step.
pub trait Integrator {
    /// What kind of step [`Integrator::step`] takes.
    fn kind(&self) -> StepKind;

    /// Whether the step is a static equilibrium solve (no time, no inertia).
    fn is_static(&self) -> bool {
        self.kind() == StepKind::Static
    }

    /// One step; on error `state` is unchanged.
    fn step(
        &mut self,
        system: &mut ShellSystem,
        state: &mut State,
    ) -> Result<StepReport, SolverError>;

    /// Sets (or clears) the observer of Newton iterations; integrators without a Newton solve
    /// ignore it.
    fn set_progress(&mut self, _hook: Option<ProgressHook>) {}

    /// Sets (or clears) the flag that cancels a running Newton solve before its next iteration
    /// ([`SolverError::Cancelled`]; the state is unchanged); integrators without a Newton solve
    /// ignore it.
    fn set_cancel(&mut self, _flag: Option<CancelFlag>) {}

    /// State the integrator carries from one step to the next that changes later results (a
    /// checkpoint saves it): the remembered regularisation shift of its Newton solves; 0 for
    /// integrators without one.
    fn carried_state(&self) -> f64 {
        0.0
    }

    /// Restores what [`Integrator::carried_state`] returned.
    fn restore_carried_state(&mut self, _mu: f64) {}

    /// The other state carried from step to step that changes later results: the input of the
    /// Cholesky factor the next Newton solve may reuse
    /// ([`NewtonSettings::reuse_factor`], [`NewtonWorkspace::kept_factor`]); `None` for
    /// integrators without one or when the next solve factorises afresh. A checkpoint saves
    /// it, so that a resumed run reuses the same factor as the run that wrote it.
    fn kept_factor(&self) -> Option<KeptFactor> {
        None
    }

    /// Restores what [`Integrator::kept_factor`] returned (before the next step; a factor whose
    /// size does not fit the next solve's Hessian pattern is an error of that step).
    fn restore_kept_factor(&mut self, _kept: Option<KeptFactor>) {}
}

pub(crate) fn check_dt(dt: f64) -> Result<(), SolverError> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(SolverError::InvalidSetting {
            name: "dt",
            value: dt,
            requirement: "must be positive and finite",
        })
    }
}

/// Checks the state's lengths; fills in zero edge angles on a system with edge unknowns when
/// the state has none yet (e.g. from [`State::at_rest`]).
pub(crate) fn check_state(system: &ShellSystem, state: &mut State) -> Result<(), SolverError> {
    let n = system.mesh.n_vertices();
    let n_edges = system.n_edge_angles();
    if state.phi.is_empty() && n_edges > 0 {
        state.phi = vec![0.0; n_edges];
    }
    for (what, len, expected) in [
        ("state.x", state.x.len(), n),
        ("state.v", state.v.len(), n),
        ("state.phi", state.phi.len(), n_edges),
    ] {
        if len != expected {
            return Err(SolverError::DimensionMismatch {
                what,
                expected,
                found: len,
            });
        }
    }
    if let Some(e) = state.phi.iter().position(|p| !p.is_finite()) {
        return Err(SolverError::NonFiniteCoordinate { dof: 3 * n + e });
    }
    Ok(())
}

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
        objective: &ShellObjective<'_>,
        settings: &NewtonSettings,
    ) -> Result<&mut NewtonWorkspace, SolverError> {
        if self.ws.as_ref().is_some_and(|ws| {
            ws.n_dofs() != objective.n_dofs()
                || !objective.sys.has_hessian_pattern(ws.hessian())
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

/// The last accepted iterate a failed Newton solve carries, if any.
fn last_good(e: &SolverError) -> Option<&[f64]> {
    match e {
        SolverError::LineSearchFailed { last_good, .. }
        | SolverError::NewtonDidNotConverge { last_good, .. } => Some(last_good),
        _ => None,
    }
}

/// The last good iterate of a failed solve, as an owned start for a retry.
pub(crate) fn retry_start<T>(r: &Result<T, SolverError>) -> Option<Vec<f64>> {
    r.as_ref().err().and_then(last_good).map(<[f64]>::to_vec)
}

/// Whether a failure may be cured by another Hessian or a shorter step (not a bad setting or
/// a wrong dimension, which would fail the same way again).
pub(crate) fn retryable(e: &SolverError) -> bool {
    !matches!(
        e,
        SolverError::InvalidSetting { .. }
            | SolverError::Cancelled { .. }
            | SolverError::DimensionMismatch { .. }
            | SolverError::InvalidForceScale(_)
            | SolverError::InvalidLengthScale(_)
    )
}

/// The fallback mode of `settings` when it differs from their own.
pub(crate) fn fallback_mode(settings: &crate::NewtonSettings) -> Option<HessianMode> {
    settings
        .fallback_hessian
        .filter(|&m| m != settings.own_hessian)
}
