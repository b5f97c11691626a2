//! Linear solves with the objective's own Hessian at a point, for adjoint sensitivities.

use super::checks::assemble;
use super::workspace::NewtonWorkspace;
use crate::linear::FactorError;
use crate::objective::Objective;
use crate::{NewtonTimings, SolverError};

impl NewtonWorkspace {
    /// Solves `H y = rhs` in place, H the objective's own Hessian at `x` **without** its
    /// diagonal shift ([`Objective::hessian_diagonal_shift`]): the exact linearisation an
    /// adjoint needs at an equilibrium. Returns `Ok(false)` (and leaves `rhs` unspecified) when
    /// that Hessian is not positive definite, i.e. `x` is not a strict minimum: the adjoint of
    /// a saddle or a point on a rigid-motion null space is not differentiated silently. Needs
    /// the direct solver; one assembly, one factorisation, one triangular solve pair.
    pub fn solve_own_hessian<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        x: &[f64],
        rhs: &mut [f64],
    ) -> Result<bool, SolverError> {
        self.check_direct(objective, x, "the adjoint solve")?;
        if rhs.len() != self.n_dofs() {
            return Err(SolverError::DimensionMismatch {
                what: "rhs",
                expected: self.n_dofs(),
                found: rhs.len(),
            });
        }
        let mut timings = NewtonTimings::default();
        assemble(objective, x, &mut self.hessian, false, 0, &mut timings)?;
        // The factor is not of the objective's (shifted) Hessian: no solve may reuse it.
        self.reusable = None;
        let shift = objective.hessian_diagonal_shift();
        if shift != 0.0 {
            let val = self.hessian.val_mut();
            self.diag_offsets.iter().for_each(|&o| val[o] -= shift);
        }
        let Some(cholesky) = self.cholesky.as_mut() else {
            return Err(SolverError::Linear("no Cholesky factorisation".into()));
        };
        match cholesky.factorize(self.hessian.as_ref()) {
            Ok(()) => {}
            Err(FactorError::NotPositiveDefinite { .. }) => return Ok(false),
            Err(FactorError::Other(e)) => return Err(e),
        }
        cholesky.solve_in_place(rhs)?;
        Ok(true)
    }
}
