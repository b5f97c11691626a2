//! Scene → [`Simulation`]: each section of the scene built by its own module
//! (`crate::scene::{mesh, initial, material, bending, rest, boundary, loads, integrator, growth,
//! contact}`) into the Rust values of a [`SimulationBuilder`], which builds the simulation as for
//! a caller who gives those values directly.

use nalgebra::Vector3;
use thinshell_energy::{EnergyTerms, RestState, ShellModel, Terms};
use thinshell_mesh::Mesh;
use thinshell_solver::{ExplicitEuler, ImplicitEuler, NewtonSettings, SolverError, State};
use thinshell_system::{Boundary, ContactSettings, Loads, ShellIntegrator, ShellSystem};

use thinshell_growth::{Growth, GrowthModel, StimulusField, apply_growth};

use super::Simulation;
use crate::scene::growth::GrowthParts;
use crate::scene::initial::Start;
use crate::scene::integrator::run_loop_static;
use crate::scene::schema::{Effect, LoadRamp};
use crate::scene::{Problem, Scene, bending, boundary, contact, initial, integrator, loads, rest};

use super::error::BuildError;

/// A boundary that leaves nothing to simulate is an error (the solver's own checks of its
/// entries come first).
fn check_held(
    boundary: &Boundary,
    mesh: &Mesh,
    model: &ShellModel,
    origin: &str,
) -> Result<(), BuildError> {
    let second_row = !ShellSystem::has_edge_unknowns_for(model);
    let held = boundary
        .held_coordinates(mesh, second_row)
        .map_err(|source| BuildError::Solver {
            origin: origin.into(),
            source,
        })?;
    if held.len() >= 3 * mesh.n_vertices() {
        return Err(BuildError::Invalid {
            origin: origin.into(),
            key: "boundary".into(),
            message: "pins every coordinate: nothing is left to simulate".into(),
        });
    }
    Ok(())
}

/// The scene's mesh (OBJ file or generator), checked to be within f64's range.
fn scene_mesh(scene: &Scene) -> Result<Mesh, BuildError> {
    let s = &scene.file;
    let mesh_err = |source| match &s.mesh.obj {
        Some(path) => BuildError::MeshFile {
            origin: format!("{}: `mesh.obj`", scene.key_location("mesh.obj")),
            path: scene.base_dir.join(path),
            source,
        },
        None => BuildError::Mesh {
            origin: scene.origin.clone(),
            source,
        },
    };
    let mesh = crate::scene::mesh::build(&s.mesh, &scene.base_dir).map_err(mesh_err)?;
    // Mesh::new judges shape only; forms of faces too small or too large for f64 would be
    // inf/NaN and surface later as an obscure energy error.
    thinshell_mesh::check_scale(&mesh, mesh.positions()).map_err(mesh_err)?;
    Ok(mesh)
}

