//! Static equilibrium: [`Static`] minimises `E(x) − F_extᵀx − p·V(x)` over the free dofs.
//!
//! Rigid motions (a null space when too few coordinates are held) are handled by a small shift
//! `κ·mean|H_dd|` of the Hessian diagonal only (the gradient is exact, so the equilibrium is
//! unchanged; the iterates simply do not drift along rigid modes), plus Newton's regularisation
//! when needed; optionally a retry with a fallback Hessian from the last good iterate (see
//! [`NewtonSettings::fallback_hessian`]).

use nalgebra::Vector3;
use thinshell_energy::HessianMode;

use super::homotopy;
use super::integrator::{
    Integrator, NewtonCache, StepKind, StepReport, check_state, fallback_mode, retry_start,
    retryable,
};
use super::objective::ShellObjective;
use super::system::{ShellSystem, State};
use crate::descent::double_while_falling;
use crate::{
    NewtonReport, NewtonSettings, NewtonWorkspace, Objective, SolverError, Stability, newton_solve,
};

/// Static equilibrium: minimise `E(x) − F_extᵀx` over the free dofs.
#[derive(Debug)]
pub struct Static {
    /// Newton parameters.
    pub newton: NewtonSettings,
    /// Relative Hessian diagonal shift κ against rigid-motion null spaces (≥ 0).
    pub hessian_shift: f64,
    /// `Some(F)`: also stop when `‖∇‖∞ ≤ gradient_tolerance · F` (N; trust it only when F is
    /// the size of the forces that matter). `None` (default): converge on the Newton correction
    /// or at round-off only (scale-free, see [`newton_solve`]); residuals are reported relative
    /// to [`ShellSystem::force_scale`].
    pub force_scale: Option<f64>,
    /// Whether [`Integrator::step`] uses rest-state continuation from the start (default
    /// `true`): rest forms from the start's own forms to the system's, loads from 0 to the
    /// system's load factor, in sub-steps (`shell/homotopy.rs`). A far start (a flat sheet
    /// grown into a cone) otherwise ends at the iteration limit or in the basin of a
    /// higher-energy minimum. It solves the step when the one-shot solve fails, and checks a
    /// one-shot solve that succeeded only after [`WANDERING_STEPS`](crate::WANDERING_STEPS) or more steps without the
    /// exact Hessian: the better equilibrium is kept ([`StepReport::continuation_checked`]).
    /// Off for callers with a continuation of their own (a scene's run loop continues from the
    /// previous step's rest forms instead).
    pub continuation: bool,
    /// The cached Newton workspace ([`Default`]: empty).
    pub cache: NewtonCache,
}

impl Default for Static {
    fn default() -> Self {
        Static {
            newton: NewtonSettings::default(),
            hessian_shift: 1e-10,
            force_scale: None,
            continuation: true,
            cache: NewtonCache::default(),
        }
    }
}

impl Static {
    /// Solves for the equilibrium starting from `x` (overwritten; held coordinates kept). With
    /// edge unknowns the angles start at 0; the solved ones are kept on the system
    /// ([`ShellSystem::edge_angles`]), where [`ShellSystem::energy`] starts from them.
    /// [`Static::solve_with_angles`] also takes and returns them.
    pub fn solve(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
    ) -> Result<NewtonReport, SolverError> {
        let mut phi = vec![0.0; system.n_edge_angles()];
        self.solve_with_angles(system, x, &mut phi)
    }

    /// Solves for the equilibrium starting from positions `x` and edge angles `phi` (rad, one
    /// per edge; empty without edge unknowns), both overwritten.
    pub fn solve_with_angles(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
    ) -> Result<NewtonReport, SolverError> {
        check_static_inputs(system, phi, self.hessian_shift)?;
        let mut u = system.gather(x, phi);
        let mut obj = self.objective(system, x, phi);
        let ws = self.cache.fit(&obj, &self.newton)?;
        let result = newton_solve(&mut obj, &mut u, &self.newton, ws);
        let sys = obj.sys;
        sys.scatter(&u, x, phi);
        if result.is_ok() {
            sys.keep_angles(phi);
        }
        result
    }
}

