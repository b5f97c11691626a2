//! The shell objectives Newton minimises, built in one place: the static potential
//! `E(x) − F_extᵀx − p·V(x)` and the incremental potential of implicit Euler
//! `1/(2Δt²)(x − x̃)ᵀΛ(x − x̃) + E(x) + E_damp(x; xⁿ) − F_extᵀx − p·V(x)` (model.md §3), over the
//! free dofs of a [`ShellSystem`] (edge angles scaled to lengths, see [`ShellSystem::gather`]).

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{DampingState, EnergyError, EnergyTerms, EvalOutput, HessianMode};

use super::loads::{add_pressure_gradient, add_pressure_hessian, enclosed_volume, unit_axis};
use super::system::ShellSystem;
use thinshell_solver::State;
use thinshell_solver::{IterationUpdate, Objective, SolverError};

/// Inertia term of the incremental potential: `1/(2Δt²) (x − x̃)ᵀ Λ (x − x̃)`.
struct Inertia {
    /// x̃ = xⁿ + Δt vⁿ per free dof.
    x_tilde: Vec<f64>,
    /// Λ/Δt² per free dof (kg/s²).
    m_over_dt2: Vec<f64>,
}

/// `E(x) + inertia − F_extᵀx − p·V(x)` over the free dofs; held coordinates and fixed angles
/// are taken from `x_full` and `phi_full`.
pub struct ShellObjective<'a> {
    pub(crate) sys: &'a mut ShellSystem,
    pub(crate) x_full: Vec<Vector3<f64>>,
    /// Edge angles (rad), one per edge with edge unknowns, else empty.
    pub(crate) phi_full: Vec<f64>,
    grad_full: Vec<f64>,
    inertia: Option<Inertia>,
    damping: Option<DampingState>,
    /// Static solves: shift κ·mean|H_dd| added to the Hessian diagonal only (the gradient is
    /// exact, so the minimiser is unchanged); it makes rigid-motion null spaces invertible.
    hessian_shift: f64,
    /// The absolute shift the last Hessian assembly added ([`Objective::hessian_diagonal_shift`]).
    last_shift: f64,
    /// Unit of the reported residuals (N).
    force_scale: f64,
    /// Whether `‖∇‖∞ ≤ tol · force_scale` may end a solve (the caller gave the scale).
    gradient_test: bool,
    pub(crate) last_terms: EnergyTerms,
    /// Self-contact pairs of the last Hessian whose couplings were not in its pattern (added
    /// block-diagonally, see [`Contact::add_hessian`](super::contact::Contact::add_hessian)).
    pub(crate) approximated_pairs: usize,
    /// What [`Objective::hessian`] assembles ([`NewtonSettings::own_hessian`](thinshell_solver::NewtonSettings::own_hessian)).
    mode: HessianMode,
    /// The smallest contact gap at the last iteration's start (m; +∞ without contact), for
    /// the within-solve stiffness update ([`ShellObjective::raise_contact_stiffness`]).
    iteration_gap: f64,
}

