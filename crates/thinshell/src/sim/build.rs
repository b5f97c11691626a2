//! Scene → [`Simulation`]: mesh, start state, rest forms, pins, loads, energy terms.

use nalgebra::{Matrix2, Vector3};
use thinshell_energy::{
    DirectorVariant, EnergyError, HessianMode, Layer, Material, MaterialModel, RestState, SffKind,
    ShellModel, Terms,
};
use thinshell_mesh::generators::Generator;
use thinshell_mesh::{Mesh, MeshError, VertexId, io};
use thinshell_solver::{
    Boundary, ContactSettings, ExplicitEuler, HessianPolicy, ImplicitEuler, Integrator, Loads,
    NewtonSettings, Obstacle, Prescribed, ShellSystem, SolverError, State, Static,
};

use thinshell_growth::{
    Anisotropy, Diffusion, DiffusionSettings, DiffusionSource, DirectedHeat, FaceStimulus, Growth,
    GrowthError, GrowthModel, Isotropic, Prescribed as PrescribedStimulus, Region, SourceKind,
    StimulusField, Surface, Swelling, apply_growth,
};

use super::Simulation;
use crate::reference::{map_xy, wrap_cylinder};
use crate::scene::Scene;
use crate::scene::schema::{
    BendingForm, ContactSpec, Effect, FallbackSpec, GrowthModelKind, GrowthSpec, HessianSpec,
    IntegratorKind, LayerSpec, LoadRamp, MaterialModelName, MaterialSpec, MeshSpec, ObstacleKind,
    RegionSpec, RestSource, StimulusKind, Surface as SceneSurface,
};

/// Why a scene could not be turned into a simulation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BuildError {
    /// The mesh could not be loaded or generated.
    #[error("{origin}: mesh: {source}")]
    Mesh {
        /// The scene.
        origin: String,
        /// Why.
        source: MeshError,
    },
    /// The scene's OBJ file could not be read or is not a valid mesh.
    #[error("{origin}: mesh file {}: {source}", .path.display())]
    MeshFile {
        /// The scene.
        origin: String,
        /// The OBJ file, resolved against the scene's directory.
        path: std::path::PathBuf,
        /// Why.
        source: MeshError,
    },
    /// Rest state, material or assembly set-up failed.
    #[error("{origin}: {source}")]
    Energy {
        /// The scene.
        origin: String,
        /// Why.
        source: EnergyError,
    },
    /// Growth model or stimulus set-up failed.
    #[error("{origin}: growth: {source}")]
    Growth {
        /// The scene.
        origin: String,
        /// Why.
        source: GrowthError,
    },
    /// Solver settings rejected.
    #[error("{origin}: solver: {source}")]
    Solver {
        /// The scene.
        origin: String,
        /// Why.
        source: SolverError,
    },
    /// A value that only the built mesh can check (a vertex index out of range, no free
    /// unknowns, …), or an effect this version cannot simulate yet.
    #[error("{origin}: `{key}` {message}")]
    Invalid {
        /// The scene.
        origin: String,
        /// Dotted key.
        key: String,
        /// What is wrong.
        message: String,
    },
}

