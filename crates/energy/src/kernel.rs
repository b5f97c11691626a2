//! The per-face kernel: energy, N-gradient and N×N Hessian of one face for any second
//! fundamental form (N face dofs) and any material law, by one chain rule through the forms.

use crate::damping::{DampingQuadratics, FaceDamping, damping_energy};
use crate::face_stencil::FaceStencil;
use crate::material::{EnergyConstants, FaceGeometry, LawEval, Material, Order};
use crate::membrane_strain::{add_metric_hessian, edges, metric, metric_gradient, metric_jacobian};
use crate::sff::SecondFundamentalForm;
use crate::small_matrix::{ProjectPsd, inv2, sym_entries};
use crate::terms::{EnergyTerms, HessianMode, Terms};
use nalgebra::{Matrix2, SMatrix, SVector, Vector3};
use std::cell::{Cell, RefCell};

/// Rest forms of a face: ā (m², SPD) and b̄ (m, symmetric), barycentric basis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceRest {
    /// Rest first fundamental form ā.
    pub a_bar: Matrix2<f64>,
    /// Rest second fundamental form b̄.
    pub b_bar: Matrix2<f64>,
}

/// What to compute besides the energy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Want {
    /// Compute the gradient.
    pub gradient: bool,
    /// Compute the Hessian in this mode (also computes the gradient).
    pub hessian: Option<HessianMode>,
}

/// Output of [`eval_face`] over the form's N face dofs: x0, x1, x2, flap0, flap1, flap2
/// (3 coordinates each), then the form's extra unknowns (φ_0, φ_1, φ_2 for N = 21).
#[derive(Clone, Debug, PartialEq)]
pub struct FaceEval<const N: usize = 18> {
    /// Energies (J).
    pub energy: EnergyTerms,
    /// Gradient (N for positions, J/rad for angles); unspecified unless requested.
    pub gradient: SVector<f64, N>,
    /// Hessian (N/m, N/rad, J/rad²), symmetric; unspecified unless requested.
    pub hessian: SMatrix<f64, N, N>,
}

impl<const N: usize> Default for FaceEval<N> {
    fn default() -> Self {
        Self {
            energy: EnergyTerms::default(),
            gradient: SVector::zeros(),
            hessian: SMatrix::zeros(),
        }
    }
}

