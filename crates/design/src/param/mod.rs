//! Parametrisations of the rest forms: the design variables p and the rest state they make.
//! One trait ([`Parametrisation`]), one file per kind: [`RestForms`] (free ā, b̄ per face),
//! [`Isotropic`] (conformal growth ā = e^{2s} ā₀ per vertex or face) and [`BilayerGrowth`]
//! (the two layers' growth tensors per face).

mod bilayer;
mod isotropic;
mod rest_forms;

pub use bilayer::BilayerGrowth;
pub use isotropic::{Isotropic, Support};
pub use rest_forms::RestForms;

use nalgebra::Matrix2;
use thinshell_energy::RestState;

/// Rest forms as a function of design parameters p (with per-parameter bounds).
///
/// Rest-form entries follow the symmetric-entry convention m̄_f = (ā11, ā12, ā22, b̄11, b̄12,
/// b̄22) of face f (barycentric basis; ā12 is the off-diagonal entry, moved on both sides).
pub trait Parametrisation: Send + Sync {
    /// Name used on the command line and in design.json (`rest_forms`, `isotropic`, `bilayer`).
    fn name(&self) -> &'static str;

    /// Number of parameters.
    fn len(&self) -> usize;

    /// Whether there are no parameters.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Parameters of the unchanged reference (no growth).
    fn initial(&self) -> Vec<f64>;

    /// Lower and upper bound per parameter.
    fn bounds(&self) -> (&[f64], &[f64]);

    /// The rest state at parameters `p`.
    fn rest(&self, p: &[f64]) -> RestState;

    /// Adds Σ_f w_f · ∂m̄_f/∂p to `grad` (the chain rule from per-face rest-form derivatives
    /// `w` to the parameters).
    fn pullback(&self, p: &[f64], w: &[[f64; 6]], grad: &mut [f64]);

    /// The parameters whose rest forms come closest to `forms` (exactly for free rest forms and
    /// bilayer growth; the area ratio for isotropic growth), not clamped to the bounds: a
    /// starting point (the algebraic design of a target of the same connectivity).
    fn fit_forms(&self, forms: &RestState) -> Vec<f64>;

    /// What one parameter group sits on (vertex or face) and how many parameters it has, for
    /// reports and the smoothness regulariser: (support, parameters per item).
    fn layout(&self) -> (Support, usize);
}

/// Symmetric-entry vector of a 2×2 matrix.
pub(crate) fn entries(m: &Matrix2<f64>) -> [f64; 3] {
    [m[(0, 0)], 0.5 * (m[(0, 1)] + m[(1, 0)]), m[(1, 1)]]
}

/// The symmetric 2×2 matrix of entries (m11, m12, m22).
pub(crate) fn matrix(e: &[f64]) -> Matrix2<f64> {
    Matrix2::new(e[0], e[1], e[1], e[2])
}

/// Clamps `p` into the bounds of `param`.
pub fn clamp_to_bounds(param: &dyn Parametrisation, p: &mut [f64]) {
    let (lo, hi) = param.bounds();
    for ((v, l), h) in p.iter_mut().zip(lo).zip(hi) {
        *v = v.clamp(*l, *h);
    }
}
