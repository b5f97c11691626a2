//! [`OutputWriter`]: a run's `steps.csv` rows ([`super::csv`]), frames (`frames`),
//! checkpoints ([`super::checkpoint`]) and `summary.json` ([`Summary`], [`Totals`]), with the
//! [`Notice`]s a caller may want to show (the writer prints nothing).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use thinshell_solver::SolverError;

use super::Failure;
use super::checkpoint::{CHECKPOINT_FILE, CheckpointEvery, RunRecord, scene_hash};
use super::csv;
use super::frames::Frames;
use crate::scene::Scene;
use crate::sim::{EnergyTerms, Observer, Simulation, StepError, StepFailure, StepRecord};

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
    /// Adds the totals' fields to a `summary.json`-like object.
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

/// How a run ended (`summary.json`'s `status`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RunStatus {
    /// Every requested step was taken.
    Completed,
    /// Stopped early (Ctrl-C, a cancelled solve); resumable from its checkpoint.
    Interrupted,
    /// A step failed; the last good state is written.
    Failed,
    /// The run goes on (a caller that steps the simulation itself wrote a summary midway).
    Running,
}

/// `summary.json`: the run's outcome and its [`Totals`].
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The scene as the user named it.
    pub scene: String,
    /// The scene's name.
    pub name: String,
    /// How the run ended.
    pub status: RunStatus,
    /// The failed step's error.
    pub error: Option<String>,
    /// The step that failed.
    pub failed_step: Option<usize>,
    /// The failed Newton solve's relative residuals, per iteration.
    pub residual_history: Option<Vec<f64>>,
    /// Steps completed.
    pub steps: usize,
    /// Steps requested.
    pub steps_requested: usize,
    /// Time of the last good state, s.
    pub time_s: f64,
    /// Energies of the last good state (the start state when step 1 failed), J.
    pub energy: EnergyTerms,
    /// Frames written.
    pub frames: usize,
    /// Load factor of the last good state.
    pub load_factor: f64,
    /// Totals over the run (flattened into the same object).
    #[serde(flatten)]
    pub totals: Totals,
}

/// The residual history a failed Newton solve carries, if any.
pub fn residual_history(e: &StepError) -> Option<Vec<f64>> {
    match &e.source {
        StepFailure::Solver(
            SolverError::LineSearchFailed { residuals, .. }
            | SolverError::NewtonDidNotConverge { residuals, .. },
        ) => Some(residuals.clone()),
        _ => None,
    }
}

/// Something the writer noticed that its caller may want to show (the command-line tool prints
/// it as one line: its [`Display`](std::fmt::Display)); collected by
/// [`OutputWriter::take_notices`]. None of them is an error of the run.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Notice {
    /// The Cholesky factor did not fit in the memory budget: Newton solves use preconditioned
    /// CG from this step on (given once per writer).
    IterativeFallback {
        /// The first step that used it.
        step: usize,
        /// CG iterations of that step.
        cg_iterations: usize,
    },
    /// A static step's equilibrium is not a minimum (the exact Hessian is not positive
    /// definite).
    Unstable {
        /// The step.
        step: usize,
    },
    /// A traced path (`[path]`) continues through unstable equilibria, as it does past a limit
    /// point: information, said once per run (each point's stability is in `steps.csv`).
    UnstableBranch {
        /// The first unstable point's step.
        step: usize,
    },
    /// A frame was written without some of its fields.
    FieldsMissing {
        /// The frame's step.
        step: usize,
        /// Why, and which fields.
        reason: String,
    },
}

impl std::fmt::Display for Notice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Notice::IterativeFallback {
                step,
                cg_iterations,
            } => write!(
                f,
                "notice: step {step}: the Cholesky factor does not fit in the memory budget; \
                 Newton solves use preconditioned CG ({cg_iterations} CG iterations in this \
                 step; convergence is checked as usual)"
            ),
            Notice::Unstable { step } => write!(
                f,
                "warning: step {step}: the equilibrium is not a minimum (the exact Hessian is \
                 not positive definite: a saddle, unstable under perturbation)"
            ),
            Notice::UnstableBranch { step } => write!(
                f,
                "note: step {step}: the traced path continues through unstable equilibria \
                 (saddles, as past a limit point); steps.csv's `stable` column has each point"
            ),
            Notice::FieldsMissing { step, reason } => {
                write!(f, "warning: frame at step {step}: {reason}")
            }
        }
    }
}

