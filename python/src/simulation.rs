//! `Simulation`: a built scene, stepped with the GIL released.
//!
//! Interruption: a step runs on a helper thread while the calling thread, without the GIL,
//! waits for it and checks Python's signals every [`SIGNAL_POLL`]; a pending signal (Ctrl-C)
//! sets the solver's cancel flag, so the running Newton solve stops before its next iteration,
//! the state stays at the last completed step and the signal's exception (KeyboardInterrupt)
//! is raised. `Simulation.cancel()` sets the same flag from any thread.
//!
//! Reads from other threads: the state getters read a snapshot taken after every change, not
//! the simulation itself, so they work while another thread runs it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use nalgebra::Vector3;
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use thinshell::scene::Scene;
use thinshell::sim::{BuildError, Simulation, StepError, StepRecord};
use thinshell_energy::{EnergyTerms, RestState};
use thinshell_growth::FaceStimulus;

use crate::mesh::PyMesh;
use crate::scene::PyScene;
use crate::{convert, errors};

/// `(a_bar, b_bar)`, each m × 2 × 2.
type Forms<'py> = (Bound<'py, PyArray3<f64>>, Bound<'py, PyArray3<f64>>);

/// How often a waiting step checks Python's signals.
const SIGNAL_POLL: Duration = Duration::from_millis(20);

// What the wrapper adds up over the steps taken through it (kept in checkpoints as their
// attachment, so a restored simulation reports the totals of the whole run): the run output's
// totals, as `thinshell run` counts them.
use thinshell::output::{Failure, OutputWriter, RunStatus, Totals};

/// The simulation and what the wrapper adds up over the steps taken through it.
struct Inner {
    sim: Simulation,
    /// The simulation's own thread pool (`threads=`), else rayon's global pool.
    pool: Option<Arc<rayon::ThreadPool>>,
    totals: Totals,
    status: &'static str,
    error: Option<String>,
    /// The scene's `[output]`, written by the run-output writer `thinshell run` uses (`Simulation(..., output=DIR)`).
    output: Option<OutputWriter>,
}

/// The message of a run-output failure.
fn failure_message(f: Failure) -> String {
    f.to_string()
}

impl Inner {
    fn record(&mut self, r: &StepRecord) {
        self.totals.add(r);
        self.status = if self.sim.steps_done() >= self.sim.steps_total() {
            "completed"
        } else {
            "running"
        };
    }
}

/// A read-only copy of the state, taken after every change of it.
#[derive(Clone)]
struct Snapshot {
    steps_done: usize,
    steps_total: usize,
    time: f64,
    dt: f64,
    load_factor: f64,
    x: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
    energy: EnergyTerms,
    kinetic: f64,
}

impl Snapshot {
    fn of(sim: &Simulation) -> Snapshot {
        Snapshot {
            steps_done: sim.steps_done(),
            steps_total: sim.steps_total(),
            time: sim.time(),
            dt: sim.dt(),
            load_factor: sim.load_factor(),
            x: sim.positions().to_vec(),
            v: sim.velocities().to_vec(),
            energy: sim.energy(),
            kinetic: sim.kinetic_energy(),
        }
    }
}

/// A scene built into a simulation: `step()`, `run()`, the state, checkpoints. Steps release
/// the GIL; one thread steps a simulation, any thread may read its state meanwhile.
#[pyclass(name = "Simulation", module = "thinshell", frozen)]
pub struct PySimulation {
    // A lock rather than `&mut self`, so that Rust can work with the GIL released; two Python
    // threads stepping the *same* simulation get an error instead of waiting (no deadlock).
    inner: Mutex<Inner>,
    /// The state after the last change, for reads that must not wait for a running step.
    snapshot: Mutex<Arc<Snapshot>>,
    /// The scene it was built from (checkpoints name it by hash; pickling rebuilds from it).
    scene: PyScene,
    threads: Option<usize>,
    /// The solver's cancel flag: set, the running Newton solve stops before its next iteration.
    cancel: Arc<AtomicBool>,
    /// `cancel()` was called (also between steps: the next step is then not taken).
    cancel_requested: AtomicBool,
}

