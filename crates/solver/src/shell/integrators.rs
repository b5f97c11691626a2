//! Time integrators and the static solver, behind the [`Integrator`] trait.
//!
//! - [`ImplicitEuler`]: minimises the incremental potential
//!   `Φ(x) = 1/(2Δt²)(x − x̃)ᵀΛ(x − x̃) + E(x) + E_damp(x; xⁿ) − F_extᵀx`, `x̃ = xⁿ + Δt vⁿ`
//!   (model.md §3), with Newton; on failure optionally a retry with a fallback Hessian
//!   (e.g. Gauss–Newton), then halving of Δt.
//! - [`ExplicitEuler`]: symplectic Euler `vⁿ⁺¹ = vⁿ + Δt Λ⁻¹(F_ext − ∇E(xⁿ))`,
//!   `xⁿ⁺¹ = xⁿ + Δt vⁿ⁺¹`; conditionally stable. Edge-director angles are relaxed at xⁿ
//!   first (`super::angles`).
//! - [`Static`]: minimises `E(x) − F_extᵀx`. Rigid motions (a null space when too few
//!   coordinates are held) are handled by a small shift `κ·mean|H_dd|` of the Hessian diagonal
//!   only (the gradient is exact, so the equilibrium is unchanged; the iterates simply do not
//!   drift along rigid modes), plus Newton's regularisation when needed; optionally a retry
//!   with a fallback Hessian from the last good iterate.
//!
//! The fallback Hessian exists because the exact Hessian of a badly crumpled or strongly
//! compressed shell is far from positive definite: the diagonal shift that regularisation needs
//! then turns Newton into a slow gradient method. The Gauss–Newton Hessian is positive
//! semi-definite by construction and keeps the curvature information of the forms.

use nalgebra::Vector3;
use thinshell_energy::{DampingState, EnergyTerms, EvalOutput, HessianMode};

use super::angles::AngleSettings;
use super::loads::face_volume_gradient;
use super::system::{Inertia, ShellObjective, ShellSystem, State, energy_error};
use crate::{NewtonReport, NewtonSettings, NewtonWorkspace, Objective, SolverError, newton_solve};

/// What one step did.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// Time at the end of the step (s).
    pub t: f64,
    /// Step length actually taken (s; smaller than requested after adaptive halving).
    pub dt: f64,
    /// The Newton solve (iterations, residuals, backtracks, regularisations, timings);
    /// `None` for explicit steps.
    pub newton: Option<NewtonReport>,
    /// Halvings of Δt before the step succeeded.
    pub halvings: usize,
    /// Hessian of the solve that succeeded: the system's own mode, or the integrator's fallback
    /// mode when the first solve failed (`ShellSystem::hessian_mode` for explicit steps).
    pub hessian: HessianMode,
    /// Energy terms (J) at the end of the step (implicit, static) or its start (explicit).
    pub energies: EnergyTerms,
    /// Static steps: whether the equilibrium is a minimum, i.e. the exact Hessian there (with
    /// the static solver's tiny `hessian_shift` against rigid motions) factorises without a
    /// shift; `Some(false)` is a saddle or maximum (unstable: a perturbation leaves it).
    /// `None` for dynamic steps.
    pub stable: Option<bool>,
}

/// Advances a [`State`] of a [`ShellSystem`] by one step.
pub trait Integrator {
    /// One step; on error `state` is unchanged.
    fn step(
        &mut self,
        system: &mut ShellSystem,
        state: &mut State,
    ) -> Result<StepReport, SolverError>;
}

/// `g −= p ∂V/∂x`: the pressure force enters like an external force.
pub(crate) fn add_pressure_gradient(system: &ShellSystem, x: &[Vector3<f64>], g: &mut [f64]) {
    let p = system.pressure();
    if p == 0.0 {
        return;
    }
    for face in system.mesh.faces() {
        let gv = face_volume_gradient([x[face[0].idx()], x[face[1].idx()], x[face[2].idx()]]);
        for (s, v) in face.iter().enumerate() {
            let base = 3 * v.idx();
            for (gc, gvc) in g[base..base + 3].iter_mut().zip(gv[s].iter()) {
                *gc -= p * gvc;
            }
        }
    }
}

fn check_dt(dt: f64) -> Result<(), SolverError> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(SolverError::InvalidSetting {
            name: "dt",
            value: dt,
            requirement: "must be positive and finite",
        })
    }
}

