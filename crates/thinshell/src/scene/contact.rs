//! The `[contact]` section: its spec (barrier distance and stiffness, self contact, rigid
//! obstacles), its validation and the solver's [`ContactSettings`] it builds
//! (`docs/scenes.md`, `docs/model.md` §7).

use std::path::Path;

use serde::{Deserialize, Serialize};
use thinshell_system::{ContactSettings, Obstacle};

use super::effects::{Effect, section_without_effect};
use super::problem::{Check, Problem, finite_all, positive, problem, v3};

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

/// What `[contact]` is checked against besides itself.
#[derive(Clone, Copy, Debug)]
pub struct ContactContext {
    /// The scene has effect `contact`.
    pub on: bool,
    /// The integrator is explicit Euler.
    pub explicit: bool,
}

/// Checks `[contact]`: effect `contact` only with a Newton integrator (static, implicit or
/// path following), something to keep apart, each obstacle with exactly its kind's keys in range.
pub fn validate(spec: &Option<ContactSpec>, cx: ContactContext) -> Check {
    if cx.on && cx.explicit {
        // Explicit Euler takes no Newton step for the CCD to limit.
        return Err(problem(
            "integrator.kind",
            "effect `contact` needs the `implicit` or `static` integrator",
        ));
    }
    let Some(c) = spec else {
        return Ok(());
    };
    if !cx.on {
        return Err(section_without_effect("contact", Effect::Contact));
    }
    if let Some(d) = c.distance {
        positive("contact.distance", d)?;
    }
    if let Some(k) = c.stiffness {
        positive("contact.stiffness", k)?;
    }
    if !c.self_contact && c.obstacles.is_empty() {
        return Err(problem(
            "contact",
            "`self = false` and no obstacles: nothing to keep apart",
        ));
    }
    for (i, o) in c.obstacles.iter().enumerate() {
        let key = format!("contact.obstacles[{i}]");
        let given = [
            ("point", o.point.is_some()),
            ("normal", o.normal.is_some()),
            ("center", o.center.is_some()),
            ("radius", o.radius.is_some()),
            ("min", o.min.is_some()),
            ("max", o.max.is_some()),
            ("path", o.path.is_some()),
        ];
        let needed: &[&str] = match o.kind {
            ObstacleKind::Plane => &["point", "normal"],
            ObstacleKind::Sphere => &["center", "radius"],
            ObstacleKind::Box => &["min", "max"],
            ObstacleKind::Mesh => &["path"],
        };
        for (name, g) in given {
            if needed.contains(&name) && !g {
                return Err(problem(&key, format!("this obstacle needs `{name}`")));
            }
        }
        for (name, g) in given {
            if g && !needed.contains(&name) {
                return Err(problem(
                    format!("{key}.{name}"),
                    "not a key of this obstacle kind",
                ));
            }
        }
        for (name, v) in [
            ("point", o.point),
            ("normal", o.normal),
            ("center", o.center),
            ("min", o.min),
            ("max", o.max),
        ] {
            if let Some(v) = v {
                finite_all(&format!("{key}.{name}"), &v)?;
            }
        }
        if let Some(n) = o.normal
            && n.iter().all(|&c| c == 0.0)
        {
            return Err(problem(format!("{key}.normal"), "must not be zero"));
        }
        if let Some(r) = o.radius {
            positive(&format!("{key}.radius"), r)?;
        }
        if o.path.as_deref().is_some_and(|p| p.trim().is_empty()) {
            return Err(problem(format!("{key}.path"), "must name an OBJ file"));
        }
        if let (Some(lo), Some(hi)) = (o.min, o.max)
            && (0..3).any(|k| lo[k] >= hi[k])
        {
            return Err(problem(
                format!("{key}.max"),
                format!("must exceed `min` on every axis (min {lo:?}, max {hi:?})"),
            ));
        }
    }
    Ok(())
}

/// The solver's contact settings of a validated `[contact]` section (all defaults without
/// one). Mesh obstacles are read from their OBJ files (paths relative to `base_dir`, the scene
/// file's directory); an unreadable or invalid file is a problem of its `path` key.
pub fn build(spec: Option<&ContactSpec>, base_dir: &Path) -> Result<ContactSettings, Problem> {
    let Some(c) = spec else {
        return Ok(ContactSettings::default());
    };
    let obstacles = c
        .obstacles
        .iter()
        .enumerate()
        .map(|(i, o)| {
            // Validation guarantees each obstacle has its keys.
            Ok(match o.kind {
                ObstacleKind::Plane => Obstacle::Plane {
                    point: v3(&o.point.unwrap_or_default()),
                    normal: v3(&o.normal.unwrap_or([0.0, 0.0, 1.0])),
                },
                ObstacleKind::Sphere => Obstacle::Sphere {
                    center: v3(&o.center.unwrap_or_default()),
                    radius: o.radius.unwrap_or(1.0),
                },
                ObstacleKind::Box => Obstacle::Box {
                    min: v3(&o.min.unwrap_or_default()),
                    max: v3(&o.max.unwrap_or([1.0; 3])),
                },
                ObstacleKind::Mesh => {
                    let path = base_dir.join(o.path.as_deref().unwrap_or_default());
                    Obstacle::mesh_from_obj(&path)
                        .map_err(|e| problem(format!("contact.obstacles[{i}].path"), e))?
                }
            })
        })
        .collect::<Result<Vec<_>, Problem>>()?;
    Ok(ContactSettings {
        obstacles,
        self_contact: c.self_contact,
        distance: c.distance,
        stiffness: c.stiffness,
        thickness_offset: c.thickness_offset,
    })
}