/// The scene argument of `Simulation(...)`: a `Scene`, a dict, or a path to a scene file.
fn scene_of(obj: &Bound<'_, PyAny>) -> PyResult<PyScene> {
    if let Ok(s) = obj.cast::<PyScene>() {
        return Ok(s.get().clone());
    }
    let py = obj.py();
    let scene_type = py.get_type::<PyScene>();
    let built = if obj.is_instance_of::<PyDict>() {
        scene_type.call_method1("from_dict", (obj,))?
    } else if obj.hasattr("__fspath__")? || obj.is_instance_of::<pyo3::types::PyString>() {
        scene_type.call_method1("from_file", (obj,))?
    } else {
        return Err(PyTypeError::new_err(
            "Simulation(scene): expected a thinshell.Scene, a dict or a path to a scene file",
        ));
    };
    Ok(built.cast::<PyScene>()?.get().clone())
}

fn build_error(e: BuildError) -> PyErr {
    match e {
        BuildError::Mesh { .. } | BuildError::MeshFile { .. } => errors::mesh(e),
        _ => errors::scene(e),
    }
}

/// Runs `work` on a helper thread while this thread, without the GIL, checks Python's signals;
/// a signal's exception sets `cancel` (the work then stops within one Newton iteration) and is
/// returned once the work has stopped, along with the work's result.
fn watched<T: Send>(
    py: Python<'_>,
    cancel: &AtomicBool,
    work: impl FnOnce() -> T + Send,
) -> (T, Option<PyErr>) {
    py.detach(|| {
        std::thread::scope(|scope| {
            let (tx, rx) = std::sync::mpsc::channel();
            scope.spawn(move || {
                // The receiver outlives this thread (it is joined at the end of the scope).
                let _ = tx.send(work());
            });
            let mut signal = None;
            loop {
                match rx.recv_timeout(SIGNAL_POLL) {
                    Ok(result) => return (result, signal),
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) if signal.is_none() => {
                        if let Err(e) = Python::attach(|py| py.check_signals()) {
                            cancel.store(true, Ordering::SeqCst);
                            signal = Some(e);
                        }
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                        // The helper panicked: the scope re-raises its panic on exit.
                        std::thread::sleep(SIGNAL_POLL);
                    }
                }
            }
        })
    })
}

