//! Static equilibrium: [`Static`] minimises `E(x) − F_extᵀx − p·V(x)` over the free dofs.
//!
//! Rigid motions (a null space when too few coordinates are held) are handled by a small shift
//! `κ·mean|H_dd|` of the Hessian diagonal only (the gradient is exact, so the equilibrium is
//! unchanged; the iterates simply do not drift along rigid modes), plus Newton's regularisation
//! when needed; optionally a retry with a fallback Hessian from the last good iterate (see
//! [`NewtonSettings::fallback_hessian`]).

use nalgebra::Vector3;
use thinshell_energy::HessianMode;

use super::cache::NewtonCache;
use super::model::{Model, ObjectiveOptions, State};
use super::retry::{
    Continued, NewtonIntegrator, check_state, continuation_walk, retryable, with_fallback_hessian,
};
use super::{Integrator, Origin, StepControl, StepKind, StepReport, forward_to_cache};
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
    /// to the model's force scale.
    pub force_scale: Option<f64>,
    /// Whether a step uses continuation from its start (default `true`): from the problem
    /// whose equilibrium the start is ([`Model::problem_at`]: a shell's own forms at the start,
    /// no loads) to the model's, in sub-steps ([`continuation_walk`]). A far start (a flat sheet
    /// grown into a cone) otherwise ends at the iteration limit or in the basin of a
    /// higher-energy minimum. It solves the step when the one-shot solve fails, and checks a
    /// one-shot solve that succeeded only after [`WANDERING_STEPS`](crate::WANDERING_STEPS) or
    /// more steps without the exact Hessian: the better equilibrium is kept
    /// ([`StepReport::continuation_checked`]). Off for callers that continue from the previous
    /// step's problem instead ([`Integrator::step_from`] with an [`Origin`]: a scene's run loop).
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
    /// extra unknowns (edge angles) they start at 0; the solved ones are kept on the model
    /// ([`Model::accept`]). [`Static::solve_with_angles`] also takes and returns them.
    pub fn solve<M: Model>(
        &mut self,
        model: &mut M,
        x: &mut [Vector3<f64>],
    ) -> Result<NewtonReport, SolverError> {
        let mut phi = vec![0.0; model.n_extra()];
        self.solve_with_angles(model, x, &mut phi)
    }

    /// Solves for the equilibrium starting from positions `x` and extra unknowns `phi` (a
    /// shell's edge angles, rad, one per edge; empty without), both overwritten.
    pub fn solve_with_angles<M: Model>(
        &mut self,
        model: &mut M,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
    ) -> Result<NewtonReport, SolverError> {
        check_static_inputs(model, phi, self.hessian_shift)?;
        let mut u = model.gather(x, phi);
        let result = {
            let mut obj = model.static_objective(x, phi, self.options(self.newton.own_hessian));
            let ws = self.cache.fit(&obj, &self.newton)?;
            newton_solve(&mut obj, &mut u, &self.newton, ws)
        };
        model.scatter(&u, x, phi);
        if result.is_ok() {
            model.accept(phi);
        }
        result
    }

    /// The options of this integrator's objectives, with the Hessian in `hessian`.
    fn options(&self, hessian: HessianMode) -> ObjectiveOptions {
        ObjectiveOptions {
            hessian,
            hessian_shift: self.hessian_shift,
            force_scale: self.force_scale,
        }
    }

    /// Whether positions `x` and extra unknowns `phi` (empty without) are a stable equilibrium
    /// candidate: the smallest eigenvalue of the **exact** Hessian of the static potential
    /// there is positive ([`Static::stability`]).
    pub fn is_stable<M: Model>(
        &mut self,
        model: &mut M,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<bool, SolverError> {
        Ok(self.stability(model, x, phi)?.stable)
    }

    /// The smallest eigenvalue and mode of the **exact** Hessian of the static potential at
    /// positions `x` and extra unknowns `phi` (no `hessian_shift`; the rigid motions the
    /// boundary leaves free, and that no obstacle or load resists, left out): see
    /// [`Stability`]. Its sign is the stability of an equilibrium; along a load path it crosses
    /// zero at a critical load, where the mode is the buckling mode. Costs one Hessian
    /// assembly, one to a few factorisations and up to 60 triangular solves.
    pub fn stability<M: Model>(
        &mut self,
        model: &mut M,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<Stability, SolverError> {
        let u = model.gather(x, phi);
        let mut obj = model.static_objective(x, phi, self.options(HessianMode::Exact));
        self.cache
            .fit(&obj, &self.newton)
            .and_then(|ws| ws.stability(&mut obj, &u))
    }

    /// The cached Newton workspace (symbolic factorisation, ordering, fill statistics) of the
    /// last solve; `None` before the first. It is rebuilt when the model's unknowns or
    /// [`NewtonSettings::ordering`] / [`NewtonSettings::parallel`] change.
    pub fn workspace(&self) -> Option<&NewtonWorkspace> {
        self.cache.get()
    }
}

impl NewtonIntegrator for Static {
    fn newton_settings(&mut self) -> &mut NewtonSettings {
        &mut self.newton
    }
}

impl StepControl for Static {
    forward_to_cache!();

    fn kind(&self) -> StepKind {
        StepKind::Static
    }
}

impl<M: Model> Integrator<M> for Static {
    fn step_from(
        &mut self,
        model: &mut M,
        state: &mut State,
        origin: Option<&Origin<M::Problem>>,
    ) -> Result<StepReport<M::Energies, M::Contact>, SolverError> {
        check_state(model, state)?;
        let first = match self.step_at(model, state, state.t) {
            Ok(r) => return Ok(r),
            Err(e) => e,
        };
        // A problem changed since the last step (rest forms, loads) is walked to from it.
        let Some(origin) = origin.filter(|_| retryable(&first)) else {
            return Err(first);
        };
        let target = model.problem();
        let t = state.t;
        let walked = continuation_walk(state, |s, trial: &mut State| {
            model.set_problem_between(&origin.problem, &target, s)?;
            let time = origin.t + s * (t - origin.t);
            self.step_at(model, trial, time)
        });
        model.restore_problem(target)?;
        match walked {
            Ok(Continued { mut report, .. }) => {
                state.t = t;
                report.t = t;
                Ok(report)
            }
            // The first error says what the step missed; the walk's adds nothing to act on.
            Err(_) => Err(first),
        }
    }
}

impl Static {
    /// The static step at time `t` (s; prescribed motion) from `state`, written into `state`
    /// on success (velocities 0): the one-shot solve with its fallback Hessian, then the
    /// rest-state continuation from the start ([`Static::continuation`]) when it failed or
    /// wandered, then [`Static::settle`].
    fn step_at<M: Model>(
        &mut self,
        model: &mut M,
        state: &mut State,
        t: f64,
    ) -> Result<StepReport<M::Energies, M::Contact>, SolverError> {
        let mut x = state.x.clone();
        let mut phi = state.phi.clone();
        model.apply_prescribed(&mut x, t)?;
        // The solves leave their last iterate in `x`, `phi`, failed or not.
        let (start_x, start_phi) = (x.clone(), phi.clone());
        let (one_shot, hessian) = with_fallback_hessian(self, |this, from| {
            x.copy_from_slice(&start_x);
            phi.copy_from_slice(&start_phi);
            if let Some(u) = from {
                model.scatter(u, &mut x, &mut phi);
            }
            this.solve_with_angles(model, &mut x, &mut phi)
        });
        let mut continuation_stages = 0;
        let mut continuation_checked = false;
        // The static potential of the result is computed once, where it is settled: the report
        // carries it and the wandering check compares by it.
        let ((report, stability), potential) = match one_shot {
            Ok(r) => {
                let wandered = self.continuation && r.wandered();
                let mut kept = self.settle(model, &mut x, &mut phi, r)?;
                let mut potential = self.potential(model, &x, &phi);
                if wandered && !self.at_zero_potential(model, potential, &start_x, &start_phi) {
                    continuation_checked = true;
                    let (mut cx, mut cphi) = (start_x, start_phi);
                    if let Some(stages) = self.check_by_continuation(
                        model,
                        (&mut x, &mut phi),
                        (&mut cx, &mut cphi),
                        (&mut kept, &mut potential),
                    ) {
                        continuation_stages = stages;
                    }
                    // The unknowns the model starts its next evaluation from are those of the
                    // result kept, not of the continuation's last solve.
                    model.accept(&phi);
                }
                (kept, potential)
            }
            Err(e) if self.continuation && retryable(&e) => {
                x.copy_from_slice(&start_x);
                phi.copy_from_slice(&start_phi);
                // The first error says what the one-shot solve missed; the continuation's own
                // failure adds nothing a user can act on.
                let Some((stages, mut settled)) = self.continue_and_settle(model, &mut x, &mut phi)
                else {
                    return Err(e);
                };
                continuation_stages = stages;
                // One count for the step: the failed one-shot solve's iterations too.
                settled.0.iterations += e.newton_iterations();
                (settled, self.potential(model, &x, &phi))
            }
            Err(e) => return Err(e),
        };
        let energies = model.energies(&x, &phi)?;
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
            contact: model.contact_stats(&state.x),
            continuation_stages,
            continuation_checked,
            potential,
        })
    }

    /// The wandering check: solves by continuation from the start `(cx, cphi)` and, when that
    /// equilibrium is better ([`better`]) than the one-shot `(x, phi)` with report and
    /// stability `kept` and static potential `kept_potential`, moves it into `(x, phi)`, `kept`
    /// and `kept_potential` and returns its sub-steps. Either way `kept`'s iteration count
    /// includes both solves.
    fn check_by_continuation<M: Model>(
        &mut self,
        model: &mut M,
        (x, phi): (&mut Vec<Vector3<f64>>, &mut Vec<f64>),
        (cx, cphi): (&mut Vec<Vector3<f64>>, &mut Vec<f64>),
        (kept, kept_potential): (&mut (NewtonReport, Option<Stability>), &mut Option<f64>),
    ) -> Option<usize> {
        let (stages, mut checked) = self.continue_and_settle(model, cx, cphi)?;
        let checked_potential = self.potential(model, cx, cphi);
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

    /// Continuation from the start `x`, `phi` ([`Static::continuation`]): from the problem
    /// whose equilibrium the start is ([`Model::problem_at`]: its own rest forms, no loads) to
    /// the model's, by [`continuation_walk`]; then [`Static::settle`]. `None` when either fails
    /// (`x`, `phi` then hold no answer). Returns the walk's sub-steps with the settled report
    /// and stability.
    ///
    /// A start far from equilibrium (a flat sheet whose rest metric is that of a cone, a strip
    /// whose rest curvature rolls it) can lead Newton into the basin of another, higher-energy
    /// minimum, or keep it among strongly indefinite Hessians until the iteration limit. The
    /// start is, however, the equilibrium of that nearby problem; the walk is the physical
    /// process (growth or loading applied gradually) that the one-shot solve skipped.
    fn continue_and_settle<M: Model>(
        &mut self,
        model: &mut M,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
    ) -> Option<(usize, (NewtonReport, Option<Stability>))> {
        let origin = model.problem_at(x, phi).ok()?;
        let target = model.problem();
        let mut walked = (x.to_vec(), phi.to_vec());
        let result = continuation_walk(&mut walked, |s, (wx, wphi): &mut (Vec<_>, Vec<_>)| {
            model.set_problem_between(&origin, &target, s)?;
            self.solve_with_angles(model, wx, wphi)
        });
        model.restore_problem(target).ok()?;
        let c = result.ok()?;
        x.copy_from_slice(&walked.0);
        phi.copy_from_slice(&walked.1);
        let settled = self.settle(model, x, phi, c.report).ok()?;
        Some((c.stages, settled))
    }

    /// The stability of the equilibrium `x`, `phi` that `report` solved for, after leaving
    /// saddles along their mode (at most [`MAX_UNSTABLE_RESTARTS`] times, each followed by a
    /// new solve whose report is appended). `None` stability where the factor does not fit in
    /// memory (the solve fell back to CG).
    fn settle<M: Model>(
        &mut self,
        model: &mut M,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
        mut report: NewtonReport,
    ) -> Result<(NewtonReport, Option<Stability>), SolverError> {
        let direct = self
            .cache
            .get()
            .is_none_or(|ws| ws.linear_solver() == crate::LinearSolver::Direct);
        let mut stability = if direct {
            Some(self.stability(model, x, phi)?)
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
            let mut u = model.gather(x, phi);
            let moved = {
                let mut obj = model.static_objective(x, phi, self.options(self.newton.own_hessian));
                descend_along(&mut obj, &mut u, &s.mode)?
            };
            if !moved {
                break;
            }
            model.scatter(&u, x, phi);
            let next = self.solve_with_angles(model, x, phi)?;
            report = report.then_escape(next);
            stability = Some(self.stability(model, x, phi)?);
        }
        Ok((report, stability))
    }

    /// Whether, without loads, an equilibrium of static potential `end` has at most 10⁻¹⁰ of
    /// the start's: the potential is then the elastic (and contact) energy, never negative, so
    /// no other equilibrium is lower (a crumpled sheet flattened to its rest shape) and the
    /// wandering check is skipped.
    fn at_zero_potential<M: Model>(
        &self,
        model: &mut M,
        end: Option<f64>,
        start_x: &[Vector3<f64>],
        start_phi: &[f64],
    ) -> bool {
        if model.is_loaded() {
            return false;
        }
        match (end, self.potential(model, start_x, start_phi)) {
            (Some(end), Some(start)) => end <= 1e-10 * start,
            _ => false,
        }
    }

    /// The static potential `E − F_extᵀx − p·V` (J) at `x`, `phi`: what two equilibria of the
    /// same problem are compared by. `None` where it is not finite or cannot be evaluated (a
    /// start inside an obstacle).
    fn potential<M: Model>(&self, model: &mut M, x: &[Vector3<f64>], phi: &[f64]) -> Option<f64> {
        let u = model.gather(x, phi);
        model
            .static_objective(x, phi, self.options(self.newton.own_hessian))
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

/// The checks shared by every static solve (equilibrium, path following): one extra unknown
/// per entry the model has, what the model needs ([`Model::check_static`]), a finite
/// non-negative Hessian shift.
pub fn check_static_inputs<M: Model + ?Sized>(
    model: &M,
    phi: &[f64],
    hessian_shift: f64,
) -> Result<(), SolverError> {
    if phi.len() != model.n_extra() {
        return Err(SolverError::DimensionMismatch {
            what: "edge angles",
            expected: model.n_extra(),
            found: phi.len(),
        });
    }
    model.check_static()?;
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
