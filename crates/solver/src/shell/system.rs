//! A shell with its boundary conditions and loads, and the objectives Newton minimises.

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{
    Assembler, DampingState, DofMap, EnergyError, EnergyTerms, EvalOutput, HessianMode, RestState,
    ShellModel, lumped_mass,
};
use thinshell_mesh::Mesh;

use super::bc::Boundary;
use super::loads::{Loads, face_volume, face_volume_gradient, face_volume_hessian};
use crate::{Objective, SolverError};

/// Dynamic state: positions (m), velocities (m/s), one entry per vertex; edge-director angles
/// (rad), one per edge; time (s).
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Positions (m).
    pub x: Vec<Vector3<f64>>,
    /// Velocities (m/s).
    pub v: Vec<Vector3<f64>>,
    /// Edge-director angles φ_e (rad), one per edge, when the system has edge unknowns
    /// ([`ShellSystem::has_edge_unknowns`]); empty otherwise. An empty vector on a system with
    /// edge unknowns means all angles 0 (integrators fill it in on the first step). The angles
    /// carry no mass: every step solves for them quasi-statically.
    pub phi: Vec<f64>,
    /// Time (s).
    pub t: f64,
}

impl State {
    /// At rest at positions `x`, time 0, edge angles 0.
    pub fn at_rest(x: Vec<Vector3<f64>>) -> State {
        let v = vec![Vector3::zeros(); x.len()];
        State {
            x,
            v,
            phi: Vec::new(),
            t: 0.0,
        }
    }
}

pub(crate) fn energy_error(e: EnergyError) -> SolverError {
    SolverError::Objective(e.to_string())
}

/// A mesh with material, rest state, boundary conditions and loads, plus the assembler (pattern
/// built once over the free dofs) and the lumped masses.
pub struct ShellSystem {
    /// The mesh (connectivity; its positions are the reference configuration).
    pub mesh: Mesh,
    /// Material, active terms, second fundamental form.
    pub model: ShellModel,
    /// Rest forms per face.
    pub rest: RestState,
    /// Held coordinates and prescribed motion.
    pub boundary: Boundary,
    /// External loads at load factor 1 (see [`ShellSystem::set_load_factor`]).
    pub loads: Loads,
    /// Hessian mode used by Newton (exact, Gauss–Newton, projected).
    pub hessian_mode: HessianMode,
    pub(crate) dofs: DofMap,
    pub(crate) mass: Vec<f64>,
    /// External forces (N) at the current load factor: `λ · loads.forces(mass)`.
    pub(crate) f_ext: Vec<f64>,
    /// Load factor λ (dimensionless) multiplying gravity, point forces and pressure.
    pub(crate) load_factor: f64,
    pub(crate) assembler: Assembler,
    /// Length ℓ̄ (m, mean edge length of the reference mesh) by which edge angles are scaled
    /// into Newton unknowns u = ℓ̄ φ, so that their gradient entries are forces (N) and their
    /// steps lengths (m), like those of the positions.
    pub(crate) angle_scale: f64,
    /// Angle-only sub-problem of [`ShellSystem::relax_edge_angles`], built on first use.
    pub(crate) angle_relaxation: Option<Box<super::angles::AngleRelaxation>>,
}

impl std::fmt::Debug for ShellSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShellSystem")
            .field("n_vertices", &self.mesh.n_vertices())
            .field("n_free", &self.dofs.n_free())
            .field("model", &self.model)
            .finish_non_exhaustive()
    }
}

impl ShellSystem {
    /// Builds the dof map, lumped masses, external forces and the assembler. With an
    /// edge-director second fundamental form and bending on, the unknowns include one angle
    /// per edge; the angles of clamped edges are fixed at 0 (pins leave them free).
    pub fn new(
        mesh: Mesh,
        model: ShellModel,
        rest: RestState,
        boundary: Boundary,
        loads: Loads,
    ) -> Result<ShellSystem, SolverError> {
        rest.validate(&mesh).map_err(energy_error)?;
        let mut dofs = boundary.dof_map(&mesh)?;
        if model.sff.director().is_some() && model.terms.bend {
            dofs = dofs
                .with_edges(mesh.n_edges(), boundary.clamped_edges.iter().copied())
                .map_err(energy_error)?;
        }
        let mass = lumped_mass(&mesh, &rest, &model.material).map_err(energy_error)?;
        let f_ext = loads.forces(&mass)?;
        let assembler = Assembler::for_model(&mesh, &dofs, &model).map_err(energy_error)?;
        let angle_scale = mean_edge_length(&mesh);
        Ok(ShellSystem {
            mesh,
            model,
            rest,
            boundary,
            loads,
            hessian_mode: HessianMode::Exact,
            dofs,
            mass,
            f_ext,
            load_factor: 1.0,
            assembler,
            angle_scale,
            angle_relaxation: None,
        })
    }