impl PySimulation {
    fn lock(&self) -> PyResult<std::sync::MutexGuard<'_, Inner>> {
        match self.inner.try_lock() {
            Ok(g) => Ok(g),
            Err(std::sync::TryLockError::WouldBlock) => Err(PyRuntimeError::new_err(
                "this Simulation is being stepped by another thread (one thread steps a \
                 simulation; the state getters and snapshot() can be read meanwhile)",
            )),
            Err(std::sync::TryLockError::Poisoned(p)) => Ok(p.into_inner()),
        }
    }

    fn snap(&self) -> Arc<Snapshot> {
        match self.snapshot.lock() {
            Ok(s) => Arc::clone(&s),
            Err(p) => Arc::clone(&p.into_inner()),
        }
    }

    fn refresh(&self, sim: &Simulation) {
        let s = Arc::new(Snapshot::of(sim));
        match self.snapshot.lock() {
            Ok(mut g) => *g = s,
            Err(p) => *p.into_inner() = s,
        }
    }

    /// One step with the GIL released and Ctrl-C watched; the record, or a `SimulationError`,
    /// or KeyboardInterrupt / `Cancelled` (the state stays at the last completed step).
    fn step_inner(&self, py: Python<'_>, inner: &mut Inner) -> PyResult<StepRecord> {
        if inner.sim.steps_done() >= inner.sim.steps_total() {
            return Err(errors::simulation(format!(
                "all {} steps of the scene are done (steps beyond `integrator.steps` are not \
                 taken silently: build the simulation with a larger `integrator.steps`)",
                inner.sim.steps_total()
            )));
        }
        self.cancel.store(false, Ordering::SeqCst);
        if self.cancel_requested.swap(false, Ordering::SeqCst) {
            return Err(errors::cancelled());
        }
        let Inner { sim, pool, .. } = inner;
        let (result, signal): (Result<StepRecord, StepError>, _) =
            watched(py, &self.cancel, || match pool {
                Some(pool) => pool.install(|| sim.step()),
                None => sim.step(),
            });
        self.cancel.store(false, Ordering::SeqCst);
        let written = match (&mut inner.output, &result) {
            (None, _) => Ok(()),
            (Some(w), Ok(r)) => {
                w.step(&inner.sim, r);
                if inner.sim.steps_done() >= inner.sim.steps_total() {
                    w.finish(&inner.sim, RunStatus::Completed, None)
                } else {
                    Ok(())
                }
            }
            (Some(w), Err(e)) if e.is_cancelled() => {
                w.finish(&inner.sim, RunStatus::Interrupted, None)
            }
            (Some(w), Err(e)) => w.finish(&inner.sim, RunStatus::Failed, Some(e)),
        };
        if let Some(w) = &mut inner.output {
            // The writer prints nothing; its notices go to stderr, as the CLI's do.
            for notice in w.take_notices() {
                eprintln!("{notice}");
            }
        }
        if let Err(f) = written {
            if let Ok(r) = &result {
                inner.record(r);
                self.refresh(&inner.sim);
            }
            return Err(errors::simulation(failure_message(f)));
        }
        match result {
            Ok(r) => {
                inner.record(&r);
                self.refresh(&inner.sim);
                // A signal that came after the last Newton iteration (or during an explicit
                // step, which has none): the step is taken, then the exception raised.
                match signal {
                    Some(e) => Err(e),
                    None => Ok(r),
                }
            }
            Err(e) if e.is_cancelled() => {
                self.cancel_requested.store(false, Ordering::SeqCst);
                inner.status = "interrupted";
                Err(signal.unwrap_or_else(errors::cancelled))
            }
            Err(e) => {
                inner.status = "failed";
                inner.error = Some(e.to_string());
                Err(signal.unwrap_or_else(|| errors::simulation(e)))
            }
        }
    }

    fn build(
        scene: PyScene,
        threads: Option<usize>,
        sim: Simulation,
        output: Option<OutputWriter>,
    ) -> PyResult<Self> {
        let pool = match threads {
            Some(0) => return Err(PyValueError::new_err("threads must be at least 1")),
            Some(n) => Some(Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| PyRuntimeError::new_err(format!("thread pool: {e}")))?,
            )),
            None => None,
        };
        let mut sim = sim;
        let cancel = Arc::new(AtomicBool::new(false));
        sim.set_cancel(Some(Arc::clone(&cancel)));
        let snapshot = Mutex::new(Arc::new(Snapshot::of(&sim)));
        Ok(PySimulation {
            inner: Mutex::new(Inner {
                sim,
                pool,
                totals: Totals::default(),
                status: "ready",
                error: None,
                output,
            }),
            snapshot,
            scene,
            threads,
            cancel,
            cancel_requested: AtomicBool::new(false),
        })
    }

    fn scene_hash(&self) -> u64 {
        thinshell::output::scene_hash(&self.scene.inner)
    }

    /// Restores checkpoint bytes; `origin` names them in errors.
    fn restore_from(&self, py: Python<'_>, bytes: &[u8], origin: &std::path::Path) -> PyResult<()> {
        let hash = self.scene_hash();
        let mut inner = self.lock()?;
        let sim = &mut inner.sim;
        let attachment = py
            .detach(|| sim.restore_bytes(bytes, hash, origin))
            .map_err(errors::simulation)?;
        // A checkpoint of this package carries its totals; one of the CLI carries the CLI's
        // own record (whose totals have other fields): then the totals start again.
        inner.totals = serde_json::from_slice(&attachment).unwrap_or_default();
        inner.status = if inner.sim.steps_done() >= inner.sim.steps_total() {
            "completed"
        } else if inner.sim.steps_done() == 0 {
            "ready"
        } else {
            "running"
        };
        inner.error = None;
        self.refresh(&inner.sim);
        Ok(())
    }

    fn checkpoint_bytes(&self) -> PyResult<Vec<u8>> {
        let inner = self.lock()?;
        if inner.sim.is_path_following() {
            return Err(errors::simulation(
                thinshell::output::CheckpointError::PathFollowing,
            ));
        }
        let attachment = serde_json::to_vec(&inner.totals)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(inner.sim.checkpoint_bytes(self.scene_hash(), &attachment))
    }
}

