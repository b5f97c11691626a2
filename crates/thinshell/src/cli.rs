//! The command implementations behind the `thinshell` binary, as library functions so that they
//! can be tested without spawning processes.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};

use crate::mesh_info::mesh_info;
pub use crate::resume::CheckpointEvery;
use crate::resume::{RunRecord, Totals};
use crate::scene::Scene;
use crate::scene::schema::Format;
use crate::sim::{Energies, Observer, Simulation, StepRecord};

/// Why a command failed; decides the exit code.
#[derive(Debug)]
pub enum Failure {
    /// Bad input: scene, mesh, arguments (exit code 2).
    BadInput(String),
    /// The simulation failed after starting (exit code 1); the last good state was written.
    Simulation(String),
}

/// `thinshell info MESH`: prints statistics and problems of an OBJ mesh.
pub fn info(path: &Path) -> Result<(), Failure> {
    let bad = |e: thinshell_mesh::MeshError| Failure::BadInput(format!("{}: {e}", path.display()));
    let mesh = thinshell_mesh::io::load_obj(path).map_err(bad)?;
    // Statistics of a mesh whose areas overflow would print inf/NaN; say why instead.
    thinshell_mesh::check_scale(&mesh, mesh.positions()).map_err(bad)?;
    println!("{}", path.display());
    println!("{}", mesh_info(&mesh));
    Ok(())
}

/// Loads a scene with overrides and builds it; any problem is bad input.
pub(crate) fn load(scene: &Path, overrides: &[String]) -> Result<(Scene, Simulation), Failure> {
    let scene = Scene::load_with_overrides(scene, overrides)
        .map_err(|e| Failure::BadInput(e.to_string()))?;
    let sim = Simulation::build(&scene).map_err(|e| Failure::BadInput(e.to_string()))?;
    Ok((scene, sim))
}

/// `thinshell check SCENE`: validates a scene and prints what would be simulated.
pub fn check(scene: &Path, overrides: &[String]) -> Result<(), Failure> {
    let (_, sim) = load(scene, overrides)?;
    print!("{}", describe(&sim));
    Ok(())
}

/// A few lines saying what a simulation will compute.
pub fn describe(sim: &Simulation) -> String {
    let mesh = sim.mesh();
    let terms = sim.model().terms;
    let effects: Vec<&str> = sim.effects().iter().map(|e| e.key()).collect();
    let mut on = Vec::new();
    if terms.stretch {
        on.push("stretching");
    }
    let bending = format!("bending ({})", sim.model().sff.name().replace('_', " "));
    if terms.bend {
        on.push(&bending);
    }
    if terms.damping {
        on.push("Kelvin-Voigt damping");
    }
    let n_angles = sim.system().n_edge_angles();
    let n_coordinates = 3 * mesh.n_vertices() + n_angles;
    let mut text = format!(
        "scene: {}\nmesh: {} vertices, {} faces, {} edges\neffects: {}\nenergy terms evaluated: {}\nunknowns: {} (of {} coordinates; {} held){}\nintegrator: {:?}, dt = {:e} s, {} steps\n",
        sim.name(),
        mesh.n_vertices(),
        mesh.n_faces(),
        mesh.n_edges(),
        effects.join(", "),
        on.join(", "),
        sim.n_unknowns(),
        n_coordinates,
        n_coordinates - sim.n_unknowns(),
        if n_angles > 0 {
            let dofs = sim.system().dofs();
            let free_angles = dofs.n_free() - dofs.n_free_positions();
            if free_angles == n_angles {
                format!(", including {n_angles} edge-director angles")
            } else {
                // Free and clamped edges' directors are not unknowns (model.md §1.2-1.3).
                format!(
                    ", including {free_angles} edge-director angles (the other {} edges are free or clamped: their directors are not unknowns)",
                    n_angles - free_angles
                )
            }
        } else {
            String::new()
        },
        sim.integrator(),
        sim.dt(),
        sim.steps_total(),
    );
    let system = sim.system();
    let has_loads = system.loads != thinshell_solver::Loads::default()
        || !system.boundary.prescribed.is_empty();
    if sim.is_path_following() {
        text += &format!(
            "path following: {} steps from load factor 0 (docs/path_following.md)\n",
            sim.steps_total()
        );
    } else if sim.integrator() == crate::scene::schema::IntegratorKind::Static && has_loads {
        let ramp = sim.load_ramp();
        let n = sim.steps_total();
        let factors = match ramp {
            _ if n == 1 => "one step at full load".to_string(),
            crate::scene::schema::LoadRamp::Linear => {
                format!("load factor 1/{n}, 2/{n}, …, 1 over the {n} steps")
            }
            crate::scene::schema::LoadRamp::None => "full loads from the first step".to_string(),
        };
        text += &format!("load ramp: {} ({factors})\n", ramp.key());
    }
    let elastic = |e: thinshell_energy::EnergyTerms| e.stretch + e.bend;
    match sim.initial_energy_grown() {
        // With growth the first step solves against the grown rest forms, not those before
        // growth: the energy the first step starts from is the one that says how far it has to go.
        Some(grown) => {
            text += &format!(
                "initial elastic energy at the grown rest state (what step 1 starts from): {:e} J\ninitial elastic energy against the rest forms before growth: {:e} J\n",
                elastic(grown),
                elastic(sim.energy()),
            );
        }
        None => text += &format!("initial elastic energy: {:e} J\n", elastic(sim.energy())),
    }
    text
}

