//! The `[integrator]` section: its spec (kind, time step, steps, load ramp, Newton settings),
//! its validation and the solver's integrator it builds (`docs/scenes.md`).

use serde::{Deserialize, Serialize};
use thinshell_energy::HessianMode;
use thinshell_solver::{
    ExplicitEuler, HessianPolicy, ImplicitEuler, IterativeFallback, NewtonSettings, SolverError,
    Static,
};
use thinshell_system::ShellIntegrator;
use thinshell_system::ShellSystem;

use super::effects::Effect;
use super::problem::{Check, absent, positive, problem};

/// Integrator kind.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorKind {
    /// Implicit Euler by Newton on the incremental potential.
    Implicit,
    /// Symplectic Euler.
    Explicit,
    /// Static equilibrium (quasi-static: one solve per step).
    Static,
}

/// How a static scene's loads grow over its steps.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum LoadRamp {
    /// Load factor λ_k = k/N at step k of N: step k solves for the equilibrium under k/N of
    /// every load, starting from the equilibrium of step k − 1.
    Linear,
    /// Full loads from the first step (λ = 1): the steps are a growth pseudo-time.
    None,
}

impl LoadRamp {
    /// The scene key's spelling.
    pub fn key(self) -> &'static str {
        match self {
            LoadRamp::Linear => "linear",
            LoadRamp::None => "none",
        }
    }
}

/// Which Hessian Newton uses.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum HessianSpec {
    /// Exact second derivatives where they are positive definite, Gauss–Newton elsewhere
    /// (`thinshell_solver::HessianPolicy::Adaptive`).
    #[default]
    Adaptive,
    /// The adaptive policy without its indefinite-Hessian handling: Gauss–Newton wherever the
    /// exact Hessian is indefinite, no trust-region steps, no saddle escape
    /// (`thinshell_solver::HessianPolicy::AdaptivePsd`; for comparisons, docs/robustness.md
    /// "Indefinite Hessians near critical points").
    AdaptivePsd,
    /// Exact second derivatives throughout (regularised when not positive definite).
    Exact,
    /// Gauss–Newton (positive semidefinite).
    GaussNewton,
    /// Exact, projected to PSD per face.
    Projected,
}

/// Time integration settings.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `implicit`, `explicit` or `static`.
    pub kind: IntegratorKind,
    /// Time step, s (required for implicit/explicit; static: pseudo-time step for growth, default 1).
    #[serde(default)]
    pub dt: Option<f64>,
    /// Number of steps (exactly one of `steps` and `end_time`; static default 1).
    #[serde(default)]
    pub steps: Option<usize>,
    /// End time, s.
    #[serde(default)]
    pub end_time: Option<f64>,
    /// Halve Δt on a failed step and grow it back after successes (default false).
    #[serde(default)]
    pub adaptive_dt: bool,
    /// Static solves only: how the loads (gravity, pressure, point loads, prescribed
    /// displacement) grow over the steps. Default: `linear` without growth, `none` with growth
    /// (see [`LoadRamp`] and `docs/scenes.md`).
    #[serde(default)]
    pub load_ramp: Option<LoadRamp>,
    /// Newton settings (implicit, static).
    #[serde(default)]
    pub newton: NewtonSpec,
}

/// Newton settings; missing values take the solver's defaults.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct NewtonSpec {
    /// Also stop when ‖∇Φ‖∞ ≤ tolerance × the system's force scale (opt-in gradient test).
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Stop when the Newton correction is smaller than this × the shell's size.
    #[serde(default)]
    pub step_tolerance: Option<f64>,
    /// Iteration limit per solve.
    #[serde(default)]
    pub max_iterations: Option<usize>,
    /// Backtracking Armijo line search (default true).
    #[serde(default)]
    pub line_search: Option<bool>,
    /// Watchdog window of the line search: iterations a non-monotone full step has to recover
    /// (default 4; 0: monotone line search).
    #[serde(default)]
    pub watchdog: Option<usize>,
    /// Leave a converged saddle along its negative curvature and go on to a minimum (default
    /// true for static solves, false for implicit steps); false keeps unstable equilibria.
    #[serde(default)]
    pub escape_saddles: Option<bool>,
    /// Add μI after a failed Cholesky (default true).
    #[serde(default)]
    pub regularization: Option<bool>,
    /// `adaptive` (default), `adaptive_psd`, `exact`, `gauss_newton`, `projected`.
    #[serde(default)]
    pub hessian: HessianSpec,
    /// Reuse the last Cholesky factor as the preconditioner of CG while it converges quickly
    /// (`thinshell_solver::NewtonSettings::reuse_factor`).
    #[serde(default)]
    pub reuse_factor: Option<bool>,
    /// Linear solver when the Cholesky factor does not fit in memory: `ic0` (default),
    /// `jacobi`, `off` (refuse).
    #[serde(default)]
    pub fallback: Option<FallbackSpec>,
    /// Solve by preconditioned CG even when the Cholesky factor fits (default false).
    #[serde(default)]
    pub force_iterative: Option<bool>,
}

