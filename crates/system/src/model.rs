//! The shell system as the solver's [`Model`]: what the integrators ask of a shell.

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{EnergyTerms, EvalOutput, RestState};
use thinshell_solver::{Model, ObjectiveOptions, SolverError, State, StepObjective};

use crate::angles::AngleSettings;
use crate::contact::ContactStats;
use crate::loads::{add_pressure_gradient, unit_axis};
use crate::objective::ShellObjective;
use crate::system::ShellSystem;

/// The problem a static solve of a [`ShellSystem`] solves: its rest forms and load factor, what
/// a continuation walks between ([`Static::continuation`](thinshell_solver::Static::continuation),
/// [`Origin`](thinshell_solver::Origin)).
#[derive(Clone, Debug, PartialEq)]
pub struct ShellProblem {
    /// The rest forms; `None`: those the system has (unchanged by a walk).
    pub rest: Option<RestState>,
    /// The load factor λ (dimensionless).
    pub load_factor: f64,
}

impl Model for ShellSystem {
    type Objective<'a> = ShellObjective<'a>;
    type Energies = EnergyTerms;
    type Contact = ContactStats;
    type Problem = ShellProblem;

    fn n_points(&self) -> usize {
        self.mesh.n_vertices()
    }

    fn n_extra(&self) -> usize {
        self.n_edge_angles()
    }

    fn gather(&self, x: &[Vector3<f64>], phi: &[f64]) -> Vec<f64> {
        ShellSystem::gather(self, x, phi)
    }

    fn scatter(&self, u: &[f64], x: &mut [Vector3<f64>], phi: &mut [f64]) {
        ShellSystem::scatter(self, u, x, phi)
    }

    fn apply_prescribed(&self, x: &mut [Vector3<f64>], t: f64) -> Result<(), SolverError> {
        self.boundary.apply_prescribed(x, t)
    }

    fn check_static(&self) -> Result<(), SolverError> {
        if self.model.terms.damping {
            return Err(SolverError::InvalidSetting {
                name: "terms.damping",
                value: 1.0,
                requirement: "a static solve has no damping (build the system without it)",
            });
        }
        Ok(())
    }

    fn static_objective(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
        options: ObjectiveOptions,
    ) -> ShellObjective<'_> {
        ShellObjective::statics(self, x, phi, options.hessian_shift, options.force_scale)
            .with_hessian(options.hessian)
    }

    fn incremental_objective(
        &mut self,
        state: &State,
        x1: &[Vector3<f64>],
        dt: f64,
        options: ObjectiveOptions,
    ) -> Result<ShellObjective<'_>, SolverError> {
        Ok(
            ShellObjective::incremental(self, state, x1, dt, options.force_scale)?
                .with_hessian(options.hessian),
        )
    }

    fn checks_collisions(&self) -> bool {
        self.contact.is_some()
    }

    fn accept(&mut self, phi: &[f64]) {
        self.keep_angles(phi);
    }

    fn energies(&mut self, x: &[Vector3<f64>], phi: &[f64]) -> Result<EnergyTerms, SolverError> {
        self.energy_at(x, phi)
    }

    fn contact_stats(&self, x: &[Vector3<f64>]) -> Option<ContactStats> {
        ShellSystem::contact_stats(self, x)
    }

    fn is_loaded(&self) -> bool {
        self.pressure() != 0.0 || self.external_forces().iter().any(|&f| f != 0.0)
    }

    fn explicit_force(
        &mut self,
        state: &State,
        dt: f64,
        phi: &mut [f64],
        force: &mut [f64],
    ) -> Result<EnergyTerms, SolverError> {
        // Damping forces use the previous configuration xⁿ − Δt vⁿ (with this step's starting
        // angles: the previous step's are not kept).
        let damping = if self.model.terms.damping {
            let prev: Vec<Vector3<f64>> = state
                .x
                .iter()
                .zip(&state.v)
                .map(|(x, v)| x - dt * v)
                .collect();
            // Through the system's assembler: its clamps enter b^prev as they enter b.
            Some(
                self.assembler
                    .damping_state(&prev, &state.phi, self.model.sff, dt)?,
            )
        } else {
            None
        };
        let n = state.x.len();
        let (mut g, energies) = if self.has_edge_unknowns() {
            let mut g = vec![0.0; self.dofs.n_coordinates()];
            let report = self.relax_edge_angles(
                &state.x,
                phi,
                damping.as_ref(),
                &AngleSettings::default(),
                Some(&mut g),
            )?;
            (g, report.energies)
        } else {
            let mut g = vec![0.0; 3 * n];
            let energies = self.assembler.evaluate(
                &self.model,
                &state.x,
                &self.rest,
                damping.as_ref(),
                EvalOutput {
                    gradient: Some(&mut g),
                    hessian: None,
                },
            )?;
            (g, energies)
        };
        add_pressure_gradient(
            &self.mesh,
            &state.x,
            self.pressure(),
            unit_axis(&self.loads),
            &mut g,
        );
        for (c, f) in force.iter_mut().enumerate().take(3 * n) {
            *f = self.f_ext[c] - g[c];
        }
        Ok(energies)
    }

    fn point_masses(&self) -> &[f64] {
        &self.mass
    }

    fn is_free_coordinate(&self, c: usize) -> bool {
        self.dofs.coordinate_dof(c).is_some()
    }

    fn prescribed_points(&self) -> Vec<usize> {
        self.boundary
            .prescribed
            .iter()
            .map(|p| p.vertex.idx())
            .collect()
    }

    fn problem(&self) -> ShellProblem {
        ShellProblem {
            rest: Some(self.rest.clone()),
            load_factor: self.load_factor,
        }
    }

    fn problem_at(&mut self, x: &[Vector3<f64>], phi: &[f64]) -> Result<ShellProblem, SolverError> {
        let own = self
            .assembler
            .damping_state(x, phi, self.model.sff, 1.0)
            .map_err(SolverError::objective)?;
        Ok(ShellProblem {
            rest: Some(RestState {
                a_bar: own.a_prev,
                b_bar: own.b_prev,
                sff: self.rest.sff,
            }),
            load_factor: 0.0,
        })
    }

    fn set_problem_between(
        &mut self,
        from: &ShellProblem,
        to: &ShellProblem,
        s: f64,
    ) -> Result<(), SolverError> {
        if let (Some(a), Some(b)) = (&from.rest, &to.rest) {
            RestState::blend(a, b, s, &mut self.rest).map_err(SolverError::objective)?;
        }
        self.set_load_factor(from.load_factor + s * (to.load_factor - from.load_factor))
    }

    fn restore_problem(&mut self, problem: ShellProblem) -> Result<(), SolverError> {
        if let Some(rest) = problem.rest {
            self.rest = rest;
        }
        self.set_load_factor(problem.load_factor)
    }
}

impl StepObjective for ShellObjective<'_> {
    type Energies = EnergyTerms;

    fn prediction(&self) -> Option<&[f64]> {
        ShellObjective::prediction(self)
    }

    fn last_energies(&self) -> EnergyTerms {
        self.last_terms
    }

    fn has_hessian_pattern(&self, h: &SparseColMat<usize, f64>) -> bool {
        self.sys.has_hessian_pattern(h)
    }
}
