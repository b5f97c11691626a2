//! The `[growth]` section: its spec (model, stimulus, sources), its validation and the growth
//! crate's model and stimulus field it builds (`docs/scenes.md`). The grown rest forms and the
//! mass uptake are derived from them by the simulation builder.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use thinshell_energy::RestState;
use thinshell_growth::{
    Anisotropy, Diffusion, DiffusionSettings, DiffusionSource, DirectedHeat, FaceStimulus,
    GrowthError, GrowthModel, Isotropic, Prescribed, Region, SourceKind, StimulusField,
    Surface as GrowthSurface, Swelling,
};
use thinshell_mesh::Mesh;

use super::problem::{Check, absent, finite, positive, problem, v3};
use super::region::RegionSpec;

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

/// Checks `[growth]` (given or not) against effects `growth` and `diffusion`.
pub fn validate(growth: &Option<GrowthSpec>, growth_on: bool, diffusion_on: bool) -> Check {
    let g = match (growth, growth_on) {
        (None, false) => {
            if diffusion_on {
                return Err(problem(
                    "effects",
                    "effect `diffusion` needs effect `growth` and a [growth] section",
                ));
            }
            return Ok(());
        }
        (Some(_), false) => {
            return Err(problem(
                "growth",
                "section given but effect `growth` is not in `effects`",
            ));
        }
        (None, true) => {
            return Err(problem(
                "growth",
                "effect `growth` needs a [growth] section",
            ));
        }
        (Some(g), true) => g,
    };
    match g.model {
        GrowthModelKind::Isotropic => {
            absent(
                "growth.coefficient",
                &g.coefficient,
                "to isotropic growth (use p)",
            )?;
            if let Some(p) = g.p {
                finite("growth.p", p)?;
            }
        }
        GrowthModelKind::Linear | GrowthModelKind::Bilayer => {
            absent("growth.p", &g.p, "to swelling models")?;
            let c = g.coefficient.ok_or_else(|| {
                problem("growth.coefficient", "is required by the swelling models")
            })?;
            finite("growth.coefficient", c)?;
            match (&g.direction, g.cross_coefficient) {
                (None, None) => {}
                (Some(d), Some(cc)) => {
                    finite("growth.cross_coefficient", cc)?;
                    for (i, v) in d.iter().enumerate() {
                        finite(&format!("growth.direction[{i}]"), *v)?;
                    }
                    if d.iter().all(|v| *v == 0.0) {
                        return Err(problem("growth.direction", "must not be zero"));
                    }
                }
                (Some(_), None) => {
                    return Err(problem(
                        "growth.cross_coefficient",
                        "is required with `direction` (anisotropic swelling)",
                    ));
                }
                (None, Some(_)) => {
                    return Err(problem(
                        "growth.direction",
                        "is required with `cross_coefficient` (anisotropic swelling)",
                    ));
                }
            }
        }
    }
    if g.model == GrowthModelKind::Isotropic {
        absent("growth.direction", &g.direction, "to isotropic growth")?;
        absent(
            "growth.cross_coefficient",
            &g.cross_coefficient,
            "to isotropic growth",
        )?;
    }
    if let Some(rho) = g.mass_uptake {
        finite("growth.mass_uptake", rho)?;
    }
    let st = &g.stimulus;
    let k = "growth.stimulus";
    let is_diffusion = st.kind == StimulusKind::Diffusion;
    if is_diffusion != diffusion_on {
        return Err(problem(
            format!("{k}.kind"),
            if is_diffusion {
                "is `diffusion` but effect `diffusion` is not in `effects`"
            } else {
                "effect `diffusion` is on, so the stimulus kind must be `diffusion`"
            },
        ));
    }
    if !is_diffusion {
        absent(
            &format!("{k}.diffusivity"),
            &st.diffusivity,
            "without diffusion",
        )?;
        absent(&format!("{k}.layers"), &st.layers, "without diffusion")?;
        if !st.sources.is_empty() {
            return Err(problem(
                format!("{k}.sources"),
                "do not apply without diffusion",
            ));
        }
    }
    match st.kind {
        StimulusKind::Uniform => {
            absent(&format!("{k}.hot"), &st.hot, "to a uniform stimulus")?;
            absent(&format!("{k}.held"), &st.held, "to a uniform stimulus")?;
            match (st.value, st.top, st.bottom) {
                (Some(v), None, None) => finite(&format!("{k}.value"), v),
                (None, Some(t), Some(b)) => {
                    if g.model == GrowthModelKind::Isotropic && t != b {
                        return Err(problem(
                            format!("{k}.top"),
                            "isotropic growth takes one value (use `value`)",
                        ));
                    }
                    finite(&format!("{k}.top"), t)?;
                    finite(&format!("{k}.bottom"), b)
                }
                _ => Err(problem(
                    k,
                    "a uniform stimulus needs either `value` or both `top` and `bottom`",
                )),
            }
        }
        StimulusKind::DirectedHeat => {
            if g.model != GrowthModelKind::Isotropic {
                return Err(problem(
                    format!("{k}.kind"),
                    "`directed_heat` drives isotropic growth only",
                ));
            }
            absent(
                &format!("{k}.top"),
                &st.top,
                "to directed heat (use `value`)",
            )?;
            absent(
                &format!("{k}.bottom"),
                &st.bottom,
                "to directed heat (use `value`)",
            )?;
            let v = st
                .value
                .ok_or_else(|| problem(format!("{k}.value"), "is required (the hot value)"))?;
            finite(&format!("{k}.value"), v)?;
            let hot = st
                .hot
                .as_ref()
                .ok_or_else(|| problem(format!("{k}.hot"), "is required by directed heat"))?;
            super::region::validate(&format!("{k}.hot"), hot)?;
            if let Some(held) = &st.held {
                super::region::validate(&format!("{k}.held"), held)?;
            }
            Ok(())
        }
        StimulusKind::Diffusion => {
            for (key, v) in [
                ("value", &st.value),
                ("top", &st.top),
                ("bottom", &st.bottom),
            ] {
                absent(&format!("{k}.{key}"), v, "to diffusion (use `sources`)")?;
            }
            absent(&format!("{k}.hot"), &st.hot, "to diffusion")?;
            absent(&format!("{k}.held"), &st.held, "to diffusion")?;
            let d = st
                .diffusivity
                .ok_or_else(|| problem(format!("{k}.diffusivity"), "is required by diffusion"))?;
            positive(&format!("{k}.diffusivity"), d)?;
            if let Some(l) = st.layers {
                if !(1..=64).contains(&l) {
                    return Err(problem(
                        format!("{k}.layers"),
                        format!("must be in 1..=64, got {l}"),
                    ));
                }
            }
            if st.sources.is_empty() {
                return Err(problem(
                    format!("{k}.sources"),
                    "diffusion needs at least one source",
                ));
            }
            for (i, src) in st.sources.iter().enumerate() {
                let sk = format!("{k}.sources[{i}]");
                match (src.value, src.flux) {
                    (Some(v), None) => finite(&format!("{sk}.value"), v)?,
                    (None, Some(f)) => finite(&format!("{sk}.flux"), f)?,
                    _ => {
                        return Err(problem(sk, "needs exactly one of `value` and `flux`"));
                    }
                }
                if let Some(r) = &src.region {
                    super::region::validate(&format!("{sk}.region"), r)?;
                }
            }
            Ok(())
        }
    }
}

