//! Scene → [`Simulation`]: mesh, start state, rest forms, pins, loads, energy terms.

use nalgebra::{Matrix2, Vector3};
use thinshell_energy::{
    DirectorVariant, EnergyError, HessianMode, RestState, SffKind, ShellModel, Terms,
};
use thinshell_mesh::{Mesh, VertexId};
use thinshell_solver::{
    Boundary, ContactSettings, ExplicitEuler, HessianPolicy, ImplicitEuler, Integrator, Loads,
    NewtonSettings, Obstacle, Prescribed, ShellSystem, State, Static,
};

use thinshell_growth::{Growth, GrowthModel, StimulusField, apply_growth};

use super::Simulation;
use crate::reference::{map_xy, wrap_cylinder};
use crate::scene::Scene;
use crate::scene::growth::GrowthParts;
use crate::scene::schema::{
    BendingForm, ContactSpec, Effect, FallbackSpec, HessianSpec, IntegratorKind, LoadRamp,
    ObstacleKind, RegionSpec, RestSource,
};

use super::error::BuildError;

fn m2(m: &[[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(m[0][0], m[0][1], m[1][0], m[1][1])
}

/// Vertices of the reference mesh inside a region.
fn region_vertices(
    origin: &str,
    key: &str,
    region: &RegionSpec,
    x: &[Vector3<f64>],
) -> Result<Vec<usize>, BuildError> {
    let inside: Vec<usize> = if let Some(list) = &region.vertices {
        if let Some(&bad) = list.iter().find(|&&i| i >= x.len()) {
            return Err(BuildError::Invalid {
                origin: origin.into(),
                key: format!("{key}.vertices"),
                message: format!("vertex {bad} out of range (the mesh has {})", x.len()),
            });
        }
        list.clone()
    } else {
        // The same geometric predicates as the growth crate's regions (half-space, ball, box).
        let r = crate::scene::region::build(region);
        (0..x.len()).filter(|&i| r.contains(&x[i])).collect()
    };
    if inside.is_empty() {
        return Err(BuildError::Invalid {
            origin: origin.into(),
            key: key.into(),
            message: "contains no vertex of the mesh".into(),
        });
    }
    Ok(inside)
}

// The scene's sections as Rust values, one phase each (what [`Simulation::build`] calls in
// order; the errors keep the scene's keys).

/// The scene's mesh (OBJ file or generator), checked to be within f64's range.
fn scene_mesh(scene: &Scene) -> Result<Mesh, BuildError> {
    let s = &scene.file;
    let mesh_err = |source| match &s.mesh.obj {
        Some(path) => BuildError::MeshFile {
            origin: scene.origin.clone(),
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

/// `[initial]`: start positions and velocities.
type Start = (Vec<Vector3<f64>>, Vec<Vector3<f64>>);
fn start_state(scene: &Scene, mesh: &Mesh, x_ref: &[Vector3<f64>]) -> Result<Start, BuildError> {
    let init = &scene.file.initial;
    let mut x = x_ref.to_vec();
    if let Some(m) = &init.linear_xy {
        x = map_xy(&x, &m2(m));
    }
    if let Some(k) = init.scale {
        x.iter_mut().for_each(|p| *p *= k);
    }
    if let Some(w) = &init.wrap_cylinder {
        x = wrap_cylinder(&x, w.radius, w.center_x.unwrap_or(0.5));
    }
    thinshell_mesh::check_scale(mesh, &x).map_err(|e| BuildError::Invalid {
        origin: scene.origin.clone(),
        key: "initial".into(),
        message: format!("maps the mesh out of range: {e}"),
    })?;
    let v0 = init
        .velocity
        .map_or(Vector3::zeros(), |v| Vector3::new(v[0], v[1], v[2]));
    Ok((x, vec![v0; x_ref.len()]))
}

/// `[bending] form` as the energy crate's form.
fn sff_of(form: BendingForm) -> SffKind {
    match form {
        BendingForm::MidEdgeAverage => SffKind::MidEdgeAverage,
        BendingForm::EdgeDirectorSin => SffKind::EdgeDirector(DirectorVariant::Sin),
        BendingForm::EdgeDirectorTan => SffKind::EdgeDirector(DirectorVariant::Tan),
    }
}

/// `[boundary]`: pins, clamps and prescribed motion (from the start positions `x`).
fn boundary_of(
    scene: &Scene,
    mesh: &Mesh,
    x_ref: &[Vector3<f64>],
    x: &[Vector3<f64>],
) -> Result<Boundary, BuildError> {
    let s = &scene.file;
    let origin = &scene.origin;
    let mut boundary = Boundary::default();
    for (i, pin) in s.boundary.pins.iter().enumerate() {
        let key = format!("boundary.pins[{i}].region");
        let axes: Vec<usize> = pin
            .axes
            .as_deref()
            .unwrap_or("xyz")
            .chars()
            .filter_map(|c| "xyz".find(c))
            .collect();
        for vtx in region_vertices(origin, &key, &pin.region, x_ref)? {
            boundary
                .pinned_coordinates
                .extend(axes.iter().map(|&a| (VertexId::new(vtx), a)));
        }
    }
    for (i, clamp) in s.boundary.clamps.iter().enumerate() {
        let key = format!("boundary.clamps[{i}].region");
        let inside = region_vertices(origin, &key, &clamp.region, x_ref)?;
        let mut mark = vec![false; x_ref.len()];
        inside.iter().for_each(|&i| mark[i] = true);
        let topo = mesh.topology();
        let before = boundary.clamped_edges.len();
        for &e in topo.boundary_edges() {
            let [a, b] = topo.edge(e).vertices;
            if mark[a.idx()] && mark[b.idx()] {
                boundary.clamped_edges.push(e);
            }
        }
        if boundary.clamped_edges.len() == before {
            return Err(BuildError::Invalid {
                origin: origin.clone(),
                key,
                message: "contains no boundary edge of the mesh".into(),
            });
        }
    }
    for (i, p) in s.boundary.prescribed.iter().enumerate() {
        let key = format!("boundary.prescribed[{i}].region");
        let vel = Vector3::new(p.velocity[0], p.velocity[1], p.velocity[2]);
        for vtx in region_vertices(origin, &key, &p.region, x_ref)? {
            let x0 = x[vtx];
            boundary.prescribed.push(Prescribed {
                vertex: VertexId::new(vtx),
                position: Box::new(move |t| x0 + vel * t),
            });
        }
    }
    Ok(boundary)
}

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

/// The loads of the effects switched on (`[gravity]`, `[pressure]`, `[[point_loads]]`).
fn loads_of(scene: &Scene, n: usize) -> Result<Loads, BuildError> {
    let s = &scene.file;
    let on = |e: Effect| s.effects.contains(&e);
    let mut loads = Loads::default();
    if on(Effect::Gravity) {
        let g = s
            .gravity
            .as_ref()
            .map_or([0.0, 0.0, -9.81], |g| g.acceleration);
        loads.gravity = Vector3::new(g[0], g[1], g[2]);
    }
    if let Some(p) = s.pressure.as_ref().filter(|_| on(Effect::Pressure)) {
        loads.pressure = p.value;
        // Checked finite and nonzero by the scene's validation.
        loads.pressure_axis = p.axis.map(|a| Vector3::new(a[0], a[1], a[2]));
    }
    if on(Effect::PointLoads) {
        for (i, p) in s.point_loads.iter().enumerate() {
            if p.vertex >= n {
                return Err(BuildError::Invalid {
                    origin: scene.origin.clone(),
                    key: format!("point_loads[{i}].vertex"),
                    message: format!("vertex {} out of range (the mesh has {n})", p.vertex),
                });
            }
            loads.point_forces.push((
                VertexId::new(p.vertex),
                Vector3::new(p.force[0], p.force[1], p.force[2]),
            ));
        }
    }
    Ok(loads)
}

/// `[integrator.newton] hessian`: the Hessian the system assembles and Newton's policy.
fn hessian_of(spec: HessianSpec) -> (HessianMode, HessianPolicy) {
    match spec {
        HessianSpec::Adaptive => (HessianMode::Exact, HessianPolicy::Adaptive),
        HessianSpec::AdaptivePsd => (HessianMode::Exact, HessianPolicy::AdaptivePsd),
        HessianSpec::Exact => (HessianMode::Exact, HessianPolicy::Fixed),
        HessianSpec::GaussNewton => (HessianMode::GaussNewton, HessianPolicy::Fixed),
        HessianSpec::Projected => (HessianMode::ProjectedPsd, HessianPolicy::Fixed),
    }
}

/// `[integrator.newton]`: the scene's keys override `defaults` (the chosen integrator's own).
fn newton_of(scene: &Scene, defaults: NewtonSettings) -> Result<NewtonSettings, BuildError> {
    let nw = &scene.file.integrator.newton;
    let mut settings = defaults;
    if let Some(v) = nw.tolerance {
        settings.gradient_tolerance = v;
    }
    if let Some(v) = nw.step_tolerance {
        settings.step_tolerance = v;
    }
    if let Some(v) = nw.max_iterations {
        settings.max_iterations = v;
    }
    if let Some(v) = nw.line_search {
        settings.line_search = v;
    }
    if let Some(v) = nw.watchdog {
        settings.watchdog = v;
    }
    if let Some(v) = nw.escape_saddles {
        settings.escape_saddles = v;
    }
    if nw.regularization == Some(false) {
        settings.regularization = None;
    }
    if let Some(v) = nw.force_iterative {
        settings.force_iterative = v;
    }
    if let Some(v) = nw.reuse_factor {
        settings.reuse_factor = v;
    }
    if let Some(v) = nw.fallback {
        settings.fallback = match v {
            FallbackSpec::Ic0 => thinshell_solver::IterativeFallback::Ic0,
            FallbackSpec::Jacobi => thinshell_solver::IterativeFallback::Jacobi,
            FallbackSpec::Off => thinshell_solver::IterativeFallback::Off,
        };
    }
    (settings.own_hessian, settings.hessian) = hessian_of(nw.hessian);
    settings.validate().map_err(|source| BuildError::Solver {
        origin: scene.origin.clone(),
        source,
    })?;
    Ok(settings)
}

/// `[integrator]`: the integrator with the scene's settings over its own defaults, for the
/// built `system` (an explicit Newton `tolerance` is relative to its force scale).
fn integrator_of(
    scene: &Scene,
    system: &ShellSystem,
) -> Result<Box<dyn Integrator + Send>, BuildError> {
    let it = &scene.file.integrator;
    let dt = it.dt.unwrap_or(1.0);
    // Convergence is the solver's scale-free test (Newton correction, round-off); an
    // explicit `tolerance` adds the gradient test against the system's one force scale.
    let force_scale = it.newton.tolerance.map(|_| system.force_scale());
    // A failed exact or adaptive solve is retried with the Gauss–Newton Hessian
    // (docs/robustness.md), a safety net the adaptive Newton rarely needs.
    let with_fallback = |mut newton: NewtonSettings, on: bool| {
        newton.fallback_hessian =
            (on && newton.own_hessian == HessianMode::Exact).then_some(HessianMode::GaussNewton);
        newton
    };
    Ok(match it.kind {
        IntegratorKind::Static => {
            let defaults = run_loop_static();
            Box::new(Static {
                newton: with_fallback(newton_of(scene, defaults.newton)?, true),
                force_scale,
                ..defaults
            })
        }
        IntegratorKind::Implicit => {
            let defaults = ImplicitEuler::new(dt);
            Box::new(ImplicitEuler {
                // With `adaptive_dt`, before halving Δt.
                newton: with_fallback(newton_of(scene, defaults.newton)?, it.adaptive_dt),
                force_scale,
                max_halvings: if it.adaptive_dt { 8 } else { 0 },
                ..defaults
            })
        }
        IntegratorKind::Explicit => Box::new(ExplicitEuler { dt }),
    })
}

impl Simulation {
    /// Builds the simulation a scene describes. Only the requested energy terms are assembled;
    /// mass is computed only with `inertia`; loads only when their effect is on. The scene's
    /// sections become the Rust values of a [`SimulationBuilder`] phase by phase (mesh, start
    /// state, model and rest state, boundary, loads, schedule, Newton settings, growth), which
    /// then builds the simulation exactly as for a caller who gives those values directly.
    pub fn build(scene: &Scene) -> Result<Simulation, BuildError> {
        let s = &scene.file;
        let origin = scene.origin.clone();
        let on = |e: Effect| s.effects.contains(&e);
        let energy_err = |source| BuildError::Energy {
            origin: origin.clone(),
            source,
        };
        let mesh = scene_mesh(scene)?;
        let x_ref = mesh.positions().to_vec();
        let (x, v) = start_state(scene, &mesh, &x_ref)?;
        let material = crate::scene::material::build(&s.material).map_err(energy_err)?;
        let model = ShellModel {
            material,
            terms: Terms {
                stretch: on(Effect::Stretching),
                bend: on(Effect::Bending),
                damping: on(Effect::Damping),
            },
            sff: sff_of(s.bending.as_ref().map(|b| b.form).unwrap_or_default()),
        };
        let rest = match s.rest.from {
            RestSource::Mesh => RestState::from_mesh(&mesh, &x_ref, model.sff),
            RestSource::Planar => {
                let a = s.rest.a_xy.as_ref().map_or(Matrix2::identity(), m2);
                let b = s.rest.b_xy.as_ref().map_or(Matrix2::zeros(), m2);
                RestState::from_planar(&mesh, a, b)
            }
        }
        .map_err(energy_err)?;
        let boundary = boundary_of(scene, &mesh, &x_ref, &x)?;
        check_held(&boundary, &mesh, &model, &origin)?;
        let loads = loads_of(scene, mesh.n_vertices())?;
        let it = &s.integrator;
        let dt = it.dt.unwrap_or(1.0);
        let steps = match (it.steps, it.end_time) {
            (Some(k), _) => k,
            (None, Some(t)) => (t / dt).ceil().max(1.0) as usize,
            (None, None) => 1,
        };
        let static_solve = it.kind == IntegratorKind::Static;
        // A static scene without growth has no other use for several steps than a load path;
        // with growth the steps are the growth's pseudo-time, and every intermediate state must
        // feel the full loads (docs/scenes.md).
        let load_ramp = match (static_solve, it.load_ramp) {
            (false, _) => LoadRamp::None,
            (true, Some(r)) => r,
            (true, None) if on(Effect::Growth) => LoadRamp::None,
            (true, None) => LoadRamp::Linear,
        };
        // Bad keys are rejected whatever the integrator, before anything else is built.
        newton_of(scene, NewtonSettings::default())?;
        let mut builder = SimulationBuilder::new(mesh, model)
            .name(&scene.name())
            .rest(rest)
            .start(x, v)
            .boundary(boundary)
            .loads(loads)
            .steps(steps)
            .load_ramp(load_ramp);
        builder.origin = origin.clone();
        builder.effects = Some(s.effects.clone());
        builder.dt = dt;
        if let Some(g) = s.growth.as_ref().filter(|_| on(Effect::Growth)) {
            let parts = crate::scene::growth::build(
                g,
                &builder.mesh,
                &x_ref,
                &builder.rest_or_default()?,
                builder.model.material.thickness,
            )
            .map_err(|source| BuildError::Growth {
                origin: origin.clone(),
                source,
            })?;
            builder = builder.growth(parts.0, parts.1, g.mass_uptake);
        }
        if on(Effect::Contact) {
            let settings = contact_settings(s.contact.as_ref(), &scene.base_dir).map_err(
                |(key, message)| BuildError::Invalid {
                    origin: origin.clone(),
                    key,
                    message,
                },
            )?;
            builder = builder.contact(settings);
        }
        builder.finish(|system| integrator_of(scene, system), s.path.as_ref())
    }
}

/// A [`Simulation`] from Rust values instead of a scene file: the mesh and the shell model
/// (material, energy terms, bending form), then optionally the rest state (default: the mesh's
/// own shape, [`RestState::from_mesh`] with the model's form, so that the form is named once),
/// start positions and velocities (default: the mesh's positions, at rest), boundary
/// conditions, loads, growth, contact and the integrator (default: [`Static`] with its default
/// settings). [`SimulationBuilder::build`] gives a simulation that steps exactly as one built
/// from a scene: continuation of large rest-form changes, static load ramps, growth with mass
/// uptake.
///
/// ```
/// use nalgebra::Matrix2;
/// use thinshell::{Simulation, SimulationBuilder};
/// use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
/// use thinshell_mesh::generators;
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
    integrator: Option<Box<dyn Integrator + Send>>,
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
    pub fn integrator(mut self, integrator: impl Integrator + Send + 'static, dt: f64) -> Self {
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
        integrator: impl FnOnce(&ShellSystem) -> Result<Box<dyn Integrator + Send>, BuildError>,
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
        let energy = elastic_energy(&self.mesh, &self.model, &rest, &x).map_err(energy_err)?;
        let energy_grown = match &grown_rest {
            Some(r) => Some(elastic_energy(&self.mesh, &self.model, r, &x).map_err(energy_err)?),
            None => None,
        };
        let mut system = ShellSystem::new(self.mesh, self.model, rest, self.boundary, self.loads)
            .map_err(solver_err)?;
        if x != x_ref {
            // Clamps hold the directors of the start state (model.md §1.3).
            system.set_clamp_reference(&x).map_err(solver_err)?;
        }
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

/// The solver's contact settings of a `[contact]` section (all defaults without one);
/// validation guarantees each obstacle has its keys. Mesh obstacles are read from their OBJ
/// files (paths relative to `base_dir`, the scene file's directory); an unreadable or invalid
/// file is an error `(key, message)`.
fn contact_settings(
    spec: Option<&ContactSpec>,
    base_dir: &std::path::Path,
) -> Result<ContactSettings, (String, String)> {
    let Some(c) = spec else {
        return Ok(ContactSettings::default());
    };
    let obstacles = c
        .obstacles
        .iter()
        .enumerate()
        .map(|(i, o)| {
            Ok(match o.kind {
                ObstacleKind::Plane => Obstacle::Plane {
                    point: v3(&o.point.unwrap_or_default()),
                    normal: v3(&o.normal.unwrap_or([0.0, 0.0, 1.0])),
                },
                ObstacleKind::Sphere => Obstacle::Sphere {
                    center: v3(&o.center.unwrap_or_default()),
                    radius: o.radius.unwrap_or(1.0),
                },
                ObstacleKind::Box => Obstacle::Box {
                    min: v3(&o.min.unwrap_or_default()),
                    max: v3(&o.max.unwrap_or([1.0; 3])),
                },
                ObstacleKind::Mesh => {
                    let path = base_dir.join(o.path.as_deref().unwrap_or_default());
                    Obstacle::mesh_from_obj(&path)
                        .map_err(|e| (format!("contact.obstacles[{i}].path"), e))?
                }
            })
        })
        .collect::<Result<Vec<_>, (String, String)>>()?;
    Ok(ContactSettings {
        obstacles,
        self_contact: c.self_contact,
        distance: c.distance,
        stiffness: c.stiffness,
        thickness_offset: c.thickness_offset,
    })
}

fn v3(a: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// Stretching and bending energy of `x` (J), without the damping term (which needs a previous
/// state): used to report the initial state.
fn elastic_energy(
    mesh: &Mesh,
    model: &ShellModel,
    rest: &RestState,
    x: &[Vector3<f64>],
) -> Result<thinshell_energy::EnergyTerms, EnergyError> {
    let terms = Terms {
        damping: false,
        ..model.terms
    };
    let model = ShellModel { terms, ..*model };
    // Edge-director angles start at 0.
    let n_angles = if ShellSystem::has_edge_unknowns_for(&model) {
        mesh.n_edges()
    } else {
        0
    };
    let dofs = thinshell_energy::DofMap::all_free(mesh.n_vertices()).with_edges(n_angles, [])?;
    let mut assembler = thinshell_energy::Assembler::for_model(mesh, &dofs, &model)?;
    assembler.evaluate_with_angles(
        &model,
        x,
        &vec![0.0; n_angles],
        rest,
        None,
        thinshell_energy::EvalOutput {
            gradient: None,
            hessian: None,
        },
    )
}

/// The static solver of a run loop: the solver's defaults without its own rest-state
/// continuation, because `Simulation::step` continues a failed step from the previous step's
/// rest forms and load factor, a better origin than the start's own forms.
fn run_loop_static() -> Static {
    Static {
        continuation: false,
        ..Static::default()
    }
}