/// Checks the state's lengths; fills in zero edge angles on a system with edge unknowns when
/// the state has none yet (e.g. from [`State::at_rest`]).
fn check_state(system: &ShellSystem, state: &mut State) -> Result<(), SolverError> {
    let n = system.mesh.n_vertices();
    let n_edges = system.n_edge_angles();
    if state.phi.is_empty() && n_edges > 0 {
        state.phi = vec![0.0; n_edges];
    }
    for (what, len, expected) in [
        ("state.x", state.x.len(), n),
        ("state.v", state.v.len(), n),
        ("state.phi", state.phi.len(), n_edges),
    ] {
        if len != expected {
            return Err(SolverError::DimensionMismatch {
                what,
                expected,
                found: len,
            });
        }
    }
    if let Some(e) = state.phi.iter().position(|p| !p.is_finite()) {
        return Err(SolverError::NonFiniteCoordinate { dof: 3 * n + e });
    }
    Ok(())
}

/// Static equilibrium: minimise `E(x) − F_extᵀx` over the free dofs.
#[derive(Debug)]
pub struct Static {
    /// Newton parameters.
    pub newton: NewtonSettings,
    /// Relative Hessian diagonal shift κ against rigid-motion null spaces (≥ 0).
    pub hessian_shift: f64,
    /// `Some(F)`: also stop when `‖∇‖∞ ≤ gradient_tolerance · F` (N; trust it only when F is
    /// the size of the forces that matter). `None` (default): converge on the Newton correction
    /// or at round-off only (scale-free, see [`newton_solve`]); residuals are reported relative
    /// to [`ShellSystem::force_scale`].
    pub force_scale: Option<f64>,
    /// Hessian mode [`Integrator::step`] retries with, from the last good iterate, when the
    /// solve with the system's mode fails (`None`: no retry).
    pub fallback_hessian: Option<HessianMode>,
    workspace: Option<NewtonWorkspace>,
}

impl Default for Static {
    fn default() -> Self {
        Static {
            newton: NewtonSettings::default(),
            hessian_shift: 1e-10,
            force_scale: None,
            fallback_hessian: None,
            workspace: None,
        }
    }
}

/// The integrator's cached Newton workspace, rebuilt when the number of unknowns changed.
fn workspace<'w>(
    slot: &'w mut Option<NewtonWorkspace>,
    objective: &ShellObjective<'_>,
    settings: &NewtonSettings,
) -> Result<&'w mut NewtonWorkspace, SolverError> {
    if slot
        .as_ref()
        .is_some_and(|ws| ws.n_dofs() != objective.n_dofs())
    {
        *slot = None;
    }
    match slot {
        Some(ws) => Ok(ws),
        None => Ok(slot.insert(NewtonWorkspace::new(objective, settings)?)),
    }
}

/// The last accepted iterate a failed Newton solve carries, if any.
fn last_good(e: &SolverError) -> Option<&[f64]> {
    match e {
        SolverError::LineSearchFailed { last_good, .. }
        | SolverError::NewtonDidNotConverge { last_good, .. } => Some(last_good),
        _ => None,
    }
}

/// The last good iterate of a failed solve, as an owned start for a retry.
fn retry_start<T>(r: &Result<T, SolverError>) -> Option<Vec<f64>> {
    r.as_ref().err().and_then(last_good).map(<[f64]>::to_vec)
}

/// Whether a failure may be cured by another Hessian or a shorter step (not a bad setting or
/// a wrong dimension, which would fail the same way again).
fn retryable(e: &SolverError) -> bool {
    !matches!(
        e,
        SolverError::InvalidSetting { .. }
            | SolverError::DimensionMismatch { .. }
            | SolverError::InvalidForceScale(_)
            | SolverError::InvalidLengthScale(_)
    )
}

/// The fallback mode when it differs from the system's own.
fn fallback_mode(system: &ShellSystem, fallback: Option<HessianMode>) -> Option<HessianMode> {
    fallback.filter(|&m| m != system.hessian_mode)
}

impl Static {
    /// Solves for the equilibrium starting from `x` (overwritten; held coordinates kept). With
    /// edge unknowns the angles start at 0 and are discarded; use
    /// [`Static::solve_with_angles`] to keep them.
    pub fn solve(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
    ) -> Result<NewtonReport, SolverError> {
        let mut phi = vec![0.0; system.n_edge_angles()];
        self.solve_with_angles(system, x, &mut phi)
    }