/// Options of `thinshell run` and `thinshell resume`.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// No progress bar and no final line.
    pub quiet: bool,
    /// Print every Newton iteration (residual, step length, Hessian, time) to stderr.
    pub verbose: bool,
    /// Write `checkpoint.bin` every N steps or seconds (and at the start).
    pub checkpoint_every: Option<CheckpointEvery>,
}

/// The header of `steps.csv`. The timing columns (`wall_s` … `other_s`) vary from run to run;
/// every other column is deterministic. `wall_s` = `assembly_s + factorization_s + solve_s +
/// line_search_s + growth_s + output_s + other_s`.
pub const STEPS_CSV_HEADER: &str = "step,time_s,stretch_J,bend_J,damping_J,kinetic_J,newton_iterations,backtracks,regularizations,residual,wall_s,assembly_s,factorization_s,solve_s,load_factor,line_search_s,growth_s,output_s,other_s,gauss_newton_iterations,shifted_iterations,negative_curvature_iterations,rejected_steps,min_eigenvalue";

/// Names of the `steps.csv` columns that are wall times (not reproducible between runs).
pub const STEPS_CSV_TIMING_COLUMNS: [&str; 8] = [
    "wall_s",
    "assembly_s",
    "factorization_s",
    "solve_s",
    "line_search_s",
    "growth_s",
    "output_s",
    "other_s",
];

/// Name of the checkpoint file in the output directory.
pub const CHECKPOINT_FILE: &str = "checkpoint.bin";

/// Writes frames, `steps.csv`, checkpoints and a progress bar while a simulation runs.
struct Writer {
    dir: PathBuf,
    every: usize,
    obj: bool,
    vtk: Option<crate::vtk::Series>,
    csv: std::io::BufWriter<std::fs::File>,
    bar: Option<ProgressBar>,
    error: Option<String>,
    frames: usize,
    /// The step of the last frame counted, so that rewriting it (the failure path writes the
    /// last good state, which may already be a frame) does not count it twice.
    last_frame: Option<usize>,
    /// Built at the first VTK frame.
    densities: Option<crate::face_fields::FaceEnergyDensity>,
    /// Rows of `steps.csv` written (after the header).
    csv_rows: usize,
    /// The notice that Newton solves fell back to CG has been printed.
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
    /// Steps done, for the Newton progress observer.
    steps_done: Arc<AtomicUsize>,
}

