#![allow(clippy::unwrap_used)]
//! `thinshell run` of the contact scene (moved from `crates/thinshell/tests/contact_scene.rs`
//! with the binary): steps.csv's contact columns and summary.json's contact totals.

use thinshell_testkit::fixtures::data_path;

/// `thinshell run` of the shipped scene (20 steps): `steps.csv` carries the contact columns,
/// every step's smallest gap is positive, and `summary.json`'s `contact` agrees with the rows.
#[test]
fn run_writes_contact_columns_and_summary() {
    let out_dir = thinshell_testkit::fixtures::fresh_temp_dir("contact-run");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .args([
            "run",
            "--quiet",
            "--set",
            "integrator.steps=20",
            "--set",
            "output.formats=[\"vtk\"]",
            "--out",
        ])
        .arg(&out_dir)
        .arg(data_path("scenes/sheet_on_sphere.toml"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
    };
    let (pairs, gap, energy) = (
        col("contact_pairs"),
        col("contact_min_gap_m"),
        col("contact_energy_J"),
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 20);
    let min_gap = rows.iter().map(|r| r[gap]).fold(f64::INFINITY, f64::min);
    let max_pairs = rows.iter().map(|r| r[pairs]).fold(0.0, f64::max);
    assert!(min_gap > 0.0, "smallest gap {min_gap}");
    // Landed by step 20: pairs active, barrier energy positive.
    let last = &rows[19];
    assert!(last[pairs] > 0.0 && last[energy] > 0.0, "{last:?}");
    // The last frame carries the contact forces (N per vertex).
    let frame = std::fs::read_to_string(out_dir.join("frame_000020.vtu")).unwrap();
    assert!(
        frame.contains("Name=\"contact_force\""),
        "no contact_force field"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    let c = &summary["contact"];
    // serde_json's default float parsing may be one ulp off.
    let summary_gap = c["min_gap_m"].as_f64().unwrap();
    assert!(
        (summary_gap - min_gap).abs() <= 1e-15 * min_gap,
        "{c} vs {min_gap}"
    );
    assert_eq!(c["max_active_pairs"].as_f64(), Some(max_pairs), "{c}");
}

/// `thinshell check` of a contact scene names the contact settings and lists every obstacle in
/// the scene's order: the pyramid mesh (5 vertices, 6 faces in `data/meshes/pyramid.obj`), then
/// the floor plane at z = −0.023 m.
#[test]
fn check_lists_the_obstacles() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .arg("check")
        .arg(data_path("scenes/sheet_on_pyramid.toml"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("contact: d̂ = ") && text.contains("κ adaptive"),
        "{text}"
    );
    assert!(
        text.contains("obstacle 0: triangle mesh, 5 vertices, 6 faces\n"),
        "{text}"
    );
    assert!(
        text.contains("obstacle 1: plane through (0e0, 0e0, -2.3e-2) m, normal (0e0, 0e0, 1e0)\n"),
        "{text}"
    );
}
