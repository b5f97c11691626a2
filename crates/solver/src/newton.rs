//! Newton's method with backtracking line search and regularisation.
//!
//! Each iteration solves `H dx = −∇f` with the sparse Cholesky factorisation of
//! [`linear`](crate::linear) (symbolic analysis done once in [`NewtonWorkspace::new`]), shifting
//! the diagonal when H is not positive definite, then backtracks along `dx` until the Armijo
//! condition `f(x + α dx) ≤ f(x) + c₁ α ∇fᵀdx` holds. It stops when
//! `‖∇f‖∞ ≤ gradient_tolerance · force_scale` or when the unshifted Newton correction is
//! shorter than `step_tolerance · length_scale` (‖dx‖∞; the gradient has then usually hit its
//! round-off floor, e.g. under a large inertia term Λ/Δt²).

use std::time::{Duration, Instant};

use faer::Par;
use faer::sparse::SparseColMat;

use crate::SolverError;
use crate::linear::{
    FactorError, FactorOutcome, FactorStats, RegularizationKind, RegularizationParams,
    SparseCholesky,
};
use crate::objective::Objective;
use crate::ordering::Ordering;

/// All parameters of a Newton solve (one plain struct; [`Default`] gives robust values).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonSettings {
    /// Maximum number of Newton iterations (≥ 1).
    pub max_iterations: usize,
    /// Converged when `‖∇f‖∞ ≤ gradient_tolerance · force_scale` (dimensionless, > 0).
    pub gradient_tolerance: f64,
    /// Converged when the unshifted Newton correction has `‖dx‖∞ ≤ step_tolerance ·
    /// length_scale` (dimensionless, ≥ 0; 0 disables the criterion).
    pub step_tolerance: f64,
    /// Backtracking Armijo line search on the objective (otherwise full steps).
    pub line_search: bool,
    /// Armijo sufficient-decrease constant c₁ ∈ (0, 1).
    pub armijo_c1: f64,
    /// Step-length factor per backtrack, in (0, 1).
    pub backtrack_factor: f64,
    /// Maximum number of backtracks per iteration.
    pub max_backtracks: usize,
    /// Shift the Hessian's diagonal when it is not positive definite (otherwise a typed error).
    pub regularization: bool,
    /// Shape of the shift.
    pub regularization_kind: RegularizationKind,
    /// First relative shift μ (relative to the mean |H_dd| for `Identity`), > 0.
    pub regularization_initial: f64,
    /// Growth factor of μ after a failed factorisation, > 1.
    pub regularization_growth: f64,
    /// Factor applied to the remembered μ before the next factorisation, in (0, 1).
    pub regularization_shrink: f64,
    /// Maximum shifted factorisation attempts per iteration (≥ 1).
    pub regularization_max_attempts: usize,
    /// Fill-reducing ordering of the factorisation (used when the workspace is built).
    pub ordering: Ordering,
    /// Let faer factorise and solve on the rayon thread pool (results may then differ in the
    /// last bits between thread counts).
    pub parallel: bool,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        let reg = RegularizationParams::default();
        Self {
            max_iterations: 50,
            gradient_tolerance: 1e-8,
            step_tolerance: 1e-12,
            line_search: true,
            armijo_c1: 1e-4,
            backtrack_factor: 0.5,
            max_backtracks: 40,
            regularization: true,
            regularization_kind: reg.kind,
            regularization_initial: reg.initial,
            regularization_growth: reg.growth,
            regularization_shrink: reg.shrink,
            regularization_max_attempts: reg.max_attempts,
            ordering: Ordering::default(),
            parallel: false,
        }
    }
}

