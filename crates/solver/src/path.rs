//! Path following of equilibria `R(u, λ) = ∇Π(u, λ) = 0` of a loaded potential
//! `Π(u, λ) = E(u) − λ·W(u)` (W: the work of the reference load, e.g. `fᵀu`), past limit points
//! and snap-backs: **arc-length** continuation (Riks/Crisfield) and **displacement control**.
//!
//! One implementation ([`PathTracer`]) drives any [`LoadedObjective`]: a shell
//! (`thinshell_system::ShellPath`) or a one-dof test problem. Each step is a predictor
//! along the tangent followed by Newton corrections of the bordered system
//!
//! ```text
//! K δu − q δλ = −R,     K = ∂R/∂u (the Hessian of Π),  q = −∂R/∂λ (the reference load),
//! g(Δu + δu, Δλ + δλ) = 0,
//! ```
//!
//! solved with two solves of the factorised `K`: `δu = δu_R + δλ·δu_q`, `K δu_R = −R`,
//! `K δu_q = q`. The constraint `g` is
//! - arc length (Crisfield's spherical constraint; cylindrical for ψ = 0):
//!   `ΔuᵀΔu + ψ²Δλ² = Δs²`, solved exactly for δλ (a quadratic; of its two roots the one
//!   whose increment makes the smaller angle with the current increment; complex roots cut
//!   the step);
//! - displacement control of dof k: `Δu_k = Δ` (then `δλ = (Δ − Δu_k − δu_R,k)/δu_q,k`). It
//!   cannot pass a snap-back of that dof (a turning point of u_k): there Newton would land on
//!   a distant branch; a converged increment more than 10 times longer than its predictor is
//!   refused as such a jump, so the step is cut back and finally fails.
//!
//! Δu, Δλ are increments from the last converged point. **Sign rule**: the predictor
//! `±(δu_q, 1)/√(δu_qᵀδu_q + ψ²)·Δs` takes the sign that continues the previous converged
//! increment, `sign(Δu_prevᵀδu_q + ψ²Δλ_prev)`, so the load factor decreases by itself after
//! a limit point and the path turns at a snap-back (the sign of det K, which fails at
//! snap-back points, is reported, not used). **Step adaptation**: after a step that took I
//! iterations the next arc length is `Δs·√(I_d/I)` (I_d = [`PathSettings::desired_iterations`],
//! factor clamped to [½, 2] and Δs to its bounds); a step that fails (no convergence within
//! [`PathSettings::max_iterations`], a singular tangent, complex roots, a reversal, non-finite
//! values) is retried from the last converged point with half the step, up to
//! [`PathSettings::max_cutbacks`] times; then [`SolverError::PathFailed`] with the residual
//! history of the last attempt.
//!
//! Every converged point is classified from the LDLᵀ factorisation of K there (its inertia):
//! the number of negative eigenvalues of the Hessian at fixed load, 0 for a stable point.
//!
//! Units: u in the objective's units (m for shells), λ dimensionless, ψ in units of u
//! (a displacement per unit load factor), Δs in units of u.

use faer::Par;
use faer::sparse::SparseColMat;

use crate::error::PathFailure;
use crate::ldlt::SparseLdlt;
use crate::{NewtonSettings, NewtonWorkspace, Objective, Ordering, SolverError, newton_solve};

/// Displacement control: a converged increment longer than this × its predictor is a jump to
/// another branch, refused (the step is cut back, and fails at a snap-back of the dof).
const JUMP_FACTOR: f64 = 10.0;

/// An [`Objective`] `Π(u, λ) = E(u) − λ·W(u)` whose load factor λ can be set: `value`,
/// `gradient` and `hessian` are those of Π at the current λ (the Hessian must be the exact
/// one: it is the tangent of the path).
pub trait LoadedObjective: Objective {
    /// The current load factor λ (dimensionless).
    fn load_factor(&self) -> f64;
    /// Sets λ for the following evaluations.
    fn set_load_factor(&mut self, lambda: f64) -> Result<(), SolverError>;
    /// Writes the reference load `q(u) = −∂(∇Π)/∂λ` at `u` into `q` (overwritten; for dead
    /// loads the force vector at λ = 1, independent of u; a follower pressure adds `p₀∂V/∂u`).
    fn load_vector(&mut self, u: &[f64], q: &mut [f64]) -> Result<(), SolverError>;
}

