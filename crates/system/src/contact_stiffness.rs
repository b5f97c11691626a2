//! The adaptive barrier stiffness κ (model.md §7), after IPC's (Li et al. 2020, §4.3): an
//! initial value that balances the forces pressing the active pairs together, then doubling
//! while gaps collapse. Applied between Newton solves (at the start of each), so a solve
//! minimises one fixed energy.
//!
//! The initial value differs from IPC's in its target: IPC balances the forces at the current
//! gaps, κ = −∇E·∇B/|∇B|², which grows without bound as the gaps approach d̂ (b′ → 0 there).
//! Here the balance is at the gap d̂/2 of every active pair: with N = Σ_k ∇g_k the sum of the
//! active pairs' gap gradients (the directions that open the gaps) and ∇E the gradient of the
//! objective without contact (−∇E is the force on the shell, so ∇E·N is the force closing them),
//!
//! κ₀ = max(0, ∇E·N) / (|N|² · |b′(d̂/2, d̂)|),
//!
//! which for P equal pairs pressed by a force f each along their normals is f / |b′(d̂/2)|: each
//! pair would carry its load at half the activation distance.

use thinshell_energy::contact::barrier;

/// κ_min / (E·h): the smallest adaptive stiffness.
pub const KAPPA_MIN_RELATIVE: f64 = 1e-6;
/// κ_max / (E·h): the largest adaptive stiffness.
pub const KAPPA_MAX_RELATIVE: f64 = 1e2;
/// Gaps below this fraction of d̂ that shrink from one solve to the next double κ.
pub const COLLAPSE_FRACTION: f64 = 1e-2;

/// The state of the adaptive stiffness of a contact term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AdaptiveStiffness {
    /// κ_min (J/m²).
    pub(crate) min: f64,
    /// κ_max (J/m²).
    pub(crate) max: f64,
    /// Whether κ₀ has been set (at the first solve that starts with active pairs pressed
    /// together; before it κ = E·h).
    pub(crate) initialised: bool,
    /// The smallest gap at the start of the previous solve (m).
    pub(crate) last_gap: f64,
}

impl AdaptiveStiffness {
    /// Bounds from the membrane stiffness `young_thickness` = E·h (N/m).
    pub(crate) fn new(young_thickness: f64) -> AdaptiveStiffness {
        AdaptiveStiffness {
            min: KAPPA_MIN_RELATIVE * young_thickness,
            max: KAPPA_MAX_RELATIVE * young_thickness,
            initialised: false,
            last_gap: f64::INFINITY,
        }
    }

    /// κ₀ from `pressing` = ∇E·N (N, for unit gap gradients) and `n2` = |N|², clamped to [κ_min, κ_max]; `None`
    /// when nothing presses the pairs together (then κ stays as it is).
    pub(crate) fn initial(&self, pressing: f64, n2: f64, activation: f64) -> Option<f64> {
        let slope = barrier(0.5 * activation, activation).1.abs();
        let k = pressing / (n2 * slope);
        (pressing > 0.0 && n2 > 0.0 && k.is_finite()).then(|| k.clamp(self.min, self.max))
    }

    /// The stiffness after a solve started at smallest gap `gap` (m): doubled (up to κ_max)
    /// when the gap is below [`COLLAPSE_FRACTION`]·d̂ and smaller than at the previous start.
    pub(crate) fn update(&mut self, kappa: f64, gap: f64, activation: f64) -> f64 {
        let collapsing = gap < COLLAPSE_FRACTION * activation && gap < self.last_gap;
        self.last_gap = gap;
        if collapsing {
            (2.0 * kappa).min(self.max)
        } else {
            kappa
        }
    }
}
