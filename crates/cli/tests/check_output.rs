//! `thinshell check` for a growth scene shows the energy at the grown rest state (what the
//! first step starts from), against the closed form for uniform isotropic growth of a flat sheet.
#![allow(clippy::unwrap_used)]

/// Energy (J) of a flat sheet of area `area` at its reference shape against the rest metric
/// ā = e^{2s} a (isotropic growth, b̄ = b = 0): per face h/8 ‖ā⁻¹a − I‖²_SV √det ā with
/// ā⁻¹a − I = (e^{−2s} − 1) I, ‖m I‖²_SV = 2(α + β) m², √det ā = 2 e^{2s} × face area.
fn grown_sheet_energy(area: f64, s: f64, h: f64, young: f64, nu: f64) -> f64 {
    let alpha = young * nu / (1.0 - nu * nu);
    let beta = young / (2.0 * (1.0 + nu));
    let m = (-2.0 * s).exp() - 1.0;
    0.5 * h * (alpha + beta) * m * m * (2.0 * s).exp() * area
}

/// The number after `label` and before ` J` in `text`.
fn value_after(text: &str, label: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no line `{label}` in\n{text}"));
    line[label.len()..]
        .trim()
        .trim_end_matches(" J")
        .parse()
        .unwrap()
}

#[test]
fn check_shows_the_energy_at_the_grown_rest_state() {
    let dir = std::env::temp_dir().join(format!("thinshell-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("grow.toml");
    let s = 0.1;
    std::fs::write(
        &scene,
        format!(
            "effects = [\"stretching\", \"bending\", \"growth\"]\n[mesh]\ngenerator = \"rectangle\"\n\
             width = 2.0\nheight = 0.5\nnx = 8\nny = 2\n[growth]\nmodel = \"isotropic\"\n\
             stimulus = {{ kind = \"uniform\", value = {s} }}\n[integrator]\nkind = \"static\"\n"
        ),
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .arg("check")
        .arg(&scene)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    println!("{text}");
    let grown = value_after(
        &text,
        "initial elastic energy at the grown rest state (what step 1 starts from):",
    );
    let before = value_after(
        &text,
        "initial elastic energy against the rest forms before growth:",
    );
    // Paper material (the scene's defaults): h = 1e-4 m, E = 2e9 Pa, ν = 0.3.
    let exact = grown_sheet_energy(1.0, s, 1e-4, 2e9, 0.3);
    assert!((grown / exact - 1.0).abs() < 1e-12, "{grown} vs {exact}");
    assert_eq!(before, 0.0);
    // No loads: nothing to ramp, no ramp line.
    assert!(!text.contains("load ramp"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
