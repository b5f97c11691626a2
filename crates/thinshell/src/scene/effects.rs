//! The top-level `effects` list: the physical effects a scene switches on, and its validation
//! (each effect once, at least one elastic effect). Every section that belongs to an effect
//! checks against this list.

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

use super::problem::{Problem, problem};

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

/// Checks `effects`: no effect twice, at least one elastic effect; returns the set.
pub fn validate(effects: &[Effect]) -> Result<BTreeSet<Effect>, Problem> {
    let mut set = BTreeSet::new();
    for (i, &e) in effects.iter().enumerate() {
        if !set.insert(e) {
            return Err(problem(
                format!("effects[{i}]"),
                format!("effect `{}` is listed twice", e.key()),
            ));
        }
    }
    if !set.contains(&Effect::Stretching) && !set.contains(&Effect::Bending) {
        return Err(problem(
            "effects",
            "needs at least one elastic effect: `stretching` or `bending`",
        ));
    }
    Ok(set)
}

/// A section given while its effect is off.
pub(crate) fn section_without_effect(key: &str, effect: Effect) -> Problem {
    problem(
        key,
        format!(
            "section given but effect `{}` is not in `effects`",
            effect.key()
        ),
    )
}
