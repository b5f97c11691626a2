//! Bending energy of a face with the edge-director second fundamental form (model.md §1.1),
//! and the edge orientation signs σ it needs from the mesh topology.
//!
//! Only the bending term depends on the edge angles; stretching and damping stay with
//! [`eval_face`](crate::eval_face).

use crate::density::{inv2, sv_quadratic, sym_entries};
use crate::kernel::{FaceRest, FaceStencil, HessianMode, Want};
use crate::material::Material;
use crate::sff::{DIRECTOR_DOFS, EdgeAngles, EdgeDirector};
use nalgebra::{SMatrix, SVector, SymmetricEigen};
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
    /// Gradient (N for positions, J/rad for angles); zero unless requested.
    pub gradient: SVector<f64, DIRECTOR_DOFS>,
    /// Hessian (N/m, N/rad, J/rad²), symmetric; zero unless requested.
    pub hessian: SMatrix<f64, DIRECTOR_DOFS, DIRECTOR_DOFS>,
}

impl Default for DirectorFaceEval {
    fn default() -> Self {
        Self {
            energy: 0.0,
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
    out.gradient.fill(0.0);
    out.hessian.fill(0.0);
    let h = material.thickness;
    let area = rest.a_bar.determinant().sqrt();
    let k = sv_quadratic(
        &inv2(&rest.a_bar),
        material.alpha(),
        material.beta(),
        h * h * h / 24.0 * area,
    );
    let b_bar = sym_entries(&rest.b_bar);
    if !want.gradient && want.hessian.is_none() {
        let d = sym_entries(&form.b_with_angles(stencil, angles)) - b_bar;
        out.energy = d.dot(&(k * d));
        return;
    }
    let exact = matches!(
        want.hessian,
        Some(HessianMode::Exact | HessianMode::ProjectedPsd)
    );
    // The contracted Hessian's weights 2Kd need b first.
    let der = if exact {
        let d = sym_entries(&form.b_with_angles(stencil, angles)) - b_bar;
        let w = (k * d) * 2.0;
        form.derivatives(stencil, angles, Some((&w, &mut out.hessian)))
    } else {
        form.derivatives(stencil, angles, None)
    };
    let d = sym_entries(&der.b) - b_bar;
    let kd = k * d;
    out.energy = d.dot(&kd);
    out.gradient = der.jacobian.transpose() * (kd * 2.0);
    if want.hessian.is_some() {
        out.hessian += der.jacobian.transpose() * (k * 2.0) * der.jacobian;
    }
    if want.hessian == Some(HessianMode::ProjectedPsd) {
        project_psd(&mut out.hessian);
    }
}

/// Replaces a symmetric matrix by its PSD projection V max(Λ, 0) Vᵀ.
fn project_psd(h: &mut SMatrix<f64, DIRECTOR_DOFS, DIRECTOR_DOFS>) {
    let sym = (*h + h.transpose()) * 0.5;
    let eig = SymmetricEigen::new(sym);
    let lam = eig.eigenvalues.map(|l| l.max(0.0));
    let v = &eig.eigenvectors;
    *h = v * SMatrix::<f64, DIRECTOR_DOFS, DIRECTOR_DOFS>::from_diagonal(&lam) * v.transpose();
}
