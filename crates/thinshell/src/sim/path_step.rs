//! A path-following step of a [`Simulation`] (`[path]`; the path itself is in `path.rs`).

use std::time::Instant;

use thinshell_solver::SolverError;

use super::path::{Monitor, PathRecord};
use super::{Simulation, StepError, StepFailure, StepRecord};

impl Simulation {
    /// The monitored vertex coordinates of a path-following scene (the controlled coordinate
    /// first, then `[[path.monitor]]`); empty otherwise.
    pub fn path_monitors(&self) -> &[Monitor] {
        self.path.as_ref().map_or(&[], |p| &p.monitors)
    }

    /// Whether the scene follows a path (`[path]`).
    pub fn is_path_following(&self) -> bool {
        self.path.is_some()
    }

    /// One path step (see [`Simulation::step`]); before the first, the start state is brought
    /// to equilibrium at load factor 0 by the scene's static solve.
    pub(crate) fn path_step(&mut self) -> Result<StepRecord, StepError> {
        let start = Instant::now();
        let step = self.steps_done + 1;
        let time = self.state.t;
        let fail = |e: SolverError| StepError {
            step,
            time,
            source: StepFailure::Solver(e),
        };
        let Some(run) = self.path.as_mut() else {
            return Err(fail(SolverError::InvalidSetting {
                name: "path",
                value: 0.0,
                requirement: "the scene has no [path] table",
            }));
        };
        if !run.started {
            self.system.set_load_factor(0.0).map_err(fail)?;
            self.integrator
                .step(&mut self.system, &mut self.state)
                .map_err(fail)?;
            self.state.t = time;
            run.started = true;
        }
        let mut x = self.state.x.clone();
        let mut phi = self.state.phi.clone();
        let point = run
            .path
            .step(&mut self.system, &mut x, &mut phi)
            .map_err(fail)?;
        let energy = self.system.energy_at(&x, &phi).map_err(fail)?;
        let monitors = run
            .monitors
            .iter()
            .map(|m| x[m.vertex][m.axis] - run.x_start[m.vertex][m.axis])
            .collect();
        self.state.x = x;
        self.state.phi = phi;
        self.state.t = time + self.dt;
        self.steps_done = step;
        self.load_factor = point.load_factor;
        self.energy = energy;
        Ok(StepRecord {
            step,
            time: self.state.t,
            energy,
            newton_iterations: point.iterations,
            residual: point.residuals.last().copied().unwrap_or(0.0),
            load_factor: point.load_factor,
            stable: Some(point.stable()),
            wall_s: start.elapsed().as_secs_f64(),
            contact: self
                .system
                .contact_stats(&self.state.x)
                .map(super::ContactRecord::from),
            path: Some(PathRecord {
                load_increment: point.load_increment,
                step_length: point.step_length,
                cutbacks: point.cutbacks,
                negative_eigenvalues: point.negative_eigenvalues,
                potential: point.value,
                monitors,
            }),
            ..StepRecord::default()
        })
    }
}
