//! Conservative continuous collision detection along a linear step: additive CCD (Li, Kaufman
//! and Jiang 2021, "Codimensional incremental potential contact", Alg. 1), written from the
//! paper's description.
//!
//! The pair moves as x(t) = x + t·Δx. After removing the mean displacement, l_p bounds the rate
//! at which the pair's distance can shrink (point–triangle: |Δp| + maxᵢ |Δtᵢ|; edge–edge:
//! max |Δaᵢ| + max |Δbⱼ|). Advancing t by at most (d(t) − ξ)/l_p therefore cannot bring the
//! distance below the minimum separation ξ, and the returned time of impact is never past a
//! true contact. The iteration stops once the gap has shrunk below `gap_fraction` of its initial
//! value, which leaves the next Newton iteration room to move the pair closer still.

use super::distance::{PairPoints, distance2_of_type, edge_edge_type, point_triangle_type};
use super::pair::PairKind;

/// Settings of [`additive_ccd`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CcdSettings {
    /// ξ (m, ≥ 0): the distance the pair keeps; include the thickness offset here when contact
    /// is between surfaces. Must exceed the rounding error of the distance computation (about
    /// 10⁻⁸ of the edge length for nearly parallel edges) for the guarantee to hold in floating
    /// point.
    pub min_separation: f64,
    /// s ∈ (0, 1): the returned time leaves at least this fraction of the initial gap d − ξ
    /// (0.1 in the paper's experiments, used here by default).
    pub gap_fraction: f64,
    /// Cap on the number of advances; reaching it returns the time reached so far (conservative:
    /// the step is only shortened).
    pub max_iterations: usize,
}

impl Default for CcdSettings {
    fn default() -> Self {
        CcdSettings {
            min_separation: 0.0,
            gap_fraction: 0.1,
            max_iterations: 100_000,
        }
    }
}

fn distance(x: &PairPoints, kind: PairKind) -> f64 {
    let ty = match kind {
        PairKind::PointTriangle => point_triangle_type(x),
        PairKind::EdgeEdge { .. } => edge_edge_type(x),
    };
    distance2_of_type(x, ty).sqrt()
}

/// The time of impact t ∈ [0, `t_max`] of a pair moving from `x` by `t·dx`: `t_max` when the
/// pair stays farther than ξ over the whole step, otherwise a time before the distance could
/// reach ξ. Returns 0 when the pair starts at or within ξ (or its distance is not finite).
///
/// `kind` only selects the pair's meaning (point–triangle or edge–edge); its mollifier
/// threshold is not used.
pub fn additive_ccd(
    x: &PairPoints,
    dx: &PairPoints,
    kind: PairKind,
    t_max: f64,
    settings: &CcdSettings,
) -> f64 {
    let xi = settings.min_separation;
    let d0 = distance(x, kind);
    if d0.is_nan() || d0 <= xi {
        return 0.0;
    }
    let mean = (dx[0] + dx[1] + dx[2] + dx[3]) * 0.25;
    let p: PairPoints = std::array::from_fn(|i| dx[i] - mean);
    let n: [f64; 4] = std::array::from_fn(|i| p[i].norm());
    let lp = match kind {
        PairKind::PointTriangle => n[0] + n[1].max(n[2]).max(n[3]),
        PairKind::EdgeEdge { .. } => n[0].max(n[1]) + n[2].max(n[3]),
    };
    if !lp.is_finite() {
        return 0.0;
    }
    if lp == 0.0 {
        return t_max;
    }
    let gap0 = d0 - xi;
    let target = settings.gap_fraction * gap0;
    let mut t = 0.0;
    let mut step = (1.0 - settings.gap_fraction) * gap0 / lp;
    for _ in 0..settings.max_iterations {
        let tn = t + step;
        let y: PairPoints = std::array::from_fn(|i| x[i] + p[i] * tn);
        let gap = distance(&y, kind) - xi;
        // Rounding can make a gap that is tiny in exact arithmetic non-positive: stop at t.
        if gap.is_nan() || gap <= 0.0 || (t > 0.0 && gap < target) {
            return t;
        }
        t = tn;
        if t > t_max {
            return t_max;
        }
        step = 0.9 * gap / lp;
    }
    t.min(t_max)
}
