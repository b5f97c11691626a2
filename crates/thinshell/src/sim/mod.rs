//! Turning a [`Scene`] into a running simulation: only the terms and loads the scene's effects
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
mod objective;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use serde::Serialize;
use thinshell_energy::{
    Assembler, DampingState, DofMap, EnergyTerms, EvalOutput, HessianMode, RestState, ShellModel,
};
use thinshell_mesh::Mesh;
use thinshell_solver::{NewtonSettings, NewtonWorkspace, Objective, SolverError, newton_solve};

pub use build::BuildError;
pub use objective::STATIC_SHIFT;
use objective::StepObjective;

use crate::scene::schema::{Effect, IntegratorKind};

/// Energies by term, J.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Energies {
    /// Stretching energy.
    pub stretch: f64,
    /// Bending energy.
    pub bend: f64,
    /// Kelvin–Voigt damping energy of the step.
    pub damping: f64,
}

impl Energies {
    /// Elastic energy (stretch + bend), J.
    pub fn elastic(&self) -> f64 {
        self.stretch + self.bend
    }
}

impl From<EnergyTerms> for Energies {
    fn from(e: EnergyTerms) -> Self {
        Energies {
            stretch: e.stretch,
            bend: e.bend,
            damping: e.damping,
        }
    }
}

/// What one step did (also one row of `steps.csv`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct StepRecord {
    /// Step number, starting at 1.
    pub step: usize,
    /// Time at the end of the step, s (static: pseudo-time).
    pub time: f64,
    /// Energies at the end of the step, J (damping: of the step just taken).
    pub energy: Energies,
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
    /// Wall time of the step, s.
    pub wall_s: f64,
    /// Of which: energy assembly, s.
    pub assembly_s: f64,
    /// Of which: factorisation, s.
    pub factorization_s: f64,
    /// Of which: triangular solves, s.
    pub solve_s: f64,
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
    pub final_energy: Energies,
    /// Newton iterations over the run.
    pub newton_iterations: usize,
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
    /// Why (a Newton failure carries its residual history).
    #[source]
    pub source: SolverError,
}

/// A built simulation: mesh, state, energy terms, loads and integrator settings.
pub struct Simulation {
    pub(crate) name: String,
    pub(crate) mesh: Mesh,
    pub(crate) effects: Vec<Effect>,
    pub(crate) x_ref: Vec<Vector3<f64>>,
    pub(crate) x: Vec<Vector3<f64>>,
    pub(crate) v: Vec<Vector3<f64>>,
    pub(crate) t: f64,
    pub(crate) steps_done: usize,
    pub(crate) steps_total: usize,
    pub(crate) dt: f64,
    pub(crate) kind: IntegratorKind,
    pub(crate) model: ShellModel,
    pub(crate) rest: RestState,
    /// Lumped mass per vertex, kg (empty without inertia).
    pub(crate) mass: Vec<f64>,
    pub(crate) dofs: DofMap,
    pub(crate) assembler: Assembler,
    pub(crate) workspace: Option<NewtonWorkspace>,
    pub(crate) settings: NewtonSettings,
    pub(crate) hessian_mode: HessianMode,
    /// External force per coordinate (3·n), N.
    pub(crate) force: Vec<f64>,
    pub(crate) force_scale: f64,
    pub(crate) length_scale: f64,
    pub(crate) grad_full: Vec<f64>,
    pub(crate) energy: EnergyTerms,
}

