//! The per-face kernel: energy, N-gradient and N×N Hessian of one face for any second
//! fundamental form (N face dofs) and any material law, by one chain rule through the forms.

use crate::density::sv_quadratic;
use crate::linalg::{ProjectPsd, inv2, sym_entries};
use crate::material::{FaceGeometry, LawEval, Material, MaterialModel, Order};
use crate::sff::SecondFundamentalForm;
use crate::stencil::FaceStencil;
pub use crate::terms::{EnergyTerms, HessianMode, Terms};
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};
use std::cell::{Cell, RefCell};

/// Rest forms of a face: ā (m², SPD) and b̄ (m, symmetric), barycentric basis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceRest {
    /// Rest first fundamental form ā.
    pub a_bar: Matrix2<f64>,
    /// Rest second fundamental form b̄.
    pub b_bar: Matrix2<f64>,
}

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
/// entries a, b), plus Kelvin–Voigt damping, with A = √det ā and ‖M‖²_SV = α/2 tr(M)² + β tr(M²)
/// (α, β, h, E, η of `material`):
///
/// damping = (η/E)/Δt · (h/8 ‖a_prev⁻¹(a − a_prev)‖²_SV + h³/24 ‖a_prev⁻¹(b − b_prev)‖²_SV) · A
/// (= (η/E) Δt (… ‖·/Δt‖² …) A), skipped when `damping` is `None`.
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
    let (h, alpha, beta) = (material.thickness, material.alpha(), material.beta());
    let area = rest.a_bar.determinant().sqrt();
    let face = FaceGeometry {
        a_bar: sym_entries(&rest.a_bar),
        b_bar: sym_entries(&rest.b_bar),
        a_bar_inv: inv2(&rest.a_bar),
        area,
    };
    // Damping quadratics (K, centre) in a and in b.
    let damp = damping.map(|d| {
        let ap_inv = inv2(&d.a_prev);
        let c = material.viscosity / material.young / d.dt * area;
        (
            (
                sv_quadratic(&ap_inv, alpha, beta, c * h / 8.0),
                sym_entries(&d.a_prev),
            ),
            (
                sv_quadratic(&ap_inv, alpha, beta, c * h * h * h / 24.0),
                sym_entries(&d.b_prev),
            ),
        )
    });
    let uses_b = terms.bend || damp.is_some();
    let coupled = law.coupled() && terms.bend;
    let uses_a = terms.stretch || damp.is_some() || coupled;
    let x = &stencil.x;
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    let a = Vector3::new(e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
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
        Some((_, (k, c))) => le.gb + k * (b - c) * 2.0,
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
        if let Some((_, (k, _))) = &damp {
            hbb += k * 2.0;
        }
        let kj = hbb * d.jacobian;
        // In place (no N×N temporary): H += Jᵀ (K J).
        out.hessian.gemm_tr(1.0, &d.jacobian, &kj, 1.0);
        if coupled {
            // J_aᵀ H_ab J_b and its transpose; J_a only touches the first 9 dofs.
            let ja = membrane_jacobian(&e1, &e2);
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
    if let Some(((ka, ca), (kb, cb))) = &damp {
        let (da, db) = (a - ca, b - cb);
        out.energy.damping = da.dot(&(ka * da)) + db.dot(&(kb * db));
    }

    // The a-part: a(x0, x1, x2).
    if uses_a && need_grad {
        add_membrane_part(&le, &damp, &a, &e1, &e2, mode, out);
    }
    if mode == Some(HessianMode::ProjectedPsd) {
        out.hessian.project_psd();
    }
}

/// Damping quadratics (K, centre) of a face in a and in b.
type DampQuads = Option<((Matrix3<f64>, Vector3<f64>), (Matrix3<f64>, Vector3<f64>))>;

/// Adds J_aᵀ ∂E/∂a to the gradient and, with a Hessian, J_aᵀ (∂²E/∂a²) J_a plus (unless
/// Gauss–Newton) Σ_k (∂E/∂a_k) ∇²a_k.
fn add_membrane_part<const N: usize>(
    le: &LawEval,
    damp: &DampQuads,
    a: &Vector3<f64>,
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
    mode: Option<HessianMode>,
    out: &mut FaceEval<N>,
) {
    let mut g = le.ga;
    let mut k_sum = le.haa;
    if let Some(((ka, ca), _)) = damp {
        g += ka * (a - ca) * 2.0;
        k_sum += ka * 2.0;
    }
    // J_aᵀ g written out (rows of J_a: a11 = e1·e1, a12 = e1·e2, a22 = e2·e2).
    let g1 = e1 * (2.0 * g[0]) + e2 * g[1];
    let g2 = e1 * g[1] + e2 * (2.0 * g[2]);
    for (blk, v) in [(0, -(g1 + g2)), (1, g1), (2, g2)] {
        let mut r = out.gradient.fixed_rows_mut::<3>(3 * blk);
        r += v;
    }
    if mode.is_some() {
        let ja = membrane_jacobian(e1, e2);
        let kj = k_sum * ja;
        let mut hb = out.hessian.fixed_view_mut::<9, 9>(0, 0);
        hb.gemm_tr(1.0, &ja, &kj, 1.0);
        if mode != Some(HessianMode::GaussNewton) {
            // Σ_k g_k ∇²a_k = (Sᵀ C S) ⊗ I, C = [[2g11, g12], [g12, 2g22]], S = [e1; e2] selector.
            let sel = [(-1.0, -1.0), (1.0, 0.0), (0.0, 1.0)];
            for (i, si) in sel.iter().enumerate() {
                for (j, sj) in sel.iter().enumerate() {
                    let c = 2.0 * g[0] * si.0 * sj.0
                        + g[1] * (si.0 * sj.1 + si.1 * sj.0)
                        + 2.0 * g[2] * si.1 * sj.1;
                    for t in 0..3 {
                        out.hessian[(3 * i + t, 3 * j + t)] += c;
                    }
                }
            }
        }
    }
}

/// Jacobian of a = (a11, a12, a22) w.r.t. (x0, x1, x2), e1 = x1 − x0, e2 = x2 − x0.
#[inline]
fn membrane_jacobian(e1: &Vector3<f64>, e2: &Vector3<f64>) -> SMatrix<f64, 3, 9> {
    let rows = [
        [-2.0 * e1, 2.0 * e1, Vector3::zeros()],
        [-(e1 + e2), *e2, *e1],
        [-2.0 * e2, Vector3::zeros(), 2.0 * e2],
    ];
    let mut ja = SMatrix::<f64, 3, 9>::zeros();
    for (k, r) in rows.iter().enumerate() {
        for (b, v) in r.iter().enumerate() {
            ja.fixed_view_mut::<1, 3>(k, 3 * b)
                .copy_from(&v.transpose());
        }
    }
    ja
}

/// Material constants of the energy-only kernel [`eval_face_energy`], computed once per mesh
/// evaluation instead of once per face: h/8 and h³/24 (m, m³), α/2 and β (Pa), η/E (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnergyConstants {
    h_8: f64,
    h3_24: f64,
    half_alpha: f64,
    beta: f64,
    eta_over_e: f64,
    /// The law is St. Venant–Kirchhoff: its energies are evaluated in closed form here.
    stvk: bool,
}

