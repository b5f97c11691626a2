//! `thinshell run` says whether a static equilibrium is stable: a strip whose rest length is
//! 1 % longer than the distance between its pinned ends, started straight and with saddles
//! kept (`integrator.newton.escape_saddles = false`), stays straight (by symmetry) — a saddle,
//! since the compression is a hundred times Euler's buckling strain — while the same strip with
//! a 1 % shorter rest length is a stable, stretched equilibrium. With the defaults the
//! compressed strip leaves the saddle and buckles into a stable arch.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::Command;

use thinshell_testkit::fixtures::temp_dir;

/// A 1 m × 0.1 m strip of paper-like film (h = 1 mm) pinned at both ends, rest metric
/// `a11` along its length.
fn scene(a11: f64, newton: &str) -> String {
    format!(
        r#"
name = "pinned strip"
effects = ["stretching", "bending"]
[mesh]
generator = "rectangle"
width = 1.0
height = 0.1
nx = 20
ny = 2
[material]
thickness = 1e-3
young = 2e9
poisson = 0.3
density = 250
[rest]
from = "planar"
a_xy = [[{a11}, 0.0], [0.0, 1.0]]
[[boundary.pins]]
region = {{ box = {{ min = [-1.0, -1.0, -1.0], max = [0.001, 2.0, 1.0] }} }}
[[boundary.pins]]
region = {{ box = {{ min = [0.999, -1.0, -1.0], max = [2.0, 2.0, 1.0] }} }}
[integrator]
kind = "static"
{newton}
"#
    )
}

fn dir() -> PathBuf {
    temp_dir("stability")
}

/// Runs the scene; returns (stderr + stdout, summary.json).
fn run(name: &str, a11: f64, newton: &str) -> (String, serde_json::Value) {
    let d = dir();
    let path = d.join(format!("{name}.toml"));
    std::fs::write(&path, scene(a11, newton)).unwrap();
    let out_dir = d.join(name);
    let out = Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .args(["run", "--out"])
        .arg(&out_dir)
        .arg(&path)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(out.status.success(), "{text}");
    let summary =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    (text, summary)
}

#[test]
fn a_saddle_is_reported_and_a_minimum_is_not() {
    // Rest length 1.01² in metric terms: compressed by 1 %, held straight by symmetry.
    let keep = "[integrator.newton]\nescape_saddles = false";
    let (text, summary) = run("compressed", 1.01 * 1.01, keep);
    println!("{text}");
    assert_eq!(summary["stable"], serde_json::json!(false), "{summary}");
    assert_eq!(
        summary["unstable_steps"],
        serde_json::json!([1]),
        "{summary}"
    );
    assert!(text.contains("warning"), "no warning line: {text}");
    // Stretched by 1 %: a minimum, no warning.
    let (text, summary) = run("stretched", 0.99 * 0.99, "");
    assert_eq!(summary["stable"], serde_json::json!(true), "{summary}");
    assert_eq!(
        summary["unstable_steps"],
        serde_json::json!([]),
        "{summary}"
    );
    assert!(!text.contains("warning"), "unexpected warning: {text}");
}

#[test]
fn with_defaults_a_straight_compressed_strip_buckles_into_a_stable_arch() {
    let (text, summary) = run("compressed-default", 1.01 * 1.01, "");
    assert_eq!(summary["stable"], serde_json::json!(true), "{summary}");
    assert_eq!(
        summary["unstable_steps"],
        serde_json::json!([]),
        "{summary}"
    );
    assert!(!text.contains("warning"), "unexpected warning: {text}");
}