impl Writer {
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
            let contact_force = sim
                .system()
                .contact
                .as_ref()
                .map(|c| c.forces(sim.positions()));
            if let Some(c) = &sim.system().contact {
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
    fn checkpoint(&mut self, sim: &Simulation) {
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

    fn say(&self, line: String) {
        // A hidden bar (stderr not a terminal: logs, scripts, CI) drops `println`.
        match self.bar.as_ref().filter(|b| !b.is_hidden()) {
            Some(bar) => bar.println(line),
            None => eprintln!("{line}"),
        }
    }
}

impl Observer for Writer {
    fn start(&mut self, sim: &Simulation) {
        if !self.resumed {
            self.frame(sim);
            if self.checkpoint_every.is_some() {
                self.checkpoint(sim);
            }
        }
    }

    fn step(&mut self, sim: &Simulation, record: &StepRecord) {
        self.steps_done
            .store(sim.steps_done(), std::sync::atomic::Ordering::Relaxed);
        let mut r = record.clone();
        r.add_output(std::mem::take(&mut self.pending_output));
        let t = Instant::now();
        if sim.steps_done() % self.every == 0 || sim.steps_done() == sim.steps_total() {
            self.frame(sim);
        }
        r.add_output(t.elapsed().as_secs_f64());
        self.totals.add(&r);
        let mut row = format!(
            "{},{:e},{:e},{:e},{:e},{:e},{},{},{},{:e},{:e},{:e},{:e},{:e},{},{:e},{:e},{:e},{:e},{},{},{},{},{}",
            r.step,
            r.time,
            r.energy.stretch,
            r.energy.bend,
            r.energy.damping,
            r.kinetic,
            r.newton_iterations,
            r.backtracks,
            r.regularizations,
            r.residual,
            r.wall_s,
            r.assembly_s,
            r.factorization_s,
            r.solve_s,
            r.load_factor,
            r.line_search_s,
            r.growth_s,
            r.output_s,
            r.other_s,
            r.gauss_newton_iterations,
            r.shifted_iterations,
            r.negative_curvature_iterations,
            r.rejected_steps,
            r.min_eigenvalue
                .map(|v| format!("{v:e}"))
                .unwrap_or_default()
        );
        row += &crate::sim::csv_extra_row(&r);
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
            self.say(format!(
                "notice: step {}: the Cholesky factor does not fit in the memory budget; Newton \
                 solves use preconditioned CG ({} CG iterations in this step; convergence is \
                 checked as usual)",
                r.step, r.cg_iterations
            ));
        }
        if r.stable == Some(false) {
            self.say(format!(
                "warning: step {}: the equilibrium is not a minimum (the exact Hessian is not \
                 positive definite: a saddle, unstable under perturbation)",
                r.step
            ));
        }
        if let Some(bar) = &self.bar {
            bar.set_position(sim.steps_done() as u64);
            bar.set_message(format!("E = {:.4e} J", r.energy.elastic()));
        }
    }
}

/// The end of a run's outputs: the last good state as an OBJ frame after a failure,
/// `summary.json` (`status`: completed, interrupted, failed, or running for a run that goes on),
/// and the first output error, if any.
fn finish_outputs(
    writer: &mut Writer,
    sim: &Simulation,
    dir: &Path,
    status: &str,
    failed: Option<&crate::sim::StepError>,
) -> Result<(), Failure> {
    let io = |e: std::io::Error, p: &Path| Failure::BadInput(format!("{}: {e}", p.display()));
    let failure = failed.map(|e| e.to_string());
    if failure.is_some() {
        // The last good state, for inspection.
        writer.obj = true;
        writer.frame(sim);
    }
    let totals = &writer.totals;
    let mut summary = serde_json::json!({
        "scene": writer.scene_origin,
        "name": sim.name(),
        "status": status,
        "error": failure,
        "failed_step": failed.map(|e| e.step),
        "residual_history": failed.and_then(crate::resume::residual_history),
        "steps": sim.steps_done(),
        "steps_requested": sim.steps_total(),
        "time_s": sim.time(),
        // Of the last good state (the start state when step 1 failed).
        "energy": Energies::from(sim.energy()),
        "frames": writer.frames,
        "load_factor": sim.load_factor(),
    });
    // wall_s, newton_iterations and the iteration kinds, stable, unstable_steps.
    totals.write_into(&mut summary);
    let summary_path = dir.join("summary.json");
    let text = serde_json::to_string_pretty(&summary)
        .map_err(|e| Failure::Simulation(format!("summary.json: {e}")))?;
    crate::atomic::write_atomic(&summary_path, text.as_bytes())
        .map_err(|e| io(e, &summary_path))?;
    if let Some(e) = &writer.error {
        return Err(Failure::Simulation(format!("writing output: {e}")));
    }
    Ok(())
}

/// The outputs of `thinshell run` (the scene's `[output]`: OBJ/VTK frames with `frames.pvd`,
/// `steps.csv`, `summary.json`), written by the same code, for callers that step a
/// [`Simulation`] themselves (the Python package): [`OutputWriter::create`] before the first
/// step (writes the start frame), [`OutputWriter::step`] after every step,
/// [`OutputWriter::finish`] for `summary.json`.
pub struct OutputWriter {
    writer: Writer,
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
        let io = |e: std::io::Error, p: &Path| Failure::BadInput(format!("{}: {e}", p.display()));
        std::fs::create_dir_all(dir).map_err(|e| io(e, dir))?;
        let stale = dir.join(CHECKPOINT_FILE);
        if stale.exists() {
            std::fs::remove_file(&stale).map_err(|e| io(e, &stale))?;
        }
        let csv_path = dir.join("steps.csv");
        let mut csv = std::io::BufWriter::new(
            std::fs::File::create(&csv_path).map_err(|e| io(e, &csv_path))?,
        );
        writeln!(
            csv,
            "{STEPS_CSV_HEADER}{}",
            crate::sim::csv_extra_header(sim)
        )
        .map_err(|e| io(e, &csv_path))?;
        let mut writer = Writer {
            dir: dir.to_path_buf(),
            every: scene.file.output.every,
            obj: scene.file.output.formats.contains(&Format::Obj),
            vtk: scene
                .file
                .output
                .formats
                .contains(&Format::Vtk)
                .then(|| crate::vtk::Series::new(dir, "frames")),
            csv,
            bar: None,
            error: None,
            densities: None,
            frames: 0,
            last_frame: None,
            csv_rows: 0,
            iterative_noticed: false,
            totals: Totals::default(),
            checkpoint_every: None,
            scene_hash: crate::sim::scene_hash(scene),
            scene_path: PathBuf::from(scene_origin),
            overrides: Vec::new(),
            last_checkpoint: Instant::now(),
            pending_output: 0.0,
            resumed: false,
            steps_done: Arc::new(AtomicUsize::new(sim.steps_done())),
            scene_origin: scene_origin.to_string(),
        };
        writer.start(sim);
        match writer.error.take() {
            Some(e) => Err(Failure::BadInput(format!("writing output: {e}"))),
            None => Ok(OutputWriter { writer }),
        }
    }

