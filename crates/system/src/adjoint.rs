//! The two pieces of an adjoint sensitivity of a static equilibrium in its rest forms (used
//! by `thinshell-design`): the solve with the static potential's exact Hessian, in the full
//! coordinates, and the product of the adjoint with the mixed derivative ∂²E/∂x∂(ā, b̄).

use nalgebra::Vector3;
use thinshell_solver::{SolverError, Static};

use crate::system::ShellSystem;

impl ShellSystem {
    /// The adjoint λ of the static equilibrium (`x`, `phi`) for the right-hand side `rhs`:
    /// `H λ = rhs` with H the **exact** Hessian of the static potential `E − F_extᵀx − p·V`
    /// (plus contact) over the free unknowns, without the rigid-motion shift
    /// ([`Static::solve_own_hessian`], with `statics`'s cached factorisation). `rhs` and λ have
    /// the full-coordinate layout (three per vertex, then one per edge with edge unknowns: ∂J/∂x,
    /// ∂J/∂φ per rad); held coordinates are ignored in `rhs` and 0 in λ.
    ///
    /// `Ok(None)` when H is not positive definite: (`x`, `phi`) is not a strict minimum and
    /// has no adjoint. Errors when the boundary leaves rigid motions free (hold them, e.g. with
    /// [`Boundary::rigid_motion_pins`](crate::Boundary::rigid_motion_pins)).
    pub fn solve_adjoint(
        &mut self,
        statics: &mut Static,
        x: &[Vector3<f64>],
        phi: &[f64],
        rhs: &[f64],
    ) -> Result<Option<Vec<f64>>, SolverError> {
        let n3 = 3 * self.dofs.n_vertices();
        let n = n3 + self.n_edge_angles();
        if rhs.len() != n {
            return Err(SolverError::DimensionMismatch {
                what: "adjoint rhs",
                expected: n,
                found: rhs.len(),
            });
        }
        // Newton's unknowns are u = ℓ̄φ for the angles: ∂J/∂u = ∂J/∂φ / ℓ̄, λ_φ = λ_u / ℓ̄.
        let scale = self.angle_scale;
        let free: Vec<usize> = self.dofs.free_coordinates().to_vec();
        let mut y: Vec<f64> = free
            .iter()
            .map(|&c| if c < n3 { rhs[c] } else { rhs[c] / scale })
            .collect();
        if !statics.solve_own_hessian(self, x, phi, &mut y)? {
            return Ok(None);
        }
        let mut lambda = vec![0.0; n];
        for (&c, v) in free.iter().zip(y) {
            lambda[c] = if c < n3 { v } else { v / scale };
        }
        Ok(Some(lambda))
    }

    /// Per face, λᵀ ∂²E/∂x∂m̄_f of the elastic energy at positions `x` and edge angles `phi`
    /// with the system's rest forms, m̄_f = (ā11, ā12, ā22, b̄11, b̄12, b̄22) of face f
    /// ([`Assembler::rest_adjoint_product`](thinshell_energy::Assembler::rest_adjoint_product);
    /// `lambda` in the layout of [`ShellSystem::solve_adjoint`]). Loads, pressure and contact
    /// do not depend on the rest forms (the masses stay those the system was built with).
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
