//! Runs that survive: `thinshell run --checkpoint-every` killed with SIGKILL at random moments
//! (deterministic seeds), then `thinshell resume`d, leave the same files as an uninterrupted
//! run: frames and `.pvd` byte for byte, `steps.csv` byte for byte in every deterministic column
//! (the wall-time columns differ between any two runs), `summary.json` byte for byte but for
//! `wall_s`. Corrupted, truncated and mismatched checkpoints are refused with a clear error.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use thinshell_cli::{steps_csv_header, steps_csv_timing_columns};
use thinshell_testkit::fixtures::temp_dir;
use thinshell_testkit::rng::SplitMix64;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_thinshell"))
}

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes")
}

/// A small dynamic scene (implicit Euler, damping; OBJ and VTK frames) and a small quasi-static
/// growth scene (moisture diffusion, continuation, regularised Newton).
fn cases() -> Vec<(&'static str, PathBuf, Vec<&'static str>)> {
    vec![
        (
            "implicit",
            scenes().join("square_enlarged.toml"),
            vec![
                "--set",
                "integrator.steps=300",
                "--set",
                "output.every=20",
                "--set",
                "output.formats=[\"obj\",\"vtk\"]",
                "--checkpoint-every",
                "9",
            ],
        ),
        (
            "growth",
            scenes().join("moisture_curl.toml"),
            vec![
                "--set",
                "integrator.steps=5",
                "--set",
                "output.every=2",
                "--set",
                "output.formats=[\"obj\",\"vtk\"]",
                "--checkpoint-every",
                "1",
            ],
        ),
    ]
}

fn run(scene: &Path, out: &Path, args: &[&str]) -> Output {
    bin()
        .args(["run", "--quiet", "--out"])
        .arg(out)
        .arg(scene)
        .args(args)
        .output()
        .unwrap()
}