impl<'a> ShellObjective<'a> {
    /// The objective over `sys`'s free dofs with the held coordinates of `x` and the fixed
    /// angles of `phi`. `force_scale`: `Some(F)` (N) turns the gradient test on against F;
    /// `None` reports residuals against [`ShellSystem::force_scale`] without the test.
    fn new(
        sys: &'a mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
        inertia: Option<Inertia>,
        damping: Option<DampingState>,
        hessian_shift: f64,
        force_scale: Option<f64>,
    ) -> ShellObjective<'a> {
        if sys.contact.as_ref().is_some_and(|c| c.self_contact()) {
            // The pairs the solve can activate: those near the motion from the start to the
            // inertial prediction (the start alone for a static solve).
            let x_end = inertia.as_ref().map(|i| {
                let (mut y, mut a) = (x.to_vec(), phi.to_vec());
                sys.scatter(&i.x_tilde, &mut y, &mut a);
                y
            });
            sys.refresh_contact_pattern(x, x_end.as_deref());
        }
        let n_coords = sys.dofs.n_coordinates();
        let mut objective = ShellObjective {
            force_scale: force_scale.unwrap_or_else(|| sys.force_scale()),
            gradient_test: force_scale.is_some(),
            sys,
            x_full: x.to_vec(),
            phi_full: phi.to_vec(),
            grad_full: vec![0.0; n_coords],
            inertia,
            damping,
            hessian_shift,
            last_shift: 0.0,
            last_terms: EnergyTerms::default(),
            approximated_pairs: 0,
            mode: HessianMode::Exact,
            iteration_gap: f64::INFINITY,
        };
        objective.adapt_contact_stiffness();
        objective
    }

    /// The adaptive barrier stiffness at the start of a solve (`contact_stiffness.rs`): κ₀ from
    /// the gradient of the objective without contact at the first start with active pairs
    /// pressed together, then doubling while the smallest gap collapses.
    fn adapt_contact_stiffness(&mut self) {
        let Some((mut a, mut kappa, d_hat)) = self
            .sys
            .contact
            .as_ref()
            .and_then(|c| c.adaptive.map(|a| (a, c.stiffness, c.activation)))
        else {
            return;
        };
        let x = self.x_full.clone();
        if !a.initialised
            && let Some(k) = self.balanced_contact_stiffness(&x)
        {
            kappa = k;
            a.initialised = true;
        }
        if let Some(c) = &mut self.sys.contact {
            let gap = c.min_gap(&x);
            if a.initialised {
                kappa = a.update(kappa, gap, d_hat);
            }
            self.iteration_gap = gap;
            c.stiffness = kappa;
            c.adaptive = Some(a);
        }
    }

    /// κ₀ at positions `x` (`contact_stiffness.rs`): the stiffness that carries the load pressing
    /// the active pairs together (the gradient of the objective without contact) at the gap
    /// d̂/2; `None` without active pairs or when nothing presses them.
    fn balanced_contact_stiffness(&mut self, x: &[Vector3<f64>]) -> Option<f64> {
        let (a, d_hat) = self
            .sys
            .contact
            .as_ref()
            .and_then(|c| c.adaptive.map(|a| (a, c.activation)))?;
        let (n, active) = self.sys.contact.as_ref()?.gap_gradient_sum(x);
        if active == 0 {
            return None;
        }
        let u = self.sys.gather(x, &self.phi_full);
        let mut g = vec![0.0; self.n_dofs()];
        let contact = self.sys.contact.take();
        let value = self.gradient(&u, &mut g);
        self.sys.contact = contact;
        if !value.is_ok_and(f64::is_finite) {
            return None;
        }
        let coords = self.sys.dofs.free_coordinates();
        let n_pos = self.sys.dofs.n_free_positions();
        let (mut pressing, mut n2) = (0.0, 0.0);
        for (d, &c) in coords.iter().enumerate().take(n_pos) {
            pressing += g[d] * n[c];
            n2 += n[c] * n[c];
        }
        a.initial(pressing, n2, d_hat)
    }

    /// IPC's barrier-stiffness update within a solve (Li et al. 2020, §4.3), for the adaptive
    /// stiffness: when the smallest gap at iterate `u` is below [`COLLAPSE_FRACTION`]·d̂ and
    /// smaller than at the previous iteration, κ is raised to the larger of 2κ and the κ₀ that
    /// balances the current load at d̂/2 (at most κ_max). Without it a solve whose start does
    /// not yet carry its load (a shell moved against an obstacle, a load applied at once)
    /// keeps the κ of its start and can press a pair to within the CCD's minimum separation
    /// (`contact_indentation.rs`). Returns whether κ changed.
    ///
    /// [`COLLAPSE_FRACTION`]: super::contact_stiffness::COLLAPSE_FRACTION
    fn raise_contact_stiffness(&mut self, u: &[f64]) -> bool {
        let Some((a, kappa, d_hat)) = self
            .sys
            .contact
            .as_ref()
            .and_then(|c| c.adaptive.map(|a| (a, c.stiffness, c.activation)))
        else {
            return false;
        };
        let mut x = self.x_full.clone();
        let mut phi = self.phi_full.clone();
        self.sys.scatter(u, &mut x, &mut phi);
        let gap = self
            .sys
            .contact
            .as_ref()
            .map_or(f64::INFINITY, |c| c.min_gap(&x));
        let last = std::mem::replace(&mut self.iteration_gap, gap);
        if !(gap < super::contact_stiffness::COLLAPSE_FRACTION * d_hat && gap < last) {
            return false;
        }
        let balanced = self.balanced_contact_stiffness(&x);
        let raised = balanced.unwrap_or(0.0).max(2.0 * kappa).min(a.max);
        match &mut self.sys.contact {
            Some(c) if raised > kappa => {
                c.stiffness = raised;
                if let Some(s) = &mut c.adaptive {
                    s.initialised |= balanced.is_some();
                }
                true
            }
            _ => false,
        }
    }

    /// The static potential `E(x) − F_extᵀx − p·V(x)` with the diagonal shift `hessian_shift`
    /// (relative to the mean |H_dd|, Hessian only) against rigid-motion null spaces.
    /// The same objective with its own Hessian assembled in `mode` (default exact).
    pub(crate) fn with_hessian(mut self, mode: HessianMode) -> Self {
        self.mode = mode;
        self
    }

    pub(crate) fn statics(
        sys: &'a mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
        hessian_shift: f64,
        force_scale: Option<f64>,
    ) -> ShellObjective<'a> {
        Self::new(sys, x, phi, None, None, hessian_shift, force_scale)
    }

    /// The incremental potential of one implicit Euler step of length `dt` (s) from `state`,
    /// with the held coordinates of `x1` (the prescribed positions at the end of the step).
    /// Edge angles have no mass: their prediction is the previous angle, their inertia 0.
    /// Kelvin–Voigt damping, when on, is measured from `state`.
    pub(crate) fn incremental(
        sys: &'a mut ShellSystem,
        state: &State,
        x1: &[Vector3<f64>],
        dt: f64,
        force_scale: Option<f64>,
    ) -> Result<ShellObjective<'a>, SolverError> {
        let damping = if sys.model.terms.damping {
            // Through the system's assembler: its clamps enter b^prev as they enter b.
            Some(
                sys.assembler
                    .damping_state(&state.x, &state.phi, sys.model.sff, dt)?,
            )
        } else {
            None
        };
        let coords = sys.dofs.free_coordinates();
        let n3 = 3 * x1.len();
        let u_prev = sys.gather(&state.x, &state.phi);
        let x_tilde = coords
            .iter()
            .zip(&u_prev)
            .map(|(&c, &u)| {
                if c < n3 {
                    u + dt * state.v[c / 3][c % 3]
                } else {
                    u
                }
            })
            .collect();
        let m_over_dt2 = coords
            .iter()
            .map(|&c| {
                if c < n3 {
                    sys.mass[c / 3] / (dt * dt)
                } else {
                    0.0
                }
            })
            .collect();
        let inertia = Inertia {
            x_tilde,
            m_over_dt2,
        };
        Ok(Self::new(
            sys,
            x1,
            &state.phi,
            Some(inertia),
            damping,
            0.0,
            force_scale,
        ))
    }

    /// The inertial prediction x̃ (free dofs) of an incremental potential.
    pub(crate) fn prediction(&self) -> Option<&[f64]> {
        self.inertia.as_ref().map(|i| i.x_tilde.as_slice())
    }
}

