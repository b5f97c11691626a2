//! Lumped mass (model.md §2).

use crate::dofs::check_len;
use crate::error::EnergyError;
use crate::material::Material;
use crate::rest::RestState;
use thinshell_mesh::Mesh;

/// Lumped vertex masses (kg): λ_i = Σ_{f ∋ i} ρ h / 3 · √det ā_f / 2, i.e. a third of each
/// incident face's rest mass ρ·h·(rest area). The same mass applies to the three coordinates
/// of a vertex. Errors on an invalid material or a rest state of the wrong length or with a
/// non-positive-definite ā.
pub fn lumped_mass(
    mesh: &Mesh,
    rest: &RestState,
    material: &Material,
) -> Result<Vec<f64>, EnergyError> {
    material.validate()?;
    check_len("rest a_bar", mesh.n_faces(), rest.a_bar.len())?;
    let mut mass = vec![0.0; mesh.n_vertices()];
    let third = material.density * material.thickness / 3.0;
    for (f, (face, a)) in mesh.faces().iter().zip(&rest.a_bar).enumerate() {
        let det = a.determinant();
        if !(det.is_finite() && det > 0.0 && a[(0, 0)] > 0.0) {
            return Err(EnergyError::InvalidRestForm {
                face: thinshell_mesh::FaceId::new(f),
                form: "a_bar",
                reason: "not positive definite",
            });
        }
        let m = third * 0.5 * det.sqrt();
        for v in face {
            mass[v.idx()] += m;
        }
    }
    Ok(mass)
}