/// Which constraint closes the bordered system of a path step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PathControl {
    /// Riks/Crisfield arc length: `ΔuᵀΔu + ψ²Δλ² = Δs²`.
    ArcLength {
        /// ψ (units of u per unit λ): the weight of the load factor in the arc length.
        /// `None` (default): `‖δu_q‖₂` at the start point, so that in the linear range a step
        /// splits evenly between load and displacement; `Some(0.0)`: cylindrical constraint.
        psi: Option<f64>,
    },
    /// Displacement control of unknown `dof` (an index of the objective's unknowns): each
    /// step prescribes its increment and solves for λ. Cannot pass a point where that dof
    /// turns back (a snap-back in it).
    Displacement {
        /// The controlled unknown.
        dof: usize,
    },
}

impl Default for PathControl {
    fn default() -> Self {
        PathControl::ArcLength { psi: None }
    }
}

/// Parameters of a [`PathTracer`] ([`Default`] gives robust values).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    /// The constraint (default: arc length with automatic ψ).
    pub control: PathControl,
    /// Size of the first step, as the load-factor increment of its predictor (dimensionless,
    /// positive; default 0.1): the first arc length (or prescribed displacement increment) is the
    /// one whose tangent predictor raises λ by this much. Ignored when
    /// [`initial_step`](Self::initial_step) is given.
    pub initial_load_increment: f64,
    /// First arc length Δs (arc length; units of u, > 0) or, for displacement control, first
    /// increment of the controlled dof (units of u, non-zero, signed). `None`: from
    /// [`initial_load_increment`](Self::initial_load_increment).
    pub initial_step: Option<f64>,
    /// Direction of the first step: `+1` raises λ (arc length) or, for displacement control
    /// with [`initial_step`](Self::initial_step) `None`, moves the dof with the load; `-1`
    /// the opposite. Later steps follow the path (the sign rule).
    pub direction: f64,
    /// Smallest step (relative to the first one, in (0, 1]): a cut-back below it fails.
    pub min_step_ratio: f64,
    /// Largest step (relative to the first one, ≥ 1).
    pub max_step_ratio: f64,
    /// Newton iterations per step the step adaptation aims at (≥ 1, default 4).
    pub desired_iterations: usize,
    /// Newton iterations after which a step counts as failed and is cut back (≥ 1).
    pub max_iterations: usize,
    /// Converged when the Newton correction has `‖δu‖∞ ≤ tolerance · length_scale` (the
    /// objective's) and `|δλ| ≤ tolerance · max(1, |λ|)` (dimensionless, > 0; default 1e-10).
    pub tolerance: f64,
    /// Halvings of a failing step before [`SolverError::PathFailed`] (default 10).
    pub max_cutbacks: usize,
    /// Fill-reducing ordering of the LDLᵀ factorisation of the tangent.
    pub ordering: Ordering,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings {
            control: PathControl::default(),
            initial_load_increment: 0.1,
            initial_step: None,
            direction: 1.0,
            min_step_ratio: 1e-4,
            max_step_ratio: 10.0,
            desired_iterations: 4,
            max_iterations: 20,
            tolerance: 1e-10,
            max_cutbacks: 10,
            ordering: Ordering::Auto,
        }
    }
}

impl PathSettings {
    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = SolverError::invalid_setting;
        if !(self.initial_load_increment.is_finite() && self.initial_load_increment > 0.0) {
            return Err(bad(
                "initial_load_increment",
                self.initial_load_increment,
                "must be positive and finite",
            ));
        }
        if let Some(s) = self.initial_step {
            let ok = match self.control {
                PathControl::ArcLength { .. } => s > 0.0,
                PathControl::Displacement { .. } => s != 0.0,
            };
            if !(s.is_finite() && ok) {
                return Err(bad(
                    "initial_step",
                    s,
                    "must be finite, positive for arc length, non-zero for displacement control",
                ));
            }
        }
        if let PathControl::ArcLength { psi: Some(psi) } = self.control {
            if !(psi.is_finite() && psi >= 0.0) {
                return Err(bad("psi", psi, "must be non-negative and finite"));
            }
        }
        if !(self.direction == 1.0 || self.direction == -1.0) {
            return Err(bad("direction", self.direction, "must be +1 or -1"));
        }
        if !(self.min_step_ratio > 0.0 && self.min_step_ratio <= 1.0) {
            return Err(bad(
                "min_step_ratio",
                self.min_step_ratio,
                "must lie in (0, 1]",
            ));
        }
        if !(self.max_step_ratio.is_finite() && self.max_step_ratio >= 1.0) {
            return Err(bad(
                "max_step_ratio",
                self.max_step_ratio,
                "must be finite and at least 1",
            ));
        }
        if self.desired_iterations == 0 {
            return Err(bad("desired_iterations", 0.0, "must be at least 1"));
        }
        if self.max_iterations == 0 {
            return Err(bad("max_iterations", 0.0, "must be at least 1"));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(bad(
                "tolerance",
                self.tolerance,
                "must be positive and finite",
            ));
        }
        Ok(())
    }
}

