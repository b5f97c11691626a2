//! The scene file as written by the user (TOML, `docs/scenes.md`): [`SceneFile`], the whole
//! file, over the sections' specs, each defined in its section's module and re-exported here.
//!
//! Every struct rejects unknown keys; every optional value has the default documented on its
//! field. The sections check themselves; [`super::validate`] checks the whole file.

use serde::{Deserialize, Serialize};

pub use super::bending::{BendingForm, BendingSpec};
pub use super::boundary::{BoundarySpec, ClampSpec, PinSpec, PrescribedSpec};
pub use super::contact::{ContactSpec, ObstacleKind, ObstacleSpec};
pub use super::effects::Effect;
pub use super::growth::{
    GrowthModelKind, GrowthSpec, SourceSpec, StimulusKind, StimulusSpec, Surface,
};
pub use super::initial::{InitialSpec, WrapCylinder};
pub use super::integrator::{
    FallbackSpec, HessianSpec, IntegratorKind, IntegratorSpec, LoadRamp, NewtonSpec,
};
pub use super::loads::{GravitySpec, LoadSpecs, PointLoadSpec, PressureSpec};
pub use super::material::{LayerSpec, MaterialModelName, MaterialSpec};
pub use super::mesh::MeshSpec;
pub use super::output::{Format, OutputSpec};
pub use super::path::PathSpec;
pub use super::region::{BoxSpec, HalfSpaceSpec, RegionSpec, SphereSpec};
pub use super::rest::{RestSource, RestSpec};

/// A whole scene file.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Free-form name used in reports (default: the file stem).
    #[serde(default)]
    pub name: Option<String>,
    /// The effects to simulate; nothing else is built or evaluated.
    pub effects: Vec<Effect>,
    /// Where the mesh comes from.
    pub mesh: MeshSpec,
    /// How the start state is obtained from the mesh (default: the mesh as it is, at rest).
    #[serde(default)]
    pub initial: InitialSpec,
    /// Material parameters (default: paper, `docs/model.md` §5–6).
    #[serde(default)]
    pub material: MaterialSpec,
    /// Rest forms before growth (default: the forms of the mesh).
    #[serde(default)]
    pub rest: RestSpec,
    /// Discretisation of the bending energy (effect `bending`; default: `edge_director_tan`,
    /// the consistent form).
    #[serde(default)]
    pub bending: Option<BendingSpec>,
    /// Growth model and its stimulus (effect `growth`).
    #[serde(default)]
    pub growth: Option<GrowthSpec>,
    /// Gravity (effect `gravity`).
    #[serde(default)]
    pub gravity: Option<GravitySpec>,
    /// Uniform pressure (effect `pressure`).
    #[serde(default)]
    pub pressure: Option<PressureSpec>,
    /// Point forces (effect `point_loads`).
    #[serde(default)]
    pub point_loads: Vec<PointLoadSpec>,
    /// Pins, clamps and prescribed motion.
    #[serde(default)]
    pub boundary: BoundarySpec,
    /// Time integration or static solve.
    pub integrator: IntegratorSpec,
    /// What to write and how often.
    #[serde(default)]
    pub output: OutputSpec,
    /// Path following of a static scene's loads (arc length, displacement control) instead
    /// of the load ramp (`docs/scenes.md`).
    #[serde(default)]
    pub path: Option<PathSpec>,
    /// Contact: barriers against self-intersection and obstacles (effect `contact`).
    #[serde(default)]
    pub contact: Option<ContactSpec>,
}

impl SceneFile {
    /// The load sections.
    pub fn load_specs(&self) -> LoadSpecs<'_> {
        LoadSpecs {
            gravity: self.gravity.as_ref(),
            pressure: self.pressure.as_ref(),
            point_loads: &self.point_loads,
        }
    }
}
