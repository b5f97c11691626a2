//! Path following in a scene (`[path]`): each step of the run is one arc-length or
//! displacement-controlled step of a [`ShellPath`], starting from the equilibrium of the
//! start state at load factor 0. The step itself, a method of the simulation, is in
//! `path_step.rs`; this module does not depend on the simulation type.

use nalgebra::Vector3;
use serde::Serialize;
use thinshell_mesh::VertexId;
use thinshell_solver::{PathControl, PathSettings};
use thinshell_system::{ShellPath, ShellSystem};

use super::error::BuildError;
use crate::scene::path::{PathControlName, PathSpec};

/// A monitored vertex coordinate (a `steps.csv` column).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Monitor {
    /// Vertex index.
    pub vertex: usize,
    /// Coordinate: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
}

impl Monitor {
    /// The `steps.csv` column: `u_<vertex>_<x|y|z>_m`, the displacement (m) of that coordinate
    /// from the start state.
    pub fn column(&self) -> String {
        format!("u_{}_{}_m", self.vertex, ["x", "y", "z"][self.axis.min(2)])
    }
}

/// What a path step did, besides the common [`StepRecord`](super::StepRecord) fields.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PathRecord {
    /// Load-factor increment of the step (negative after a limit point).
    pub load_increment: f64,
    /// Step size: arc length (m) or the controlled coordinate's increment (m).
    pub step_length: f64,
    /// Halvings of the step before it converged.
    pub cutbacks: usize,
    /// Negative eigenvalues of the Hessian at fixed load (`None`: singular there).
    pub negative_eigenvalues: Option<usize>,
    /// Total potential Π = E − λ(F·x + p·V), J.
    pub potential: f64,
    /// Displacements of the monitored coordinates from the start state, m (order of
    /// [`Simulation::path_monitors`](super::Simulation::path_monitors)).
    pub monitors: Vec<f64>,
}

/// The path-following part of a simulation.
pub(crate) struct PathRun {
    pub(super) path: ShellPath,
    pub(super) monitors: Vec<Monitor>,
    /// The start state the monitored displacements are measured from.
    pub(super) x_start: Vec<Vector3<f64>>,
    /// Whether the start state has been brought to equilibrium at λ = 0.
    pub(super) started: bool,
}

/// Builds the path run of `spec` on `system` (its load factor is set to 0), starting at `x`.
pub(crate) fn build(
    spec: &PathSpec,
    system: &mut ShellSystem,
    x: &[Vector3<f64>],
    origin: &str,
) -> Result<PathRun, BuildError> {
    let n = x.len();
    let invalid = |key: String, message: String| BuildError::Invalid {
        origin: origin.into(),
        key,
        message,
    };
    let mut monitors = Vec::new();
    let control = match spec.control {
        PathControlName::ArcLength => PathControl::ArcLength { psi: spec.psi },
        PathControlName::Displacement => {
            // Validation guarantees both keys.
            let (Some(vertex), Some(axis)) = (spec.vertex, spec.coordinate) else {
                return Err(invalid(
                    "path.vertex".into(),
                    "and `path.coordinate` are required with displacement control".into(),
                ));
            };
            if vertex >= n {
                return Err(invalid(
                    "path.vertex".into(),
                    format!("vertex {vertex} out of range (the mesh has {n})"),
                ));
            }
            monitors.push(Monitor {
                vertex,
                axis: axis.index(),
            });
            ShellPath::displacement_control(system, VertexId::new(vertex), axis.index()).map_err(
                |_| {
                    invalid(
                        "path.vertex".into(),
                        format!(
                            "coordinate {} of vertex {vertex} is held by a pin or clamp: it \
                             cannot be controlled",
                            axis.name()
                        ),
                    )
                },
            )?
        }
    };
    for (i, m) in spec.monitor.iter().enumerate() {
        if m.vertex >= n {
            return Err(invalid(
                format!("path.monitor[{i}].vertex"),
                format!("vertex {} out of range (the mesh has {n})", m.vertex),
            ));
        }
        let m = Monitor {
            vertex: m.vertex,
            axis: m.coordinate.index(),
        };
        if !monitors.contains(&m) {
            monitors.push(m);
        }
    }
    let d = PathSettings::default();
    let settings = PathSettings {
        control,
        initial_load_increment: spec
            .initial_load_increment
            .unwrap_or(d.initial_load_increment),
        initial_step: spec.initial_step,
        direction: spec.direction.unwrap_or(d.direction),
        min_step_ratio: spec.min_step_ratio.unwrap_or(d.min_step_ratio),
        max_step_ratio: spec.max_step_ratio.unwrap_or(d.max_step_ratio),
        desired_iterations: spec.desired_iterations.unwrap_or(d.desired_iterations),
        max_iterations: spec.max_iterations.unwrap_or(d.max_iterations),
        tolerance: spec.tolerance.unwrap_or(d.tolerance),
        max_cutbacks: spec.max_cutbacks.unwrap_or(d.max_cutbacks),
        ordering: d.ordering,
    };
    settings.validate().map_err(|source| BuildError::Solver {
        origin: origin.into(),
        source,
    })?;
    system
        .set_load_factor(0.0)
        .map_err(|source| BuildError::Solver {
            origin: origin.into(),
            source,
        })?;
    Ok(PathRun {
        path: ShellPath::new(settings),
        monitors,
        x_start: x.to_vec(),
        started: false,
    })
}

/// The `steps.csv` columns a path-following run adds after the common ones
/// ([`crate::output::STEPS_CSV_COLUMNS`]; other runs add none), before contact's: `stable` (1 / 0),
/// `negative_eigenvalues` (of the Hessian at fixed load; empty where singular),
/// `load_increment`, `step_length`, `cutbacks`, `potential_J` and one `u_<vertex>_<axis>_m`
/// per monitored coordinate (`monitors`: `None` for a run that does not follow a path). Empty or
/// starting with a comma.
pub(crate) fn path_csv_header(monitors: Option<&[Monitor]>) -> String {
    let Some(monitors) = monitors else {
        return String::new();
    };
    let mut h = String::from(
        ",stable,negative_eigenvalues,load_increment,step_length,cutbacks,potential_J",
    );
    for m in monitors {
        h.push(',');
        h += &m.column();
    }
    h
}

/// The values of [`path_csv_header`]'s columns for one step, from its stability and path record
/// (`StepRecord::stable`, `StepRecord::path`; empty or starting with a comma).
pub(crate) fn path_csv_row(stable: Option<bool>, path: Option<&PathRecord>) -> String {
    let Some(p) = path else {
        return String::new();
    };
    let stable = match stable {
        Some(true) => "1",
        Some(false) => "0",
        None => "",
    };
    let negative = p
        .negative_eigenvalues
        .map(|n| n.to_string())
        .unwrap_or_default();
    let mut row = format!(
        ",{stable},{negative},{:e},{:e},{},{:e}",
        p.load_increment, p.step_length, p.cutbacks, p.potential
    );
    for u in &p.monitors {
        row += &format!(",{u:e}");
    }
    row
}
