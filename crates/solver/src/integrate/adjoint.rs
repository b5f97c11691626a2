//! The linear solve of an adjoint sensitivity at a static equilibrium.

use nalgebra::Vector3;
use thinshell_energy::HessianMode;

use super::model::{Model, ObjectiveOptions};
use super::statics::Static;
use crate::{Objective, SolverError};

impl Static {
    /// Solves `H y = rhs` in place in the model's free unknowns (Newton's `u`, the layout of
    /// [`Model::gather`]), H the **exact** Hessian of the static potential at positions `x` and
    /// extra unknowns `phi` without the rigid-motion shift: the adjoint of an equilibrium.
    /// `Ok(false)` (with `rhs` unspecified) when H is not positive definite — the point is not
    /// a strict minimum and has no adjoint. Errors when the model leaves rigid motions free (H
    /// is singular there; the equilibrium is not unique).
    pub fn solve_own_hessian<M: Model>(
        &mut self,
        model: &mut M,
        x: &[Vector3<f64>],
        phi: &[f64],
        rhs: &mut [f64],
    ) -> Result<bool, SolverError> {
        let u = model.gather(x, phi);
        let options = ObjectiveOptions {
            hessian: HessianMode::Exact,
            hessian_shift: self.hessian_shift,
            force_scale: self.force_scale,
        };
        let mut obj = model.static_objective(x, phi, options);
        let rigid = obj.rigid_modes(&u).len();
        if rigid > 0 {
            return Err(SolverError::InvalidSetting {
                name: "free rigid motions",
                value: rigid as f64,
                requirement: "an adjoint needs every rigid motion held (pins, e.g. \
                              Boundary::rigid_motion_pins): the equilibrium is not unique",
            });
        }
        self.cache
            .fit(&obj, &self.newton)
            .and_then(|ws| ws.solve_own_hessian(&mut obj, &u, rhs))
    }
}
