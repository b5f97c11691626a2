//! The command implementations behind the `thinshell` binary, as library functions so that they
//! can be tested without spawning processes.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use indicatif::{ProgressBar, ProgressStyle};

use crate::mesh_info::mesh_info;
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
fn load(scene: &Path, overrides: &[String]) -> Result<(Scene, Simulation), Failure> {
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
            format!(", including {n_angles} edge-director angles")
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

/// Writes frames, `steps.csv` and a progress bar while a simulation runs.
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
}

impl Writer {
    fn frame(&mut self, sim: &Simulation) {
        if self.error.is_some() {
            return;
        }
        let step = sim.steps_done();
        if self.obj {
            let path = self.dir.join(format!("frame_{step:06}.obj"));
            if let Err(e) = thinshell_mesh::io::save_obj(&path, sim.mesh(), sim.positions()) {
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
            if let Some(g) = sim.growth() {
                cell_scalars.push(("stimulus_top", g.stimulus().iter().map(|m| m.top).collect()));
                cell_scalars.push((
                    "stimulus_bottom",
                    g.stimulus().iter().map(|m| m.bottom).collect(),
                ));
            }
            let frame = crate::vtk::Frame {
                mesh: sim.mesh(),
                points: sim.positions(),
                point_vectors: vec![
                    ("displacement", &displacement),
                    ("velocity", sim.velocities()),
                ],
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
}

impl Observer for Writer {
    fn start(&mut self, sim: &Simulation) {
        self.frame(sim);
    }

    fn step(&mut self, sim: &Simulation, r: &StepRecord) {
        if sim.steps_done() % self.every == 0 || sim.steps_done() == sim.steps_total() {
            self.frame(sim);
        }
        let mut row = format!(
            "{},{:e},{:e},{:e},{:e},{:e},{},{},{},{:e},{:e},{:e},{:e},{:e},{}",
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
            r.load_factor
        );
        row += &crate::sim::csv_extra_row(r);
        row.push('\n');
        if let Err(e) = self
            .csv
            .write_all(row.as_bytes())
            .and_then(|_| self.csv.flush())
        {
            self.error.get_or_insert(format!("steps.csv: {e}"));
        }
        if r.stable == Some(false) {
            let warning = format!(
                "warning: step {}: the equilibrium is not a minimum (the exact Hessian is not \
                 positive definite: a saddle, unstable under perturbation)",
                r.step
            );
            // A hidden bar (stderr not a terminal: logs, scripts, CI) drops `println`.
            match self.bar.as_ref().filter(|b| !b.is_hidden()) {
                Some(bar) => bar.println(warning),
                None => eprintln!("{warning}"),
            }
        }
        if let Some(bar) = &self.bar {
            bar.set_position(sim.steps_done() as u64);
            bar.set_message(format!("E = {:.4e} J", r.energy.elastic()));
        }
    }
}

/// `thinshell run SCENE`: runs a scene, writing frames (OBJ and/or VTK), `steps.csv` and `summary.json`
/// into `out` (default `out/<scene name>`). Ctrl-C (the `stop` flag) ends the run cleanly after
/// the current step.
pub fn run(
    scene: &Path,
    out: Option<&Path>,
    overrides: &[String],
    quiet: bool,
    stop: &AtomicBool,
) -> Result<(), Failure> {
    let (scene, mut sim) = load(scene, overrides)?;
    let dir = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| Path::new("out").join(sim.name().replace([' ', '/', ','], "_")));
    let io = |e: std::io::Error, p: &Path| Failure::BadInput(format!("{}: {e}", p.display()));
    std::fs::create_dir_all(&dir).map_err(|e| io(e, &dir))?;
    let csv_path = dir.join("steps.csv");
    let mut csv =
        std::io::BufWriter::new(std::fs::File::create(&csv_path).map_err(|e| io(e, &csv_path))?);
    let header = format!(
        "step,time_s,stretch_J,bend_J,damping_J,kinetic_J,newton_iterations,backtracks,regularizations,residual,wall_s,assembly_s,factorization_s,solve_s,load_factor{}\n",
        crate::sim::csv_extra_header(&sim)
    );
    csv.write_all(header.as_bytes())
        .map_err(|e| io(e, &csv_path))?;
    let bar = (!quiet).then(|| {
        let bar = ProgressBar::new(sim.steps_total() as u64);
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} steps  {per_sec}  {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let mut writer = Writer {
        dir: dir.clone(),
        every: scene.file.output.every,
        obj: scene.file.output.formats.contains(&Format::Obj),
        vtk: scene
            .file
            .output
            .formats
            .contains(&Format::Vtk)
            .then(|| crate::vtk::Series::new(&dir, "frames")),
        csv,
        bar,
        error: None,
        frames: 0,
        last_frame: None,
    };
    let result = sim.run(&mut writer, stop);
    if let Some(bar) = &writer.bar {
        bar.finish_and_clear();
    }
    let (status, failure) = match &result {
        Ok(s) if s.interrupted => ("interrupted", None),
        Ok(_) => ("completed", None),
        Err(e) => ("failed", Some(e.to_string())),
    };
    if failure.is_some() {
        // The last good state, for inspection.
        writer.obj = true;
        writer.frame(&sim);
    }
    let summary = serde_json::json!({
        "scene": scene.origin,
        "name": sim.name(),
        "status": status,
        "error": failure,
        "steps": sim.steps_done(),
        "steps_requested": sim.steps_total(),
        "time_s": sim.time(),
        "energy": Energies::from(sim.energy()),
        "frames": writer.frames,
        "wall_s": result.as_ref().map(|s| s.wall_s).ok(),
        "newton_iterations": result.as_ref().map(|s| s.newton_iterations).ok(),
        "load_factor": sim.load_factor(),
        "gauss_newton_iterations": result.as_ref().map(|s| s.gauss_newton_iterations).ok(),
        "stable": result.as_ref().ok().and_then(|s| s.stable),
        "unstable_steps": result.as_ref().map(|s| s.unstable_steps.clone()).ok(),
    });
    let summary_path = dir.join("summary.json");
    let text = serde_json::to_string_pretty(&summary)
        .map_err(|e| Failure::Simulation(format!("summary.json: {e}")))?;
    std::fs::write(&summary_path, text).map_err(|e| io(e, &summary_path))?;
    if let Some(e) = writer.error {
        return Err(Failure::Simulation(format!("writing output: {e}")));
    }
    match (result, quiet) {
        (Err(e), _) => Err(Failure::Simulation(e.to_string())),
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