/// One converged point of the path.
#[derive(Clone, Debug, PartialEq)]
pub struct PathPoint {
    /// Step number (1 for the first converged step of the tracer).
    pub step: usize,
    /// Load factor λ of the point.
    pub load_factor: f64,
    /// Π(u, λ) at the point (J for shells: energy minus the work of the loads).
    pub value: f64,
    /// Newton corrections of the successful attempt.
    pub iterations: usize,
    /// Halvings of the step before it converged.
    pub cutbacks: usize,
    /// The step taken: arc length Δs, or the prescribed increment of the controlled dof.
    pub step_length: f64,
    /// Load-factor increment Δλ of the step (negative after a limit point).
    pub load_increment: f64,
    /// Number of negative eigenvalues of the Hessian at fixed load at the point (from its
    /// LDLᵀ factorisation); `None` if the tangent there is singular to working precision
    /// (the step ended exactly on a critical point).
    pub negative_eigenvalues: Option<usize>,
    /// Relative residual ‖R‖∞ / force scale of every iterate of the successful attempt
    /// (first: the predictor, last: the converged point).
    pub residuals: Vec<f64>,
}

impl PathPoint {
    /// Whether the point is a stable equilibrium at fixed load: the Hessian is positive
    /// definite (no negative eigenvalue).
    pub fn stable(&self) -> bool {
        self.negative_eigenvalues == Some(0)
    }
}

/// Traces an equilibrium path step by step; keeps the previous increment (for the sign rule),
/// the adapted step size and the factorised tangent of the last point. One tracer per path:
/// the objective must be the same between steps (call [`PathTracer::reset`] after changing it).
///
/// A one-dof softening spring `Π(u, λ) = u²/2 − u⁴/4 − λu`: equilibria `λ = u − u³`, a limit
/// point at `u = 1/√3`, where load control would jump; arc length passes it:
///
/// ```
/// use faer::sparse::{SparseColMat, Triplet};
/// use thinshell_solver::{LoadedObjective, Objective, PathSettings, PathTracer, SolverError};
///
/// struct Spring { lambda: f64 }
/// impl Objective for Spring {
///     fn n_dofs(&self) -> usize { 1 }
///     fn value(&mut self, u: &[f64]) -> Result<f64, SolverError> {
///         Ok(u[0].powi(2) / 2.0 - u[0].powi(4) / 4.0 - self.lambda * u[0])
///     }
///     fn gradient(&mut self, u: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
///         g[0] = u[0] - u[0].powi(3) - self.lambda;
///         self.value(u)
///     }
///     fn hessian(&mut self, u: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
///         h.val_mut()[0] = 1.0 - 3.0 * u[0] * u[0];
///         Ok(())
///     }
///     fn hessian_template(&self) -> SparseColMat<usize, f64> {
///         SparseColMat::try_new_from_triplets(1, 1, &[Triplet::new(0, 0, 0.0)]).unwrap()
///     }
///     fn force_scale(&self) -> f64 { 1.0 }
/// }
/// impl LoadedObjective for Spring {
///     fn load_factor(&self) -> f64 { self.lambda }
///     fn set_load_factor(&mut self, lambda: f64) -> Result<(), SolverError> {
///         self.lambda = lambda;
///         Ok(())
///     }
///     fn load_vector(&mut self, _u: &[f64], q: &mut [f64]) -> Result<(), SolverError> {
///         q[0] = 1.0; // dead load
///         Ok(())
///     }
/// }
///
/// let mut spring = Spring { lambda: 0.0 };
/// let mut u = [0.0];
/// let mut tracer = PathTracer::new(PathSettings::default());
/// let mut lambda_max = 0.0f64;
/// while u[0] < 0.9 {
///     let p = tracer.step(&mut spring, &mut u)?;
///     assert!((p.load_factor - (u[0] - u[0].powi(3))).abs() < 1e-9); // on the path
///     assert_eq!(p.stable(), 1.0 - 3.0 * u[0] * u[0] > 0.0); // unstable past the limit
///     lambda_max = lambda_max.max(p.load_factor);
/// }
/// // Through the limit point λ_max = 2/(3√3) ≈ 0.385 and down the other side.
/// assert!(lambda_max > 0.37 && lambda_max <= 2.0 / (3.0 * 3f64.sqrt()));
/// assert!(spring.lambda < 0.2);
/// # Ok::<(), SolverError>(())
/// ```
#[derive(Debug)]
pub struct PathTracer {
    /// The settings (read at every step; [`PathTracer::reset`] after changing the control).
    pub settings: PathSettings,
    steps: usize,
    /// Current step size (arc length, or |Δu_k|), after adaptation; `None` before the first.
    step_length: Option<f64>,
    first_step: f64,
    psi: f64,
    /// Increment (Δu, Δλ) of the last converged step.
    previous: Option<(Vec<f64>, f64)>,
    factor: Option<SparseLdlt>,
    hessian: Option<SparseColMat<usize, f64>>,
    /// Whether `factor` holds the tangent at the last converged point.
    tangent_current: bool,
    /// Whether the objective changed itself during the current step's attempt
    /// ([`Objective::begin_iteration`] reported a new value).
    function_changed: bool,
}

