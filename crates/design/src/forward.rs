//! The forward problem: the static equilibrium of a shell at given rest forms, warm-started from
//! the previous one, and the two adjoint pieces at it. The one module of this crate that talks
//! to the solver (`thinshell_solver`): everything else sees [`Forward`] and [`Equilibrium`].

use nalgebra::Vector3;
use thinshell_energy::{RestState, ShellModel};
use thinshell_mesh::Mesh;
use thinshell_solver::{Integrator, State, Static};
use thinshell_system::ShellSystem;

use crate::DesignError;

/// A static equilibrium: positions (m), edge angles (rad, one per edge with edge unknowns) and
/// what the solve took.
#[derive(Clone, Debug, PartialEq)]
pub struct Equilibrium {
    /// Positions (m).
    pub x: Vec<Vector3<f64>>,
    /// Edge angles (rad; empty without edge unknowns).
    pub phi: Vec<f64>,
    /// Newton iterations of the solve (all continuation stages).
    pub iterations: usize,
}

/// The forward map rest forms → static equilibrium of one shell system (its boundary, loads and
/// contact as the forward solve has them; the masses, and so gravity, stay those the system was
/// built with), solved by Newton from the last equilibrium ([`Static`] without continuation),
/// falling back to [`Static`]'s step with rest-form continuation when that fails, then polished
/// by full Newton steps.
pub struct Forward {
    system: ShellSystem,
    statics: Static,
    direct: Static,
    polish: Static,
    state: State,
}

impl std::fmt::Debug for Forward {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Forward")
            .field("system", &self.system)
            .finish_non_exhaustive()
    }
}

impl Forward {
    /// The forward map of `system` (its rest forms are replaced at every solve) from the start
    /// positions `start` (m, one per vertex; held coordinates keep their values).
    pub fn new(system: ShellSystem, start: Vec<Vector3<f64>>) -> Result<Forward, DesignError> {
        if start.len() != system.mesh().n_vertices() {
            return Err(DesignError::Invalid(format!(
                "start has {} positions, the mesh {} vertices",
                start.len(),
                system.mesh().n_vertices()
            )));
        }
        let mut state = State::at_rest(start);
        state.phi = vec![0.0; system.n_edge_angles()];
        let mut polish = Static {
            continuation: false,
            ..Static::default()
        };
        polish.newton.line_search = false;
        polish.newton.watchdog = 0;
        polish.newton.max_iterations = 8;
        Ok(Forward {
            system,
            statics: Static::default(),
            direct: Static {
                continuation: false,
                ..Static::default()
            },
            polish,
            state,
        })
    }

    /// The mesh (its positions are the reference configuration).
    pub fn mesh(&self) -> &Mesh {
        self.system.mesh()
    }

    /// Material, terms and bending form.
    pub fn model(&self) -> &ShellModel {
        self.system.model()
    }

    /// The rest forms of the last solve (initially the system's).
    pub fn rest(&self) -> &RestState {
        self.system.rest()
    }

    /// The last equilibrium's positions (the start before the first solve).
    pub fn positions(&self) -> &[Vector3<f64>] {
        &self.state.x
    }

    /// Restarts the next solve from `x` (m) with edge angles 0 (e.g. after a failed solve).
    pub fn restart_from(&mut self, x: Vec<Vector3<f64>>) {
        self.state = State::at_rest(x);
        self.state.phi = vec![0.0; self.system.n_edge_angles()];
    }

    /// Starts the next solve from the equilibrium `eq` (e.g. of the nearest parameters seen).
    pub fn start_from(&mut self, eq: &Equilibrium) {
        self.state = State::at_rest(eq.x.clone());
        self.state.phi = eq.phi.clone();
    }

    /// The static equilibrium at rest forms `rest`, from the last equilibrium. A failed solve
    /// leaves the start unchanged.
    pub fn solve(&mut self, rest: &RestState) -> Result<Equilibrium, DesignError> {
        self.system.set_rest(rest.clone())?;
        // Newton from the warm start first (the branch of the previous equilibrium: J(p) stays
        // continuous along a line search); the robust step, with rest-form continuation and
        // its check for a lower-energy equilibrium, only when that fails.
        let mut state = self.state.clone();
        let (mut x, mut phi) = (state.x.clone(), state.phi.clone());
        let mut iterations = match self
            .direct
            .solve_with_angles(&mut self.system, &mut x, &mut phi)
        {
            Ok(r) => {
                state.x = x;
                state.phi = phi;
                r.iterations
            }
            Err(_) => {
                let report = self.statics.step(&mut self.system, &mut state)?;
                report.newton.as_ref().map_or(0, |n| n.iterations)
            }
        };
        let (mut x, mut phi) = (state.x.clone(), state.phi.clone());
        if let Ok(r) = self
            .polish
            .solve_with_angles(&mut self.system, &mut x, &mut phi)
        {
            iterations += r.iterations;
            state.x = x;
            state.phi = phi;
        }
        self.state = state;
        Ok(Equilibrium {
            x: self.state.x.clone(),
            phi: self.state.phi.clone(),
            iterations,
        })
    }

    /// The adjoint part of the gradient at `eq` (solved at the current rest forms): per face
    /// f, w_f = λᵀ ∂²E/∂x∂m̄_f with H λ = `dj_dx` (full coordinates: three per vertex, then one
    /// per edge with edge unknowns). dJ/dm̄_f = ∂J/∂m̄_f − w_f. Errors with
    /// [`DesignError::NotAMinimum`] when `eq` is not a strict minimum.
    pub fn adjoint(
        &mut self,
        eq: &Equilibrium,
        dj_dx: &[f64],
    ) -> Result<Vec<[f64; 6]>, DesignError> {
        let lambda = self
            .system
            .solve_adjoint(&mut self.statics, &eq.x, &eq.phi, dj_dx)?
            .ok_or(DesignError::NotAMinimum)?;
        Ok(self.system.rest_adjoint_product(&eq.x, &eq.phi, &lambda)?)
    }

    /// Length of the full coordinate vector (3 per vertex, then one per edge with edge
    /// unknowns).
    pub fn n_coordinates(&self) -> usize {
        3 * self.system.mesh().n_vertices() + self.system.n_edge_angles()
    }
}
