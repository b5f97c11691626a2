//! The command implementations behind the `thinshell` binary.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize};

use indicatif::{ProgressBar, ProgressStyle};
use thinshell::mesh_info::mesh_info;
use thinshell::output::{CheckpointEvery, Failure, OutputWriter, RunRecord, RunStatus};
use thinshell::sim::{Observer, Simulation, StepRecord};

/// `thinshell info MESH`: prints statistics and every problem of an OBJ mesh. A mesh with
/// problems that make it unusable gets them all listed (each with its OBJ lines), with the
/// statistics of the faces without problems, and then fails as bad input naming the first.
pub fn info(path: &Path) -> Result<(), Failure> {
    let bad = |e: thinshell_mesh::MeshError| Failure::BadInput(format!("{}: {e}", path.display()));
    let data = thinshell_mesh::io::read_obj_data(std::io::BufReader::new(
        std::fs::File::open(path).map_err(|e| bad(e.into()))?,
    ))
    .map_err(bad)?;
    let diagnosis = thinshell_mesh::diagnose(&data.positions, &data.faces);
    let located: Vec<thinshell_mesh::MeshError> = diagnosis
        .problems
        .into_iter()
        .map(|e| thinshell_mesh::io::locate_in_obj(e, &data.face_lines, &data.vertex_lines))
        .collect();
    let Some(first) = located.first() else {
        let mesh = diagnosis
            .mesh
            .ok_or_else(|| bad(thinshell_mesh::MeshError::Empty))?;
        println!("{}", path.display());
        println!("{}", mesh_info(&mesh));
        return Ok(());
    };
    println!("{}", path.display());
    match &diagnosis.mesh {
        Some(mesh) => {
            println!(
                "statistics of the {} of {} faces without problems:",
                diagnosis.kept_faces.len(),
                data.faces.len()
            );
            let mut info = mesh_info(mesh);
            let warnings = std::mem::take(&mut info.problems);
            info.problems = located.iter().map(ToString::to_string).collect();
            info.problems.extend(warnings);
            println!("{info}");
        }
        None => {
            println!("no statistics: no valid mesh is left without the faces below");
            println!("problems:");
            for p in &located {
                println!("  - {p}");
            }
        }
    }
    let more = match located.len() {
        1 => String::new(),
        n => format!(" (and {} more problems, listed above)", n - 1),
    };
    Err(Failure::BadInput(format!(
        "{}: {first}{more}",
        path.display()
    )))
}

/// `thinshell check SCENE`: validates a scene and prints what would be simulated.
pub fn check(scene: &Path, overrides: &[String]) -> Result<(), Failure> {
    let (_, sim) = crate::load::load(scene, overrides)?;
    print!("{}", sim.describe());
    Ok(())
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

/// The library's writer plus the terminal: the progress bar follows the steps, and the step
/// count feeds the Newton progress line.
struct Terminal {
    writer: OutputWriter,
    bar: Option<ProgressBar>,
    steps_done: Arc<AtomicUsize>,
}

impl Terminal {
    /// Prints the writer's notices above the progress bar (or to stderr).
    fn show_notices(&mut self) {
        for notice in self.writer.take_notices() {
            crate::resume::say(self.bar.as_ref(), &notice.to_string());
        }
    }
}

impl Observer for Terminal {
    fn start(&mut self, sim: &Simulation) {
        self.writer.start(sim);
        self.show_notices();
    }

    fn step(&mut self, sim: &Simulation, record: &StepRecord) {
        self.steps_done
            .store(sim.steps_done(), std::sync::atomic::Ordering::Relaxed);
        self.writer.step(sim, record);
        self.show_notices();
        if let Some(bar) = &self.bar {
            bar.set_position(sim.steps_done() as u64);
            bar.set_message(format!("E = {:.4e} J", record.energy.elastic()));
        }
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
    run_with(scene, out, overrides, &options, stop).map(|_| ())
}

/// `thinshell run SCENE`: runs a scene, writing frames (OBJ and/or VTK), `steps.csv`,
/// `summary.json` and (with [`RunOptions::checkpoint_every`]) `checkpoint.bin` into `out`
/// (default `out/<scene name>`). Ctrl-C (the `stop` flag) ends the run cleanly after the
/// current step (a running Newton solve stops within one iteration and its step is not taken)
/// and writes a checkpoint there, so that `resume` continues from it; the result then says
/// [`RunEnd::Interrupted`] (the binary exits with 130 and prints the `thinshell resume` command).
pub fn run_with(
    scene_path: &Path,
    out: Option<&Path>,
    overrides: &[String],
    options: &RunOptions,
    stop: &Arc<AtomicBool>,
) -> Result<RunEnd, Failure> {
    let (scene, sim) = crate::load::load(scene_path, overrides)?;
    if options.checkpoint_every.is_some() && sim.is_path_following() {
        return Err(Failure::BadInput(format!(
            "--checkpoint-every: {}",
            thinshell::output::CheckpointError::PathFollowing
        )));
    }
    let dir = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| Path::new("out").join(sim.name().replace([' ', '/', ','], "_")));
    let scene_abs = std::fs::canonicalize(scene_path)
        .map_err(|e| Failure::BadInput(format!("{}: {e}", scene_path.display())))?;
    let record = RunRecord::new(scene_abs, scene.origin.clone(), overrides.to_vec());
    let writer = OutputWriter::for_run(&scene, &sim, &dir, record, options.checkpoint_every)?;
    drive(sim, writer, options, stop)
}

/// `thinshell resume OUT_DIR`: continues the run whose checkpoint is `OUT_DIR/checkpoint.bin`;
/// its frames, `.pvd`, `steps.csv` and `summary.json` continue as if it had never stopped.
/// Without `options.checkpoint_every` the run's own setting is kept.
pub fn resume(dir: &Path, options: &RunOptions, stop: &Arc<AtomicBool>) -> Result<RunEnd, Failure> {
    let (sim, writer, checkpoint_every) = crate::resume::reopen(dir, options.checkpoint_every)?;
    let options = RunOptions {
        checkpoint_every,
        ..options.clone()
    };
    drive(sim, writer, &options, stop)
}

/// How a run that did not fail ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunEnd {
    /// Every step was taken.
    Completed,
    /// Stopped by Ctrl-C (the `stop` flag) after the last completed step, with a checkpoint
    /// that `thinshell resume` continues from (path-following runs: no checkpoint).
    Interrupted,
}