fn resume(out: &Path) -> Output {
    bin().args(["resume", "--quiet"]).arg(out).output().unwrap()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `steps.csv` without its wall-time columns.
fn deterministic_columns(text: &str) -> String {
    let common = steps_csv_header();
    let timing_columns = steps_csv_timing_columns();
    let header: Vec<&str> = common.split(',').collect();
    let keep: Vec<bool> = header.iter().map(|h| !timing_columns.contains(h)).collect();
    text.lines()
        .map(|l| {
            l.split(',')
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(c, _)| c)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// `summary.json` without its `wall_s` line.
fn without_wall_time(text: &str) -> String {
    text.lines()
        .filter(|l| !l.trim_start().starts_with("\"wall_s\""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every output file of `a` equals the one in `b` (the checkpoint, which holds wall times,
/// aside), and `b` has no file `a` lacks.
fn assert_same_outputs(a: &Path, b: &Path, what: &str) {
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n != "checkpoint.bin")
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(a), names(b), "{what}: file lists differ");
    for name in names(a) {
        let (x, y) = (
            std::fs::read(a.join(&name)).unwrap(),
            std::fs::read(b.join(&name)).unwrap(),
        );
        let (x, y) = match name.as_str() {
            "steps.csv" => (
                deterministic_columns(&String::from_utf8(x).unwrap()),
                deterministic_columns(&String::from_utf8(y).unwrap()),
            ),
            "summary.json" => (
                without_wall_time(&String::from_utf8(x).unwrap()),
                without_wall_time(&String::from_utf8(y).unwrap()),
            ),
            _ => {
                assert!(x == y, "{what}: {name} differs");
                continue;
            }
        };
        assert_eq!(x, y, "{what}: {name} differs");
    }
}

#[test]
fn a_run_killed_at_random_moments_and_resumed_equals_an_uninterrupted_run() {
    let d = temp_dir("crash-resume");
    for (name, scene, args) in cases() {
        let reference = d.join(format!("{name}-reference"));
        let t0 = Instant::now();
        ok(&run(&scene, &reference, &args));
        let runtime = t0.elapsed();
        for seed in 0..3u64 {
            let mut rng = SplitMix64::new(seed);
            let out = d.join(format!("{name}-{seed}"));
            let mut child = bin()
                .args(["run", "--quiet", "--out"])
                .arg(&out)
                .arg(&scene)
                .args(&args)
                .spawn()
                .unwrap();
            // Once the start checkpoint exists, kill at a random moment of the run.
            let checkpoint = out.join("checkpoint.bin");
            while !checkpoint.exists() && child.try_wait().unwrap().is_none() {
                std::thread::sleep(Duration::from_millis(2));
            }
            std::thread::sleep(runtime.mul_f64(rng.uniform(0.0, 0.9)));
            let killed = child.try_wait().unwrap().is_none();
            child.kill().unwrap_or(()); // SIGKILL on Unix; the run may have ended already
            child.wait().unwrap();
            // A second interruption, during the resume, for odd seeds.
            if seed % 2 == 1 {
                let mut again = bin().args(["resume", "--quiet"]).arg(&out).spawn().unwrap();
                std::thread::sleep(runtime.mul_f64(rng.uniform(0.0, 0.5)));
                again.kill().unwrap_or(());
                again.wait().unwrap();
            }
            ok(&resume(&out));
            assert_same_outputs(
                &reference,
                &out,
                &format!("{name}, seed {seed} (killed mid-run: {killed})"),
            );
        }
    }
}

#[test]
fn ctrl_c_leaves_a_checkpoint_that_resume_continues_from() {
    let d = temp_dir("crash-ctrl-c");
    let (_, scene, mut args) = cases().remove(0);
    args.truncate(args.len() - 2); // no --checkpoint-every: Ctrl-C writes one anyway
    let reference = d.join("reference");
    ok(&run(&scene, &reference, &args));
    let out = d.join("out");
    let mut child = bin()
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&scene)
        .args(&args)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let rows = || {
        std::fs::read_to_string(out.join("steps.csv"))
            .map(|t| t.lines().count())
            .unwrap_or(0)
    };
    while rows() < 30 && child.try_wait().unwrap().is_none() {
        std::thread::sleep(Duration::from_millis(2));
    }
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let stopped = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&stopped.stderr);
    assert_eq!(
        stopped.status.code(),
        Some(130),
        "a clean stop exits with 130: {err}"
    );
    assert!(
        err.contains(&format!("thinshell resume {}", out.display())),
        "the resume command is printed: {err}"
    );
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("\"status\": \"interrupted\""), "{summary}");
    assert!(out.join("checkpoint.bin").exists());
    ok(&resume(&out));
    assert_same_outputs(&reference, &out, "Ctrl-C then resume");
}

/// A finished run with a checkpoint, for the corruption tests.
fn checkpointed_run(d: &Path) -> (PathBuf, Vec<&'static str>) {
    let (_, scene, args) = cases().remove(0);
    let out = d.join("out");
    ok(&run(&scene, &out, &args));
    assert!(out.join("checkpoint.bin").exists());
    (out, args)
}

fn refused_with(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(needle), "expected `{needle}` in: {err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
}

#[test]
fn a_corrupted_checkpoint_is_refused() {
    let d = temp_dir("crash-corrupt");
    let (out, _) = checkpointed_run(&d);
    let path = out.join("checkpoint.bin");
    let mut bytes = std::fs::read(&path).unwrap();
    let i = bytes.len() - 100;
    bytes[i] ^= 0x10; // one bit of a position
    std::fs::write(&path, &bytes).unwrap();
    refused_with(&resume(&out), "corrupted checkpoint");
}

#[test]
fn a_truncated_checkpoint_is_refused() {
    let d = temp_dir("crash-truncated");
    let (out, _) = checkpointed_run(&d);
    let path = out.join("checkpoint.bin");
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    refused_with(&resume(&out), "truncated checkpoint");
    std::fs::write(&path, b"not a checkpoint at all").unwrap();
    refused_with(&resume(&out), "not a thinshell checkpoint");
}

#[test]
fn a_checkpoint_of_a_changed_scene_is_refused() {
    let d = temp_dir("crash-mismatch");
    let scene = d.join("scene.toml");
    std::fs::copy(scenes().join("square_enlarged.toml"), &scene).unwrap();
    let out = d.join("out");
    ok(&run(
        &scene,
        &out,
        &["--set", "integrator.steps=20", "--checkpoint-every", "5"],
    ));
    // The scene file changes after the run (another Δt): resuming would continue the wrong run.
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, text.replace("dt = 5e-6", "dt = 4e-6")).unwrap();
    refused_with(&resume(&out), "belongs to another scene");
}

#[test]
fn resuming_a_directory_without_a_checkpoint_says_so() {
    let d = temp_dir("crash-none");
    refused_with(&resume(&d), "no checkpoint");
}