impl NewtonSettings {
    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), SolverError> {
        fn bad(name: &'static str, value: f64, requirement: &'static str) -> SolverError {
            SolverError::InvalidSetting {
                name,
                value,
                requirement,
            }
        }
        if self.max_iterations == 0 {
            return Err(bad("max_iterations", 0.0, "must be at least 1"));
        }
        if !(self.gradient_tolerance.is_finite() && self.gradient_tolerance > 0.0) {
            return Err(bad(
                "gradient_tolerance",
                self.gradient_tolerance,
                "must be positive and finite",
            ));
        }
        if !(self.step_tolerance.is_finite() && self.step_tolerance >= 0.0) {
            return Err(bad(
                "step_tolerance",
                self.step_tolerance,
                "must be non-negative and finite",
            ));
        }
        if !(self.armijo_c1 > 0.0 && self.armijo_c1 < 1.0) {
            return Err(bad("armijo_c1", self.armijo_c1, "must lie in (0, 1)"));
        }
        if !(self.backtrack_factor > 0.0 && self.backtrack_factor < 1.0) {
            return Err(bad(
                "backtrack_factor",
                self.backtrack_factor,
                "must lie in (0, 1)",
            ));
        }
        if !(self.regularization_initial.is_finite() && self.regularization_initial > 0.0) {
            return Err(bad(
                "regularization_initial",
                self.regularization_initial,
                "must be positive and finite",
            ));
        }
        if !(self.regularization_growth.is_finite() && self.regularization_growth > 1.0) {
            return Err(bad(
                "regularization_growth",
                self.regularization_growth,
                "must be finite and greater than 1",
            ));
        }
        if !(self.regularization_shrink > 0.0 && self.regularization_shrink < 1.0) {
            return Err(bad(
                "regularization_shrink",
                self.regularization_shrink,
                "must lie in (0, 1)",
            ));
        }
        if self.regularization_max_attempts == 0 {
            return Err(bad(
                "regularization_max_attempts",
                0.0,
                "must be at least 1",
            ));
        }
        Ok(())
    }

    /// The regularisation parameters as the linear solver takes them.
    pub fn regularization_params(&self) -> RegularizationParams {
        RegularizationParams {
            kind: self.regularization_kind,
            initial: self.regularization_initial,
            growth: self.regularization_growth,
            shrink: self.regularization_shrink,
            max_attempts: if self.regularization {
                self.regularization_max_attempts
            } else {
                0
            },
        }
    }

    fn par(&self) -> Par {
        if self.parallel {
            Par::rayon(0)
        } else {
            Par::Seq
        }
    }
}

/// Which criterion ended a converged solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convergence {
    /// `‖∇f‖∞ ≤ gradient_tolerance · force_scale`.
    Gradient,
    /// An unshifted Newton correction shorter than `step_tolerance · length_scale` (not taken).
    Step,
}

/// A factorisation that needed a diagonal shift.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularizationEvent {
    /// Newton iteration (0-based).
    pub iteration: usize,
    /// Relative shift μ of the factorisation that succeeded (> 0).
    pub mu: f64,
    /// Largest absolute diagonal entry added.
    pub max_shift: f64,
    /// Factorisation attempts in that iteration.
    pub attempts: usize,
}

/// Wall time spent per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NewtonTimings {
    /// Objective evaluations: values, gradients, Hessians (including line-search trials).
    pub assembly: Duration,
    /// Numeric Cholesky factorisations (including failed attempts).
    pub factorization: Duration,
    /// Triangular solves.
    pub solve: Duration,
}

/// What a converged Newton solve did.
#[derive(Clone, Debug, PartialEq)]
pub struct NewtonReport {
    /// Newton iterations (Hessian factorisations with a step taken).
    pub iterations: usize,
    /// The criterion that stopped the solve.
    pub convergence: Convergence,
    /// Relative residual `‖∇f‖∞ / force_scale` of every accepted iterate (first = initial).
    pub residuals: Vec<f64>,
    /// Objective value of every accepted iterate (first = initial); non-increasing with line
    /// search (up to round-off once the predicted decrease is below it).
    pub values: Vec<f64>,
    /// Line-search backtracks over the whole solve.
    pub backtracks: usize,
    /// Factorisations that needed a diagonal shift.
    pub regularizations: Vec<RegularizationEvent>,
    /// Time per stage.
    pub timings: NewtonTimings,
}

/// Reusable state of Newton solves on objectives with one Hessian pattern: the symbolic
/// factorisation, the Hessian matrix, vectors, and the remembered regularisation shift.
/// Build it once (e.g. per simulation) and pass it to every [`newton_solve`].
#[derive(Debug)]
pub struct NewtonWorkspace {
    cholesky: SparseCholesky,
    hessian: SparseColMat<usize, f64>,
    g: Vec<f64>,
    g_trial: Vec<f64>,
    dx: Vec<f64>,
    x_trial: Vec<f64>,
    mu: f64,
}