    /// Whether the unknowns include one edge-director angle per edge.
    pub fn has_edge_unknowns(&self) -> bool {
        self.assembler.has_edge_unknowns()
    }

    /// Number of edge angles a [`State`] of this system carries (0 without edge unknowns).
    pub fn n_edge_angles(&self) -> usize {
        self.dofs.n_edges()
    }

    /// Free dofs.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Lumped vertex masses (kg).
    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    /// Replaces the lumped vertex masses (kg), e.g. when a stimulus adds mass, and recomputes
    /// the external forces that depend on them (gravity). Errors on a length mismatch or a mass
    /// that is not positive and finite.
    pub fn set_mass(&mut self, mass: Vec<f64>) -> Result<(), SolverError> {
        if mass.len() != self.mesh.n_vertices() {
            return Err(SolverError::InvalidSetting {
                name: "mass.len",
                value: mass.len() as f64,
                requirement: "one mass per vertex",
            });
        }
        if let Some(&m) = mass.iter().find(|m| !(m.is_finite() && **m > 0.0)) {
            return Err(SolverError::InvalidSetting {
                name: "mass",
                value: m,
                requirement: "must be positive and finite",
            });
        }
        self.f_ext = self.scaled_forces(&mass)?;
        self.mass = mass;
        Ok(())
    }

    /// `λ · loads.forces(mass)` (N).
    fn scaled_forces(&self, mass: &[f64]) -> Result<Vec<f64>, SolverError> {
        let mut f = self.loads.forces(mass)?;
        if self.load_factor != 1.0 {
            f.iter_mut().for_each(|v| *v *= self.load_factor);
        }
        Ok(f)
    }

    /// Sets the load factor λ (dimensionless, finite): from now on the external forces
    /// (gravity, point forces) and the pressure are λ times those of [`ShellSystem::loads`].
    /// A static load ramp solves a sequence of equilibria at growing λ, each from the previous
    /// one. Prescribed motion is a function of time and is not scaled here: a static ramp
    /// evaluates it at a time proportional to λ (the scene runner does, `docs/scenes.md`).
    pub fn set_load_factor(&mut self, lambda: f64) -> Result<(), SolverError> {
        if !lambda.is_finite() {
            return Err(SolverError::InvalidSetting {
                name: "load_factor",
                value: lambda,
                requirement: "must be finite",
            });
        }
        let previous = self.load_factor;
        self.load_factor = lambda;
        match self.scaled_forces(&self.mass) {
            Ok(f) => {
                self.f_ext = f;
                Ok(())
            }
            Err(e) => {
                self.load_factor = previous;
                Err(e)
            }
        }
    }

    /// The load factor λ (1 unless changed by [`ShellSystem::set_load_factor`]).
    pub fn load_factor(&self) -> f64 {
        self.load_factor
    }

    /// The pressure (Pa) at the current load factor: `λ · loads.pressure`.
    pub fn pressure(&self) -> f64 {
        self.load_factor * self.loads.pressure
    }

    /// External force per coordinate (N) at the current load factor.
    pub fn external_forces(&self) -> &[f64] {
        &self.f_ext
    }

    /// The force scale (N) of this system — the one definition used by the integrators, the
    /// scene runner and the xtasks: `E·h·L` (stretching force of a unit strain over the
    /// bounding-box diagonal L), or the total external load if larger. Reported residuals are
    /// relative to it. It does **not** decide convergence unless an integrator is given an
    /// explicit force scale: Newton converges on its correction (distance to the equilibrium in
    /// metres, scale-free; see [`newton_solve`](crate::newton_solve)), because bending forces
    /// and edge-director moments are orders of magnitude below any membrane force scale.
    pub fn force_scale(&self) -> f64 {
        let m = &self.model.material;
        let load: f64 = self.f_ext.iter().map(|f| f.abs()).sum();
        (m.young * m.thickness * self.length_scale()).max(load)
    }

    /// Bounding-box diagonal of the reference mesh (m).
    pub fn length_scale(&self) -> f64 {
        let p = self.mesh.positions();
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for q in p {
            lo = lo.inf(q);
            hi = hi.sup(q);
        }
        let d = (hi - lo).norm();
        if d.is_finite() && d > 0.0 { d } else { 1.0 }
    }

