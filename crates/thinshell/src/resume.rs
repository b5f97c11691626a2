//! What `thinshell run --checkpoint-every` and `thinshell resume` need beyond the library's
//! checkpoints: when to write them, the output bookkeeping stored in each (rows of `steps.csv`,
//! frames, the `.pvd` list, run totals, the scene and its `--set` overrides), reopening an
//! output directory, the Newton progress shown during long solves, and the honest failure
//! details of `summary.json`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use indicatif::ProgressBar;
use serde::{Deserialize, Serialize};
use thinshell_solver::{IterationHessian, NewtonProgress, ProgressHook, SolverError};

use crate::cli::{CHECKPOINT_FILE, Failure, STEPS_CSV_HEADER};
use crate::scene::Scene;
use crate::sim::{Simulation, StepError, StepFailure, StepRecord};

/// How often `thinshell run --checkpoint-every` writes `checkpoint.bin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CheckpointEvery {
    /// After every N-th step (`--checkpoint-every 100`).
    Steps(usize),
    /// After the first step that ends at least this many seconds after the last checkpoint
    /// (`--checkpoint-every 30s`).
    Seconds(f64),
}

impl std::str::FromStr for CheckpointEvery {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || format!("`{s}`: expected a number of steps (e.g. 100) or seconds (e.g. 30s)");
        match s.trim().strip_suffix('s') {
            Some(secs) => match secs.trim().parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 => Ok(CheckpointEvery::Seconds(v)),
                _ => Err(bad()),
            },
            None => match s.trim().parse::<usize>() {
                Ok(n) if n > 0 => Ok(CheckpointEvery::Steps(n)),
                _ => Err(bad()),
            },
        }
    }
}

impl std::fmt::Display for CheckpointEvery {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CheckpointEvery::Steps(n) => write!(f, "{n}"),
            CheckpointEvery::Seconds(s) => write!(f, "{s}s"),
        }
    }
}

/// Totals over a whole run, across resumes (what `summary.json` reports).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Totals {
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Of which with the Gauss–Newton (PSD) Hessian.
    pub gauss_newton_iterations: usize,
    /// Of which trust-region steps on the shifted exact Hessian (it was indefinite there).
    #[serde(default)]
    pub shifted_iterations: usize,
    /// Of which steps along a direction of negative curvature (leaving a saddle).
    #[serde(default)]
    pub negative_curvature_iterations: usize,
    /// Newton steps tried and rejected (not in `newton_iterations`).
    #[serde(default)]
    pub rejected_steps: usize,
    /// Whether the last static equilibrium is a minimum.
    pub stable: Option<bool>,
    /// Static steps whose equilibrium is not a minimum.
    pub unstable_steps: Vec<usize>,
    /// Wall time of the steps, s (the sum of `steps.csv`'s `wall_s`; varies between runs).
    pub wall_s: f64,
    /// With the `contact` effect: the contact term over the run (absent from checkpoints of
    /// earlier versions, hence the default).
    #[serde(default)]
    pub contact: Option<crate::sim::ContactTotals>,
}

impl Totals {
    /// Adds the totals' fields to a `summary.json` object (the one place that names them).
    pub fn write_into(&self, summary: &mut serde_json::Value) {
        if let (Some(obj), Ok(serde_json::Value::Object(fields))) =
            (summary.as_object_mut(), serde_json::to_value(self))
        {
            obj.extend(fields);
        }
    }

    /// Counts one step.
    pub fn add(&mut self, r: &StepRecord) {
        self.newton_iterations += r.newton_iterations;
        self.gauss_newton_iterations += r.gauss_newton_iterations;
        self.shifted_iterations += r.shifted_iterations;
        self.negative_curvature_iterations += r.negative_curvature_iterations;
        self.rejected_steps += r.rejected_steps;
        self.stable = r.stable;
        if r.stable == Some(false) {
            self.unstable_steps.push(r.step);
        }
        self.wall_s += r.wall_s;
        if let Some(c) = &r.contact {
            self.contact.get_or_insert_default().add(c);
        }
    }
}

