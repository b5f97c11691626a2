//! Two bonded layers with their own moduli and eigenstrains (model.md §2.2).

use super::{ElasticLaw, FaceGeometry, LawEval, Material, Order};
use crate::error::EnergyError;
use crate::stvk_quadratic::sv_quadratic;
use crate::terms::Terms;
use nalgebra::Vector3;

/// One layer of a [`Bilayer`] (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Thickness h_l (m), > 0.
    pub thickness: f64,
    /// Young's modulus E_l (Pa), > 0.
    pub young: f64,
    /// Poisson ratio ν_l, in [0, 0.5).
    pub poisson: f64,
    /// Isotropic eigenstrain ε_l (dimensionless, > −1): the layer's stress-free metric is
    /// (1 + ε_l)² ā (thermal α ΔT, moisture swelling, …).
    pub eigenstrain: f64,
}

/// Two bonded St. Venant–Kirchhoff layers: `bottom` on z ∈ [−h/2, −h/2 + h₁], `top` on
/// [−h/2 + h₁, h/2], h = h₁ + h₂, z along the unit normal from the mid-surface (top = +z, the
/// outward side for outward normals; docs/architecture.md).
///
/// The metric at height z is a(z) = a − 2z b (b ≈ −a/r on a sphere with outward normals, so
/// a(z) ≈ (1 + z/r)² a), and layer l is stress-free at ā_l(z) = (1 + ε_l)² ā − 2z b̄. The energy
///
/// E = Σ_l ∫_{layer l} 1/8 ‖ā⁻¹(a(z) − ā_l(z))‖²_{SV,l} √det ā dz
///
/// (‖·‖_{SV,l} with the layer's α_l, β_l) is, with u_l = (a − ā) − s_l ā, s_l = (1+ε_l)² − 1,
/// v = b − b̄, K_l = A/8 · K_SV(ā⁻¹; α_l, β_l) ([`sv_quadratic`]) and the moments
/// m_k = ∫ z^k dz over the layer,
///
/// E = Σ_l m0 u_lᵀK_l u_l − 4 m1 u_lᵀK_l v + 4 m2 vᵀK_l v,
///
/// a quadratic in (a, b) with an a–b coupling block −4 Σ m1 K_l. The first term is reported
/// as stretching, the other two as bending (the coupling is negative when the sheet curls as the
/// mismatch drives it, so a curled bilayer's "bend" can be negative; the total is ≥ 0). One layer of thickness h with ε = 0 (m1 = 0,
/// m2 = h³/12) is exactly [`StVK`](super::StVK). Minimising over a flat sheet's membrane strain
/// and curvature gives Timoshenko's bimetal curvature for the mismatch
/// Δε = (s_top − s_bottom)/2 (= ε_top − ε_bottom to first order) when ν₁ = ν₂.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bilayer {
    /// Layer on the −z side.
    pub bottom: Layer,
    /// Layer on the +z side.
    pub top: Layer,
}

impl Bilayer {
    /// Total thickness h₁ + h₂ (m).
    pub fn thickness(&self) -> f64 {
        self.bottom.thickness + self.top.thickness
    }

    /// Per layer: (m0, m1, m2) = (∫dz, ∫z dz, ∫z² dz) over the layer (m, m², m³), α_l, β_l, s_l.
    pub(super) fn layers(&self) -> [([f64; 3], f64, f64, f64); 2] {
        let h = self.thickness();
        let z = [-0.5 * h, -0.5 * h + self.bottom.thickness, 0.5 * h];
        let moments = |z0: f64, z1: f64| {
            [
                z1 - z0,
                0.5 * (z1 * z1 - z0 * z0),
                (z1 * z1 * z1 - z0 * z0 * z0) / 3.0,
            ]
        };
        let one = |l: &Layer, z0: f64, z1: f64| {
            let alpha = l.young * l.poisson / (1.0 - l.poisson * l.poisson);
            let beta = l.young / (2.0 * (1.0 + l.poisson));
            let s = (1.0 + l.eigenstrain) * (1.0 + l.eigenstrain) - 1.0;
            (moments(z0, z1), alpha, beta, s)
        };
        [one(&self.bottom, z[0], z[1]), one(&self.top, z[1], z[2])]
    }
}

