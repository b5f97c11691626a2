//! Bending energy of a face with the edge-director second fundamental form (model.md §1.1),
//! and the edge orientation signs σ it needs from the mesh topology.
//!
//! Only the bending term depends on the edge angles; stretching and damping stay with
//! [`eval_face`](crate::eval_face).

use crate::density::{inv2, sv_quadratic, sym_entries};
use crate::kernel::{FaceDamping, FaceRest, FaceStencil, HessianMode, Want};
use crate::material::Material;
use crate::sff::{DIRECTOR_DOFS, EdgeAngles, EdgeDirector};
use nalgebra::{SMatrix, SVector, SymmetricEigen, Vector3};
use thinshell_mesh::{FaceId, Mesh};

/// σ_{f,e} for every face f and local edge e (opposite local vertex e): +1 when the edge's
/// stored direction (`Edge::vertices[0] → [1]`) is the direction f runs it
/// (`f[e+1] → f[e+2]`), else −1. The two faces of an interior edge get opposite signs on a
/// consistently oriented mesh.
pub fn edge_signs(mesh: &Mesh) -> Vec<[f64; 3]> {
    let topo = mesh.topology();
    mesh.faces()
        .iter()
        .enumerate()
        .map(|(f, face)| {
            let ids = topo.face_edges(FaceId::new(f));
            std::array::from_fn(|e| {
                if topo.edge(ids[e]).vertices[0] == face[(e + 1) % 3] {
                    1.0
                } else {
                    -1.0
                }
            })
        })
        .collect()
}

/// Output of [`eval_director_bend`]; dofs x0, x1, x2, flap0, flap1, flap2 (3 each), φ_0, φ_1, φ_2.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectorFaceEval {
    /// Bending energy (J).
    pub energy: f64,
    /// Bending part of the Kelvin–Voigt damping pseudo-energy (J); 0 without damping.
    pub damping: f64,
    /// Gradient (N for positions, J/rad for angles); zero unless requested.
    pub gradient: SVector<f64, DIRECTOR_DOFS>,
    /// Hessian (N/m, N/rad, J/rad²), symmetric; zero unless requested.
    pub hessian: SMatrix<f64, DIRECTOR_DOFS, DIRECTOR_DOFS>,
}

impl Default for DirectorFaceEval {
    fn default() -> Self {
        Self {
            energy: 0.0,
            damping: 0.0,
            gradient: SVector::zeros(),
            hessian: SMatrix::zeros(),
        }
    }
}

/// Bending energy h³/24 · ‖ā⁻¹(b − b̄)‖²_SV · √det ā (J) of one face with b from the edge
/// director form at `angles`, its gradient and Hessian over the 21 face dofs.
///
/// The energy is the quadratic dᵀKd, d = b − b̄ ([`sv_quadratic`]), so
/// ∇E = Jᵀ 2Kd and ∇²E = Jᵀ 2K J + Σ_k (2Kd)_k ∇²b_k (the last term dropped for
/// [`HessianMode::GaussNewton`]; [`HessianMode::ProjectedPsd`] clamps negative eigenvalues of
/// the exact one). `out` is overwritten; a Hessian implies the gradient.
pub fn eval_director_bend(
    form: &EdgeDirector,
    material: &Material,
    stencil: &FaceStencil,
    angles: &EdgeAngles,
    rest: &FaceRest,
    want: Want,
    out: &mut DirectorFaceEval,
) {
    eval_director_b_terms(form, material, stencil, angles, rest, None, want, out);
    if want.hessian == Some(HessianMode::ProjectedPsd) {
        project_psd(&mut out.hessian);
    }
}

/// The b-dependent terms of a face with the edge-director form: bending (always) and, when
/// `damping` is given, the bending part of Kelvin–Voigt damping
/// (η/E)/Δt · h³/24 ‖a_prev⁻¹(b − b_prev)‖²_SV · √det ā. Both are quadratics in b, summed before
/// the chain rule so that b and its derivatives are computed once. No PSD projection here (the
/// caller projects the whole face Hessian).
#[allow(clippy::too_many_arguments)] // independent plain inputs of one kernel
pub(crate) fn eval_director_b_terms(
    form: &EdgeDirector,
    material: &Material,
    stencil: &FaceStencil,
    angles: &EdgeAngles,
    rest: &FaceRest,
    damping: Option<&FaceDamping>,
    want: Want,
    out: &mut DirectorFaceEval,
) {
    out.energy = 0.0;
    out.damping = 0.0;
    out.gradient.fill(0.0);
    out.hessian.fill(0.0);
    let h3 = material.thickness.powi(3) / 24.0;
    let area = rest.a_bar.determinant().sqrt();
    let bend = (
        sv_quadratic(
            &inv2(&rest.a_bar),
            material.alpha(),
            material.beta(),
            h3 * area,
        ),
        sym_entries(&rest.b_bar),
    );
    let damp = damping.map(|d| {
        let c = material.viscosity / material.young / d.dt;
        (
            sv_quadratic(
                &inv2(&d.a_prev),
                material.alpha(),
                material.beta(),
                c * h3 * area,
            ),
            sym_entries(&d.b_prev),
        )
    });
    // Σ_i (b − c_i)ᵀ K_i (b − c_i) has gradient 2(K b − Σ K_i c_i) in b.
    let mut k_sum = bend.0;
    let mut center = bend.0 * bend.1;
    if let Some((k, c)) = &damp {
        k_sum += k;
        center += k * c;
    }
    let energies = |b: &Vector3<f64>, out: &mut DirectorFaceEval| {
        let d = b - bend.1;
        out.energy = d.dot(&(bend.0 * d));
        if let Some((k, c)) = &damp {
            let d = b - c;
            out.damping = d.dot(&(k * d));
        }
    };
    if !want.gradient && want.hessian.is_none() {
        let b = sym_entries(&form.b_with_angles(stencil, angles));
        energies(&b, out);
        return;
    }
    let exact = matches!(
        want.hessian,
        Some(HessianMode::Exact | HessianMode::ProjectedPsd)
    );
    // The contracted Hessian's weights need b first.
    let der = if exact {
        let b = sym_entries(&form.b_with_angles(stencil, angles));
        let w = (k_sum * b - center) * 2.0;
        form.derivatives(stencil, angles, Some((&w, &mut out.hessian)))
    } else {
        form.derivatives(stencil, angles, None)
    };
    let b = sym_entries(&der.b);
    energies(&b, out);
    out.gradient = der.jacobian.transpose() * ((k_sum * b - center) * 2.0);
    if want.hessian.is_some() {
        out.hessian += der.jacobian.transpose() * (k_sum * 2.0) * der.jacobian;
    }
}

/// `fn $name(h: &mut SMatrix<f64, $n, $n>)`: replaces a symmetric matrix by its PSD projection
/// V max(Λ, 0) Vᵀ (nalgebra's fixed-size eigen-decomposition needs a concrete size).
macro_rules! psd_projection {
    ($name:ident, $n:expr) => {
        pub(crate) fn $name(h: &mut SMatrix<f64, $n, $n>) {
            let sym = (*h + h.transpose()) * 0.5;
            let eig = SymmetricEigen::new(sym);
            if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
                *h = sym;
                return;
            }
            let lam = eig.eigenvalues.map(|l| l.max(0.0));
            let v = &eig.eigenvectors;
            *h = v * SMatrix::<f64, $n, $n>::from_diagonal(&lam) * v.transpose();
        }
    };
}
psd_projection!(project_psd, DIRECTOR_DOFS);
psd_projection!(project_psd_18, 18);
