//! The `[initial]` section: its spec (maps of the mesh to the start positions, a start
//! velocity), its validation and the start state it builds (`docs/scenes.md`).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use thinshell_mesh::Mesh;

use super::problem::{Check, Problem, finite, finite_all, m2, positive, problem};
use crate::reference::{map_xy, wrap_cylinder};

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

/// Checks `[initial]`: an orientation-preserving linear map, a positive scale, a positive
/// radius, finite values. (That a static solve has no use for `velocity` is the whole file's
/// check.)
pub fn validate(i: &InitialSpec) -> Check {
    if let Some(m) = &i.linear_xy {
        finite_all("initial.linear_xy", &[m[0][0], m[0][1], m[1][0], m[1][1]])?;
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        if det <= 0.0 {
            return Err(problem(
                "initial.linear_xy",
                format!("must have a positive determinant (no flips, no collapse), got {det}"),
            ));
        }
    }
    if let Some(s) = i.scale {
        positive("initial.scale", s)?;
    }
    if let Some(w) = &i.wrap_cylinder {
        positive("initial.wrap_cylinder.radius", w.radius)?;
        if let Some(c) = w.center_x {
            finite("initial.wrap_cylinder.center_x", c)?;
        }
    }
    if let Some(v) = &i.velocity {
        finite_all("initial.velocity", v)?;
    }
    Ok(())
}

/// Start positions (m) and velocities (m/s), one per vertex.
pub type Start = (Vec<Vector3<f64>>, Vec<Vector3<f64>>);

/// The start state of a validated `[initial]` section: the mesh's positions `x_ref` mapped,
/// every vertex with the given velocity. A map that takes the mesh out of f64's range is a
/// problem of `initial`.
pub fn build(spec: &InitialSpec, mesh: &Mesh, x_ref: &[Vector3<f64>]) -> Result<Start, Problem> {
    let mut x = x_ref.to_vec();
    if let Some(m) = &spec.linear_xy {
        x = map_xy(&x, &m2(m));
    }
    if let Some(k) = spec.scale {
        x.iter_mut().for_each(|p| *p *= k);
    }
    if let Some(w) = &spec.wrap_cylinder {
        x = wrap_cylinder(&x, w.radius, w.center_x.unwrap_or(0.5));
    }
    thinshell_mesh::check_scale(mesh, &x)
        .map_err(|e| problem("initial", format!("maps the mesh out of range: {e}")))?;
    let v0 = spec
        .velocity
        .map_or(Vector3::zeros(), |v| Vector3::new(v[0], v[1], v[2]));
    Ok((x, vec![v0; x_ref.len()]))
}