    /// Solves for the equilibrium starting from positions `x` and edge angles `phi` (rad, one
    /// per edge; empty without edge unknowns), both overwritten.
    pub fn solve_with_angles(
        &mut self,
        system: &mut ShellSystem,
        x: &mut [Vector3<f64>],
        phi: &mut [f64],
    ) -> Result<NewtonReport, SolverError> {
        if phi.len() != system.n_edge_angles() {
            return Err(SolverError::DimensionMismatch {
                what: "edge angles",
                expected: system.n_edge_angles(),
                found: phi.len(),
            });
        }
        if system.model.terms.damping {
            return Err(SolverError::InvalidSetting {
                name: "terms.damping",
                value: 1.0,
                requirement: "a static solve has no damping (build the system without it)",
            });
        }
        if !(self.hessian_shift.is_finite() && self.hessian_shift >= 0.0) {
            return Err(SolverError::InvalidSetting {
                name: "hessian_shift",
                value: self.hessian_shift,
                requirement: "must be non-negative and finite",
            });
        }
        let mut u = system.gather(x, phi);
        let mut obj = self.objective(system, x, phi);
        let ws = workspace(&mut self.workspace, &obj, &self.newton)?;
        let result = newton_solve(&mut obj, &mut u, &self.newton, ws);
        let sys = obj.sys;
        sys.scatter(&u, x, phi);
        result
    }
}

impl Static {
    fn objective<'a>(
        &self,
        system: &'a mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> ShellObjective<'a> {
        let force_scale = self.force_scale.unwrap_or_else(|| system.force_scale());
        let n_coords = system.dofs.n_coordinates();
        ShellObjective {
            sys: system,
            x_full: x.to_vec(),
            phi_full: phi.to_vec(),
            grad_full: vec![0.0; n_coords],
            inertia: None,
            damping: None,
            hessian_shift: self.hessian_shift,
            force_scale,
            gradient_test: self.force_scale.is_some(),
            last_terms: EnergyTerms::default(),
        }
    }

    /// Whether positions `x` and edge angles `phi` (rad, one per edge; empty without edge
    /// unknowns) are a stable equilibrium candidate: the **exact** Hessian of the static
    /// potential there, plus the shift `hessian_shift · mean|H_dd|` that makes rigid motions of
    /// an unheld shell invertible, factorises without further shift. Negative eigenvalues
    /// smaller in magnitude than that shift (1e-10 of the mean diagonal by default, far below
    /// bending stiffness) go unnoticed. Costs one Hessian assembly and factorisation.
    pub fn is_stable(
        &mut self,
        system: &mut ShellSystem,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<bool, SolverError> {
        let u = system.gather(x, phi);
        let own = std::mem::replace(&mut system.hessian_mode, HessianMode::Exact);
        let mut obj = self.objective(system, x, phi);
        let result = workspace(&mut self.workspace, &obj, &self.newton)
            .and_then(|ws| ws.is_positive_definite(&mut obj, &u));
        system.hessian_mode = own;
        result
    }
}

impl Integrator for Static {
    fn step(
        &mut self,
        system: &mut ShellSystem,
        state: &mut State,
    ) -> Result<StepReport, SolverError> {
        check_state(system, state)?;
        let mut x = state.x.clone();
        let mut phi = state.phi.clone();
        system.boundary.apply_prescribed(&mut x, state.t)?;
        let mut hessian = system.hessian_mode;
        // `solve_with_angles` leaves its last iterate in `x`, `phi`, failed or not.
        let (start_x, start_phi) = (x.clone(), phi.clone());
        let report = match self.solve_with_angles(system, &mut x, &mut phi) {
            Ok(r) => r,
            Err(e) => match fallback_mode(system, self.fallback_hessian) {
                Some(mode) if retryable(&e) => {
                    let own = std::mem::replace(&mut system.hessian_mode, mode);
                    hessian = mode;
                    // First from the best point found (line search never increased E), then,
                    // if that fails too, from the start: the failed path may have led into a
                    // region that is hard for any Hessian.
                    let mut retry = Err(e);
                    for from in [retry_start(&retry), None] {
                        if retry.is_ok() {
                            break;
                        }
                        x.copy_from_slice(&start_x);
                        phi.copy_from_slice(&start_phi);
                        if let Some(u) = from {
                            system.scatter(&u, &mut x, &mut phi);
                        }
                        retry = self.solve_with_angles(system, &mut x, &mut phi);
                    }
                    system.hessian_mode = own;
                    retry?
                }
                _ => return Err(e),
            },
        };
        let energies = system.energy_at(&x, &phi)?;
        let stable = self.is_stable(system, &x, &phi)?;
        state.x = x;
        state.phi = phi;
        state.v.iter_mut().for_each(|v| *v = Vector3::zeros());
        Ok(StepReport {
            t: state.t,
            dt: 0.0,
            newton: Some(report),
            halvings: 0,
            hessian,
            energies,
            stable: Some(stable),
        })
    }
}

/// Implicit (backward) Euler by minimisation of the incremental potential.
#[derive(Debug)]
pub struct ImplicitEuler {
    /// Time step Δt (s).
    pub dt: f64,
    /// Newton parameters.
    pub newton: NewtonSettings,
    /// `Some(F)`: also stop when `‖∇‖∞ ≤ gradient_tolerance · F` (N). `None` (default):
    /// converge on the Newton correction or at round-off only (see [`Static::force_scale`]).
    pub force_scale: Option<f64>,
    /// Times Δt may be halved when Newton fails (0: no adaptivity).
    pub max_halvings: usize,
    /// Hessian mode tried at the same Δt, from the last good iterate, when the solve with the
    /// system's mode fails, before Δt is halved (`None`: no retry).
    pub fallback_hessian: Option<HessianMode>,
    workspace: Option<NewtonWorkspace>,
}

impl ImplicitEuler {
    /// Fixed step `dt` (s) with default Newton settings.
    pub fn new(dt: f64) -> ImplicitEuler {
        ImplicitEuler {
            dt,
            newton: NewtonSettings::default(),
            force_scale: None,
            max_halvings: 0,
            fallback_hessian: None,
            workspace: None,
        }
    }

