//! The fields of a frame: everything a VTK frame carries besides the positions, computed from a
//! simulation's state in this one module (the output writer only writes what it returns).
//!
//! Point data: `displacement` (m, from the reference configuration), `velocity` (m/s), with
//! contact `contact_force` (N, the barrier's force on each vertex); the shell's curvature per
//! vertex ([`shell`]): `mean_curvature` (1/m), `gaussian_curvature` (1/m²) and the unit
//! principal directions `curvature_direction_1` / `curvature_direction_2`. Cell data:
//! `stretch_density` and `bend_density` (J/m²: a face's elastic energy — the one per-face
//! function [`Assembler::elastic_face_energies`], no damping — at the frame's positions and edge
//! angles over its rest area ½√det ā of the current rest state, so growth is included; density ×
//! rest area summed over the faces is the run's stretching / bending energy), with growth
//! `stimulus_top` / `stimulus_bottom`, with contact `contact_gap` (m, the smallest gap of the
//! face's vertices' contact pairs, capped at d̂); then per face ([`shell`]):
//! `principal_curvature_1` / `_2` (1/m), `face_mean_curvature` (1/m), `face_gaussian_curvature`
//! (1/m²), `membrane_strain_1` / `_2` (Green–Lagrange, dimensionless), `stress_resultant_1` /
//! `_2` (N/m), `bending_moment_1` / `_2` (N·m/m), larger value first, and the unit principal
//! directions `face_curvature_direction_1` / `_2`. `docs/scenes.md` (`[output] formats`) lists
//! them for users.

pub mod shell;

use nalgebra::Vector3;
use thinshell_energy::{Assembler, ShellModel};

use crate::sim::Simulation;