/// Runs a loaded (fresh or restored) simulation to its end and writes `summary.json`.
fn drive(
    mut sim: Simulation,
    writer: OutputWriter,
    options: &RunOptions,
    stop: &Arc<AtomicBool>,
) -> Result<RunEnd, Failure> {
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
    let mut terminal = Terminal {
        writer,
        bar,
        steps_done,
    };
    // Ctrl-C also cancels a long Newton solve between its iterations (the step is not taken).
    sim.set_cancel(Some(Arc::clone(stop)));
    let result = sim.run(&mut terminal, stop);
    if let Some(bar) = &terminal.bar {
        bar.finish_and_clear();
    }
    let writer = &mut terminal.writer;
    if result.as_ref().is_ok_and(|s| s.interrupted) && !sim.is_path_following() {
        // Ctrl-C: `resume` continues from exactly here, with or without --checkpoint-every.
        writer.checkpoint(&sim);
    }
    let status = match &result {
        Ok(s) if s.interrupted => RunStatus::Interrupted,
        Ok(_) => RunStatus::Completed,
        Err(_) => RunStatus::Failed,
    };
    let finished = writer.finish(&sim, status, result.as_ref().err());
    // The last good state of a failed run is written as a frame, which may have notices.
    terminal.show_notices();
    finished?;
    let writer = &terminal.writer;
    let s = match result {
        Err(e) => {
            return match crate::resume::memory_refusal(&e, &sim) {
                Some(line) => Err(Failure::BadInput(line)),
                None => Err(Failure::Simulation(format!(
                    "{e}{}",
                    failed_step_hint(&e, &sim)
                ))),
            };
        }
        Ok(s) => s,
    };
    let end = if s.interrupted {
        RunEnd::Interrupted
    } else {
        RunEnd::Completed
    };
    if !options.quiet {
        let stability = match s.stable {
            Some(true) => ", a stable equilibrium",
            Some(false) => ", an UNSTABLE equilibrium (saddle)",
            None => "",
        };
        let status = match end {
            RunEnd::Interrupted => "interrupted",
            RunEnd::Completed => "completed",
        };
        println!(
            "{}: {} {} of {} steps in {:.3} s, elastic energy {:.6e} J{stability}; output in {}",
            sim.name(),
            status,
            s.steps,
            s.steps_requested,
            s.wall_s,
            s.final_energy.elastic(),
            writer.dir().display()
        );
    }
    if end == RunEnd::Interrupted {
        // Also with --quiet: what to type next is the one thing a stopped run must say.
        if sim.is_path_following() {
            eprintln!(
                "thinshell: interrupted; a path-following run cannot be resumed (run it again)"
            );
        } else {
            eprintln!(
                "thinshell: interrupted; continue with: thinshell resume {}",
                shell_quote(&writer.dir().display().to_string())
            );
        }
    }
    Ok(end)
}

/// `s` as one shell word (single-quoted unless it is plain), for a command to copy.
fn shell_quote(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c));
    if plain {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// What to try after a failed step that the message alone does not say: an implicit step whose
/// Newton solve ran out of iterations has usually been asked to follow a fast instability in one
/// step (empty otherwise). On the same line: a failure is one line of output.
fn failed_step_hint(e: &thinshell::sim::StepError, sim: &Simulation) -> &'static str {
    let newton_limit = matches!(
        &e.source,
        thinshell::sim::StepFailure::Solver(
            thinshell_solver::SolverError::NewtonDidNotConverge { .. }
        )
    );
    if newton_limit && sim.integrator() == thinshell::scene::integrator::IntegratorKind::Implicit {
        "; hint: an implicit step that has to follow a fast instability (buckling, collapse, \
         snap-through) within one Δt can need more Newton iterations than the limit: \
         `integrator.adaptive_dt = true` halves Δt where a step fails; a smaller \
         `integrator.dt` or a larger `integrator.newton.max_iterations` also help"
    } else {
        ""
    }
}
