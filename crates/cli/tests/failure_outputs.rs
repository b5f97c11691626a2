//! Outputs that never lie: a run that fails in step 1 writes the flat start state as frame 0
//! and a `summary.json` that says what failed; `steps.csv` accounts for the whole step time;
//! `--verbose` shows every Newton iteration; a factor too big for the memory budget is refused
//! before factorising, with exit code 2 and one line.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use thinshell_cli::steps_csv_header;
use thinshell_testkit::fixtures::temp_dir;

/// A flat strip, clamped at x = 0, whose top swells: step 1 must curl it. With 10 Newton
/// iterations the full step fails, continuation's first half-steps succeed and a later one
/// fails — a half-curled shape (max |z| = 0.03 m) must not be written as "frame 0".
const FAILING: &str = r#"
name = "failing strip"
effects = ["stretching", "bending", "growth"]
[mesh]
generator = "rectangle"
width = 0.1
height = 0.01
nx = 20
ny = 4
[growth]
model = "linear"
coefficient = 0.002
[growth.stimulus]
kind = "uniform"
top = 10.0
bottom = 0.0
[[boundary.clamps]]
region = { box = { min = [-1.0, -1.0, -1.0], max = [1e-6, 1.0, 1.0] } }
[integrator]
kind = "static"
steps = 1
[integrator.newton]
max_iterations = 10
[output]
every = 1
formats = ["obj"]
"#;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_thinshell"))
}