#[pymethods]
impl PySimulation {
    /// Builds the simulation a scene describes (`Scene`, dict, or path to a TOML file).
    /// `threads`: the number of threads its steps use (its own pool); default: the shared
    /// pool of all cores (`RAYON_NUM_THREADS`). `output`: a directory that receives the
    /// scene's `[output]` as `thinshell run --out` writes it (frames, `steps.csv`, and
    /// `summary.json` once the run completes, fails or is interrupted); default: no files.
    #[new]
    #[pyo3(signature = (scene, threads=None, output=None))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        threads: Option<usize>,
        output: Option<std::path::PathBuf>,
    ) -> PyResult<Self> {
        let scene = scene_of(scene)?;
        if threads == Some(0) {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        let built: &Scene = &scene.inner;
        let sim = py
            .detach(|| Simulation::build(built))
            .map_err(build_error)?;
        let writer = match &output {
            Some(dir) => {
                let mut w = OutputWriter::create(built, &sim, dir, &scene.origin_text())
                    .map_err(|f| errors::scene(failure_message(f)))?;
                for notice in w.take_notices() {
                    eprintln!("{notice}");
                }
                Some(w)
            }
            None => None,
        };
        Self::build(scene, threads, sim, writer)
    }

    /// The simulation of `scene` in the state of the checkpoint `data` (bytes of
    /// `to_bytes()` or of a `checkpoint.bin`); what unpickling calls.
    #[staticmethod]
    #[pyo3(signature = (scene, data, threads=None))]
    fn from_bytes(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        data: &[u8],
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let this = Self::new(py, scene, threads, None)?;
        this.restore_from(py, data, std::path::Path::new("<bytes>"))?;
        Ok(this)
    }

    /// The current state as checkpoint bytes (the format of the CLI's `checkpoint.bin`).
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, &self.checkpoint_bytes()?))
    }

    /// Writes a checkpoint of the current state to `path` (atomically), in the format of the
    /// CLI's `checkpoint.bin`; `restore` continues from it bit for bit.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let bytes = self.checkpoint_bytes()?;
        py.detach(|| thinshell::atomic::write_atomic(&path, &bytes))
            .map_err(|e| errors::simulation(format!("{}: {e}", path.display())))
    }

    /// Restores the checkpoint at `path` (written by `save` or by the CLI's
    /// `--checkpoint-every`) into this simulation, which must have been built from the same
    /// scene (after overrides); on any error the simulation is unchanged.
    fn restore(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let bytes = std::fs::read(&path)
            .map_err(|e| errors::simulation(format!("{}: {e}", path.display())))?;
        self.restore_from(py, &bytes, &path)
    }

    fn __reduce__(slf: &Bound<'_, Self>) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let py = slf.py();
        let this = slf.get();
        let ctor = py
            .get_type::<PySimulation>()
            .getattr("from_bytes")?
            .unbind();
        let scene = Py::new(py, this.scene.clone())?;
        let args = (scene, this.to_bytes(py)?, this.threads)
            .into_pyobject(py)?
            .into_any()
            .unbind();
        Ok((ctor, args))
    }

    /// Asks a running `step()`/`run()` (in any thread) to stop: its Newton solve stops before
    /// the next iteration, the state stays at the last completed step, and the call raises
    /// `thinshell.Cancelled`. Called between steps, the next step is not taken.
    fn cancel(&self) {
        self.cancel_requested.store(true, Ordering::SeqCst);
        self.cancel.store(true, Ordering::SeqCst);
    }

    /// Takes one step; returns its record (a dict: step, time, energy, newton_iterations, …).
    /// Raises `SimulationError` once the scene's `integrator.steps` are done.
    fn step<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut inner = self.lock()?;
        let r = self.step_inner(py, &mut inner)?;
        convert::to_py(py, &r)
    }

    /// Runs the remaining steps of the scene, calling `callback(sim, record)` after every
    /// `every`-th step and after the last; returns the summary. Ctrl-C stops the running
    /// Newton solve within one iteration (KeyboardInterrupt; the state is that of the last
    /// completed step, and `run()` continues from it).
    #[pyo3(signature = (callback=None, every=1))]
    fn run<'py>(
        slf: &Bound<'py, Self>,
        callback: Option<Bound<'py, PyAny>>,
        every: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        if every == 0 {
            return Err(PyValueError::new_err("run(): every must be at least 1"));
        }
        let this = slf.get();
        loop {
            let record = {
                let mut inner = this.lock()?;
                if inner.sim.steps_done() >= inner.sim.steps_total() {
                    break;
                }
                let r = this.step_inner(py, &mut inner)?;
                let last = inner.sim.steps_done() >= inner.sim.steps_total();
                (r, last)
            };
            let (r, last) = record;
            if let Some(cb) = &callback {
                if r.step % every == 0 || last {
                    cb.call1((slf, convert::to_py(py, &r)?))?;
                }
            }
            py.check_signals()?;
        }
        this.summary(py)
    }

    /// Summary of the steps taken (the fields of the CLI's `summary.json`).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let inner = self.lock()?;
        let s = &inner.sim;
        let t = &inner.totals;
        let mut value = serde_json::json!({
            "name": s.name(),
            "status": inner.status,
            "error": inner.error,
            "steps": s.steps_done(),
            "steps_requested": s.steps_total(),
            "time_s": s.time(),
            "energy": s.energy(),
            "load_factor": s.load_factor(),
        });
        t.write_into(&mut value);
        convert::to_py(py, &value)
    }

    /// A read-only copy of the state after the last completed step (readable while another
    /// thread runs this simulation): a dict with `step`, `steps_total`, `time` (s),
    /// `positions` (n × 3, m), `velocities` (n × 3, m/s), `energies` (J: stretch, bend,
    /// damping, elastic, kinetic) and `load_factor`.
    fn snapshot<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.snap();
        let d = PyDict::new(py);
        d.set_item("step", s.steps_done)?;
        d.set_item("steps_total", s.steps_total)?;
        d.set_item("time", s.time)?;
        d.set_item("positions", readonly(convert::points_to_py(py, &s.x))?)?;
        d.set_item("velocities", readonly(convert::points_to_py(py, &s.v))?)?;
        d.set_item("energies", energies_dict(py, &s)?)?;
        d.set_item("load_factor", s.load_factor)?;
        Ok(d)
    }

    /// Sets the current positions (n × 3, m); the energies are re-evaluated there. The next
    /// step starts from them (held vertices stay where they are put; prescribed motion is
    /// applied from the next step).
    fn set_positions(&self, positions: &Bound<'_, PyAny>) -> PyResult<()> {
        let x = convert::points(positions, "positions")?;
        let mut inner = self.lock()?;
        let sim = &mut inner.sim;
        positions
            .py()
            .detach(|| sim.set_positions(x))
            .map_err(errors::simulation)?;
        self.refresh(&inner.sim);
        Ok(())
    }

    /// Sets the current velocities (n × 3, m/s); the next dynamic step starts from them.
    fn set_velocities(&self, velocities: &Bound<'_, PyAny>) -> PyResult<()> {
        let v = convert::points(velocities, "velocities")?;
        let mut inner = self.lock()?;
        inner.sim.set_velocities(v).map_err(errors::simulation)?;
        self.refresh(&inner.sim);
        Ok(())
    }

    /// What will be simulated (the text `thinshell check` prints).
    fn describe(&self) -> PyResult<String> {
        Ok(self.lock()?.sim.describe())
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.scene.inner.name()
    }
    /// The mesh (faces and reference positions).
    #[getter]
    fn mesh(&self) -> PyResult<PyMesh> {
        Ok(PyMesh {
            inner: self.lock()?.sim.mesh().clone(),
        })
    }
    /// Faces, m × 3 int64.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        crate::mesh::faces_to_py(py, self.lock()?.sim.mesh())
    }
    /// Current positions, n × 3, m.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(convert::points_to_py(py, &self.snap().x))
    }
    /// Current velocities, n × 3, m/s.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(convert::points_to_py(py, &self.snap().v))
    }
    /// Reference (input) positions, n × 3, m.
    #[getter]
    fn reference_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(convert::points_to_py(
            py,
            self.lock()?.sim.reference_positions(),
        ))
    }
    /// Edge-director angles φ_e, rad, one per edge (edge-director bending forms; all 0 before
    /// the first step; empty for `mid_edge_average`).
    #[getter]
    fn edge_angles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let inner = self.lock()?;
        let s = &inner.sim;
        let phi = if s.edge_angles().is_empty() && s.system().has_edge_unknowns() {
            vec![0.0; s.mesh().n_edges()]
        } else {
            s.edge_angles().to_vec()
        };
        Ok(PyArray1::from_vec(py, phi))
    }
    /// Current time, s (static scenes: pseudo-time).
    #[getter]
    fn time(&self) -> f64 {
        self.snap().time
    }
    /// Time step, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.snap().dt
    }
    /// Steps taken.
    #[getter]
    fn steps_done(&self) -> usize {
        self.snap().steps_done
    }
    /// Steps the scene asks for.
    #[getter]
    fn steps_total(&self) -> usize {
        self.snap().steps_total
    }
    /// Load factor λ of the current state.
    #[getter]
    fn load_factor(&self) -> f64 {
        self.snap().load_factor
    }
    /// Energies of the current state by term, J: stretch, bend, damping (of the last step),
    /// elastic (stretch + bend), kinetic.
    #[getter]
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        energies_dict(py, &self.snap())
    }

    /// Energy of every face at the current state, J: a dict of float64 arrays (length m)
    /// `stretch` and `bend`; they sum to `energies["stretch"]`, `energies["bend"]`.
    fn face_energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut inner = self.lock()?;
        // `&mut` because a shared `&Simulation` is not `Send` (its integrator is not `Sync`).
        let sim = &mut inner.sim;
        let faces = py
            .detach(move || sim.face_energies())
            .map_err(errors::energy)?;
        let d = PyDict::new(py);
        d.set_item(
            "stretch",
            PyArray1::from_iter(py, faces.iter().map(|e| e.stretch)),
        )?;
        d.set_item(
            "bend",
            PyArray1::from_iter(py, faces.iter().map(|e| e.bend)),
        )?;
        Ok(d)
    }

    /// The bending form (docs/scenes.md `[bending]`): "edge_director_tan" (the default),
    /// "edge_director_sin" or "mid_edge_average".
    #[getter]
    fn form(&self) -> PyResult<String> {
        Ok(self.lock()?.sim.model().sff.name().to_string())
    }

    /// The material: a dict with `thickness` (m), `young` (Pa), `poisson`, `density`
    /// (kg/m³), `viscosity` (Pa·s) and `model` ("stvk", "neo_hookean", "bilayer",
    /// "tension_field").
    #[getter]
    fn material<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = self.lock()?.sim.model().material;
        let d = PyDict::new(py);
        d.set_item("thickness", m.thickness)?;
        d.set_item("young", m.young)?;
        d.set_item("poisson", m.poisson)?;
        d.set_item("density", m.density)?;
        d.set_item("viscosity", m.viscosity)?;
        d.set_item("model", m.model.name())?;
        Ok(d)
    }

    /// The elastic energy (J; stretching and bending, no damping, no loads) at the
    /// simulation's own state — positions and edge angles (the state's; before the first step
    /// of an edge-director scene, the minimising ones) — with its gradient over all coordinates
    /// (N, then J/rad per edge) and, when `hessian`, its Hessian (`scipy.sparse.csc_matrix`,
    /// rows and columns of held coordinates empty; clamped directors held as in the
    /// simulation): an `EnergyResult`, whose `edge_angles` are the angles used.
    ///
    /// With `positions` (n × 3, m): the same model — this simulation's faces, current rest
    /// forms (grown, edited), material and bending form — at those positions, with the
    /// minimising edge angles (what `thinshell.energy(positions, sim=sim)` computes; boundary
    /// clamps are not applied there).
    #[pyo3(signature = (positions=None, hessian=true))]
    fn energy<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        positions: Option<Bound<'py, PyAny>>,
        hessian: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        if let Some(x) = positions {
            let kwargs = PyDict::new(py);
            kwargs.set_item("hessian", hessian)?;
            return py
                .import("thinshell")?
                .getattr("_energy_of_simulation")?
                .call((slf, x), Some(&kwargs));
        }
        let this = slf.borrow();
        let mut inner = this.lock()?;
        let sim = &mut inner.sim;
        let e = py
            .detach(move || crate::state_energy::state_energy(sim, hessian))
            .map_err(errors::energy)?;
        py.import("thinshell")?.getattr("_energy_result")?.call1((
            e.stretch,
            e.bend,
            PyArray1::from_vec(py, e.gradient),
            PyArray1::from_vec(py, e.rows),
            PyArray1::from_vec(py, e.cols),
            PyArray1::from_vec(py, e.vals),
            e.n,
            hessian,
            PyArray1::from_vec(py, e.edge_angles),
        ))
    }

    /// The `count` lowest natural frequencies and mode shapes about the simulation's current
    /// state (docs/modal.md; damping left out, the massless edge angles condensed): a
    /// `Modes` with `frequencies` (Hz, ascending), `eigenvalues` (ω², rad²/s²), `shapes`
    /// (count × n × 3, M-normalised displacements, m) and `residuals`.
    #[pyo3(signature = (count=6))]
    fn modes<'py>(&self, py: Python<'py>, count: usize) -> PyResult<Bound<'py, PyAny>> {
        let mut inner = self.lock()?;
        let sim = &mut inner.sim;
        let m = py
            .detach(move || crate::state_energy::state_modes(sim, count))
            .map_err(errors::simulation)?;
        let n = m.shapes.first().map_or(0, Vec::len);
        let flat: Vec<f64> = m
            .shapes
            .iter()
            .flat_map(|s| s.iter().flat_map(|v| [v.x, v.y, v.z]))
            .collect();
        let shapes = numpy::ndarray::Array3::from_shape_vec((m.shapes.len(), n, 3), flat)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        py.import("thinshell")?.getattr("Modes")?.call1((
            PyArray1::from_vec(py, m.frequencies),
            PyArray1::from_vec(py, m.eigenvalues),
            PyArray3::from_owned_array(py, shapes),
            PyArray1::from_vec(py, m.residuals),
        ))
    }

    /// The rest forms the next step solves against: `(a_bar, b_bar)`, each m × 2 × 2 (ā in m²,
    /// b̄ in m), in each face's basis (x_j − x_i, x_k − x_i).
    #[getter]
    fn rest_forms<'py>(&self, py: Python<'py>) -> PyResult<Forms<'py>> {
        let inner = self.lock()?;
        let r = inner.sim.rest();
        Ok((
            convert::forms_to_py(py, &r.a_bar),
            convert::forms_to_py(py, &r.b_bar),
        ))
    }

    /// Replaces the rest forms of every face (m × 2 × 2 arrays ā, b̄); see `rest_forms`.
    fn set_rest_forms(&self, a_bar: &Bound<'_, PyAny>, b_bar: &Bound<'_, PyAny>) -> PyResult<()> {
        let rest = RestState {
            a_bar: convert::forms(a_bar, "a_bar")?,
            b_bar: convert::forms(b_bar, "b_bar")?,
            sff: None,
        };
        let mut inner = self.lock()?;
        let sim = &mut inner.sim;
        a_bar
            .py()
            .detach(|| sim.set_rest_forms(rest))
            .map_err(errors::simulation)?;
        self.refresh(&inner.sim);
        Ok(())
    }

    /// The current stimulus per face, m × 2 (top, bottom), in the stimulus' unit; None
    /// without growth.
    #[getter]
    fn stimulus<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        let inner = self.lock()?;
        let Some(m) = inner.sim.stimulus() else {
            return Ok(None);
        };
        let flat: Vec<f64> = m.iter().flat_map(|s| [s.top, s.bottom]).collect();
        let a = Array2::from_shape_vec((m.len(), 2), flat)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Some(PyArray2::from_owned_array(py, a)))
    }

    /// Sets the stimulus of every face (growth scenes), held constant from now on: an array of
    /// length m (the same value at top and bottom) or m × 2 (top, bottom).
    fn set_stimulus(&self, values: &Bound<'_, PyAny>) -> PyResult<()> {
        let np = values.py().import("numpy")?;
        let arr = np.call_method1("asarray", (values, "float64"))?;
        let ndim: usize = arr.getattr("ndim")?.extract()?;
        let stimulus: Vec<FaceStimulus> = match ndim {
            1 => {
                let v: Vec<f64> = arr.call_method0("tolist")?.extract()?;
                v.into_iter().map(FaceStimulus::uniform).collect()
            }
            2 => {
                let v: Vec<[f64; 2]> = arr.call_method0("tolist")?.extract().map_err(|_| {
                    PyValueError::new_err("stimulus: expected shape (m,) or (m, 2)")
                })?;
                v.into_iter()
                    .map(|[top, bottom]| FaceStimulus { top, bottom })
                    .collect()
            }
            _ => {
                return Err(PyValueError::new_err(
                    "stimulus: expected shape (m,) or (m, 2)",
                ));
            }
        };
        self.lock()?
            .sim
            .set_stimulus(stimulus)
            .map_err(errors::simulation)
    }

    fn __repr__(&self) -> String {
        let s = self.snap();
        format!(
            "Simulation({:?}, step {}/{}, t = {:e} s)",
            self.scene.inner.name(),
            s.steps_done,
            s.steps_total,
            s.time
        )
    }
}

/// The energies of a snapshot by term, J.
fn energies_dict<'py>(py: Python<'py>, s: &Snapshot) -> PyResult<Bound<'py, PyDict>> {
    let e = s.energy;
    let d = PyDict::new(py);
    d.set_item("stretch", e.stretch)?;
    d.set_item("bend", e.bend)?;
    d.set_item("damping", e.damping)?;
    d.set_item("elastic", e.elastic())?;
    d.set_item("kinetic", s.kinetic)?;
    Ok(d)
}

/// `a` with its writeable flag cleared (a snapshot is not a handle on the state).
fn readonly<'py, T>(a: Bound<'py, T>) -> PyResult<Bound<'py, T>> {
    a.as_any().getattr("flags")?.setattr("writeable", false)?;
    Ok(a)
}