    fn try_step(
        &mut self,
        system: &mut ShellSystem,
        state: &State,
        dt: f64,
        start: Option<&[f64]>,
    ) -> Result<(State, NewtonReport, EnergyTerms), SolverError> {
        let t1 = state.t + dt;
        let mut x1 = state.x.clone();
        system.boundary.apply_prescribed(&mut x1, t1)?;
        let damping = if system.model.terms.damping {
            Some(
                DampingState::from_configuration(
                    &system.mesh,
                    &state.x,
                    &state.phi,
                    system.model.sff,
                    dt,
                )
                .map_err(energy_error)?,
            )
        } else {
            None
        };
        let coords = system.dofs.free_coordinates().to_vec();
        let n3 = 3 * x1.len();
        // Edge angles have no mass: their prediction is the previous angle, their inertia 0.
        let u_prev = system.gather(&state.x, &state.phi);
        let x_tilde: Vec<f64> = coords
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
                    system.mass[c / 3] / (dt * dt)
                } else {
                    0.0
                }
            })
            .collect();
        let mut u = x_tilde.clone();
        let force_scale = self.force_scale.unwrap_or_else(|| system.force_scale());
        let n_coords = system.dofs.n_coordinates();
        let mut phi1 = state.phi.clone();
        let mut obj = ShellObjective {
            sys: system,
            x_full: x1.clone(),
            phi_full: phi1.clone(),
            grad_full: vec![0.0; n_coords],
            inertia: Some(Inertia {
                x_tilde,
                m_over_dt2,
            }),
            damping,
            hessian_shift: 0.0,
            force_scale,
            gradient_test: self.force_scale.is_some(),
            last_terms: EnergyTerms::default(),
        };
        // Start from the given point (a retry), else the inertial prediction x̃ unless it is an
        // invalid (e.g. inverted) configuration; then from xⁿ.
        if let Some(s) = start.filter(|s| s.len() == u.len()) {
            u.copy_from_slice(s);
        } else if !obj.value(&u)?.is_finite() {
            u = u_prev;
        }
        let ws = workspace(&mut self.workspace, &obj, &self.newton)?;
        let report = newton_solve(&mut obj, &mut u, &self.newton, ws)?;
        let energies = obj.last_terms;
        obj.sys.scatter(&u, &mut x1, &mut phi1);
        let v1 = x1.iter().zip(&state.x).map(|(a, b)| (a - b) / dt).collect();
        Ok((
            State {
                x: x1,
                v: v1,
                phi: phi1,
                t: t1,
            },
            report,
            energies,
        ))
    }
}

