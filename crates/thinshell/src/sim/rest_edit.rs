//! Changing the rest shape of a built simulation between steps: the rest forms ā, b̄ of every
//! face directly, or the stimulus that a growth scene turns into rest forms. Also the energy of
//! every face, for energy maps. The Python package's `Simulation.set_rest_forms` /
//! `set_stimulus` / `face_energies` are these functions.

use nalgebra::Vector3;
use thinshell_energy::{EnergyError, EnergyTerms, EvalOutput, RestState, ShellModel, Terms};
use thinshell_growth::{FaceStimulus, GrowthError};
use thinshell_system::ShellSystem;

use super::Simulation;

/// Why the rest shape could not be changed; the simulation is unchanged then.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RestEditError {
    /// A stimulus was given to a scene without the `growth` effect.
    #[error(
        "the scene has no `growth` effect: there is no stimulus to set (set the rest forms instead)"
    )]
    NoGrowth,
    /// Rest forms of the wrong length, non-finite, not symmetric or ā not positive definite.
    #[error("rest forms: {0}")]
    Rest(#[from] EnergyError),
    /// A stimulus of the wrong length or non-finite.
    #[error("stimulus: {0}")]
    Growth(#[from] GrowthError),
    /// Rest forms the shell system refuses (computed with another bending form).
    #[error("rest forms: {0}")]
    System(#[from] thinshell_solver::SolverError),
    /// Positions or velocities of the wrong length, or a non-finite value.
    #[error("{what}: {message}")]
    State {
        /// `positions` or `velocities`.
        what: &'static str,
        /// What is wrong.
        message: String,
    },
}

impl Simulation {
    /// The rest forms the next step solves against: ā (m²) and b̄ (m) per face, in the face's
    /// barycentric basis (docs/architecture.md, conventions). With growth they are rewritten at
    /// the start of a step whose stimulus changed.
    pub fn rest(&self) -> &RestState {
        self.system.rest()
    }

    /// Replaces the rest forms of every face (ā in m², b̄ in m, one each per face). They are
    /// checked as [`RestState::validate`] does (length, finite, symmetric, ā positive definite);
    /// the energies ([`Simulation::energy`]) are re-evaluated at the current state against them.
    ///
    /// With growth, the growth's own rest forms are brought up to date first, so the new forms
    /// hold until the stimulus next changes (a time-dependent or diffusing stimulus changes every
    /// step; [`Simulation::set_stimulus`] is the way to drive those scenes).
    pub fn set_rest_forms(&mut self, rest: RestState) -> Result<(), RestEditError> {
        rest.validate(self.system.mesh())?;
        let (energy, _) = elastic_faces(&self.system, &rest, &self.state.x, &self.state.phi)?;
        if let Some(g) = &mut self.growth {
            let mut scratch = self.system.rest().clone();
            g.update_rest(&mut scratch)?;
        }
        self.system.set_rest(rest)?;
        self.energy = energy;
        Ok(())
    }

    /// Sets the stimulus of every face (m⁺ at the top surface, m⁻ at the bottom, in the unit of
    /// the scene's stimulus), held constant from now on: the scene's own stimulus field (time
    /// law, directed heat, diffusion) is replaced. The next step computes the rest forms (and
    /// masses, with mass uptake) from it. Errors without the `growth` effect, on a wrong length or
    /// a non-finite value.
    pub fn set_stimulus(&mut self, stimulus: Vec<FaceStimulus>) -> Result<(), RestEditError> {
        let g = self.growth.as_mut().ok_or(RestEditError::NoGrowth)?;
        g.set_stimulus(stimulus)?;
        Ok(())
    }

    /// Replaces the current positions (m, one per vertex, in mesh order); the energies
    /// ([`Simulation::energy`]) are re-evaluated there against the current rest forms. The next
    /// step starts from them; boundary conditions act on it as on any state (a pinned vertex
    /// moved here is held where it now is, a prescribed motion is applied from the next step).
    /// Errors on a wrong length or a non-finite value, leaving the simulation unchanged.
    pub fn set_positions(&mut self, x: Vec<Vector3<f64>>) -> Result<(), RestEditError> {
        check_vectors("positions", &x, self.system.mesh().n_vertices())?;
        let (energy, _) = elastic_faces(&self.system, self.system.rest(), &x, &self.state.phi)?;
        self.state.x = x;
        self.energy = energy;
        Ok(())
    }

    /// Replaces the current velocities (m/s, one per vertex); the next dynamic step starts
    /// from them (static solves ignore velocities). Errors on a wrong length or a non-finite
    /// value, leaving the simulation unchanged.
    pub fn set_velocities(&mut self, v: Vec<Vector3<f64>>) -> Result<(), RestEditError> {
        check_vectors("velocities", &v, self.system.mesh().n_vertices())?;
        self.state.v = v;
        Ok(())
    }

    /// The current stimulus per face (growth scenes; `None` otherwise).
    pub fn stimulus(&self) -> Option<&[FaceStimulus]> {
        self.growth.as_ref().map(|g| g.stimulus())
    }

    /// Energy terms (J) of every face at the current state against the current rest forms
    /// (stretch and bend; damping 0), in face order; they sum to the state's elastic energy.
    pub fn face_energies(&self) -> Result<Vec<EnergyTerms>, EnergyError> {
        let (_, faces) = elastic_faces(
            &self.system,
            self.system.rest(),
            &self.state.x,
            &self.state.phi,
        )?;
        Ok(faces)
    }
}

/// `n` finite vectors, else [`RestEditError::State`] naming the first bad entry.
fn check_vectors(what: &'static str, v: &[Vector3<f64>], n: usize) -> Result<(), RestEditError> {
    let bad = |message: String| RestEditError::State { what, message };
    if v.len() != n {
        return Err(bad(format!(
            "{} vectors given, the mesh has {n} vertices",
            v.len()
        )));
    }
    match v.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(i) => Err(bad(format!(
            "vertex {i} is not finite ({:?})",
            v[i].as_slice()
        ))),
        None => Ok(()),
    }
}

/// Stretching and bending energy (J) of `x` and edge angles `phi` (empty = all 0) against
/// `rest` with `system`'s mesh, model and clamps, in total and per face, without damping (which
/// needs a previous state).
fn elastic_faces(
    system: &ShellSystem,
    rest: &RestState,
    x: &[Vector3<f64>],
    phi: &[f64],
) -> Result<(EnergyTerms, Vec<EnergyTerms>), EnergyError> {
    let model = ShellModel {
        terms: Terms {
            damping: false,
            ..system.model().terms
        },
        ..*system.model()
    };
    let n_angles = if ShellSystem::has_edge_unknowns_for(&model) {
        system.mesh().n_edges()
    } else {
        0
    };
    let zeros;
    let phi = if phi.is_empty() {
        zeros = vec![0.0; n_angles];
        &zeros
    } else {
        phi
    };
    let mut assembler = system.assembler_for(&model)?;
    let total =
        assembler.evaluate_with_angles(&model, x, phi, rest, None, EvalOutput::default())?;
    Ok((total, assembler.face_energies().to_vec()))
}