impl ElasticLaw for Bilayer {
    fn name(&self) -> &'static str {
        "bilayer"
    }

    /// Each layer: h_l > 0, E_l > 0, 0 ≤ ν_l < 0.5, ε_l > −1, finite; and h₁ + h₂ equal to the
    /// material's thickness (relative 1e-12), which sets mass and growth.
    fn validate(&self, material: &Material) -> Result<(), EnergyError> {
        for (which, l) in [("bottom", &self.bottom), ("top", &self.top)] {
            let checks: [(&'static str, &'static str, f64, bool, &'static str); 4] = [
                (
                    "bottom.thickness",
                    "top.thickness",
                    l.thickness,
                    l.thickness > 0.0,
                    "must be finite and > 0",
                ),
                (
                    "bottom.young",
                    "top.young",
                    l.young,
                    l.young > 0.0,
                    "must be finite and > 0",
                ),
                (
                    "bottom.poisson",
                    "top.poisson",
                    l.poisson,
                    (0.0..0.5).contains(&l.poisson),
                    "must be finite and in [0, 0.5)",
                ),
                (
                    "bottom.eigenstrain",
                    "top.eigenstrain",
                    l.eigenstrain,
                    l.eigenstrain > -1.0,
                    "must be finite and > -1",
                ),
            ];
            for (bottom_name, top_name, value, ok, reason) in checks {
                if !(ok && value.is_finite()) {
                    let name = if which == "bottom" {
                        bottom_name
                    } else {
                        top_name
                    };
                    return Err(EnergyError::InvalidParameter {
                        name,
                        value,
                        reason,
                    });
                }
            }
        }
        let h = self.thickness();
        if (h - material.thickness).abs() > 1e-12 * h {
            return Err(EnergyError::InvalidParameter {
                name: "thickness",
                value: material.thickness,
                reason: "must equal the bilayer's bottom.thickness + top.thickness",
            });
        }
        Ok(())
    }

    fn coupled(&self) -> bool {
        true
    }

    fn rest_mixed(
        &self,
        _material: &Material,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        a_bar: &Vector3<f64>,
        b_bar: &Vector3<f64>,
        terms: Terms,
    ) -> Option<nalgebra::Matrix6<f64>> {
        Some(super::rest_mixed::bilayer(self, a, b, a_bar, b_bar, terms))
    }

    fn eval(
        &self,
        _material: &Material,
        face: &FaceGeometry,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        terms: Terms,
        order: Order,
        out: &mut LawEval,
    ) {
        out.clear(order);
        let da = a - face.a_bar;
        let v = b - face.b_bar;
        let both = terms.stretch && terms.bend;
        for ([m0, m1, m2], alpha, beta, s) in self.layers() {
            let k = sv_quadratic(&face.a_bar_inv, alpha, beta, face.area / 8.0);
            let u = da - face.a_bar * s;
            let (ku, kv) = (k * u, k * v);
            if terms.stretch {
                out.stretch += m0 * u.dot(&ku);
            }
            if terms.bend {
                out.bend += 4.0 * m2 * v.dot(&kv);
            }
            if both {
                out.bend -= 4.0 * m1 * u.dot(&kv);
            }
            if order != Order::Energy {
                if terms.stretch {
                    out.ga += ku * (2.0 * m0);
                }
                if terms.bend {
                    out.gb += kv * (8.0 * m2);
                }
                if both {
                    out.ga -= kv * (4.0 * m1);
                    out.gb -= ku * (4.0 * m1);
                }
            }
            if order == Order::Hessian {
                if terms.stretch {
                    out.haa += k * (2.0 * m0);
                }
                if terms.bend {
                    out.hbb += k * (8.0 * m2);
                }
                if both {
                    out.hab -= k * (4.0 * m1);
                }
            }
        }
    }
}