fn m2(m: &[[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(m[0][0], m[0][1], m[1][0], m[1][1])
}

fn make_mesh(scene: &Scene, spec: &MeshSpec) -> Result<Mesh, MeshError> {
    if let Some(path) = &spec.obj {
        return io::load_obj(scene.base_dir.join(path));
    }
    let generator = spec.generator.as_deref().and_then(Generator::from_name);
    // Unknown names are rejected by scene validation already.
    let Some(generator) = generator else {
        return Err(MeshError::InvalidParameter {
            name: "generator",
            value: f64::NAN,
            reason: "unknown generator",
        });
    };
    let given = spec.given();
    generator.build(|key| given.iter().find(|(k, _)| *k == key).map(|&(_, v)| v))
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
        let r = region_of(region);
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

impl Simulation {
    /// Builds the simulation a scene describes. Only the requested energy terms are assembled;
    /// mass is computed only with `inertia`; loads only when their effect is on.
    pub fn build(scene: &Scene) -> Result<Simulation, BuildError> {
        let s = &scene.file;
        let origin = scene.origin.clone();
        let on = |e: Effect| s.effects.contains(&e);
        let invalid = |key: &str, message: String| BuildError::Invalid {
            origin: origin.clone(),
            key: key.into(),
            message,
        };
        let energy_err = |source| BuildError::Energy {
            origin: origin.clone(),
            source,
        };
        let solver_err = |source| BuildError::Solver {
            origin: origin.clone(),
            source,
        };
        let mesh_err = |source| match &s.mesh.obj {
            Some(path) => BuildError::MeshFile {
                origin: origin.clone(),
                path: scene.base_dir.join(path),
                source,
            },
            None => BuildError::Mesh {
                origin: origin.clone(),
                source,
            },
        };
        let mesh = make_mesh(scene, &s.mesh).map_err(mesh_err)?;
        // Mesh::new judges shape only; forms of faces too small or too large for f64 would be
        // inf/NaN and surface later as an obscure energy error.
        thinshell_mesh::check_scale(&mesh, mesh.positions()).map_err(mesh_err)?;
        let n = mesh.n_vertices();
        let x_ref = mesh.positions().to_vec();

        // Start state.
        let mut x = x_ref.clone();
        if let Some(m) = &s.initial.linear_xy {
            x = map_xy(&x, &m2(m));
        }
        if let Some(k) = s.initial.scale {
            x.iter_mut().for_each(|p| *p *= k);
        }
        if let Some(w) = &s.initial.wrap_cylinder {
            x = wrap_cylinder(&x, w.radius, w.center_x.unwrap_or(0.5));
        }
        thinshell_mesh::check_scale(&mesh, &x)
            .map_err(|e| invalid("initial", format!("maps the mesh out of range: {e}")))?;
        let v0 = s
            .initial
            .velocity
            .map_or(Vector3::zeros(), |v| Vector3::new(v[0], v[1], v[2]));
        let v = vec![v0; n];

        let material = material_of(&s.material).map_err(energy_err)?;
        let terms = Terms {
            stretch: on(Effect::Stretching),
            bend: on(Effect::Bending),
            damping: on(Effect::Damping),
        };
        let sff = match s.bending.as_ref().map(|b| b.form).unwrap_or_default() {
            BendingForm::MidEdgeAverage => SffKind::MidEdgeAverage,
            BendingForm::EdgeDirectorSin => SffKind::EdgeDirector(DirectorVariant::Sin),
            BendingForm::EdgeDirectorTan => SffKind::EdgeDirector(DirectorVariant::Tan),
        };
        let model = ShellModel {
            material,
            terms,
            sff,
        };
        let rest = match s.rest.from {
            RestSource::Mesh => RestState::from_mesh(&mesh, &x_ref, sff),
            RestSource::Planar => {
                let a = s.rest.a_xy.as_ref().map_or(Matrix2::identity(), m2);
                let b = s.rest.b_xy.as_ref().map_or(Matrix2::zeros(), m2);
                RestState::from_planar(&mesh, a, b)
            }
        }
        .map_err(energy_err)?;

        // Boundary conditions.
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
            for vtx in region_vertices(&origin, &key, &pin.region, &x_ref)? {
                boundary
                    .pinned_coordinates
                    .extend(axes.iter().map(|&a| (VertexId::new(vtx), a)));
            }
        }
        for (i, clamp) in s.boundary.clamps.iter().enumerate() {
            let key = format!("boundary.clamps[{i}].region");
            let inside = region_vertices(&origin, &key, &clamp.region, &x_ref)?;
            let mut mark = vec![false; n];
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
                return Err(invalid(
                    &key,
                    "contains no boundary edge of the mesh".into(),
                ));
            }
        }
        for (i, p) in s.boundary.prescribed.iter().enumerate() {
            let key = format!("boundary.prescribed[{i}].region");
            let vel = Vector3::new(p.velocity[0], p.velocity[1], p.velocity[2]);
            for vtx in region_vertices(&origin, &key, &p.region, &x_ref)? {
                let x0 = x[vtx];
                boundary.prescribed.push(Prescribed {
                    vertex: VertexId::new(vtx),
                    position: Box::new(move |t| x0 + vel * t),
                });
            }
        }
        let second_row = !ShellSystem::has_edge_unknowns_for(&model);
        let held = boundary
            .held_coordinates(&mesh, second_row)
            .map_err(solver_err)?;
        if held.len() >= 3 * n {
            return Err(invalid(
                "boundary",
                "pins every coordinate: nothing is left to simulate".into(),
            ));
        }

        // Loads, only for the effects switched on.
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
        }
        if on(Effect::PointLoads) {
            for (i, p) in s.point_loads.iter().enumerate() {
                if p.vertex >= n {
                    return Err(invalid(
                        &format!("point_loads[{i}].vertex"),
                        format!("vertex {} out of range (the mesh has {n})", p.vertex),
                    ));
                }
                loads.point_forces.push((
                    VertexId::new(p.vertex),
                    Vector3::new(p.force[0], p.force[1], p.force[2]),
                ));
            }
        }

        // Integrator.
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
        // The scene's Newton keys override the solver's defaults of the chosen integrator.
        let nw = &it.newton;
        let (hessian_mode, policy) = match nw.hessian {
            HessianSpec::Adaptive => (HessianMode::Exact, HessianPolicy::Adaptive),
            HessianSpec::AdaptivePsd => (HessianMode::Exact, HessianPolicy::AdaptivePsd),
            HessianSpec::Exact => (HessianMode::Exact, HessianPolicy::Fixed),
            HessianSpec::GaussNewton => (HessianMode::GaussNewton, HessianPolicy::Fixed),
            HessianSpec::Projected => (HessianMode::ProjectedPsd, HessianPolicy::Fixed),
        };
        let newton = |defaults: NewtonSettings| -> Result<NewtonSettings, BuildError> {
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
            settings.hessian = policy;
            settings.validate().map_err(|source| BuildError::Solver {
                origin: origin.clone(),
                source,
            })?;
            Ok(settings)
        };
        // Bad keys are rejected whatever the integrator, before anything else is built.
        newton(NewtonSettings::default())?;

        let (growth, grown_rest) = match s.growth.as_ref().filter(|_| on(Effect::Growth)) {
            Some(g) => {
                let (growth, grown) = build_growth(g, &mesh, &x_ref, &rest, material.thickness)
                    .map_err(|source| BuildError::Growth {
                        origin: origin.clone(),
                        source,
                    })?;
                (Some(growth), Some(grown))
            }
            None => (None, None),
        };
        let energy = elastic_energy(&mesh, &model, &rest, &x).map_err(energy_err)?;
        let energy_grown = match &grown_rest {
            Some(r) => Some(elastic_energy(&mesh, &model, r, &x).map_err(energy_err)?),
            None => None,
        };
        let mut system =
            ShellSystem::new(mesh, model, rest, boundary, loads).map_err(solver_err)?;
        if x != x_ref {
            // Clamps hold the directors of the start state (model.md §1.3).
            system.set_clamp_reference(&x).map_err(solver_err)?;
        }
        system.hessian_mode = hessian_mode;
        if on(Effect::Contact) {
            let settings = contact_settings(s.contact.as_ref(), &scene.base_dir)
                .map_err(|(key, message)| invalid(&key, message))?;
            system.set_contact(&settings, &x).map_err(solver_err)?;
        }
        // Convergence is the solver's scale-free test (Newton correction, round-off); an
        // explicit `tolerance` adds the gradient test against the system's one force scale.
        let force_scale = nw.tolerance.map(|_| system.force_scale());
        // A failed exact or adaptive solve is retried with the Gauss–Newton Hessian
        // (docs/robustness.md), a safety net the adaptive Newton rarely needs.
        let fallback = (hessian_mode == HessianMode::Exact).then_some(HessianMode::GaussNewton);
        let integrator: Box<dyn Integrator + Send> = match it.kind {
            IntegratorKind::Static => {
                let defaults = Static::default();
                Box::new(Static {
                    newton: newton(defaults.newton)?,
                    force_scale,
                    fallback_hessian: fallback,
                    ..defaults
                })
            }
            IntegratorKind::Implicit => {
                let defaults = ImplicitEuler::new(dt);
                Box::new(ImplicitEuler {
                    newton: newton(defaults.newton)?,
                    force_scale,
                    max_halvings: if it.adaptive_dt { 8 } else { 0 },
                    // With `adaptive_dt`, before halving Δt.
                    fallback_hessian: fallback.filter(|_| it.adaptive_dt),
                    ..defaults
                })
            }
            IntegratorKind::Explicit => Box::new(ExplicitEuler { dt }),
        };
        let path = match &s.path {
            Some(spec) => Some(super::path::build(spec, &mut system, &x, &origin)?),
            None => None,
        };
        let mut state = State::at_rest(x);
        state.v = v;
        Ok(Simulation {
            name: scene.name(),
            effects: s.effects.clone(),
            x_ref,
            system,
            state,
            integrator,
            dt,
            steps_done: 0,
            steps_total: steps,
            energy,
            energy_grown,
            growth,
            load_ramp,
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

/// The scene's region as a growth-crate region (validation guarantees exactly one key).
fn region_of(spec: &RegionSpec) -> Region {
    if let Some(h) = &spec.half_space {
        Region::HalfSpace {
            point: v3(&h.point),
            normal: v3(&h.normal),
        }
    } else if let Some(b) = &spec.sphere {
        Region::Ball {
            center: v3(&b.center),
            radius: b.radius,
        }
    } else if let Some(b) = &spec.aabb {
        Region::Box {
            min: v3(&b.min),
            max: v3(&b.max),
        }
    } else if let Some(v) = &spec.vertices {
        Region::Vertices(v.clone())
    } else {
        Region::All
    }
}

/// Growth model and stimulus field of a validated `[growth]` section, and the rest forms for
/// the initial stimulus (what the first step sees).
fn build_growth(
    g: &GrowthSpec,
    mesh: &Mesh,
    x_ref: &[Vector3<f64>],
    rest: &RestState,
    thickness: f64,
) -> Result<(Growth, RestState), GrowthError> {
    let model: Box<dyn GrowthModel> = match g.model {
        GrowthModelKind::Isotropic => Box::new(Isotropic {
            p: g.p.unwrap_or(0.0),
            coefficient: 1.0,
        }),
        GrowthModelKind::Linear | GrowthModelKind::Bilayer => {
            let c = g.coefficient.unwrap_or(0.0);
            let mut sw = if g.model == GrowthModelKind::Linear {
                Swelling::linear(c)
            } else {
                Swelling::bilayer(c)
            };
            if let Some(d) = &g.direction {
                let cross = g.cross_coefficient.unwrap_or(c);
                sw.anisotropy = Some(Anisotropy::along(mesh, x_ref, v3(d), cross)?);
            }
            Box::new(sw)
        }
    };
    let st = &g.stimulus;
    let field: Box<dyn StimulusField> = match st.kind {
        StimulusKind::Uniform => {
            let m = match (st.value, st.top, st.bottom) {
                (Some(v), _, _) => FaceStimulus::uniform(v),
                (None, t, b) => FaceStimulus {
                    top: t.unwrap_or(0.0),
                    bottom: b.unwrap_or(0.0),
                },
            };
            Box::new(PrescribedStimulus::uniform(mesh.n_faces(), m)?)
        }
        StimulusKind::DirectedHeat => {
            let hot = st.hot.as_ref().map_or(Region::Faces(Vec::new()), region_of);
            let held = st
                .held
                .as_ref()
                .map_or(Region::Faces(Vec::new()), region_of);
            Box::new(DirectedHeat::new(
                mesh,
                x_ref,
                &hot,
                &held,
                st.value.unwrap_or(0.0),
            )?)
        }
        StimulusKind::Diffusion => {
            let mut sources = Vec::with_capacity(st.sources.len());
            for (i, src) in st.sources.iter().enumerate() {
                let faces = src
                    .region
                    .as_ref()
                    .map_or(Region::All, region_of)
                    .faces(mesh, x_ref)?;
                if !faces.iter().any(|&f| f) {
                    return Err(GrowthError::EmptyRegion {
                        name: format!("growth.stimulus.sources[{i}].region"),
                    });
                }
                sources.push(DiffusionSource {
                    surface: match src.surface {
                        SceneSurface::Top => Surface::Top,
                        SceneSurface::Bottom => Surface::Bottom,
                    },
                    faces,
                    kind: match (src.value, src.flux) {
                        (Some(v), _) => SourceKind::Value(v),
                        (None, f) => SourceKind::Flux(f.unwrap_or(0.0)),
                    },
                });
            }
            let settings = DiffusionSettings {
                diffusivity: st.diffusivity.unwrap_or(0.0),
                thickness,
                layers: st.layers.unwrap_or(2),
                initial: 0.0,
            };
            Box::new(Diffusion::new(mesh, rest, settings, &sources)?)
        }
    };
    let mut grown = rest.clone();
    apply_growth(model.as_ref(), rest, field.values(), thickness, &mut grown)?;
    let growth = Growth::new(model, field, rest.clone(), thickness)?;
    let growth = match g.mass_uptake {
        Some(rho) => growth.with_mass_uptake(rho)?,
        None => growth,
    };
    Ok((growth, grown))
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

/// The energy crate's material of a `[material]` table, validated.
fn material_of(mat: &MaterialSpec) -> Result<Material, EnergyError> {
    let single = |model| Material {
        thickness: mat.thickness(),
        young: mat.young(),
        poisson: mat.poisson(),
        density: mat.density,
        viscosity: mat.viscosity,
        model,
    };
    let material = match mat.model {
        MaterialModelName::Stvk => single(MaterialModel::StVK),
        MaterialModelName::NeoHookean => single(MaterialModel::NeoHookean),
        MaterialModelName::Bilayer => {
            // Scene validation requires both layers; a missing one is still a typed error.
            let layer = |name: &'static str, l: &Option<LayerSpec>| {
                l.map(|l| Layer {
                    thickness: l.thickness,
                    young: l.young,
                    poisson: l.poisson,
                    eigenstrain: l.eigenstrain,
                })
                .ok_or(EnergyError::InvalidParameter {
                    name,
                    value: f64::NAN,
                    reason: "is required with model = \"bilayer\"",
                })
            };
            Material::bilayer(
                layer("material.bottom", &mat.bottom)?,
                layer("material.top", &mat.top)?,
                mat.density,
                mat.viscosity,
            )
        }
    };
    material.validate()?;
    Ok(material)
}
