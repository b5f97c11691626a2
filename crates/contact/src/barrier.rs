//! IPC's smoothly clamped log barrier (Li et al. 2020).

/// The barrier b(g, ĝ) = −(g − ĝ)² ln(g / ĝ) for 0 < g < ĝ, 0 for g ≥ ĝ and +∞ for g ≤ 0,
/// with its first and second derivatives in g: `(b, b′, b″)`.
///
/// `g` is the gap (m) and `ĝ` (`g_hat`, m, > 0) the activation distance; b has units m², so a
/// stiffness κ in J/m² (= Pa·m) makes κ·b an energy. b is C² at g = ĝ (b = b′ = b″ = 0 there),
/// positive, decreasing and convex on (0, ĝ), and b → +∞ as g → 0⁺.
pub fn barrier(g: f64, g_hat: f64) -> (f64, f64, f64) {
    if g >= g_hat {
        return (0.0, 0.0, 0.0);
    }
    if g <= 0.0 {
        return (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
    }
    let r = g - g_hat;
    let ln = (g / g_hat).ln();
    let b = -r * r * ln;
    let db = -2.0 * r * ln - r * r / g;
    let ddb = -2.0 * ln - 4.0 * r / g + r * r / (g * g);
    (b, db, ddb)
}
