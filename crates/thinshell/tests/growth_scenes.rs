//! The shipped growth scenes run through the library, and do what the physics says.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use nalgebra::Vector3;
use thinshell::scene::Scene;
use thinshell::sim::{Observer, Simulation, StepRecord};
use thinshell_testkit::fixtures::data_path;

fn scene(name: &str, overrides: &[&str]) -> Scene {
    let p = data_path(&format!("scenes/{name}"));
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Scene::load_with_overrides(&p, &o).unwrap()
}

#[test]
fn every_shipped_scene_builds() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes");
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        let s = Scene::load(&p).unwrap();
        if let Err(e) = Simulation::build(&s) {
            panic!("{}: {e}", p.display());
        }
    }
}

#[test]
fn uniform_heat_sets_the_rest_metric_once() {
    let mut sim = Simulation::build(&scene("sphere_uniform_heat.toml", &[])).unwrap();
    for _ in 0..5 {
        sim.step().unwrap();
    }
    let g = sim.growth().unwrap();
    assert_eq!(g.rest_updates(), 1, "a constant stimulus is applied once");
    for (a, a0) in sim.system().rest().a_bar.iter().zip(&g.initial().a_bar) {
        assert!(
            (a - a0 * 0.9).norm() < 1e-15 * a0.norm(),
            "ā = 0.9 a⁰ (model.md §5)"
        );
    }
    assert_eq!(
        sim.system().rest().b_bar,
        g.initial().b_bar,
        "p = 0: b̄ = b⁰"
    );
    // The sphere starts to shrink: mean radius below 1.
    let r: f64 =
        sim.positions().iter().map(|p| p.norm()).sum::<f64>() / sim.positions().len() as f64;
    assert!(r < 1.0 && r > 0.9, "{r}");
}

#[test]
fn directed_heat_holds_the_cap_and_the_bottom() {
    let mut sim = Simulation::build(&scene("sphere_directed_heat.toml", &[])).unwrap();
    for _ in 0..3 {
        sim.step().unwrap();
    }
    let x = sim.reference_positions();
    let rest = sim.system().rest();
    let g = sim.growth().unwrap();
    let (mut hot, mut held, mut between) = (0, 0, 0);
    for (f, face) in sim.mesh().faces().iter().enumerate() {
        let z: Vec<f64> = face.iter().map(|v| x[v.idx()].z).collect();
        let ratio = rest.a_bar[f][(0, 0)] / g.initial().a_bar[f][(0, 0)];
        if z.iter().all(|&z| z > 0.75) {
            assert!((ratio - 0.75).abs() < 1e-14, "hot face {f}: {ratio}");
            hot += 1;
        } else if z.iter().all(|&z| z <= 0.0) {
            assert_eq!(ratio, 1.0, "held face {f}");
            held += 1;
        } else if ratio < 1.0 {
            assert!(ratio > 0.75);
            between += 1;
        }
    }
    assert!(hot > 0 && held > 0 && between > 0, "{hot} {held} {between}");
}

/// Records, at every step, the strip's tip rotation and the natural curvature of its rest forms.
struct Curl {
    samples: Vec<(f64, f64)>,
}

impl Observer for Curl {
    fn step(&mut self, sim: &Simulation, _r: &StepRecord) {
        // Centre line (row 2) of the 50 × 4 grid: vertices 102..=152; the tip is the last.
        let x = sim.positions();
        let t: Vector3<f64> = (x[152] - x[151]).normalize();
        let angle = (-t.z).atan2(t.x);
        // Natural curvature −tr(ā⁻¹b̄)/2 of a face in the middle (the stimulus is uniform in x).
        let rest = sim.system().rest();
        let f = 50;
        let kappa = -(rest.a_bar[f].try_inverse().unwrap() * rest.b_bar[f]).trace() / 2.0;
        self.samples.push((angle, kappa));
    }
}

#[test]
fn moisture_strip_follows_its_natural_curvature() {
    let mut sim = Simulation::build(&scene("moisture_curl.toml", &[])).unwrap();
    let mut curl = Curl { samples: vec![] };
    sim.run(&mut curl, &std::sync::atomic::AtomicBool::new(false))
        .unwrap();
    // The rest forms of step k are those of the stimulus after k − 1 diffusion steps; a narrow
    // clamped strip of length L = 0.1 m relaxes to an arc, so its tip turns by κ·L.
    let (mut peak, mut last) = (0.0f64, 0.0);
    for (k, &(angle, kappa)) in curl.samples.iter().enumerate().skip(1) {
        let want = kappa * 0.1;
        // Narrow-strip regime w²κ/h ≪ 1 (w = 2 mm, h = 0.1 mm): within 1.5 % (measured
        // +1.1 … +1.3 %, the mid-edge average with 4 cells across); at the peak w²κ/h ≈ 0.8 and
        // the strip bends 3 % less than κL (the finite-width correction). The clamp holds the
        // whole first cell (Δx = 2 mm) flat, a first-order error of about Δx/(2L) = 1 % in the
        // tip angle (docs/scenes.md, clamps); holding only part of the second row, as clamps
        // did before, gave +0.3 … +0.5 % here.
        let narrowness = 0.002f64.powi(2) * kappa.abs() / 1e-4;
        let tol = if narrowness < 0.1 { 0.015 } else { 0.05 };
        assert!(
            (angle / want - 1.0).abs() < tol,
            "step {}: tip {angle} vs κL {want} (w²κ/h = {narrowness})",
            k + 1
        );
        peak = peak.max(angle);
        last = angle;
    }
    // Wetting the top curls it (the swollen top convex) by more than a quarter turn at first
    // (κ up to c/h = 20 1/m), then it uncurls as the moisture evens out.
    assert!(peak > 1.3 && last < 0.2 * peak, "peak {peak}, last {last}");
}

#[test]
fn bad_growth_settings_name_the_key() {
    let base = |extra: &str| {
        format!(
            r#"
name = "bad"
effects = ["stretching", "bending", "growth"]
[mesh]
generator = "rectangle"
[integrator]
kind = "static"
[growth]
model = "linear"
coefficient = 0.01
{extra}
[growth.stimulus]
kind = "uniform"
value = 1.0
"#
        )
    };
    for (extra, key) in [
        ("direction = [1.0, 0.0, 0.0]", "growth.cross_coefficient"),
        ("cross_coefficient = 0.1", "growth.direction"),
        (
            "direction = [0.0, 0.0, 0.0]\ncross_coefficient = 0.1",
            "growth.direction",
        ),
        ("mass_uptake = nan", "growth.mass_uptake"),
    ] {
        let e = Scene::from_toml(&base(extra), "bad.toml", std::path::Path::new("."))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(key), "{extra}: {e}");
    }
    // A direction normal to the sheet is refused when the simulation is built.
    let s = Scene::from_toml(
        &base("direction = [0.0, 0.0, 1.0]\ncross_coefficient = 0.1"),
        "bad.toml",
        std::path::Path::new("."),
    )
    .unwrap();
    let e = Simulation::build(&s).err().unwrap().to_string();
    assert!(
        e.contains("growth") && e.contains("normal to the face"),
        "{e}"
    );
}
