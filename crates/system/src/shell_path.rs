//! Path following on a [`ShellSystem`]: the static potential `E(x) − λ(F_extᵀx + p·V(x))` as
//! a [`LoadedObjective`] (its loads scaled by [`ShellSystem::set_load_factor`]), traced by the
//! one [`PathTracer`] (arc length or displacement control, see [`thinshell_solver::path`]).

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::HessianMode;
use thinshell_mesh::VertexId;

use super::loads::{add_pressure_gradient, unit_axis};
use super::objective::ShellObjective;
use super::system::ShellSystem;
use thinshell_solver::path::{LoadedObjective, PathControl, PathPoint, PathSettings, PathTracer};
use thinshell_solver::{IterationUpdate, Objective, SolverError};

/// Arc-length or displacement-controlled path following of a shell's static equilibria
/// under its loads ([`ShellSystem::loads`] at load factor 1: gravity, point forces and
/// pressure, all scaled by λ; prescribed motion is not scaled: held coordinates stay where
/// the positions passed in put them).
///
/// Start from an equilibrium at the system's current load factor (e.g. the reference
/// configuration at λ = 0) and call [`ShellPath::step`] repeatedly; each call returns the
/// next converged [`PathPoint`] and leaves its positions, edge angles and load factor in
/// `x`, `phi` and the system. The tangent is the exact Hessian (whatever
/// [`NewtonSettings::own_hessian`](thinshell_solver::NewtonSettings::own_hessian) says), plus the
/// rigid-motion shift of a static solve.
///
/// A shallow arch strip under a central point load, traced over its limit point (load
/// control would jump there; the load factor falls after it):
///
/// ```
/// use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
/// use thinshell_mesh::{Mesh, VertexId};
/// use thinshell_solver::nalgebra::Vector3;
/// use thinshell_solver::PathSettings;
/// use thinshell_system::{Boundary, Loads, ShellPath, ShellSystem};
///
/// // A strip 1 × 0.1 m, 20 × 2 cells, curved into a shallow arch z = a·(1 − (2x − 1)²),
/// // a = 15 mm, h = 10 mm, E = 10 MPa.
/// let flat = thinshell_mesh::generators::rectangle(1.0, 0.1, 20, 2)?;
/// let arch: Vec<Vector3<f64>> = flat.positions().iter()
///     .map(|p| Vector3::new(p.x, p.y, 0.015 * (1.0 - (2.0 * p.x - 1.0).powi(2))))
///     .collect();
/// let mesh = Mesh::new(arch.clone(), flat.faces_usize())?;
/// let sff = SffKind::MidEdgeAverage;
/// let rest = RestState::from_mesh(&mesh, mesh.positions(), sff)?;
/// let model = ShellModel { material: Material { thickness: 0.01, young: 1e7, poisson: 0.3, ..Material::paper() }, terms: Terms::ELASTIC, sff };
/// // Both short ends pinned; the load on the middle vertex of the crown line.
/// let ends = (0..mesh.n_vertices()).map(VertexId::new)
///     .filter(|v| arch[v.idx()].x < 1e-9 || arch[v.idx()].x > 1.0 - 1e-9).collect();
/// let top = mesh.nearest_vertex(&Vector3::new(0.5, 0.05, 0.015));
/// let boundary = Boundary { pinned_vertices: ends, ..Default::default() };
/// let loads = Loads { point_forces: vec![(top, Vector3::new(0.0, 0.0, -1.0))], ..Default::default() };
/// let mut system = ShellSystem::new(mesh, model, rest, boundary, loads)?;
/// system.set_load_factor(0.0)?;
///
/// let mut path = ShellPath::new(PathSettings { initial_load_increment: 0.02, ..Default::default() });
/// let (mut x, mut phi) = (arch.clone(), Vec::new());
/// let mut lambda_max = 0.0f64;
/// let mut passed_limit = false;
/// for _ in 0..20 {
///     let point = path.step(&mut system, &mut x, &mut phi)?;
///     lambda_max = lambda_max.max(point.load_factor);
///     // After the limit point: λ decreases, and the point is unstable at fixed load.
///     if point.load_increment < 0.0 && !point.stable() {
///         passed_limit = true;
///         break;
///     }
/// }
/// assert!(passed_limit && lambda_max > 0.16); // the limit load is about 0.17 N
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct ShellPath {
    /// The tracer (settings, step size, direction, tangent).
    pub tracer: PathTracer,
    /// Relative Hessian diagonal shift κ against rigid-motion null spaces (≥ 0; as
    /// [`Static::hessian_shift`](thinshell_solver::Static::hessian_shift)).
    pub hessian_shift: f64,
    /// Unit (N) of the reported residuals; `None`: [`ShellSystem::force_scale`].
    pub force_scale: Option<f64>,
}

impl ShellPath {
    /// A path at its start with `settings`, the static solve's Hessian shift (1e-10) and
    /// residuals reported against the system's force scale.
    pub fn new(settings: PathSettings) -> ShellPath {
        ShellPath {
            tracer: PathTracer::new(settings),
            hessian_shift: thinshell_solver::Static::default().hessian_shift,
            force_scale: None,
        }
    }