    /// Energy terms (J) at positions `x` (no damping), with all edge angles 0 when the system
    /// has edge unknowns (see [`ShellSystem::energy_at`]).
    pub fn energy(&mut self, x: &[Vector3<f64>]) -> Result<EnergyTerms, SolverError> {
        self.energy_at(x, &[])
    }

    /// Energy terms (J) at positions `x` and edge angles `phi` (rad, one per edge; empty = all
    /// 0; must be empty without edge unknowns), no damping.
    pub fn energy_at(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<EnergyTerms, SolverError> {
        let model = ShellModel {
            terms: self.assembler.terms(),
            ..self.model
        };
        if model.terms.damping {
            return Err(SolverError::InvalidSetting {
                name: "terms.damping",
                value: 1.0,
                requirement: "energy() evaluates without damping state; use an integrator",
            });
        }
        let zeros;
        let phi = if phi.is_empty() && self.has_edge_unknowns() {
            zeros = vec![0.0; self.dofs.n_edges()];
            &zeros
        } else {
            phi
        };
        self.assembler
            .evaluate_with_angles(&model, x, phi, &self.rest, None, EvalOutput::default())
            .map_err(energy_error)
    }

    /// The force (N) the supports exert on every held coordinate at `x`:
    /// `R = ∂E/∂x − F_ext − p ∂V/∂x` there (0 on free coordinates).
    /// With edge unknowns the angles are taken as 0 (see [`ShellSystem::reactions_at`]).
    pub fn reactions(&mut self, x: &[Vector3<f64>]) -> Result<Vec<f64>, SolverError> {
        self.reactions_at(x, &[])
    }

    /// [`ShellSystem::reactions`] at edge angles `phi` (rad, one per edge; empty = all 0).
    pub fn reactions_at(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<Vec<f64>, SolverError> {
        let zeros;
        let phi = if phi.is_empty() && self.has_edge_unknowns() {
            zeros = vec![0.0; self.dofs.n_edges()];
            &zeros
        } else {
            phi
        };
        let mut g = vec![0.0; self.dofs.n_coordinates()];
        self.assembler
            .evaluate_with_angles(
                &self.model,
                x,
                phi,
                &self.rest,
                None,
                EvalOutput {
                    gradient: Some(&mut g),
                    hessian: None,
                },
            )
            .map_err(energy_error)?;
        super::integrators::add_pressure_gradient(self, x, &mut g);
        g.truncate(3 * x.len());
        Ok(g.iter()
            .zip(&self.f_ext)
            .enumerate()
            .map(|(c, (g, f))| {
                if self.dofs.coordinate_dof(c).is_some() {
                    0.0
                } else {
                    g - f
                }
            })
            .collect())
    }

    /// Free dofs (Newton's unknowns) of positions `x` (m) and edge angles `phi` (rad, one per
    /// edge, or empty for all 0): free coordinates, then ℓ̄·φ_e (m) of the free edges.
    pub fn gather(&self, x: &[Vector3<f64>], phi: &[f64]) -> Vec<f64> {
        let n3 = 3 * self.dofs.n_vertices();
        self.dofs
            .free_coordinates()
            .iter()
            .map(|&c| {
                if c < n3 {
                    x[c / 3][c % 3]
                } else {
                    self.angle_scale * phi.get(c - n3).copied().unwrap_or(0.0)
                }
            })
            .collect()
    }

    /// Writes free dofs `u` into positions `x` and edge angles `phi` (held coordinates and
    /// fixed angles untouched; `phi` may be empty when there are no edge unknowns).
    pub fn scatter(&self, u: &[f64], x: &mut [Vector3<f64>], phi: &mut [f64]) {
        let n3 = 3 * self.dofs.n_vertices();
        for (&c, &val) in self.dofs.free_coordinates().iter().zip(u) {
            if c < n3 {
                x[c / 3][c % 3] = val;
            } else if let Some(p) = phi.get_mut(c - n3) {
                *p = val / self.angle_scale;
            }
        }
    }
}

/// Mean edge length (m) of the reference mesh; 1 if degenerate.
fn mean_edge_length(mesh: &Mesh) -> f64 {
    let p = mesh.positions();
    let edges = mesh.topology().edges();
    let sum: f64 = edges
        .iter()
        .map(|e| (p[e.vertices[1].idx()] - p[e.vertices[0].idx()]).norm())
        .sum();
    let mean = sum / edges.len().max(1) as f64;
    if mean.is_finite() && mean > 0.0 {
        mean
    } else {
        1.0
    }
}

/// Inertia term of the incremental potential: `1/(2Δt²) (x − x̃)ᵀ Λ (x − x̃)`.
pub(crate) struct Inertia {
    /// x̃ = xⁿ + Δt vⁿ per free dof.
    pub x_tilde: Vec<f64>,
    /// Λ/Δt² per free dof (kg/s²).
    pub m_over_dt2: Vec<f64>,
}

/// `E(x) + inertia − F_extᵀx` over the free dofs; held coordinates are taken from `base`.
pub(crate) struct ShellObjective<'a> {
    pub sys: &'a mut ShellSystem,
    pub x_full: Vec<Vector3<f64>>,
    /// Edge angles (rad), one per edge with edge unknowns, else empty.
    pub phi_full: Vec<f64>,
    pub grad_full: Vec<f64>,
    pub inertia: Option<Inertia>,
    pub damping: Option<DampingState>,
    /// Static solves: shift κ·mean|H_dd| added to the Hessian diagonal only (the gradient is
    /// exact, so the minimiser is unchanged); it makes rigid-motion null spaces invertible.
    pub hessian_shift: f64,
    /// Unit of the reported residuals (N).
    pub force_scale: f64,
    /// Whether `‖∇‖∞ ≤ tol · force_scale` may end a solve (the caller gave the scale).
    pub gradient_test: bool,
    pub last_terms: EnergyTerms,
}

impl ShellObjective<'_> {
    fn face_x(&self, f: usize) -> [Vector3<f64>; 3] {
        let face = self.sys.mesh.faces()[f];
        [
            self.x_full[face[0].idx()],
            self.x_full[face[1].idx()],
            self.x_full[face[2].idx()],
        ]
    }

