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
                return;
            }
            // K d without forming K (energy and gradient paths): K = c (α/2 v vᵀ + β Q) with
            // v = (p, 2q, r) and Q of `sv_quadratic`, for ā⁻¹ = [[p, q], [q, r]].
            let ai = &face.a_bar_inv;
            let (p, q, r) = (ai[(0, 0)], 0.5 * (ai[(0, 1)] + ai[(1, 0)]), ai[(1, 1)]);
            let v = Vector3::new(p, 2.0 * q, r);
            let qd = Vector3::new(
                p * p * d[0] + 2.0 * p * q * d[1] + q * q * d[2],
                2.0 * p * q * d[0] + 2.0 * (q * q + p * r) * d[1] + 2.0 * q * r * d[2],
                q * q * d[0] + 2.0 * q * r * d[1] + r * r * d[2],
            );
            let kd = (v * (0.5 * alpha * v.dot(&d)) + qd * beta) * c;
            *e = d.dot(&kd);
            if order == Order::Gradient {
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
}
