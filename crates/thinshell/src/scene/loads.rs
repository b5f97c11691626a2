//! The load sections `[gravity]`, `[pressure]` and `[[point_loads]]`: their specs, their
//! validation against the effects list and the solver's [`Loads`] they build
//! (`docs/scenes.md`).

use serde::{Deserialize, Serialize};
use thinshell_mesh::VertexId;
use thinshell_system::Loads;

use super::effects::{Effect, section_without_effect};
use super::problem::{Check, Problem, finite, finite_all, problem, v3};

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

/// A scene's load sections, borrowed from the scene file.
#[derive(Clone, Copy, Debug)]
pub struct LoadSpecs<'a> {
    /// `[gravity]`.
    pub gravity: Option<&'a GravitySpec>,
    /// `[pressure]`.
    pub pressure: Option<&'a PressureSpec>,
    /// `[[point_loads]]`.
    pub point_loads: &'a [PointLoadSpec],
}

/// Checks the load sections: each given exactly when its effect is on (`[gravity]` may be
/// left out for the default acceleration), finite values, a nonzero pressure axis.
pub fn validate(l: LoadSpecs<'_>, on: &dyn Fn(Effect) -> bool) -> Check {
    match (l.gravity, on(Effect::Gravity)) {
        (Some(_), false) => return Err(section_without_effect("gravity", Effect::Gravity)),
        (Some(g), true) => finite_all("gravity.acceleration", &g.acceleration)?,
        _ => {}
    }
    match (l.pressure, on(Effect::Pressure)) {
        (Some(_), false) => return Err(section_without_effect("pressure", Effect::Pressure)),
        (None, true) => {
            return Err(problem(
                "pressure",
                "effect `pressure` needs a [pressure] section with `value`",
            ));
        }
        (Some(p), true) => {
            finite("pressure.value", p.value)?;
            if let Some(a) = &p.axis {
                finite_all("pressure.axis", a)?;
                if a.iter().all(|c| *c == 0.0) {
                    return Err(problem("pressure.axis", "must be a nonzero vector"));
                }
            }
        }
        (None, false) => {}
    }
    match (l.point_loads.is_empty(), on(Effect::PointLoads)) {
        (false, false) => {
            return Err(problem(
                "point_loads",
                "given but effect `point_loads` is not in `effects`",
            ));
        }
        (true, true) => {
            return Err(problem(
                "point_loads",
                "effect `point_loads` needs at least one [[point_loads]] entry",
            ));
        }
        _ => {}
    }
    for (i, p) in l.point_loads.iter().enumerate() {
        finite_all(&format!("point_loads[{i}].force"), &p.force)?;
    }
    Ok(())
}

/// The loads of the effects switched on, for a mesh of `n_vertices`; a point load on a vertex
/// the mesh does not have is a problem of its `vertex` key.
pub fn build(
    l: LoadSpecs<'_>,
    on: &dyn Fn(Effect) -> bool,
    n_vertices: usize,
) -> Result<Loads, Problem> {
    let mut loads = Loads::default();
    if on(Effect::Gravity) {
        loads.gravity = v3(&l.gravity.map_or_else(default_gravity, |g| g.acceleration));
    }
    if let Some(p) = l.pressure.filter(|_| on(Effect::Pressure)) {
        loads.pressure = p.value;
        // Checked finite and nonzero by validation.
        loads.pressure_axis = p.axis.as_ref().map(v3);
    }
    if on(Effect::PointLoads) {
        for (i, p) in l.point_loads.iter().enumerate() {
            if p.vertex >= n_vertices {
                return Err(problem(
                    format!("point_loads[{i}].vertex"),
                    format!(
                        "vertex {} out of range (the mesh has {n_vertices})",
                        p.vertex
                    ),
                ));
            }
            loads
                .point_forces
                .push((VertexId::new(p.vertex), v3(&p.force)));
        }
    }
    Ok(loads)
}
