//! The `[mesh]` section: its spec (an OBJ file or a named generator with its keys), its
//! validation and the mesh it builds (`docs/scenes.md`).

use std::path::Path;

use serde::{Deserialize, Serialize};
use thinshell_mesh::generators::{Generator, Value};
use thinshell_mesh::{Mesh, MeshError, io};

use super::problem::{Check, positive, problem};

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

/// Checks `[mesh]`: one source, a known generator with its own keys in range.
pub fn validate(m: &MeshSpec) -> Check {
    let allowed: Vec<&str> = match (&m.obj, &m.generator) {
        (Some(_), Some(_)) => {
            return Err(problem(
                "mesh",
                "give either `obj` or `generator`, not both",
            ));
        }
        (None, None) => return Err(problem("mesh", "needs `obj` or `generator`")),
        (Some(path), None) => {
            if path.trim().is_empty() {
                return Err(problem("mesh.obj", "is an empty path"));
            }
            Vec::new()
        }
        (None, Some(g)) => match Generator::from_name(g) {
            Some(generator) => generator.params().iter().map(|p| p.name).collect(),
            None => {
                let names: Vec<&str> = Generator::ALL.iter().map(|g| g.name()).collect();
                return Err(problem(
                    "mesh.generator",
                    format!("unknown generator `{g}`; known: {}", names.join(", ")),
                ));
            }
        },
    };
    let what = match &m.generator {
        Some(g) => format!("to generator `{g}`"),
        None => "to an OBJ mesh".to_string(),
    };
    for (key, _) in m.given() {
        if !allowed.contains(&key) {
            return Err(problem(
                format!("mesh.{key}"),
                format!("does not apply {what}"),
            ));
        }
    }
    for (key, v) in [
        ("width", m.width),
        ("height", m.height),
        ("radius", m.radius),
        ("angle", m.angle),
        ("length", m.length),
        ("inner_radius", m.inner_radius),
        ("outer_radius", m.outer_radius),
    ] {
        if let Some(v) = v {
            positive(&format!("mesh.{key}"), v)?;
        }
    }
    for (key, v, min) in [
        ("nx", m.nx, 1),
        ("ny", m.ny, 1),
        ("n", m.n, 2),
        ("n_around", m.n_around, 1),
        ("n_along", m.n_along, 1),
        ("n_rings", m.n_rings, 1),
    ] {
        if let Some(v) = v {
            if v < min {
                return Err(problem(
                    format!("mesh.{key}"),
                    format!("must be ≥ {min}, got {v}"),
                ));
            }
            if v > 4096 {
                return Err(problem(
                    format!("mesh.{key}"),
                    format!("must be ≤ 4096, got {v}"),
                ));
            }
        }
    }
    if let Some(level) = m.level {
        if level > 8 {
            return Err(problem(
                "mesh.level",
                format!("must be ≤ 8 (level 8 has 1.3 million faces), got {level}"),
            ));
        }
    }
    // The generator's defaults take part too: `inner_radius = 2` alone is as wrong as with an
    // explicit `outer_radius = 1`.
    if m.inner_radius.is_some() || m.outer_radius.is_some() {
        let default = |key| {
            Generator::Annulus
                .default_of(key)
                .map_or(f64::NAN, |v| v.as_real())
        };
        let a = m.inner_radius.unwrap_or_else(|| default("inner_radius"));
        let b = m.outer_radius.unwrap_or_else(|| default("outer_radius"));
        if a >= b {
            return Err(problem(
                "mesh.inner_radius",
                format!("must be smaller than outer_radius = {b}, got {a}"),
            ));
        }
    }
    if let Some(angle) = m.angle {
        if angle >= 2.0 * std::f64::consts::PI {
            return Err(problem("mesh.angle", format!("must be < 2π, got {angle}")));
        }
    }
    Ok(())
}

/// The mesh of a validated `[mesh]` section: the OBJ file (relative to `base_dir`, the
/// scene's directory) or the generator with the keys given.
pub fn build(spec: &MeshSpec, base_dir: &Path) -> Result<Mesh, MeshError> {
    if let Some(path) = &spec.obj {
        return io::load_obj(base_dir.join(path));
    }
    let generator = spec.generator.as_deref().and_then(Generator::from_name);
    // Unknown names are rejected by scene validation already.
    let Some(generator) = generator else {
        return Err(MeshError::InvalidParameter {
            name: "generator",
            value: f64::NAN,
            reason: "unknown generator",
        });
    };
    let given = spec.given();
    generator.build(|key| given.iter().find(|(k, _)| *k == key).map(|&(_, v)| v))
}
