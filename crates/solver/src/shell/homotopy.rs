//! Rest-state continuation of a static solve from a far start ([`Static::continuation`]).
//!
//! A start far from equilibrium (a flat sheet whose rest metric is that of a cone, a strip
//! whose rest curvature rolls it) can lead Newton into the basin of another, higher-energy
//! minimum, or keep it among strongly indefinite Hessians until the iteration limit. The start
//! is, however, the equilibrium of a nearby problem: the one whose rest forms are the start's
//! own forms and whose loads are zero. The continuation walks from that problem to the real one,
//! `rest(s) = (1 − s)·forms(x₀) + s·rest`, loads `s·λ`, solving each sub-problem from the last
//! equilibrium: the physical process (growth or loading applied gradually) that the one-shot
//! solve skipped. Sub-steps start at ½ and halve on failure, down to 2⁻⁶.

use nalgebra::Vector3;
use thinshell_energy::RestState;

use super::system::ShellSystem;
use crate::{NewtonReport, SolverError};

/// Halvings of the continuation sub-step before it gives up (smallest sub-step 2⁻⁶).
pub(crate) const MAX_HALVINGS: u32 = 6;

/// What a continuation did: the report of its last sub-step, with the iterations of all.
pub(crate) struct Continued {
    /// The last sub-step's Newton report; `iterations` summed over every sub-step (failed
    /// ones included), `backtracks`, `rejected_steps` and `factorizations` over the sub-steps
    /// that succeeded.
    pub report: NewtonReport,
    /// Sub-steps solved successfully (the last one at s = 1).
    pub stages: usize,
}

/// Solves the static problem of `system` from `x`, `phi` by continuation from the problem whose
/// rest forms are those of the start and whose loads are zero (module docs). On success `x`,
/// `phi` hold the equilibrium of the real problem; on failure the start. The system's rest
/// forms and load factor are restored either way.
pub(crate) fn solve_by_continuation(
    solve: &mut Solve<'_>,
    system: &mut ShellSystem,
    x: &mut [Vector3<f64>],
    phi: &mut [f64],
) -> Result<Continued, SolverError> {
    let target = system.rest.clone();
    let lambda = system.load_factor();
    let origin = system
        .assembler
        .damping_state(x, phi, system.model.sff, 1.0)
        .map_err(SolverError::objective)?;
    let origin = RestState {
        a_bar: origin.a_prev,
        b_bar: origin.b_prev,
        sff: target.sff,
    };
    let result = walk(solve, system, &origin, &target, lambda, x, phi);
    system.rest = target;
    system.set_load_factor(lambda)?;
    result
}

/// One static solve of `system` from `x`, `phi` (both overwritten).
pub(crate) type Solve<'a> = dyn FnMut(&mut ShellSystem, &mut [Vector3<f64>], &mut [f64]) -> Result<NewtonReport, SolverError>
    + 'a;

fn walk(
    solve: &mut Solve<'_>,
    system: &mut ShellSystem,
    origin: &RestState,
    target: &RestState,
    lambda: f64,
    x: &mut [Vector3<f64>],
    phi: &mut [f64],
) -> Result<Continued, SolverError> {
    let (start_x, start_phi) = (x.to_vec(), phi.to_vec());
    let (mut done, mut step) = (0.0f64, 0.5f64);
    let mut total = (0, 0, 0, 0);
    let mut stages = 0;
    loop {
        let s = (done + step).min(1.0);
        RestState::blend(origin, target, s, &mut system.rest).map_err(SolverError::objective)?;
        system.set_load_factor(s * lambda)?;
        let (keep_x, keep_phi) = (x.to_vec(), phi.to_vec());
        match solve(system, x, phi) {
            Ok(mut report) => {
                total.0 += report.iterations;
                total.1 += report.backtracks;
                total.2 += report.rejected_steps;
                total.3 += report.factorizations;
                stages += 1;
                done = s;
                if done >= 1.0 {
                    (
                        report.iterations,
                        report.backtracks,
                        report.rejected_steps,
                        report.factorizations,
                    ) = total;
                    return Ok(Continued { report, stages });
                }
            }
            Err(e) => {
                total.0 += e.newton_iterations();
                x.copy_from_slice(&keep_x);
                phi.copy_from_slice(&keep_phi);
                let cancelled = matches!(e, SolverError::Cancelled { .. });
                if cancelled || step <= 0.5f64.powi(MAX_HALVINGS as i32) {
                    x.copy_from_slice(&start_x);
                    phi.copy_from_slice(&start_phi);
                    return Err(e);
                }
                step /= 2.0;
            }
        }
    }
}