    /// After a completed step: its row of `steps.csv` and, every `[output] every` steps and
    /// at the last, a frame. Output errors are kept for [`OutputWriter::finish`].
    pub fn step(&mut self, sim: &Simulation, record: &StepRecord) {
        self.writer.step(sim, record);
    }

    /// Writes `summary.json` with `status` (completed, interrupted, failed, running) and the
    /// failed step's error (whose last good state is then also written as an OBJ frame); may be
    /// called again later (a run that goes on). Errors with the first output error.
    pub fn finish(
        &mut self,
        sim: &Simulation,
        status: &str,
        failed: Option<&crate::sim::StepError>,
    ) -> Result<(), Failure> {
        self.writer
            .csv
            .flush()
            .map_err(|e| Failure::Simulation(format!("writing output: steps.csv: {e}")))?;
        let dir = self.writer.dir.clone();
        finish_outputs(&mut self.writer, sim, &dir, status, failed)
    }
}

/// `thinshell run SCENE` with default options (see [`run_with`]).
pub fn run(
    scene: &Path,
    out: Option<&Path>,
    overrides: &[String],
    quiet: bool,
    stop: &Arc<AtomicBool>,
) -> Result<(), Failure> {
    let options = RunOptions {
        quiet,
        ..RunOptions::default()
    };
    run_with(scene, out, overrides, &options, stop)
}

/// `thinshell run SCENE`: runs a scene, writing frames (OBJ and/or VTK), `steps.csv`,
/// `summary.json` and (with [`RunOptions::checkpoint_every`]) `checkpoint.bin` into `out`
/// (default `out/<scene name>`). Ctrl-C (the `stop` flag) ends the run cleanly after the
/// current step (a running Newton solve stops within one iteration and its step is not taken) and writes a checkpoint there, so that `resume` continues from it.
pub fn run_with(
    scene_path: &Path,
    out: Option<&Path>,
    overrides: &[String],
    options: &RunOptions,
    stop: &Arc<AtomicBool>,
) -> Result<(), Failure> {
    let (scene, sim) = load(scene_path, overrides)?;
    if options.checkpoint_every.is_some() && sim.is_path_following() {
        return Err(Failure::BadInput(format!(
            "--checkpoint-every: {}",
            crate::sim::CheckpointError::PathFollowing
        )));
    }
    let dir = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| Path::new("out").join(sim.name().replace([' ', '/', ','], "_")));
    let io = |e: std::io::Error, p: &Path| Failure::BadInput(format!("{}: {e}", p.display()));
    std::fs::create_dir_all(&dir).map_err(|e| io(e, &dir))?;
    // A stale checkpoint of an earlier run in this directory must not be resumed later.
    let stale = dir.join(CHECKPOINT_FILE);
    if stale.exists() {
        std::fs::remove_file(&stale).map_err(|e| io(e, &stale))?;
    }
    let csv_path = dir.join("steps.csv");
    let mut csv =
        std::io::BufWriter::new(std::fs::File::create(&csv_path).map_err(|e| io(e, &csv_path))?);
    writeln!(
        csv,
        "{STEPS_CSV_HEADER}{}",
        crate::sim::csv_extra_header(&sim)
    )
    .map_err(|e| io(e, &csv_path))?;
    let scene_abs = std::fs::canonicalize(scene_path).map_err(|e| io(e, scene_path))?;
    let record = RunRecord {
        scene: scene_abs,
        scene_origin: scene.origin.clone(),
        overrides: overrides.to_vec(),
        csv_rows: 0,
        frames: 0,
        last_frame: None,
        pvd: Vec::new(),
        totals: Totals::default(),
        checkpoint_every: None,
    };
    drive(scene, sim, dir, csv, record, options, false, stop)
}