/// How often one step may re-equilibrate its start after the objective changed itself there.
const MAX_REEQUILIBRATIONS: usize = 8;

/// Why one attempt of a step failed (it is then cut back).
struct Attempt {
    reason: String,
    residuals: Vec<f64>,
}

impl PathTracer {
    /// A tracer at the start of a path.
    pub fn new(settings: PathSettings) -> PathTracer {
        PathTracer {
            settings,
            steps: 0,
            step_length: None,
            first_step: 0.0,
            psi: 0.0,
            previous: None,
            factor: None,
            hessian: None,
            tangent_current: false,
            function_changed: false,
        }
    }

    /// Forgets the path so far (direction, step size, tangent): the next step starts afresh.
    pub fn reset(&mut self) {
        *self = PathTracer::new(self.settings);
    }

    /// Converged steps so far.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The step size the next step will try (arc length, or |Δu_k| for displacement
    /// control); `None` before the first step.
    pub fn step_length(&self) -> Option<f64> {
        self.step_length
    }

    /// ψ in use (units of u per unit λ; 0 before the first arc-length step and for
    /// displacement control).
    pub fn psi(&self) -> f64 {
        self.psi
    }

    /// Takes one step from the equilibrium `u` at the objective's current load factor
    /// (`u` and the load factor are overwritten with the next point; on error both are left
    /// at the start point). `u` must be an equilibrium (e.g. the undeformed state at λ = 0).
    ///
    /// An objective that changes itself ([`Objective::begin_iteration`], e.g. contact raising
    /// its barrier stiffness) has its start re-equilibrated at the same load factor first; an
    /// update that [`Objective::max_step`] does not admit whole (with contact: one that would
    /// make primitives cross) fails the attempt, which is cut back.
    pub fn step<O: LoadedObjective + ?Sized>(
        &mut self,
        obj: &mut O,
        u: &mut [f64],
    ) -> Result<PathPoint, SolverError> {
        self.settings.validate()?;
        let n = obj.n_dofs();
        if u.len() != n {
            return Err(SolverError::DimensionMismatch {
                what: "u",
                expected: n,
                found: u.len(),
            });
        }
        if let PathControl::Displacement { dof } = self.settings.control {
            if dof >= n {
                return Err(SolverError::invalid_setting(
                    "control.dof",
                    dof as f64,
                    "must be an unknown of the objective (a free dof)",
                ));
            }
        }
        self.step_from_equilibrium(obj, u, 0)
    }

