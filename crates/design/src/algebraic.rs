//! The algebraic bilayer design of van Rees, Vouga & Mahadevan (PNAS 2017): for a target of
//! the reference's connectivity, the two layers' growth metrics that make its forms the
//! stress-free ones, ā_l = a − 2 z_l b (bottom and top mid-planes z_l), so that the target is
//! a zero-energy equilibrium of the grown bilayer.

use nalgebra::Vector3;
use thinshell_energy::{Material, RestState, SffKind};
use thinshell_mesh::Mesh;

use crate::DesignError;
use crate::param::{BilayerGrowth, Parametrisation};

/// The target's forms (a, b) per face with bending form `sff` (edge angles 0).
pub fn target_forms(
    mesh: &Mesh,
    target: &[Vector3<f64>],
    sff: SffKind,
) -> Result<RestState, DesignError> {
    if target.len() != mesh.n_vertices() {
        return Err(DesignError::Invalid(format!(
            "target has {} positions, the mesh {} vertices",
            target.len(),
            mesh.n_vertices()
        )));
    }
    Ok(RestState::from_mesh(mesh, target, sff)?)
}

/// The algebraic bilayer design: the layer growth parameters of `param` (a [`BilayerGrowth`]
/// on the flat reference of `mesh`) for the target positions `target`, with the rest forms
/// they give (equal to the target's forms).
pub fn bilayer_design(
    mesh: &Mesh,
    target: &[Vector3<f64>],
    sff: SffKind,
    material: &Material,
    reference: &RestState,
) -> Result<(BilayerGrowth, Vec<f64>, RestState), DesignError> {
    let forms = target_forms(mesh, target, sff)?;
    let param = BilayerGrowth::new(reference, material);
    let p = param.fit_forms(&forms);
    let rest = param.rest(&p);
    Ok((param, p, rest))
}
