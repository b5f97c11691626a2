//! Turning a [`Scene`](crate::Scene) into a running simulation: only the terms and loads the scene's effects
//! ask for are built, and [`Simulation::run`] steps it with an [`Observer`] for progress and
//! output.
//!
//! ```no_run
//! use std::sync::atomic::AtomicBool;
//! use thinshell::scene::Scene;
//! use thinshell::sim::{NoObserver, Simulation};
//! let scene = Scene::load("data/scenes/square_enlarged.toml".as_ref())?;
//! let mut sim = Simulation::build(&scene)?;
//! let summary = sim.run(&mut NoObserver, &AtomicBool::new(false))?;
//! println!("{} steps, final elastic energy {:e} J", summary.steps, summary.final_energy.elastic());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod build;
mod describe;
mod error;
mod path;
mod path_step;
mod rest_edit;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use serde::Serialize;
pub use thinshell_energy::EnergyTerms;
use thinshell_energy::ShellModel;
use thinshell_growth::{Growth, GrowthError};
use thinshell_mesh::Mesh;
use thinshell_solver::{IterationHessian, Origin, SolverError, State, StepKind};
use thinshell_system::{ShellIntegrator, ShellProblem, ShellSystem};

pub use build::SimulationBuilder;
pub use error::BuildError;
pub use path::{Monitor, PathRecord};
pub use rest_edit::RestEditError;

use crate::scene::schema::{Effect, IntegratorKind, LoadRamp};

/// What one step did (also one row of `steps.csv`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct StepRecord {
    /// Step number, starting at 1.
    pub step: usize,
    /// Time at the end of the step, s (static: pseudo-time).
    pub time: f64,
    /// Energies at the end of the step, J (damping: of the step just taken).
    pub energy: EnergyTerms,
    /// Kinetic energy ½ vᵀΛv at the end of the step, J (0 for static solves).
    pub kinetic: f64,
    /// Newton iterations (0 for explicit Euler).
    pub newton_iterations: usize,
    /// Line-search backtracks.
    pub backtracks: usize,
    /// Factorisations that needed a diagonal shift.
    pub regularizations: usize,
    /// Final relative residual ‖∇Φ‖∞ / force scale (0 for explicit Euler).
    pub residual: f64,
    /// Load factor λ of the step (static load ramps; 1 for dynamic integrators).
    pub load_factor: f64,
    /// Newton iterations that used the Gauss–Newton (PSD) Hessian instead of the exact one.
    pub gauss_newton_iterations: usize,
    /// Newton iterations that took a trust-region step on the shifted exact Hessian (it was
    /// indefinite there).
    pub shifted_iterations: usize,
    /// Newton iterations that stepped along a direction of negative curvature (leaving a
    /// saddle).
    pub negative_curvature_iterations: usize,
    /// Newton steps tried and rejected (not in `newton_iterations`; they count against the
    /// iteration limit).
    pub rejected_steps: usize,
    /// Static steps: whether the equilibrium is a minimum (smallest eigenvalue of the exact
    /// Hessian positive); `false` is a saddle or maximum. `None` for dynamic steps.
    pub stable: Option<bool>,
    /// Static steps: that smallest eigenvalue, relative to each unknown's own stiffness
    /// (`thinshell_solver::Stability`); it crosses 0 at a critical load. `None` for dynamic
    /// steps.
    pub min_eigenvalue: Option<f64>,
    /// Path-following steps (`[path]`): the step's path quantities; `None` otherwise.
    pub path: Option<PathRecord>,
    /// Scenes with the `contact` effect: the contact term at the end of the step; `None`
    /// otherwise.
    pub contact: Option<ContactRecord>,
    /// Numeric factorisations of the step's Newton solve (fewer with
    /// `integrator.newton.reuse_factor`).
    pub factorizations: usize,
    /// CG iterations of the step (factor reuse, iterative fallback).
    pub cg_iterations: usize,
    /// The step's Newton solve used the iterative fallback (the Cholesky factor did not fit in
    /// the memory budget).
    pub iterative: bool,
    /// Wall time of the step, s.
    pub wall_s: f64,
    /// Of which: energy assembly, s.
    pub assembly_s: f64,
    /// Of which: factorisation, s.
    pub factorization_s: f64,
    /// Of which: triangular solves, s.
    pub solve_s: f64,
    /// Of which: energy-only evaluations of the line search (backtracked trials), s.
    pub line_search_s: f64,
    /// Of which: growth updates (rest forms, masses, stimulus step), s.
    pub growth_s: f64,
    /// Of which: writing output (frames, checkpoints), s; filled in by the writer
    /// ([`StepRecord::add_output`]), 0 from [`Simulation::step`].
    pub output_s: f64,
    /// Of which: everything else (set-up, stability check, energies, vector work), s: the
    /// remainder, so that the parts sum to `wall_s`.
    pub other_s: f64,
}

