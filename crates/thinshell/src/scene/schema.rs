//! The scene file as written by the user (TOML, `docs/scenes.md`).
//!
//! Every struct rejects unknown keys; every optional value has the default documented on its
//! field. Checks that need more than the type system (ranges, contradictions) live in
//! [`super::validate`].

use serde::{Deserialize, Serialize};
use thinshell_mesh::generators::Value;

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
    pub path: Option<super::path::PathSpec>,
    /// Contact: barriers against self-intersection and obstacles (effect `contact`).
    #[serde(default)]
    pub contact: Option<ContactSpec>,
}

/// `[contact]` (effect `contact`; `docs/scenes.md`, `docs/model.md` §7).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Activation distance d̂ in m (default: 0.1 × the mesh's mean edge length).
    #[serde(default)]
    pub distance: Option<f64>,
    /// A fixed barrier stiffness κ in J/m² (default: adaptive, model.md §7).
    #[serde(default)]
    pub stiffness: Option<f64>,
    /// Keep the shell from passing through itself (default true).
    #[serde(default = "default_true", rename = "self")]
    pub self_contact: bool,
    /// Measure gaps between the faces' surfaces (offset by the thickness) rather than between
    /// mid-surfaces (default true).
    #[serde(default = "default_true")]
    pub thickness_offset: bool,
    /// Rigid obstacles (`[[contact.obstacles]]`).
    #[serde(default)]
    pub obstacles: Vec<ObstacleSpec>,
}

fn default_true() -> bool {
    true
}

/// One rigid obstacle: `kind = "plane"` with `point` and `normal` (the shell stays on the
/// normal's side), `kind = "sphere"` with `center` and `radius`, `kind = "box"` with the
/// corners `min` and `max` of an axis-aligned box (m; the shell stays outside both), or
/// `kind = "mesh"` with the `path` of an OBJ file (relative to the scene file; the shell
/// crosses none of its triangles).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// `plane`, `sphere`, `box` or `mesh`.
    pub kind: ObstacleKind,
    /// A point of the plane (m).
    #[serde(default)]
    pub point: Option<[f64; 3]>,
    /// The plane's normal, towards the shell (any non-zero length).
    #[serde(default)]
    pub normal: Option<[f64; 3]>,
    /// The sphere's centre (m).
    #[serde(default)]
    pub center: Option<[f64; 3]>,
    /// The sphere's radius (m).
    #[serde(default)]
    pub radius: Option<f64>,
    /// The box's lower corner (m).
    #[serde(default)]
    pub min: Option<[f64; 3]>,
    /// The box's upper corner (m).
    #[serde(default)]
    pub max: Option<[f64; 3]>,
    /// The mesh's OBJ file (positions in m), relative to the scene file's directory.
    #[serde(default)]
    pub path: Option<String>,
}

/// The shape of an obstacle.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// A half-space bounded by a plane.
    Plane,
    /// A ball.
    Sphere,
    /// An axis-aligned box.
    Box,
    /// A fixed triangle mesh read from an OBJ file.
    Mesh,
}

/// A physical effect a scene can switch on.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Membrane (first fundamental form) energy.
    Stretching,
    /// Bending (second fundamental form) energy.
    Bending,
    /// Mass and kinetic terms (dynamic integrators).
    Inertia,
    /// Kelvin–Voigt viscous damping.
    Damping,
    /// Gravity load (`[gravity]`).
    Gravity,
    /// Uniform pressure load (`[pressure]`).
    Pressure,
    /// Point forces (`[[point_loads]]`).
    PointLoads,
    /// Rest forms driven by a stimulus (`[growth]`).
    Growth,
    /// Stimulus from a diffusion solve through the thickness (`[growth.stimulus] kind = "diffusion"`).
    Diffusion,
    /// Barriers against self-intersection and obstacles, CCD-limited steps (`[contact]`).
    Contact,
}

