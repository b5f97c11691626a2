//! The shell model handed to the assembler: material, active terms, discretisation of b.

use crate::material::Material;
use crate::sff::SffKind;
use crate::terms::Terms;

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

impl ShellModel {
    /// Whether the model's unknowns include one angle per edge: an edge-director second
    /// fundamental form with bending on (without bending the angles do not enter the energy).
    /// The one definition of the test, used by the assembler and the solver.
    pub fn has_edge_unknowns(&self) -> bool {
        self.sff.director().is_some() && self.terms.bend
    }

    /// This model without its damping term: the elastic energy of one configuration (damping
    /// needs the previous step's forms and is not an energy of a state).
    pub fn elastic(&self) -> ShellModel {
        ShellModel {
            terms: Terms {
                damping: false,
                ..self.terms
            },
            ..*self
        }
    }
}