impl NewtonWorkspace {
    /// Analyses `objective`'s Hessian pattern with `settings.ordering` (using the objective's dof
    /// coordinates for nested dissection when it has them).
    pub fn new<O: Objective + ?Sized>(
        objective: &O,
        settings: &NewtonSettings,
    ) -> Result<NewtonWorkspace, SolverError> {
        settings.validate()?;
        let n = objective.n_dofs();
        let hessian = objective.hessian_template();
        if hessian.ncols() != n || hessian.nrows() != n {
            return Err(SolverError::DimensionMismatch {
                what: "Hessian template",
                expected: n,
                found: hessian.ncols(),
            });
        }
        let coords = objective.dof_coordinates();
        let cholesky = SparseCholesky::new(
            hessian.symbolic(),
            settings.ordering,
            coords.as_deref(),
            settings.par(),
        )?;
        Ok(NewtonWorkspace {
            cholesky,
            hessian,
            g: vec![0.0; n],
            g_trial: vec![0.0; n],
            dx: vec![0.0; n],
            x_trial: vec![0.0; n],
            mu: 0.0,
        })
    }

    /// Number of unknowns the workspace was built for.
    pub fn n_dofs(&self) -> usize {
        self.g.len()
    }

    /// Statistics of the symbolic factorisation (ordering, fill, flops).
    pub fn factor_stats(&self) -> &FactorStats {
        self.cholesky.stats()
    }

    /// The remembered relative regularisation shift (0 when the last factorisation needed none).
    pub fn regularization_memory(&self) -> f64 {
        self.mu
    }

    /// The gradient at the last accepted iterate of the last solve.
    pub fn gradient(&self) -> &[f64] {
        &self.g
    }
}