/// The iterative fallback (`thinshell_solver::IterativeFallback`).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FallbackSpec {
    /// CG preconditioned by incomplete Cholesky IC(0).
    Ic0,
    /// CG preconditioned by the diagonal.
    Jacobi,
    /// No fallback: a factor over the memory budget is refused.
    Off,
}

/// Most steps a scene may ask for (directly or through `end_time`).
const MAX_STEPS: usize = 1_000_000_000;

/// Checks `[integrator]`: a dynamic integrator with `inertia`, a usable Δt and exactly one of
/// `steps` and `end_time`; a static one without `inertia`, `damping` or `end_time`; Newton
/// settings in range and none for explicit Euler. (`load_ramp` is checked with the loads, by
/// the whole file.)
pub fn validate(i: &IntegratorSpec, on: &dyn Fn(Effect) -> bool) -> Check {
    let dynamic = matches!(i.kind, IntegratorKind::Implicit | IntegratorKind::Explicit);
    if dynamic {
        if !on(Effect::Inertia) {
            return Err(problem(
                "effects",
                "a dynamic integrator (implicit/explicit) needs effect `inertia`",
            ));
        }
        let dt =
            i.dt.ok_or_else(|| problem("integrator.dt", "is required by dynamic integrators"))?;
        positive("integrator.dt", dt)?;
        // The inertia term divides by Δt²: a Δt whose square underflows makes every step inf.
        if !(1.0 / (dt * dt)).is_finite() {
            return Err(problem(
                "integrator.dt",
                format!("is too small to compute with (1/dt² overflows), got {dt:e}"),
            ));
        }
        match (i.steps, i.end_time) {
            (Some(_), Some(_)) | (None, None) => {
                return Err(problem(
                    "integrator",
                    "give exactly one of `steps` and `end_time`",
                ));
            }
            (Some(0), None) => return Err(problem("integrator.steps", "must be ≥ 1")),
            (None, Some(t)) => {
                positive("integrator.end_time", t)?;
                if t / dt > MAX_STEPS as f64 {
                    return Err(problem(
                        "integrator.end_time",
                        format!("needs {:.3e} steps of dt = {dt}: more than 1e9", t / dt),
                    ));
                }
            }
            _ => {}
        }
    } else {
        for e in [Effect::Inertia, Effect::Damping] {
            if on(e) {
                return Err(problem(
                    "effects",
                    format!("effect `{}` has no meaning in a static solve", e.key()),
                ));
            }
        }
        if let Some(dt) = i.dt {
            positive("integrator.dt", dt)?;
        }
        if i.steps == Some(0) {
            return Err(problem("integrator.steps", "must be ≥ 1"));
        }
        absent(
            "integrator.end_time",
            &i.end_time,
            "to a static solve (use steps)",
        )?;
    }
    // The same bound as for `end_time`: a run of more steps would never finish.
    if let Some(k) = i.steps.filter(|&k| k > MAX_STEPS) {
        return Err(problem(
            "integrator.steps",
            format!("must be ≤ 1e9, got {k}"),
        ));
    }
    let n = &i.newton;
    if i.kind == IntegratorKind::Explicit && *n != NewtonSpec::default() {
        return Err(problem(
            "integrator.newton",
            "does not apply to the explicit integrator",
        ));
    }
    if let Some(t) = n.tolerance {
        positive("integrator.newton.tolerance", t)?;
    }
    if let Some(t) = n.step_tolerance {
        positive("integrator.newton.step_tolerance", t)?;
    }
    if n.max_iterations == Some(0) {
        return Err(problem("integrator.newton.max_iterations", "must be ≥ 1"));
    }
    Ok(())
}

/// How a run advances: the step Δt (s; static: pseudo-time), the number of steps and the
/// static load ramp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    /// Time step, s (static default 1).
    pub dt: f64,
    /// Steps (`steps`, or `end_time / dt` rounded up).
    pub steps: usize,
    /// `LoadRamp::None` for dynamic integrators.
    pub load_ramp: LoadRamp,
}

