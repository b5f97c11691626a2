//! The `[path]` table: path following (arc length or displacement control) of a static
//! scene's loads instead of the load ramp (`docs/scenes.md`, `docs/path_following.md`).

use serde::{Deserialize, Serialize};

use super::problem::{Problem, problem};

/// Path following settings; every key but `control` is optional with the default stated
/// (the solver's, `thinshell_solver::PathSettings::default`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PathSpec {
    /// `arc_length` or `displacement`.
    pub control: PathControlName,
    /// Displacement control: the controlled vertex (0-based; required there).
    #[serde(default)]
    pub vertex: Option<usize>,
    /// Displacement control: its controlled coordinate, `x`, `y` or `z` (required there).
    #[serde(default)]
    pub coordinate: Option<Axis>,
    /// Size of the first step as the load-factor increment of its predictor (default 0.1).
    #[serde(default)]
    pub initial_load_increment: Option<f64>,
    /// First arc length, m (arc length), or first increment of the controlled coordinate, m,
    /// signed (displacement control); default: from `initial_load_increment`.
    #[serde(default)]
    pub initial_step: Option<f64>,
    /// Weight ψ of the load factor in the arc length, m per unit load factor (≥ 0; 0 =
    /// cylindrical constraint; default: the start tangent's displacement per unit λ).
    #[serde(default)]
    pub psi: Option<f64>,
    /// `+1` (default): the first step raises the load; `-1`: lowers it.
    #[serde(default)]
    pub direction: Option<f64>,
    /// Newton iterations per step the step adaptation aims at (default 4).
    #[serde(default)]
    pub desired_iterations: Option<usize>,
    /// Newton iterations after which a step is cut back (default 20).
    #[serde(default)]
    pub max_iterations: Option<usize>,
    /// Relative Newton correction that ends a step (default 1e-10).
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Halvings of a failing step before the run fails (default 10).
    #[serde(default)]
    pub max_cutbacks: Option<usize>,
    /// Smallest step relative to the first, in (0, 1] (default 1e-4).
    #[serde(default)]
    pub min_step_ratio: Option<f64>,
    /// Largest step relative to the first, ≥ 1 (default 10).
    #[serde(default)]
    pub max_step_ratio: Option<f64>,
    /// Vertex coordinates whose displacements are written to `steps.csv` (default none; the
    /// controlled coordinate of displacement control is always written).
    #[serde(default)]
    pub monitor: Vec<MonitorSpec>,
}

/// The constraint of a path step.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PathControlName {
    /// Riks/Crisfield arc length (passes limit points and snap-backs).
    ArcLength,
    /// Displacement control of one vertex coordinate (passes load limit points).
    Displacement,
}

/// A coordinate axis.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// x.
    X,
    /// y.
    Y,
    /// z.
    Z,
}

impl Axis {
    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
    /// `x`, `y` or `z`.
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }
}

/// One monitored vertex coordinate.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MonitorSpec {
    /// Vertex index (0-based).
    pub vertex: usize,
    /// `x`, `y` or `z`.
    pub coordinate: Axis,
}

/// What `[path]` must agree with in the rest of the scene (filled in by the scene's validation,
/// so that this section needs no other section's types).
#[derive(Clone, Copy, Debug)]
pub struct PathContext {
    /// `integrator.kind = "static"`.
    pub static_integrator: bool,
    /// `integrator.load_ramp` is given.
    pub load_ramp: bool,
    /// `integrator.end_time` is given.
    pub end_time: bool,
    /// Effect `growth` is on.
    pub growth: bool,
    /// `[[boundary.prescribed]]` is given.
    pub prescribed: bool,
    /// Effect `gravity`, `pressure` or `point_loads` is on.
    pub loads: bool,
}

