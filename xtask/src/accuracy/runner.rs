//! Building a shell system and solving it: static equilibrium and time stepping, with
//! the knobs the study varies and the cost of each run.

use std::time::Instant;

use anyhow::{Result, anyhow};
use thinshell::reference::rms_distance_modulo_rigid;
use thinshell_energy::{HessianMode, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::Mesh;
use thinshell_solver::{Integrator, NewtonSettings, SolverError, State, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};

use super::study::{Run, STATIC_TOLERANCE, V3};

#[derive(Clone, Copy, Debug)]
pub(super) struct Knobs {
    pub(super) tolerance: f64,
    pub(super) hessian: HessianMode,
    pub(super) line_search: bool,
}

impl Knobs {
    pub(super) fn tight() -> Knobs {
        Knobs {
            tolerance: STATIC_TOLERANCE,
            hessian: HessianMode::Exact,
            line_search: true,
        }
    }
    pub(super) fn hessian_name(&self) -> &'static str {
        match self.hessian {
            // The solver's default policy with the exact Hessian as its own: exact where it
            // factorises and its steps hold, Gauss–Newton elsewhere.
            HessianMode::Exact => "adaptive",
            HessianMode::GaussNewton => "Gauss-Newton",
            HessianMode::ProjectedPsd => "projected",
        }
    }
    pub(super) fn label(&self) -> String {
        format!(
            "tol {:.0e}, {} Hessian, line search {}",
            self.tolerance,
            self.hessian_name(),
            if self.line_search { "on" } else { "off" }
        )
    }
    pub(super) fn settings(&self, max_iterations: usize) -> NewtonSettings {
        NewtonSettings {
            gradient_tolerance: self.tolerance,
            line_search: self.line_search,
            max_iterations,
            own_hessian: self.hessian,
            ..NewtonSettings::default()
        }
    }
}

/// What a solve or a run of steps cost.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Cost {
    pub(super) wall_s: f64,
    pub(super) iterations: usize,
    pub(super) steps: usize,
    pub(super) ok: bool,
}

pub(super) fn paper(thickness: f64) -> Material {
    Material {
        thickness,
        ..Material::paper()
    }
}

/// The elastic shell (stretching + bending, no inertia) of `mesh` with rest forms `rest`: the
/// one system builder of the accuracy and verification studies.
pub(crate) fn shell(
    mesh: Mesh,
    rest: RestState,
    sff: SffKind,
    material: Material,
    boundary: Boundary,
    loads: Loads,
) -> Result<ShellSystem> {
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff,
    };
    Ok(ShellSystem::new(mesh, model, rest, boundary, loads)?)
}

pub(super) fn iterations_of(e: &SolverError) -> usize {
    match e {
        SolverError::NewtonDidNotConverge { iterations, .. } => *iterations,
        _ => 0,
    }
}

/// Static equilibrium from `x` and, for edge-director forms, the edge angles `phi` (both
/// overwritten by the solution, or the last accepted iterate on failure; an empty `phi` starts
/// from zero angles).
pub(super) fn static_solve(
    sys: &mut ShellSystem,
    x: &mut [V3],
    phi: &mut Vec<f64>,
    k: Knobs,
    max_iterations: usize,
) -> Cost {
    let mut st = Static {
        newton: k.settings(max_iterations),
        // The knob's tolerance is a gradient test against the solver's one force scale, on top
        // of the solver's scale-free convergence test.
        force_scale: Some(sys.force_scale()),
        ..Static::default()
    };
    phi.resize(sys.n_edge_angles(), 0.0);
    let t0 = Instant::now();
    let r = st.solve_with_angles(sys, x, phi);
    let wall_s = t0.elapsed().as_secs_f64();
    match r {
        Ok(rep) => Cost {
            wall_s,
            iterations: rep.iterations,
            steps: 1,
            ok: true,
        },
        Err(e) => Cost {
            wall_s,
            iterations: iterations_of(&e),
            steps: 1,
            ok: false,
        },
    }
}

/// Steps `state` with `integrator`, stopping at each of `checkpoints` (step counts, ascending)
/// to call `at` with the cost so far (step time only). Stops at the first failed step.
pub(super) fn integrate(
    sys: &mut ShellSystem,
    integrator: &mut dyn Integrator<ShellSystem>,
    state: &mut State,
    checkpoints: &[usize],
    mut at: impl FnMut(&State, Cost) -> Result<()>,
) -> Result<Cost> {
    let mut cost = Cost {
        ok: true,
        ..Cost::default()
    };
    let last = checkpoints.last().copied().unwrap_or(0);
    let mut next = 0;
    while cost.steps < last {
        let t0 = Instant::now();
        let r = integrator.step(sys, state);
        cost.wall_s += t0.elapsed().as_secs_f64();
        match r {
            Ok(rep) => {
                cost.iterations += rep.newton.map_or(0, |n| n.iterations);
                cost.steps += 1;
            }
            Err(e) => {
                cost.iterations += iterations_of(&e);
                cost.ok = false;
                at(state, cost)?;
                return Ok(cost);
            }
        }
        if !state.x.iter().all(|p| p.iter().all(|c| c.is_finite())) {
            cost.ok = false;
            at(state, cost)?;
            return Ok(cost);
        }
        if next < checkpoints.len() && cost.steps == checkpoints[next] {
            at(state, cost)?;
            next += 1;
        }
    }
    Ok(cost)
}

/// Elastic energy (J) of `x` and edge angles `phi` (empty: none or all 0), `None` if it cannot
/// be evaluated.
pub(super) fn elastic(sys: &mut ShellSystem, x: &[V3], phi: &[f64]) -> Option<f64> {
    sys.energy_at(x, phi).ok().map(|e| e.stretch + e.bend)
}

/// Of the converged runs on one mesh, the error of the one with the lowest final energy (the
/// equilibrium shape is the energy minimiser; different Hessians may stop at different
/// stationary points).
pub(super) fn best_equilibrium(runs: &[Run]) -> Option<f64> {
    runs.iter()
        .filter(|r| r.converged)
        .min_by(|a, b| {
            a.energy
                .unwrap_or(f64::INFINITY)
                .total_cmp(&b.energy.unwrap_or(f64::INFINITY))
        })
        .map(|r| r.error)
}

pub(super) fn rms_rigid(x: &[V3], y: &[V3]) -> Result<f64> {
    rms_distance_modulo_rigid(x, y).ok_or_else(|| anyhow!("cannot compare positions"))
}

/// RMS distance between corresponding points (no rigid motion removed), m.
pub(super) fn rms(x: &[V3], y: &[V3]) -> f64 {
    let s: f64 = x.iter().zip(y).map(|(p, q)| (p - q).norm_squared()).sum();
    (s / x.len().max(1) as f64).sqrt()
}
