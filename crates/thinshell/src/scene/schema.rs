//! The scene file as written by the user (TOML, `docs/scenes.md`).
//!
//! Every struct rejects unknown keys; every optional value has the default documented on its
//! field. Checks that need more than the type system (ranges, contradictions) live in
//! [`super::validate`].

use serde::{Deserialize, Serialize};

pub use super::growth::{
    GrowthModelKind, GrowthSpec, SourceSpec, StimulusKind, StimulusSpec, Surface,
};
pub use super::material::{LayerSpec, MaterialModelName, MaterialSpec};
pub use super::mesh::MeshSpec;
pub use super::region::{BoxSpec, HalfSpaceSpec, RegionSpec, SphereSpec};

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
    /// For an open tube whose ends stay in planes normal to this axis (through the origin):
    /// the pressure's volume is the tube's own (`Loads::pressure_axis`). Default: none (the
    /// cone over the origin, right for closed surfaces).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
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
