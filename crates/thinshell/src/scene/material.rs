//! The `[material]` section: its spec, its validation and the energy crate's [`Material`] it
//! builds (`docs/scenes.md`).

use serde::{Deserialize, Serialize};
use thinshell_energy::{EnergyError, Layer, Material, MaterialModel};

use super::problem::{Check, absent, finite, positive, problem};

/// Material parameters, SI units (`docs/scenes.md`, `[material]`).
///
/// `thickness`, `young` and `poisson` belong to the single-layer models (`stvk`,
/// `neo_hookean`, `tension_field`); `bottom` and `top` to `bilayer`, which takes its thickness and moduli from
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
    /// StVK stretching with the compressive stress relaxed (wrinkling membrane), no bending
    /// (§2.3).
    TensionField,
}

impl MaterialModelName {
    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            MaterialModelName::Stvk => "stvk",
            MaterialModelName::NeoHookean => "neo_hookean",
            MaterialModelName::Bilayer => "bilayer",
            MaterialModelName::TensionField => "tension_field",
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

/// Checks `[material]`: the keys of its model only, each in range.
pub fn validate(m: &MaterialSpec) -> Check {
    let model = m.model.name();
    let single = |key: &str, v: &Option<f64>| match v {
        Some(_) if m.model == MaterialModelName::Bilayer => Err(problem(
            key,
            "does not apply to model = \"bilayer\" (set it per layer in `bottom` and `top`)",
        )),
        _ => Ok(()),
    };
    single("material.thickness", &m.thickness)?;
    single("material.young", &m.young)?;
    single("material.poisson", &m.poisson)?;
    if m.model == MaterialModelName::Bilayer {
        for (key, layer) in [("material.bottom", &m.bottom), ("material.top", &m.top)] {
            let Some(l) = layer else {
                return Err(problem(key, "is required with model = \"bilayer\""));
            };
            positive(&format!("{key}.thickness"), l.thickness)?;
            positive(&format!("{key}.young"), l.young)?;
            poisson(&format!("{key}.poisson"), l.poisson)?;
            finite(&format!("{key}.eigenstrain"), l.eigenstrain)?;
            if l.eigenstrain <= -1.0 {
                return Err(problem(
                    format!("{key}.eigenstrain"),
                    format!("must be > -1, got {}", l.eigenstrain),
                ));
            }
        }
    } else {
        let why = format!("to model = \"{model}\" (only to \"bilayer\")");
        absent("material.bottom", &m.bottom, &why)?;
        absent("material.top", &m.top, &why)?;
        positive("material.thickness", m.thickness())?;
        positive("material.young", m.young())?;
        poisson("material.poisson", m.poisson())?;
    }
    positive("material.density", m.density)?;
    finite("material.viscosity", m.viscosity)?;
    if m.viscosity < 0.0 {
        return Err(problem(
            "material.viscosity",
            format!("must be ≥ 0, got {}", m.viscosity),
        ));
    }
    Ok(())
}

fn poisson(key: &str, v: f64) -> Check {
    finite(key, v)?;
    if !(0.0..0.5).contains(&v) {
        return Err(problem(key, format!("must be in [0, 0.5), got {v}")));
    }
    Ok(())
}

/// The energy crate's material of a `[material]` table, validated.
pub fn build(mat: &MaterialSpec) -> Result<Material, EnergyError> {
    let single = |model| Material {
        thickness: mat.thickness(),
        young: mat.young(),
        poisson: mat.poisson(),
        density: mat.density,
        viscosity: mat.viscosity,
        model,
    };
    let material = match mat.model {
        MaterialModelName::Stvk => single(MaterialModel::StVK),
        MaterialModelName::NeoHookean => single(MaterialModel::NeoHookean),
        MaterialModelName::TensionField => single(MaterialModel::TensionField),
        MaterialModelName::Bilayer => {
            // Scene validation requires both layers; a missing one is still a typed error.
            let layer = |name: &'static str, l: &Option<LayerSpec>| {
                l.map(|l| Layer {
                    thickness: l.thickness,
                    young: l.young,
                    poisson: l.poisson,
                    eigenstrain: l.eigenstrain,
                })
                .ok_or(EnergyError::InvalidParameter {
                    name,
                    value: f64::NAN,
                    reason: "is required with model = \"bilayer\"",
                })
            };
            Material::bilayer(
                layer("material.bottom", &mat.bottom)?,
                layer("material.top", &mat.top)?,
                mat.density,
                mat.viscosity,
            )
        }
    };
    material.validate()?;
    Ok(material)
}
