//! Time integration over a [`Model`]: the [`Integrator`] trait and its [`StepReport`], one
//! integrator per file — [`Static`] (`statics.rs`), [`ImplicitEuler`] (`implicit.rs`),
//! [`ExplicitEuler`] (`explicit.rs`) — the Newton workspace they keep between solves
//! (`cache.rs`) and what they do after a failed solve (`retry.rs`).
//!
//! Module dependencies point one way: `model` → `cache`, `retry` → the integrators → this
//! module's trait.

mod adjoint;
mod cache;
mod explicit;
mod implicit;
mod model;
mod retry;
mod statics;

pub use cache::NewtonCache;
pub use explicit::ExplicitEuler;
pub use implicit::ImplicitEuler;
pub use model::{Model, ObjectiveOptions, State, StepObjective};
pub use retry::MAX_CONTINUATION_HALVINGS;
pub use statics::{Static, check_static_inputs};

use thinshell_energy::HessianMode;

use crate::{CancelFlag, KeptFactor, NewtonReport, ProgressHook, SolverError};

/// What one step did. `E` are the model's energy terms ([`Model::Energies`]), `C` its contact
/// statistics ([`Model::Contact`]).
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport<E, C> {
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
    pub energies: E,
    /// Static steps: whether the equilibrium is a minimum, i.e. the smallest eigenvalue of the
    /// exact, unshifted Hessian there (rigid motions the boundary leaves free left out) is
    /// positive; `Some(false)` is a saddle or maximum (unstable: a perturbation leaves it).
    /// `None` for dynamic steps, and where the Cholesky factor does not fit in memory.
    pub stable: Option<bool>,
    /// With contact: the contact term at the end of the step ([`Model::contact_stats`]).
    /// `None` without.
    pub contact: Option<C>,
    /// Static steps: that smallest eigenvalue and its mode ([`crate::Stability`]); `None` as
    /// for `stable`.
    pub stability: Option<crate::Stability>,
    /// Static steps: sub-steps of the continuation ([`Static::continuation`]) whose result the
    /// step returns: after the one-shot solve failed, or when the check of a wandering one-shot
    /// solve (`continuation_checked`) found a better equilibrium; 0 when the one-shot solve's
    /// result is returned, and for dynamic steps.
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

impl<E, C> StepReport<E, C> {
    /// Whether this static step's equilibrium is a better answer than `other`'s, of the same
    /// problem: a stable one beats an unstable one, otherwise the lower
    /// [`potential`](Self::potential) wins (ties, and reports without a potential, keep
    /// `other`). The rule [`Static`]'s wandering check keeps its result by.
    pub fn is_better_equilibrium_than(&self, other: &StepReport<E, C>) -> bool {
        match (self.potential, other.potential) {
            (Some(a), Some(b)) => statics::better((self.stable, a), (other.stable, b)),
            _ => false,
        }
    }
}

/// The Newton report inside a step's report, for the continuation walk's counts.
pub(crate) trait StepReportNewton {
    fn newton_mut(&mut self) -> Option<&mut NewtonReport>;
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

/// Where a step starts from: the problem (rest state, loads) and the time of the last
/// accepted step, when the caller changed the problem since. A static step that fails walks
/// from it to the model's current problem ([`Static::continuation`]); dynamic steps ignore it.
#[derive(Debug)]
pub struct Origin<P> {
    /// The problem of the last accepted step.
    pub problem: P,
    /// The time (s) at which it evaluated prescribed motion.
    pub t: f64,
}

/// What an integrator is besides its step ([`Integrator`]): its kind, the observers of its
/// solves, and the state it carries from one step to the next.
pub trait StepControl {
    /// What kind of step [`Integrator::step`] takes.
    fn kind(&self) -> StepKind;

    /// Whether the step is a static equilibrium solve (no time, no inertia).
    fn is_static(&self) -> bool {
        self.kind() == StepKind::Static
    }

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

    /// Restores what [`StepControl::carried_state`] returned.
    fn restore_carried_state(&mut self, _mu: f64) {}

    /// The other state carried from step to step that changes later results: the input of the
    /// Cholesky factor the next Newton solve may reuse
    /// ([`NewtonSettings::reuse_factor`](crate::NewtonSettings::reuse_factor),
    /// [`NewtonWorkspace::kept_factor`](crate::NewtonWorkspace::kept_factor)); `None` for
    /// integrators without one or when the next solve factorises afresh. A checkpoint saves
    /// it, so that a resumed run reuses the same factor as the run that wrote it.
    fn kept_factor(&self) -> Option<KeptFactor> {
        None
    }

    /// Restores what [`StepControl::kept_factor`] returned (before the next step; a factor
    /// whose size does not fit the next solve's Hessian pattern is an error of that step).
    fn restore_kept_factor(&mut self, _kept: Option<KeptFactor>) {}
}

/// Advances a [`State`] of a [`Model`] by one step.
pub trait Integrator<M: Model>: StepControl {
    /// One step; on error `state` is unchanged.
    fn step(
        &mut self,
        model: &mut M,
        state: &mut State,
    ) -> Result<StepReport<M::Energies, M::Contact>, SolverError> {
        self.step_from(model, state, None)
    }

    /// One step of a problem that changed since the last accepted step, which was `origin`'s
    /// (`None`: unchanged, as [`Integrator::step`]); on error `state` is unchanged.
    fn step_from(
        &mut self,
        model: &mut M,
        state: &mut State,
        origin: Option<&Origin<M::Problem>>,
    ) -> Result<StepReport<M::Energies, M::Contact>, SolverError>;
}

/// The forwarding every integrator with a Newton solve does to its [`NewtonCache`].
macro_rules! forward_to_cache {
    () => {
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
    };
}
pub(crate) use forward_to_cache;
