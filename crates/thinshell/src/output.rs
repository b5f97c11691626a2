//! Run output: what `thinshell run` and the Python package write while a [`Simulation`] runs —
//! OBJ/VTK frames with `frames.pvd`, `steps.csv` (its common columns from one table,
//! [`STEPS_CSV_COLUMNS`], then the path-following and contact columns of
//! [`crate::sim::csv_extra_header`]), `summary.json` (one [`Summary`]), the run [`Totals`] and,
//! for resumable runs, `checkpoint.bin` with its [`RunRecord`].
//!
//! [`OutputWriter`] is the one writer; it is an [`Observer`], so [`Simulation::run`] drives it,
//! or a caller that steps the simulation itself calls [`OutputWriter::step`] after every step.
//! The command-line tool (crate `thinshell-cli`) adds the progress bar, Ctrl-C and `resume` on
//! top of it.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use thinshell_solver::SolverError;

use crate::scene::Scene;
use crate::scene::schema::Format;
use crate::sim::{EnergyTerms, Observer, Simulation, StepError, StepFailure, StepRecord};

/// Why writing a run (or the run itself) failed; the command-line tool maps it to its exit
/// code.
#[derive(Debug)]
pub enum Failure {
    /// Bad input: scene, mesh, arguments, an output directory that cannot be created (the
    /// command-line tool's exit code 2).
    BadInput(String),
    /// The simulation or its output failed after starting (exit code 1); the last good state
    /// was written.
    Simulation(String),
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::BadInput(m) | Failure::Simulation(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Failure {}

/// Name of the checkpoint file in the output directory.
pub const CHECKPOINT_FILE: &str = "checkpoint.bin";

/// How often a run writes `checkpoint.bin` (`thinshell run --checkpoint-every`).
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

/// One of the common columns of `steps.csv`: its name, whether it is a wall time (those vary
/// from run to run; every other column is deterministic) and its value in a step's row.
#[derive(Clone, Copy)]
pub struct Column {
    /// The header name (units as a suffix: `_J`, `_s`).
    pub name: &'static str,
    /// A wall time (not reproducible between runs).
    pub timing: bool,
    /// The cell of one step.
    pub value: fn(&StepRecord) -> String,
}

impl std::fmt::Debug for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Column")
            .field("name", &self.name)
            .field("timing", &self.timing)
            .finish()
    }
}

macro_rules! column {
    ($name:literal, $timing:literal, |$r:ident| $value:expr) => {
        Column {
            name: $name,
            timing: $timing,
            value: |$r: &StepRecord| $value,
        }
    };
}

/// The common columns of `steps.csv`, in order: the one table that names them and formats their
/// cells. Floats are written with `{:e}` (round-trip exact). `wall_s` = `assembly_s +
/// factorization_s + solve_s + line_search_s + growth_s + output_s + other_s`.
pub const STEPS_CSV_COLUMNS: [Column; 24] = [
    column!("step", false, |r| r.step.to_string()),
    column!("time_s", false, |r| format!("{:e}", r.time)),
    column!("stretch_J", false, |r| format!("{:e}", r.energy.stretch)),
    column!("bend_J", false, |r| format!("{:e}", r.energy.bend)),
    column!("damping_J", false, |r| format!("{:e}", r.energy.damping)),
    column!("kinetic_J", false, |r| format!("{:e}", r.kinetic)),
    column!("newton_iterations", false, |r| r
        .newton_iterations
        .to_string()),
    column!("backtracks", false, |r| r.backtracks.to_string()),
    column!("regularizations", false, |r| r.regularizations.to_string()),
    column!("residual", false, |r| format!("{:e}", r.residual)),
    column!("wall_s", true, |r| format!("{:e}", r.wall_s)),
    column!("assembly_s", true, |r| format!("{:e}", r.assembly_s)),
    column!("factorization_s", true, |r| format!(
        "{:e}",
        r.factorization_s
    )),
    column!("solve_s", true, |r| format!("{:e}", r.solve_s)),
    column!("load_factor", false, |r| r.load_factor.to_string()),
    column!("line_search_s", true, |r| format!("{:e}", r.line_search_s)),
    column!("growth_s", true, |r| format!("{:e}", r.growth_s)),
    column!("output_s", true, |r| format!("{:e}", r.output_s)),
    column!("other_s", true, |r| format!("{:e}", r.other_s)),
    column!("gauss_newton_iterations", false, |r| r
        .gauss_newton_iterations
        .to_string()),
    column!("shifted_iterations", false, |r| r
        .shifted_iterations
        .to_string()),
    column!("negative_curvature_iterations", false, |r| r
        .negative_curvature_iterations
        .to_string()),
    column!("rejected_steps", false, |r| r.rejected_steps.to_string()),
    column!("min_eigenvalue", false, |r| r
        .min_eigenvalue
        .map(|v| format!("{v:e}"))
        .unwrap_or_default()),
];

