//! Per-face energy kernel: energy, 18-gradient and 18×18 Hessian of one face stencil.

use crate::density::{inv2, sv_quadratic, sym_entries};
use crate::material::Material;
use crate::sff::SecondFundamentalForm;
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};

/// Positions of a face stencil (m). `x[0..3]`: face vertices in stored order; `x[3 + e]`: flap
/// vertex across local edge e (the edge opposite local vertex e), ignored when `!flap[e]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceStencil {
    /// Stencil positions (m).
    pub x: [Vector3<f64>; 6],
    /// `flap[e]`: edge e is interior (has a flap vertex).
    pub flap: [bool; 3],
}

/// Which energy terms are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Terms {
    /// Stretching (membrane) energy.
    pub stretch: bool,
    /// Bending energy.
    pub bend: bool,
    /// Kelvin–Voigt damping (needs a [`FaceDamping`]).
    pub damping: bool,
}

impl Terms {
    /// All three terms.
    pub const ALL: Terms = Terms {
        stretch: true,
        bend: true,
        damping: true,
    };
}

/// How the Hessian is formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HessianMode {
    /// Exact second derivatives.
    Exact,
    /// Only first-derivative products Jᵀ (∂²E/∂form²) J (PSD by construction).
    GaussNewton,
    /// Exact face Hessian projected to PSD (symmetric eigen-decomposition, negatives clamped to 0).
    ProjectedPsd,
}

/// Energies per term (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyTerms {
    /// Stretching energy (J).
    pub stretch: f64,
    /// Bending energy (J).
    pub bend: f64,
    /// Damping pseudo-energy (J).
    pub damping: f64,
}

impl EnergyTerms {
    /// Sum of the terms (J).
    pub fn total(&self) -> f64 {
        self.stretch + self.bend + self.damping
    }
}

impl std::ops::AddAssign for EnergyTerms {
    fn add_assign(&mut self, o: Self) {
        self.stretch += o.stretch;
        self.bend += o.bend;
        self.damping += o.damping;
    }
}

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

/// Output of [`eval_face`]; dofs ordered x0, x1, x2, flap0, flap1, flap2 (3 coordinates each).
#[derive(Clone, Debug, PartialEq)]
pub struct FaceEval {
    /// Energies (J).
    pub energy: EnergyTerms,
    /// Gradient (N); zero unless requested.
    pub gradient: SVector<f64, 18>,
    /// Hessian (N/m), symmetric; zero unless requested.
    pub hessian: SMatrix<f64, 18, 18>,
}

impl Default for FaceEval {
    fn default() -> Self {
        Self {
            energy: EnergyTerms::default(),
            gradient: SVector::zeros(),
            hessian: SMatrix::zeros(),
        }
    }
}

/// Energy of one face (model.md §2), with A = √det ā and ‖M‖²_SV = α/2 tr(M)² + β tr(M²):
///
/// - stretch = h/8 · ‖ā⁻¹a − I‖²_SV · A  (first 9 dofs only),
/// - bend = h³/24 · ‖ā⁻¹(b − b̄)‖²_SV · A,
/// - damping = (η/E)/Δt · (h/8 ‖a_prev⁻¹(a − a_prev)‖²_SV + h³/24 ‖a_prev⁻¹(b − b_prev)‖²_SV) · A
///   (= (η/E) Δt (… ‖·/Δt‖² …) A); skipped when `damping` is `None`.
///
/// Each is a quadratic dᵀKd in the three form entries (see [`crate::density::sv_quadratic`]); the
/// stretch and damping-stretch quadratics in a, and the bend and damping-bend quadratics in b,
/// are summed before the chain rule H = Jᵀ(∂²E/∂m²)J + Σ_k (∂E/∂m_k) ∇²m_k, so b, its Jacobian and
/// its contracted Hessian are computed once. Only switched-on terms are evaluated. `out` is
/// overwritten (gradient/Hessian zero when not requested). Requesting a Hessian implies the gradient.
#[allow(clippy::too_many_arguments)] // the kernel's inputs are independent plain data
pub fn eval_face(
    sff: &dyn SecondFundamentalForm,
    material: &Material,
    stencil: &FaceStencil,
    rest: &FaceRest,
    damping: Option<&FaceDamping>,
    terms: Terms,
    want: Want,
    out: &mut FaceEval,
) {
    eval_face_parts(
        Some(sff),
        material,
        stencil,
        rest,
        damping,
        terms,
        want,
        out,
    );
    if want.hessian == Some(HessianMode::ProjectedPsd) {
        project_psd(&mut out.hessian);
    }
}