impl Effect {
    /// The spelling used in scene files.
    pub fn key(self) -> &'static str {
        match self {
            Effect::Stretching => "stretching",
            Effect::Bending => "bending",
            Effect::Inertia => "inertia",
            Effect::Damping => "damping",
            Effect::Gravity => "gravity",
            Effect::Pressure => "pressure",
            Effect::PointLoads => "point_loads",
            Effect::Growth => "growth",
            Effect::Diffusion => "diffusion",
            Effect::Contact => "contact",
        }
    }
}

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

/// Mesh source: exactly one of `obj` or `generator`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// OBJ file, relative to the scene file.
    #[serde(default)]
    pub obj: Option<String>,
    /// Generator name: one of [`thinshell_mesh::generators::Generator::ALL`] (`seed_square`,
    /// `rectangle`, `irregular_rectangle`, `icosphere`, `icosphere_recursive`,
    /// `cylinder_patch`, `disc`, `annulus`); its keys and defaults are listed there.
    #[serde(default)]
    pub generator: Option<String>,
    /// Width in m (`rectangle`, `irregular_rectangle`; default 1).
    #[serde(default)]
    pub width: Option<f64>,
    /// Height in m (`rectangle`, `irregular_rectangle`; default 1).
    #[serde(default)]
    pub height: Option<f64>,
    /// Cells along x (`rectangle`).
    #[serde(default)]
    pub nx: Option<usize>,
    /// Cells along y (`rectangle`).
    #[serde(default)]
    pub ny: Option<usize>,
    /// Resolution (`irregular_rectangle`: points per side).
    #[serde(default)]
    pub n: Option<usize>,
    /// Seed of the jitter (`irregular_rectangle`; default 1).
    #[serde(default)]
    pub seed: Option<u64>,
    /// Radius in m (`icosphere`, `icosphere_recursive`, `cylinder_patch`, `disc`; default 1).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Subdivision level (`icosphere`, `icosphere_recursive`; default 2 = 320 faces).
    #[serde(default)]
    pub level: Option<u32>,
    /// Opening angle in rad (`cylinder_patch`).
    #[serde(default)]
    pub angle: Option<f64>,
    /// Length along the axis in m (`cylinder_patch`).
    #[serde(default)]
    pub length: Option<f64>,
    /// Divisions around (`cylinder_patch`, `annulus`).
    #[serde(default)]
    pub n_around: Option<usize>,
    /// Divisions along the axis (`cylinder_patch`).
    #[serde(default)]
    pub n_along: Option<usize>,
    /// Rings (`disc`, `annulus`).
    #[serde(default)]
    pub n_rings: Option<usize>,
    /// Inner radius in m (`annulus`).
    #[serde(default)]
    pub inner_radius: Option<f64>,
    /// Outer radius in m (`annulus`).
    #[serde(default)]
    pub outer_radius: Option<f64>,
}

impl MeshSpec {
    /// The generator keys this spec sets, with their values, in a fixed order (the order
    /// validation reports keys that do not apply in).
    pub fn given(&self) -> Vec<(&'static str, Value)> {
        let real = |key, v: Option<f64>| v.map(|v| (key, Value::Real(v)));
        let int = |key, v: Option<u64>| v.map(|v| (key, Value::Int(v)));
        // usize and u32 always fit in u64 on supported targets (64-bit usize at most).
        let count = |key, v: Option<usize>| int(key, v.map(|v| v as u64));
        [
            real("width", self.width),
            real("height", self.height),
            count("nx", self.nx),
            count("ny", self.ny),
            count("n", self.n),
            int("seed", self.seed),
            real("radius", self.radius),
            int("level", self.level.map(u64::from)),
            real("angle", self.angle),
            real("length", self.length),
            count("n_around", self.n_around),
            count("n_along", self.n_along),
            count("n_rings", self.n_rings),
            real("inner_radius", self.inner_radius),
            real("outer_radius", self.outer_radius),
        ]
        .into_iter()
        .flatten()
        .collect()
    }
}