/// The contact term at the end of a step (the `contact_*` columns of `steps.csv`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ContactRecord {
    /// Pairs with a gap below d̂ (self pairs and vertex–obstacle pairs).
    pub active_pairs: usize,
    /// The smallest gap between surfaces (m; thickness offsets subtracted) over the active
    /// self pairs and every vertex–obstacle pair; `None` when there is neither.
    pub min_gap: Option<f64>,
    /// Barrier energy κ Σ b (J), not in `energy` (which holds the shell's terms).
    pub energy: f64,
    /// Self pairs of the step's last Newton Hessian that entered block-diagonally because
    /// their couplings were outside the Hessian pattern (0: the Hessian was exact).
    pub approximated_pairs: usize,
    /// Rebuilds of the self-contact Hessian pattern so far.
    pub pattern_rebuilds: usize,
}

impl From<thinshell_system::ContactStats> for ContactRecord {
    fn from(s: thinshell_system::ContactStats) -> Self {
        ContactRecord {
            active_pairs: s.active_pairs,
            min_gap: s.min_gap.is_finite().then_some(s.min_gap),
            energy: s.energy,
            approximated_pairs: s.approximated_pairs,
            pattern_rebuilds: s.pattern_rebuilds,
        }
    }
}

/// The contact term over a run (`summary.json`'s `contact`; kept in checkpoints).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct ContactTotals {
    /// The most active pairs of any step.
    pub max_active_pairs: usize,
    /// The smallest gap of any step's end state (m; `None` while no pair was a candidate).
    pub min_gap_m: Option<f64>,
    /// Steps whose last Newton Hessian approximated some self pairs.
    pub approximated_steps: usize,
    /// Rebuilds of the self-contact Hessian pattern (of the last step counted).
    pub pattern_rebuilds: usize,
}

impl ContactTotals {
    /// Counts one step.
    pub fn add(&mut self, c: &ContactRecord) {
        self.max_active_pairs = self.max_active_pairs.max(c.active_pairs);
        self.min_gap_m = match (self.min_gap_m, c.min_gap) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self.approximated_steps += usize::from(c.approximated_pairs > 0);
        self.pattern_rebuilds = c.pattern_rebuilds;
    }
}

impl StepRecord {
    /// Adds `seconds` of output writing to the step's wall time.
    pub fn add_output(&mut self, seconds: f64) {
        self.output_s += seconds;
        self.wall_s += seconds;
    }
}

/// Receives progress; every method has a default that does nothing.
pub trait Observer {
    /// Before the first step (the initial state).
    fn start(&mut self, _sim: &Simulation) {}
    /// After every successful step.
    fn step(&mut self, _sim: &Simulation, _record: &StepRecord) {}
}

/// An observer that ignores everything.
pub struct NoObserver;
impl Observer for NoObserver {}

/// Outcome of [`Simulation::run`].
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    /// Steps completed.
    pub steps: usize,
    /// Steps requested.
    pub steps_requested: usize,
    /// True when stopped early by the stop flag (Ctrl-C).
    pub interrupted: bool,
    /// Final time, s.
    pub time: f64,
    /// Energies at the end, J.
    pub final_energy: EnergyTerms,
    /// Newton iterations over the run.
    pub newton_iterations: usize,
    /// Of which with the Gauss–Newton (PSD) Hessian.
    pub gauss_newton_iterations: usize,
    /// Static runs: whether the last equilibrium is a minimum (`None` for dynamic runs or no
    /// step).
    pub stable: Option<bool>,
    /// Static steps (numbers) whose equilibrium is not a minimum.
    pub unstable_steps: Vec<usize>,
    /// Wall time of the run, s.
    pub wall_s: f64,
}

/// A step that failed; the simulation keeps the last good state.
#[derive(Debug, thiserror::Error)]
#[error("step {step} (t = {time:e} s) failed: {source}")]
pub struct StepError {
    /// The step that failed.
    pub step: usize,
    /// Time at the start of the failed step, s.
    pub time: f64,
    /// Why.
    #[source]
    pub source: StepFailure,
}

