//! `Simulation`: a built scene, stepped with the GIL released.

use std::sync::Mutex;

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thinshell::scene::Scene;
use thinshell::sim::{BuildError, Energies, Simulation, StepRecord};
use thinshell_energy::RestState;
use thinshell_growth::FaceStimulus;

use crate::mesh::PyMesh;
use crate::scene::PyScene;
use crate::{convert, errors};

/// `(a_bar, b_bar)`, each m × 2 × 2.
type Forms<'py> = (Bound<'py, PyArray3<f64>>, Bound<'py, PyArray3<f64>>);

/// The simulation and what the wrapper adds up over the steps taken through it.
struct Inner {
    sim: Simulation,
    /// The simulation's own thread pool (`threads=`), else rayon's global pool.
    pool: Option<rayon::ThreadPool>,
    newton_iterations: usize,
    gauss_newton_iterations: usize,
    stable: Option<bool>,
    unstable_steps: Vec<usize>,
    wall_s: f64,
    status: &'static str,
    error: Option<String>,
}

impl Inner {
    fn record(&mut self, r: &StepRecord) {
        self.newton_iterations += r.newton_iterations;
        self.gauss_newton_iterations += r.gauss_newton_iterations;
        self.wall_s += r.wall_s;
        self.stable = r.stable;
        if r.stable == Some(false) {
            self.unstable_steps.push(r.step);
        }
        self.status = if self.sim.steps_done() >= self.sim.steps_total() {
            "completed"
        } else {
            "running"
        };
    }
}

/// A simulation built from a scene (`thinshell::sim::Simulation`).
#[pyclass(name = "Simulation", module = "thinshell", frozen)]
pub struct PySimulation {
    // A lock rather than `&mut self`, so that Rust can work with the GIL released; two Python
    // threads using the *same* simulation get an error instead of waiting (no deadlock).
    inner: Mutex<Inner>,
}

/// The scene argument of `Simulation(...)`: a `Scene`, a dict, or a path to a scene file.
fn scene_of(obj: &Bound<'_, PyAny>) -> PyResult<Scene> {
    if let Ok(s) = obj.cast::<PyScene>() {
        return Ok(s.get().inner.clone());
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
    Ok(built.cast::<PyScene>()?.get().inner.clone())
}

fn build_error(e: BuildError) -> PyErr {
    match e {
        BuildError::Mesh { .. } | BuildError::MeshFile { .. } => errors::mesh(e),
        _ => errors::scene(e),
    }
}

impl PySimulation {
    fn lock(&self) -> PyResult<std::sync::MutexGuard<'_, Inner>> {
        match self.inner.try_lock() {
            Ok(g) => Ok(g),
            Err(std::sync::TryLockError::WouldBlock) => Err(PyRuntimeError::new_err(
                "this Simulation is in use by another thread (one thread per simulation)",
            )),
            Err(std::sync::TryLockError::Poisoned(p)) => Ok(p.into_inner()),
        }
    }

    /// One step with the GIL released; the record, or a `SimulationError`.
    fn step_inner(&self, py: Python<'_>, inner: &mut Inner) -> PyResult<StepRecord> {
        let Inner { sim, pool, .. } = inner;
        let result = py.detach(|| match pool {
            Some(pool) => pool.install(|| sim.step()),
            None => sim.step(),
        });
        match result {
            Ok(r) => {
                inner.record(&r);
                Ok(r)
            }
            Err(e) => {
                inner.status = "failed";
                inner.error = Some(e.to_string());
                Err(errors::simulation(e))
            }
        }
    }
}

