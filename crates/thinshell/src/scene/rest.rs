//! The `[rest]` section: its spec (rest forms from the mesh or planar forms), its validation
//! and the rest state it builds (`docs/scenes.md`).

use nalgebra::{Matrix2, Vector3};
use serde::{Deserialize, Serialize};
use thinshell_energy::{EnergyError, RestState, SffKind};
use thinshell_mesh::Mesh;

use super::problem::{Check, absent, m2, matrix, problem};

/// Where the rest forms (ā, b̄) come from before any growth.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum RestSource {
    /// The forms (a⁰, b⁰) of the mesh as loaded or generated (before `[initial]`).
    #[default]
    Mesh,
    /// Planar forms `a_xy`, `b_xy` mapped to each face: ā = Tᵀ ā^{xy} T (model.md §5).
    Planar,
}

/// Rest forms.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct RestSpec {
    /// `mesh` (default) or `planar`.
    #[serde(default)]
    pub from: RestSource,
    /// ā^{xy} (row-major 2×2, symmetric positive definite), for `from = "planar"`.
    #[serde(default)]
    pub a_xy: Option<[[f64; 2]; 2]>,
    /// b̄^{xy} (row-major 2×2, symmetric), for `from = "planar"`; default 0.
    #[serde(default)]
    pub b_xy: Option<[[f64; 2]; 2]>,
}

/// Checks `[rest]`: planar forms only with `from = "planar"`, ā^{xy} given and SPD, b̄^{xy}
/// symmetric.
pub fn validate(r: &RestSpec) -> Check {
    match r.from {
        RestSource::Mesh => {
            absent("rest.a_xy", &r.a_xy, "when rest.from = \"mesh\"")?;
            absent("rest.b_xy", &r.b_xy, "when rest.from = \"mesh\"")
        }
        RestSource::Planar => {
            let a = r
                .a_xy
                .as_ref()
                .ok_or_else(|| problem("rest.a_xy", "is required when rest.from = \"planar\""))?;
            matrix("rest.a_xy", a, true)?;
            if let Some(b) = &r.b_xy {
                matrix("rest.b_xy", b, false)?;
            }
            Ok(())
        }
    }
}

/// The rest state (before growth) of a validated `[rest]` section: the forms of the mesh's
/// positions `x_ref` with the bending form `sff`, or the planar forms.
pub fn build(
    spec: &RestSpec,
    mesh: &Mesh,
    x_ref: &[Vector3<f64>],
    sff: SffKind,
    mirror_edges: &[(thinshell_mesh::EdgeId, Vector3<f64>)],
) -> Result<RestState, EnergyError> {
    match spec.from {
        RestSource::Mesh => RestState::from_mesh_with_mirrors(mesh, x_ref, sff, mirror_edges),
        RestSource::Planar => {
            let a = spec.a_xy.as_ref().map_or(Matrix2::identity(), m2);
            let b = spec.b_xy.as_ref().map_or(Matrix2::zeros(), m2);
            RestState::from_planar(mesh, a, b)
        }
    }
}