/// Maps the mesh to the start state. Applied in the order: `linear_xy`, `scale`, `wrap_cylinder`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// 2×2 matrix applied to the (x, y) coordinates (row-major).
    #[serde(default)]
    pub linear_xy: Option<[[f64; 2]; 2]>,
    /// Uniform scale about the origin.
    #[serde(default)]
    pub scale: Option<f64>,
    /// Rolls a flat mesh in the xy-plane onto a cylinder with axis ∥ y (the seed's map, model.md §5).
    #[serde(default)]
    pub wrap_cylinder: Option<WrapCylinder>,
    /// Initial velocity of every vertex, m/s (default 0); dynamic integrators only.
    #[serde(default)]
    pub velocity: Option<[f64; 3]>,
}

/// The seed's map of the unit square onto a cylinder: θ = (x − x_c)/r − π/2, x = r cos θ, z = r sin θ.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WrapCylinder {
    /// Cylinder radius, m.
    pub radius: f64,
    /// x coordinate that maps to the bottom of the cylinder (default 0.5).
    #[serde(default)]
    pub center_x: Option<f64>,
}

/// Material parameters, SI units (`docs/scenes.md`, `[material]`).
///
/// `thickness`, `young` and `poisson` belong to the single-layer models (`stvk`,
/// `neo_hookean`); `bottom` and `top` to `bilayer`, which takes its thickness and moduli from
/// its layers. Keys of one model are refused for another (`validate`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Elastic model (default `stvk`).
    #[serde(default)]
    pub model: MaterialModelName,
    /// Thickness h, m (default 1e-4; single-layer models).
    #[serde(default)]
    pub thickness: Option<f64>,
    /// Young's modulus E, Pa (default 2e9; single-layer models).
    #[serde(default)]
    pub young: Option<f64>,
    /// Poisson ratio ν (default 0.3; single-layer models).
    #[serde(default)]
    pub poisson: Option<f64>,
    /// Density ρ, kg/m³ (default 250).
    #[serde(default = "default_density")]
    pub density: f64,
    /// Viscosity η, Pa·s (default 5e-13, the seed's value: practically no damping).
    #[serde(default = "default_viscosity")]
    pub viscosity: f64,
    /// `bilayer`: the layer on the −z side (z ∈ [−h/2, −h/2 + h₁]).
    #[serde(default)]
    pub bottom: Option<LayerSpec>,
    /// `bilayer`: the layer on the +z side (the side the unit normal points to).
    #[serde(default)]
    pub top: Option<LayerSpec>,
}

impl Default for MaterialSpec {
    fn default() -> Self {
        MaterialSpec {
            model: MaterialModelName::default(),
            thickness: None,
            young: None,
            poisson: None,
            density: default_density(),
            viscosity: default_viscosity(),
            bottom: None,
            top: None,
        }
    }
}

impl MaterialSpec {
    /// Thickness h (m) of a single-layer model, default 1e-4.
    pub fn thickness(&self) -> f64 {
        self.thickness.unwrap_or(1e-4)
    }

    /// Young's modulus E (Pa) of a single-layer model, default 2e9.
    pub fn young(&self) -> f64 {
        self.young.unwrap_or(2e9)
    }

    /// Poisson ratio ν of a single-layer model, default 0.3.
    pub fn poisson(&self) -> f64 {
        self.poisson.unwrap_or(0.3)
    }
}

/// Elastic model of `[material]` (`thinshell_energy::MaterialModel`).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum MaterialModelName {
    /// St. Venant–Kirchhoff, the paper's quadratic energies (`docs/model.md` §2). Default.
    #[default]
    Stvk,
    /// Compressible neo-Hookean stretching, bending in the current metric (§2.1).
    NeoHookean,
    /// Two bonded layers with their own moduli and eigenstrains (§2.2): keys `bottom`, `top`.
    Bilayer,
}

impl MaterialModelName {
    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            MaterialModelName::Stvk => "stvk",
            MaterialModelName::NeoHookean => "neo_hookean",
            MaterialModelName::Bilayer => "bilayer",
        }
    }
}