#[pymethods]
impl PySimulation {
    /// Builds the simulation a scene describes (`Scene`, dict, or path to a TOML file).
    /// `threads`: the number of threads its steps use (its own pool); default: the shared
    /// pool of all cores (`RAYON_NUM_THREADS`).
    #[new]
    #[pyo3(signature = (scene, threads=None))]
    fn new(py: Python<'_>, scene: &Bound<'_, PyAny>, threads: Option<usize>) -> PyResult<Self> {
        let scene = scene_of(scene)?;
        let pool = match threads {
            Some(0) => return Err(PyValueError::new_err("threads must be at least 1")),
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| PyRuntimeError::new_err(format!("thread pool: {e}")))?,
            ),
            None => None,
        };
        let sim = py
            .detach(|| Simulation::build(&scene))
            .map_err(build_error)?;
        Ok(PySimulation {
            inner: Mutex::new(Inner {
                sim,
                pool,
                newton_iterations: 0,
                gauss_newton_iterations: 0,
                stable: None,
                unstable_steps: Vec::new(),
                wall_s: 0.0,
                status: "ready",
                error: None,
            }),
        })
    }

    /// Takes one step; returns its record (a dict: step, time, energy, newton_iterations, …).
    fn step<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut inner = self.lock()?;
        let r = self.step_inner(py, &mut inner)?;
        convert::to_py(py, &r)
    }

    /// Runs the remaining steps of the scene, calling `callback(sim, record)` after every
    /// `every`-th step and after the last; returns the summary. Ctrl-C stops after the current
    /// step (KeyboardInterrupt).
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
        let value = serde_json::json!({
            "name": s.name(),
            "status": inner.status,
            "error": inner.error,
            "steps": s.steps_done(),
            "steps_requested": s.steps_total(),
            "time_s": s.time(),
            "energy": Energies::from(s.energy()),
            "wall_s": inner.wall_s,
            "newton_iterations": inner.newton_iterations,
            "gauss_newton_iterations": inner.gauss_newton_iterations,
            "load_factor": s.load_factor(),
            "stable": inner.stable,
            "unstable_steps": inner.unstable_steps,
        });
        convert::to_py(py, &value)
    }

    /// What will be simulated (the text `thinshell check` prints).
    fn describe(&self) -> PyResult<String> {
        Ok(thinshell::cli::describe(&self.lock()?.sim))
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> PyResult<String> {
        Ok(self.lock()?.sim.name().to_string())
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
        Ok(convert::points_to_py(py, self.lock()?.sim.positions()))
    }
    /// Current velocities, n × 3, m/s.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(convert::points_to_py(py, self.lock()?.sim.velocities()))
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
    fn time(&self) -> PyResult<f64> {
        Ok(self.lock()?.sim.time())
    }
    /// Time step, s.
    #[getter]
    fn dt(&self) -> PyResult<f64> {
        Ok(self.lock()?.sim.dt())
    }
    /// Steps taken.
    #[getter]
    fn steps_done(&self) -> PyResult<usize> {
        Ok(self.lock()?.sim.steps_done())
    }
    /// Steps the scene asks for.
    #[getter]
    fn steps_total(&self) -> PyResult<usize> {
        Ok(self.lock()?.sim.steps_total())
    }
    /// Load factor λ of the current state.
    #[getter]
    fn load_factor(&self) -> PyResult<f64> {
        Ok(self.lock()?.sim.load_factor())
    }
    /// Energies of the current state by term, J: stretch, bend, damping (of the last step),
    /// elastic (stretch + bend), kinetic.
    #[getter]
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let inner = self.lock()?;
        let e = Energies::from(inner.sim.energy());
        let d = PyDict::new(py);
        d.set_item("stretch", e.stretch)?;
        d.set_item("bend", e.bend)?;
        d.set_item("damping", e.damping)?;
        d.set_item("elastic", e.elastic())?;
        d.set_item("kinetic", inner.sim.kinetic_energy())?;
        Ok(d)
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
        };
        let mut inner = self.lock()?;
        let sim = &mut inner.sim;
        a_bar
            .py()
            .detach(|| sim.set_rest_forms(rest))
            .map_err(errors::simulation)
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

    fn __repr__(&self) -> PyResult<String> {
        let inner = self.lock()?;
        Ok(format!(
            "Simulation({:?}, step {}/{}, t = {:e} s)",
            inner.sim.name(),
            inner.sim.steps_done(),
            inner.sim.steps_total(),
            inner.sim.time()
        ))
    }
}
