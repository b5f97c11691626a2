//! Implicit (backward) Euler: [`ImplicitEuler`] minimises the incremental potential
//! `Φ(x) = 1/(2Δt²)(x − x̃)ᵀΛ(x − x̃) + E(x) + E_damp(x; xⁿ) − F_extᵀx − p·V(x)`,
//! `x̃ = xⁿ + Δt vⁿ` (model.md §3), with Newton; on failure optionally a retry with a fallback
//! Hessian (e.g. Gauss–Newton), then halving of Δt.
//!
//! The fallback Hessian exists because the exact Hessian of a badly crumpled or strongly
//! compressed shell is far from positive definite: the diagonal shift that regularisation needs
//! then turns Newton into a slow gradient method. The Gauss–Newton Hessian is positive
//! semi-definite by construction and keeps the curvature information of the forms.

use super::cache::NewtonCache;
use super::model::{Model, ObjectiveOptions, State, StepObjective};
use super::retry::{NewtonIntegrator, check_dt, check_state, retryable, with_fallback_hessian};
use super::{Integrator, Origin, StepControl, StepKind, StepReport, forward_to_cache};
use crate::{NewtonReport, NewtonSettings, NewtonWorkspace, Objective, SolverError, newton_solve};

/// Implicit (backward) Euler by minimisation of the incremental potential.
#[derive(Debug)]
pub struct ImplicitEuler {
    /// Time step Δt (s).
    pub dt: f64,
    /// Newton parameters.
    pub newton: NewtonSettings,
    /// `Some(F)`: also stop when `‖∇‖∞ ≤ gradient_tolerance · F` (N). `None` (default):
    /// converge on the Newton correction or at round-off only (see
    /// [`Static::force_scale`](super::Static::force_scale)).
    pub force_scale: Option<f64>,
    /// Times Δt may be halved when Newton fails (0: no adaptivity).
    pub max_halvings: usize,
    /// The cached Newton workspace ([`Default`]: empty).
    pub cache: NewtonCache,
}

/// Default [`NewtonSettings::relative_step_tolerance`] of implicit steps: a step's Newton
/// solve has converged once its correction is 10⁻³ of how far the step moved from its start
/// (the move Δt²·a is of the order of the step's own time discretisation error). What it costs
/// and saves against a solve converged to round-off: docs/robustness.md, "Indefinite Hessians
/// near critical points" (the falling flag of `tests/implicit_tolerance.rs`).
const IMPLICIT_RELATIVE_STEP_TOLERANCE: f64 = 1e-3;

impl ImplicitEuler {
    /// Fixed step `dt` (s) with default Newton settings, except that saddles of the
    /// incremental potential are kept ([`NewtonSettings::escape_saddles`] = `false`): a shell in
    /// a symmetric state (a planar sheet under in-plane compression) stays in it, as its
    /// dynamics do without a perturbation; a static solve leaves such a saddle; and that the
    /// Cholesky factor is reused across iterations and steps
    /// ([`NewtonSettings::reuse_factor`] = `true`): successive steps' Hessians differ little,
    /// so CG preconditioned with an earlier factor converges in a few iterations where a
    /// factorisation costs tens to hundreds of them (measured in docs/performance.md, "Factor
    /// reuse").
    pub fn new(dt: f64) -> ImplicitEuler {
        ImplicitEuler {
            dt,
            newton: NewtonSettings {
                escape_saddles: false,
                relative_step_tolerance: IMPLICIT_RELATIVE_STEP_TOLERANCE,
                reuse_factor: true,
                ..NewtonSettings::default()
            },
            force_scale: None,
            max_halvings: 0,
            cache: NewtonCache::default(),
        }
    }

