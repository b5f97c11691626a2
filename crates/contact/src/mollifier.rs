//! The edge–edge mollifier of IPC (Li et al. 2020, §4.3): nearly parallel edges have an
//! ill-defined closest-feature classification, so their barrier is multiplied by a smooth
//! factor that vanishes with the squared sine of their angle.

use super::distance::PairPoints;

/// The relative threshold ε× = 10⁻³ of IPC: edges with |(a1 − a0) × (b1 − b0)|² below
/// 10⁻³ |ā1 − ā0|² |b̄1 − b̄0|² (rest lengths) are mollified, i.e. below a sine of about 0.03.
pub const MOLLIFIER_RELATIVE_THRESHOLD: f64 = 1e-3;

/// The mollifier threshold e× = 10⁻³ |ā1 − ā0|² |b̄1 − b̄0|² (m⁴) of an edge pair from its
/// rest (or initial) positions `[ā0, ā1, b̄0, b̄1]`.
pub fn mollifier_threshold(rest: &PairPoints) -> f64 {
    MOLLIFIER_RELATIVE_THRESHOLD
        * (rest[1] - rest[0]).norm_squared()
        * (rest[3] - rest[2]).norm_squared()
}

/// The mollifier m(c) = (2 − c/e×)·c/e× for c < e×, 1 otherwise, of c = |(a1 − a0) × (b1 − b0)|²
/// (m⁴), with its first and second derivatives in c: `(m, m′, m″)`. C¹ at c = e×.
pub fn mollifier(c: f64, threshold: f64) -> (f64, f64, f64) {
    if c >= threshold {
        return (1.0, 0.0, 0.0);
    }
    let r = 1.0 / threshold;
    let q = c * r;
    ((2.0 - q) * q, (2.0 - 2.0 * q) * r, -2.0 * r * r)
}