    /// Displacement control of coordinate `axis` (0 = x, 1 = y, 2 = z) of `vertex`: the
    /// [`PathControl`] for it, or an error if that coordinate is held or out of range.
    pub fn displacement_control(
        system: &ShellSystem,
        vertex: VertexId,
        axis: usize,
    ) -> Result<PathControl, SolverError> {
        system
            .dofs()
            .dof(vertex, axis)
            .map(|dof| PathControl::Displacement { dof })
            .ok_or(SolverError::InvalidSetting {
                name: "displacement control",
                value: vertex.idx() as f64,
                requirement: "the controlled coordinate must exist and be free (not pinned)",
            })
    }

    /// Takes one path step from the equilibrium `x` (m), `phi` (rad, one per edge with edge
    /// unknowns, or empty = all 0) at the system's load factor; overwrites them and the load
    /// factor with the next point. On error they are left at the start point.
    pub fn step(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
        phi: &mut Vec<f64>,
    ) -> Result<PathPoint, SolverError> {
        if x.len() != system.mesh.n_vertices() {
            return Err(SolverError::DimensionMismatch {
                what: "positions",
                expected: system.mesh.n_vertices(),
                found: x.len(),
            });
        }
        if phi.is_empty() {
            phi.resize(system.n_edge_angles(), 0.0);
        }
        thinshell_solver::integrate::check_static_inputs(system, phi, self.hessian_shift)?;
        let mut u = system.gather(x, phi);
        let lambda0 = system.load_factor();
        let result = (|| {
            let reference = system.loads.forces(&system.mass)?;
            let obj = ShellObjective::statics(system, x, phi, self.hessian_shift, self.force_scale)
                .with_hessian(HessianMode::Exact);
            let mut loaded = ShellLoaded { obj, reference };
            let point = self.tracer.step(&mut loaded, &mut u);
            loaded.obj.sys.scatter(&u, x, phi);
            point
        })();
        if result.is_err() {
            // The tracer restored u and λ; make sure the system agrees.
            let _ = system.set_load_factor(lambda0);
        }
        result
    }
}

/// The static shell objective with a settable load factor.
struct ShellLoaded<'a> {
    obj: ShellObjective<'a>,
    /// External forces at λ = 1 (N, per coordinate).
    reference: Vec<f64>,
}

impl Objective for ShellLoaded<'_> {
    fn n_dofs(&self) -> usize {
        self.obj.n_dofs()
    }
    fn value(&mut self, u: &[f64]) -> Result<f64, SolverError> {
        self.obj.value(u)
    }
    fn gradient(&mut self, u: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        self.obj.gradient(u, g)
    }
    fn hessian(&mut self, u: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
        self.obj.hessian(u, h)
    }
    fn hessian_template(&self) -> SparseColMat<usize, f64> {
        self.obj.hessian_template()
    }
    fn force_scale(&self) -> f64 {
        self.obj.force_scale()
    }
    fn length_scale(&self) -> f64 {
        self.obj.length_scale()
    }
    fn hessian_diagonal_shift(&self) -> f64 {
        self.obj.hessian_diagonal_shift()
    }
    fn dof_coordinates(&self) -> Option<Vec<[f64; 3]>> {
        self.obj.dof_coordinates()
    }
    fn max_step(&mut self, u: &[f64], du: &[f64]) -> Result<f64, SolverError> {
        self.obj.max_step(u, du)
    }
    fn begin_iteration(
        &mut self,
        u: &[f64],
        iteration: usize,
    ) -> Result<IterationUpdate, SolverError> {
        self.obj.begin_iteration(u, iteration)
    }
}

impl LoadedObjective for ShellLoaded<'_> {
    fn load_factor(&self) -> f64 {
        self.obj.sys.load_factor()
    }

    fn set_load_factor(&mut self, lambda: f64) -> Result<(), SolverError> {
        self.obj.sys.set_load_factor(lambda)
    }

    fn load_vector(&mut self, u: &[f64], q: &mut [f64]) -> Result<(), SolverError> {
        let sys = &*self.obj.sys;
        let p0 = sys.loads.pressure;
        let mut full = self.reference.clone();
        if p0 != 0.0 {
            // The follower pressure's share: p₀ ∂V/∂x at the current positions.
            let mut x = self.obj.x_full.clone();
            let mut phi = self.obj.phi_full.clone();
            sys.scatter(u, &mut x, &mut phi);
            let mut g = vec![0.0; full.len()];
            add_pressure_gradient(&sys.mesh, &x, -p0, unit_axis(&sys.loads), &mut g);
            full.iter_mut().zip(&g).for_each(|(f, gv)| *f += gv);
        }
        let n_pos = sys.dofs.n_free_positions();
        for (d, (qd, &c)) in q.iter_mut().zip(sys.dofs.free_coordinates()).enumerate() {
            *qd = if d < n_pos {
                full.get(c).copied().unwrap_or(0.0)
            } else {
                0.0
            };
        }
        Ok(())
    }
}