impl Simulation {
    /// Builds the simulation a scene describes. Only the requested energy terms are assembled;
    /// mass is computed only with `inertia`; loads only when their effect is on. Each section
    /// becomes a Rust value by its own module's `build` (mesh, start state, material, bending
    /// form, rest state, boundary, loads, schedule, growth, contact, integrator), in that order;
    /// the values then build the simulation through the same [`SimulationBuilder`] a caller
    /// who gives them directly uses.
    pub fn build(scene: &Scene) -> Result<Simulation, BuildError> {
        let s = &scene.file;
        let origin = scene.origin.as_str();
        let on = |e: Effect| s.effects.contains(&e);
        let energy_err = |source| BuildError::Energy {
            origin: origin.into(),
            source,
        };
        let invalid = |p: Problem| BuildError::Invalid {
            origin: origin.into(),
            key: p.key,
            message: p.message,
        };
        let solver_err = |source| BuildError::Solver {
            origin: origin.into(),
            source,
        };
        let mesh = scene_mesh(scene)?;
        let x_ref = mesh.positions().to_vec();
        let (x, v) = initial::build(&s.initial, &mesh, &x_ref).map_err(invalid)?;
        let model = ShellModel {
            material: crate::scene::material::build(&s.material).map_err(energy_err)?,
            terms: Terms {
                stretch: on(Effect::Stretching),
                bend: on(Effect::Bending),
                damping: on(Effect::Damping),
            },
            sff: bending::build(s.bending.as_ref()),
        };
        let boundary = boundary::build(&s.boundary, &mesh, &x_ref, &x).map_err(invalid)?;
        // Mirror edges enter the rest forms as they enter the energy (model.md §1.4).
        let mirrors = boundary.mirror_normals();
        let rest = match s.rest.from {
            rest::RestSource::File => {
                rest::read_file(&s.rest, &scene.base_dir, &mesh).map_err(invalid)?
            }
            _ => rest::build(&s.rest, &mesh, &x_ref, model.sff, &mirrors).map_err(energy_err)?,
        };
        check_held(&boundary, &mesh, &model, origin)?;
        let loads = loads::build(s.load_specs(), &on, mesh.n_vertices()).map_err(invalid)?;
        let schedule = integrator::schedule(&s.integrator, on(Effect::Growth));
        // Bad keys are rejected whatever the integrator, before anything else is built.
        integrator::newton(&s.integrator.newton, NewtonSettings::default()).map_err(solver_err)?;
        let growth = match s.growth.as_ref().filter(|_| on(Effect::Growth)) {
            Some(g) => {
                let thickness = model.material.thickness;
                let parts = crate::scene::growth::build(g, &mesh, &x_ref, &rest, thickness)
                    .map_err(|source| BuildError::Growth {
                        origin: origin.into(),
                        source,
                    })?;
                Some((parts, g.mass_uptake))
            }
            None => None,
        };
        let contact = match on(Effect::Contact) {
            true => Some(contact::build(s.contact.as_ref(), &scene.base_dir).map_err(invalid)?),
            false => None,
        };
        let mut builder = SimulationBuilder::new(mesh, model)
            .name(&scene.name())
            .rest(rest)
            .start(x, v)
            .boundary(boundary)
            .loads(loads)
            .steps(schedule.steps)
            .load_ramp(schedule.load_ramp);
        builder.origin = origin.into();
        builder.effects = Some(s.effects.clone());
        builder.dt = schedule.dt;
        builder.growth = growth;
        builder.contact = contact;
        builder.finish(
            |system| integrator::build(&s.integrator, system).map_err(solver_err),
            s.path.as_ref(),
        )
    }
}

/// A [`Simulation`] from Rust values instead of a scene file: the mesh and the shell model
/// (material, energy terms, bending form), then optionally the rest state (default: the mesh's
/// own shape, [`RestState::from_mesh`] with the model's form, so that the form is named once),
/// start positions and velocities (default: the mesh's positions, at rest), boundary
/// conditions, loads, growth, contact and the integrator (default: [`Static`](thinshell_solver::Static) with its default
/// settings). [`SimulationBuilder::build`] gives a simulation that steps exactly as one built
/// from a scene: continuation of large rest-form changes, static load ramps, growth with mass
/// uptake.
///
/// ```
/// use thinshell::prelude::*; // the types below, from `thinshell` alone
///
/// // A flat unit square whose rest metric is ā = [[2, 1], [1, 2]] in xy relaxes, in one static
/// // solve, to the rhombus with that metric: an edge along x grows by √2.
/// let mesh = generators::rectangle(1.0, 1.0, 4, 4)?;
/// let rest = RestState::from_planar(&mesh, Matrix2::new(2.0, 1.0, 1.0, 2.0), Matrix2::zeros())?;
/// let model = ShellModel {
///     material: Material::paper(),
///     terms: Terms::ELASTIC,
///     sff: SffKind::default(), // edge directors (tan), the scenes' default
/// };
/// let mut sim: Simulation = SimulationBuilder::new(mesh, model).rest(rest).build()?;
/// sim.step()?;
/// let x = sim.positions();
/// assert!(((x[1] - x[0]).norm() - 0.25 * 2f64.sqrt()).abs() < 1e-6);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct SimulationBuilder {
    name: String,
    origin: String,
    mesh: Mesh,
    model: ShellModel,
    rest: Option<RestState>,
    start: Option<Start>,
    boundary: Boundary,
    loads: Loads,
    /// Growth model, stimulus field and mass uptake.
    growth: Option<(GrowthParts, Option<f64>)>,
    contact: Option<ContactSettings>,
    integrator: Option<Box<ShellIntegrator>>,
    dt: f64,
    steps: usize,
    load_ramp: Option<LoadRamp>,
    /// A scene's effects list; derived from the values otherwise.
    effects: Option<Vec<Effect>>,
}

