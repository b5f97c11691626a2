//! The fields of a frame: everything a VTK frame carries besides the positions, computed from a
//! simulation's state in this one module (the output writer only writes what it returns).
//!
//! Point data: `displacement` (m, from the reference configuration), `velocity` (m/s) and, with
//! contact, `contact_force` (N, the barrier's force on each vertex). Cell data:
//! `stretch_density` and `bend_density` (J/m²: a face's elastic energy — the one per-face
//! function [`Assembler::elastic_face_energies`], no damping — at the frame's positions and edge
//! angles over its rest area ½√det ā of the current rest state, so growth is included; density ×
//! rest area summed over the faces is the run's stretching / bending energy), with growth
//! `stimulus_top` / `stimulus_bottom`, and with contact `contact_gap` (m, the smallest gap of the
//! face's vertices' contact pairs, capped at d̂). `docs/scenes.md` (`[output] formats`) lists
//! them for users.

use nalgebra::Vector3;
use thinshell_energy::{Assembler, ShellModel};

use crate::sim::Simulation;

/// The arrays of one frame, in the order they are written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameFields {
    /// Per-vertex 3-vectors (name, one per vertex).
    pub point_vectors: Vec<(&'static str, Vec<Vector3<f64>>)>,
    /// Per-face scalars (name, one per face).
    pub cell_scalars: Vec<(&'static str, Vec<f64>)>,
    /// Why some fields could not be computed (the frame is written without them), if so.
    pub missing: Option<String>,
}

/// Computes the fields of a run's frames; built once per run (it keeps an energy-only
/// assembler between frames).
#[derive(Default)]
pub struct FieldEvaluator {
    /// Built at the first frame.
    densities: Option<FaceEnergyDensity>,
}

impl FieldEvaluator {
    /// An evaluator with nothing built yet.
    pub fn new() -> FieldEvaluator {
        FieldEvaluator::default()
    }

    /// The fields of `sim`'s current state. A failure of the energy densities (the last good
    /// state after a failed step, say) is not fatal: the other fields are returned and
    /// [`FrameFields::missing`] says why those are absent.
    pub fn evaluate(&mut self, sim: &Simulation) -> FrameFields {
        let mut fields = FrameFields::default();
        let displacement = sim
            .positions()
            .iter()
            .zip(sim.reference_positions())
            .map(|(x, x0)| x - x0)
            .collect();
        fields.point_vectors.push(("displacement", displacement));
        fields
            .point_vectors
            .push(("velocity", sim.velocities().to_vec()));
        let densities = match self.densities.take() {
            Some(d) => Ok(d),
            None => FaceEnergyDensity::new(sim),
        }
        .and_then(|mut d| {
            let values = d.evaluate(sim);
            self.densities = Some(d);
            values
        });
        match densities {
            Ok(d) => {
                fields.cell_scalars.push(("stretch_density", d.stretch));
                fields.cell_scalars.push(("bend_density", d.bend));
            }
            Err(e) => fields.missing = Some(format!("{e}; written without energy densities")),
        }
        if let Some(g) = sim.growth() {
            let stimulus = g.stimulus();
            fields
                .cell_scalars
                .push(("stimulus_top", stimulus.iter().map(|m| m.top).collect()));
            fields.cell_scalars.push((
                "stimulus_bottom",
                stimulus.iter().map(|m| m.bottom).collect(),
            ));
        }
        if let Some(c) = &sim.system().contact {
            fields
                .cell_scalars
                .push(("contact_gap", c.face_gaps(sim.positions())));
            fields
                .point_vectors
                .push(("contact_force", c.forces(sim.positions())));
        }
        fields
    }
}

/// An energy-only assembler for one run (damping off), built once and evaluated at every frame.
struct FaceEnergyDensity {
    assembler: Assembler,
    model: ShellModel,
}

/// Per-face densities of one frame, J/m² (face order).
#[derive(Clone, Debug, PartialEq)]
struct Densities {
    /// Stretching energy per unit rest area.
    stretch: Vec<f64>,
    /// Bending energy per unit rest area (may be negative for a bilayer, see `docs/model.md`).
    bend: Vec<f64>,
}

impl FaceEnergyDensity {
    /// An evaluator for `sim`'s mesh, material and bending form.
    fn new(sim: &Simulation) -> Result<FaceEnergyDensity, String> {
        let model = sim.model().elastic();
        let assembler = sim
            .system()
            .assembler_for(&model)
            .map_err(|e| format!("energy densities: {e}"))?;
        Ok(FaceEnergyDensity { assembler, model })
    }

    /// The densities at `sim`'s current state (its edge angles: empty before the first solve,
    /// all 0 then, as the assembler reads them).
    fn evaluate(&mut self, sim: &Simulation) -> Result<Densities, String> {
        let rest = &sim.system().rest;
        let (_, faces) = self
            .assembler
            .elastic_face_energies(&self.model, sim.positions(), sim.edge_angles(), rest)
            .map_err(|e| format!("energy densities: {e}"))?;
        let mut d = Densities {
            stretch: Vec::with_capacity(rest.a_bar.len()),
            bend: Vec::with_capacity(rest.a_bar.len()),
        };
        for (f, (e, a)) in faces.iter().zip(&rest.a_bar).enumerate() {
            let area = 0.5 * a.determinant().max(0.0).sqrt();
            if !(area > 0.0 && area.is_finite()) {
                return Err(format!(
                    "energy densities: face {f} has rest area {area:e} m²"
                ));
            }
            d.stretch.push(e.stretch / area);
            d.bend.push(e.bend / area);
        }
        Ok(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    /// Density × rest area summed over the faces gives back the run's energies (an independent
    /// evaluation through the simulation's own system).
    #[test]
    fn densities_integrate_to_the_energy() -> Result<(), Box<dyn std::error::Error>> {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let scene = Scene::load_with_overrides(
            &root.join("data/scenes/square_cylinder.toml"),
            &["integrator.steps=1".to_string()],
        )?;
        let mut sim = Simulation::build(&scene)?;
        sim.step()?;
        let d = FaceEnergyDensity::new(&sim)?.evaluate(&sim)?;
        let rest = &sim.system().rest;
        let area = |a: &nalgebra::Matrix2<f64>| 0.5 * a.determinant().sqrt();
        let s: f64 = d
            .stretch
            .iter()
            .zip(&rest.a_bar)
            .map(|(x, a)| x * area(a))
            .sum();
        let b: f64 = d
            .bend
            .iter()
            .zip(&rest.a_bar)
            .map(|(x, a)| x * area(a))
            .sum();
        let e = sim.energy();
        assert!(
            (s - e.stretch).abs() <= 1e-9 * e.stretch.abs().max(1e-300),
            "{s} vs {}",
            e.stretch
        );
        assert!(
            (b - e.bend).abs() <= 1e-9 * e.bend.abs(),
            "{b} vs {}",
            e.bend
        );
        assert!(e.bend > 0.0);
        Ok(())
    }
}