    /// Enclosed volume (m³) of `x_full`; 0 without pressure.
    fn volume(&self) -> f64 {
        if self.sys.pressure() == 0.0 {
            return 0.0;
        }
        (0..self.sys.mesh.n_faces())
            .map(|f| face_volume(self.face_x(f)))
            .sum()
    }

    /// Adds the pressure force gradient −p ∂V/∂x into the full gradient.
    fn add_pressure_gradient(&mut self) {
        let p = self.sys.pressure();
        if p == 0.0 {
            return;
        }
        for f in 0..self.sys.mesh.n_faces() {
            let g = face_volume_gradient(self.face_x(f));
            let face = self.sys.mesh.faces()[f];
            for (s, v) in face.iter().enumerate() {
                let base = 3 * v.idx();
                for (gc, gv) in self.grad_full[base..base + 3].iter_mut().zip(g[s].iter()) {
                    *gc -= p * gv;
                }
            }
        }
    }

    fn eval(
        &mut self,
        u: &[f64],
        gradient: bool,
        hessian: Option<&mut SparseColMat<usize, f64>>,
    ) -> Result<EnergyTerms, EnergyError> {
        let mode = self.sys.hessian_mode;
        self.eval_mode(u, gradient, hessian, mode)
    }

    fn eval_mode(
        &mut self,
        u: &[f64],
        gradient: bool,
        hessian: Option<&mut SparseColMat<usize, f64>>,
        mode: HessianMode,
    ) -> Result<EnergyTerms, EnergyError> {
        self.sys.scatter(u, &mut self.x_full, &mut self.phi_full);
        let out = EvalOutput {
            gradient: if gradient {
                Some(&mut self.grad_full)
            } else {
                None
            },
            hessian: hessian.map(|h| (h, mode)),
        };
        self.sys.assembler.evaluate_with_angles(
            &self.sys.model,
            &self.x_full,
            &self.phi_full,
            &self.sys.rest,
            self.damping.as_ref(),
            out,
        )
    }

    /// Inertia and load part of the value at `u` (call after `eval`, which fills `x_full`).
    fn extra_value(&self, u: &[f64]) -> f64 {
        let coords = self.sys.dofs.free_coordinates();
        let mut v = -self.sys.pressure() * self.volume();
        for (d, &c) in coords.iter().enumerate() {
            v -= self.sys.f_ext.get(c).copied().unwrap_or(0.0) * u[d];
            if let Some(i) = &self.inertia {
                let dx = u[d] - i.x_tilde[d];
                v += 0.5 * i.m_over_dt2[d] * dx * dx;
            }
        }
        v
    }
}

