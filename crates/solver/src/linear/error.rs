//! A failed numeric factorisation: its own module, so that the sequential engine (`linear`) and
//! the split one (`split`) both use it without using each other.

use crate::SolverError;

/// Failure of one numeric factorisation attempt.
#[derive(Debug)]
pub enum FactorError {
    /// faer met a non-positive pivot (index in the permuted order; a diagnostic only).
    NotPositiveDefinite {
        /// Failing pivot.
        pivot: usize,
    },
    /// Anything else (pattern mismatch, faer failure).
    Other(SolverError),
}
