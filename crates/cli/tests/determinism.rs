//! The same scene gives bit-identical results whatever the number of threads and from one run
//! to the next: per-face work runs on rayon's pool, but every sum is taken in a fixed order.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;

use thinshell::scene::Scene;
use thinshell::sim::{Observer, Simulation, StepRecord};

/// Bending, damping (η/E = 1 ms, visibly damped) and growth (the seed's directed heat) on a
/// level-2 icosphere: every parallel code path of a step (stretch, bend and damping kernels,
/// assembly, growth update, stimulus step) is exercised in a small run.
const SCENE: &str = r#"
name = "determinism"
effects = ["stretching", "bending", "inertia", "damping", "growth"]
[mesh]
generator = "icosphere"
level = 2
[material]
viscosity = 2e6
[growth]
model = "isotropic"
[growth.stimulus]
kind = "directed_heat"
value = -0.14384103622589045
hot = { half_space = { point = [0.0, 0.0, 0.75], normal = [0.0, 0.0, 1.0] } }
held = { half_space = { point = [0.0, 0.0, 1e-9], normal = [0.0, 0.0, -1.0] } }
[integrator]
kind = "implicit"
dt = 5e-6
steps = 12
[output]
every = 4
formats = ["obj", "vtk"]
"#;

/// Everything a run produces that must not depend on scheduling, as raw bits.
#[derive(Debug, PartialEq, Eq)]
struct Trace {
    /// Per step: energies, kinetic energy, Newton iterations and residual.
    steps: Vec<[u64; 6]>,
    /// Final positions.
    x: Vec<[u64; 3]>,
    /// Final velocities.
    v: Vec<[u64; 3]>,
}

struct Recorder(Vec<[u64; 6]>);
impl Observer for Recorder {
    fn step(&mut self, _sim: &Simulation, r: &StepRecord) {
        self.0.push([
            r.energy.stretch.to_bits(),
            r.energy.bend.to_bits(),
            r.energy.damping.to_bits(),
            r.kinetic.to_bits(),
            r.newton_iterations as u64,
            r.residual.to_bits(),
        ]);
    }
}

fn run_with_threads(scene: &Scene, threads: usize) -> Trace {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut sim = Simulation::build(scene).unwrap();
        let mut rec = Recorder(Vec::new());
        let summary = sim.run(&mut rec, &AtomicBool::new(false)).unwrap();
        assert_eq!(summary.steps, 12);
        let bits = |p: &nalgebra::Vector3<f64>| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        Trace {
            steps: rec.0,
            x: sim.positions().iter().map(bits).collect(),
            v: sim.velocities().iter().map(bits).collect(),
        }
    })
}

#[test]
fn library_results_do_not_depend_on_the_thread_count() {
    let scene = Scene::from_toml(SCENE, "determinism.toml", Path::new(".")).unwrap();
    let reference = run_with_threads(&scene, 1);
    // The run does something: the shell moved, growth and damping are active.
    let sim = Simulation::build(&scene).unwrap();
    let x0: Vec<[u64; 3]> = sim
        .positions()
        .iter()
        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect();
    assert_ne!(reference.x, x0, "nothing moved");
    assert!(
        reference.steps.iter().any(|s| f64::from_bits(s[2]) > 0.0),
        "no damping energy"
    );
    for threads in [1, 2, 3, 3] {
        let trace = run_with_threads(&scene, threads);
        assert!(trace == reference, "{threads} threads differ from 1 thread");
    }
}

fn bin_run(scene: &Path, out: &Path, threads: &str) {
    let o = Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .env("RAYON_NUM_THREADS", threads)
        .args(["run", "--quiet", "--out"])
        .arg(out)
        .arg(scene)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `steps.csv` without the timing columns (`thinshell_cli::steps_csv_timing_columns`).
fn csv_without_timings(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let columns = thinshell_cli::steps_csv_timing_columns();
    let timing: Vec<bool> = header.iter().map(|h| columns.contains(h)).collect();
    assert_eq!(
        timing.iter().filter(|&&t| t).count(),
        columns.len(),
        "{header:?}"
    );
    text.lines()
        .map(|l| {
            l.split(',')
                .zip(&timing)
                .filter(|(_, t)| !**t)
                .map(|(c, _)| c)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}

#[test]
fn cli_outputs_do_not_depend_on_the_thread_count() {
    let d = std::env::temp_dir().join(format!("thinshell-determinism-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let scene = d.join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let outs: Vec<PathBuf> = ["1", "2"]
        .iter()
        .map(|t| {
            let out = d.join(format!("threads-{t}"));
            bin_run(&scene, &out, t);
            out
        })
        .collect();
    let (a, b) = (&outs[0], &outs[1]);

    // Frames byte for byte: the start, steps 4, 8, 12, as OBJ and VTK, and the index.
    let mut files = vec!["frames.pvd".to_string()];
    for k in [0, 4, 8, 12] {
        files.push(format!("frame_{k:06}.obj"));
        files.push(format!("frame_{k:06}.vtu"));
    }
    for f in &files {
        let (fa, fb) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(fa == fb, "{f} differs between 1 and 2 threads");
    }
    assert_ne!(
        std::fs::read(a.join("frame_000000.obj")).unwrap(),
        std::fs::read(a.join("frame_000012.obj")).unwrap(),
        "nothing moved"
    );

    // steps.csv and summary.json apart from wall-clock times.
    let (ca, cb) = (
        csv_without_timings(&a.join("steps.csv")),
        csv_without_timings(&b.join("steps.csv")),
    );
    assert_eq!(ca.len(), 13);
    assert_eq!(ca, cb);
    let summary = |p: &Path| {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(p.join("summary.json")).unwrap())
                .unwrap();
        let obj = v.as_object_mut().unwrap();
        assert!(obj.remove("wall_s").is_some());
        v
    };
    assert_eq!(summary(a), summary(b));
}