fn norm_inf(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn first_non_finite(v: &[f64]) -> Option<usize> {
    v.iter().position(|x| !x.is_finite())
}

/// Minimises `objective` from `x` (overwritten with the result).
///
/// On success `x` is the converged iterate. On failure `x` holds the last accepted iterate
/// (also carried by the error, with the residual history), never a rejected trial point.
pub fn newton_solve<O: Objective + ?Sized>(
    objective: &mut O,
    x: &mut [f64],
    settings: &NewtonSettings,
    ws: &mut NewtonWorkspace,
) -> Result<NewtonReport, SolverError> {
    settings.validate()?;
    let n = objective.n_dofs();
    if x.len() != n {
        return Err(SolverError::DimensionMismatch {
            what: "x",
            expected: n,
            found: x.len(),
        });
    }
    if ws.n_dofs() != n {
        return Err(SolverError::DimensionMismatch {
            what: "Newton workspace",
            expected: n,
            found: ws.n_dofs(),
        });
    }
    let force_scale = objective.force_scale();
    if !(force_scale.is_finite() && force_scale > 0.0) {
        return Err(SolverError::InvalidForceScale(force_scale));
    }
    let length_scale = objective.length_scale();
    if !(length_scale.is_finite() && length_scale > 0.0) {
        return Err(SolverError::InvalidLengthScale(length_scale));
    }
    let reg_params = settings.regularization_params();
    if !settings.regularization {
        // A shift remembered from an earlier solve must not leak into an unregularised one.
        ws.mu = 0.0;
    }
    let mut timings = NewtonTimings::default();
    let mut report_regs = Vec::new();
    let mut backtracks_total = 0;

    let t = Instant::now();
    let mut f = objective.gradient(x, &mut ws.g)?;
    timings.assembly += t.elapsed();
    if !f.is_finite() {
        return Err(SolverError::NonFinite {
            what: "value",
            iteration: 0,
            dof: None,
        });
    }
    if let Some(dof) = first_non_finite(&ws.g) {
        return Err(SolverError::NonFinite {
            what: "gradient",
            iteration: 0,
            dof: Some(dof),
        });
    }
    let mut residuals = vec![norm_inf(&ws.g) / force_scale];
    let mut values = vec![f];
    let mut iteration = 0;

    loop {
        let residual = residuals[residuals.len() - 1];
        if residual <= settings.gradient_tolerance {
            return Ok(NewtonReport {
                iterations: iteration,
                convergence: Convergence::Gradient,
                residuals,
                values,
                backtracks: backtracks_total,
                regularizations: report_regs,
                timings,
            });
        }
        if iteration >= settings.max_iterations {
            return Err(SolverError::NewtonDidNotConverge {
                residuals,
                iterations: iteration,
                tolerance: settings.gradient_tolerance,
                last_good: x.to_vec(),
            });
        }

        // Hessian and (regularised) factorisation.
        let t = Instant::now();
        objective.hessian(x, &mut ws.hessian)?;
        timings.assembly += t.elapsed();
        if ws.hessian.val().iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite {
                what: "Hessian",
                iteration,
                dof: None,
            });
        }
        let t = Instant::now();
        let outcome = ws
            .cholesky
            .factorize_regularized(&mut ws.hessian, &reg_params, &mut ws.mu);
        timings.factorization += t.elapsed();
        let outcome: FactorOutcome = match outcome {
            Ok(o) => o,
            Err(FactorError::NotPositiveDefinite { pivot }) => {
                return Err(if settings.regularization {
                    SolverError::RegularizationFailed {
                        iteration,
                        mu: ws.mu,
                        attempts: reg_params.max_attempts + 1,
                    }
                } else {
                    SolverError::NotPositiveDefinite { iteration, pivot }
                });
            }
            Err(FactorError::Other(e)) => return Err(e),
        };
        if outcome.mu > 0.0 {
            report_regs.push(RegularizationEvent {
                iteration,
                mu: outcome.mu,
                max_shift: outcome.max_shift,
                attempts: outcome.attempts,
            });
        }

        // Newton direction dx = −H⁻¹∇f.
        for (d, g) in ws.dx.iter_mut().zip(&ws.g) {
            *d = -g;
        }
        let t = Instant::now();
        ws.cholesky.solve_in_place(&mut ws.dx)?;
        timings.solve += t.elapsed();
        if let Some(dof) = first_non_finite(&ws.dx) {
            return Err(SolverError::NonFinite {
                what: "Newton direction",
                iteration,
                dof: Some(dof),
            });
        }
        let slope: f64 = ws.dx.iter().zip(&ws.g).map(|(d, g)| d * g).sum();

        // An unshifted Newton correction below the step tolerance: x is converged (typically
        // the gradient has reached its round-off floor). The step is not taken.
        if outcome.mu == 0.0 && norm_inf(&ws.dx) <= settings.step_tolerance * length_scale {
            return Ok(NewtonReport {
                iterations: iteration,
                convergence: Convergence::Step,
                residuals,
                values,
                backtracks: backtracks_total,
                regularizations: report_regs,
                timings,
            });
        }

        // Backtracking line search. The first trial evaluates the gradient too (it is usually
        // accepted); later trials only the value.
        let mut alpha = 1.0;
        let mut backtracks = 0;
        let mut trial_has_gradient;
        let f_trial = loop {
            for ((xt, &xi), &d) in ws.x_trial.iter_mut().zip(x.iter()).zip(&ws.dx) {
                *xt = xi + alpha * d;
            }
            let t = Instant::now();
            let f_t = if backtracks == 0 {
                trial_has_gradient = true;
                objective.gradient(&ws.x_trial, &mut ws.g_trial)?
            } else {
                trial_has_gradient = false;
                objective.value(&ws.x_trial)?
            };
            timings.assembly += t.elapsed();
            if !settings.line_search {
                if !f_t.is_finite() {
                    return Err(SolverError::NonFinite {
                        what: "value",
                        iteration: iteration + 1,
                        dof: None,
                    });
                }
                break f_t;
            }
            if f_t.is_finite() && slope < 0.0 {
                if f_t <= f + settings.armijo_c1 * alpha * slope {
                    break f_t;
                }
                // Once the predicted decrease is below the round-off of f, values cannot
                // discriminate: accept a full step that does not raise f beyond round-off
                // and reduces the gradient.
                let noise = 16.0 * f64::EPSILON * f.abs().max(f_t.abs());
                if trial_has_gradient
                    && -slope <= noise
                    && f_t <= f + noise
                    && norm_inf(&ws.g_trial) < norm_inf(&ws.g)
                {
                    break f_t;
                }
            }
            if backtracks >= settings.max_backtracks || slope >= 0.0 {
                return Err(SolverError::LineSearchFailed {
                    iteration,
                    backtracks,
                    residuals,
                    last_good: x.to_vec(),
                });
            }
            backtracks += 1;
            alpha *= settings.backtrack_factor;
        };
        backtracks_total += backtracks;

        // Accept the trial point.
        x.copy_from_slice(&ws.x_trial);
        if trial_has_gradient {
            std::mem::swap(&mut ws.g, &mut ws.g_trial);
            f = f_trial;
        } else {
            let t = Instant::now();
            f = objective.gradient(x, &mut ws.g)?;
            timings.assembly += t.elapsed();
        }
        iteration += 1;
        if !f.is_finite() {
            return Err(SolverError::NonFinite {
                what: "value",
                iteration,
                dof: None,
            });
        }
        if let Some(dof) = first_non_finite(&ws.g) {
            return Err(SolverError::NonFinite {
                what: "gradient",
                iteration,
                dof: Some(dof),
            });
        }
        residuals.push(norm_inf(&ws.g) / force_scale);
        values.push(f);
    }
}