    /// [`PathTracer::step`] after the checks; `reequilibrations`: how often the start has been
    /// re-equilibrated because the objective changed itself.
    fn step_from_equilibrium<O: LoadedObjective + ?Sized>(
        &mut self,
        obj: &mut O,
        u: &mut [f64],
        mut reequilibrations: usize,
    ) -> Result<PathPoint, SolverError> {
        let n = u.len();
        self.function_changed = false;
        // The objective may change itself at the start point (contact: new pairs near u, a
        // stiffer barrier).
        let update = obj.begin_iteration(u, 0)?;
        if update.pattern_changed {
            self.factor = None;
        }
        if update.value_changed {
            self.reequilibrate(obj, u)?;
        }
        if self.factor.as_ref().is_none_or(|f| f.n() != n) {
            self.analyse(obj)?;
        }
        let lambda0 = obj.load_factor();
        let u0 = u.to_vec();
        // The tangent at the start point: its load direction v = K⁻¹q.
        if !self.tangent_current {
            self.factorize(obj, u)?;
        }
        let mut v = vec![0.0; n];
        obj.load_vector(u, &mut v)?;
        if v.iter().all(|q| *q == 0.0) {
            return Err(SolverError::invalid_setting(
                "load_vector",
                0.0,
                "the reference load is zero: there is no load to follow",
            ));
        }
        self.solve(&mut v)?;
        let v_norm2: f64 = v.iter().map(|x| x * x).sum();
        if self.step_length.is_none() {
            self.start(&v, v_norm2)?;
        }
        let mut cutbacks = 0;
        loop {
            let ds = self.step_length.unwrap_or(self.first_step);
            match self.attempt(obj, u, &u0, lambda0, &v, v_norm2, ds) {
                Ok((iterations, residuals, du, dl)) => {
                    let value = match obj.value(u) {
                        Ok(v) => v,
                        Err(e) => {
                            u.copy_from_slice(&u0);
                            obj.set_load_factor(lambda0)?;
                            self.tangent_current = false;
                            return Err(e);
                        }
                    };
                    self.previous = Some((du, dl));
                    let negative = match self.factorize(obj, u) {
                        Ok(()) => self.factor.as_ref().map(|f| f.negative_pivots()),
                        Err(_) => None,
                    };
                    self.steps += 1;
                    let adapt = (self.settings.desired_iterations as f64
                        / iterations.max(1) as f64)
                        .sqrt()
                        .clamp(0.5, 2.0);
                    self.step_length = Some((ds * adapt).clamp(
                        self.first_step * self.settings.min_step_ratio,
                        self.first_step * self.settings.max_step_ratio,
                    ));
                    return Ok(PathPoint {
                        step: self.steps,
                        load_factor: obj.load_factor(),
                        value,
                        iterations,
                        cutbacks,
                        step_length: ds,
                        load_increment: dl,
                        negative_eigenvalues: negative,
                        residuals,
                    });
                }
                Err(failure) => {
                    u.copy_from_slice(&u0);
                    obj.set_load_factor(lambda0)?;
                    if std::mem::take(&mut self.function_changed)
                        && reequilibrations < MAX_REEQUILIBRATIONS
                    {
                        // The attempt changed the objective (a stiffer barrier): the start is
                        // no longer an equilibrium of it, and no arc from there would close.
                        reequilibrations += 1;
                        self.reequilibrate(obj, u)?;
                        return self.step_from_equilibrium(obj, u, reequilibrations);
                    }
                    let next = ds * 0.5;
                    if cutbacks >= self.settings.max_cutbacks
                        || next < self.first_step * self.settings.min_step_ratio
                    {
                        // Leave the tracer able to retry from the start point.
                        self.tangent_current = false;
                        return Err(SolverError::PathFailed(Box::new(PathFailure {
                            step: self.steps + 1,
                            load_factor: lambda0,
                            step_length: ds,
                            cutbacks,
                            reason: failure.reason,
                            residuals: failure.residuals,
                            last_good: u0,
                        })));
                    }
                    cutbacks += 1;
                    self.step_length = Some(next);
                }
            }
        }
    }

    /// First step: ψ and the step size from the settings and the start tangent `v`.
    fn start(&mut self, v: &[f64], v_norm2: f64) -> Result<(), SolverError> {
        let s = &self.settings;
        let first = match s.control {
            PathControl::ArcLength { psi } => {
                self.psi = psi.unwrap_or(v_norm2.sqrt());
                s.initial_step.unwrap_or_else(|| {
                    s.initial_load_increment * (v_norm2 + self.psi * self.psi).sqrt()
                })
            }
            PathControl::Displacement { dof } => {
                self.psi = 0.0;
                match s.initial_step {
                    Some(d) => d.abs(),
                    None => s.initial_load_increment * v[dof].abs(),
                }
            }
        };
        if !(first.is_finite() && first > 0.0) {
            return Err(SolverError::invalid_setting(
                "initial_step",
                first,
                "the first step is zero or not finite (the load does not move the controlled \
                 dof, or the start tangent is singular)",
            ));
        }
        self.first_step = first;
        self.step_length = Some(first);
        Ok(())
    }

