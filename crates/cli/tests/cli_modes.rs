//! `thinshell modes` end to end (docs/modal.md): the simply supported steel plate scene's
//! `modes.json` (frequencies ascending, in Hz, against Kirchhoff's), one VTK frame per mode
//! that the viewer loads, and a clear error for a bad count.
#![allow(clippy::unwrap_used)]

use std::f64::consts::PI;
use std::process::Command;

use thinshell_cli::view::run::Run;
use thinshell_testkit::fixtures::{data_path as data, temp_dir};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_thinshell"))
}

#[test]
fn plate_modes_are_written_and_match_kirchhoff() {
    let out_dir = temp_dir("cli-modes").join("plate");
    let out = bin()
        .arg("modes")
        .arg(data("scenes/plate_modes.toml"))
        .args(["--count", "4", "--out"])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("modes.json")).unwrap())
            .unwrap();
    let f: Vec<f64> = json["frequencies_hz"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    // Kirchhoff, a = 1.5 m, b = 1 m, h = 0.01 m, E = 200 GPa, ν = 0.3, ρ = 7850 kg/m³:
    // (1,1), (2,1), (1,2), (3,1).
    let (a, b, h, e, nu, rho) = (1.5f64, 1.0f64, 0.01f64, 2e11, 0.3, 7850.0);
    let d = e * h.powi(3) / (12.0 * (1.0 - nu * nu));
    let w =
        |m: f64, n: f64| PI * (m * m / (a * a) + n * n / (b * b)) * (d / (rho * h)).sqrt() / 2.0;
    let exact = [w(1.0, 1.0), w(2.0, 1.0), w(1.0, 2.0), w(3.0, 1.0)];
    assert_eq!(f.len(), 4);
    assert!(f.windows(2).all(|p| p[0] <= p[1]), "not ascending: {f:?}");
    for (got, want) in f.iter().zip(exact) {
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "{got} Hz vs Kirchhoff {want} Hz"
        );
    }
    let shapes = json["shapes"].as_array().unwrap();
    assert_eq!(shapes.len(), 4);
    // The viewer reads the directory: the state plus one frame per mode.
    let run = Run::load(&out_dir).unwrap();
    assert_eq!(run.frames.len(), 5);
    assert_eq!(run.n_vertices, shapes[0].as_array().unwrap().len());
}

#[test]
fn a_zero_count_is_refused() {
    let out = bin()
        .arg("modes")
        .arg(data("scenes/plate_modes.toml"))
        .args(["--count", "0", "--out"])
        .arg(temp_dir("cli-modes").join("zero"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("count"), "{err}");
}