impl ShellObjective<'_> {
    fn eval(
        &mut self,
        u: &[f64],
        gradient: bool,
        hessian: Option<&mut SparseColMat<usize, f64>>,
    ) -> Result<EnergyTerms, EnergyError> {
        let mode = self.mode;
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
        let p = self.sys.pressure();
        let mut v = if p == 0.0 {
            0.0
        } else {
            -p * enclosed_volume(&self.sys.mesh, &self.x_full, unit_axis(&self.sys.loads))
        };
        for (d, &c) in coords.iter().enumerate() {
            v -= self.sys.f_ext.get(c).copied().unwrap_or(0.0) * u[d];
            if let Some(i) = &self.inertia {
                let dx = u[d] - i.x_tilde[d];
                v += 0.5 * i.m_over_dt2[d] * dx * dx;
            }
        }
        if let Some(c) = &self.sys.contact {
            v += c.energy(&self.x_full);
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
            Err(e) => Err(e.into()),
        }
    }

    fn gradient(&mut self, u: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        let terms = match self.eval(u, true, None) {
            Ok(t) => t,
            Err(EnergyError::NonFinite { .. }) => {
                g.fill(f64::NAN);
                return Ok(f64::INFINITY);
            }
            Err(e) => return Err(e.into()),
        };
        self.last_terms = terms;
        add_pressure_gradient(
            &self.sys.mesh,
            &self.x_full,
            self.sys.pressure(),
            unit_axis(&self.sys.loads),
            &mut self.grad_full,
        );
        if let Some(c) = &self.sys.contact {
            c.add_gradient(&self.x_full, &mut self.grad_full);
        }
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
        let mode = self.mode;
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
        self.sys.hessian_template()
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

    fn hessian_diagonal_shift(&self) -> f64 {
        self.last_shift
    }

    /// The rigid motions the boundary leaves free: translations unless an obstacle is in
    /// contact, rotations also when no external load (whose work changes under rotation) acts
    /// either.
    fn rigid_modes(&mut self, u: &[f64]) -> Vec<Vec<f64>> {
        let mut x = self.x_full.clone();
        let mut phi = self.phi_full.clone();
        self.sys.scatter(u, &mut x, &mut phi);
        let rotations = self.sys.f_ext.iter().all(|&f| f == 0.0);
        super::rigid::free_rigid_modes(&self.sys.dofs, &x, self.sys.contact.is_none(), rotations)
    }

    /// With the adaptive contact stiffness: raises κ when the smallest gap collapses within the
    /// solve ([`ShellObjective::raise_contact_stiffness`]). With self-contact: when the last
    /// Hessian had to approximate pairs outside its pattern (they came near during the solve),
    /// widen the pattern around the current iterate so that the next Hessian holds them exactly
    /// (`contact_pattern.rs`; a new symbolic factorisation).
    fn begin_iteration(
        &mut self,
        u: &[f64],
        _iteration: usize,
    ) -> Result<IterationUpdate, SolverError> {
        let value_changed = self.raise_contact_stiffness(u);
        if self.approximated_pairs == 0 {
            return Ok(IterationUpdate {
                value_changed,
                pattern_changed: false,
            });
        }
        self.approximated_pairs = 0;
        let mut x = self.x_full.clone();
        let mut phi = self.phi_full.clone();
        self.sys.scatter(u, &mut x, &mut phi);
        Ok(IterationUpdate {
            value_changed,
            pattern_changed: self.sys.refresh_contact_pattern(&x, None),
        })
    }

    /// With contact on: the CCD step limit ([`super::contact::Contact::max_step`]).
    fn max_step(&mut self, u: &[f64], du: &[f64]) -> Result<f64, SolverError> {
        let Some(c) = &self.sys.contact else {
            return Ok(1.0);
        };
        let mut x0 = self.x_full.clone();
        let mut phi = self.phi_full.clone();
        self.sys.scatter(u, &mut x0, &mut phi);
        let end: Vec<f64> = u.iter().zip(du).map(|(a, b)| a + b).collect();
        let mut x1 = x0.clone();
        self.sys.scatter(&end, &mut x1, &mut phi);
        Ok(c.max_step(&x0, &x1)?)
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
    /// The Hessian in `mode` plus pressure, angle scaling, inertia, the static shift and
    /// contact. With self-contact the shell terms are assembled into the assembler-pattern
    /// scratch and copied into `h`, whose pattern is widened by the contact couplings.
    fn hessian_in_mode(
        &mut self,
        u: &[f64],
        h: &mut SparseColMat<usize, f64>,
        mode: HessianMode,
    ) -> Result<(), SolverError> {
        let mut scratch = match &mut self.sys.contact_pattern {
            Some(p) if p.has_pattern(h) => p.scratch.take(),
            _ => None,
        };
        let result = self.shell_hessian(u, scratch.as_mut().unwrap_or(h), mode);
        if let (Some(p), Some(s)) = (&mut self.sys.contact_pattern, scratch) {
            if result.is_ok() {
                p.widen(&s, h);
            }
            p.scratch = Some(s);
        }
        result?;
        if let Some(c) = &self.sys.contact {
            // The exact Hessian keeps each pair's own (indefinite) curvature; the PSD modes
            // project it per pair, as they do per face.
            let project = mode != HessianMode::Exact;
            self.approximated_pairs = c.add_hessian(&self.x_full, &self.sys.dofs, h, project);
            self.sys.contact_approximated = self.approximated_pairs;
        }
        Ok(())
    }

    /// The shell part of [`hessian_in_mode`](Self::hessian_in_mode), in the assembler's pattern.
    fn shell_hessian(
        &mut self,
        u: &[f64],
        h: &mut SparseColMat<usize, f64>,
        mode: HessianMode,
    ) -> Result<(), SolverError> {
        self.eval_mode(u, false, Some(h), mode)?;
        add_pressure_hessian(
            &self.sys.mesh,
            &self.sys.assembler,
            &self.x_full,
            self.sys.pressure(),
            unit_axis(&self.sys.loads),
            h,
        )?;
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
        self.last_shift = 0.0;
        if self.hessian_shift > 0.0 && !offsets.is_empty() {
            let mean = offsets.iter().map(|&o| val[o].abs()).sum::<f64>() / offsets.len() as f64;
            self.last_shift = self.hessian_shift * mean;
            for &o in offsets {
                val[o] += self.last_shift;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::{Boundary, Loads};
    use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
    use thinshell_mesh::generators;

    /// Gradient and Hessian of the static and implicit objectives with pressure (both volume
    /// measures), gravity and a point force against central differences.
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
            terms: Terms::ELASTIC,
            sff,
        };
        let loads = Loads {
            gravity: Vector3::new(0.0, 0.0, -9.81),
            point_forces: vec![(
                thinshell_mesh::VertexId::new(3),
                Vector3::new(0.1, 0.2, -0.3),
            )],
            pressure: 7.0,
            pressure_axis: None,
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
        // Both volume measures of the pressure: the cone over the origin and a tube's.
        for (axis, inertia) in [None, Some(Vector3::new(0.2, -0.1, 1.0))]
            .into_iter()
            .flat_map(|a| [(a, false), (a, true)])
        {
            sys.loads.pressure_axis = axis;
            let u0 = sys.gather(&x, &[]);
            let inertia = inertia.then(|| Inertia {
                x_tilde: u0.iter().map(|v| v + 0.01).collect(),
                m_over_dt2: (0..n).map(|d| 1.0 + d as f64 * 0.01).collect(),
            });
            let mut obj = ShellObjective::new(&mut sys, &x, &[], inertia, None, 0.0, Some(1.0));
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

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod contact_tests {
    use super::*;
    use crate::contact::ContactSettings;
    use crate::{Boundary, Loads};
    use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
    use thinshell_mesh::generators;

    /// Two sheets 2.5 mm apart (gap between surfaces 1.5 mm < d̂ = 4 mm): the exact Hessian of
    /// the static potential, with the self-contact pairs' off-diagonal blocks in the widened
    /// pattern, against central differences of the gradient, every column.
    #[test]
    fn self_contact_hessian_is_exact_in_the_widened_pattern() {
        let mesh = generators::stacked_sheets(0.1, 4, 0.0025, 0.3).unwrap();
        let sff = SffKind::MidEdgeAverage;
        let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
        let model = ShellModel {
            material: Material {
                thickness: 1e-3,
                young: 1e4,
                poisson: 0.3,
                ..Material::paper()
            },
            terms: Terms::ELASTIC,
            sff,
        };
        let x: Vec<Vector3<f64>> = mesh
            .positions()
            .iter()
            .enumerate()
            .map(|(i, p)| p + Vector3::new(0.0, 0.0, 2e-4 * ((i as f64) * 0.9).sin()))
            .collect();
        let mut sys =
            ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default()).unwrap();
        let settings = ContactSettings {
            distance: Some(0.004),
            stiffness: Some(10.0),
            ..ContactSettings::default()
        };
        sys.set_contact(&settings, &x).unwrap();
        let active = sys.contact.as_ref().unwrap().stats(&x).active_pairs;
        let n = sys.dofs.n_free();
        let u0 = sys.gather(&x, &[]);
        let mut obj = ShellObjective::statics(&mut sys, &x, &[], 0.0, Some(1.0));
        let extra = obj.sys.contact_pattern.as_ref().unwrap().extra_entries();
        assert!(
            active > 50 && extra > 0,
            "{active} active pairs, {extra} extra entries"
        );
        // The same Hessian in the shell's own pattern: the pairs fall back to their diagonal
        // blocks (the approximation before the widened pattern), measurably off.
        let mut narrow = obj.sys.assembler.hessian_template();
        obj.hessian(&u0, &mut narrow).unwrap();
        assert!(obj.approximated_pairs > 50, "{}", obj.approximated_pairs);
        let mut h = obj.hessian_template();
        obj.hessian(&u0, &mut h).unwrap();
        assert_eq!(obj.approximated_pairs, 0);
        let (mut gp, mut gm) = (vec![0.0; n], vec![0.0; n]);
        let eps = 1e-7;
        let mut worst = 0.0f64;
        let mut worst_narrow = 0.0f64;
        for d in 0..n {
            let col = column(&h, d);
            let mut up = u0.clone();
            up[d] += eps;
            let mut um = u0.clone();
            um[d] -= eps;
            obj.gradient(&up, &mut gp).unwrap();
            obj.gradient(&um, &mut gm).unwrap();
            let scale = col.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let narrow_col = column(&narrow, d);
            for i in 0..n {
                let fd = (gp[i] - gm[i]) / (2.0 * eps);
                worst = worst.max((fd - col[i]).abs() / scale);
                worst_narrow = worst_narrow.max((fd - narrow_col[i]).abs() / scale);
            }
        }
        eprintln!("relative Hessian error: widened {worst:e}, shell pattern {worst_narrow:e}");
        assert!(worst < 1e-5, "largest relative Hessian error {worst:e}");
        assert!(worst_narrow > 1e-2, "{worst_narrow:e}");
    }

    /// Column `d` of the symmetric matrix stored as its lower triangle.
    fn column(h: &SparseColMat<usize, f64>, d: usize) -> Vec<f64> {
        let mut col = vec![0.0; h.ncols()];
        for j in 0..h.ncols() {
            for p in h.symbolic().col_range(j) {
                let i = h.symbolic().row_idx()[p];
                if j == d {
                    col[i] += h.val()[p];
                }
                if i == d && i != j {
                    col[j] += h.val()[p];
                }
            }
        }
        col
    }
}
