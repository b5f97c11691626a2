//! What `thinshell resume` and the terminal need beyond the library's run output
//! (`thinshell::output`): reopening an output directory from its checkpoint, the Newton progress
//! shown during long solves, and the one-line reason for a factorisation refused for lack of
//! memory.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use indicatif::ProgressBar;
use thinshell::output::{CHECKPOINT_FILE, CheckpointEvery, Failure, OutputWriter, RunRecord};
use thinshell::sim::{Simulation, StepError, StepFailure};
use thinshell_solver::{IterationHessian, NewtonProgress, ProgressHook, SolverError};

/// Reopens an output directory for `thinshell resume`: reads and verifies its checkpoint,
/// reloads the scene it names with its overrides (refusing a scene whose hash changed), builds
/// and restores the simulation, and continues its outputs ([`OutputWriter::reopen`] cuts
/// `steps.csv` back to the checkpoint's rows). The checkpoint interval is `checkpoint_every`,
/// else the interrupted run's.
pub(crate) fn reopen(
    dir: &Path,
    checkpoint_every: Option<CheckpointEvery>,
) -> Result<(Simulation, OutputWriter, Option<CheckpointEvery>), Failure> {
    let bad = Failure::BadInput;
    let path = dir.join(CHECKPOINT_FILE);
    if !path.exists() {
        return Err(bad(format!(
            "{}: no checkpoint (run with --checkpoint-every to write one)",
            path.display()
        )));
    }
    let info = thinshell::output::read_checkpoint_info(&path).map_err(|e| bad(e.to_string()))?;
    let record: RunRecord = serde_json::from_slice(&info.attachment)
        .map_err(|e| bad(format!("{}: unreadable run record: {e}", path.display())))?;
    let (scene, mut sim) = crate::load::load(&record.scene, &record.overrides)?;
    let hash = thinshell::output::scene_hash(&scene);
    sim.restore(&path, hash).map_err(|e| bad(e.to_string()))?;
    let checkpoint_every = checkpoint_every.or_else(|| {
        record
            .checkpoint_every
            .as_deref()
            .and_then(|c| c.parse().ok())
    });
    let writer = OutputWriter::reopen(&scene, &sim, dir, record, checkpoint_every)?;
    Ok((sim, writer, checkpoint_every))
}

/// Prints a line above the progress bar, or to stderr (a hidden bar — stderr not a terminal:
/// logs, scripts, CI — drops `println`).
pub(crate) fn say(bar: Option<&ProgressBar>, line: &str) {
    match bar.filter(|b| !b.is_hidden()) {
        Some(bar) => bar.println(line),
        None => eprintln!("{line}"),
    }
}

/// The Newton observer of a run: the progress bar shows the iteration and residual of the
/// current solve; `verbose` prints every iteration. `steps_done` is kept up to date by the
/// writer (the solve in progress is step `steps_done + 1`).
pub(crate) fn progress_hook(
    bar: Option<ProgressBar>,
    verbose: bool,
    steps_done: Arc<AtomicUsize>,
) -> Option<ProgressHook> {
    if bar.is_none() && !verbose {
        return None;
    }
    Some(Arc::new(move |p: &NewtonProgress| {
        let s = steps_done.load(Ordering::Relaxed) + 1;
        let hessian = match p.hessian {
            IterationHessian::Own => "own",
            IterationHessian::Psd => "Gauss-Newton",
            IterationHessian::Shifted => "shifted (trust region)",
            IterationHessian::NegativeCurvature => "negative curvature",
        };
        if let Some(bar) = &bar {
            bar.set_message(format!(
                "step {s}: Newton iteration {}, residual {:.3e}",
                p.iteration, p.residual
            ));
        }
        if verbose {
            let line = format!(
                "step {s} iteration {}: residual {:.3e}, step length {}, Hessian {hessian}{}, {:.3} s",
                p.iteration,
                p.residual,
                p.step_length,
                if p.regularized { " (shifted)" } else { "" },
                p.elapsed.as_secs_f64()
            );
            say(bar.as_ref(), &line);
        }
    }))
}

/// One line for a factorisation refused for lack of memory, naming the mesh and the estimate.
pub(crate) fn memory_refusal(e: &StepError, sim: &Simulation) -> Option<String> {
    match &e.source {
        StepFailure::Solver(SolverError::InsufficientMemory {
            n,
            estimate,
            budget,
        }) => Some(format!(
            "mesh of {} vertices, {} faces ({n} unknowns): the Cholesky factor needs an estimated {} (symbolic analysis), more than the {} available ({}); refused before factorising",
            sim.mesh().n_vertices(),
            sim.mesh().n_faces(),
            thinshell_solver::memory::human_bytes(*estimate),
            thinshell_solver::memory::human_bytes(*budget),
            thinshell_solver::memory::BUDGET_RULE,
        )),
        StepFailure::Solver(SolverError::InsufficientMemoryForIterative {
            n,
            factor_estimate,
            estimate,
            budget,
        }) => Some(format!(
            "mesh of {} vertices, {} faces ({n} unknowns): the Cholesky factor needs an estimated {} (symbolic analysis) and the iterative fallback (preconditioned CG) {}, more than the {} available ({}); refused before factorising",
            sim.mesh().n_vertices(),
            sim.mesh().n_faces(),
            thinshell_solver::memory::human_bytes(*factor_estimate),
            thinshell_solver::memory::human_bytes(*estimate),
            thinshell_solver::memory::human_bytes(*budget),
            thinshell_solver::memory::BUDGET_RULE,
        )),
        _ => None,
    }
}