impl StepError {
    /// Whether the step stopped because its cancel flag was set ([`Simulation::set_cancel`]),
    /// not because it failed.
    pub fn is_cancelled(&self) -> bool {
        matches!(
            self.source,
            StepFailure::Solver(SolverError::Cancelled { .. })
        )
    }
}

/// What failed in a step.
#[derive(Debug, thiserror::Error)]
pub enum StepFailure {
    /// The elastic solve (a Newton failure carries its residual history and last iterate).
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// The growth update or the stimulus step.
    #[error("growth: {0}")]
    Growth(#[from] GrowthError),
}

/// A built simulation: the shell system (mesh, energy terms, rest state, boundary conditions,
/// loads), its state and the integrator the scene chose.
pub struct Simulation {
    pub(crate) name: String,
    pub(crate) effects: Vec<Effect>,
    pub(crate) x_ref: Vec<Vector3<f64>>,
    pub(crate) system: ShellSystem,
    pub(crate) state: State,
    pub(crate) integrator: Box<ShellIntegrator>,
    pub(crate) dt: f64,
    pub(crate) steps_done: usize,
    pub(crate) steps_total: usize,
    pub(crate) energy: EnergyTerms,
    /// Energy of the start state against the rest forms of the initial stimulus (growth only).
    pub(crate) energy_grown: Option<EnergyTerms>,
    pub(crate) growth: Option<Growth>,
    pub(crate) load_ramp: LoadRamp,
    /// Load factor λ of the current state (static: 0 before the first step).
    pub(crate) load_factor: f64,
    /// Path following (`[path]`), instead of the load ramp.
    pub(crate) path: Option<path::PathRun>,
}

impl Simulation {
    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The mesh (connectivity and reference positions).
    pub fn mesh(&self) -> &Mesh {
        self.system.mesh()
    }
    /// Current positions, m.
    pub fn positions(&self) -> &[Vector3<f64>] {
        &self.state.x
    }
    /// Current edge-director angles φ_e (rad, one per edge) when the bending form has edge
    /// unknowns; empty otherwise (and before the first step, meaning all 0).
    pub fn edge_angles(&self) -> &[f64] {
        &self.state.phi
    }
    /// Current velocities, m/s.
    pub fn velocities(&self) -> &[Vector3<f64>] {
        &self.state.v
    }
    /// Positions of the mesh as given (the reference configuration), m.
    pub fn reference_positions(&self) -> &[Vector3<f64>] {
        &self.x_ref
    }
    /// Current time, s.
    pub fn time(&self) -> f64 {
        self.state.t
    }
    /// Steps completed.
    pub fn steps_done(&self) -> usize {
        self.steps_done
    }
    /// Steps the scene asks for.
    pub fn steps_total(&self) -> usize {
        self.steps_total
    }
    /// Energies of the current state, J. Before the first step: the start state's elastic
    /// energies as [`ShellSystem::energy`] gives them (edge angles at their minimiser, clamps
    /// held), against the rest forms before growth (see [`Simulation::initial_energy_grown`]);
    /// NaN when the memory budget refused the angle relaxation's factor (the first step then
    /// meets the same budget).
    pub fn energy(&self) -> EnergyTerms {
        self.energy
    }
    /// Growth scenes: energies (J) of the start state against the rest forms of the initial
    /// stimulus, the grown rest state the first step solves against; `None` without growth.
    pub fn initial_energy_grown(&self) -> Option<EnergyTerms> {
        self.energy_grown
    }
    /// The effects switched on.
    pub fn effects(&self) -> &[Effect] {
        &self.effects
    }
    /// Number of unknowns (free coordinates).
    pub fn n_unknowns(&self) -> usize {
        self.system.dofs().n_free()
    }
    /// The energy terms evaluated.
    pub fn model(&self) -> &ShellModel {
        self.system.model()
    }

    /// The shell system and the current positions (m), taking the simulation apart (e.g. for
    /// `thinshell_design::Forward`, which solves its statics itself).
    pub fn into_system(self) -> (ShellSystem, Vec<Vector3<f64>>) {
        (self.system, self.state.x)
    }

