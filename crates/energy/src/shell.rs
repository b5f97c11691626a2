//! The shell model handed to the assembler: material, active terms, discretisation of b.

use crate::kernel::Terms;
use crate::material::Material;
use crate::sff::SffKind;

/// Material, the energy terms to evaluate and the second-fundamental-form discretisation.
#[derive(Clone, Copy, Debug)]
pub struct ShellModel {
    /// Material parameters (SI) and elastic model.
    pub material: Material,
    /// Which energy terms are evaluated (must equal the terms the [`crate::Assembler`] was
    /// built for).
    pub terms: Terms,
    /// Discretisation of the second fundamental form.
    pub sff: SffKind,
}