impl Simulation {
    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The mesh (connectivity and reference positions).
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }
    /// Current positions, m.
    pub fn positions(&self) -> &[Vector3<f64>] {
        &self.x
    }
    /// Current velocities, m/s.
    pub fn velocities(&self) -> &[Vector3<f64>] {
        &self.v
    }
    /// Positions of the mesh as given (the reference configuration), m.
    pub fn reference_positions(&self) -> &[Vector3<f64>] {
        &self.x_ref
    }
    /// Current time, s.
    pub fn time(&self) -> f64 {
        self.t
    }
    /// Steps completed.
    pub fn steps_done(&self) -> usize {
        self.steps_done
    }
    /// Steps the scene asks for.
    pub fn steps_total(&self) -> usize {
        self.steps_total
    }
    /// Energies of the current state, J.
    pub fn energy(&self) -> EnergyTerms {
        self.energy
    }
    /// The effects switched on.
    pub fn effects(&self) -> &[Effect] {
        &self.effects
    }
    /// Number of unknowns (free coordinates).
    pub fn n_unknowns(&self) -> usize {
        self.dofs.n_free()
    }
    /// The energy terms evaluated.
    pub fn model(&self) -> &ShellModel {
        &self.model
    }
    /// The integrator.
    pub fn integrator(&self) -> IntegratorKind {
        self.kind
    }
    /// Time step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Kinetic energy ½ Σ λ_i |v_i|², J.
    pub fn kinetic_energy(&self) -> f64 {
        self.mass
            .iter()
            .zip(&self.v)
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
        let mut interrupted = false;
        while self.steps_done < self.steps_total {
            if stop.load(Ordering::SeqCst) {
                interrupted = true;
                break;
            }
            let record = self.step()?;
            iterations += record.newton_iterations;
            observer.step(self, &record);
        }
        Ok(RunSummary {
            steps: self.steps_done,
            steps_requested: self.steps_total,
            interrupted,
            time: self.t,
            final_energy: self.energy.into(),
            newton_iterations: iterations,
            wall_s: t0.elapsed().as_secs_f64(),
        })
    }

    /// Takes one step with the scene's integrator.
    pub fn step(&mut self) -> Result<StepRecord, StepError> {
        let start = Instant::now();
        let step = self.steps_done + 1;
        let time = self.t;
        let fail = |source| StepError { step, time, source };
        let mut record = match self.kind {
            IntegratorKind::Explicit => self.explicit_step().map_err(fail)?,
            IntegratorKind::Implicit | IntegratorKind::Static => {
                self.newton_step().map_err(fail)?
            }
        };
        self.steps_done = step;
        self.t += self.dt;
        record.step = step;
        record.time = self.t;
        record.energy = self.energy.into();
        record.kinetic = self.kinetic_energy();
        record.wall_s = start.elapsed().as_secs_f64();
        Ok(record)
    }

    fn damping_state(&self) -> Result<Option<DampingState>, SolverError> {
        if !self.model.terms.damping {
            return Ok(None);
        }
        DampingState::from_positions(&self.mesh, &self.x, self.model.sff, self.dt)
            .map(Some)
            .map_err(|e| SolverError::Objective(e.to_string()))
    }

    /// Implicit Euler or a static solve by Newton.
    fn newton_step(&mut self) -> Result<StepRecord, SolverError> {
        let damping = self.damping_state()?;
        let free = self.dofs.free_coordinates().to_vec();
        let coord = |x: &[Vector3<f64>], c: usize| x[c / 3][c % 3];
        let x_prev = self.x.clone();
        let dynamic = self.kind == IntegratorKind::Implicit;
        // x̃ = xⁿ + Δt vⁿ is both the inertia target and the initial guess.
        let x_tilde: Vec<f64> = free
            .iter()
            .map(|&c| {
                if dynamic {
                    coord(&self.x, c) + self.dt * coord(&self.v, c)
                } else {
                    coord(&self.x, c)
                }
            })
            .collect();
        let mass_dof: Vec<f64> = if dynamic {
            free.iter().map(|&c| self.mass[c / 3]).collect()
        } else {
            Vec::new()
        };
        let mut unknowns = x_tilde.clone();
        let mut x_full = self.x.clone();
        let mut objective = StepObjective {
            assembler: &mut self.assembler,
            model: &self.model,
            rest: &self.rest,
            damping: damping.as_ref(),
            dofs: &self.dofs,
            x_full: &mut x_full,
            grad_full: &mut self.grad_full,
            force: &self.force,
            inertia: dynamic.then_some((&mass_dof[..], &x_tilde[..], self.dt)),
            hessian_mode: self.hessian_mode,
            force_scale: self.force_scale,
            length_scale: self.length_scale,
            last_energy: EnergyTerms::default(),
        };
        if self.workspace.is_none() {
            self.workspace = Some(NewtonWorkspace::new(&objective, &self.settings)?);
        }
        let ws = self
            .workspace
            .as_mut()
            .ok_or_else(|| SolverError::Objective("no Newton workspace".into()))?;
        let report = newton_solve(&mut objective, &mut unknowns, &self.settings, ws)?;
        // Energies of the accepted state (the last evaluation may have been a trial point).
        objective.value(&unknowns)?;
        let energy = objective.last_energy;
        for (d, &c) in free.iter().enumerate() {
            self.x[c / 3][c % 3] = unknowns[d];
        }
        if dynamic {
            for (i, (v, (x, xp))) in self
                .v
                .iter_mut()
                .zip(self.x.iter().zip(&x_prev))
                .enumerate()
            {
                *v = (x - xp) / self.dt;
                let _ = i;
            }
        }
        self.energy = energy;
        let timings = report.timings;
        Ok(StepRecord {
            newton_iterations: report.iterations,
            backtracks: report.backtracks,
            regularizations: report.regularizations.len(),
            residual: report.residuals.last().copied().unwrap_or(0.0),
            assembly_s: secs(timings.assembly),
            factorization_s: secs(timings.factorization),
            solve_s: secs(timings.solve),
            ..StepRecord::default()
        })
    }

    /// Symplectic Euler: vⁿ⁺¹ = vⁿ + Δt Λ⁻¹ F(xⁿ), xⁿ⁺¹ = xⁿ + Δt vⁿ⁺¹; pinned coordinates keep
    /// zero velocity.
    fn explicit_step(&mut self) -> Result<StepRecord, SolverError> {
        let damping = self.damping_state()?;
        let t = Instant::now();
        let energy = self
            .assembler
            .evaluate(
                &self.model,
                &self.x,
                &self.rest,
                damping.as_ref(),
                EvalOutput {
                    gradient: Some(&mut self.grad_full),
                    hessian: None,
                },
            )
            .map_err(|e| SolverError::Objective(e.to_string()))?;
        let assembly = t.elapsed();
        for &c in self.dofs.free_coordinates() {
            let (i, k) = (c / 3, c % 3);
            let f = self.force[c] - self.grad_full[c];
            self.v[i][k] += self.dt * f / self.mass[i];
            self.x[i][k] += self.dt * self.v[i][k];
        }
        if let Some((i, p)) = self
            .x
            .iter()
            .enumerate()
            .find(|(_, p)| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
        {
            return Err(SolverError::Objective(format!(
                "explicit Euler diverged: vertex {i} position {p:?} (time step above the stability limit?)"
            )));
        }
        self.energy = energy;
        Ok(StepRecord {
            assembly_s: secs(assembly),
            ..StepRecord::default()
        })
    }
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}