/// Energy of one face (model.md §2) with b from `form` over its N dofs and the elastic energy
/// of `material`'s law ([`crate::ElasticLaw`]: stretching and bending as functions of the form
/// entries a, b), plus Kelvin–Voigt damping ([`crate::damping`], skipped when `damping` is
/// `None`); the metric a and its derivatives are [`crate::membrane_strain`]'s.
///
/// One chain rule for every term: with m = (a, b) the six form entries, E(m) the law's energy
/// plus the damping quadratics, J_a (3×9, the face vertices) and J_b (3×N, from the form),
///
/// ∇E = J_aᵀ ∂E/∂a + J_bᵀ ∂E/∂b,
/// ∇²E = Jᵀ (∂²E/∂m²) J + Σ_k (∂E/∂a_k) ∇²a_k + Σ_k (∂E/∂b_k) ∇²b_k,
///
/// b, its Jacobian and its contracted Hessian computed once (the last two terms dropped for
/// [`HessianMode::GaussNewton`]; [`HessianMode::ProjectedPsd`] projects the exact face Hessian).
/// The gradient alone goes through b in reverse mode, without the Jacobian. Only switched-on
/// terms are evaluated: with bending and damping off, the flap slots and the form are not read.
/// `out.energy` is overwritten, and `out.gradient` / `out.hessian` when requested (a Hessian
/// implies the gradient); unrequested ones are left as they are.
#[allow(clippy::too_many_arguments)] // the kernel's inputs are independent plain data
pub fn eval_face<const N: usize, F>(
    form: &F,
    material: &Material,
    stencil: &FaceStencil,
    rest: &FaceRest,
    damping: Option<&FaceDamping>,
    terms: Terms,
    want: Want,
    out: &mut FaceEval<N>,
) where
    F: SecondFundamentalForm<N> + ?Sized,
    SMatrix<f64, N, N>: ProjectPsd,
{
    let mode = want.hessian;
    let need_grad = want.gradient || mode.is_some();
    out.energy = EnergyTerms::default();
    // Through the slices: nalgebra's `fill` walks its element iterator (a scalar loop with a
    // branch per element, about a third of this function's own time on the 18×18 Hessian),
    // a slice fill is a memset.
    if need_grad {
        out.gradient.as_mut_slice().fill(0.0);
    }
    if mode.is_some() {
        out.hessian.as_mut_slice().fill(0.0);
    }
    let law = material.model.law();
    let damping = if terms.damping { damping } else { None };
    let area = rest.a_bar.determinant().sqrt();
    let face = FaceGeometry {
        a_bar: sym_entries(&rest.a_bar),
        b_bar: sym_entries(&rest.b_bar),
        a_bar_inv: inv2(&rest.a_bar),
        area,
    };
    let damp = damping.map(|d| DampingQuadratics::new(material, area, d));
    let uses_b = terms.bend || damp.is_some();
    let coupled = law.coupled() && terms.bend;
    let uses_a = terms.stretch || damp.is_some() || coupled;
    let (e1, e2) = edges(&[stencil.x[0], stencil.x[1], stencil.x[2]]);
    let a = metric(&e1, &e2);
    let order = match (need_grad, mode) {
        (_, Some(_)) => Order::Hessian,
        (true, None) => Order::Gradient,
        (false, None) => Order::Energy,
    };
    let mut le = LawEval::default();
    // Whether `le` already holds the law at (a, b) to the order needed.
    let mut law_done = false;
    // ∂E/∂b of the law plus the damping quadratic in b, at b.
    let grad_b = |le: &LawEval, b: &Vector3<f64>| match &damp {
        Some(dq) => le.gb + dq.gradient_b(b),
        None => le.gb,
    };

    // b and the b-part of the derivatives.
    let b = if !uses_b {
        face.b_bar
    } else if !need_grad {
        sym_entries(&form.b(stencil))
    } else if mode.is_none() {
        // Gradient only: reverse mode through b, no Jacobian. The law's evaluation at b made
        // for the weights is kept for the energy and the a-part (not evaluated twice).
        // (RefCell: `weights` is a `&dyn Fn`; borrowing avoids copying the LawEval around.)
        let seen = Cell::new(None);
        let cell = RefCell::new(LawEval::default());
        let weights = |bm: &Matrix2<f64>| {
            let b = sym_entries(bm);
            let mut lw = cell.borrow_mut();
            law.eval(material, &face, &a, &b, terms, Order::Gradient, &mut lw);
            seen.set(Some(b));
            grad_b(&lw, &b)
        };
        let (bm, _, g) = form.b_and_weighted_gradient(stencil, &weights);
        out.gradient += g;
        let b = sym_entries(&bm);
        if seen.get() == Some(b) {
            le = cell.into_inner();
            law_done = true;
        }
        b
    } else {
        // The contracted Hessian's weights need ∂E/∂b, hence b, first.
        let exact = mode != Some(HessianMode::GaussNewton);
        let (d, b) = if exact {
            let b = sym_entries(&form.b(stencil));
            law.eval(material, &face, &a, &b, terms, order, &mut le);
            let gb = grad_b(&le, &b);
            (
                form.b_derivatives(stencil, Some((&gb, &mut out.hessian))),
                b,
            )
        } else {
            let d = form.b_derivatives(stencil, None);
            let b = sym_entries(&d.b);
            (d, b)
        };
        if !exact {
            law.eval(material, &face, &a, &b, terms, order, &mut le);
        }
        let gb = grad_b(&le, &b);
        out.gradient += d.jacobian.transpose() * gb;
        let mut hbb = le.hbb;
        if let Some(dq) = &damp {
            hbb += dq.hessian_b();
        }
        let kj = hbb * d.jacobian;
        // In place (no N×N temporary): H += Jᵀ (K J).
        out.hessian.gemm_tr(1.0, &d.jacobian, &kj, 1.0);
        if coupled {
            // J_aᵀ H_ab J_b and its transpose; J_a only touches the first 9 dofs.
            let ja = metric_jacobian(&e1, &e2);
            let cross = ja.transpose() * (le.hab * d.jacobian);
            let mut top = out.hessian.fixed_rows_mut::<9>(0);
            top += cross;
            let mut left = out.hessian.fixed_columns_mut::<9>(0);
            left += cross.transpose();
        }
        b
    };
    if !(law_done || uses_b && mode.is_some()) {
        // The Hessian branch above has evaluated the law already.
        law.eval(material, &face, &a, &b, terms, order, &mut le);
    }
    out.energy.stretch = le.stretch;
    out.energy.bend = le.bend;
    if let Some(dq) = &damp {
        out.energy.damping = dq.energy(&a, &b);
    }

    // The a-part: a(x0, x1, x2).
    if uses_a && need_grad {
        add_membrane_part(&le, &damp, &a, &e1, &e2, mode, out);
    }
    if mode == Some(HessianMode::ProjectedPsd) {
        out.hessian.project_psd();
    }
}