/// Growth model and stimulus field of a validated `[growth]` section (the builder derives the
/// grown rest forms and the mass uptake from them).
pub type GrowthParts = (Box<dyn GrowthModel>, Box<dyn StimulusField>);

/// The growth model and stimulus field of a validated `[growth]` section on `mesh` (reference
/// positions `x_ref`, rest forms before growth `rest`, shell thickness `thickness` in m).
pub fn build(
    g: &GrowthSpec,
    mesh: &Mesh,
    x_ref: &[Vector3<f64>],
    rest: &RestState,
    thickness: f64,
) -> Result<GrowthParts, GrowthError> {
    let model: Box<dyn GrowthModel> = match g.model {
        GrowthModelKind::Isotropic => Box::new(Isotropic {
            p: g.p.unwrap_or(0.0),
            coefficient: 1.0,
        }),
        GrowthModelKind::Linear | GrowthModelKind::Bilayer => {
            let c = g.coefficient.unwrap_or(0.0);
            let mut sw = if g.model == GrowthModelKind::Linear {
                Swelling::linear(c)
            } else {
                Swelling::bilayer(c)
            };
            if let Some(d) = &g.direction {
                let cross = g.cross_coefficient.unwrap_or(c);
                sw.anisotropy = Some(Anisotropy::along(mesh, x_ref, v3(d), cross)?);
            }
            Box::new(sw)
        }
    };
    let st = &g.stimulus;
    let field: Box<dyn StimulusField> = match st.kind {
        StimulusKind::Uniform => {
            let m = match (st.value, st.top, st.bottom) {
                (Some(v), _, _) => FaceStimulus::uniform(v),
                (None, t, b) => FaceStimulus {
                    top: t.unwrap_or(0.0),
                    bottom: b.unwrap_or(0.0),
                },
            };
            Box::new(Prescribed::uniform(mesh.n_faces(), m)?)
        }
        StimulusKind::DirectedHeat => {
            let hot = st
                .hot
                .as_ref()
                .map_or(Region::Faces(Vec::new()), super::region::build);
            let held = st
                .held
                .as_ref()
                .map_or(Region::Faces(Vec::new()), super::region::build);
            Box::new(DirectedHeat::new(
                mesh,
                x_ref,
                &hot,
                &held,
                st.value.unwrap_or(0.0),
            )?)
        }
        StimulusKind::Diffusion => {
            let mut sources = Vec::with_capacity(st.sources.len());
            for (i, src) in st.sources.iter().enumerate() {
                let faces = src
                    .region
                    .as_ref()
                    .map_or(Region::All, super::region::build)
                    .faces(mesh, x_ref)?;
                if !faces.iter().any(|&f| f) {
                    return Err(GrowthError::EmptyRegion {
                        name: format!("growth.stimulus.sources[{i}].region"),
                    });
                }
                sources.push(DiffusionSource {
                    surface: match src.surface {
                        Surface::Top => GrowthSurface::Top,
                        Surface::Bottom => GrowthSurface::Bottom,
                    },
                    faces,
                    kind: match (src.value, src.flux) {
                        (Some(v), _) => SourceKind::Value(v),
                        (None, f) => SourceKind::Flux(f.unwrap_or(0.0)),
                    },
                });
            }
            let settings = DiffusionSettings {
                diffusivity: st.diffusivity.unwrap_or(0.0),
                thickness,
                layers: st.layers.unwrap_or(2),
                initial: 0.0,
            };
            Box::new(Diffusion::new(mesh, rest, settings, &sources)?)
        }
    };
    Ok((model, field))
}