/// `thinshell resume OUT_DIR`: continues the run whose checkpoint is `OUT_DIR/checkpoint.bin`;
/// its frames, `.pvd`, `steps.csv` and `summary.json` continue as if it had never stopped.
/// Without `options.checkpoint_every` the run's own setting is kept.
pub fn resume(dir: &Path, options: &RunOptions, stop: &Arc<AtomicBool>) -> Result<(), Failure> {
    let (scene, sim, csv, record) = crate::resume::reopen(dir)?;
    let mut options = options.clone();
    if options.checkpoint_every.is_none() {
        options.checkpoint_every = record
            .checkpoint_every
            .as_deref()
            .and_then(|c| c.parse().ok());
    }
    drive(
        scene,
        sim,
        dir.to_path_buf(),
        csv,
        record,
        &options,
        true,
        stop,
    )
}

/// Runs a loaded (fresh or restored) simulation to its end and writes `summary.json`.
#[allow(clippy::too_many_arguments)]
fn drive(
    scene: Scene,
    mut sim: Simulation,
    dir: PathBuf,
    csv: std::io::BufWriter<std::fs::File>,
    record: RunRecord,
    options: &RunOptions,
    resumed: bool,
    stop: &Arc<AtomicBool>,
) -> Result<(), Failure> {
    let bar = (!options.quiet).then(|| {
        let bar = ProgressBar::new(sim.steps_total() as u64);
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} steps  {per_sec}  {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_position(sim.steps_done() as u64);
        bar
    });
    let steps_done = Arc::new(AtomicUsize::new(sim.steps_done()));
    sim.set_newton_progress(crate::resume::progress_hook(
        bar.clone(),
        options.verbose,
        Arc::clone(&steps_done),
    ));
    let vtk = scene
        .file
        .output
        .formats
        .contains(&Format::Vtk)
        .then(|| crate::vtk::Series::new(&dir, "frames"))
        .map(|mut s| {
            s.set_entries(
                record
                    .pvd
                    .iter()
                    .map(|(t, f)| (f64::from_bits(*t), f.clone()))
                    .collect(),
            );
            s
        });
    let mut writer = Writer {
        dir: dir.clone(),
        every: scene.file.output.every,
        obj: scene.file.output.formats.contains(&Format::Obj),
        vtk,
        csv,
        bar,
        error: None,
        densities: None,
        frames: record.frames,
        last_frame: record.last_frame,
        csv_rows: record.csv_rows,
        iterative_noticed: false,
        totals: record.totals,
        checkpoint_every: options.checkpoint_every,
        scene_hash: crate::sim::scene_hash(&scene),
        scene_path: record.scene,
        overrides: record.overrides,
        last_checkpoint: Instant::now(),
        pending_output: 0.0,
        resumed,
        steps_done,
        scene_origin: record.scene_origin.clone(),
    };
    // Ctrl-C also cancels a long Newton solve between its iterations (the step is not taken).
    sim.set_cancel(Some(Arc::clone(stop)));
    let result = sim.run(&mut writer, stop);
    if let Some(bar) = &writer.bar {
        bar.finish_and_clear();
    }
    if result.as_ref().is_ok_and(|s| s.interrupted) && !sim.is_path_following() {
        // Ctrl-C: `resume` continues from exactly here, with or without --checkpoint-every.
        writer.checkpoint(&sim);
    }
    let status = match &result {
        Ok(s) if s.interrupted => "interrupted",
        Ok(_) => "completed",
        Err(_) => "failed",
    };
    finish_outputs(&mut writer, &sim, &dir, status, result.as_ref().err())?;
    match (result, options.quiet) {
        (Err(e), _) => match crate::resume::memory_refusal(&e, &sim) {
            Some(line) => Err(Failure::BadInput(line)),
            None => Err(Failure::Simulation(e.to_string())),
        },
        (Ok(s), false) => {
            let stability = match s.stable {
                Some(true) => ", a stable equilibrium",
                Some(false) => ", an UNSTABLE equilibrium (saddle)",
                None => "",
            };
            println!(
                "{}: {} {} of {} steps in {:.3} s, elastic energy {:.6e} J{stability}; output in {}",
                sim.name(),
                status,
                s.steps,
                s.steps_requested,
                s.wall_s,
                s.final_energy.elastic(),
                dir.display()
            );
            Ok(())
        }
        (Ok(_), true) => Ok(()),
    }
}
