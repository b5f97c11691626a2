//! Symplectic Euler: [`ExplicitEuler`] takes `vⁿ⁺¹ = vⁿ + Δt Λ⁻¹(F_ext + p ∂V/∂x − ∇E(xⁿ))`,
//! `xⁿ⁺¹ = xⁿ + Δt vⁿ⁺¹`; conditionally stable. Edge-director angles are relaxed at xⁿ first
//! ([`ShellSystem::relax_edge_angles`]).

use nalgebra::Vector3;
use thinshell_energy::EvalOutput;

use super::angles::AngleSettings;
use super::integrator::{Integrator, StepKind, StepReport, check_dt, check_state};
use super::loads::{add_pressure_gradient, unit_axis};
use super::system::{ShellSystem, State};
use crate::SolverError;

/// Symplectic (semi-implicit) Euler with lumped masses.
///
/// With an edge-director form the massless edge angles are relaxed at xⁿ before the force is
/// taken ([`ShellSystem::relax_edge_angles`], default [`AngleSettings`]): the force is then the
/// gradient of the reduced energy min_φ E(x, φ), so the scheme keeps the energy behaviour of
/// symplectic Euler. The relaxation usually costs one to three gradient evaluations per step
/// and a refactorisation of the small angle Hessian now and then.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExplicitEuler {
    /// Time step Δt (s).
    pub dt: f64,
}

impl Integrator for ExplicitEuler {
    fn kind(&self) -> StepKind {
        StepKind::Explicit
    }

    fn step(
        &mut self,
        system: &mut ShellSystem,
        state: &mut State,
    ) -> Result<StepReport, SolverError> {
        let dt = self.dt;
        check_dt(dt)?;
        check_state(system, state)?;
        let n = state.x.len();
        // Damping forces use the previous configuration xⁿ − Δt vⁿ (with this step's starting
        // angles: the previous step's are not kept).
        let damping = if system.model.terms.damping {
            let prev: Vec<Vector3<f64>> = state
                .x
                .iter()
                .zip(&state.v)
                .map(|(x, v)| x - dt * v)
                .collect();
            // Through the system's assembler: its clamps enter b^prev as they enter b.
            Some(
                system
                    .assembler
                    .damping_state(&prev, &state.phi, system.model.sff, dt)?,
            )
        } else {
            None
        };
        let mut phi1 = state.phi.clone();
        let (mut g, energies) = if system.has_edge_unknowns() {
            let mut g = vec![0.0; system.dofs.n_coordinates()];
            let report = system.relax_edge_angles(
                &state.x,
                &mut phi1,
                damping.as_ref(),
                &AngleSettings::default(),
                Some(&mut g),
            )?;
            (g, report.energies)
        } else {
            let mut g = vec![0.0; 3 * n];
            let energies = system.assembler.evaluate(
                &system.model,
                &state.x,
                &system.rest,
                damping.as_ref(),
                EvalOutput {
                    gradient: Some(&mut g),
                    hessian: None,
                },
            )?;
            (g, energies)
        };
        add_pressure_gradient(
            &system.mesh,
            &state.x,
            system.pressure(),
            unit_axis(&system.loads),
            &mut g,
        );
        let t1 = state.t + dt;
        let mut x1 = state.x.clone();
        let mut v1 = state.v.clone();
        for (vtx, (x, v)) in x1.iter_mut().zip(v1.iter_mut()).enumerate() {
            for a in 0..3 {
                let c = 3 * vtx + a;
                if system.dofs.coordinate_dof(c).is_some() {
                    v[a] += dt * (system.f_ext[c] - g[c]) / system.mass[vtx];
                    x[a] += dt * v[a];
                } else {
                    v[a] = 0.0;
                }
            }
        }
        system.boundary.apply_prescribed(&mut x1, t1)?;
        for p in &system.boundary.prescribed {
            let i = p.vertex.idx();
            v1[i] = (x1[i] - state.x[i]) / dt;
        }
        if let Some(c) = x1
            .iter()
            .chain(&v1)
            .flat_map(|p| p.iter())
            .position(|c| !c.is_finite())
        {
            return Err(SolverError::NonFinite {
                what: "explicit state",
                iteration: 0,
                dof: Some(c),
            });
        }
        state.x = x1;
        state.v = v1;
        state.phi = phi1;
        system.keep_angles(&state.phi);
        state.t = t1;
        Ok(StepReport {
            t: t1,
            dt,
            newton: None,
            halvings: 0,
            // No Hessian: reported as exact.
            hessian: thinshell_energy::HessianMode::Exact,
            energies,
            stable: None,
            contact: system.contact_stats(&state.x),
            continuation_stages: 0,
            continuation_checked: false,
            potential: None,
            stability: None,
        })
    }
}
