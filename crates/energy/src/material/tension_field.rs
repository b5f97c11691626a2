//! Tension-field St. Venant–Kirchhoff membrane (model.md §2.3): StVK stretching with the
//! compressive stress relaxed, the continuum model of a finely wrinkled sheet (the formulation
//! of libshell's `TensionFieldStVKMaterial`).

use super::dual::{Dual1, DualN, Scalar};
use super::{ElasticLaw, FaceGeometry, LawEval, Material, Order, StVK};
use crate::stvk_quadratic::inv_entries;
use crate::terms::Terms;
use nalgebra::Vector3;

/// Tension-field StVK membrane. With M = ā⁻¹a − I (principal strains λ₁ ≥ λ₂, real: M is
/// similar to a symmetric matrix), A = √det ā and α, β of the [`Material`]'s h, E, ν:
///
/// - **taut** (λ₁ ≥ 0 and λ₂ ≥ −α/2 / (α/2 + β) · λ₁: both principal stresses ≥ 0): the
///   [`StVK`] stretching h/8 · A · ‖M‖²_SV;
/// - **wrinkled** (λ₁ ≥ 0, λ₂ below that bound): the StVK energy minimised over λ₂, i.e. the
///   stress across the wrinkles relaxed to zero: h/8 · A · k λ₁² with
///   k = β(α + β)/(α/2 + β) (= E/2, uniaxial stress);
/// - **slack** (λ₁ < 0): 0.
///
/// The energy is C¹ in the forms (its gradient is continuous across the three regions) and
/// piecewise C^∞. The Hessian is that of the region the branch test picks, as libshell does:
/// on the taut/wrinkled boundary the taut (StVK) one, at λ₁ = 0 with λ₂ < 0 the wrinkled one
/// (the one-sided second derivative). No bending energy (as libshell's: the material models a
/// membrane whose wrinkles carry no bending stiffness), so the law is not coupled. Derivatives
/// of the wrinkled branch are exact (forward-mode numbers in a; its λ₁ > λ₂ strictly, so √ of
/// the discriminant is differentiable there).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TensionField;

/// Which branch of [`TensionField`] a strain is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Region {
    Taut,
    Wrinkled,
    Slack,
}

/// The larger principal strain λ₁ = tr M/2 + √(tr²M/4 − det M) of M = ā⁻¹D for the entries
/// d of D = a − ā and those (p, q, r) of ā⁻¹.
fn largest_strain<S: Scalar>(d: &[S; 3], [p, q, r]: [f64; 3]) -> S {
    let half_tr = (d[0].scale(p) + d[1].scale(2.0 * q) + d[2].scale(r)).scale(0.5);
    let det = (d[0] * d[2] - d[1] * d[1]).scale(p * r - q * q);
    half_tr + (half_tr * half_tr - det).sqrt()
}

/// The wrinkled branch's energy c·λ₁² (c = h/8 · A · k).
fn wrinkled<S: Scalar>(d: &[S; 3], inv: [f64; 3], c: f64) -> S {
    let l1 = largest_strain(d, inv);
    (l1 * l1).scale(c)
}

/// The region of the strain d = a − ā (f64; the discriminant clamped at 0 against round-off).
fn region(d: &Vector3<f64>, inv: [f64; 3], alpha: f64, beta: f64) -> Region {
    let [p, q, r] = inv;
    let half_tr = 0.5 * (p * d[0] + 2.0 * q * d[1] + r * d[2]);
    let det = (p * r - q * q) * (d[0] * d[2] - d[1] * d[1]);
    let root = (half_tr * half_tr - det).max(0.0).sqrt();
    let (l1, l2) = (half_tr + root, half_tr - root);
    if l1 < 0.0 {
        Region::Slack
    } else if l2 >= -0.5 * alpha / (0.5 * alpha + beta) * l1 {
        Region::Taut
    } else {
        Region::Wrinkled
    }
}

impl ElasticLaw for TensionField {
    fn name(&self) -> &'static str {
        "tension_field"
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
        if !terms.stretch {
            return;
        }
        let (alpha, beta) = (m.alpha(), m.beta());
        let inv = inv_entries(&face.a_bar_inv);
        let d = a - face.a_bar;
        match region(&d, inv, alpha, beta) {
            Region::Slack => {}
            Region::Taut => {
                let stretch_only = Terms {
                    stretch: true,
                    bend: false,
                    damping: false,
                };
                StVK.eval(m, face, a, b, stretch_only, order, out);
            }
            Region::Wrinkled => {
                let c =
                    m.thickness / 8.0 * face.area * (beta * (alpha + beta) / (0.5 * alpha + beta));
                match order {
                    Order::Energy => out.stretch = wrinkled(&[d[0], d[1], d[2]], inv, c),
                    Order::Gradient => {
                        let dv: [Dual1<3>; 3] = std::array::from_fn(|i| Dual1::variable(d[i], i));
                        let e = wrinkled(&dv, inv, c);
                        (out.stretch, out.ga) = (e.v, e.g);
                    }
                    Order::Hessian => {
                        let dv: [DualN<3>; 3] = std::array::from_fn(|i| DualN::variable(d[i], i));
                        let e = wrinkled(&dv, inv, c);
                        (out.stretch, out.ga, out.haa) = (e.v, e.g, e.h);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;

    /// The wrinkled branch's constant is E/2 (uniaxial stress) for every ν, to 1e-15
    /// relative, and the region boundary λ₂ = −α/2/(α/2 + β) λ₁ is −ν (the Poisson contraction
    /// of uniaxial stress in the strain M = 2ε).
    #[test]
    fn wrinkled_constant_is_uniaxial() {
        for nu in [0.0, 0.2, 0.3, 0.45] {
            let m = Material {
                poisson: nu,
                ..Material::paper()
            };
            let (alpha, beta) = (m.alpha(), m.beta());
            let k = beta * (alpha + beta) / (0.5 * alpha + beta);
            assert!((k / (0.5 * m.young) - 1.0).abs() <= 1e-15, "ν = {nu}: {k}");
            let bound = -0.5 * alpha / (0.5 * alpha + beta);
            assert!((bound + nu).abs() <= 1e-15, "ν = {nu}: {bound}");
        }
    }

    /// The three regions at diagonal strains on ā = I (ν = 0.3, bound −0.3).
    #[test]
    fn regions_of_diagonal_strains() {
        let m = Material::paper();
        let face = FaceGeometry {
            a_bar: Vector3::new(1.0, 0.0, 1.0),
            b_bar: Vector3::zeros(),
            a_bar_inv: Matrix2::identity(),
            area: 1.0,
        };
        let inv = inv_entries(&face.a_bar_inv);
        let at = |l1: f64, l2: f64| region(&Vector3::new(l1, 0.0, l2), inv, m.alpha(), m.beta());
        assert_eq!(at(0.1, 0.05), Region::Taut);
        assert_eq!(at(0.1, -0.029), Region::Taut);
        assert_eq!(at(0.1, -0.031), Region::Wrinkled);
        assert_eq!(at(-0.031, 0.1), Region::Wrinkled);
        assert_eq!(at(-0.01, -0.02), Region::Slack);
        assert_eq!(at(0.0, 0.0), Region::Taut);
    }
}
