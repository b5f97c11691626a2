//! A region of space as scenes give it (`half_space`, `sphere`, `box` or `vertices`; used by
//! `[boundary]` and `[growth.stimulus]`): its spec, its validation and the growth crate's
//! [`Region`] it builds.

use serde::{Deserialize, Serialize};
use thinshell_growth::Region;

use super::problem::{Check, finite_all, positive, problem, v3};

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

/// Checks a region given under `key`: exactly one kind, its values in range.
pub fn validate(key: &str, r: &RegionSpec) -> Check {
    let n = [
        r.half_space.is_some(),
        r.sphere.is_some(),
        r.aabb.is_some(),
        r.vertices.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if n != 1 {
        return Err(problem(
            key,
            "needs exactly one of `half_space`, `sphere`, `box`, `vertices`",
        ));
    }
    if let Some(h) = &r.half_space {
        finite_all(&format!("{key}.half_space.point"), &h.point)?;
        finite_all(&format!("{key}.half_space.normal"), &h.normal)?;
        if h.normal.iter().all(|&c| c == 0.0) {
            return Err(problem(
                format!("{key}.half_space.normal"),
                "must not be zero",
            ));
        }
    }
    if let Some(s) = &r.sphere {
        finite_all(&format!("{key}.sphere.center"), &s.center)?;
        positive(&format!("{key}.sphere.radius"), s.radius)?;
    }
    if let Some(b) = &r.aabb {
        finite_all(&format!("{key}.box.min"), &b.min)?;
        finite_all(&format!("{key}.box.max"), &b.max)?;
        if (0..3).any(|i| b.min[i] > b.max[i]) {
            return Err(problem(
                format!("{key}.box"),
                "needs min ≤ max in every coordinate",
            ));
        }
    }
    if let Some(v) = &r.vertices {
        if v.is_empty() {
            return Err(problem(format!("{key}.vertices"), "is empty"));
        }
    }
    Ok(())
}

/// The growth crate's region (the same geometric predicates for boundary regions and
/// stimulus regions); validation guarantees exactly one key.
pub fn build(spec: &RegionSpec) -> Region {
    if let Some(h) = &spec.half_space {
        Region::HalfSpace {
            point: v3(&h.point),
            normal: v3(&h.normal),
        }
    } else if let Some(b) = &spec.sphere {
        Region::Ball {
            center: v3(&b.center),
            radius: b.radius,
        }
    } else if let Some(b) = &spec.aabb {
        Region::Box {
            min: v3(&b.min),
            max: v3(&b.max),
        }
    } else if let Some(v) = &spec.vertices {
        Region::Vertices(v.clone())
    } else {
        Region::All
    }
}
