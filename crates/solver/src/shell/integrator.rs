//! What the integrators share: the [`Integrator`] trait and its [`StepReport`], the checks of
//! a step's inputs, the cached Newton workspace, and the retry rules after a failed solve.
//!
//! The integrators themselves live one per file: [`Static`](super::Static) (`statics.rs`),
//! [`ImplicitEuler`](super::ImplicitEuler) (`implicit.rs`), [`ExplicitEuler`](super::ExplicitEuler)
//! (`explicit.rs`).

use thinshell_energy::{EnergyTerms, HessianMode};

use super::objective::ShellObjective;
use super::system::{ShellSystem, State};
use crate::{NewtonReport, NewtonSettings, NewtonWorkspace, Objective, SolverError};

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
    /// Hessian of the solve that succeeded: the system's own mode, or the integrator's fallback
    /// mode when the first solve failed (`ShellSystem::hessian_mode` for explicit steps).
    pub hessian: HessianMode,
    /// Energy terms (J) at the end of the step (implicit, static) or its start (explicit).
    pub energies: EnergyTerms,
    /// Static steps: whether the equilibrium is a minimum, i.e. the exact Hessian there (with
    /// the static solver's tiny `hessian_shift` against rigid motions) factorises without a
    /// shift; `Some(false)` is a saddle or maximum (unstable: a perturbation leaves it).
    /// `None` for dynamic steps.
    pub stable: Option<bool>,
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
#[derive(Debug, Default)]
pub struct NewtonCache(Option<NewtonWorkspace>);

impl NewtonCache {
    /// The workspace of the last solve, `None` before the first.
    pub fn get(&self) -> Option<&NewtonWorkspace> {
        self.0.as_ref()
    }

    /// The workspace for `objective` and `settings`, rebuilt if it does not fit them.
    pub(crate) fn fit(
        &mut self,
        objective: &ShellObjective<'_>,
        settings: &NewtonSettings,
    ) -> Result<&mut NewtonWorkspace, SolverError> {
        if self.0.as_ref().is_some_and(|ws| {
            ws.n_dofs() != objective.n_dofs()
                || !objective.sys.assembler.has_pattern(ws.hessian())
                || !ws.matches(settings)
        }) {
            self.0 = None;
        }
        match &mut self.0 {
            Some(ws) => Ok(ws),
            slot => Ok(slot.insert(NewtonWorkspace::new(objective, settings)?)),
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
            | SolverError::DimensionMismatch { .. }
            | SolverError::InvalidForceScale(_)
            | SolverError::InvalidLengthScale(_)
    )
}

/// The fallback mode when it differs from the system's own.
pub(crate) fn fallback_mode(
    system: &ShellSystem,
    fallback: Option<HessianMode>,
) -> Option<HessianMode> {
    fallback.filter(|&m| m != system.hessian_mode)
}