/// Checks `[path]` against the rest of the scene (ranges; vertex indices are checked when the
/// mesh is built).
pub fn validate(p: &PathSpec, s: &PathContext) -> Result<(), Problem> {
    if !s.static_integrator {
        return Err(problem(
            "path",
            "needs `integrator.kind = \"static\"` (path following traces static equilibria)",
        ));
    }
    if s.load_ramp {
        return Err(problem(
            "integrator.load_ramp",
            "does not apply with `[path]`: path following sets the load factor itself",
        ));
    }
    if s.end_time {
        return Err(problem(
            "integrator.end_time",
            "does not apply with `[path]`: give the number of path steps as `integrator.steps`",
        ));
    }
    if s.growth {
        return Err(problem(
            "path",
            "cannot be combined with effect `growth` (the rest forms would change along the path)",
        ));
    }
    if s.prescribed {
        return Err(problem(
            "boundary.prescribed",
            "does not apply with `[path]`: only loads are scaled by the load factor (pin the \
             vertices instead, or use displacement control)",
        ));
    }
    if !s.loads {
        return Err(problem(
            "path",
            "has no load to follow: it needs effect `gravity`, `pressure` or `point_loads`",
        ));
    }
    let displacement = p.control == PathControlName::Displacement;
    match (displacement, p.vertex, p.coordinate) {
        (true, None, _) => {
            return Err(problem(
                "path.vertex",
                "is required with `control = \"displacement\"` (the controlled vertex)",
            ));
        }
        (true, _, None) => {
            return Err(problem(
                "path.coordinate",
                "is required with `control = \"displacement\"` (\"x\", \"y\" or \"z\")",
            ));
        }
        (false, Some(_), _) => {
            return Err(problem(
                "path.vertex",
                "applies to `control = \"displacement\"` only (use `[[path.monitor]]` to \
                 record a vertex)",
            ));
        }
        (false, _, Some(_)) => {
            return Err(problem(
                "path.coordinate",
                "applies to `control = \"displacement\"` only",
            ));
        }
        _ => {}
    }
    if !displacement && p.psi.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
        return Err(problem("path.psi", "must be ≥ 0 and finite"));
    }
    if displacement && p.psi.is_some() {
        return Err(problem(
            "path.psi",
            "applies to `control = \"arc_length\"` only",
        ));
    }
    if let Some(v) = p.initial_load_increment {
        if !(v.is_finite() && v > 0.0) {
            return Err(problem(
                "path.initial_load_increment",
                format!("must be > 0 and finite, got {v}"),
            ));
        }
    }
    if let Some(v) = p.initial_step {
        let ok = v.is_finite() && if displacement { v != 0.0 } else { v > 0.0 };
        if !ok {
            return Err(problem(
                "path.initial_step",
                format!(
                    "must be finite and {}, got {v}",
                    if displacement { "non-zero" } else { "> 0" }
                ),
            ));
        }
    }
    if let Some(d) = p.direction {
        if d != 1.0 && d != -1.0 {
            return Err(problem(
                "path.direction",
                format!("must be 1 or -1, got {d}"),
            ));
        }
    }
    for (key, v) in [
        ("path.desired_iterations", p.desired_iterations),
        ("path.max_iterations", p.max_iterations),
    ] {
        if v == Some(0) {
            return Err(problem(key, "must be ≥ 1"));
        }
    }
    if let Some(t) = p.tolerance {
        if !(t.is_finite() && t > 0.0) {
            return Err(problem(
                "path.tolerance",
                format!("must be > 0 and finite, got {t}"),
            ));
        }
    }
    if let Some(r) = p.min_step_ratio {
        if !(r > 0.0 && r <= 1.0) {
            return Err(problem(
                "path.min_step_ratio",
                format!("must lie in (0, 1], got {r}"),
            ));
        }
    }
    if let Some(r) = p.max_step_ratio {
        if !(r.is_finite() && r >= 1.0) {
            return Err(problem(
                "path.max_step_ratio",
                format!("must be ≥ 1 and finite, got {r}"),
            ));
        }
    }
    Ok(())
}
