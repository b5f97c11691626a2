//! Compressible neo-Hookean shell (model.md §2.1).

use super::dual::{Dual, DualMat, mat_mul};
use super::{ElasticLaw, FaceGeometry, LawEval, Material, Order};
use crate::stvk_quadratic::sv_norm_sq_general;
use crate::terms::Terms;
use nalgebra::Vector3;

/// Compressible neo-Hookean shell: with A = √det ā, α = Eν/(1−ν²), β = E/(2(1+ν)) (the
/// [`Material`]'s h, E, ν) and ln J = ½ ln(det a / det ā),
///
/// - stretch = h/4 · A · [β (tr(ā⁻¹a) − 2 − 2 ln J) + α ln²J],
/// - bend = h³/24 · A · ‖a⁻¹b − ā⁻¹b̄‖²_SV (the shape operator's change, measured in the
///   current metric).
///
/// At small strain M = ā⁻¹a − I the stretching term equals [`StVK`](super::StVK)'s to second
/// order (tr M − 2 ln J = ½ tr M² + O(M³), ln J = ½ tr M + O(M²)), and so does the bending term
/// on a flat rest shape (b̄ = 0; with b̄ ≠ 0 it also charges the metric change in a⁻¹b̄); the stretching energy grows
/// without bound as det a → 0 and is NaN (flagged `EnergyError::NonFinite` by the assembler)
/// for det a ≤ 0. Derivatives are exact (second-order forward mode in the six form entries).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NeoHookean;

impl ElasticLaw for NeoHookean {
    fn name(&self) -> &'static str {
        "neo_hookean"
    }

    fn coupled(&self) -> bool {
        true // the bending term reads a⁻¹
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
        Some(super::rest_mixed::neo_hookean(
            material, a, b, a_bar, b_bar, terms,
        ))
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
        let ai = face.a_bar_inv;
        let av: [Dual; 3] = std::array::from_fn(|i| Dual::variable(a[i], i));
        let det_a = av[0] * av[2] - av[1] * av[1];
        let mut total = Dual::constant(0.0);
        if terms.stretch {
            // tr(ā⁻¹a) with symmetric ā⁻¹ and a.
            let tr =
                av[0].scale(ai[(0, 0)]) + av[1].scale(2.0 * ai[(0, 1)]) + av[2].scale(ai[(1, 1)]);
            let det_bar = face.a_bar[0] * face.a_bar[2] - face.a_bar[1] * face.a_bar[1];
            let ln_j = (det_a.ln() - Dual::constant(det_bar.ln())).scale(0.5);
            let psi = (tr - Dual::constant(2.0) - ln_j.scale(2.0)).scale(beta)
                + (ln_j * ln_j).scale(alpha);
            let e = psi.scale(h / 4.0 * face.area);
            out.stretch = e.v;
            total = total + e;
        }
        if terms.bend {
            let bv: [Dual; 3] = std::array::from_fn(|i| Dual::variable(b[i], 3 + i));
            let inv_det = det_a.recip();
            let a_inv: DualMat = [
                [av[2] * inv_det, (av[1] * inv_det).scale(-1.0)],
                [(av[1] * inv_det).scale(-1.0), av[0] * inv_det],
            ];
            let b_mat: DualMat = [[bv[0], bv[1]], [bv[1], bv[2]]];
            let s = mat_mul(&a_inv, &b_mat);
            // ā⁻¹b̄ is constant.
            let bb = face.b_bar;
            let s_bar = [
                [
                    ai[(0, 0)] * bb[0] + ai[(0, 1)] * bb[1],
                    ai[(0, 0)] * bb[1] + ai[(0, 1)] * bb[2],
                ],
                [
                    ai[(1, 0)] * bb[0] + ai[(1, 1)] * bb[1],
                    ai[(1, 0)] * bb[1] + ai[(1, 1)] * bb[2],
                ],
            ];
            let diff: DualMat = std::array::from_fn(|i| {
                std::array::from_fn(|j| s[i][j] - Dual::constant(s_bar[i][j]))
            });
            let e = sv_norm_sq_general(&diff, alpha, beta).scale(h * h * h / 24.0 * face.area);
            out.bend = e.v;
            total = total + e;
        }
        if order != Order::Energy {
            out.ga = total.g.fixed_rows::<3>(0).into_owned();
            out.gb = total.g.fixed_rows::<3>(3).into_owned();
        }
        if order == Order::Hessian {
            out.haa = total.h.fixed_view::<3, 3>(0, 0).into_owned();
            out.hab = total.h.fixed_view::<3, 3>(0, 3).into_owned();
            out.hbb = total.h.fixed_view::<3, 3>(3, 3).into_owned();
        }
    }
}