impl SimulationBuilder {
    /// A simulation of `mesh` with `model`: rest state from the mesh's own shape, start at
    /// rest in it, no boundary conditions or loads, one static step.
    pub fn new(mesh: Mesh, model: ShellModel) -> SimulationBuilder {
        SimulationBuilder {
            name: "simulation".into(),
            origin: "simulation".into(),
            mesh,
            model,
            rest: None,
            start: None,
            boundary: Boundary::default(),
            loads: Loads::default(),
            growth: None,
            contact: None,
            integrator: None,
            dt: 1.0,
            steps: 1,
            load_ramp: None,
            effects: None,
        }
    }

    /// The simulation's name (errors and `summary.json` name it).
    pub fn name(mut self, name: &str) -> Self {
        self.name = name.to_string();
        self.origin = name.to_string();
        self
    }

    /// The rest forms (ā, b̄ per face); default [`RestState::from_mesh`] of the mesh's positions
    /// with the model's bending form.
    pub fn rest(mut self, rest: RestState) -> Self {
        self.rest = Some(rest);
        self
    }

    /// Start positions (m) and velocities (m/s), one per vertex; default the mesh's positions,
    /// at rest. Clamped edges hold the directors of these start positions.
    pub fn start(mut self, positions: Vec<Vector3<f64>>, velocities: Vec<Vector3<f64>>) -> Self {
        self.start = Some((positions, velocities));
        self
    }

    /// Pins, clamps and prescribed motion.
    pub fn boundary(mut self, boundary: Boundary) -> Self {
        self.boundary = boundary;
        self
    }

    /// Gravity, point forces and pressure (scaled by the load factor of static ramps).
    pub fn loads(mut self, loads: Loads) -> Self {
        self.loads = loads;
        self
    }

    /// Growth: `model` driven by the stimulus `field`, starting from the rest state (before
    /// growth) and the material's thickness; `mass_uptake` (kg/m³ per unit stimulus) adds mass
    /// as the stimulus soaks in. The first step solves against the rest forms of the initial
    /// stimulus ([`Simulation::initial_energy_grown`]).
    pub fn growth(
        mut self,
        model: Box<dyn GrowthModel>,
        field: Box<dyn StimulusField>,
        mass_uptake: Option<f64>,
    ) -> Self {
        self.growth = Some(((model, field), mass_uptake));
        self
    }

    /// IPC contact (self contact and obstacles).
    pub fn contact(mut self, settings: ContactSettings) -> Self {
        self.contact = Some(settings);
        self
    }

    /// Static equilibrium solves with the solver's default settings (the default integrator);
    /// `dt` is 1 s of pseudo-time per step (growth fields and prescribed motion advance by it).
    pub fn static_solve(self) -> Self {
        self.integrator(run_loop_static(), 1.0)
    }

    /// Implicit Euler with time step `dt` (s) and the solver's default Newton settings.
    pub fn implicit(self, dt: f64) -> Self {
        self.integrator(ImplicitEuler::new(dt), dt)
    }

    /// Explicit Euler with time step `dt` (s).
    pub fn explicit(self, dt: f64) -> Self {
        self.integrator(ExplicitEuler { dt }, dt)
    }

    /// Any integrator with its own settings; `dt` (s) is the time a step advances the growth
    /// field and prescribed motion by, and must be the integrator's own step (static solves:
    /// the pseudo-time of a step, 1 s by convention).
    pub fn integrator(
        mut self,
        integrator: impl thinshell_solver::Integrator<ShellSystem> + Send + 'static,
        dt: f64,
    ) -> Self {
        self.integrator = Some(Box::new(integrator));
        self.dt = dt;
        self
    }

