//! One solve in progress ([`Solve`]): the objective, the iterate and the record that the
//! phases of an iteration (direction, step, escape, policy) share, the settings fixed for the
//! solve ([`Frame`]), and the shift and decrease thresholds those phases share.

use std::time::Instant;

use super::checks::step_limit_of;
use super::report::Record;
use super::settings::NewtonSettings;
use super::workspace::NewtonWorkspace;
use crate::SolverError;
use crate::linear::RegularizationParams;
use crate::objective::Objective;

/// Largest relative shift (of the mean |H_dd|) the adaptive policy applies to the own Hessian
/// before it switches to the PSD one; also the largest shift with which a Newton correction
/// still counts for the convergence test.
pub(super) const SMALL_SHIFT: f64 = 1e-8;

/// A watchdog step (and a step to a saddle, `escape.rs`) needs a predicted decrease this many times
/// the round-off of f: near round-off, values cannot tell a good step from a bad one and the usual
/// rules apply.
pub(super) const WATCHDOG_MIN_DECREASE: f64 = 1e4;

/// Largest trust-region shift σ (relative to each unknown's own stiffness, see
/// `curvature.rs`): an own Hessian that needs more is strongly indefinite — a compressed
/// membrane far from equilibrium — where the shifted steps crawl (the cone-growing annulus of
/// docs/robustness.md) and PSD steps do better.
pub(super) const TR_MAX_SHIFT: f64 = 1e-2;

/// What stays fixed during one solve.
pub(super) struct Frame<'a> {
    pub(super) settings: &'a NewtonSettings,
    /// [`Objective::length_scale`] (m) and [`Objective::force_scale`] (N).
    pub(super) length_scale: f64,
    pub(super) force_scale: f64,
    /// [`Objective::gradient_test`].
    pub(super) gradient_test: bool,
    pub(super) reg_params: RegularizationParams,
    pub(super) started: Instant,
    /// The start of the solve, kept for [`NewtonSettings::relative_step_tolerance`].
    pub(super) x_start: Option<Vec<f64>>,
    /// The initial gradient's norm, the reference of the CG forcing term.
    pub(super) g0: f64,
}

impl Frame<'_> {
    /// The step-convergence limit at `x` (m): the absolute one, or the relative one of
    /// [`NewtonSettings::relative_step_tolerance`] when that is larger.
    pub(super) fn step_limit(&self, x: &[f64]) -> f64 {
        let absolute = self.settings.step_tolerance * self.length_scale;
        match &self.x_start {
            Some(x0) => {
                let moved = x
                    .iter()
                    .zip(x0)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                absolute.max(self.settings.relative_step_tolerance * moved)
            }
            None => absolute,
        }
    }
}

/// One solve in progress: what every phase of an iteration reads and moves. `x` is the
/// current iterate, `f` its value and `ws.g` its gradient; `iteration` counts the accepted
/// iterations (the record's length less one); `rec` is the accepted path so far.
pub(super) struct Solve<'a, O: ?Sized> {
    pub(super) objective: &'a mut O,
    pub(super) x: &'a mut [f64],
    pub(super) f: f64,
    pub(super) ws: &'a mut NewtonWorkspace,
    pub(super) rec: Record,
    pub(super) frame: Frame<'a>,
    pub(super) iteration: usize,
}

impl<O: Objective + ?Sized> Solve<'_, O> {
    /// The objective's step limit for `ws.dx` from `x`, checked ([`step_limit_of`]).
    pub(super) fn max_step(&mut self) -> Result<f64, SolverError> {
        step_limit_of(self.objective, self.x, &self.ws.dx)
    }
}
