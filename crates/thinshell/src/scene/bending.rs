//! The `[bending]` section: its spec (the discrete second fundamental form), its validation and
//! the energy crate's [`SffKind`] it selects (`docs/scenes.md`).

use serde::{Deserialize, Serialize};
use thinshell_energy::{DirectorVariant, SffKind};

use super::effects::{Effect, section_without_effect};
use super::problem::Check;

/// How the bending energy is discretised.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct BendingSpec {
    /// The second fundamental form (default `edge_director_tan`).
    #[serde(default)]
    pub form: BendingForm,
}

/// The discrete second fundamental form (`docs/model.md` §1, §1.1).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum BendingForm {
    /// Normalised average of the two face normals per edge (the paper's form): positions only,
    /// cheapest, but not consistent on irregular meshes, at free edges, or on
    /// alternating-diagonal grids bent across the grid.
    MidEdgeAverage,
    /// Edge directors, II = 2d sin α: one extra unknown (an angle) per edge, consistent.
    EdgeDirectorSin,
    /// Edge directors, II = 2d tan α: like `edge_director_sin`, with an energy barrier against
    /// folding a hinge flat onto itself. The default (`thinshell_energy::SffKind::default`).
    #[default]
    EdgeDirectorTan,
}

/// Checks `[bending]`: given only with effect `bending` (`bending_on`).
pub fn validate(spec: &Option<BendingSpec>, bending_on: bool) -> Check {
    match spec {
        Some(_) if !bending_on => Err(section_without_effect("bending", Effect::Bending)),
        _ => Ok(()),
    }
}

/// The energy crate's form of a `[bending]` section (the default form without one).
pub fn build(spec: Option<&BendingSpec>) -> SffKind {
    match spec.map(|b| b.form).unwrap_or_default() {
        BendingForm::MidEdgeAverage => SffKind::MidEdgeAverage,
        BendingForm::EdgeDirectorSin => SffKind::EdgeDirector(DirectorVariant::Sin),
        BendingForm::EdgeDirectorTan => SffKind::EdgeDirector(DirectorVariant::Tan),
    }
}