    /// Steps the simulation runs ([`Simulation::run`]); default 1.
    pub fn steps(mut self, steps: usize) -> Self {
        self.steps = steps;
        self
    }

    /// How a static simulation's loads grow over its steps; default [`LoadRamp::Linear`]
    /// without growth and [`LoadRamp::None`] with it (dynamic integrators always apply the
    /// full loads).
    pub fn load_ramp(mut self, ramp: LoadRamp) -> Self {
        self.load_ramp = Some(ramp);
        self
    }

    fn rest_or_default(&self) -> Result<RestState, BuildError> {
        match &self.rest {
            Some(r) => Ok(r.clone()),
            None => RestState::from_mesh(&self.mesh, self.mesh.positions(), self.model.sff)
                .map_err(|source| BuildError::Energy {
                    origin: self.origin.clone(),
                    source,
                }),
        }
    }

    /// Builds the simulation. Errors name the simulation ([`SimulationBuilder::name`]) and say
    /// what is wrong: a rest state or start of the wrong size, a boundary that holds every
    /// coordinate, bad growth, solver or contact settings.
    pub fn build(mut self) -> Result<Simulation, BuildError> {
        let integrator = self.integrator.take();
        let is_static = integrator.as_ref().is_none_or(|i| i.is_static());
        if self.load_ramp.is_none() && is_static {
            self.load_ramp = Some(if self.growth.is_some() {
                LoadRamp::None
            } else {
                LoadRamp::Linear
            });
        }
        check_held(&self.boundary, &self.mesh, &self.model, &self.origin)?;
        self.finish(
            move |_| Ok(integrator.unwrap_or_else(|| Box::new(run_loop_static()))),
            None,
        )
    }

    /// The effects these values switch on (what a scene would list).
    fn derived_effects(&self, is_static: bool) -> Vec<Effect> {
        // Order of `Effect`, as a scene lists them.
        let t = self.model.terms;
        let l = &self.loads;
        [
            (Effect::Stretching, t.stretch),
            (Effect::Bending, t.bend),
            (Effect::Inertia, !is_static),
            (Effect::Damping, t.damping),
            (Effect::Gravity, l.gravity != Vector3::zeros()),
            (Effect::Pressure, l.pressure != 0.0),
            (Effect::PointLoads, !l.point_forces.is_empty()),
            (Effect::Growth, self.growth.is_some()),
            (Effect::Contact, self.contact.is_some()),
        ]
        .into_iter()
        .filter_map(|(e, on)| on.then_some(e))
        .collect()
    }