/// Writes a run's outputs (the scene's `[output]`: OBJ/VTK frames with `frames.pvd`,
/// `steps.csv`, `summary.json`, and `checkpoint.bin` when asked) while a [`Simulation`] runs.
///
/// Fresh outputs: [`OutputWriter::create`] (writes the start frame at once, for callers that
/// step the simulation themselves) or [`OutputWriter::for_run`] (the start frame is written
/// by [`Observer::start`] when [`Simulation::run`] drives it); continuing after a checkpoint:
/// [`OutputWriter::reopen`]. Then [`OutputWriter::step`] after every step and
/// [`OutputWriter::finish`] for `summary.json`.
pub struct OutputWriter {
    dir: PathBuf,
    every: usize,
    frames: Frames,
    csv: std::io::BufWriter<std::fs::File>,
    error: Option<String>,
    /// Rows of `steps.csv` written (after the header).
    csv_rows: usize,
    /// The notice that Newton solves fell back to CG has been given.
    iterative_noticed: bool,
    /// A traced path's first unstable point was noted (one line, not a warning per point).
    unstable_path_noticed: bool,
    /// Totals over the whole run (across resumes).
    totals: Totals,
    /// Checkpointing: when, the scene's identity, and the last one written.
    checkpoint_every: Option<CheckpointEvery>,
    scene_hash: u64,
    scene_path: PathBuf,
    overrides: Vec<String>,
    last_checkpoint: Instant,
    /// Output time not yet in a row (a checkpoint written after the previous row).
    pending_output: f64,
    /// A resumed run does not rewrite its start frame.
    resumed: bool,
    /// The scene as the user named it (`summary.json`).
    scene_origin: String,
    /// Notices not yet taken by the caller.
    notices: Vec<Notice>,
}

impl OutputWriter {
    /// Creates `dir`, `steps.csv` (header) and the start frame of `sim`, built from `scene`;
    /// `scene_origin` names the scene in `summary.json`. A `checkpoint.bin` of an earlier run in
    /// `dir` is removed (it would not belong to these outputs).
    pub fn create(
        scene: &Scene,
        sim: &Simulation,
        dir: &Path,
        scene_origin: &str,
    ) -> Result<OutputWriter, Failure> {
        let record = RunRecord::new(
            PathBuf::from(scene_origin),
            scene_origin.to_string(),
            Vec::new(),
        );
        let mut writer = OutputWriter::for_run(scene, sim, dir, record, None)?;
        writer.start(sim);
        match writer.error.take() {
            Some(e) => Err(Failure::BadInput(format!("writing output: {e}"))),
            None => Ok(writer),
        }
    }

    /// Fresh outputs of a run that [`Simulation::run`] will drive: creates `dir` (removing a
    /// stale `checkpoint.bin`) and `steps.csv` with its header; the start frame is written by
    /// [`Observer::start`]. `record` names the scene and its overrides (stored in
    /// checkpoints); with `checkpoint_every` a checkpoint is written at the start and then as
    /// often as it says.
    pub fn for_run(
        scene: &Scene,
        sim: &Simulation,
        dir: &Path,
        record: RunRecord,
        checkpoint_every: Option<CheckpointEvery>,
    ) -> Result<OutputWriter, Failure> {
        let io = |e: std::io::Error, p: &Path| Failure::BadInput(format!("{}: {e}", p.display()));
        std::fs::create_dir_all(dir).map_err(|e| io(e, dir))?;
        // A stale checkpoint of an earlier run in this directory must not be resumed later.
        let stale = dir.join(CHECKPOINT_FILE);
        if stale.exists() {
            std::fs::remove_file(&stale).map_err(|e| io(e, &stale))?;
        }
        let csv_path = dir.join("steps.csv");
        let mut csv = std::io::BufWriter::new(
            std::fs::File::create(&csv_path).map_err(|e| io(e, &csv_path))?,
        );
        writeln!(csv, "{}", csv::header(sim)).map_err(|e| io(e, &csv_path))?;
        Ok(OutputWriter::with_csv(
            scene,
            dir,
            csv,
            record,
            checkpoint_every,
            false,
        ))
    }

