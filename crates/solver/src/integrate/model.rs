//! What the integrators step: a [`Model`] of point masses with massless extra unknowns, its
//! [`State`], and the [`StepObjective`] each of its solves minimises.

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::HessianMode;

use crate::{Objective, SolverError};

/// Dynamic state: positions (m), velocities (m/s), one entry per point; extra unknowns without
/// mass (e.g. a shell's edge-director angles, rad), solved quasi-statically at every step; time
/// (s).
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Positions (m).
    pub x: Vec<Vector3<f64>>,
    /// Velocities (m/s).
    pub v: Vec<Vector3<f64>>,
    /// The model's massless extra unknowns (a shell's edge-director angles φ_e, rad, one per
    /// edge), or empty when it has none. An empty vector on a model with extra unknowns means
    /// all 0 (integrators fill it in on the first step).
    pub phi: Vec<f64>,
    /// Time (s).
    pub t: f64,
}

impl State {
    /// At rest at positions `x`, time 0, extra unknowns 0.
    pub fn at_rest(x: Vec<Vector3<f64>>) -> State {
        let v = vec![Vector3::zeros(); x.len()];
        State {
            x,
            v,
            phi: Vec::new(),
            t: 0.0,
        }
    }
}

/// How an integrator wants the objective of one solve built: the choices that are the
/// integrator's, not the model's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectiveOptions {
    /// The Hessian [`Objective::hessian`] assembles
    /// ([`NewtonSettings::own_hessian`](crate::NewtonSettings::own_hessian)).
    pub hessian: HessianMode,
    /// Static solves: relative Hessian diagonal shift κ against rigid-motion null spaces
    /// (added to the Hessian only, so the minimiser is unchanged); 0 for dynamic steps.
    pub hessian_shift: f64,
    /// `Some(F)` (N): the gradient test against F ends a solve; `None`: residuals are
    /// reported against the model's own force scale and convergence is scale-free.
    pub force_scale: Option<f64>,
}

/// The objective of one solve of a [`Model`]: an [`Objective`] over the model's free unknowns
/// that also answers what the integrators ask of it between iterations.
pub trait StepObjective: Objective {
    /// Energy terms the model reports (J).
    type Energies;

    /// The inertial prediction x̃ (free unknowns) of an incremental potential; `None` for a
    /// static potential.
    fn prediction(&self) -> Option<&[f64]>;

    /// The energy terms of the last evaluation.
    fn last_energies(&self) -> Self::Energies;

    /// Whether `h` has the pattern of this objective's Hessian (a cached factorisation fits).
    fn has_hessian_pattern(&self, h: &SparseColMat<usize, f64>) -> bool;
}

/// A mechanical model the integrators ([`Static`](crate::Static),
/// [`ImplicitEuler`](crate::ImplicitEuler), [`ExplicitEuler`](crate::ExplicitEuler)) step: point
/// masses with positions and velocities plus massless extra unknowns, whose free unknowns are
/// gathered into one vector `u` for Newton.
///
/// The model owns its physics — energies, loads, boundary conditions, contact — and builds the
/// objectives; the integrators own the time discretisation, the Newton solves and what happens
/// after a failed one (`integrate/retry.rs`).
pub trait Model {
    /// The objective of one solve.
    type Objective<'a>: StepObjective<Energies = Self::Energies>
    where
        Self: 'a;
    /// Energy terms a step reports (J).
    type Energies: Clone + std::fmt::Debug + PartialEq;
    /// Statistics of the model's contact term a step reports.
    type Contact: Clone + std::fmt::Debug + PartialEq;
    /// The problem a static solve solves (its rest state and load factor), what a
    /// continuation walks between.
    type Problem;

    /// Number of points (entries of [`State::x`]).
    fn n_points(&self) -> usize;

    /// Number of massless extra unknowns (entries of [`State::phi`]).
    fn n_extra(&self) -> usize;

    /// The free unknowns of positions `x` and extra unknowns `phi` (empty: all 0).
    fn gather(&self, x: &[Vector3<f64>], phi: &[f64]) -> Vec<f64>;

    /// Writes free unknowns `u` into `x` and `phi` (held entries untouched).
    fn scatter(&self, u: &[f64], x: &mut [Vector3<f64>], phi: &mut [f64]);

    /// Sets the prescribed positions of `x` at time `t` (s).
    fn apply_prescribed(&self, x: &mut [Vector3<f64>], t: f64) -> Result<(), SolverError>;

    /// Checks what a static solve needs of the model (e.g. no damping term).
    fn check_static(&self) -> Result<(), SolverError>;

    /// The static potential at positions `x` and extra unknowns `phi` (held entries taken from
    /// them).
    fn static_objective(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
        options: ObjectiveOptions,
    ) -> Self::Objective<'_>;

    /// The incremental potential of one implicit Euler step of length `dt` (s) from `state`,
    /// with the held coordinates of `x1` (the prescribed positions at the end of the step).
    fn incremental_objective(
        &mut self,
        state: &State,
        x1: &[Vector3<f64>],
        dt: f64,
        options: ObjectiveOptions,
    ) -> Result<Self::Objective<'_>, SolverError>;

    /// Whether the objectives limit their steps by a collision check (contact), so that a
    /// solve's start must be reached by collision-checked motion.
    fn checks_collisions(&self) -> bool;

    /// Records the extra unknowns `phi` of a solve whose result is kept.
    fn accept(&mut self, phi: &[f64]);

    /// The energy terms at positions `x` and extra unknowns `phi`.
    fn energies(&mut self, x: &[Vector3<f64>], phi: &[f64]) -> Result<Self::Energies, SolverError>;

    /// The contact term's statistics at positions `x`; `None` without contact.
    fn contact_stats(&self, x: &[Vector3<f64>]) -> Option<Self::Contact>;

    /// Whether any external load (force, pressure) acts at the current load factor.
    fn is_loaded(&self) -> bool;

    /// Explicit steps: the net force `F_ext − ∇E` (N) per coordinate (3 per point) of `state`,
    /// written into `force`, with the extra unknowns relaxed from `phi` (overwritten) first, and
    /// the energy terms there. `dt` (s) is the step, for rate-dependent terms (damping).
    fn explicit_force(
        &mut self,
        state: &State,
        dt: f64,
        phi: &mut [f64],
        force: &mut [f64],
    ) -> Result<Self::Energies, SolverError>;

    /// Lumped mass (kg) of every point.
    fn point_masses(&self) -> &[f64];

    /// Whether coordinate `c` (3 per point) is free.
    fn is_free_coordinate(&self, c: usize) -> bool;

    /// Points whose positions are prescribed functions of time.
    fn prescribed_points(&self) -> Vec<usize>;

    /// The model's current problem (what a continuation returns to).
    fn problem(&self) -> Self::Problem;

    /// The problem whose equilibrium positions `x` and extra unknowns `phi` are: their own rest
    /// state and no loads (the origin of a continuation from a far start).
    fn problem_at(&mut self, x: &[Vector3<f64>], phi: &[f64])
    -> Result<Self::Problem, SolverError>;

    /// Sets the model's problem to the blend `(1 − s)·from + s·to` (s ∈ [0, 1]).
    fn set_problem_between(
        &mut self,
        from: &Self::Problem,
        to: &Self::Problem,
        s: f64,
    ) -> Result<(), SolverError>;

    /// Sets the model's problem back to `problem` exactly.
    fn restore_problem(&mut self, problem: Self::Problem) -> Result<(), SolverError>;
}
