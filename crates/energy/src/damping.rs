//! Kelvin–Voigt damping of a face (model.md §2): the St. Venant–Kirchhoff quadratic of the
//! form change over the step, measured in the metric at the start of the step,
//!
//! damping = (η/E)/Δt · (h/8 ‖a_prev⁻¹(a − a_prev)‖²_SV + h³/24 ‖a_prev⁻¹(b − b_prev)‖²_SV) · A
//!
//! (= (η/E) Δt (… ‖·/Δt‖² …) A), A = √det ā, with h, E, ν, η of the [`Material`] for every
//! elastic model (damping is not part of an [`ElasticLaw`](crate::ElasticLaw)). The per-face
//! kernels evaluate it here: [`DampingQuadratics`] (value, gradient and Hessian in the form
//! entries) for [`crate::eval_face`], [`damping_energy`] for the energy-only path.

use crate::material::{EnergyConstants, Material};
use crate::small_matrix::{inv2, sym_entries};
use crate::stvk_quadratic::{sv_norm_sq_entries, sv_quadratic};
use nalgebra::{Matrix2, Matrix3, Vector3};

/// Damping data of a face: forms at the start of the step and the step Δt (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceDamping {
    /// a at the start of the step (SPD).
    pub a_prev: Matrix2<f64>,
    /// b at the start of the step.
    pub b_prev: Matrix2<f64>,
    /// Time step Δt (s), > 0.
    pub dt: f64,
}

/// The damping of one face as two quadratics in the form entries, (a − a_prev)ᵀ K_a (a − a_prev)
/// + (b − b_prev)ᵀ K_b (b − b_prev) (J), with their derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DampingQuadratics {
    /// K_a (J/m⁴).
    pub k_a: Matrix3<f64>,
    /// Entries of a_prev (m²).
    pub a_prev: Vector3<f64>,
    /// K_b (J/m²).
    pub k_b: Matrix3<f64>,
    /// Entries of b_prev (m).
    pub b_prev: Vector3<f64>,
}

impl DampingQuadratics {
    /// The quadratics of a face with rest area factor `area` = A = √det ā (m²).
    #[inline]
    pub fn new(material: &Material, area: f64, d: &FaceDamping) -> Self {
        let (h, alpha, beta) = (material.thickness, material.alpha(), material.beta());
        let ap_inv = inv2(&d.a_prev);
        let c = material.viscosity / material.young / d.dt * area;
        Self {
            k_a: sv_quadratic(&ap_inv, alpha, beta, c * h / 8.0),
            a_prev: sym_entries(&d.a_prev),
            k_b: sv_quadratic(&ap_inv, alpha, beta, c * h * h * h / 24.0),
            b_prev: sym_entries(&d.b_prev),
        }
    }

    /// The damping energy (J) at forms a, b (entries).
    #[inline]
    pub fn energy(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        let (da, db) = (a - self.a_prev, b - self.b_prev);
        da.dot(&(self.k_a * da)) + db.dot(&(self.k_b * db))
    }

    /// ∂/∂a = 2 K_a (a − a_prev) (J/m²).
    #[inline]
    pub fn gradient_a(&self, a: &Vector3<f64>) -> Vector3<f64> {
        self.k_a * (a - self.a_prev) * 2.0
    }

    /// ∂/∂b = 2 K_b (b − b_prev) (J/m).
    #[inline]
    pub fn gradient_b(&self, b: &Vector3<f64>) -> Vector3<f64> {
        self.k_b * (b - self.b_prev) * 2.0
    }

    /// ∂²/∂a² = 2 K_a.
    #[inline]
    pub fn hessian_a(&self) -> Matrix3<f64> {
        self.k_a * 2.0
    }

    /// ∂²/∂b² = 2 K_b.
    #[inline]
    pub fn hessian_b(&self) -> Matrix3<f64> {
        self.k_b * 2.0
    }
}

/// The damping energy (J) of a face at forms a, b (entries) with rest area factor `area` (m²),
/// by the SV norm directly (no 3×3 matrices), `constants` hoisted out of the face loop. Equals
/// [`DampingQuadratics::energy`] to round-off.
#[inline]
pub fn damping_energy(
    constants: &EnergyConstants,
    area: f64,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    d: &FaceDamping,
) -> f64 {
    let k = constants;
    let ap_inv = inv2(&d.a_prev);
    let c = k.eta_over_e / d.dt * area;
    c * (k.h_8 * sv_norm_sq_entries(&ap_inv, k.half_alpha, k.beta, &(a - sym_entries(&d.a_prev)))
        + k.h3_24
            * sv_norm_sq_entries(&ap_inv, k.half_alpha, k.beta, &(b - sym_entries(&d.b_prev))))
}