/// The CLI's bookkeeping stored in every checkpoint (JSON in the checkpoint's attachment).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunRecord {
    /// The scene file (absolute path).
    pub scene: PathBuf,
    /// The scene as the user named it (for `summary.json`).
    pub scene_origin: String,
    /// Its `--set` overrides.
    pub overrides: Vec<String>,
    /// Rows of `steps.csv` after the header at the checkpoint.
    pub csv_rows: usize,
    /// Frames counted so far.
    pub frames: usize,
    /// Step of the last frame.
    pub last_frame: Option<usize>,
    /// The `.pvd` list: time (f64 bit pattern, so that it round-trips exactly) and file.
    pub pvd: Vec<(u64, String)>,
    /// Run totals so far.
    pub totals: Totals,
    /// The run's `--checkpoint-every`, kept by `resume`.
    pub checkpoint_every: Option<String>,
}

/// Reopens an output directory for `thinshell resume`: reads and verifies its checkpoint,
/// reloads the scene it names with its overrides (refusing a scene whose hash changed), builds
/// and restores the simulation, and truncates `steps.csv` to the checkpoint's rows.
pub(crate) fn reopen(
    dir: &Path,
) -> Result<
    (
        Scene,
        Simulation,
        std::io::BufWriter<std::fs::File>,
        RunRecord,
    ),
    Failure,
> {
    let bad = Failure::BadInput;
    let path = dir.join(CHECKPOINT_FILE);
    if !path.exists() {
        return Err(bad(format!(
            "{}: no checkpoint (run with --checkpoint-every to write one)",
            path.display()
        )));
    }
    let info = crate::sim::read_checkpoint_info(&path).map_err(|e| bad(e.to_string()))?;
    let record: RunRecord = serde_json::from_slice(&info.attachment)
        .map_err(|e| bad(format!("{}: unreadable run record: {e}", path.display())))?;
    let (scene, mut sim) = crate::cli::load(&record.scene, &record.overrides)?;
    let hash = crate::sim::scene_hash(&scene);
    sim.restore(&path, hash).map_err(|e| bad(e.to_string()))?;
    let csv_path = dir.join("steps.csv");
    let io = |e: std::io::Error| bad(format!("{}: {e}", csv_path.display()));
    let text = std::fs::read_to_string(&csv_path).map_err(io)?;
    let mut lines = text.lines();
    let header = format!("{STEPS_CSV_HEADER}{}", crate::sim::csv_extra_header(&sim));
    if lines.next() != Some(header.as_str()) {
        return Err(bad(format!(
            "{}: not the steps.csv of this version (header differs)",
            csv_path.display()
        )));
    }
    let rows: Vec<&str> = lines.take(record.csv_rows).collect();
    if rows.len() != record.csv_rows {
        return Err(bad(format!(
            "{}: {} rows, the checkpoint counts {}",
            csv_path.display(),
            rows.len(),
            record.csv_rows
        )));
    }
    // Rows after the checkpoint are written again by the resumed steps.
    let mut kept = String::with_capacity(text.len());
    kept.push_str(&header);
    kept.push('\n');
    for r in rows {
        kept.push_str(r);
        kept.push('\n');
    }
    crate::atomic::write_atomic(&csv_path, kept.as_bytes()).map_err(io)?;
    let file = std::fs::OpenOptions::new()
        .append(true)
        .open(&csv_path)
        .map_err(io)?;
    let mut csv = std::io::BufWriter::new(file);
    csv.flush().map_err(io)?;
    Ok((scene, sim, csv, record))
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
            match bar.as_ref().filter(|b| !b.is_hidden()) {
                Some(bar) => bar.println(line),
                None => eprintln!("{line}"),
            }
        }
    }))
}

/// The residual history a failed Newton solve carries, if any.
pub(crate) fn residual_history(e: &StepError) -> Option<Vec<f64>> {
    match &e.source {
        StepFailure::Solver(
            SolverError::LineSearchFailed { residuals, .. }
            | SolverError::NewtonDidNotConverge { residuals, .. },
        ) => Some(residuals.clone()),
        _ => None,
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoint_intervals_parse_steps_and_seconds() {
        assert_eq!("100".parse(), Ok(CheckpointEvery::Steps(100)));
        assert_eq!("30s".parse(), Ok(CheckpointEvery::Seconds(30.0)));
        assert_eq!("0.5s".parse(), Ok(CheckpointEvery::Seconds(0.5)));
        for bad in ["0", "-3", "0s", "abc", "s", "infs"] {
            assert!(bad.parse::<CheckpointEvery>().is_err(), "{bad}");
        }
        assert_eq!(CheckpointEvery::Seconds(30.0).to_string(), "30s");
        assert_eq!(CheckpointEvery::Steps(7).to_string(), "7");
    }
}
