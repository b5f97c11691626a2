//! The diagonal shift by which a matrix that is not positive definite is factorised anyway:
//! its parameters and the retry loop.

use faer::sparse::SparseColMat;

use super::{FactorError, SparseCholesky};
use crate::SolverError;

/// How the diagonal shift of a regularised factorisation is shaped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum RegularizationKind {
    /// `H + μ·s·I`, `s` = mean |H_dd| (so μ is relative to the Hessian's scale).
    #[default]
    Identity,
    /// `H + μ·diag(max(|H_dd|, 1e-6·s))`: shifts each dof in proportion to its own stiffness
    /// (mass-weighted problems with very different dof scales).
    Diagonal,
}

/// Parameters of the shift search in [`SparseCholesky::factorize_regularized`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularizationParams {
    /// Shape of the shift.
    pub kind: RegularizationKind,
    /// First relative shift μ tried after a failed unshifted factorisation (default 1e-10:
    /// below the bending stiffness of thin shells, whose bending entries are a fraction
    /// ~(h/ℓ)² of the membrane ones that dominate the mean |H_dd|; a first shift of 1e-6 of the
    /// mean already swamped the bending of paper, h/ℓ ≈ 1e-3, and turned Newton into a slow
    /// gradient method there).
    pub initial: f64,
    /// Factor μ grows by after each failure (> 1).
    pub growth: f64,
    /// Factor the remembered μ is multiplied by before the next factorisation (in (0, 1));
    /// once it falls below `initial` the next factorisation is tried unshifted again.
    pub shrink: f64,
    /// Maximum number of shifted attempts per factorisation.
    pub max_attempts: usize,
}

impl RegularizationParams {
    /// Checks every parameter; the error names the first bad one (as the flat names
    /// `regularization_initial`, … of the scene and of earlier versions).
    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = SolverError::invalid_setting;
        if !(self.initial.is_finite() && self.initial > 0.0) {
            return Err(bad(
                "regularization_initial",
                self.initial,
                "must be positive and finite",
            ));
        }
        if !(self.growth.is_finite() && self.growth > 1.0) {
            return Err(bad(
                "regularization_growth",
                self.growth,
                "must be finite and greater than 1",
            ));
        }
        if !(self.shrink > 0.0 && self.shrink < 1.0) {
            return Err(bad(
                "regularization_shrink",
                self.shrink,
                "must lie in (0, 1)",
            ));
        }
        if self.max_attempts == 0 {
            return Err(bad(
                "regularization_max_attempts",
                0.0,
                "must be at least 1",
            ));
        }
        Ok(())
    }
}

impl Default for RegularizationParams {
    fn default() -> Self {
        Self {
            kind: RegularizationKind::Identity,
            initial: 1e-10,
            growth: 10.0,
            shrink: 0.1,
            max_attempts: 24,
        }
    }
}

/// Result of one (possibly regularised) factorisation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FactorOutcome {
    /// Relative shift μ of the factorisation that succeeded (0: unshifted).
    pub mu: f64,
    /// Largest absolute diagonal entry added (same units as H).
    pub max_shift: f64,
    /// Factorisation attempts, including the successful one.
    pub attempts: usize,
}

impl SparseCholesky {
    /// Factorises `h`, retrying with a growing diagonal shift while it is not positive definite.
    ///
    /// `mu` is the caller's memory of the last successful shift: the first attempt uses
    /// `mu·shrink` (or no shift once that falls below `params.initial`), failures multiply it by
    /// `params.growth`, and the successful value is written back. `h` is restored to its input
    /// values before returning. With `params.max_attempts == 0` no shift is tried.
    pub fn factorize_regularized(
        &mut self,
        h: &mut SparseColMat<usize, f64>,
        params: &RegularizationParams,
        mu: &mut f64,
    ) -> Result<FactorOutcome, FactorError> {
        let mut trial = if *mu > 0.0 && *mu * params.shrink >= params.initial {
            *mu * params.shrink
        } else {
            0.0
        };
        {
            let val = h.val_mut();
            for (b, &o) in self.diag_backup.iter_mut().zip(&self.diag_offsets) {
                *b = val[o];
            }
        }
        let n = self.diag_offsets.len().max(1);
        let scale = {
            let s = self.diag_backup.iter().map(|d| d.abs()).sum::<f64>() / n as f64;
            if s.is_finite() && s > 0.0 { s } else { 1.0 }
        };
        let mut attempts = 0;
        let mut shifted_attempts = 0;
        self.mixed.skip_single = false;
        let result = loop {
            attempts += 1;
            let mut max_shift = 0.0f64;
            {
                let val = h.val_mut();
                for (&o, &d) in self.diag_offsets.iter().zip(&self.diag_backup) {
                    let shift = match params.kind {
                        RegularizationKind::Identity => trial * scale,
                        RegularizationKind::Diagonal => trial * d.abs().max(1e-6 * scale),
                    };
                    max_shift = max_shift.max(shift);
                    val[o] = d + shift;
                }
            }
            match self.factorize(h.as_ref()) {
                Ok(()) => {
                    *mu = trial;
                    break Ok(FactorOutcome {
                        mu: trial,
                        max_shift,
                        attempts,
                    });
                }
                Err(FactorError::NotPositiveDefinite { pivot }) => {
                    if shifted_attempts >= params.max_attempts {
                        break Err(FactorError::NotPositiveDefinite { pivot });
                    }
                    shifted_attempts += 1;
                    trial = if trial == 0.0 {
                        params.initial
                    } else {
                        trial * params.growth
                    };
                }
                Err(e) => break Err(e),
            }
        };
        self.mixed.skip_single = false;
        let val = h.val_mut();
        for (&o, &d) in self.diag_offsets.iter().zip(&self.diag_backup) {
            val[o] = d;
        }
        result
    }
}
