//! The function Newton minimises in one step, over the free coordinates:
//!
//! - implicit Euler: Φ(x) = 1/(2Δt²)(x − x̃)ᵀΛ(x − x̃) + E(x) + E_damp(x; xⁿ) − F_extᵀx (model.md §3);
//! - static: E(x) − F_extᵀx. Rigid motions are a null space when nothing is pinned: the Hessian
//!   handed to Newton carries a small diagonal shift (a Levenberg–Marquardt step, relative
//!   [`STATIC_SHIFT`] of the mean diagonal) while the objective itself is unchanged, so the
//!   equilibrium found is exact and only the convergence along rigid modes is linear.

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{
    Assembler, DampingState, DofMap, EnergyTerms, EvalOutput, HessianMode, RestState, ShellModel,
};
use thinshell_solver::{Objective, SolverError};

/// Relative diagonal shift of the static Hessian (see the module docs).
pub const STATIC_SHIFT: f64 = 1e-10;

/// One step's objective. Positions of pinned coordinates are taken from `x_full`.
pub struct StepObjective<'a> {
    pub(crate) assembler: &'a mut Assembler,
    pub(crate) model: &'a ShellModel,
    pub(crate) rest: &'a RestState,
    pub(crate) damping: Option<&'a DampingState>,
    pub(crate) dofs: &'a DofMap,
    /// Full positions; free coordinates are overwritten from the unknowns at every evaluation.
    pub(crate) x_full: &'a mut Vec<Vector3<f64>>,
    /// Full gradient buffer (3·n).
    pub(crate) grad_full: &'a mut Vec<f64>,
    /// External force per coordinate (3·n), N.
    pub(crate) force: &'a [f64],
    /// Inertia: (mass per free dof, x̃ per free dof, Δt). None for a static solve.
    pub(crate) inertia: Option<(&'a [f64], &'a [f64], f64)>,
    pub(crate) hessian_mode: HessianMode,
    pub(crate) force_scale: f64,
    pub(crate) length_scale: f64,
    /// Energies at the last evaluation.
    pub(crate) last_energy: EnergyTerms,
}

fn objective_error(e: impl std::fmt::Display) -> SolverError {
    SolverError::Objective(e.to_string())
}

impl StepObjective<'_> {
    fn scatter(&mut self, x: &[f64]) {
        for (d, &c) in self.dofs.free_coordinates().iter().enumerate() {
            self.x_full[c / 3][c % 3] = x[d];
        }
    }

    fn extra_value(&self, x: &[f64]) -> f64 {
        let mut v = 0.0;
        for (d, &c) in self.dofs.free_coordinates().iter().enumerate() {
            v -= self.force[c] * x[d];
        }
        if let Some((m, xt, dt)) = self.inertia {
            let k = 0.5 / (dt * dt);
            for d in 0..x.len() {
                let dx = x[d] - xt[d];
                v += k * m[d] * dx * dx;
            }
        }
        v
    }
}

impl Objective for StepObjective<'_> {
    fn n_dofs(&self) -> usize {
        self.dofs.n_free()
    }

    fn value(&mut self, x: &[f64]) -> Result<f64, SolverError> {
        self.scatter(x);
        let e = match self.assembler.evaluate(
            self.model,
            self.x_full,
            self.rest,
            self.damping,
            EvalOutput {
                gradient: None,
                hessian: None,
            },
        ) {
            Ok(e) => e,
            // A trial point where a face degenerates is rejected by the line search.
            Err(thinshell_energy::EnergyError::NonFinite { .. }) => return Ok(f64::INFINITY),
            Err(e) => return Err(objective_error(e)),
        };
        self.last_energy = e;
        Ok(e.total() + self.extra_value(x))
    }

    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        self.scatter(x);
        let e = self
            .assembler
            .evaluate(
                self.model,
                self.x_full,
                self.rest,
                self.damping,
                EvalOutput {
                    gradient: Some(self.grad_full),
                    hessian: None,
                },
            )
            .map_err(objective_error)?;
        self.last_energy = e;
        for (d, &c) in self.dofs.free_coordinates().iter().enumerate() {
            g[d] = self.grad_full[c] - self.force[c];
        }
        if let Some((m, xt, dt)) = self.inertia {
            let k = 1.0 / (dt * dt);
            for d in 0..x.len() {
                g[d] += k * m[d] * (x[d] - xt[d]);
            }
        }
        Ok(e.total() + self.extra_value(x))
    }

    fn hessian(&mut self, x: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
        self.scatter(x);
        self.assembler
            .evaluate(
                self.model,
                self.x_full,
                self.rest,
                self.damping,
                EvalOutput {
                    gradient: None,
                    hessian: Some((h, self.hessian_mode)),
                },
            )
            .map_err(objective_error)?;
        let diag = self.assembler.diagonal_offsets();
        let vals = h.val_mut();
        match self.inertia {
            Some((m, _, dt)) => {
                let k = 1.0 / (dt * dt);
                for (d, &o) in diag.iter().enumerate() {
                    vals[o] += k * m[d];
                }
            }
            None => {
                let mean =
                    diag.iter().map(|&o| vals[o].abs()).sum::<f64>() / diag.len().max(1) as f64;
                let shift = STATIC_SHIFT * mean.max(f64::MIN_POSITIVE);
                for &o in diag {
                    vals[o] += shift;
                }
            }
        }
        Ok(())
    }

    fn hessian_template(&self) -> SparseColMat<usize, f64> {
        self.assembler.hessian_template()
    }

    fn force_scale(&self) -> f64 {
        self.force_scale
    }

    fn length_scale(&self) -> f64 {
        self.length_scale
    }

    fn dof_coordinates(&self) -> Option<Vec<[f64; 3]>> {
        Some(
            self.dofs
                .free_coordinates()
                .iter()
                .map(|&c| {
                    let p = self.x_full[c / 3];
                    [p.x, p.y, p.z]
                })
                .collect(),
        )
    }
}
