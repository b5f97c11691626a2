//! The two pieces of an adjoint sensitivity of a static equilibrium in its rest forms
//! (used by `thinshell-design`): the solve with the static potential's exact Hessian, and the
//! product of the adjoint with the mixed derivative ∂²E/∂x∂(ā, b̄).

use nalgebra::Vector3;
use thinshell_energy::HessianMode;

use super::objective::ShellObjective;
use super::statics::Static;
use super::system::ShellSystem;
use crate::{Objective, SolverError};

impl Static {
    /// The adjoint λ of the static equilibrium (`x`, `phi`) for the right-hand side `rhs`:
    /// `H λ = rhs` with H the **exact** Hessian of the static potential `E − F_extᵀx − p·V`
    /// (plus contact) over the free unknowns, without the rigid-motion shift. `rhs` and λ
    /// have the full-coordinate layout (three per vertex, then one per edge with edge unknowns:
    /// ∂J/∂x in 1/m-duals, ∂J/∂φ per rad); held coordinates are ignored in `rhs` and 0 in λ.
    ///
    /// `Ok(None)` when H is not positive definite: (`x`, `phi`) is not a strict minimum and
    /// has no adjoint. Errors when the boundary leaves rigid motions free (H is singular
    /// there: hold them, e.g. with [`Boundary::rigid_motion_pins`](super::Boundary::rigid_motion_pins)).
    pub fn solve_adjoint(
        &mut self,
        system: &mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
        rhs: &[f64],
    ) -> Result<Option<Vec<f64>>, SolverError> {
        let n3 = 3 * system.dofs.n_vertices();
        let n = n3 + system.n_edge_angles();
        if rhs.len() != n {
            return Err(SolverError::DimensionMismatch {
                what: "adjoint rhs",
                expected: n,
                found: rhs.len(),
            });
        }
        let scale = system.angle_scale;
        let free: Vec<usize> = system.dofs.free_coordinates().to_vec();
        let u = system.gather(x, phi);
        let mut y: Vec<f64> = free
            .iter()
            .map(|&c| if c < n3 { rhs[c] } else { rhs[c] / scale })
            .collect();
        let mut obj = ShellObjective::statics(system, x, phi, self.hessian_shift, self.force_scale)
            .with_hessian(HessianMode::Exact);
        let rigid = obj.rigid_modes(&u).len();
        if rigid > 0 {
            return Err(SolverError::InvalidSetting {
                name: "free rigid motions",
                value: rigid as f64,
                requirement: "an adjoint needs every rigid motion held (pins, e.g. \
                              Boundary::rigid_motion_pins): the equilibrium is not unique",
            });
        }
        let ws = self.cache.fit(&obj, &self.newton)?;
        if !ws.solve_own_hessian(&mut obj, &u, &mut y)? {
            return Ok(None);
        }
        let mut lambda = vec![0.0; n];
        for (&c, v) in free.iter().zip(y) {
            lambda[c] = if c < n3 { v } else { v / scale };
        }
        Ok(Some(lambda))
    }
}

impl ShellSystem {
    /// Per face, λᵀ ∂²E/∂x∂m̄_f of the elastic energy at positions `x` and edge angles `phi`
    /// with the system's rest forms, m̄_f = (ā11, ā12, ā22, b̄11, b̄12, b̄22) of face f
    /// ([`Assembler::rest_adjoint_product`](thinshell_energy::Assembler::rest_adjoint_product);
    /// `lambda` in the layout of [`Static::solve_adjoint`]). Loads, pressure and contact do not
    /// depend on the rest forms (the masses stay those the system was built with).
    pub fn rest_adjoint_product(
        &self,
        x: &[Vector3<f64>],
        phi: &[f64],
        lambda: &[f64],
    ) -> Result<Vec<[f64; 6]>, SolverError> {
        Ok(self
            .assembler
            .rest_adjoint_product(&self.model, x, phi, &self.rest, lambda)?)
    }
}