impl Objective for ShellObjective<'_> {
    fn n_dofs(&self) -> usize {
        self.sys.dofs.n_free()
    }

    fn value(&mut self, u: &[f64]) -> Result<f64, SolverError> {
        match self.eval(u, false, None) {
            Ok(t) => Ok(t.total() + self.extra_value(u)),
            // An inverted or degenerate trial configuration: let the line search backtrack.
            Err(EnergyError::NonFinite { .. }) => Ok(f64::INFINITY),
            Err(e) => Err(energy_error(e)),
        }
    }

    fn gradient(&mut self, u: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        let terms = match self.eval(u, true, None) {
            Ok(t) => t,
            Err(EnergyError::NonFinite { .. }) => {
                g.fill(f64::NAN);
                return Ok(f64::INFINITY);
            }
            Err(e) => return Err(energy_error(e)),
        };
        self.last_terms = terms;
        self.add_pressure_gradient();
        let coords = self.sys.dofs.free_coordinates();
        let n_pos = self.sys.dofs.n_free_positions();
        let inv_scale = 1.0 / self.sys.angle_scale;
        for (d, &c) in coords.iter().enumerate() {
            g[d] = if d < n_pos {
                self.grad_full[c] - self.sys.f_ext[c]
            } else {
                self.grad_full[c] * inv_scale
            };
            if let Some(i) = &self.inertia {
                g[d] += i.m_over_dt2[d] * (u[d] - i.x_tilde[d]);
            }
        }
        Ok(terms.total() + self.extra_value(u))
    }

    fn hessian(&mut self, u: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
        let mode = self.sys.hessian_mode;
        self.hessian_in_mode(u, h, mode)
    }

    /// The Gauss–Newton Hessian (PSD by construction; the pressure and inertia terms are added
    /// as in [`hessian`](Objective::hessian)).
    fn psd_hessian(
        &mut self,
        u: &[f64],
        h: &mut SparseColMat<usize, f64>,
    ) -> Result<(), SolverError> {
        self.hessian_in_mode(u, h, HessianMode::GaussNewton)
    }

    fn has_psd_hessian(&self) -> bool {
        true
    }

    fn hessian_template(&self) -> SparseColMat<usize, f64> {
        self.sys.assembler.hessian_template()
    }

    fn force_scale(&self) -> f64 {
        self.force_scale
    }

    fn gradient_test(&self) -> bool {
        self.gradient_test
    }

    fn length_scale(&self) -> f64 {
        self.sys.length_scale()
    }

    fn dof_coordinates(&self) -> Option<Vec<[f64; 3]>> {
        let p = self.sys.mesh.positions();
        let n3 = 3 * p.len();
        let edges = self.sys.mesh.topology().edges();
        Some(
            self.sys
                .dofs
                .free_coordinates()
                .iter()
                .map(|&c| {
                    // An edge angle sits at its edge's midpoint.
                    let q = if c < n3 {
                        p[c / 3]
                    } else {
                        let e = &edges[c - n3];
                        (p[e.vertices[0].idx()] + p[e.vertices[1].idx()]) * 0.5
                    };
                    [q.x, q.y, q.z]
                })
                .collect(),
        )
    }
}