/// One layer of a `bilayer` material; every key is required.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LayerSpec {
    /// Layer thickness, m (> 0).
    pub thickness: f64,
    /// Young's modulus, Pa (> 0).
    pub young: f64,
    /// Poisson ratio, in [0, 0.5).
    pub poisson: f64,
    /// Isotropic eigenstrain ε (> −1): the layer is stress-free at (1 + ε)² times the rest
    /// metric (thermal α ΔT, swelling).
    pub eigenstrain: f64,
}

fn default_density() -> f64 {
    250.0
}
fn default_viscosity() -> f64 {
    5e-13
}

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

/// Growth model name.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum GrowthModelKind {
    /// ā = e^{2s} a⁰, b̄ = e^{p s} b⁰ with s the stimulus.
    Isotropic,
    /// Stimulus linear through the thickness (model.md §4).
    Linear,
    /// Piecewise-constant (bilayer) stimulus (model.md §4).
    Bilayer,
}

/// Growth model and stimulus.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GrowthSpec {
    /// The model.
    pub model: GrowthModelKind,
    /// b̄ exponent p of isotropic growth (default 0, the seed's).
    #[serde(default)]
    pub p: Option<f64>,
    /// Swelling coefficient c per unit stimulus (linear, bilayer; along `direction` if given).
    #[serde(default)]
    pub coefficient: Option<f64>,
    /// Material direction (swelling models): the stretch is `1 + c·m` along it (projected onto
    /// each face) and `1 + cross_coefficient·m` across it.
    #[serde(default)]
    pub direction: Option<[f64; 3]>,
    /// Swelling coefficient across `direction` (required with it).
    #[serde(default)]
    pub cross_coefficient: Option<f64>,
    /// Mass added per unit volume and unit stimulus, kg/m³ (moisture soaking in); default none.
    #[serde(default)]
    pub mass_uptake: Option<f64>,
    /// Where the stimulus comes from.
    pub stimulus: StimulusSpec,
}

/// Stimulus kind.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StimulusKind {
    /// The same value everywhere (`value`, or `top`/`bottom`).
    Uniform,
    /// The seed's directed heat: `hot` region set to `value`, others averaged with neighbours each
    /// step, `held` region fixed at 0.
    DirectedHeat,
    /// Diffusion through the thickness from `sources` (effect `diffusion`).
    Diffusion,
}

/// A region of space (exactly one key).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Points with `(x − point)·normal > 0`.
    #[serde(default)]
    pub half_space: Option<HalfSpaceSpec>,
    /// Points inside a sphere.
    #[serde(default)]
    pub sphere: Option<SphereSpec>,
    /// Points inside an axis-aligned box.
    #[serde(default, rename = "box")]
    pub aabb: Option<BoxSpec>,
    /// Explicit vertex indices (0-based, as in the mesh).
    #[serde(default)]
    pub vertices: Option<Vec<usize>>,
}

/// Half-space `(x − point)·normal > 0`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HalfSpaceSpec {
    /// A point on the plane, m.
    pub point: [f64; 3],
    /// Outward normal (need not be unit).
    pub normal: [f64; 3],
}

/// Ball `|x − center| < radius`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Centre, m.
    pub center: [f64; 3],
    /// Radius, m.
    pub radius: f64,
}

/// Axis-aligned box `min ≤ x ≤ max`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Lower corner, m.
    pub min: [f64; 3],
    /// Upper corner, m.
    pub max: [f64; 3],
}

/// Stimulus source. A face belongs to a region when all three of its vertices do.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StimulusSpec {
    /// `uniform`, `directed_heat` or `diffusion`.
    pub kind: StimulusKind,
    /// Uniform value (both surfaces) or the hot value of `directed_heat`.
    #[serde(default)]
    pub value: Option<f64>,
    /// Uniform value at the top surface (z = +h/2).
    #[serde(default)]
    pub top: Option<f64>,
    /// Uniform value at the bottom surface (z = −h/2).
    #[serde(default)]
    pub bottom: Option<f64>,
    /// `directed_heat`: region held at `value`.
    #[serde(default)]
    pub hot: Option<RegionSpec>,
    /// `directed_heat`: region held at 0.
    #[serde(default)]
    pub held: Option<RegionSpec>,
    /// `diffusion`: diffusivity D, m²/s.
    #[serde(default)]
    pub diffusivity: Option<f64>,
    /// `diffusion`: prism layers through the thickness (default 2).
    #[serde(default)]
    pub layers: Option<usize>,
    /// `diffusion`: boundary sources.
    #[serde(default)]
    pub sources: Vec<SourceSpec>,
}