    /// Continues the outputs in `dir` of a run restored from its checkpoint (`sim` is built
    /// from `scene` and restored; `record` is the checkpoint's): `steps.csv` is checked to be
    /// this version's and cut back to the checkpoint's rows (later rows are written again by
    /// the resumed steps), and the frame list continues.
    pub fn reopen(
        scene: &Scene,
        sim: &Simulation,
        dir: &Path,
        record: RunRecord,
        checkpoint_every: Option<CheckpointEvery>,
    ) -> Result<OutputWriter, Failure> {
        let bad = Failure::BadInput;
        let csv_path = dir.join("steps.csv");
        let io = |e: std::io::Error| bad(format!("{}: {e}", csv_path.display()));
        let text = std::fs::read_to_string(&csv_path).map_err(io)?;
        let mut lines = text.lines();
        let header = csv::header(sim);
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
        let csv = std::io::BufWriter::new(file);
        Ok(OutputWriter::with_csv(
            scene,
            dir,
            csv,
            record,
            checkpoint_every,
            true,
        ))
    }

    fn with_csv(
        scene: &Scene,
        dir: &Path,
        csv: std::io::BufWriter<std::fs::File>,
        record: RunRecord,
        checkpoint_every: Option<CheckpointEvery>,
        resumed: bool,
    ) -> OutputWriter {
        let output = &scene.file.output;
        OutputWriter {
            dir: dir.to_path_buf(),
            every: output.every,
            frames: Frames::new(dir, output, record.frames, record.last_frame, &record.pvd),
            csv,
            error: None,
            csv_rows: record.csv_rows,
            iterative_noticed: false,
            unstable_path_noticed: false,
            totals: record.totals,
            checkpoint_every,
            scene_hash: scene_hash(scene),
            scene_path: record.scene,
            overrides: record.overrides,
            last_checkpoint: Instant::now(),
            pending_output: 0.0,
            resumed,
            scene_origin: record.scene_origin,
            notices: Vec::new(),
        }
    }

    /// The notices collected since the last call, oldest first (the writer prints nothing:
    /// the command-line tool shows them as lines above its progress bar).
    pub fn take_notices(&mut self) -> Vec<Notice> {
        std::mem::take(&mut self.notices)
    }

    /// The output directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The run's totals so far.
    pub fn totals(&self) -> &Totals {
        &self.totals
    }

    fn frame(&mut self, sim: &Simulation) {
        if self.error.is_some() {
            return;
        }
        match self.frames.write(sim) {
            Ok(None) => {}
            Ok(Some(reason)) => self.notices.push(Notice::FieldsMissing {
                step: sim.steps_done(),
                reason,
            }),
            Err(e) => self.error = Some(e),
        }
    }

    /// What a resumed run needs to continue this writer's files.
    fn record(&self) -> RunRecord {
        RunRecord {
            scene: self.scene_path.clone(),
            scene_origin: self.scene_origin.clone(),
            overrides: self.overrides.clone(),
            csv_rows: self.csv_rows,
            frames: self.frames.count(),
            last_frame: self.frames.last(),
            pvd: self.frames.pvd(),
            totals: self.totals.clone(),
            checkpoint_every: self.checkpoint_every.map(|c| c.to_string()),
        }
    }

    /// Writes `checkpoint.bin` (after `steps.csv` is on disk, so that the rows it counts are).
    /// Errors are kept for [`OutputWriter::finish`].
    pub fn checkpoint(&mut self, sim: &Simulation) {
        if self.error.is_some() {
            return;
        }
        let t = Instant::now();
        let result = self
            .csv
            .flush()
            .and_then(|_| self.csv.get_ref().sync_data())
            .map_err(|e| format!("steps.csv: {e}"))
            .and_then(|_| serde_json::to_vec(&self.record()).map_err(|e| e.to_string()))
            .and_then(|attachment| {
                sim.save_with(
                    &self.dir.join(CHECKPOINT_FILE),
                    self.scene_hash,
                    &attachment,
                )
                .map_err(|e| e.to_string())
            });
        if let Err(e) = result {
            self.error = Some(e);
        }
        self.last_checkpoint = Instant::now();
        self.pending_output += t.elapsed().as_secs_f64();
    }