/// The arrays of one frame, in the order they are written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameFields {
    /// Per-vertex 3-vectors (name, one per vertex).
    pub point_vectors: Vec<(&'static str, Vec<Vector3<f64>>)>,
    /// Per-vertex scalars (name, one per vertex).
    pub point_scalars: Vec<(&'static str, Vec<f64>)>,
    /// Per-face scalars (name, one per face).
    pub cell_scalars: Vec<(&'static str, Vec<f64>)>,
    /// Per-face 3-vectors (name, one per face).
    pub cell_vectors: Vec<(&'static str, Vec<Vector3<f64>>)>,
    /// Why some fields could not be computed (the frame is written without them), if so.
    pub missing: Option<String>,
}

/// Computes the fields of a run's frames; built once per run (it keeps an elastic-energy
/// assembler between frames).
#[derive(Default)]
pub struct FieldEvaluator {
    /// Built at the first frame.
    elastic: Option<ElasticEval>,
}

impl FieldEvaluator {
    /// An evaluator with nothing built yet.
    pub fn new() -> FieldEvaluator {
        FieldEvaluator::default()
    }

    /// The fields of `sim`'s current state. A failure of the energy evaluation (the last good
    /// state after a failed step, say) is not fatal: the other fields are returned and
    /// [`FrameFields::missing`] says why the energy densities and the shell's fields are
    /// absent.
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
        let elastic = match self.elastic.take() {
            Some(e) => Ok(e),
            None => ElasticEval::new(sim),
        };
        let shell = match elastic {
            Ok(mut e) => {
                let values = e.evaluate(sim);
                self.elastic = Some(e);
                values
            }
            Err(e) => Err(e),
        };
        let shell = match shell {
            Ok(s) => Some(s),
            Err(e) => {
                fields.missing = Some(format!(
                    "{e}; written without energy densities, curvatures, strains, stress \
                     resultants and bending moments"
                ));
                None
            }
        };
        if let Some(s) = &shell {
            fields
                .cell_scalars
                .push(("stretch_density", s.stretch.clone()));
            fields.cell_scalars.push(("bend_density", s.bend.clone()));
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
        if let Some(c) = sim.system().contact() {
            fields
                .cell_scalars
                .push(("contact_gap", c.face_gaps(sim.positions())));
            fields
                .point_vectors
                .push(("contact_force", c.forces(sim.positions())));
        }
        if let Some(s) = shell {
            push_shell_fields(&mut fields, sim, &s.faces);
        }
        fields
    }
}

/// Appends the curvature, strain, stress-resultant and moment arrays of `faces`.
fn push_shell_fields(fields: &mut FrameFields, sim: &Simulation, faces: &[shell::FaceFields]) {
    let vertex = shell::vertex_curvatures(sim.mesh(), faces);
    let [d1, d2] = vertex.directions;
    fields.point_vectors.push(("curvature_direction_1", d1));
    fields.point_vectors.push(("curvature_direction_2", d2));
    fields.point_scalars.push(("mean_curvature", vertex.mean));
    fields
        .point_scalars
        .push(("gaussian_curvature", vertex.gaussian));
    let column = |f: fn(&shell::FaceFields) -> f64| faces.iter().map(f).collect::<Vec<f64>>();
    type Column = (&'static str, fn(&shell::FaceFields) -> f64);
    let cells: [Column; 10] = [
        ("principal_curvature_1", |f| f.curvatures[0]),
        ("principal_curvature_2", |f| f.curvatures[1]),
        ("face_mean_curvature", |f| f.mean_curvature()),
        ("face_gaussian_curvature", |f| f.gaussian_curvature()),
        ("membrane_strain_1", |f| f.strains[0]),
        ("membrane_strain_2", |f| f.strains[1]),
        ("stress_resultant_1", |f| f.stress_resultants[0]),
        ("stress_resultant_2", |f| f.stress_resultants[1]),
        ("bending_moment_1", |f| f.moments[0]),
        ("bending_moment_2", |f| f.moments[1]),
    ];
    for (name, f) in cells {
        fields.cell_scalars.push((name, column(f)));
    }
    for k in 0..2 {
        let name = ["face_curvature_direction_1", "face_curvature_direction_2"][k];
        fields
            .cell_vectors
            .push((name, faces.iter().map(|f| f.directions[k]).collect()));
    }
}

/// An elastic-energy assembler for one run (damping off), built once and evaluated at every
/// frame.
struct ElasticEval {
    assembler: Assembler,
    model: ShellModel,
}

/// The per-face shell quantities of one frame (face order).
#[derive(Clone, Debug, PartialEq)]
struct ShellValues {
    /// Stretching energy per unit rest area, J/m².
    stretch: Vec<f64>,
    /// Bending energy per unit rest area, J/m² (may be negative for a bilayer, see
    /// `docs/model.md`).
    bend: Vec<f64>,
    /// Curvatures, strains, resultants and moments.
    faces: Vec<shell::FaceFields>,
}

impl ElasticEval {
    /// An evaluator for `sim`'s mesh, material and bending form.
    fn new(sim: &Simulation) -> Result<ElasticEval, String> {
        let model = sim.model().elastic();
        let assembler = sim
            .system()
            .assembler_for(&model)
            .map_err(|e| format!("energy densities: {e}"))?;
        Ok(ElasticEval { assembler, model })
    }

    /// The values at `sim`'s current state (its edge angles: empty before the first solve,
    /// all 0 then, as the assembler reads them).
    fn evaluate(&mut self, sim: &Simulation) -> Result<ShellValues, String> {
        let rest = sim.system().rest();
        let (x, phi) = (sim.positions(), sim.edge_angles());
        let (_, energies) = self
            .assembler
            .elastic_face_energies(&self.model, x, phi, rest)
            .map_err(|e| format!("energy densities: {e}"))?;
        let n = rest.a_bar.len();
        let mut v = ShellValues {
            stretch: Vec::with_capacity(n),
            bend: Vec::with_capacity(n),
            faces: Vec::with_capacity(n),
        };
        for (f, (e, a)) in energies.iter().zip(&rest.a_bar).enumerate() {
            let area = 0.5 * a.determinant().max(0.0).sqrt();
            if !(area > 0.0 && area.is_finite()) {
                return Err(format!(
                    "energy densities: face {f} has rest area {area:e} m²"
                ));
            }
            v.stretch.push(e.stretch / area);
            v.bend.push(e.bend / area);
        }
        let forms = self
            .assembler
            .face_forms(&self.model, x, phi, rest)
            .map_err(|e| format!("face forms: {e}"))?;
        for (f, (face, forms)) in sim.mesh().faces().iter().zip(&forms).enumerate() {
            let (i, j, k) = (face[0].idx(), face[1].idx(), face[2].idx());
            let values = shell::face_fields(&(x[j] - x[i]), &(x[k] - x[i]), forms, &rest.a_bar[f])
                .filter(|v| {
                    v.curvatures
                        .iter()
                        .chain(&v.strains)
                        .chain(&v.stress_resultants)
                        .chain(&v.moments)
                        .all(|c| c.is_finite())
                })
                .ok_or_else(|| format!("face {f} is degenerate (no curvature or strain)"))?;
            v.faces.push(values);
        }
        Ok(v)
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
        let d = ElasticEval::new(&sim)?.evaluate(&sim)?;
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