    /// The common end of [`Simulation::build`] and [`SimulationBuilder::build`]: growth, the
    /// initial energies, the shell system, contact, the integrator (made once the system
    /// exists: its force scale may enter the Newton test) and path following.
    fn finish(
        self,
        integrator: impl FnOnce(&ShellSystem) -> Result<Box<ShellIntegrator>, BuildError>,
        path: Option<&crate::scene::path::PathSpec>,
    ) -> Result<Simulation, BuildError> {
        let origin = self.origin.clone();
        // What a scene would list (without knowing yet whether the integrator is dynamic).
        let effects = self
            .effects
            .clone()
            .ok_or_else(|| (self.derived_effects(true), self.derived_effects(false)));
        let energy_err = |source| BuildError::Energy {
            origin: origin.clone(),
            source,
        };
        let solver_err = |source| BuildError::Solver {
            origin: origin.clone(),
            source,
        };
        let rest = self.rest_or_default()?;
        let x_ref = self.mesh.positions().to_vec();
        let n = x_ref.len();
        let (x, v) = match self.start {
            Some((x, v)) => (x, v),
            None => (x_ref.clone(), vec![Vector3::zeros(); n]),
        };
        if x.len() != n || v.len() != n {
            return Err(BuildError::Invalid {
                origin,
                key: "start".into(),
                message: format!(
                    "has {} positions and {} velocities for a mesh of {n} vertices",
                    x.len(),
                    v.len()
                ),
            });
        }
        let thickness = self.model.material.thickness;
        let (growth, grown_rest) = match self.growth {
            Some(((model, field), uptake)) => {
                let grown = (|| {
                    let mut grown = rest.clone();
                    apply_growth(model.as_ref(), &rest, field.values(), thickness, &mut grown)?;
                    let growth = Growth::new(model, field, rest.clone(), thickness)?;
                    let growth = match uptake {
                        Some(rho) => growth.with_mass_uptake(rho)?,
                        None => growth,
                    };
                    Ok((growth, grown))
                })()
                .map_err(|source| BuildError::Growth {
                    origin: origin.clone(),
                    source,
                })?;
                (Some(grown.0), Some(grown.1))
            }
            None => (None, None),
        };
        let mut system = ShellSystem::new(self.mesh, self.model, rest, self.boundary, self.loads)
            .map_err(solver_err)?;
        if x != x_ref {
            // Clamps hold the directors of the start state (model.md §1.3).
            system.set_clamp_reference(&x).map_err(solver_err)?;
        }
        let (energy, energy_grown) =
            initial_energies(&mut system, &x, grown_rest).map_err(|e| match e {
                SolverError::Energy(source) => energy_err(source),
                source => solver_err(source),
            })?;
        if let Some(settings) = &self.contact {
            system.set_contact(settings, &x).map_err(solver_err)?;
        }
        let integrator = integrator(&system)?;
        let static_solve = integrator.is_static();
        let path = match path {
            Some(spec) => Some(super::path::build(spec, &mut system, &x, &origin)?),
            None => None,
        };
        let effects = match effects {
            Ok(e) => e,
            Err((static_effects, _)) if static_solve => static_effects,
            Err((_, dynamic_effects)) => dynamic_effects,
        };
        let mut state = State::at_rest(x);
        state.v = v;
        Ok(Simulation {
            name: self.name,
            effects,
            x_ref,
            system,
            state,
            integrator,
            dt: self.dt,
            steps_done: 0,
            steps_total: self.steps,
            energy,
            energy_grown,
            growth,
            load_ramp: if static_solve {
                self.load_ramp.unwrap_or(LoadRamp::Linear)
            } else {
                LoadRamp::None
            },
            // A static solve starts from the unloaded start state; dynamic loads act from t = 0.
            load_factor: if static_solve { 0.0 } else { 1.0 },
            path,
        })
    }
}

/// The elastic energies (J; stretching and bending, no damping) of the start positions `x`,
/// as [`ShellSystem::energy`] gives them: edge angles at their minimiser for `x`, clamps held;
/// with growth also against the `grown` rest forms (the system's rest forms are put back).
///
/// The angle relaxation factorises the angle block. When the memory budget refuses that factor
/// the energies are NaN (not evaluated) rather than a build error: the first step then meets
/// the run's own memory check, whose refusal names the mesh and the estimates, or runs by its
/// iterative fallback and reports its own energies.
fn initial_energies(
    system: &mut ShellSystem,
    x: &[Vector3<f64>],
    grown: Option<RestState>,
) -> Result<(EnergyTerms, Option<EnergyTerms>), SolverError> {
    let not_evaluated = EnergyTerms {
        stretch: f64::NAN,
        bend: f64::NAN,
        damping: 0.0,
    };
    let energy = match system.energy(x) {
        Ok(e) => e,
        Err(SolverError::InsufficientMemory { .. })
        | Err(SolverError::InsufficientMemoryForIterative { .. }) => {
            return Ok((not_evaluated, grown.map(|_| not_evaluated)));
        }
        Err(e) => return Err(e),
    };
    let energy_grown = match grown {
        Some(grown) => {
            let own = system.set_rest(grown)?;
            let e = system.energy(x);
            system.set_rest(own)?;
            Some(e?)
        }
        None => None,
    };
    Ok((energy, energy_grown))
}