impl Static {
    fn objective<'a>(
        &self,
        system: &'a mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> ShellObjective<'a> {
        ShellObjective::statics(system, x, phi, self.hessian_shift, self.force_scale)
            .with_hessian(self.newton.own_hessian)
    }

    /// Whether positions `x` and edge angles `phi` (rad, one per edge; empty without edge
    /// unknowns) are a stable equilibrium candidate: the smallest eigenvalue of the **exact**
    /// Hessian of the static potential there is positive ([`Static::stability`]).
    pub fn is_stable(
        &mut self,
        system: &mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<bool, SolverError> {
        Ok(self.stability(system, x, phi)?.stable)
    }

    /// The smallest eigenvalue and mode of the **exact** Hessian of the static potential at
    /// positions `x` and edge angles `phi` (no `hessian_shift`; the rigid motions the boundary
    /// leaves free, and that no obstacle or load resists, left out): see [`Stability`]. Its
    /// sign is the stability of an equilibrium; along a load path it crosses zero at a
    /// critical load, where the mode is the buckling mode. Costs one Hessian assembly, one to
    /// a few factorisations and up to 60 triangular solves.
    pub fn stability(
        &mut self,
        system: &mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<Stability, SolverError> {
        let u = system.gather(x, phi);
        let mut obj = self
            .objective(system, x, phi)
            .with_hessian(HessianMode::Exact);
        self.cache
            .fit(&obj, &self.newton)
            .and_then(|ws| ws.stability(&mut obj, &u))
    }
}

impl Static {
    /// The cached Newton workspace (symbolic factorisation, ordering, fill statistics) of the
    /// last solve; `None` before the first. It is rebuilt when the system's unknowns or
    /// [`NewtonSettings::ordering`] / [`NewtonSettings::parallel`] change.
    pub fn workspace(&self) -> Option<&NewtonWorkspace> {
        self.cache.get()
    }
}

impl Integrator for Static {
    fn set_progress(&mut self, hook: Option<crate::ProgressHook>) {
        self.cache.set_progress(hook);
    }

    fn set_cancel(&mut self, flag: Option<crate::CancelFlag>) {
        self.cache.set_cancel(flag);
    }

    fn carried_state(&self) -> f64 {
        self.cache.regularization_memory()
    }

    fn restore_carried_state(&mut self, mu: f64) {
        self.cache.set_regularization_memory(mu);
    }

    fn kept_factor(&self) -> Option<crate::KeptFactor> {
        self.cache.kept_factor()
    }

    fn restore_kept_factor(&mut self, kept: Option<crate::KeptFactor>) {
        self.cache.set_kept_factor(kept);
    }

    fn kind(&self) -> StepKind {
        StepKind::Static
    }

    fn step(
        &mut self,
        system: &mut ShellSystem,
        state: &mut State,
    ) -> Result<StepReport, SolverError> {
        check_state(system, state)?;
        let mut x = state.x.clone();
        let mut phi = state.phi.clone();
        system.boundary.apply_prescribed(&mut x, state.t)?;
        // The solves leave their last iterate in `x`, `phi`, failed or not.
        let (start_x, start_phi) = (x.clone(), phi.clone());
        let (one_shot, hessian) = self.one_shot(system, &mut x, &mut phi, &start_x, &start_phi);
        let mut continuation_stages = 0;
        let mut continuation_checked = false;
        // The static potential of the result is computed once, where it is settled: the report
        // carries it and the wandering check compares by it.
        let ((report, stability), potential) = match one_shot {
            Ok(r) => {
                let wandered = self.continuation && r.wandered();
                let mut kept = self.settle(system, &mut x, &mut phi, r)?;
                let mut potential = self.potential(system, &x, &phi);
                if wandered && !self.at_zero_potential(system, potential, &start_x, &start_phi) {
                    continuation_checked = true;
                    let (mut cx, mut cphi) = (start_x, start_phi);
                    if let Some(stages) = self.check_by_continuation(
                        system,
                        (&mut x, &mut phi),
                        (&mut cx, &mut cphi),
                        (&mut kept, &mut potential),
                    ) {
                        continuation_stages = stages;
                    }
                    // The angles the system starts its next evaluation from are those of the
                    // result kept, not of the continuation's last solve.
                    system.keep_angles(&phi);
                }
                (kept, potential)
            }
            Err(e) if self.continuation && retryable(&e) => {
                x.copy_from_slice(&start_x);
                phi.copy_from_slice(&start_phi);
                // The first error says what the one-shot solve missed; the continuation's own
                // failure adds nothing a user can act on.
                let Some((stages, mut settled)) =
                    self.continue_and_settle(system, &mut x, &mut phi)
                else {
                    return Err(e);
                };
                continuation_stages = stages;
                // One count for the step: the failed one-shot solve's iterations too.
                settled.0.iterations += e.newton_iterations();
                (settled, self.potential(system, &x, &phi))
            }
            Err(e) => return Err(e),
        };
        let energies = system.energy_at(&x, &phi)?;
        state.x = x;
        state.phi = phi;
        state.v.iter_mut().for_each(|v| *v = Vector3::zeros());
        Ok(StepReport {
            t: state.t,
            dt: 0.0,
            newton: Some(report),
            halvings: 0,
            hessian,
            energies,
            stable: stability.as_ref().map(|s| s.stable),
            stability,
            contact: system.contact_stats(&state.x),
            continuation_stages,
            continuation_checked,
            potential,
        })
    }
}

impl Static {
    /// The one-shot solve from `x`, `phi` (the start `start_x`, `start_phi`), retried with the
    /// fallback Hessian when it fails; returns the own-Hessian mode of the last solve.
    fn one_shot(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
        start_x: &[Vector3<f64>],
        start_phi: &[f64],
    ) -> (Result<NewtonReport, SolverError>, HessianMode) {
        let e = match self.solve_with_angles(system, x, phi) {
            Ok(r) => return (Ok(r), self.newton.own_hessian),
            Err(e) => e,
        };
        let Some(mode) = fallback_mode(&self.newton).filter(|_| retryable(&e)) else {
            return (Err(e), self.newton.own_hessian);
        };
        let own = std::mem::replace(&mut self.newton.own_hessian, mode);
        // First from the best point found (line search never increased E), then, if that fails
        // too, from the start: the failed path may have led into a region that is hard for any
        // Hessian.
        let mut retry = Err(e);
        for from in [retry_start(&retry), None] {
            if retry.is_ok() {
                break;
            }
            x.copy_from_slice(start_x);
            phi.copy_from_slice(start_phi);
            if let Some(u) = from {
                system.scatter(&u, x, phi);
            }
            retry = self.solve_with_angles(system, x, phi);
        }
        self.newton.own_hessian = own;
        (retry, mode)
    }

    /// The wandering check: solves by continuation from the start `(cx, cphi)` and, when that
    /// equilibrium is better ([`better`]) than the one-shot `(x, phi)` with report and
    /// stability `kept` and static potential `kept_potential`, moves it into `(x, phi)`, `kept`
    /// and `kept_potential` and returns its sub-steps. Either way `kept`'s iteration count
    /// includes both solves.
    fn check_by_continuation(
        &mut self,
        system: &mut ShellSystem,
        (x, phi): (&mut Vec<Vector3<f64>>, &mut Vec<f64>),
        (cx, cphi): (&mut Vec<Vector3<f64>>, &mut Vec<f64>),
        (kept, kept_potential): (&mut (NewtonReport, Option<Stability>), &mut Option<f64>),
    ) -> Option<usize> {
        let (stages, mut checked) = self.continue_and_settle(system, cx, cphi)?;
        let checked_potential = self.potential(system, cx, cphi);
        // A potential that cannot be evaluated keeps the one-shot result.
        let is_better = match (checked_potential, *kept_potential) {
            (Some(pc), Some(pk)) => better(
                (checked.1.as_ref().map(|s| s.stable), pc),
                (kept.1.as_ref().map(|s| s.stable), pk),
            ),
            _ => false,
        };
        if !is_better {
            kept.0.iterations += checked.0.iterations;
            return None;
        }
        std::mem::swap(x, cx);
        std::mem::swap(phi, cphi);
        checked.0.iterations += kept.0.iterations;
        *kept = checked;
        *kept_potential = checked_potential;
        Some(stages)
    }

    /// Rest-state continuation from the start `x`, `phi` ([`Static::continuation`]), then
    /// [`Static::settle`]; `None` when either fails (`x`, `phi` then hold no answer). Returns
    /// the continuation's sub-steps with the settled report and stability.
    fn continue_and_settle(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
    ) -> Option<(usize, (NewtonReport, Option<Stability>))> {
        let mut solve = |sys: &mut ShellSystem, x: &mut [Vector3<f64>], phi: &mut [f64]| {
            self.solve_with_angles(sys, x, phi)
        };
        let c = homotopy::solve_by_continuation(&mut solve, system, x, phi).ok()?;
        let settled = self.settle(system, x, phi, c.report).ok()?;
        Some((c.stages, settled))
    }

    /// The stability of the equilibrium `x`, `phi` that `report` solved for, after leaving
    /// saddles along their mode (at most [`MAX_UNSTABLE_RESTARTS`] times, each followed by a
    /// new solve whose report is appended). `None` stability where the factor does not fit in
    /// memory (the solve fell back to CG).
    fn settle(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
        mut report: NewtonReport,
    ) -> Result<(NewtonReport, Option<Stability>), SolverError> {
        let direct = self
            .cache
            .get()
            .is_none_or(|ws| ws.linear_solver() == crate::LinearSolver::Direct);
        let mut stability = if direct {
            Some(self.stability(system, x, phi)?)
        } else {
            None
        };
        // Saddles are not answers: an unstable equilibrium is left along its mode
        // and the solve goes on from there. Newton's own escapes test the Hessian with the
        // small shift that makes factorisations robust, which hides the slightly negative
        // eigenvalues of thin shells just past a critical load; the stability analysis does not.
        for _ in 0..MAX_UNSTABLE_RESTARTS {
            let Some(s) = stability.as_ref() else { break };
            if !self.newton.escape_saddles || s.stable || !s.min_eigenvalue.is_finite() {
                break;
            }
            let mut u = system.gather(x, phi);
            let moved = {
                let mut obj = self.objective(system, x, phi);
                descend_along(&mut obj, &mut u, &s.mode)?
            };
            if !moved {
                break;
            }
            system.scatter(&u, x, phi);
            let next = self.solve_with_angles(system, x, phi)?;
            report = report.then_escape(next);
            stability = Some(self.stability(system, x, phi)?);
        }
        Ok((report, stability))
    }

    /// Whether, without loads, an equilibrium of static potential `end` has at most 10⁻¹⁰ of
    /// the start's: the potential is then the elastic (and contact) energy, never negative, so
    /// no other equilibrium is lower (a crumpled sheet flattened to its rest shape) and the
    /// wandering check is skipped.
    fn at_zero_potential(
        &self,
        system: &mut ShellSystem,
        end: Option<f64>,
        start_x: &[Vector3<f64>],
        start_phi: &[f64],
    ) -> bool {
        if system.pressure() != 0.0 || system.external_forces().iter().any(|&f| f != 0.0) {
            return false;
        }
        match (end, self.potential(system, start_x, start_phi)) {
            (Some(end), Some(start)) => end <= 1e-10 * start,
            _ => false,
        }
    }

    /// The static potential `E − F_extᵀx − p·V` (J) at `x`, `phi`: what two equilibria of the
    /// same problem are compared by. `None` where it is not finite or cannot be evaluated (a
    /// start inside an obstacle).
    fn potential(&self, system: &mut ShellSystem, x: &[Vector3<f64>], phi: &[f64]) -> Option<f64> {
        let u = system.gather(x, phi);
        self.objective(system, x, phi)
            .value(&u)
            .ok()
            .filter(|v| v.is_finite())
    }
}

/// Whether equilibrium `a` (stable or not, or unknown; static potential in J) is a better
/// answer than `b`: a stable one beats an unstable one; otherwise the lower potential wins
/// (ties keep `b`).
pub(crate) fn better(a: (Option<bool>, f64), b: (Option<bool>, f64)) -> bool {
    match (a.0, b.0) {
        (Some(true), Some(false)) => true,
        (Some(false), Some(true)) => false,
        _ => a.1 < b.1,
    }
}

/// Unstable equilibria a static step leaves along their mode before it reports one as it is.
const MAX_UNSTABLE_RESTARTS: usize = 3;

/// Moves `u` along `±mode` (free unknowns, `‖mode‖∞ = 1`) to lower the objective: from a step
/// of 1e-6 of the length scale, doubled until either sign lowers f by more than its round-off,
/// then doubled along that sign while f keeps decreasing, within the length scale and the
/// objective's step limit. Returns whether `u` moved. At a saddle f falls quadratically along
/// the mode (for a symmetric one, on both sides alike) until the quartic terms take over.
pub(crate) fn descend_along<O: Objective + ?Sized>(
    obj: &mut O,
    u: &mut [f64],
    mode: &[f64],
) -> Result<bool, SolverError> {
    let length = obj.length_scale();
    let f0 = obj.value(u)?;
    // Evaluation round-off of f (as the Newton solver's `value_noise`, plus a margin: the
    // potential of a pressure load is large against the energy a buckle releases).
    let noise = 64.0 * f64::EPSILON * f0.abs().max(f64::MIN_POSITIVE);
    let mut trial = u.to_vec();
    let value = |t: f64, trial: &mut Vec<f64>, obj: &mut O| -> Result<f64, SolverError> {
        for ((y, &a), &d) in trial.iter_mut().zip(u.iter()).zip(mode) {
            *y = a + t * d;
        }
        let v = obj.value(trial)?;
        Ok(if v.is_finite() { v } else { f64::INFINITY })
    };
    let scaled: Vec<f64> = mode.iter().map(|d| d * length).collect();
    let limit_plus = length * obj.max_step(u, &scaled)?;
    let minus: Vec<f64> = scaled.iter().map(|d| -d).collect();
    let limit_minus = length * obj.max_step(u, &minus)?;
    let mut t = 1e-6 * length;
    let mut best: Option<(f64, f64)> = None;
    while best.is_none() && t <= limit_plus.min(limit_minus) {
        let (fp, fm) = (value(t, &mut trial, obj)?, value(-t, &mut trial, obj)?);
        if fp.min(fm) < f0 - noise {
            best = Some(if fp <= fm { (t, fp) } else { (-t, fm) });
        } else {
            t *= 2.0;
        }
    }
    let Some(first) = best else {
        return Ok(false);
    };
    let limit = if first.0 > 0.0 {
        limit_plus
    } else {
        limit_minus
    };
    let (t, _) = double_while_falling(
        |t| value(t, &mut trial, obj),
        first,
        limit,
        usize::MAX,
        |_| 0.0,
    )?;
    for (a, &d) in u.iter_mut().zip(mode) {
        *a += t * d;
    }
    Ok(true)
}

/// The checks shared by every static solve (equilibrium, path following): one edge angle per
/// edge, no damping term, a finite non-negative Hessian shift.
pub(crate) fn check_static_inputs(
    system: &ShellSystem,
    phi: &[f64],
    hessian_shift: f64,
) -> Result<(), SolverError> {
    if phi.len() != system.n_edge_angles() {
        return Err(SolverError::DimensionMismatch {
            what: "edge angles",
            expected: system.n_edge_angles(),
            found: phi.len(),
        });
    }
    if system.model.terms.damping {
        return Err(SolverError::InvalidSetting {
            name: "terms.damping",
            value: 1.0,
            requirement: "a static solve has no damping (build the system without it)",
        });
    }
    if !(hessian_shift.is_finite() && hessian_shift >= 0.0) {
        return Err(SolverError::InvalidSetting {
            name: "hessian_shift",
            value: hessian_shift,
            requirement: "must be non-negative and finite",
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::better;

    #[test]
    fn stable_beats_unstable_then_lower_potential_wins() {
        assert!(better((Some(true), 2.0), (Some(false), 1.0)));
        assert!(!better((Some(false), 1.0), (Some(true), 2.0)));
        assert!(better((Some(true), 1.0), (Some(true), 2.0)));
        assert!(!better((Some(true), 2.0), (Some(true), 1.0)));
        assert!(!better((Some(true), 1.0), (Some(true), 1.0)));
        assert!(better((None, 1.0), (Some(false), 2.0)));
        assert!(!better((None, 3.0), (Some(false), 2.0)));
    }
}