/// Which surface of the shell.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Surface {
    /// z = +h/2, the side the face normals point to.
    Top,
    /// z = −h/2.
    Bottom,
}

/// A diffusion boundary source on a region of one surface: exactly one of `value` or `flux`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SourceSpec {
    /// Surface it acts on.
    pub surface: Surface,
    /// Where (default: the whole surface).
    #[serde(default)]
    pub region: Option<RegionSpec>,
    /// Fixed stimulus value.
    #[serde(default)]
    pub value: Option<f64>,
    /// Inflow per unit area and time (stimulus·m/s).
    #[serde(default)]
    pub flux: Option<f64>,
}

/// Gravity.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GravitySpec {
    /// Acceleration, m/s² (default [0, 0, −9.81]).
    #[serde(default = "default_gravity")]
    pub acceleration: [f64; 3],
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}

/// Uniform pressure.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PressureSpec {
    /// Pressure, Pa; positive pushes along the face normals.
    pub value: f64,
}

/// A point force.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PointLoadSpec {
    /// Vertex index (0-based).
    pub vertex: usize,
    /// Force, N.
    pub force: [f64; 3],
}

/// Boundary conditions.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    /// Pinned vertices (all or some coordinates).
    #[serde(default)]
    pub pins: Vec<PinSpec>,
    /// Clamped boundary edges: both rows of vertices pinned.
    #[serde(default)]
    pub clamps: Vec<ClampSpec>,
    /// Vertices moved with a prescribed velocity.
    #[serde(default)]
    pub prescribed: Vec<PrescribedSpec>,
}

/// Pins the vertices of a region.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PinSpec {
    /// The vertices.
    pub region: RegionSpec,
    /// Pinned coordinates, a subset of "xyz" (default "xyz").
    #[serde(default)]
    pub axes: Option<String>,
}

/// Clamps the boundary edges whose two vertices lie in the region.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ClampSpec {
    /// The edges' region.
    pub region: RegionSpec,
}

/// Prescribed motion x(t) = x(0) + t·velocity of the region's vertices.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PrescribedSpec {
    /// The vertices.
    pub region: RegionSpec,
    /// Velocity, m/s.
    pub velocity: [f64; 3],
}

/// Integrator kind.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorKind {
    /// Implicit Euler by Newton on the incremental potential.
    Implicit,
    /// Symplectic Euler.
    Explicit,
    /// Static equilibrium (quasi-static: one solve per step).
    Static,
}

/// How a static scene's loads grow over its steps.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum LoadRamp {
    /// Load factor λ_k = k/N at step k of N: step k solves for the equilibrium under k/N of
    /// every load, starting from the equilibrium of step k − 1.
    Linear,
    /// Full loads from the first step (λ = 1): the steps are a growth pseudo-time.
    None,
}

impl LoadRamp {
    /// The scene key's spelling.
    pub fn key(self) -> &'static str {
        match self {
            LoadRamp::Linear => "linear",
            LoadRamp::None => "none",
        }
    }
}

/// Which Hessian Newton uses.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum HessianSpec {
    /// Exact second derivatives where they are positive definite, Gauss–Newton elsewhere
    /// (`thinshell_solver::HessianPolicy::Adaptive`).
    #[default]
    Adaptive,
    /// The adaptive policy as it was before issue #26: Gauss–Newton wherever the exact Hessian
    /// is indefinite, no trust-region steps, no saddle escape
    /// (`thinshell_solver::HessianPolicy::AdaptivePsd`; for comparisons).
    AdaptivePsd,
    /// Exact second derivatives throughout (regularised when not positive definite).
    Exact,
    /// Gauss–Newton (positive semidefinite).
    GaussNewton,
    /// Exact, projected to PSD per face.
    Projected,
}

