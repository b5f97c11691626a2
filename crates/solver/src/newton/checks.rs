//! The checks every phase of a solve applies to what the objective returns (finite values,
//! gradients and Hessians, a step limit in (0, 1]), and the norm the solve measures with.

use std::time::Instant;

use faer::sparse::SparseColMat;

use super::report::NewtonTimings;
use super::settings::IterationHessian;
use crate::SolverError;
use crate::objective::Objective;

pub(super) fn norm_inf(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// A non-finite value `f` or gradient `g` at an iterate, as the error of iteration
/// `iteration`.
pub(super) fn check_finite(f: f64, g: &[f64], iteration: usize) -> Result<(), SolverError> {
    if !f.is_finite() {
        return Err(SolverError::NonFinite {
            what: "value",
            iteration,
            dof: None,
        });
    }
    if let Some(dof) = first_non_finite(g) {
        return Err(SolverError::NonFinite {
            what: "gradient",
            iteration,
            dof: Some(dof),
        });
    }
    Ok(())
}

pub(super) fn first_non_finite(v: &[f64]) -> Option<usize> {
    v.iter().position(|x| !x.is_finite())
}

/// Assembles the PSD Hessian when `psd`, else the own Hessian.
pub(super) fn assemble<O: Objective + ?Sized>(
    objective: &mut O,
    x: &[f64],
    h: &mut SparseColMat<usize, f64>,
    psd: bool,
    iteration: usize,
    timings: &mut NewtonTimings,
) -> Result<IterationHessian, SolverError> {
    let t = Instant::now();
    let kind = if psd {
        objective.psd_hessian(x, h)?;
        IterationHessian::Psd
    } else {
        objective.hessian(x, h)?;
        IterationHessian::Own
    };
    timings.assembly += t.elapsed();
    if h.val().iter().any(|v| !v.is_finite()) {
        return Err(SolverError::NonFinite {
            what: "Hessian",
            iteration,
            dof: None,
        });
    }
    Ok(kind)
}

/// The objective's step limit for `dx` from `x` (see [`Objective::max_step`]), checked.
pub(super) fn step_limit_of<O: Objective + ?Sized>(
    objective: &mut O,
    x: &[f64],
    dx: &[f64],
) -> Result<f64, SolverError> {
    let alpha = objective.max_step(x, dx)?;
    if !(alpha.is_finite() && alpha > 0.0 && alpha <= 1.0) {
        return Err(SolverError::InvalidSetting {
            name: "Objective::max_step",
            value: alpha,
            requirement: "the objective's step limit must lie in (0, 1]",
        });
    }
    Ok(alpha)
}
