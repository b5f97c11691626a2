//! Per-face energy densities written into every VTK frame (`stretch_density`, `bend_density`,
//! J/m²), for energy maps such as the colour fields of `thinshell view`.
//!
//! A face's density is its elastic energy (the per-face terms of the assembler, no damping) at
//! the frame's positions and edge angles, divided by its rest area ½√det ā (m², the current rest
//! state, so growth is included). The sum of density × rest area over the faces is the run's
//! stretching (bending) energy.

use thinshell_energy::{Assembler, EvalOutput, ShellModel, Terms};

use crate::sim::Simulation;

/// An energy-only assembler for one run, built once and evaluated at every frame.
pub struct FaceEnergyDensity {
    assembler: Assembler,
    model: ShellModel,
}

/// Per-face densities of one frame, J/m² (face order).
#[derive(Clone, Debug, PartialEq)]
pub struct Densities {
    /// Stretching energy per unit rest area.
    pub stretch: Vec<f64>,
    /// Bending energy per unit rest area (may be negative for a bilayer, see `docs/model.md`).
    pub bend: Vec<f64>,
}

impl FaceEnergyDensity {
    /// An evaluator for `sim`'s mesh, material and bending form (damping off: it needs the
    /// previous step and is not an energy of the frame).
    pub fn new(sim: &Simulation) -> Result<FaceEnergyDensity, String> {
        let model = ShellModel {
            terms: Terms {
                damping: false,
                ..sim.model().terms
            },
            ..*sim.model()
        };
        let assembler = sim
            .system()
            .assembler_for(&model)
            .map_err(|e| format!("energy densities: {e}"))?;
        Ok(FaceEnergyDensity { assembler, model })
    }

    /// The densities at `sim`'s current state.
    pub fn evaluate(&mut self, sim: &Simulation) -> Result<Densities, String> {
        let rest = sim.system().rest();
        let zeros;
        let phi = if sim.edge_angles().is_empty() && self.assembler.has_edge_unknowns() {
            zeros = vec![0.0; sim.mesh().n_edges()];
            &zeros[..]
        } else {
            sim.edge_angles()
        };
        self.assembler
            .evaluate_with_angles(
                &self.model,
                sim.positions(),
                phi,
                rest,
                None,
                EvalOutput::default(),
            )
            .map_err(|e| format!("energy densities: {e}"))?;
        let mut d = Densities {
            stretch: Vec::with_capacity(rest.a_bar.len()),
            bend: Vec::with_capacity(rest.a_bar.len()),
        };
        for (f, (e, a)) in self
            .assembler
            .face_energies()
            .iter()
            .zip(&rest.a_bar)
            .enumerate()
        {
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
        let rest = sim.system().rest();
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