/// Adds J_aᵀ ∂E/∂a to the gradient and, with a Hessian, J_aᵀ (∂²E/∂a²) J_a plus (unless
/// Gauss–Newton) Σ_k (∂E/∂a_k) ∇²a_k.
fn add_membrane_part<const N: usize>(
    le: &LawEval,
    damp: &Option<DampingQuadratics>,
    a: &Vector3<f64>,
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
    mode: Option<HessianMode>,
    out: &mut FaceEval<N>,
) {
    let mut g = le.ga;
    let mut k_sum = le.haa;
    if let Some(dq) = damp {
        g += dq.gradient_a(a);
        k_sum += dq.hessian_a();
    }
    for (blk, v) in metric_gradient(&g, e1, e2).iter().enumerate() {
        let mut r = out.gradient.fixed_rows_mut::<3>(3 * blk);
        r += v;
    }
    if mode.is_some() {
        let ja = metric_jacobian(e1, e2);
        let kj = k_sum * ja;
        let mut hb = out.hessian.fixed_view_mut::<9, 9>(0, 0);
        hb.gemm_tr(1.0, &ja, &kj, 1.0);
        if mode != Some(HessianMode::GaussNewton) {
            add_metric_hessian(&g, &mut out.hessian);
        }
    }
}

/// Energy terms (J) of one face, the same quantity as [`eval_face`] with nothing but the
/// energy wanted, by a lean path for line-search trials: no gradient or Hessian buffers, b
/// from [`SecondFundamentalForm::b`] only when bending or damping is on, the law's energies by
/// [`ElasticLaw::energy`](crate::ElasticLaw::energy) (St. Venant–Kirchhoff in closed form,
/// statically dispatched) and the damping by [`damping_energy`], with `constants` hoisted out
/// of the face loop. Agrees with [`eval_face`] to round-off (tested to 1e-12 relative).
pub fn eval_face_energy<const N: usize, F>(
    form: &F,
    material: &Material,
    constants: &EnergyConstants,
    stencil: &FaceStencil,
    rest: &FaceRest,
    damping: Option<&FaceDamping>,
    terms: Terms,
) -> EnergyTerms
where
    F: SecondFundamentalForm<N> + ?Sized,
{
    let damping = if terms.damping { damping } else { None };
    let (e1, e2) = edges(&[stencil.x[0], stencil.x[1], stencil.x[2]]);
    let a = metric(&e1, &e2);
    let b_bar = sym_entries(&rest.b_bar);
    let b = if terms.bend || damping.is_some() {
        sym_entries(&form.b(stencil))
    } else {
        b_bar
    };
    let area = rest.a_bar.determinant().sqrt();
    let face = FaceGeometry {
        a_bar: sym_entries(&rest.a_bar),
        b_bar,
        a_bar_inv: inv2(&rest.a_bar),
        area,
    };
    let (stretch, bend) = material
        .model
        .energy(material, constants, &face, &a, &b, terms);
    EnergyTerms {
        stretch,
        bend,
        damping: damping.map_or(0.0, |d| damping_energy(constants, area, &a, &b, d)),
    }
}