impl ShellObjective<'_> {
    /// The Hessian in `mode` plus pressure, angle scaling, inertia and the static shift.
    fn hessian_in_mode(
        &mut self,
        u: &[f64],
        h: &mut SparseColMat<usize, f64>,
        mode: HessianMode,
    ) -> Result<(), SolverError> {
        self.eval_mode(u, false, Some(h), mode)
            .map_err(energy_error)?;
        let p = self.sys.pressure();
        if p != 0.0 {
            let this = &*self;
            this.sys
                .assembler
                .add_face_blocks(|f| face_volume_hessian(this.face_x(f.idx())) * -p, h)
                .map_err(energy_error)?;
        }
        if self.sys.has_edge_unknowns() {
            // u = ℓ̄ φ for edge dofs: H_uu = D H_φφ D with D = diag(1, 1/ℓ̄).
            let n_pos = self.sys.dofs.n_free_positions();
            let inv_scale = 1.0 / self.sys.angle_scale;
            let (symbolic, val) = h.parts_mut();
            for j in n_pos.min(symbolic.ncols())..symbolic.ncols() {
                for p in symbolic.col_range(j) {
                    // Rows of an angle column are angles too (lower triangle, angles last).
                    val[p] *= inv_scale * inv_scale;
                }
            }
            for j in 0..n_pos.min(symbolic.ncols()) {
                for p in symbolic.col_range(j) {
                    if symbolic.row_idx()[p] >= n_pos {
                        val[p] *= inv_scale;
                    }
                }
            }
        }
        let offsets = self.sys.assembler.diagonal_offsets();
        let val = h.val_mut();
        if let Some(i) = &self.inertia {
            for (&o, &m) in offsets.iter().zip(&i.m_over_dt2) {
                val[o] += m;
            }
        }
        if self.hessian_shift > 0.0 && !offsets.is_empty() {
            let mean = offsets.iter().map(|&o| val[o].abs()).sum::<f64>() / offsets.len() as f64;
            for &o in offsets {
                val[o] += self.hessian_shift * mean;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use thinshell_energy::{Material, SffKind, Terms};
    use thinshell_mesh::generators;

    /// Gradient and Hessian of the static and implicit objectives with pressure, gravity and a
    /// point force against central differences.
    #[test]
    fn objective_derivatives_match_finite_differences() {
        let mesh = generators::icosphere(1.0, 1).unwrap();
        let sff = SffKind::MidEdgeAverage;
        let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
        let model = ShellModel {
            material: Material {
                young: 1e3,
                thickness: 1e-2,
                ..Material::paper()
            },
            terms: Terms {
                stretch: true,
                bend: true,
                damping: false,
            },
            sff,
        };
        let loads = Loads {
            gravity: Vector3::new(0.0, 0.0, -9.81),
            point_forces: vec![(
                thinshell_mesh::VertexId::new(3),
                Vector3::new(0.1, 0.2, -0.3),
            )],
            pressure: 7.0,
        };
        let boundary = Boundary {
            pinned_vertices: vec![thinshell_mesh::VertexId::new(0)],
            ..Default::default()
        };
        let mut sys = ShellSystem::new(mesh, model, rest, boundary, loads).unwrap();
        // A deformed configuration.
        let x: Vec<Vector3<f64>> = sys
            .mesh
            .positions()
            .iter()
            .enumerate()
            .map(|(i, p)| p * (1.0 + 0.05 * ((i as f64) * 0.7).sin()))
            .collect();
        let n = sys.dofs.n_free();
        for inertia in [false, true] {
            let u0 = sys.gather(&x, &[]);
            let inertia = inertia.then(|| Inertia {
                x_tilde: u0.iter().map(|v| v + 0.01).collect(),
                m_over_dt2: (0..n).map(|d| 1.0 + d as f64 * 0.01).collect(),
            });
            let n3 = 3 * x.len();
            let mut obj = ShellObjective {
                sys: &mut sys,
                x_full: x.clone(),
                phi_full: Vec::new(),
                grad_full: vec![0.0; n3],
                inertia,
                damping: None,
                hessian_shift: 0.0,
                force_scale: 1.0,
                gradient_test: true,
                last_terms: EnergyTerms::default(),
            };
            let mut g = vec![0.0; n];
            let f0 = obj.gradient(&u0, &mut g).unwrap();
            assert_eq!(obj.value(&u0).unwrap(), f0);
            let mut h = obj.hessian_template();
            obj.hessian(&u0, &mut h).unwrap();
            let eps = 1e-6;
            let gscale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for d in (0..n).step_by(7) {
                let mut up = u0.clone();
                up[d] += eps;
                let mut um = u0.clone();
                um[d] -= eps;
                let fd = (obj.value(&up).unwrap() - obj.value(&um).unwrap()) / (2.0 * eps);
                assert!(
                    (fd - g[d]).abs() < 1e-6 * gscale,
                    "dof {d}: fd {fd} vs {}",
                    g[d]
                );
                // Column d of the Hessian vs difference of gradients.
                let mut gp = vec![0.0; n];
                let mut gm = vec![0.0; n];
                obj.gradient(&up, &mut gp).unwrap();
                obj.gradient(&um, &mut gm).unwrap();
                let mut col = vec![0.0; n];
                for j in 0..n {
                    for p in h.symbolic().col_range(j) {
                        let i = h.symbolic().row_idx()[p];
                        let v = h.val()[p];
                        if j == d {
                            col[i] += v;
                        }
                        if i == d && i != j {
                            col[j] += v;
                        }
                    }
                }
                let hscale = col.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for i in 0..n {
                    let fdh = (gp[i] - gm[i]) / (2.0 * eps);
                    assert!(
                        (fdh - col[i]).abs() < 1e-5 * hscale,
                        "H[{i},{d}]: fd {fdh} vs {}",
                        col[i]
                    );
                }
            }
        }
    }
}
