//! The adaptive Hessian policy (see the module documentation of `newton.rs`): which Hessian the
//! next iteration tries, the trust-region shift of indefinite own Hessians, the damping of PSD
//! steps, and when a saddle is left along negative curvature.

use super::escape::escape_saddle;
use super::settings::{HessianPolicy, IterationHessian, NewtonSettings};
use super::solve::{SMALL_SHIFT, Solve};
use crate::SolverError;
use crate::curvature::SHIFT_GROWTH;
use crate::objective::Objective;

/// First Levenberg–Marquardt damping of PSD steps (relative to the mean |H_dd|) after a
/// backtracked PSD step; below it the damping is switched off.
const DAMPING_MIN: f64 = 1e-6;
/// Backtracks of a PSD step (its full step was at least 2³ times too long) that raise the
/// damping.
const DAMPING_BACKTRACKS: usize = 3;
/// Factor the damping grows by after a backtracked PSD step and shrinks by after a good one.
const DAMPING_GROWTH: f64 = 10.0;

/// A PSD iteration that leaves more than this fraction of the residual is slow.
const PSD_SLOW_RATIO: f64 = 0.5;
/// Consecutive slow PSD iterations after which the PSD iterations count as stalled.
const PSD_STALL_ITERATIONS: usize = 2;

/// A shifted step is taken when its actual decrease is at least this fraction of the decrease
/// the exact quadratic model predicts (the trust-region acceptance ratio).
pub(super) const TR_ACCEPT: f64 = 0.1;
/// Factor the trust-region shift grows by after a rejected or poor (ρ < 0.25) step.
const TR_GROWTH: f64 = 4.0;
/// Factor the trust-region shift shrinks by after a very good (ρ > 0.75) step.
const TR_SHRINK: f64 = 16.0;
/// Consecutive rejected shifted steps after which the solve turns to the PSD Hessian for a
/// while (the shifted model does not describe f here at any shift tried so far).
const MAX_TR_REJECTIONS: usize = 6;
/// Negative-curvature escapes per solve.
const MAX_ESCAPES: usize = 50;

/// The state of the adaptive policy during one solve.
pub(super) struct Policy {
    /// Own and PSD Hessians alternate ([`HessianPolicy::Adaptive`] or `AdaptivePsd` with an
    /// objective that has a PSD Hessian); otherwise every iteration uses the own one.
    pub(super) adaptive: bool,
    /// Trust-region steps on the shifted own Hessian where it is indefinite: the adaptive
    /// policy with a direct solver.
    pub(super) trust: bool,
    /// Converged saddles are left along negative curvature.
    escape: bool,
    /// Whether the next iteration tries the own Hessian.
    pub(super) try_own: bool,
    /// Good PSD steps to wait before trying the own Hessian again, and that wait after the
    /// next failure.
    wait: usize,
    backoff: usize,
    /// Trust-region (Levenberg–Marquardt) parameter σ of shifted steps, relative to S, after
    /// the last step's ratio test (0: none).
    pub(super) sigma: f64,
    /// The last shift at which own + σS factorised.
    pub(super) pd_floor: f64,
    tr_rejections: usize,
    escapes: usize,
    /// Whether an iterate of this solve met an indefinite own Hessian or used another one:
    /// only then can a converged point be a saddle (an own Hessian positive definite all along
    /// ends at a minimum).
    pub(super) met_indefinite: bool,
    /// The last shifted step was as good as its model yet limited by the shift that keeps
    /// `H + σS` positive definite: the next iteration moves along negative curvature.
    pub(super) want_escape: bool,
    /// Consecutive PSD iterations that reduced the residual by less than [`PSD_SLOW_RATIO`],
    /// and whether the PSD iterations have stalled: only then does an indefinite own Hessian
    /// get trust-region steps (far from a solution Gauss–Newton is the faster: its model
    /// ignores the compressive stresses whose negative curvature makes the shifted steps
    /// short). Without line search PSD steps are taken in full, unguarded: the trust region
    /// (which has its own acceptance test) is used from the start.
    psd_slow: usize,
    pub(super) psd_stalled: bool,
    /// Levenberg–Marquardt damping of PSD iterations (relative to the mean |H_dd|).
    pub(super) damping: f64,
}

impl Policy {
    pub(super) fn new(settings: &NewtonSettings, has_psd_hessian: bool, direct: bool) -> Self {
        let adaptive = matches!(
            settings.hessian,
            HessianPolicy::Adaptive | HessianPolicy::AdaptivePsd
        ) && has_psd_hessian;
        let trust = adaptive && settings.hessian == HessianPolicy::Adaptive && direct;
        Self {
            adaptive,
            trust,
            escape: trust && settings.escape_saddles,
            try_own: true,
            wait: 0,
            backoff: 1,
            sigma: 0.0,
            pd_floor: 0.0,
            tr_rejections: 0,
            escapes: 0,
            met_indefinite: false,
            want_escape: false,
            psd_slow: 0,
            psd_stalled: !settings.line_search,
            damping: 0.0,
        }
    }

    /// Whether steps along negative curvature may be taken (escapes and extrapolation).
    pub(super) fn escapes_saddles(&self) -> bool {
        self.escape
    }

    /// The shift the trust-region search starts from, and whether the own Hessian is known
    /// to be indefinite (σ or the last positive-definite shift above the small one).
    pub(super) fn trust_start(&self) -> (f64, bool) {
        let start = self.sigma.max(self.pd_floor / SHIFT_GROWTH);
        (start, self.trust && start > SMALL_SHIFT)
    }