    /// Assembles and factorises the tangent K at `u` (current λ).
    fn factorize<O: LoadedObjective + ?Sized>(
        &mut self,
        obj: &mut O,
        u: &[f64],
    ) -> Result<(), SolverError> {
        self.tangent_current = false;
        let (Some(h), Some(f)) = (self.hessian.as_mut(), self.factor.as_mut()) else {
            return Err(SolverError::Linear("path tracer used before set-up".into()));
        };
        obj.hessian(u, h)?;
        if h.val().iter().any(|x| !x.is_finite()) {
            return Err(SolverError::NonFinite {
                what: "Hessian",
                iteration: 0,
                dof: None,
            });
        }
        f.factorize(h.as_ref())?;
        self.tangent_current = true;
        Ok(())
    }

    fn solve(&mut self, rhs: &mut [f64]) -> Result<(), SolverError> {
        match self.factor.as_mut() {
            Some(f) => f.solve_in_place(rhs),
            None => Err(SolverError::Linear("path tracer used before set-up".into())),
        }
    }

    /// Re-solves the equilibrium at the current load factor from `u` (overwritten) after the
    /// objective changed itself there (e.g. contact raised its barrier stiffness), with
    /// [`newton_solve`]'s defaults and its line search (which, with contact, is collision
    /// checked): a path step starts from an equilibrium of the function it follows.
    fn reequilibrate<O: LoadedObjective + ?Sized>(
        &mut self,
        obj: &mut O,
        u: &mut [f64],
    ) -> Result<(), SolverError> {
        self.tangent_current = false;
        let settings = NewtonSettings {
            ordering: self.settings.ordering,
            ..NewtonSettings::default()
        };
        let mut ws = NewtonWorkspace::new(obj, &settings)?;
        newton_solve(obj, u, &settings, &mut ws)?;
        // newton_solve may have widened the Hessian pattern (contact pairs came near).
        self.analyse(obj)
    }

    /// The tangent's pattern and symbolic factorisation from the objective's current Hessian
    /// template; the factor no longer holds a tangent.
    fn analyse<O: LoadedObjective + ?Sized>(&mut self, obj: &O) -> Result<(), SolverError> {
        let template = obj.hessian_template();
        self.factor = Some(SparseLdlt::new(
            template.symbolic(),
            self.settings.ordering,
            Par::Seq,
        )?);
        self.hessian = Some(template);
        self.tangent_current = false;
        Ok(())
    }

    /// Moves the iterate from `previous` to `u` if the objective admits the whole straight
    /// motion ([`Objective::max_step`]: with contact, no pair of primitives crosses on the
    /// way), then lets the objective update itself at `u` ([`Objective::begin_iteration`]),
    /// rebuilding the tangent's symbolic factorisation when its pattern changed. A motion
    /// admitted only in part fails the attempt, which is then cut back: the bordered Newton
    /// step has no line search to shorten it, and a shorter arc keeps the path on the side
    /// it came from. `previous` becomes `u`.
    fn admit<O: LoadedObjective + ?Sized>(
        &mut self,
        obj: &mut O,
        previous: &mut [f64],
        u: &[f64],
        iteration: usize,
    ) -> Result<(), String> {
        let step: Vec<f64> = u.iter().zip(&*previous).map(|(a, b)| a - b).collect();
        if step.iter().any(|d| *d != 0.0) {
            let alpha = obj.max_step(previous, &step).map_err(|e| e.to_string())?;
            if alpha < 1.0 || alpha.is_nan() {
                return Err(format!(
                    "iteration {iteration}: the update would make two parts of the shell (or \
                     the shell and an obstacle) cross; continuous collision detection admits \
                     {alpha:.3e} of it"
                ));
            }
        }
        previous.copy_from_slice(u);
        let update = obj
            .begin_iteration(u, iteration)
            .map_err(|e| e.to_string())?;
        if update.pattern_changed {
            self.analyse(obj).map_err(|e| e.to_string())?;
        }
        if update.pattern_changed || update.value_changed {
            self.tangent_current = false;
        }
        self.function_changed |= update.value_changed;
        Ok(())
    }

