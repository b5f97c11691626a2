//! Natural frequencies and mode shapes of a scene (docs/modal.md): the library function
//! [`simulation_modes`], the writer of `modes.json` plus one VTK frame per mode
//! ([`write_modes`]) and the `thinshell modes` command ([`modes_command`]). Self-contained so
//! that it moves with the CLI.

use std::path::Path;

use nalgebra::Vector3;
use serde::Serialize;
use thinshell_solver::SolverError;
use thinshell_system::{ModalSettings, Modes};

use crate::sim::Simulation;
use crate::vtk::{Frame, Series};

/// The `count` lowest natural frequencies and mode shapes of `sim` about its current state
/// (positions and edge angles; for a freshly built scene its start state, an equilibrium when
/// the scene starts at its rest shape without loads). Damping is left out; the massless edge
/// angles are condensed. Errors: see [`ShellSystem::natural_modes`](thinshell_system::ShellSystem::natural_modes).
pub fn simulation_modes(sim: &mut Simulation, count: usize) -> Result<Modes, SolverError> {
    let x = sim.positions().to_vec();
    let phi = sim.edge_angles().to_vec();
    let settings = ModalSettings {
        count,
        ..ModalSettings::default()
    };
    let system = sim.system_mut();
    // The state's angles when it has them all; else the minimising ones (model.md §1.1).
    let phi = if phi.len() == system.n_edge_angles() {
        phi
    } else {
        Vec::new()
    };
    system.natural_modes(&x, &phi, &settings)
}

/// `modes.json`: what [`write_modes`] writes.
#[derive(Serialize)]
struct ModesJson<'a> {
    scene: &'a str,
    /// Frequencies (Hz), ascending.
    frequencies_hz: &'a [f64],
    /// ω² (rad²/s²), ascending.
    eigenvalues: &'a [f64],
    /// Relative residual of each mode.
    residuals: &'a [f64],
    /// Mode shapes: one [x, y, z] displacement per vertex (m), M-normalised.
    shapes: Vec<Vec<[f64; 3]>>,
    /// `frame_NNNNNN.vtu` of mode k is frame k (frame 0: the undeformed state).
    frames: &'a str,
}

/// Writes `dir/modes.json` (frequencies in Hz ascending, ω², residuals, M-normalised shapes)
/// and a VTK series the viewer shows: `frame_000000.vtu` the state itself, `frame_00000k.vtu`
/// mode k added with its largest displacement scaled to 10 % of the bounding-box diagonal
/// (point data `displacement`: the scaled mode), indexed by `frames.pvd` at "time" k.
pub fn write_modes(dir: &Path, sim: &Simulation, modes: &Modes) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let json = ModesJson {
        scene: sim.name(),
        frequencies_hz: &modes.frequencies,
        eigenvalues: &modes.eigenvalues,
        residuals: &modes.residuals,
        shapes: modes
            .shapes
            .iter()
            .map(|s| s.iter().map(|v| [v.x, v.y, v.z]).collect())
            .collect(),
        frames: "frames.pvd: frame k = mode k (k >= 1), frame 0 = the state",
    };
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    crate::atomic::write_atomic(&dir.join("modes.json"), text.as_bytes())
        .map_err(|e| format!("{}: {e}", dir.join("modes.json").display()))?;
    let mesh = sim.mesh();
    let x = sim.positions();
    let size = 0.1 * mesh.bounding_box().diagonal();
    let mut series = Series::new(dir, "frames");
    let zero = vec![Vector3::zeros(); x.len()];
    series
        .write(
            "frame_000000.vtu",
            0.0,
            &Frame {
                mesh,
                points: x,
                point_vectors: vec![("displacement", &zero)],
                cell_scalars: Vec::new(),
            },
        )
        .map_err(|e| e.to_string())?;
    for (k, shape) in modes.shapes.iter().enumerate() {
        let max = shape.iter().map(|v| v.norm()).fold(0.0f64, f64::max);
        let scale = if max > 0.0 { size / max } else { 0.0 };
        let d: Vec<Vector3<f64>> = shape.iter().map(|v| v * scale).collect();
        let points: Vec<Vector3<f64>> = x.iter().zip(&d).map(|(p, d)| p + d).collect();
        series
            .write(
                &format!("frame_{:06}.vtu", k + 1),
                (k + 1) as f64,
                &Frame {
                    mesh,
                    points: &points,
                    point_vectors: vec![("displacement", &d)],
                    cell_scalars: Vec::new(),
                },
            )
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}