/// The schedule of a validated `[integrator]`; `growth_on`: the scene has effect `growth`.
pub fn schedule(i: &IntegratorSpec, growth_on: bool) -> Schedule {
    let dt = i.dt.unwrap_or(1.0);
    let steps = match (i.steps, i.end_time) {
        (Some(k), _) => k,
        (None, Some(t)) => (t / dt).ceil().max(1.0) as usize,
        (None, None) => 1,
    };
    // A static scene without growth has no other use for several steps than a load path;
    // with growth the steps are the growth's pseudo-time, and every intermediate state must
    // feel the full loads (docs/scenes.md).
    let load_ramp = match (i.kind == IntegratorKind::Static, i.load_ramp) {
        (false, _) => LoadRamp::None,
        (true, Some(r)) => r,
        (true, None) if growth_on => LoadRamp::None,
        (true, None) => LoadRamp::Linear,
    };
    Schedule {
        dt,
        steps,
        load_ramp,
    }
}

/// `hessian`: the Hessian the system assembles and Newton's policy.
fn hessian(spec: HessianSpec) -> (HessianMode, HessianPolicy) {
    match spec {
        HessianSpec::Adaptive => (HessianMode::Exact, HessianPolicy::Adaptive),
        HessianSpec::AdaptivePsd => (HessianMode::Exact, HessianPolicy::AdaptivePsd),
        HessianSpec::Exact => (HessianMode::Exact, HessianPolicy::Fixed),
        HessianSpec::GaussNewton => (HessianMode::GaussNewton, HessianPolicy::Fixed),
        HessianSpec::Projected => (HessianMode::ProjectedPsd, HessianPolicy::Fixed),
    }
}

/// `[integrator.newton]`: the scene's keys over `defaults` (the chosen integrator's own),
/// checked by the solver.
pub fn newton(nw: &NewtonSpec, defaults: NewtonSettings) -> Result<NewtonSettings, SolverError> {
    let mut settings = defaults;
    if let Some(v) = nw.tolerance {
        settings.gradient_tolerance = v;
    }
    if let Some(v) = nw.step_tolerance {
        settings.step_tolerance = v;
    }
    if let Some(v) = nw.max_iterations {
        settings.max_iterations = v;
    }
    if let Some(v) = nw.line_search {
        settings.line_search = v;
    }
    if let Some(v) = nw.watchdog {
        settings.watchdog = v;
    }
    if let Some(v) = nw.escape_saddles {
        settings.escape_saddles = v;
    }
    if nw.regularization == Some(false) {
        settings.regularization = None;
    }
    if let Some(v) = nw.force_iterative {
        settings.force_iterative = v;
    }
    if let Some(v) = nw.reuse_factor {
        settings.reuse_factor = v;
    }
    if let Some(v) = nw.fallback {
        settings.fallback = match v {
            FallbackSpec::Ic0 => IterativeFallback::Ic0,
            FallbackSpec::Jacobi => IterativeFallback::Jacobi,
            FallbackSpec::Off => IterativeFallback::Off,
        };
    }
    (settings.own_hessian, settings.hessian) = hessian(nw.hessian);
    settings.validate()?;
    Ok(settings)
}

/// The integrator of a validated `[integrator]` section, the scene's settings over the
/// integrator's own defaults, for the built `system` (an explicit Newton `tolerance` is
/// relative to its force scale).
pub fn build(
    i: &IntegratorSpec,
    system: &ShellSystem,
) -> Result<Box<ShellIntegrator>, SolverError> {
    let dt = i.dt.unwrap_or(1.0);
    // Convergence is the solver's scale-free test (Newton correction, round-off); an
    // explicit `tolerance` adds the gradient test against the system's one force scale.
    let force_scale = i.newton.tolerance.map(|_| system.force_scale());
    // A failed exact or adaptive solve is retried with the Gauss–Newton Hessian
    // (docs/robustness.md), a safety net the adaptive Newton rarely needs.
    let with_fallback = |mut newton: NewtonSettings, on: bool| {
        newton.fallback_hessian =
            (on && newton.own_hessian == HessianMode::Exact).then_some(HessianMode::GaussNewton);
        newton
    };
    Ok(match i.kind {
        IntegratorKind::Static => {
            let defaults = run_loop_static();
            Box::new(Static {
                newton: with_fallback(newton(&i.newton, defaults.newton)?, true),
                force_scale,
                ..defaults
            })
        }
        IntegratorKind::Implicit => {
            let defaults = ImplicitEuler::new(dt);
            Box::new(ImplicitEuler {
                // With `adaptive_dt`, before halving Δt.
                newton: with_fallback(newton(&i.newton, defaults.newton)?, i.adaptive_dt),
                force_scale,
                max_halvings: if i.adaptive_dt { 8 } else { 0 },
                ..defaults
            })
        }
        IntegratorKind::Explicit => Box::new(ExplicitEuler { dt }),
    })
}

/// The static solver of a run loop: the solver's defaults without its own rest-state
/// continuation, because `Simulation::step` continues a failed step from the previous step's
/// rest forms and load factor, a better origin than the start's own forms.
pub fn run_loop_static() -> Static {
    Static {
        continuation: false,
        ..Static::default()
    }
}
