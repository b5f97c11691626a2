//! St. Venant–Kirchhoff shell (model.md §2): the quadratic SV-norm energies of the paper.

use super::{ElasticLaw, FaceGeometry, LawEval, Material, Order};
use crate::density::sv_quadratic;
use crate::terms::Terms;
use nalgebra::Vector3;

/// St. Venant–Kirchhoff: with A = √det ā and ‖M‖²_SV = α/2 tr(M)² + β tr(M²)
/// (α = Eν/(1−ν²), β = E/(2(1+ν)), from the [`Material`]'s h, E, ν),
///
/// - stretch = h/8 · ‖ā⁻¹a − I‖²_SV · A,
/// - bend = h³/24 · ‖ā⁻¹(b − b̄)‖²_SV · A.
///
/// Each is a quadratic dᵀKd in the three form entries ([`sv_quadratic`]); no a–b coupling.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StVK;

impl ElasticLaw for StVK {
    fn name(&self) -> &'static str {
        "stvk"
    }

    fn coupled(&self) -> bool {
        false
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
        let (h, alpha, beta) = (m.thickness, m.alpha(), m.beta());
        let quadratic = |scale: f64, d: Vector3<f64>, stretch: bool, out: &mut LawEval| {
            let k = sv_quadratic(&face.a_bar_inv, alpha, beta, scale * face.area);
            let kd = k * d;
            let (e, g, hh) = if stretch {
                (&mut out.stretch, &mut out.ga, &mut out.haa)
            } else {
                (&mut out.bend, &mut out.gb, &mut out.hbb)
            };
            *e = d.dot(&kd);
            if order != Order::Energy {
                *g = kd * 2.0;
            }
            if order == Order::Hessian {
                *hh = k * 2.0;
            }
        };
        if terms.stretch {
            quadratic(h / 8.0, a - face.a_bar, true, out);
        }
        if terms.bend {
            quadratic(h * h * h / 24.0, b - face.b_bar, false, out);
        }
    }
}