    fn checkpoint_due(&self, sim: &Simulation) -> bool {
        match self.checkpoint_every {
            None => false,
            // The last step needs none: the run is complete (summary.json says so).
            _ if sim.steps_done() == sim.steps_total() => false,
            Some(CheckpointEvery::Steps(n)) => sim.steps_done() % n == 0,
            Some(CheckpointEvery::Seconds(s)) => self.last_checkpoint.elapsed().as_secs_f64() >= s,
        }
    }

    /// After a completed step: its row of `steps.csv` and, every `[output] every` steps and
    /// at the last, a frame (and a checkpoint when one is due). Output errors are kept for
    /// [`OutputWriter::finish`].
    pub fn step(&mut self, sim: &Simulation, record: &StepRecord) {
        let mut r = record.clone();
        r.add_output(std::mem::take(&mut self.pending_output));
        let t = Instant::now();
        if sim.steps_done() % self.every == 0 || sim.steps_done() == sim.steps_total() {
            self.frame(sim);
        }
        r.add_output(t.elapsed().as_secs_f64());
        self.totals.add(&r);
        let mut row = csv::row(&r);
        row.push('\n');
        if let Err(e) = self
            .csv
            .write_all(row.as_bytes())
            .and_then(|_| self.csv.flush())
        {
            self.error.get_or_insert(format!("steps.csv: {e}"));
        }
        self.csv_rows += 1;
        if self.checkpoint_due(sim) {
            self.checkpoint(sim);
        }
        if r.iterative && !self.iterative_noticed {
            self.iterative_noticed = true;
            self.notices.push(Notice::IterativeFallback {
                step: r.step,
                cg_iterations: r.cg_iterations,
            });
        }
        if r.stable == Some(false) && sim.is_path_following() {
            // Tracing a path past a limit point is asked for: its unstable branch is
            // information, said once.
            if !self.unstable_path_noticed {
                self.unstable_path_noticed = true;
                self.notices.push(Notice::UnstableBranch { step: r.step });
            }
        } else if r.stable == Some(false) {
            self.notices.push(Notice::Unstable { step: r.step });
        }
    }

    /// Writes `summary.json` with `status` and the failed step's error (whose last good state
    /// is then also written as an OBJ frame); may be called again later (a run that goes on).
    /// Errors with the first output error.
    pub fn finish(
        &mut self,
        sim: &Simulation,
        status: RunStatus,
        failed: Option<&StepError>,
    ) -> Result<(), Failure> {
        self.csv
            .flush()
            .map_err(|e| Failure::Simulation(format!("writing output: steps.csv: {e}")))?;
        if failed.is_some() {
            // The last good state, for inspection.
            self.frames.add_obj();
            self.frame(sim);
        }
        let summary = Summary {
            scene: self.scene_origin.clone(),
            name: sim.name().to_string(),
            status,
            error: failed.map(|e| e.to_string()),
            failed_step: failed.map(|e| e.step),
            residual_history: failed.and_then(residual_history),
            steps: sim.steps_done(),
            steps_requested: sim.steps_total(),
            time_s: sim.time(),
            energy: sim.energy(),
            frames: self.frames.count(),
            load_factor: sim.load_factor(),
            totals: self.totals.clone(),
        };
        let summary_path = self.dir.join("summary.json");
        // Through a `Value`, whose keys serde_json orders as it always has for this file.
        let text = serde_json::to_value(&summary)
            .and_then(|v| serde_json::to_string_pretty(&v))
            .map_err(|e| Failure::Simulation(format!("summary.json: {e}")))?;
        crate::atomic::write_atomic(&summary_path, text.as_bytes())
            .map_err(|e| Failure::BadInput(format!("{}: {e}", summary_path.display())))?;
        if let Some(e) = &self.error {
            return Err(Failure::Simulation(format!("writing output: {e}")));
        }
        Ok(())
    }
}

impl Observer for OutputWriter {
    fn start(&mut self, sim: &Simulation) {
        if !self.resumed {
            self.frame(sim);
            if self.checkpoint_every.is_some() {
                self.checkpoint(sim);
            }
        }
    }

    fn step(&mut self, sim: &Simulation, record: &StepRecord) {
        OutputWriter::step(self, sim, record);
    }
}