    /// The signed prescribed quantity of the step: arc length Δs, or the dof increment.
    fn predictor(&self, v: &[f64], v_norm2: f64, ds: f64) -> f64 {
        match self.settings.control {
            PathControl::ArcLength { .. } => {
                let sign = match &self.previous {
                    // Continue the previous increment (the sign rule).
                    Some((du, dl)) => {
                        let dot: f64 = du.iter().zip(v).map(|(a, b)| a * b).sum::<f64>()
                            + self.psi * self.psi * dl;
                        if dot != 0.0 {
                            dot.signum()
                        } else {
                            dl.signum()
                        }
                    }
                    None => self.settings.direction,
                };
                sign * ds / (v_norm2 + self.psi * self.psi).sqrt()
            }
            PathControl::Displacement { dof } => match (&self.previous, self.settings.initial_step)
            {
                // Keep moving the dof the way it moved.
                (Some((du, _)), _) => du[dof].signum() * ds,
                (None, Some(d)) => d.signum() * ds,
                (None, None) => self.settings.direction * v[dof].signum() * ds,
            },
        }
    }

    /// One attempt of a step of size `ds` from (u0, λ0); returns the iterations, the
    /// residual history, Δu and Δλ. On failure `u` and λ are garbage (the caller restores
    /// them).
    #[allow(clippy::too_many_arguments)]
    fn attempt<O: LoadedObjective + ?Sized>(
        &mut self,
        obj: &mut O,
        u: &mut [f64],
        u0: &[f64],
        lambda0: f64,
        v: &[f64],
        v_norm2: f64,
        ds: f64,
    ) -> Result<(usize, Vec<f64>, Vec<f64>, f64), Attempt> {
        let n = u.len();
        let psi2 = self.psi * self.psi;
        let length = obj.length_scale();
        let force = obj.force_scale();
        let mut residuals = Vec::new();
        let fail = |reason: String, residuals: &Vec<f64>| Attempt {
            reason,
            residuals: residuals.clone(),
        };
        // Predictor.
        let p = self.predictor(v, v_norm2, ds);
        let (mut du, mut dl) = match self.settings.control {
            PathControl::ArcLength { .. } => (v.iter().map(|x| p * x).collect::<Vec<_>>(), p),
            PathControl::Displacement { dof } => {
                let dl = p / v[dof];
                (v.iter().map(|x| dl * x).collect(), dl)
            }
        };
        let target = p; // displacement control: the prescribed Δu_k
        let predictor_dir = (du.clone(), dl);
        let mut r = vec![0.0; n];
        let mut q = vec![0.0; n];
        let mut previous = u0.to_vec();
        for iteration in 0..=self.settings.max_iterations {
            for ((ui, u0i), dui) in u.iter_mut().zip(u0).zip(&du) {
                *ui = u0i + dui;
            }
            self.admit(obj, &mut previous, u, iteration)
                .map_err(|reason| fail(reason, &residuals))?;
            let lambda = lambda0 + dl;
            obj.set_load_factor(lambda)
                .map_err(|e| fail(e.to_string(), &residuals))?;
            let value = obj
                .gradient(u, &mut r)
                .map_err(|e| fail(e.to_string(), &residuals))?;
            let res = r.iter().fold(0.0f64, |m, x| m.max(x.abs())) / force;
            residuals.push(res);
            if !(value.is_finite() && res.is_finite()) {
                return Err(fail(
                    format!("non-finite residual at iteration {iteration}"),
                    &residuals,
                ));
            }
            if iteration == self.settings.max_iterations {
                break;
            }
            if let Err(e) = self.factorize(obj, u) {
                return Err(fail(format!("tangent: {e}"), &residuals));
            }
            obj.load_vector(u, &mut q)
                .map_err(|e| fail(e.to_string(), &residuals))?;
            r.iter_mut().for_each(|x| *x = -*x);
            self.solve(&mut r)
                .and_then(|_| self.solve(&mut q))
                .map_err(|e| fail(e.to_string(), &residuals))?;
            let (a, b) = (&r, &q); // δu = a + δλ b
            let dlam = match self.settings.control {
                PathControl::ArcLength { .. } => {
                    let w: Vec<f64> = du.iter().zip(a).map(|(x, y)| x + y).collect();
                    let qa = b.iter().map(|x| x * x).sum::<f64>() + psi2;
                    let qb = 2.0 * (b.iter().zip(&w).map(|(x, y)| x * y).sum::<f64>() + psi2 * dl);
                    let qc = w.iter().map(|x| x * x).sum::<f64>() + psi2 * dl * dl - ds * ds;
                    let disc = qb * qb - 4.0 * qa * qc;
                    if !(disc >= 0.0 && qa > 0.0) {
                        return Err(fail(
                            format!(
                                "arc-length constraint has no real root at iteration {iteration}"
                            ),
                            &residuals,
                        ));
                    }
                    let sq = disc.sqrt();
                    // Numerically stable roots of qa·x² + qb·x + qc.
                    let t = -0.5 * (qb + qb.signum() * sq);
                    let roots = if t != 0.0 {
                        [t / qa, qc / t]
                    } else {
                        [0.0, 0.0]
                    };
                    // The root whose new increment is closest in angle to the current one.
                    let score = |x: f64| {
                        w.iter()
                            .zip(b)
                            .zip(&du)
                            .map(|((wi, bi), di)| (wi + x * bi) * di)
                            .sum::<f64>()
                            + psi2 * (dl + x) * dl
                    };
                    if score(roots[0]) >= score(roots[1]) {
                        roots[0]
                    } else {
                        roots[1]
                    }
                }
                PathControl::Displacement { dof } => {
                    if b[dof] == 0.0 {
                        return Err(fail(
                            "the load does not move the controlled dof (tangent δu_q,k = 0)".into(),
                            &residuals,
                        ));
                    }
                    (target - du[dof] - a[dof]) / b[dof]
                }
            };
            let mut max_du = 0.0f64;
            for ((d, ai), bi) in du.iter_mut().zip(a).zip(b) {
                let step = ai + dlam * bi;
                max_du = max_du.max(step.abs());
                *d += step;
            }
            dl += dlam;
            if !(max_du.is_finite() && dlam.is_finite()) {
                return Err(fail(
                    format!("non-finite correction at iteration {iteration}"),
                    &residuals,
                ));
            }
            let lam = lambda0 + dl;
            if max_du <= self.settings.tolerance * length
                && dlam.abs() <= self.settings.tolerance * lam.abs().max(1.0)
            {
                // Converged: evaluate the residual of the final iterate for the record.
                for ((ui, u0i), dui) in u.iter_mut().zip(u0).zip(&du) {
                    *ui = u0i + dui;
                }
                self.admit(obj, &mut previous, u, iteration + 1)
                    .map_err(|reason| fail(reason, &residuals))?;
                obj.set_load_factor(lam)
                    .map_err(|e| fail(e.to_string(), &residuals))?;
                obj.gradient(u, &mut r)
                    .map_err(|e| fail(e.to_string(), &residuals))?;
                residuals.push(r.iter().fold(0.0f64, |m, x| m.max(x.abs())) / force);
                if let PathControl::Displacement { .. } = self.settings.control {
                    // The constraint does not bound the other unknowns: past a turning point
                    // of the controlled dof Newton lands on a distant branch. Refuse the jump.
                    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
                    let (got, predicted) = (norm(&du), norm(&predictor_dir.0));
                    if got > JUMP_FACTOR * predicted {
                        return Err(fail(
                            format!(
                                "the converged increment is {:.0}× the predictor's: the path \
                                 does not continue in the controlled dof (it turns back there, \
                                 a snap-back); use arc length",
                                got / predicted
                            ),
                            &residuals,
                        ));
                    }
                }
                if let PathControl::ArcLength { .. } = self.settings.control {
                    let forward = du
                        .iter()
                        .zip(&predictor_dir.0)
                        .map(|(a, b)| a * b)
                        .sum::<f64>()
                        + psi2 * dl * predictor_dir.1;
                    if forward <= 0.0 {
                        return Err(fail(
                            "the corrector turned back along the path".into(),
                            &residuals,
                        ));
                    }
                }
                return Ok((iteration + 1, residuals, du, dl));
            }
        }
        Err(fail(
            format!(
                "no convergence in {} iterations",
                self.settings.max_iterations
            ),
            &residuals,
        ))
    }
}