fn write_scene(d: &Path, text: &str) -> PathBuf {
    let p = d.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn run(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    bin()
        .args(["run", "--quiet", "--out"])
        .arg(out)
        .arg(scene)
        .args(extra)
        .output()
        .unwrap()
}

fn max_abs_z(obj: &Path) -> f64 {
    std::fs::read_to_string(obj)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("v "))
        .map(|l| {
            l.split_whitespace()
                .nth(3)
                .unwrap()
                .parse::<f64>()
                .unwrap()
                .abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_run_failing_in_step_1_writes_the_flat_start_as_frame_0_and_says_why() {
    let d = temp_dir("fail-step1");
    let scene = write_scene(&d, FAILING);
    let out = d.join("out");
    let o = run(&scene, &out, &[]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        max_abs_z(&out.join("frame_000000.obj")),
        0.0,
        "frame 0 is the flat start"
    );
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["status"], "failed");
    assert_eq!(s["failed_step"], 1);
    assert_eq!(s["steps"], 0);
    assert!(
        s["error"].as_str().unwrap().contains("did not converge"),
        "{s}"
    );
    // The residual history of the failed solve: the initial residual and one per iteration.
    let history = s["residual_history"].as_array().unwrap();
    assert!(history.len() >= 2, "{s}");
    assert!(history.iter().all(|r| r.as_f64().unwrap().is_finite()));
    // The last good state is the flat start, whose energy (against the rest forms before
    // growth) is 0.
    assert_eq!(s["energy"]["stretch"], 0.0);
    assert_eq!(s["energy"]["bend"], 0.0);
}

const SMALL: &str = r#"
name = "small rhombus"
effects = ["stretching", "bending", "inertia", "damping"]
[mesh]
generator = "rectangle"
nx = 6
ny = 6
[initial]
scale = 0.95
[rest]
from = "planar"
a_xy = [[2.0, 1.0], [1.0, 2.0]]
[integrator]
kind = "implicit"
dt = 1e-4
steps = 12
[output]
every = 4
formats = ["obj", "vtk"]
"#;

#[test]
fn steps_csv_timing_columns_sum_to_the_wall_time_of_each_step() {
    let d = temp_dir("csv-sum");
    let scene = write_scene(&d, SMALL);
    let out = d.join("out");
    let o = run(&scene, &out, &["--checkpoint-every", "3"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.join(","), steps_csv_header());
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let parts = [
        "assembly_s",
        "factorization_s",
        "solve_s",
        "line_search_s",
        "growth_s",
        "output_s",
        "other_s",
    ];
    let mut rows = 0;
    let mut output_total = 0.0;
    for line in lines {
        // Empty cells: columns that do not apply to the step (min_eigenvalue of dynamic steps).
        let v: Vec<f64> = line
            .split(',')
            .map(|c| {
                if c.is_empty() {
                    f64::NAN
                } else {
                    c.parse().unwrap()
                }
            })
            .collect();
        let wall = v[col("wall_s")];
        let sum: f64 = parts.iter().map(|p| v[col(p)]).sum();
        assert!(
            (sum - wall).abs() <= 1e-12 + 1e-9 * wall,
            "{line}: parts sum to {sum}, wall {wall}"
        );
        // Every part is a measured duration; "other" is the remainder, so a negative one
        // would mean a part counted twice.
        for p in parts {
            assert!(v[col(p)] >= -1e-9 * wall, "{p} < 0 in {line}");
        }
        output_total += v[col("output_s")];
        rows += 1;
    }
    assert_eq!(rows, 12);
    // Frames (every 4 steps, OBJ + VTK with fsync) and checkpoints take measurable time.
    assert!(output_total > 0.0);
}

#[test]
fn verbose_prints_every_newton_iteration() {
    let d = temp_dir("verbose");
    let scene = write_scene(&d, SMALL);
    let out = d.join("out");
    let o = run(&scene, &out, &["--verbose", "--set", "integrator.steps=2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| l.contains(" iteration ")).collect();
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    let iterations: usize = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(6).unwrap().parse::<usize>().unwrap())
        .sum();
    assert_eq!(lines.len(), iterations, "{err}");
    assert!(
        lines[0].starts_with("step 1 iteration 1: residual "),
        "{err}"
    );
    assert!(
        lines[0].contains("step length") && lines[0].contains("Hessian"),
        "{err}"
    );
}

#[test]
fn a_factor_beyond_the_memory_budget_is_refused_before_factorising() {
    let d = temp_dir("memory");
    let scene = write_scene(&d, SMALL);
    let out = d.join("out");
    let o = bin()
        .env("THINSHELL_MEMORY_LIMIT", "4K")
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&scene)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("mesh of 49 vertices, 72 faces"), "{err}");
    assert!(
        err.contains("needs an estimated") && err.contains("4.0 KiB"),
        "{err}"
    );
    // Neither the factor nor the iterative fallback fits: both estimates are named.
    assert!(
        err.contains("iterative fallback (preconditioned CG)"),
        "{err}"
    );
    // Over the factor's estimate (203 KiB) but not the fallback's (108 KiB): the run completes
    // by preconditioned CG and says so once.
    let o = bin()
        .env("THINSHELL_MEMORY_LIMIT", "150K")
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&scene)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert_eq!(
        err.matches("Newton solves use preconditioned CG").count(),
        1,
        "{err}"
    );
    // A generous limit runs (directly: no notice).
    let o = bin()
        .env("THINSHELL_MEMORY_LIMIT", "1G")
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&scene)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("preconditioned CG"), "{err}");
}

/// An implicit step that runs out of Newton iterations (the shipped pressure-dimpling sphere at
/// 2.5× its Δt: the second step has to follow the buckling in one step) fails with the solver's
/// message and a hint at adaptive Δt; with `adaptive_dt = true` the same run completes.
#[test]
fn an_implicit_step_out_of_iterations_hints_at_adaptive_dt() {
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/scenes/sphere_pressure_dimples.toml");
    let d = temp_dir("implicit-hint");
    let fixed = ["--set", "integrator.dt=5e-4", "--set", "integrator.steps=3"];
    let out = run(&scene, &d.join("fixed"), &fixed);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("Newton did not converge in 100 iterations"),
        "{err}"
    );
    assert!(
        err.contains("hint:") && err.contains("integrator.adaptive_dt = true"),
        "{err}"
    );
    let adaptive = [&fixed[..], &["--set", "integrator.adaptive_dt=true"]].concat();
    let out = run(&scene, &d.join("adaptive"), &adaptive);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