    /// The shell system (mesh, model, rest state, boundary conditions, loads).
    pub fn system(&self) -> &ShellSystem {
        &self.system
    }
    /// Mutable access to the shell system, for callers that change rest forms, loads or
    /// boundary conditions between steps themselves (growth, when on, rewrites the rest forms
    /// whenever its stimulus changes).
    pub fn system_mut(&mut self) -> &mut ShellSystem {
        &mut self.system
    }
    /// The integrator's kind (derived from the integrator itself).
    pub fn integrator(&self) -> IntegratorKind {
        match self.integrator.kind() {
            StepKind::Static => IntegratorKind::Static,
            StepKind::Implicit => IntegratorKind::Implicit,
            StepKind::Explicit => IntegratorKind::Explicit,
        }
    }
    /// Time step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// How a static scene's loads grow over its steps (`LoadRamp::None` for dynamic ones).
    pub fn load_ramp(&self) -> LoadRamp {
        self.load_ramp
    }
    /// Load factor λ of the current state: the fraction of the scene's loads (forces,
    /// pressure, prescribed displacement) it is in equilibrium with (static solves: 0 before
    /// the first step); 1 for dynamic integrators.
    pub fn load_factor(&self) -> f64 {
        self.load_factor
    }
    /// Load factor λ_k that static step `k` (1-based) solves for: k/N with a linear ramp over
    /// N steps, else 1.
    pub fn load_factor_of_step(&self, k: usize) -> f64 {
        match self.load_ramp {
            LoadRamp::Linear if self.integrator.is_static() && self.steps_total > 0 => {
                (k.min(self.steps_total) as f64) / self.steps_total as f64
            }
            _ => 1.0,
        }
    }
    /// Time (s) at which a static solve at load factor λ evaluates the prescribed motion
    /// x₀ + t·v: λ·N·Δt, so that the whole prescribed displacement N·Δt·v is reached at λ = 1
    /// (with a linear ramp this is the end of step k, k·Δt).
    fn prescribed_time(&self, lambda: f64) -> f64 {
        lambda * self.steps_total as f64 * self.dt
    }
    /// Sets (or clears) the observer called after every accepted Newton iteration of the
    /// following steps (progress inside a long solve); explicit steps never call it.
    pub fn set_newton_progress(&mut self, hook: Option<thinshell_solver::ProgressHook>) {
        self.integrator.set_progress(hook);
    }

    /// Sets (or clears) the flag that cancels a running step's Newton solve before its next
    /// iteration: the step then fails with [`SolverError::Cancelled`] and the state stays at
    /// the last completed step ([`Simulation::run`] reports that as an interruption). The
    /// owner clears the flag before stepping again.
    pub fn set_cancel(&mut self, flag: Option<thinshell_solver::CancelFlag>) {
        self.integrator.set_cancel(flag);
    }

    /// The growth coupling, when the scene has the `growth` effect.
    pub fn growth(&self) -> Option<&Growth> {
        self.growth.as_ref()
    }

    /// Kinetic energy ½ Σ λ_i |v_i|², J.
    pub fn kinetic_energy(&self) -> f64 {
        self.system
            .mass()
            .iter()
            .zip(&self.state.v)
            .map(|(m, v)| 0.5 * m * v.norm_squared())
            .sum()
    }

    /// Runs the remaining steps, calling `observer` after each; stops early (cleanly, with the
    /// state of the last completed step) when `stop` becomes true.
    pub fn run(
        &mut self,
        observer: &mut dyn Observer,
        stop: &AtomicBool,
    ) -> Result<RunSummary, StepError> {
        let t0 = Instant::now();
        observer.start(self);
        let mut iterations = 0;
        let mut gauss_newton = 0;
        let mut stable = None;
        let mut unstable_steps = Vec::new();
        let mut interrupted = false;
        while self.steps_done < self.steps_total {
            if stop.load(Ordering::SeqCst) {
                interrupted = true;
                break;
            }
            let record = match self.step() {
                Ok(r) => r,
                Err(e) if e.is_cancelled() => {
                    interrupted = true;
                    break;
                }
                Err(e) => return Err(e),
            };
            iterations += record.newton_iterations;
            gauss_newton += record.gauss_newton_iterations;
            stable = record.stable;
            if record.stable == Some(false) {
                unstable_steps.push(record.step);
            }
            observer.step(self, &record);
        }
        Ok(RunSummary {
            steps: self.steps_done,
            steps_requested: self.steps_total,
            interrupted,
            time: self.state.t,
            final_energy: self.energy,
            newton_iterations: iterations,
            gauss_newton_iterations: gauss_newton,
            stable,
            unstable_steps,
            wall_s: t0.elapsed().as_secs_f64(),
        })
    }

