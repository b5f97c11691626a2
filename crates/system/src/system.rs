//! A shell with its boundary conditions and loads: the one owner of the dof map, masses,
//! external forces, the force and length scales, and the assembler.

use nalgebra::Vector3;
use thinshell_energy::{
    Assembler, DampingState, DofMap, EnergyError, EnergyTerms, EvalOutput, RestState, ShellModel,
    Terms, lumped_mass,
};
use thinshell_mesh::Mesh;

use super::angles::{AngleRelaxation, AngleReport, AngleSettings};
use super::boundary::Boundary;
use super::contact::{Contact, ContactError, ContactRunState, ContactSettings, ContactStats};
use super::contact_pattern::ContactPattern;
use super::loads::{Loads, add_pressure_gradient, unit_axis};
use thinshell_solver::SolverError;

/// A mesh with material, rest state, boundary conditions and loads, plus the assembler (pattern
/// built once over the free dofs) and the lumped masses.
pub struct ShellSystem {
    /// The mesh (connectivity; its positions are the reference configuration; read with
    /// [`ShellSystem::mesh`]: the unknowns, masses and assembler are built from it).
    pub(crate) mesh: Mesh,
    /// Material, active terms, second fundamental form (read with [`ShellSystem::model`]: the
    /// unknowns, masses and assembler are built from it).
    pub(crate) model: ShellModel,
    /// Rest forms per face (read with [`ShellSystem::rest`], changed with
    /// [`ShellSystem::set_rest`], which re-checks them).
    pub(crate) rest: RestState,
    /// Held coordinates and prescribed motion (read with [`ShellSystem::boundary`]: the
    /// unknowns are built from it).
    pub(crate) boundary: Boundary,
    /// External loads at load factor 1 (read with [`ShellSystem::loads`]; see
    /// [`ShellSystem::set_load_factor`]).
    pub(crate) loads: Loads,
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
    pub(crate) angle_relaxation: Option<Box<AngleRelaxation>>,
    /// Edge angles (rad, one per edge) of the last solve on this system, or of the last
    /// relaxation by [`ShellSystem::energy`]; empty before the first (see
    /// [`ShellSystem::edge_angles`]).
    pub(crate) angles: Vec<f64>,
    /// Positions (m) at which clamped edges' directors are held (model.md §1.3); empty: the
    /// mesh's positions.
    pub(crate) clamp_reference: Vec<Vector3<f64>>,
    /// The contact term, when the scene names the `contact` effect (read with
    /// [`ShellSystem::contact`], set with [`ShellSystem::set_contact`]).
    pub(crate) contact: Option<Contact>,
    /// The Hessian pattern widened by self-contact couplings, when self-contact is on (built
    /// and rebuilt by the objectives, see `contact_pattern.rs`).
    pub(crate) contact_pattern: Option<ContactPattern>,
    /// Self-contact pairs approximated in the last Hessian ([`ContactStats::approximated_pairs`]).
    pub(crate) contact_approximated: usize,
    /// Rebuilds of `contact_pattern` since contact was set.
    pub(crate) contact_pattern_rebuilds: usize,
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
    /// Material, active terms and bending form, as given to [`ShellSystem::new`] (fixed: a
    /// different model needs a new system).
    pub fn model(&self) -> &ShellModel {
        &self.model
    }

