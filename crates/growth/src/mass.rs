//! Lumped mass with stimulus uptake (model.md §4, "Mass").

use thinshell_energy::{Material, RestState};
use thinshell_mesh::Mesh;

use crate::error::{GrowthError, check, check_len};

/// Lumped vertex masses (kg) of a shell whose stimulus adds mass: each face contributes a third
/// of `(ρ + ρ_added·m̄_f) · h · A⁰_f` to each of its vertices, with A⁰_f the *initial* rest area
/// (from `initial.a_bar`), m̄_f the face's through-thickness mean stimulus and `added_density`
/// ρ_added in kg/m³ per unit stimulus. With `added_density = 0` this is
/// [`thinshell_energy::lumped_mass`] of the initial rest state. Errors when a vertex mass would
/// not be positive (e.g. a negative stimulus draining more than the dry mass).
pub fn mass_with_uptake(
    mesh: &Mesh,
    initial: &RestState,
    material: &Material,
    added_density: f64,
    face_means: &[f64],
) -> Result<Vec<f64>, GrowthError> {
    material.validate()?;
    check("added_density", added_density, true, "must be finite")?;
    check_len("initial a_bar", mesh.n_faces(), initial.a_bar.len())?;
    check_len("face means", mesh.n_faces(), face_means.len())?;
    let mut mass = vec![0.0; mesh.n_vertices()];
    for ((face, a), m) in mesh.faces().iter().zip(&initial.a_bar).zip(face_means) {
        let density = material.density + added_density * m;
        let share = density * material.thickness * 0.5 * a.determinant().sqrt() / 3.0;
        for v in face {
            mass[v.idx()] += share;
        }
    }
    if let Some(&bad) = mass.iter().find(|m| !(m.is_finite() && **m > 0.0)) {
        return Err(GrowthError::InvalidParameter {
            name: "vertex mass",
            value: bad,
            reason: "must stay positive (stimulus uptake drains more than the dry mass)",
        });
    }
    Ok(mass)
}
