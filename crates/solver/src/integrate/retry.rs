//! What the integrators do after a failed solve, in one place: which failures are worth a
//! retry, the retry with the fallback Hessian from the last good iterate, the halving of Δt,
//! and the one continuation walk.
//!
//! The order, for every integrator: the solve with the settings' own Hessian; if it fails, the
//! same solve with their fallback Hessian ([`NewtonSettings::fallback_hessian`]), first from the
//! last good iterate, then from the usual start; then the integrator's own remedy — implicit
//! steps halve Δt ([`ImplicitEuler::max_halvings`](crate::ImplicitEuler::max_halvings)), static
//! steps walk to the problem by continuation ([`Static::continuation`](crate::Static::continuation),
//! [`continuation_walk`]).

use thinshell_energy::HessianMode;

use super::model::{Model, State};
use super::{StepReport, StepReportNewton};
use crate::{NewtonReport, NewtonSettings, NewtonTimings, SolverError};

/// Halvings of the continuation sub-step before it gives up (smallest sub-step 2⁻⁶).
pub const MAX_CONTINUATION_HALVINGS: u32 = 6;

/// Checks a time step: positive and finite.
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

/// Checks the state's lengths; fills in zero extra unknowns on a model that has them when the
/// state has none yet (e.g. from [`State::at_rest`]).
pub(crate) fn check_state<M: Model + ?Sized>(
    model: &M,
    state: &mut State,
) -> Result<(), SolverError> {
    let n = model.n_points();
    let n_extra = model.n_extra();
    if state.phi.is_empty() && n_extra > 0 {
        state.phi = vec![0.0; n_extra];
    }
    for (what, len, expected) in [
        ("state.x", state.x.len(), n),
        ("state.v", state.v.len(), n),
        ("state.phi", state.phi.len(), n_extra),
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

/// The last accepted iterate a failed Newton solve carries, if any.
fn last_good(e: &SolverError) -> Option<&[f64]> {
    match e {
        SolverError::LineSearchFailed { last_good, .. }
        | SolverError::NewtonDidNotConverge { last_good, .. } => Some(last_good),
        _ => None,
    }
}

/// Whether a failure may be cured by another Hessian, a shorter step or a continuation (not a
/// bad setting, a cancellation or a wrong dimension, which would fail the same way again).
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

/// An integrator that solves with Newton: the settings [`with_fallback_hessian`] switches.
pub(crate) trait NewtonIntegrator {
    fn newton_settings(&mut self) -> &mut NewtonSettings;
}

/// Runs `solve(integrator, None)` with the settings' own Hessian; when it fails retryably and
/// the settings name a fallback Hessian different from their own, runs it again with the
/// fallback, from the failed solve's last good iterate (`Some(u)`, free unknowns) and, if that
/// fails too, from the usual start (`None`). The settings' `own_hessian` is the fallback during
/// the retries and restored after. Returns the last result and the own-Hessian mode it was
/// obtained with.
pub(crate) fn with_fallback_hessian<I: NewtonIntegrator, T>(
    integrator: &mut I,
    mut solve: impl FnMut(&mut I, Option<&[f64]>) -> Result<T, SolverError>,
) -> (Result<T, SolverError>, HessianMode) {
    let own = integrator.newton_settings().own_hessian;
    let fallback = integrator.newton_settings().fallback_hessian;
    let first = solve(integrator, None);
    let mode = match (&first, fallback.filter(|&m| m != own)) {
        (Err(e), Some(mode)) if retryable(e) => mode,
        _ => return (first, own),
    };
    let from_last: Option<Vec<f64>> = first
        .as_ref()
        .err()
        .and_then(last_good)
        .map(<[f64]>::to_vec);
    integrator.newton_settings().own_hessian = mode;
    let mut result = solve(integrator, from_last.as_deref());
    if result.is_err() && from_last.is_some() {
        result = solve(integrator, None);
    }
    integrator.newton_settings().own_hessian = own;
    (result, mode)
}

/// What a continuation walk did: the report of its last sub-step, with the counts of all.
#[derive(Debug)]
pub(crate) struct Continued<R> {
    /// The last sub-step's report; its Newton `iterations` summed over every sub-step (failed
    /// ones included), `backtracks`, `rejected_steps`, `factorizations` and `timings` over the
    /// sub-steps that succeeded.
    pub report: R,
    /// Sub-steps solved successfully (the last one at s = 1).
    pub stages: usize,
}

/// The one continuation walk: solves `stage(s, trial)` for s rising from 0 to 1, each stage
/// from the last stage's result (`trial`, a copy of `state`), with sub-steps that start at ½
/// and halve on failure, down to 2^−[`MAX_CONTINUATION_HALVINGS`]. On success `state` holds the
/// result at s = 1; on failure (or cancellation) the state it started from, and the error of
/// the last failed stage.
pub(crate) fn continuation_walk<S: Clone, R: StepReportNewton>(
    state: &mut S,
    mut stage: impl FnMut(f64, &mut S) -> Result<R, SolverError>,
) -> Result<Continued<R>, SolverError> {
    let start = state.clone();
    let (mut done, mut step) = (0.0f64, 0.5f64);
    let mut total = Totals::default();
    let mut stages = 0;
    loop {
        let s = (done + step).min(1.0);
        let mut trial = state.clone();
        match stage(s, &mut trial) {
            Ok(mut report) => {
                *state = trial;
                stages += 1;
                done = s;
                if let Some(n) = report.newton_mut() {
                    total.iterations += n.iterations;
                    total.backtracks += n.backtracks;
                    total.rejected_steps += n.rejected_steps;
                    total.factorizations += n.factorizations;
                    add_timings(&mut total, n);
                    if done >= 1.0 {
                        n.iterations = total.iterations;
                        n.backtracks = total.backtracks;
                        n.rejected_steps = total.rejected_steps;
                        n.factorizations = total.factorizations;
                        n.timings = total.timings;
                    }
                }
                if done >= 1.0 {
                    return Ok(Continued { report, stages });
                }
            }
            Err(e) => {
                total.iterations += e.newton_iterations();
                let cancelled = matches!(e, SolverError::Cancelled { .. });
                if cancelled || step <= 0.5f64.powi(MAX_CONTINUATION_HALVINGS as i32) {
                    *state = start;
                    return Err(e);
                }
                step /= 2.0;
            }
        }
    }
}

/// The counts a walk sums over its sub-steps.
#[derive(Default)]
struct Totals {
    iterations: usize,
    backtracks: usize,
    rejected_steps: usize,
    factorizations: usize,
    timings: NewtonTimings,
}

fn add_timings(total: &mut Totals, n: &NewtonReport) {
    let (a, b) = (&mut total.timings, &n.timings);
    a.assembly += b.assembly;
    a.factorization += b.factorization;
    a.solve += b.solve;
    a.line_search += b.line_search;
    a.line_search_evaluations += b.line_search_evaluations;
}

impl StepReportNewton for NewtonReport {
    fn newton_mut(&mut self) -> Option<&mut NewtonReport> {
        Some(self)
    }
}

impl<E, C> StepReportNewton for StepReport<E, C> {
    fn newton_mut(&mut self) -> Option<&mut NewtonReport> {
        self.newton.as_mut()
    }
}