impl EnergyConstants {
    /// The constants of `material` (not validated: [`crate::Assembler::evaluate`] validates).
    pub fn new(material: &Material) -> Self {
        let h = material.thickness;
        Self {
            h_8: h / 8.0,
            h3_24: h * h * h / 24.0,
            half_alpha: 0.5 * material.alpha(),
            beta: material.beta(),
            eta_over_e: material.viscosity / material.young,
            stvk: matches!(material.model, MaterialModel::StVK),
        }
    }

    /// ‖A⁻¹D‖²_SV = α/2 tr(M)² + β tr(M²), M = A⁻¹D, for symmetric A⁻¹ and D = (d11, d12, d22):
    /// the quadratic form of [`sv_quadratic`] (without its scale) written out, ~20 flops.
    #[inline]
    fn sv_norm_sq(&self, a_inv: &Matrix2<f64>, d: &Vector3<f64>) -> f64 {
        let (p, q, r) = (
            a_inv[(0, 0)],
            0.5 * (a_inv[(0, 1)] + a_inv[(1, 0)]),
            a_inv[(1, 1)],
        );
        let m00 = p * d[0] + q * d[1];
        let m01 = p * d[1] + q * d[2];
        let m10 = q * d[0] + r * d[1];
        let m11 = q * d[1] + r * d[2];
        let t = m00 + m11;
        self.half_alpha * t * t + self.beta * (m00 * m00 + 2.0 * m01 * m10 + m11 * m11)
    }
}

/// Energy terms (J) of one face, the same quantity as [`eval_face`] with nothing but the
/// energy wanted, by a lean path for line-search trials: no gradient or Hessian buffers, b
/// from [`SecondFundamentalForm::b`] only when bending or damping is on, and the St.
/// Venant–Kirchhoff and damping energies in closed form (‖ā⁻¹(a − ā)‖²_SV directly, not
/// through the 3×3 quadratic-form matrices) with `constants` hoisted out of the face loop.
/// Other laws go through [`ElasticLaw::eval`](crate::ElasticLaw::eval) at [`Order::Energy`].
/// Agrees with [`eval_face`] to round-off (tested to 1e-12 relative).
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
    let k = constants;
    let damping = if terms.damping { damping } else { None };
    let x = &stencil.x;
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    let a = Vector3::new(e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
    let b_bar = sym_entries(&rest.b_bar);
    let b = if terms.bend || damping.is_some() {
        sym_entries(&form.b(stencil))
    } else {
        b_bar
    };
    let area = rest.a_bar.determinant().sqrt();
    let a_bar_inv = inv2(&rest.a_bar);
    let mut e = EnergyTerms::default();
    if k.stvk {
        if terms.stretch {
            e.stretch = k.h_8 * area * k.sv_norm_sq(&a_bar_inv, &(a - sym_entries(&rest.a_bar)));
        }
        if terms.bend {
            e.bend = k.h3_24 * area * k.sv_norm_sq(&a_bar_inv, &(b - b_bar));
        }
    } else {
        let face = FaceGeometry {
            a_bar: sym_entries(&rest.a_bar),
            b_bar,
            a_bar_inv,
            area,
        };
        let mut le = LawEval::default();
        material
            .model
            .law()
            .eval(material, &face, &a, &b, terms, Order::Energy, &mut le);
        e.stretch = le.stretch;
        e.bend = le.bend;
    }
    if let Some(d) = damping {
        let ap_inv = inv2(&d.a_prev);
        let c = k.eta_over_e / d.dt * area;
        e.damping = c
            * (k.h_8 * k.sv_norm_sq(&ap_inv, &(a - sym_entries(&d.a_prev)))
                + k.h3_24 * k.sv_norm_sq(&ap_inv, &(b - sym_entries(&d.b_prev))));
    }
    e
}