    /// Takes one step with the scene's integrator; on failure the state is unchanged. With
    /// `[path]` the step is one path-following step instead (the load factor is an unknown).
    ///
    /// With growth, the step is: rest forms (and masses, if the stimulus adds mass) from the
    /// current stimulus → elastic step → stimulus step. A static step solves at the load factor
    /// of [`Simulation::load_factor_of_step`], starting from the previous equilibrium. A static
    /// step whose Newton solve fails after the rest forms or the load factor changed is retried
    /// by continuation: rest forms and load factor move from their previous to their new values
    /// in up to 2⁶ sub-steps.
    pub fn step(&mut self) -> Result<StepRecord, StepError> {
        if self.path.is_some() {
            return self.path_step();
        }
        let start = Instant::now();
        let step = self.steps_done + 1;
        let time = self.state.t;
        let fail = |source: StepFailure| StepError { step, time, source };
        let mut previous_rest = None;
        let mut growth_time = Duration::ZERO;
        let growth_start = Instant::now();
        if let Some(g) = &mut self.growth {
            let mut rest = self.system.rest().clone();
            if g.update_rest(&mut rest).map_err(|e| fail(e.into()))? {
                previous_rest = Some(self.system.set_rest(rest).map_err(|e| fail(e.into()))?);
            }
            if let Some(mass) = g
                .update_mass(self.system.mesh(), &self.system.model().material)
                .map_err(|e| fail(e.into()))?
            {
                self.system.set_mass(mass).map_err(|e| fail(e.into()))?;
            }
        }
        growth_time += growth_start.elapsed();
        let static_solve = self.integrator.is_static();
        let lambda_prev = self.load_factor;
        let lambda = self.load_factor_of_step(step);
        if static_solve {
            self.system
                .set_load_factor(lambda)
                .map_err(|e| fail(e.into()))?;
            // The static integrator evaluates prescribed motion at the state's time.
            self.state.t = self.prescribed_time(lambda);
        }
        // A static step whose rest forms or loads changed is walked to from the last step's
        // problem if its one-shot solve fails (`Static`'s continuation).
        let origin =
            (static_solve && (previous_rest.is_some() || lambda != lambda_prev)).then(|| Origin {
                problem: ShellProblem {
                    rest: previous_rest,
                    load_factor: lambda_prev,
                },
                t: self.prescribed_time(lambda_prev),
            });
        let result = self
            .integrator
            .step_from(&mut self.system, &mut self.state, origin.as_ref());
        let report = match result {
            Ok(r) => r,
            Err(e) => {
                self.state.t = time;
                if static_solve {
                    // Back to the loads of the last good state (cannot fail: it was set before).
                    let _ = self.system.set_load_factor(lambda_prev);
                }
                return Err(fail(e.into()));
            }
        };
        self.load_factor = lambda;
        if let Some(g) = &mut self.growth {
            let t = Instant::now();
            g.advance(time, self.dt).map_err(|e| fail(e.into()))?;
            growth_time += t.elapsed();
        }
        if static_solve {
            // Quasi-static: the pseudo-time advances by one step per solve.
            self.state.t = time + self.dt;
        }
        self.steps_done = step;
        self.energy = report.energies;
        let mut record = StepRecord {
            step,
            time: self.state.t,
            energy: self.energy,
            kinetic: self.kinetic_energy(),
            load_factor: lambda,
            ..StepRecord::default()
        };
        if let Some(n) = &report.newton {
            record.newton_iterations = n.iterations;
            record.backtracks = n.backtracks;
            record.factorizations = n.factorizations;
            record.cg_iterations = n.cg_iterations;
            record.iterative = n.linear_solver != thinshell_solver::LinearSolver::Direct;
            record.regularizations = n.regularizations.len();
            record.residual = n.residuals.last().copied().unwrap_or(0.0);
            let count = |k: IterationHessian| n.hessians.iter().filter(|h| **h == k).count();
            record.gauss_newton_iterations = count(IterationHessian::Psd);
            record.shifted_iterations = count(IterationHessian::Shifted);
            record.negative_curvature_iterations = count(IterationHessian::NegativeCurvature);
            record.rejected_steps = n.rejected_steps;
            record.assembly_s = secs(n.timings.assembly);
            record.factorization_s = secs(n.timings.factorization);
            record.solve_s = secs(n.timings.solve);
            record.line_search_s = secs(n.timings.line_search);
        }
        record.growth_s = secs(growth_time);
        record.stable = report.stable;
        record.contact = report.contact.map(ContactRecord::from);
        record.min_eigenvalue = report.stability.as_ref().map(|s| s.min_eigenvalue);
        record.wall_s = secs(start.elapsed());
        record.other_s = record.wall_s
            - (record.assembly_s
                + record.factorization_s
                + record.solve_s
                + record.line_search_s
                + record.growth_s);
        Ok(record)
    }
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}