/// [`eval_face`] without the PSD projection; with `sff = None` only the membrane terms
/// (stretching and the membrane part of damping) are evaluated, for callers that evaluate the
/// b-dependent terms with another form (the edge directors).
#[allow(clippy::too_many_arguments)] // the kernel's inputs are independent plain data
pub(crate) fn eval_face_parts(
    sff: Option<&dyn SecondFundamentalForm>,
    material: &Material,
    stencil: &FaceStencil,
    rest: &FaceRest,
    damping: Option<&FaceDamping>,
    terms: Terms,
    want: Want,
    out: &mut FaceEval,
) {
    out.energy = EnergyTerms::default();
    out.gradient.fill(0.0);
    out.hessian.fill(0.0);
    let damping = if terms.damping { damping } else { None };
    let (h, alpha, beta) = (material.thickness, material.alpha(), material.beta());
    let area = rest.a_bar.determinant().sqrt();
    let a_bar_inv = inv2(&rest.a_bar);
    let damp = damping.map(|d| {
        (
            inv2(&d.a_prev),
            material.viscosity / material.young / d.dt,
            d,
        )
    });
    let need_grad = want.gradient || want.hessian.is_some();
    let mode = want.hessian;

    // Membrane part: a(x0, x1, x2).
    if terms.stretch || damp.is_some() {
        let x = &stencil.x;
        let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
        let a = Vector3::new(e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
        let mut k_sum = Matrix3::zeros();
        let mut g = Vector3::zeros();
        if terms.stretch {
            let k = sv_quadratic(&a_bar_inv, alpha, beta, h / 8.0 * area);
            let d = a - sym_entries(&rest.a_bar);
            let kd = k * d;
            out.energy.stretch = d.dot(&kd);
            g += kd * 2.0;
            k_sum += k;
        }
        if let Some((ap_inv, c, fd)) = &damp {
            let k = sv_quadratic(ap_inv, alpha, beta, c * h / 8.0 * area);
            let d = a - sym_entries(&fd.a_prev);
            let kd = k * d;
            out.energy.damping += d.dot(&kd);
            g += kd * 2.0;
            k_sum += k;
        }
        if need_grad {
            // Jacobian of a: rows a11, a12, a22; blocks x0, x1, x2 (same pattern as b with n → e).
            let rows = [
                [-2.0 * e1, 2.0 * e1, Vector3::zeros()],
                [-(e1 + e2), e2, e1],
                [-2.0 * e2, Vector3::zeros(), 2.0 * e2],
            ];
            let mut ja = SMatrix::<f64, 3, 9>::zeros();
            for (k, r) in rows.iter().enumerate() {
                for (b, v) in r.iter().enumerate() {
                    ja.fixed_view_mut::<1, 3>(k, 3 * b)
                        .copy_from(&v.transpose());
                }
            }
            let grad = ja.transpose() * g;
            out.gradient.fixed_rows_mut::<9>(0).copy_from(&grad);
            if mode.is_some() {
                let kj = (k_sum * 2.0) * ja;
                let mut hb = out.hessian.fixed_view_mut::<9, 9>(0, 0);
                hb += ja.transpose() * kj;
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
    }

    // Bending part: b(stencil).
    let Some(sff) = sff else { return };
    if terms.bend || damp.is_some() {
        let h3 = h * h * h / 24.0;
        let mut k_sum = Matrix3::zeros();
        let mut center = Vector3::zeros(); // Σ K_i c_i
        let mut quads: [Option<(Matrix3<f64>, Vector3<f64>)>; 2] = [None, None];
        if terms.bend {
            quads[0] = Some((
                sv_quadratic(&a_bar_inv, alpha, beta, h3 * area),
                sym_entries(&rest.b_bar),
            ));
        }
        if let Some((ap_inv, c, fd)) = &damp {
            quads[1] = Some((
                sv_quadratic(ap_inv, alpha, beta, c * h3 * area),
                sym_entries(&fd.b_prev),
            ));
        }
        for (k, c) in quads.iter().flatten() {
            k_sum += k;
            center += k * c;
        }
        let energies = |b: &Vector3<f64>, out: &mut EnergyTerms| {
            if let Some((k, c)) = &quads[0] {
                let d = b - c;
                out.bend = d.dot(&(k * d));
            }
            if let Some((k, c)) = &quads[1] {
                let d = b - c;
                out.damping += d.dot(&(k * d));
            }
        };
        if !need_grad {
            let b = sym_entries(&sff.b(stencil));
            energies(&b, &mut out.energy);
        } else if mode.is_none() {
            // Gradient only: reverse mode through b, no Jacobian.
            let weights = |b: &Matrix2<f64>| (k_sum * sym_entries(b) - center) * 2.0;
            let (b, _, g) = sff.b_and_weighted_gradient(stencil, &weights);
            energies(&sym_entries(&b), &mut out.energy);
            out.gradient += g;
        } else {
            // Gradient in b first needs b; the contracted Hessian needs that gradient as weights,
            // so for the exact Hessian b is evaluated once cheaply, then derivatives with weights.
            let exact = matches!(mode, Some(HessianMode::Exact | HessianMode::ProjectedPsd));
            let (d, gb) = if exact {
                let b = sym_entries(&sff.b(stencil));
                let gb = (k_sum * b - center) * 2.0;
                let d = sff.b_derivatives(stencil, Some((&gb, &mut out.hessian)));
                (d, gb)
            } else {
                let d = sff.b_derivatives(stencil, None);
                let b = sym_entries(&d.b);
                let gb = (k_sum * b - center) * 2.0;
                (d, gb)
            };
            let b = sym_entries(&d.b);
            energies(&b, &mut out.energy);
            out.gradient += d.jacobian.transpose() * gb;
            if mode.is_some() {
                let kj = (k_sum * 2.0) * d.jacobian;
                out.hessian += d.jacobian.transpose() * kj;
            }
        }
    }
}

/// Replaces a symmetric matrix by its PSD projection V max(Λ, 0) Vᵀ.
pub fn project_psd(h: &mut SMatrix<f64, 18, 18>) {
    crate::director::project_psd_18(h);
}
