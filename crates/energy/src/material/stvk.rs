//! St. Venant–Kirchhoff shell (model.md §2): the quadratic SV-norm energies of the paper.

use super::{ElasticLaw, EnergyConstants, FaceGeometry, LawEval, Material, Order};
use crate::real::{Real, Vec3};
use crate::stvk_quadratic::{inv_entries, sv_norm_sq_of, sv_quadratic, sv_quadratic_times};
use crate::terms::Terms;
use nalgebra::Vector3;

/// St. Venant–Kirchhoff: with A = √det ā and ‖M‖²_SV = α/2 tr(M)² + β tr(M²)
/// (α = Eν/(1−ν²), β = E/(2(1+ν)), from the [`Material`]'s h, E, ν),
///
/// - stretch = h/8 · ‖ā⁻¹a − I‖²_SV · A,
/// - bend = h³/24 · ‖ā⁻¹(b − b̄)‖²_SV · A.
///
/// Each is a quadratic dᵀKd in the three form entries ([`crate::stvk_quadratic`]); no a–b
/// coupling. The energy alone is the SV norm written out (`sv_energy_of`), the gradient
/// 2Kd without forming K, the Hessian 2K.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StVK;

impl ElasticLaw for StVK {
    fn name(&self) -> &'static str {
        "stvk"
    }

    fn coupled(&self) -> bool {
        false
    }

    fn rest_mixed(
        &self,
        material: &Material,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        a_bar: &Vector3<f64>,
        b_bar: &Vector3<f64>,
        terms: Terms,
    ) -> Option<nalgebra::Matrix6<f64>> {
        Some(super::rest_mixed::stvk(material, a, b, a_bar, b_bar, terms))
    }

    fn eval(
        &self,
        m: &Material,
        face: &FaceGeometry,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        terms: Terms,
        order: Order,
        out: &mut LawEval,
    ) {
        out.clear(order);
        if order == Order::Energy {
            (out.stretch, out.bend) = self.energy(m, &EnergyConstants::new(m), face, a, b, terms);
            return;
        }
        let (h, alpha, beta) = (m.thickness, m.alpha(), m.beta());
        let quadratic = |scale: f64, d: Vector3<f64>, stretch: bool, out: &mut LawEval| {
            let c = scale * face.area;
            let (e, g, hh) = if stretch {
                (&mut out.stretch, &mut out.ga, &mut out.haa)
            } else {
                (&mut out.bend, &mut out.gb, &mut out.hbb)
            };
            if order == Order::Hessian {
                let k = sv_quadratic(&face.a_bar_inv, alpha, beta, c);
                let kd = k * d;
                *e = d.dot(&kd);
                *g = kd * 2.0;
                *hh = k * 2.0;
            } else {
                let kd = sv_quadratic_times(&face.a_bar_inv, alpha, beta, c, &d);
                *e = d.dot(&kd);
                *g = kd * 2.0;
            }
        };
        if terms.stretch {
            quadratic(h / 8.0, a - face.a_bar, true, out);
        }
        if terms.bend {
            quadratic(h * h * h / 24.0, b - face.b_bar, false, out);
        }
    }

    /// The SV norms written out, no 3×3 matrices (`sv_energy_of`, shared with the batched pass).
    #[inline]
    fn energy(
        &self,
        _material: &Material,
        k: &EnergyConstants,
        face: &FaceGeometry,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        terms: Terms,
    ) -> (f64, f64) {
        let inv = inv_entries(&face.a_bar_inv);
        let term = |scale: f64, d: Vector3<f64>| {
            sv_energy_of(scale, face.area, &inv, k.half_alpha, k.beta, &d.into())
        };
        let stretch = if terms.stretch {
            term(k.h_8, a - face.a_bar)
        } else {
            0.0
        };
        let bend = if terms.bend {
            term(k.h3_24, b - face.b_bar)
        } else {
            0.0
        };
        (stretch, bend)
    }
}

/// One StVK energy term `scale`·A·‖ā⁻¹D‖²_SV (J) from ā⁻¹'s entries `inv` and D's entries `d`,
/// over any [`Real`]: the energy-only kernel's and the batched pass's one definition
/// (`scale` = h/8 for stretching, h³/24 for bending).
#[inline(always)]
pub(crate) fn sv_energy_of<T: Real>(
    scale: f64,
    area: T,
    inv: &Vec3<T>,
    half_alpha: f64,
    beta: f64,
    d: &Vec3<T>,
) -> T {
    T::cst(scale) * area * sv_norm_sq_of(inv, half_alpha, beta, d)
}