/// The common part of `steps.csv`'s header (the names of [`STEPS_CSV_COLUMNS`]).
pub fn steps_csv_header() -> String {
    STEPS_CSV_COLUMNS.map(|c| c.name).join(",")
}

/// The names of the common columns that are wall times.
pub fn steps_csv_timing_columns() -> Vec<&'static str> {
    STEPS_CSV_COLUMNS
        .iter()
        .filter(|c| c.timing)
        .map(|c| c.name)
        .collect()
}

/// The full header of `sim`'s `steps.csv` (common columns, then path following and contact).
fn full_header(sim: &Simulation) -> String {
    format!(
        "{}{}",
        steps_csv_header(),
        crate::sim::csv_extra_header(sim)
    )
}

/// One row of `steps.csv` (no newline).
fn steps_csv_row(r: &StepRecord) -> String {
    let mut row = STEPS_CSV_COLUMNS.map(|c| (c.value)(r)).join(",");
    row += &crate::sim::csv_extra_row(r);
    row
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

/// The bookkeeping stored in every checkpoint (JSON in the checkpoint's attachment), so that a
/// resumed run continues the same files.
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

impl RunRecord {
    /// The record of a run that has not started: `scene` (absolute path) with `overrides`,
    /// named `scene_origin` in `summary.json`.
    pub fn new(scene: PathBuf, scene_origin: String, overrides: Vec<String>) -> RunRecord {
        RunRecord {
            scene,
            scene_origin,
            overrides,
            csv_rows: 0,
            frames: 0,
            last_frame: None,
            pvd: Vec::new(),
            totals: Totals::default(),
            checkpoint_every: None,
        }
    }
}

/// A sink for the writer's one-line notices (the iterative fallback, an unstable equilibrium).
pub type Notify = Box<dyn Fn(&str) + Send + Sync>;

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
    obj: bool,
    vtk: Option<crate::vtk::Series>,
    csv: std::io::BufWriter<std::fs::File>,
    error: Option<String>,
    frames: usize,
    /// The step of the last frame counted, so that rewriting it (the failure path writes the
    /// last good state, which may already be a frame) does not count it twice.
    last_frame: Option<usize>,
    /// Built at the first VTK frame.
    densities: Option<crate::face_fields::FaceEnergyDensity>,
    /// Rows of `steps.csv` written (after the header).
    csv_rows: usize,
    /// The notice that Newton solves fell back to CG has been given.
    iterative_noticed: bool,
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
    notify: Notify,
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
        writeln!(csv, "{}", full_header(sim)).map_err(|e| io(e, &csv_path))?;
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
        let header = full_header(sim);
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
        let vtk = output.formats.contains(&Format::Vtk).then(|| {
            let mut s = crate::vtk::Series::new(dir, "frames");
            s.set_entries(
                record
                    .pvd
                    .iter()
                    .map(|(t, f)| (f64::from_bits(*t), f.clone()))
                    .collect(),
            );
            s
        });
        OutputWriter {
            dir: dir.to_path_buf(),
            every: output.every,
            obj: output.formats.contains(&Format::Obj),
            vtk,
            csv,
            error: None,
            densities: None,
            frames: record.frames,
            last_frame: record.last_frame,
            csv_rows: record.csv_rows,
            iterative_noticed: false,
            totals: record.totals,
            checkpoint_every,
            scene_hash: crate::sim::scene_hash(scene),
            scene_path: record.scene,
            overrides: record.overrides,
            last_checkpoint: Instant::now(),
            pending_output: 0.0,
            resumed,
            scene_origin: record.scene_origin,
            notify: Box::new(|line| eprintln!("{line}")),
        }
    }

    /// Where the one-line notices go (default: stderr).
    pub fn set_notify(&mut self, notify: Notify) {
        self.notify = notify;
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
        let step = sim.steps_done();
        if self.obj {
            let path = self.dir.join(format!("frame_{step:06}.obj"));
            let mut text = Vec::new();
            if let Err(e) = thinshell_mesh::io::write_obj(sim.mesh(), sim.positions(), &mut text)
                .map_err(|e| e.to_string())
                .and_then(|_| crate::atomic::write_atomic(&path, &text).map_err(|e| e.to_string()))
            {
                self.error = Some(format!("{}: {e}", path.display()));
                return;
            }
        }
        if let Some(series) = &mut self.vtk {
            let displacement: Vec<_> = sim
                .positions()
                .iter()
                .zip(sim.reference_positions())
                .map(|(x, x0)| x - x0)
                .collect();
            let mut cell_scalars = Vec::new();
            // Per-face energy densities (J/m²) for energy maps (`thinshell view`).
            let densities = match self.densities.take() {
                Some(d) => Ok(d),
                None => crate::face_fields::FaceEnergyDensity::new(sim),
            }
            .and_then(|mut d| {
                let values = d.evaluate(sim);
                self.densities = Some(d);
                values
            });
            match densities {
                Ok(d) => {
                    cell_scalars.push(("stretch_density", d.stretch));
                    cell_scalars.push(("bend_density", d.bend));
                }
                // Not fatal: the frame (the last good state after a failure, say) is still
                // worth writing; the viewer names the frame that lacks the arrays.
                Err(e) => eprintln!(
                    "warning: frame at step {step}: {e}; written without energy densities"
                ),
            }
            if let Some(g) = sim.growth() {
                cell_scalars.push(("stimulus_top", g.stimulus().iter().map(|m| m.top).collect()));
                cell_scalars.push((
                    "stimulus_bottom",
                    g.stimulus().iter().map(|m| m.bottom).collect(),
                ));
            }
            let contact_force = sim.system().contact().map(|c| c.forces(sim.positions()));
            if let Some(c) = sim.system().contact() {
                // Per-face smallest contact gap (m, capped at d̂) for `thinshell view`.
                cell_scalars.push(("contact_gap", c.face_gaps(sim.positions())));
            }
            let mut point_vectors = vec![
                ("displacement", displacement.as_slice()),
                ("velocity", sim.velocities()),
            ];
            if let Some(f) = &contact_force {
                point_vectors.push(("contact_force", f));
            }
            let frame = crate::vtk::Frame {
                mesh: sim.mesh(),
                points: sim.positions(),
                point_vectors,
                cell_scalars,
            };
            if let Err(e) = series.write(&format!("frame_{step:06}.vtu"), sim.time(), &frame) {
                self.error = Some(e.to_string());
                return;
            }
        }
        if (self.obj || self.vtk.is_some()) && self.last_frame != Some(step) {
            self.frames += 1;
            self.last_frame = Some(step);
        }
    }

    /// What a resumed run needs to continue this writer's files.
    fn record(&self) -> RunRecord {
        RunRecord {
            scene: self.scene_path.clone(),
            scene_origin: self.scene_origin.clone(),
            overrides: self.overrides.clone(),
            csv_rows: self.csv_rows,
            frames: self.frames,
            last_frame: self.last_frame,
            pvd: self
                .vtk
                .as_ref()
                .map(|s| {
                    s.entries()
                        .iter()
                        .map(|(t, f)| (t.to_bits(), f.clone()))
                        .collect()
                })
                .unwrap_or_default(),
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
        let mut row = steps_csv_row(&r);
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
            (self.notify)(&format!(
                "notice: step {}: the Cholesky factor does not fit in the memory budget; Newton \
                 solves use preconditioned CG ({} CG iterations in this step; convergence is \
                 checked as usual)",
                r.step, r.cg_iterations
            ));
        }
        if r.stable == Some(false) {
            (self.notify)(&format!(
                "warning: step {}: the equilibrium is not a minimum (the exact Hessian is not \
                 positive definite: a saddle, unstable under perturbation)",
                r.step
            ));
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
            self.obj = true;
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
            frames: self.frames,
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

    /// The header as it was written out by hand before the table (the format readers rely on).
    #[test]
    fn the_column_table_gives_the_documented_header() {
        assert_eq!(
            steps_csv_header(),
            "step,time_s,stretch_J,bend_J,damping_J,kinetic_J,newton_iterations,backtracks,regularizations,residual,wall_s,assembly_s,factorization_s,solve_s,load_factor,line_search_s,growth_s,output_s,other_s,gauss_newton_iterations,shifted_iterations,negative_curvature_iterations,rejected_steps,min_eigenvalue"
        );
        assert_eq!(
            steps_csv_timing_columns(),
            [
                "wall_s",
                "assembly_s",
                "factorization_s",
                "solve_s",
                "line_search_s",
                "growth_s",
                "output_s",
                "other_s"
            ]
        );
    }
}