impl Integrator for ImplicitEuler {
    fn step(
        &mut self,
        system: &mut ShellSystem,
        state: &mut State,
    ) -> Result<StepReport, SolverError> {
        check_dt(self.dt)?;
        check_state(system, state)?;
        let mut dt = self.dt;
        let mut halvings = 0;
        let own = system.hessian_mode;
        loop {
            let mut hessian = own;
            let mut result = self.try_step(system, state, dt, None);
            if let (Err(e), Some(mode)) = (&result, fallback_mode(system, self.fallback_hessian)) {
                if retryable(e) {
                    // As in `Static`: from the last good iterate, then from the usual start.
                    let from_last = retry_start(&result);
                    system.hessian_mode = mode;
                    hessian = mode;
                    result = self.try_step(system, state, dt, from_last.as_deref());
                    if result.is_err() && from_last.is_some() {
                        result = self.try_step(system, state, dt, None);
                    }
                    system.hessian_mode = own;
                }
            }
            match result {
                Ok((next, report, energies)) => {
                    *state = next;
                    return Ok(StepReport {
                        t: state.t,
                        dt,
                        newton: Some(report),
                        halvings,
                        hessian,
                        energies,
                        stable: None,
                    });
                }
                Err(e) if halvings < self.max_halvings && retryable(&e) => {
                    halvings += 1;
                    dt *= 0.5;
                }
                Err(e) => return Err(e),
            }
        }
    }
}

/// Symplectic (semi-implicit) Euler with lumped masses.
///
/// With an edge-director form the massless edge angles are relaxed at xⁿ before the force is
/// taken ([`ShellSystem::relax_edge_angles`], default [`AngleSettings`]): the force is then the
/// gradient of the reduced energy min_φ E(x, φ), so the scheme keeps the energy behaviour of
/// symplectic Euler. The relaxation usually costs one to three gradient evaluations per step
/// and a refactorisation of the small angle Hessian now and then.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExplicitEuler {
    /// Time step Δt (s).
    pub dt: f64,
}

impl Integrator for ExplicitEuler {
    fn step(
        &mut self,
        system: &mut ShellSystem,
        state: &mut State,
    ) -> Result<StepReport, SolverError> {
        let dt = self.dt;
        check_dt(dt)?;
        check_state(system, state)?;
        let n = state.x.len();
        // Damping forces use the previous configuration xⁿ − Δt vⁿ (with this step's starting
        // angles: the previous step's are not kept).
        let damping = if system.model.terms.damping {
            let prev: Vec<Vector3<f64>> = state
                .x
                .iter()
                .zip(&state.v)
                .map(|(x, v)| x - dt * v)
                .collect();
            Some(
                DampingState::from_configuration(
                    &system.mesh,
                    &prev,
                    &state.phi,
                    system.model.sff,
                    dt,
                )
                .map_err(energy_error)?,
            )
        } else {
            None
        };
        let mut phi1 = state.phi.clone();
        let (mut g, energies) = if system.has_edge_unknowns() {
            let mut g = vec![0.0; system.dofs.n_coordinates()];
            let report = system.relax_edge_angles(
                &state.x,
                &mut phi1,
                damping.as_ref(),
                &AngleSettings::default(),
                Some(&mut g),
            )?;
            (g, report.energies)
        } else {
            let mut g = vec![0.0; 3 * n];
            let energies = system
                .assembler
                .evaluate(
                    &system.model,
                    &state.x,
                    &system.rest,
                    damping.as_ref(),
                    EvalOutput {
                        gradient: Some(&mut g),
                        hessian: None,
                    },
                )
                .map_err(energy_error)?;
            (g, energies)
        };
        add_pressure_gradient(system, &state.x, &mut g);
        let t1 = state.t + dt;
        let mut x1 = state.x.clone();
        let mut v1 = state.v.clone();
        for (vtx, (x, v)) in x1.iter_mut().zip(v1.iter_mut()).enumerate() {
            for a in 0..3 {
                let c = 3 * vtx + a;
                if system.dofs.coordinate_dof(c).is_some() {
                    v[a] += dt * (system.f_ext[c] - g[c]) / system.mass[vtx];
                    x[a] += dt * v[a];
                } else {
                    v[a] = 0.0;
                }
            }
        }
        system.boundary.apply_prescribed(&mut x1, t1)?;
        for p in &system.boundary.prescribed {
            let i = p.vertex.idx();
            v1[i] = (x1[i] - state.x[i]) / dt;
        }
        if let Some(c) = x1
            .iter()
            .chain(&v1)
            .flat_map(|p| p.iter())
            .position(|c| !c.is_finite())
        {
            return Err(SolverError::NonFinite {
                what: "explicit state",
                iteration: 0,
                dof: Some(c),
            });
        }
        state.x = x1;
        state.v = v1;
        state.phi = phi1;
        state.t = t1;
        Ok(StepReport {
            t: t1,
            dt,
            newton: None,
            halvings: 0,
            hessian: system.hessian_mode,
            energies,
            stable: None,
        })
    }
}