    /// The own Hessian failed (did not factorise, or its step was rejected): PSD steps, the
    /// own Hessian tried again after 1, 2, 4, … good ones.
    pub(super) fn own_failed(&mut self) {
        self.try_own = false;
        self.wait = self.backoff;
        self.backoff = self.backoff.saturating_mul(2);
    }

    /// As [`Self::own_failed`], and the trust-region memory is dropped.
    pub(super) fn psd_instead(&mut self) {
        self.own_failed();
        self.sigma = 0.0;
        self.pd_floor = 0.0;
    }

    /// A shifted direction was found with shift `mu`.
    pub(super) fn shifted(&mut self, mu: f64) {
        self.sigma = mu;
        self.pd_floor = mu;
    }

    /// A shifted step was rejected by the ratio test.
    pub(super) fn shifted_rejected(&mut self, line_search: bool) {
        self.tr_rejections += 1;
        self.sigma *= TR_GROWTH;
        if self.tr_rejections >= MAX_TR_REJECTIONS {
            // The shifted model keeps failing here (far from any quadratic behaviour): PSD
            // steps until they stall again.
            self.psd_stalled = !line_search;
            self.psd_slow = 0;
            self.psd_instead();
            self.tr_rejections = 0;
        }
    }

    /// A shifted step passed the ratio test.
    pub(super) fn shifted_accepted(&mut self) {
        self.tr_rejections = 0;
    }

    /// Leaves a point where the own Hessian is indefinite along negative curvature
    /// ([`escape_saddle`]), while escapes are allowed. `known`: the Hessian in `ws` is the own
    /// one at x, known indefinite. Returns whether x moved (the solve's value and gradient are
    /// then the new point's); the Newton loop then goes on from the new point with the shift
    /// found there (from inside the line search, a retry of the stale direction and slope of
    /// the point before the escape passed its round-off test at once: a false convergence far
    /// from equilibrium, robustness.md).
    pub(super) fn leave_saddle<O: Objective + ?Sized>(
        &mut self,
        s: &mut Solve<'_, O>,
        known: bool,
    ) -> Result<bool, SolverError> {
        if !(self.escape && self.escapes < MAX_ESCAPES) {
            return Ok(false);
        }
        self.escapes += 1;
        let moved = escape_saddle(s, &mut self.sigma, known)?;
        if moved {
            self.pd_floor = self.sigma;
            self.try_own = true;
        }
        Ok(moved)
    }

    /// Updates the policy after an accepted step of kind `kind` that backtracked `backtracks`
    /// times, with trust-region ratio `rho` (shifted steps), slope `∇fᵀdx` and values before
    /// and after; `residuals` is the record including the new iterate.
    pub(super) fn after_step(
        &mut self,
        kind: IterationHessian,
        backtracks: usize,
        rho: f64,
        slope: f64,
        (f_old, f): (f64, f64),
        residuals: &[f64],
    ) {
        if kind == IterationHessian::Psd {
            let n = residuals.len();
            if residuals[n - 1] > PSD_SLOW_RATIO * residuals[n - 2] {
                self.psd_slow += 1;
            } else {
                self.psd_slow = 0;
            }
            if self.trust && !self.psd_stalled && self.psd_slow >= PSD_STALL_ITERATIONS {
                // Gauss–Newton converges only linearly here: the own Hessian (shifted in a
                // trust region where it is indefinite) from the next iteration on.
                self.psd_stalled = true;
                self.try_own = true;
                self.wait = 0;
                self.backoff = 1;
            }
        } else {
            self.psd_slow = 0;
        }
        if !self.adaptive {
            return;
        }
        // A backtracked step of the own Hessian means its quadratic model is poor here; a full
        // PSD step that achieved at least half the predicted decrease (ratio ρ = Δf / (½ ∇fᵀdx),
        // the PSD model's prediction) means the iterate is where the quadratic model holds, so
        // the own Hessian is worth another try.
        match kind {
            IterationHessian::Shifted => {
                // Levenberg–Marquardt update of the trust-region shift.
                if rho > 0.75 {
                    self.sigma /= TR_SHRINK;
                    self.want_escape = self.sigma < self.pd_floor / SHIFT_GROWTH;
                } else if rho < 0.25 {
                    self.sigma *= TR_GROWTH;
                }
                if self.sigma <= SMALL_SHIFT {
                    self.sigma = 0.0;
                }
            }
            IterationHessian::Own if backtracks > 0 => self.try_own = false,
            IterationHessian::Psd if backtracks > 0 => {
                if backtracks >= DAMPING_BACKTRACKS {
                    self.damping = (self.damping * DAMPING_GROWTH).max(DAMPING_MIN);
                }
                // The PSD model overshoots too: the own Hessian may do better here (a
                // membrane sagging from flat). Rejections make it wait 1, 2, 4, … steps.
                self.own_again();
            }
            IterationHessian::Psd if backtracks == 0 && slope < 0.0 => {
                let rho = (f - f_old) / (0.5 * slope);
                if rho >= 0.5 {
                    self.damping /= DAMPING_GROWTH * DAMPING_GROWTH;
                    if self.damping < DAMPING_MIN {
                        self.damping = 0.0;
                    }
                    self.own_again();
                }
            }
            _ => {}
        }
    }

    /// One more good PSD step: the own Hessian next, once the wait is over.
    fn own_again(&mut self) {
        if self.wait == 0 {
            self.try_own = true;
        } else {
            self.wait -= 1;
        }
    }
}