    /// The mesh, as given to [`ShellSystem::new`] (fixed: connectivity and reference positions
    /// of the unknowns, masses and assembler).
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Held coordinates, clamps and prescribed motion, as given to [`ShellSystem::new`] (fixed:
    /// the free unknowns are built from them).
    pub fn boundary(&self) -> &Boundary {
        &self.boundary
    }

    /// Rest forms per face.
    pub fn rest(&self) -> &RestState {
        &self.rest
    }

    /// Replaces the rest forms (growth, a rest-state edit), checked as [`ShellSystem::new`]
    /// checks them (one pair of forms per face, positive definite ā, finite entries, the
    /// system's bending form); returns the forms replaced. On error the system keeps its own.
    pub fn set_rest(&mut self, rest: RestState) -> Result<RestState, SolverError> {
        check_rest(&self.mesh, &self.model, &rest)?;
        Ok(std::mem::replace(&mut self.rest, rest))
    }

    /// External loads at load factor 1 (gravity, point forces, pressure).
    pub fn loads(&self) -> &Loads {
        &self.loads
    }

    /// Replaces the external loads at load factor 1 and recomputes the external forces (follower
    /// loads turned between solves). Errors, leaving the system unchanged, on a point force at a
    /// vertex the mesh does not have or a non-finite value.
    pub fn set_loads(&mut self, loads: Loads) -> Result<(), SolverError> {
        let previous = std::mem::replace(&mut self.loads, loads);
        match self.scaled_forces(&self.mass) {
            Ok(f) => {
                self.f_ext = f;
                Ok(())
            }
            Err(e) => {
                self.loads = previous;
                Err(e)
            }
        }
    }

    /// The contact term, when contact is on ([`ShellSystem::set_contact`]).
    pub fn contact(&self) -> Option<&Contact> {
        self.contact.as_ref()
    }

    /// Turns contact off (the adaptive stiffness it learned is forgotten).
    pub fn clear_contact(&mut self) {
        self.contact = None;
        self.contact_pattern = None;
        self.contact_approximated = 0;
        self.contact_pattern_rebuilds = 0;
    }

    /// Holds the directors of the clamped edges as they are at `x_ref` (m, one position per
    /// vertex) instead of at the mesh's positions (model.md §1.3): for a start state that is not
    /// the mesh's own shape. No effect without edge-director unknowns. Errors on a wrong length
    /// or a degenerate clamped face.
    pub fn set_clamp_reference(&mut self, x_ref: &[Vector3<f64>]) -> Result<(), SolverError> {
        if !self.has_edge_unknowns() {
            return Ok(());
        }
        self.assembler
            .clamp_edges(&self.boundary.clamped_edges, x_ref)?;
        self.clamp_reference = x_ref.to_vec();
        self.angle_relaxation = None;
        Ok(())
    }

    /// An assembler over this system's unknowns for `model` (this system's mesh and form, e.g.
    /// with damping off) that holds the system's clamped directors (model.md §1.3): per-face
    /// diagnostics then match the system's energy.
    pub fn assembler_for(&self, model: &ShellModel) -> Result<Assembler, EnergyError> {
        let mut assembler = Assembler::for_model(&self.mesh, &self.dofs, model)?;
        if self.has_edge_unknowns() {
            assembler.clamp_edges(&self.boundary.clamped_edges, self.clamp_reference())?;
        }
        assembler.set_mirror_edges(&self.boundary.mirror_normals())?;
        Ok(assembler)
    }

    /// Positions at which the clamped directors are held.
    fn clamp_reference(&self) -> &[Vector3<f64>] {
        if self.clamp_reference.is_empty() {
            self.mesh.positions()
        } else {
            &self.clamp_reference
        }
    }

    /// Builds the dof map, lumped masses, external forces and the assembler. With an
    /// edge-director second fundamental form and bending on, the unknowns include one angle
    /// per edge, except on clamped edges (fixed at 0; their directors are held, model.md §1.3)
    /// and on fitted free edges (model.md §1.2); pins leave the angles free.
    pub fn new(
        mesh: Mesh,
        model: ShellModel,
        rest: RestState,
        boundary: Boundary,
        loads: Loads,
    ) -> Result<ShellSystem, SolverError> {
        check_rest(&mesh, &model, &rest)?;
        let directors = ShellSystem::has_edge_unknowns_for(&model);
        let mut dofs = boundary.dof_map(&mesh, !directors)?;
        if directors {
            dofs = dofs.with_edges(mesh.n_edges(), boundary.fixed_angle_edges(&mesh))?;
        }
        let mass = lumped_mass(&mesh, &rest, &model.material)?;
        let f_ext = loads.forces(&mass)?;
        let mut assembler = Assembler::for_model(&mesh, &dofs, &model)?;
        if directors {
            // The clamp holds the directors of the clamped edges (model.md §1.3).
            assembler.clamp_edges(&boundary.clamped_edges, mesh.positions())?;
        }
        // Every bending form sees the mirrored shell across a mirror edge (§1.4).
        assembler.set_mirror_edges(&boundary.mirror_normals())?;
        let angle_scale = mean_edge_length(&mesh);
        Ok(ShellSystem {
            mesh,
            model,
            rest,
            boundary,
            loads,
            dofs,
            mass,
            f_ext,
            load_factor: 1.0,
            assembler,
            angle_scale,
            angle_relaxation: None,
            angles: Vec::new(),
            clamp_reference: Vec::new(),
            contact: None,
            contact_pattern: None,
            contact_approximated: 0,
            contact_pattern_rebuilds: 0,
        })
    }

    /// Whether a system of `model` has one edge-director angle per edge among its unknowns:
    /// an edge-director second fundamental form with bending on (without bending the angles do
    /// not enter the energy). The one definition of the test, for callers that need it before
    /// a system exists (the scene runner's initial energy).
    pub fn has_edge_unknowns_for(model: &ShellModel) -> bool {
        model.has_edge_unknowns()
    }

    /// Whether the unknowns include one edge-director angle per edge.
    pub fn has_edge_unknowns(&self) -> bool {
        self.assembler.has_edge_unknowns()
    }

    /// Turns contact on (or replaces it) with `settings`, checking that the starting positions
    /// `x0` (m) are intersection-free; the error names the first intersecting pair (and the
    /// system keeps its contact term as it was).
    ///
    /// Replacing a term — obstacles moved between solves, self-contact switched — keeps the
    /// adaptive stiffness κ it has learned when the new settings leave κ adaptive and resolve
    /// to the same d̂ and thickness offset (model.md §7): the next solve starts from that κ
    /// instead of E·h. A fixed `stiffness`, another d̂ or offset, or setting
    /// [`ShellSystem::clear_contact`] before the call start afresh. The widened Hessian
    /// pattern and its counters restart.
    pub fn set_contact(
        &mut self,
        settings: &ContactSettings,
        x0: &[Vector3<f64>],
    ) -> Result<(), SolverError> {
        let m = &self.model.material;
        let mut contact = Contact::new(&self.mesh, m.thickness, m.young, settings)?;
        contact.check(x0)?;
        if let Some(previous) = &self.contact {
            contact.keep_stiffness_of(previous);
        }
        self.contact = Some(contact);
        self.contact_pattern = None;
        self.contact_approximated = 0;
        self.contact_pattern_rebuilds = 0;
        Ok(())
    }

    /// The contact term's statistics at positions `x` (m) with the Hessian counters of this
    /// system; `None` without contact.
    pub fn contact_stats(&self, x: &[Vector3<f64>]) -> Option<ContactStats> {
        self.contact.as_ref().map(|c| ContactStats {
            approximated_pairs: self.contact_approximated,
            pattern_rebuilds: self.contact_pattern_rebuilds,
            ..c.stats(x)
        })
    }

    /// The contact term's run state (κ, the adaptive stiffness's memory, the counters and the
    /// widened Hessian pattern's couplings); `None` without contact.
    pub fn contact_run_state(&self) -> Option<ContactRunState> {
        self.contact.as_ref().map(|c| ContactRunState {
            stiffness: c.stiffness,
            adaptive_initialised: c.adaptive.is_some_and(|a| a.initialised),
            adaptive_last_gap: c.adaptive.map_or(f64::INFINITY, |a| a.last_gap),
            approximated_pairs: self.contact_approximated,
            pattern_rebuilds: self.contact_pattern_rebuilds,
            pattern_couplings: self.contact_pattern.as_ref().map(|p| p.couplings.clone()),
        })
    }

    /// Restores what [`ShellSystem::contact_run_state`] returned (on a system whose contact was
    /// set with the same settings). Errors, leaving the system unchanged: no contact, a
    /// stiffness that is not positive and finite, a coupling out of range.
    pub fn restore_contact_run_state(&mut self, s: &ContactRunState) -> Result<(), SolverError> {
        let n = self.mesh.n_vertices();
        let bad = |what: String| SolverError::from(ContactError::Invalid(what));
        if !(s.stiffness > 0.0 && s.stiffness.is_finite()) {
            return Err(bad(format!("restored stiffness {}", s.stiffness)));
        }
        if let Some(&[a, b]) = s
            .pattern_couplings
            .iter()
            .flatten()
            .find(|&&[a, b]| !(a < b && b < n))
        {
            return Err(bad(format!(
                "restored coupling [{a}, {b}] with {n} vertices"
            )));
        }
        let Some(c) = &mut self.contact else {
            return Err(bad("a contact state for a system without contact".into()));
        };
        c.stiffness = s.stiffness;
        if let Some(a) = &mut c.adaptive {
            a.initialised = s.adaptive_initialised;
            a.last_gap = s.adaptive_last_gap;
        }
        self.contact_approximated = s.approximated_pairs;
        self.contact_pattern_rebuilds = s.pattern_rebuilds;
        self.contact_pattern = s.pattern_couplings.as_ref().map(|couplings| {
            ContactPattern::new(&self.assembler.hessian_template(), &self.dofs, couplings)
        });
        Ok(())
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
    /// metres, scale-free; see [`newton_solve`](thinshell_solver::newton_solve)), because bending forces
    /// and edge-director moments are orders of magnitude below any membrane force scale.
    pub fn force_scale(&self) -> f64 {
        let m = &self.model.material;
        let load: f64 = self.f_ext.iter().map(|f| f.abs()).sum();
        (m.young * m.thickness * self.length_scale()).max(load)
    }

    /// Bounding-box diagonal of the reference mesh (m).
    pub fn length_scale(&self) -> f64 {
        let d = self.mesh.bounding_box().diagonal();
        if d.is_finite() && d > 0.0 { d } else { 1.0 }
    }

    /// Elastic energy terms (J; stretching and bending, no damping) at positions `x`. With
    /// edge unknowns the massless edge angles are at their minimiser φ*(x) for these
    /// positions, the energy the shell has there (model.md §1.1): relaxed by Newton on the
    /// angle block ([`ShellSystem::relax_edge_angles`]) from the angles of the last solve
    /// ([`ShellSystem::edge_angles`]), which then hold the relaxed ones. Errors when the
    /// relaxation fails (never a value at unrelaxed angles).
    pub fn energy(&mut self, x: &[Vector3<f64>]) -> Result<EnergyTerms, SolverError> {
        self.energy_at(x, &[])
    }

    /// Elastic energy terms (J; no damping) at positions `x` and edge angles `phi` (rad, one
    /// per edge; empty: the minimising angles at `x`, as in [`ShellSystem::energy`]; must be
    /// empty without edge unknowns).
    pub fn energy_at(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<EnergyTerms, SolverError> {
        Ok(self.elastic_eval(x, phi, false)?.0)
    }

    /// Elastic energy terms (J; no damping) of every face, in face order, at positions `x`
    /// and edge angles `phi` (rad, one per edge; empty: the minimising angles at `x`, as in
    /// [`ShellSystem::energy`]); they sum to [`ShellSystem::energy_at`]. For energy maps and
    /// per-face studies.
    pub fn face_energies(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<Vec<EnergyTerms>, SolverError> {
        Ok(self.elastic_eval(x, phi, true)?.1)
    }

    /// The model without its damping term (the elastic energy).
    fn elastic_model(&self) -> ShellModel {
        ShellModel {
            terms: Terms {
                damping: false,
                ..self.assembler.terms()
            },
            ..self.model
        }
    }

    /// Elastic energy (and, when `faces`, per-face energies) at `x` and `phi` (empty: the
    /// minimising angles). A system with damping evaluates through a separate elastic-only
    /// assembler, since its own includes the damping term.
    fn elastic_eval(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
        faces: bool,
    ) -> Result<(EnergyTerms, Vec<EnergyTerms>), SolverError> {
        let relaxed;
        let phi = if phi.is_empty() && self.has_edge_unknowns() {
            relaxed = self.relaxed_angles(x)?;
            &relaxed
        } else {
            phi
        };
        let model = self.elastic_model();
        let mut own;
        let assembler = if model.terms == self.assembler.terms() {
            &mut self.assembler
        } else {
            own = self.assembler_for(&model)?;
            &mut own
        };
        let e = assembler.evaluate_with_angles(
            &model,
            x,
            phi,
            &self.rest,
            None,
            EvalOutput::default(),
        )?;
        let per_face = if faces {
            assembler.face_energies().to_vec()
        } else {
            Vec::new()
        };
        Ok((e, per_face))
    }

    /// Edge angles (rad, one per edge) of the last solve on this system (static, implicit or
    /// explicit step, [`Static::solve`](super::Static::solve)) or of the last relaxation by
    /// [`ShellSystem::energy`]; empty before the first and without edge unknowns.
    pub fn edge_angles(&self) -> &[f64] {
        &self.angles
    }

    /// Records `phi` as the angles of the last solve (ignored unless one per edge).
    pub fn keep_angles(&mut self, phi: &[f64]) {
        if self.has_edge_unknowns() && phi.len() == self.n_edge_angles() {
            self.angles.clear();
            self.angles.extend_from_slice(phi);
        }
    }

    /// The minimising edge angles φ*(x) (rad) of the elastic energy at positions `x`, relaxed
    /// from the kept angles (or 0), and kept.
    fn relaxed_angles(&mut self, x: &[Vector3<f64>]) -> Result<Vec<f64>, SolverError> {
        let mut phi = if self.angles.len() == self.n_edge_angles() {
            self.angles.clone()
        } else {
            vec![0.0; self.n_edge_angles()]
        };
        let settings = AngleSettings::default();
        if self.model.terms.damping {
            // The cached angle problem includes damping; the elastic minimiser needs its own.
            let model = self.elastic_model();
            let mut problem =
                AngleRelaxation::new(&self.mesh, &model, &self.boundary, self.clamp_reference())?;
            problem.relax(&model, &self.rest, x, &mut phi, None, &settings)?;
        } else {
            self.relax_edge_angles(x, &mut phi, None, &settings, None)?;
        }
        self.keep_angles(&phi);
        Ok(phi)
    }

    /// The force (N) the supports exert on every held coordinate at `x`:
    /// `R = ∂E/∂x − F_ext − p ∂V/∂x` there (0 on free coordinates).
    /// With edge unknowns the angles are the minimising ones at `x` (see
    /// [`ShellSystem::energy`]).
    pub fn reactions(&mut self, x: &[Vector3<f64>]) -> Result<Vec<f64>, SolverError> {
        self.reactions_at(x, &[])
    }

    /// [`ShellSystem::reactions`] at edge angles `phi` (rad, one per edge; empty: the
    /// minimising angles at `x`).
    pub fn reactions_at(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<Vec<f64>, SolverError> {
        let relaxed;
        let phi = if phi.is_empty() && self.has_edge_unknowns() {
            relaxed = self.relaxed_angles(x)?;
            &relaxed
        } else {
            phi
        };
        let mut g = vec![0.0; self.dofs.n_coordinates()];
        self.assembler.evaluate_with_angles(
            &self.model,
            x,
            phi,
            &self.rest,
            None,
            EvalOutput {
                gradient: Some(&mut g),
                hessian: None,
            },
        )?;
        add_pressure_gradient(
            &self.mesh,
            x,
            self.pressure(),
            unit_axis(&self.loads),
            &mut g,
        );
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

    /// The Hessian's sparsity pattern (lower triangle, all values 0), e.g. to size its
    /// factorisation before a solve: the assembler's, widened by the couplings of nearby
    /// self-contact pairs once a solve with self-contact has built them.
    pub fn hessian_template(&self) -> faer::sparse::SparseColMat<usize, f64> {
        match &self.contact_pattern {
            Some(p) => p.template(),
            None => self.assembler.hessian_template(),
        }
    }

    /// Whether `h` has the pattern of [`ShellSystem::hessian_template`].
    pub(crate) fn has_hessian_pattern(&self, h: &faer::sparse::SparseColMat<usize, f64>) -> bool {
        match &self.contact_pattern {
            Some(p) => p.has_pattern(h),
            None => self.assembler.has_pattern(h),
        }
    }

    /// Makes the Hessian pattern cover every self-contact pair that can become active on the
    /// motion `x` → `x_end` (m; `None`: at `x`): kept when it already does, else rebuilt with
    /// the reach [`PATTERN_REACH`](super::contact_pattern::PATTERN_REACH)·d̂ (model.md §7).
    /// Returns whether it was rebuilt. Nothing to do without self-contact.
    pub(crate) fn refresh_contact_pattern(
        &mut self,
        x: &[Vector3<f64>],
        x_end: Option<&[Vector3<f64>]>,
    ) -> bool {
        let Some(c) = self.contact.as_ref().filter(|c| c.self_contact()) else {
            return false;
        };
        let needed = c.couplings(x, x_end, c.activation);
        if self
            .contact_pattern
            .as_ref()
            .is_some_and(|p| p.covers(&self.dofs, &needed))
        {
            return false;
        }
        let reach = (1.0 + super::contact_pattern::PATTERN_REACH) * c.activation;
        let couplings = c.couplings(x, x_end, reach);
        self.contact_pattern = Some(ContactPattern::new(
            &self.assembler.hessian_template(),
            &self.dofs,
            &couplings,
        ));
        self.contact_pattern_rebuilds += 1;
        true
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

impl ShellSystem {
    /// Minimises the energy over the free edge-director angles `phi` (rad, one per edge; the
    /// start, overwritten with the result) at fixed positions `x` (m), by Newton's method on
    /// the angle block of the Hessian (see [`angles`](super::angles)). `damping`, when the system has
    /// damping on, is the Kelvin–Voigt state of the step. When `gradient` is given it receives
    /// the full gradient (N, then J/rad per edge; length `3·n_vertices + n_edges`) at the
    /// returned angles. Without edge unknowns nothing is done except that gradient.
    ///
    /// Errors: wrong lengths, an invalid configuration, or no convergence within
    /// `settings.max_iterations` ([`SolverError::NewtonDidNotConverge`], whose `residuals`
    /// are the corrections in rad and `last_good` the angles reached).
    pub fn relax_edge_angles(
        &mut self,
        x: &[Vector3<f64>],
        phi: &mut [f64],
        damping: Option<&DampingState>,
        settings: &AngleSettings,
        gradient: Option<&mut [f64]>,
    ) -> Result<AngleReport, SolverError> {
        if !self.has_edge_unknowns() {
            return Err(SolverError::InvalidSetting {
                name: "sff",
                value: 0.0,
                requirement: "edge angles exist only with an edge-director form and bending on",
            });
        }
        let n_edges = self.n_edge_angles();
        for (what, len, expected) in [
            ("positions", x.len(), self.mesh.n_vertices()),
            ("edge angles", phi.len(), n_edges),
        ] {
            if len != expected {
                return Err(SolverError::DimensionMismatch {
                    what,
                    expected,
                    found: len,
                });
            }
        }
        if !(settings.tolerance > 0.0
            && settings.tolerance.is_finite()
            && settings.contraction > 0.0
            && settings.contraction < 1.0)
        {
            return Err(SolverError::InvalidSetting {
                name: "angle settings",
                value: settings.tolerance,
                requirement: "tolerance > 0 and finite, contraction in (0, 1)",
            });
        }
        let mut cache = match self.angle_relaxation.take() {
            Some(c) if c.fits(&self.dofs) => c,
            _ => Box::new(AngleRelaxation::new(
                &self.mesh,
                &self.model,
                &self.boundary,
                self.clamp_reference(),
            )?),
        };
        let result = cache.relax(&self.model, &self.rest, x, phi, damping, settings);
        if let (Ok(_), Some(g)) = (&result, gradient) {
            let full = cache.gradient_full();
            let n = g.len().min(full.len());
            g[..n].copy_from_slice(&full[..n]);
        }
        self.angle_relaxation = Some(cache);
        result
    }

    /// Totals of every [`ShellSystem::relax_edge_angles`] call on this system so far
    /// (evaluations and factorisations; `energies` and `last_correction` of the last call).
    pub fn angle_relaxation_totals(&self) -> AngleReport {
        self.angle_relaxation
            .as_ref()
            .map(|c| c.totals)
            .unwrap_or_default()
    }
}

/// The checks of a rest state for a system of `mesh` and `model`.
fn check_rest(mesh: &Mesh, model: &ShellModel, rest: &RestState) -> Result<(), SolverError> {
    rest.validate(mesh)?;
    // The form is named once: a rest state computed with one form and a model of another
    // would measure bending against the wrong b̄ without a word.
    if let Some(form) = rest.sff.filter(|&s| s != model.sff) {
        return Err(SolverError::FormMismatch {
            rest: form,
            model: model.sff,
        });
    }
    Ok(())
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
