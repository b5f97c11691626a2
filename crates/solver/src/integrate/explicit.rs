//! Symplectic Euler: [`ExplicitEuler`] takes `vⁿ⁺¹ = vⁿ + Δt Λ⁻¹(F_ext − ∇E(xⁿ))`,
//! `xⁿ⁺¹ = xⁿ + Δt vⁿ⁺¹`; conditionally stable. The model's massless extra unknowns are relaxed
//! at xⁿ first ([`Model::explicit_force`]).

use super::model::{Model, State};
use super::retry::{check_dt, check_state};
use super::{Integrator, Origin, StepControl, StepKind, StepReport};
use crate::SolverError;

/// Symplectic (semi-implicit) Euler with lumped masses.
///
/// With massless extra unknowns (a shell's edge-director angles) the model relaxes them at xⁿ
/// before the force is taken: the force is then the gradient of the reduced energy
/// min_φ E(x, φ), so the scheme keeps the energy behaviour of symplectic Euler.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExplicitEuler {
    /// Time step Δt (s).
    pub dt: f64,
}

impl StepControl for ExplicitEuler {
    fn kind(&self) -> StepKind {
        StepKind::Explicit
    }
}

impl<M: Model> Integrator<M> for ExplicitEuler {
    fn step_from(
        &mut self,
        model: &mut M,
        state: &mut State,
        _origin: Option<&Origin<M::Problem>>,
    ) -> Result<StepReport<M::Energies, M::Contact>, SolverError> {
        let dt = self.dt;
        check_dt(dt)?;
        check_state(model, state)?;
        let mut phi1 = state.phi.clone();
        let mut force = vec![0.0; 3 * state.x.len()];
        let energies = model.explicit_force(state, dt, &mut phi1, &mut force)?;
        let t1 = state.t + dt;
        let mut x1 = state.x.clone();
        let mut v1 = state.v.clone();
        let mass = model.point_masses();
        for (vtx, (x, v)) in x1.iter_mut().zip(v1.iter_mut()).enumerate() {
            for a in 0..3 {
                let c = 3 * vtx + a;
                if model.is_free_coordinate(c) {
                    v[a] += dt * force[c] / mass[vtx];
                    x[a] += dt * v[a];
                } else {
                    v[a] = 0.0;
                }
            }
        }
        model.apply_prescribed(&mut x1, t1)?;
        for i in model.prescribed_points() {
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
        model.accept(&state.phi);
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
            contact: model.contact_stats(&state.x),
            continuation_stages: 0,
            continuation_checked: false,
            potential: None,
            stability: None,
        })
    }
}