/// Time integration settings.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `implicit`, `explicit` or `static`.
    pub kind: IntegratorKind,
    /// Time step, s (required for implicit/explicit; static: pseudo-time step for growth, default 1).
    #[serde(default)]
    pub dt: Option<f64>,
    /// Number of steps (exactly one of `steps` and `end_time`; static default 1).
    #[serde(default)]
    pub steps: Option<usize>,
    /// End time, s.
    #[serde(default)]
    pub end_time: Option<f64>,
    /// Halve Δt on a failed step and grow it back after successes (default false).
    #[serde(default)]
    pub adaptive_dt: bool,
    /// Static solves only: how the loads (gravity, pressure, point loads, prescribed
    /// displacement) grow over the steps. Default: `linear` without growth, `none` with growth
    /// (see [`LoadRamp`] and `docs/scenes.md`).
    #[serde(default)]
    pub load_ramp: Option<LoadRamp>,
    /// Newton settings (implicit, static).
    #[serde(default)]
    pub newton: NewtonSpec,
}

/// Newton settings; missing values take the solver's defaults.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct NewtonSpec {
    /// Also stop when ‖∇Φ‖∞ ≤ tolerance × the system's force scale (opt-in gradient test).
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Stop when the Newton correction is smaller than this × the shell's size.
    #[serde(default)]
    pub step_tolerance: Option<f64>,
    /// Iteration limit per solve.
    #[serde(default)]
    pub max_iterations: Option<usize>,
    /// Backtracking Armijo line search (default true).
    #[serde(default)]
    pub line_search: Option<bool>,
    /// Watchdog window of the line search: iterations a non-monotone full step has to recover
    /// (default 4; 0: monotone line search).
    #[serde(default)]
    pub watchdog: Option<usize>,
    /// Leave a converged saddle along its negative curvature and go on to a minimum (default
    /// true for static solves, false for implicit steps); false keeps unstable equilibria.
    #[serde(default)]
    pub escape_saddles: Option<bool>,
    /// Add μI after a failed Cholesky (default true).
    #[serde(default)]
    pub regularization: Option<bool>,
    /// `adaptive` (default), `adaptive_psd`, `exact`, `gauss_newton`, `projected`.
    #[serde(default)]
    pub hessian: HessianSpec,
    /// Reuse the last Cholesky factor as the preconditioner of CG while it converges quickly
    /// (`thinshell_solver::NewtonSettings::reuse_factor`).
    #[serde(default)]
    pub reuse_factor: Option<bool>,
    /// Linear solver when the Cholesky factor does not fit in memory: `ic0` (default),
    /// `jacobi`, `off` (refuse).
    #[serde(default)]
    pub fallback: Option<FallbackSpec>,
    /// Solve by preconditioned CG even when the Cholesky factor fits (default false).
    #[serde(default)]
    pub force_iterative: Option<bool>,
}

/// The iterative fallback (`thinshell_solver::IterativeFallback`).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FallbackSpec {
    /// CG preconditioned by incomplete Cholesky IC(0).
    Ic0,
    /// CG preconditioned by the diagonal.
    Jacobi,
    /// No fallback: a factor over the memory budget is refused.
    Off,
}

/// Output format.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// One OBJ per frame.
    Obj,
    /// VTK `.vtu` per frame plus a `.pvd` index.
    Vtk,
}

/// Output settings.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write a frame every n steps (default 10; the first and last are always written).
    #[serde(default = "default_every")]
    pub every: usize,
    /// Frame formats (default ["obj"]). The per-step CSV and `summary.json` are always written.
    #[serde(default = "default_formats")]
    pub formats: Vec<Format>,
}

fn default_every() -> usize {
    10
}
fn default_formats() -> Vec<Format> {
    vec![Format::Obj]
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            every: default_every(),
            formats: default_formats(),
        }
    }
}
