//! The shell objectives Newton minimises, built in one place: the static potential
//! `E(x) − F_extᵀx − p·V(x)` and the incremental potential of implicit Euler
//! `1/(2Δt²)(x − x̃)ᵀΛ(x − x̃) + E(x) + E_damp(x; xⁿ) − F_extᵀx − p·V(x)` (model.md §3), over the
//! free dofs of a [`ShellSystem`] (edge angles scaled to lengths, see [`ShellSystem::gather`]).

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{DampingState, EnergyError, EnergyTerms, EvalOutput, HessianMode};

use super::loads::{add_pressure_gradient, add_pressure_hessian, enclosed_volume};
use super::system::{ShellSystem, State};
use crate::{Objective, SolverError};

/// Inertia term of the incremental potential: `1/(2Δt²) (x − x̃)ᵀ Λ (x − x̃)`.
struct Inertia {
    /// x̃ = xⁿ + Δt vⁿ per free dof.
    x_tilde: Vec<f64>,
    /// Λ/Δt² per free dof (kg/s²).
    m_over_dt2: Vec<f64>,
}

/// `E(x) + inertia − F_extᵀx − p·V(x)` over the free dofs; held coordinates and fixed angles
/// are taken from `x_full` and `phi_full`.
pub(crate) struct ShellObjective<'a> {
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
    /// Unit of the reported residuals (N).
    force_scale: f64,
    /// Whether `‖∇‖∞ ≤ tol · force_scale` may end a solve (the caller gave the scale).
    gradient_test: bool,
    pub(crate) last_terms: EnergyTerms,
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
        let n_coords = sys.dofs.n_coordinates();
        ShellObjective {
            force_scale: force_scale.unwrap_or_else(|| sys.force_scale()),
            gradient_test: force_scale.is_some(),
            sys,
            x_full: x.to_vec(),
            phi_full: phi.to_vec(),
            grad_full: vec![0.0; n_coords],
            inertia,
            damping,
            hessian_shift,
            last_terms: EnergyTerms::default(),
        }
    }

    /// The static potential `E(x) − F_extᵀx − p·V(x)` with the diagonal shift `hessian_shift`
    /// (relative to the mean |H_dd|, Hessian only) against rigid-motion null spaces.
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
        let p = self.sys.pressure();
        let mut v = if p == 0.0 {
            0.0
        } else {
            -p * enclosed_volume(&self.sys.mesh, &self.x_full)
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
    /// The Hessian in `mode` plus pressure, angle scaling, inertia and the static shift.
    fn hessian_in_mode(
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
            h,
        )?;
        if let Some(c) = &self.sys.contact {
            c.add_hessian(&self.x_full, &self.sys.dofs, h);
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
    use crate::{Boundary, Loads};
    use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
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
