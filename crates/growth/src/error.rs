//! Errors of the growth crate.

use thinshell_energy::EnergyError;
use thinshell_mesh::FaceId;

/// Why a growth model, stimulus field or coupling step could not be set up or evaluated.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GrowthError {
    /// A parameter outside its admissible range (NaN, negative thickness, zero layers, …).
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must satisfy.
        reason: &'static str,
    },
    /// A per-face or per-vertex array of the wrong length.
    #[error("{what}: expected {expected} entries, got {got}")]
    LengthMismatch {
        /// Which array.
        what: &'static str,
        /// Entries expected (faces or vertices of the mesh).
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// The stimulus of a face is NaN or infinite.
    #[error("face {face}: non-finite stimulus (top {top}, bottom {bottom})")]
    NonFiniteStimulus {
        /// The face.
        face: FaceId,
        /// m⁺.
        top: f64,
        /// m⁻.
        bottom: f64,
    },
    /// The stimulus of a face drives its rest metric to zero or below (e.g. `1 + c·m ≤ 0`).
    #[error(
        "face {face}: stimulus (top {top}, bottom {bottom}) collapses the rest state: {reason}"
    )]
    CollapsedRest {
        /// The face.
        face: FaceId,
        /// m⁺.
        top: f64,
        /// m⁻.
        bottom: f64,
        /// What went wrong.
        reason: &'static str,
    },
    /// A region that selects nothing where something is required.
    #[error("region `{name}` contains no face of the mesh")]
    EmptyRegion {
        /// Which region.
        name: String,
    },
    /// The diffusion system could not be factored (should not happen for valid input).
    #[error("diffusion: factorisation failed: {0}")]
    Factorization(String),
    /// Rest state or material problem reported by the energy crate.
    #[error(transparent)]
    Energy(#[from] EnergyError),
}

/// `Ok` when `value` is finite and satisfies `ok`.
pub(crate) fn check(
    name: &'static str,
    value: f64,
    ok: bool,
    reason: &'static str,
) -> Result<(), GrowthError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(GrowthError::InvalidParameter {
            name,
            value,
            reason,
        })
    }
}

pub(crate) fn check_len(
    what: &'static str,
    expected: usize,
    got: usize,
) -> Result<(), GrowthError> {
    if expected == got {
        Ok(())
    } else {
        Err(GrowthError::LengthMismatch {
            what,
            expected,
            got,
        })
    }
}