    /// One solve of the step of length `dt` from `state`, with the own Hessian of `newton`,
    /// from `start` (free unknowns) when given, else from the inertial prediction.
    fn try_step<M: Model>(
        &mut self,
        model: &mut M,
        state: &State,
        dt: f64,
        start: Option<&[f64]>,
    ) -> Result<(State, NewtonReport, M::Energies), SolverError> {
        let t1 = state.t + dt;
        let mut x1 = state.x.clone();
        model.apply_prescribed(&mut x1, t1)?;
        let mut phi1 = state.phi.clone();
        let checks_collisions = model.checks_collisions();
        let un = model.gather(&state.x, &state.phi);
        let options = ObjectiveOptions {
            hessian: self.newton.own_hessian,
            hessian_shift: 0.0,
            force_scale: self.force_scale,
        };
        let mut obj = model.incremental_objective(state, &x1, dt, options)?;
        let mut u = obj.prediction().map(<[f64]>::to_vec).unwrap_or_default();
        if let Some(s) = start.filter(|s| s.len() == u.len()) {
            // A retry: its start is a former iterate, reached by collision-limited steps.
            u.copy_from_slice(s);
        } else {
            u = collision_free_start(&mut obj, checks_collisions, un, u)?;
        }
        let ws = self.cache.fit(&obj, &self.newton)?;
        let report = newton_solve(&mut obj, &mut u, &self.newton, ws)?;
        let energies = obj.last_energies();
        drop(obj);
        model.scatter(&u, &mut x1, &mut phi1);
        let v1 = x1.iter().zip(&state.x).map(|(a, b)| (a - b) / dt).collect();
        Ok((
            State {
                x: x1,
                v: v1,
                phi: phi1,
                t: t1,
            },
            report,
            energies,
        ))
    }
}

/// Where Newton starts a step: the inertial prediction x̃ (`prediction`, free dofs), as far as
/// the straight path from xⁿ to it stays free of collisions, and at xⁿ when that point is not a
/// valid configuration (e.g. an inverted face).
///
/// Without contact the step limit is 1 and this is x̃ itself. With contact x̃ can lie on the far
/// side of a face: every vertex–face and edge–edge distance there is positive, so the barrier is
/// finite, yet an edge passes through a face, and Newton would converge from there to a state
/// that crosses. The continuous collision check of the path xⁿ → x̃ (the same as every Newton
/// step's) stops the start short of the first crossing, so every iterate of the step is reached
/// from the collision-free xⁿ by collision-checked motion.
fn collision_free_start<O: Objective>(
    obj: &mut O,
    checks_collisions: bool,
    un: Vec<f64>,
    prediction: Vec<f64>,
) -> Result<Vec<f64>, SolverError> {
    let start = if !checks_collisions {
        prediction
    } else {
        if prediction.len() != un.len() {
            return Ok(un);
        }
        let du: Vec<f64> = prediction.iter().zip(&un).map(|(p, a)| p - a).collect();
        let alpha = obj.max_step(&un, &du)?;
        if alpha >= 1.0 {
            prediction
        } else {
            un.iter().zip(&du).map(|(a, d)| a + alpha * d).collect()
        }
    };
    if obj.value(&start)?.is_finite() {
        Ok(start)
    } else {
        Ok(un)
    }
}

impl ImplicitEuler {
    /// The cached Newton workspace (symbolic factorisation, ordering, fill statistics) of the
    /// last solve; `None` before the first. It is rebuilt when the system's unknowns or
    /// [`NewtonSettings::ordering`] / [`NewtonSettings::parallel`] change.
    pub fn workspace(&self) -> Option<&NewtonWorkspace> {
        self.cache.get()
    }
}

impl NewtonIntegrator for ImplicitEuler {
    fn newton_settings(&mut self) -> &mut NewtonSettings {
        &mut self.newton
    }
}

impl StepControl for ImplicitEuler {
    forward_to_cache!();

    fn kind(&self) -> StepKind {
        StepKind::Implicit
    }
}

impl<M: Model> Integrator<M> for ImplicitEuler {
    fn step_from(
        &mut self,
        model: &mut M,
        state: &mut State,
        _origin: Option<&Origin<M::Problem>>,
    ) -> Result<StepReport<M::Energies, M::Contact>, SolverError> {
        check_dt(self.dt)?;
        check_state(model, state)?;
        let mut dt = self.dt;
        let mut halvings = 0;
        loop {
            let (result, hessian) =
                with_fallback_hessian(self, |this, start| this.try_step(model, state, dt, start));
            match result {
                Ok((next, report, energies)) => {
                    *state = next;
                    model.accept(&state.phi);
                    return Ok(StepReport {
                        t: state.t,
                        dt,
                        newton: Some(report),
                        halvings,
                        hessian,
                        energies,
                        stable: None,
                        contact: model.contact_stats(&state.x),
                        continuation_stages: 0,
                        continuation_checked: false,
                        potential: None,
                        stability: None,
                    });
                }
                Err(e) if halvings < self.max_halvings && retryable(&e) => {
                    halvings += 1;
                    dt *= 0.5;
                }
                Err(e) => return Err(e),
            }
        }
    }
}
