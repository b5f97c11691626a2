//! Sensitivity of the elastic forces to the rest forms: the mixed second derivative
//! ∂²E_face/∂x∂m̄ of one face over its N dofs and its six rest-form entries
//! m̄ = (ā11, ā12, ā22, b̄11, b̄12, b̄22) (symmetric-entry convention of
//! [`crate::small_matrix::sym_entries`]: the m12 entries move both off-diagonal entries together).
//!
//! The adjoint of a static equilibrium x*(m̄) needs it (`thinshell-design`):
//! dJ/dm̄ = ∂J/∂m̄ − λᵀ ∂²E/∂x∂m̄ with H λ = ∂J/∂x. No discrete second fundamental form
//! depends on the rest forms, so the chain rule through the forms m = (a, b) is one product:
//!
//! ∂²E/∂x∂m̄ = J_aᵀ ∂²W/∂a∂m̄ + J_bᵀ ∂²W/∂b∂m̄,
//!
//! with J_a (3×9, the metric's Jacobian) and J_b (3×N, the form's) those of [`crate::eval_face`]
//! and ∂²W/∂m∂m̄ the law's [`ElasticLaw::rest_mixed`](crate::ElasticLaw::rest_mixed). Only
//! the elastic terms (stretching, bending) are covered: Kelvin–Voigt damping has no static
//! part. Whole meshes: [`Assembler::rest_adjoint_product`](crate::Assembler::rest_adjoint_product)
//! and [`Assembler::rest_mixed_matrix`](crate::Assembler::rest_mixed_matrix).

use crate::error::EnergyError;
use crate::face_stencil::FaceStencil;
use crate::kernel::FaceRest;
use crate::material::Material;
use crate::membrane_strain::{edges, metric, metric_jacobian};
use crate::sff::SecondFundamentalForm;
use crate::small_matrix::sym_entries;
use crate::terms::Terms;
use nalgebra::SMatrix;

/// ∂²E/∂x∂m̄ of one face (N × 6: rows the form's N face dofs in [`crate::FaceEval`] order,
/// columns m̄ = (ā11, ā12, ā22, b̄11, b̄12, b̄22)) for the elastic terms on in `terms`
/// (damping ignored), at the stencil's positions and edge angles.
///
/// Errors with [`EnergyError::Unsupported`] when the material's law does not provide
/// [`ElasticLaw::rest_mixed`](crate::ElasticLaw::rest_mixed).
pub fn face_rest_mixed<const N: usize, F>(
    form: &F,
    material: &Material,
    stencil: &FaceStencil,
    rest: &FaceRest,
    terms: Terms,
) -> Result<SMatrix<f64, N, 6>, EnergyError>
where
    F: SecondFundamentalForm<N> + ?Sized,
{
    let law = material.model.law();
    let (e1, e2) = edges(&[stencil.x[0], stencil.x[1], stencil.x[2]]);
    let a = metric(&e1, &e2);
    let (a_bar, b_bar) = (sym_entries(&rest.a_bar), sym_entries(&rest.b_bar));
    let derivatives = terms.bend.then(|| form.b_derivatives(stencil, None));
    let b = derivatives.as_ref().map_or(b_bar, |d| sym_entries(&d.b));
    let elastic = Terms {
        damping: false,
        ..terms
    };
    let m = law
        .rest_mixed(material, &a, &b, &a_bar, &b_bar, elastic)
        .ok_or(EnergyError::Unsupported {
            what: "rest-form derivatives (ElasticLaw::rest_mixed)",
            of: law.name(),
        })?;
    let mut out = SMatrix::<f64, N, 6>::zeros();
    let ja = metric_jacobian(&e1, &e2);
    let top = ja.transpose() * m.fixed_rows::<3>(0);
    out.fixed_rows_mut::<9>(0).copy_from(&top);
    if let Some(d) = derivatives {
        out += d.jacobian.transpose() * m.fixed_rows::<3>(3);
    }
    Ok(out)
}
