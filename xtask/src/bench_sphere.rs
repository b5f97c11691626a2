//! `cargo xtask bench-sphere`: the seed's two sphere experiments (uniform heat, directed heat;
//! model.md §5) with the seed's settings, energy plots (the seed's Figure 6) and rendered shapes
//! at several times (Figures 1 and 5).

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::{Context, Result};
use nalgebra::Vector3;
use serde_json::json;
use thinshell::scene::Scene;
use thinshell::sim::{Observer, Simulation, StepRecord};

use crate::plot::{Chart, Mark, Series, save};
use crate::render::{Image, View, render, save_panels};

const CASES: [(&str, &str); 2] = [
    ("uniform heat", "sphere_uniform_heat.toml"),
    ("directed heat", "sphere_directed_heat.toml"),
];
const PANELS: usize = 5;
const PANEL_SIZE: usize = 300;

fn view() -> View {
    View {
        forward: Vector3::new(-1.0, 1.6, -0.7),
        up: Vector3::z(),
        center: Vector3::zeros(),
        half_extent: 1.15,
    }
}

/// Energy after every step and renders at evenly spaced steps.
struct Recorder {
    energy: Vec<(f64, f64)>,
    every: usize,
    panels: Vec<(Image, String)>,
    faces: Vec<[usize; 3]>,
}

impl Recorder {
    fn snapshot(&mut self, sim: &Simulation) {
        let img = render(&self.faces, sim.positions(), &view(), PANEL_SIZE);
        let caption = format!("t = {:.2} ms (step {})", 1e3 * sim.time(), sim.steps_done());
        self.panels.push((img, caption));
    }
}

impl Observer for Recorder {
    fn start(&mut self, sim: &Simulation) {
        self.energy
            .push((0.0, sim.energy().stretch + sim.energy().bend));
        self.snapshot(sim);
    }
    fn step(&mut self, sim: &Simulation, r: &StepRecord) {
        self.energy.push((r.time, r.energy.elastic()));
        if sim.steps_done() % self.every == 0 {
            self.snapshot(sim);
        }
    }
}

/// Runs the task; `quick` runs 200 steps instead of the seed's 2000.
pub fn run(quick: bool) -> Result<()> {
    let out = crate::common::out_dir();
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let scenes = crate::common::workspace_root().join("data").join("scenes");
    let stop = AtomicBool::new(false);
    let overrides: Vec<String> = if quick {
        vec!["integrator.steps=200".into()]
    } else {
        vec![]
    };
    let mut rows = Vec::new();
    let mut series = Vec::new();
    println!(
        "{:<14} {:>6} {:>6} {:>9} {:>10} {:>12} {:>12} {:>10}",
        "case", "faces", "steps", "wall [s]", "ms/step", "E_end [J]", "mean radius", "min z"
    );
    for (name, file) in CASES {
        let path = scenes.join(file);
        let scene = Scene::load_with_overrides(&path, &overrides)
            .with_context(|| format!("loading {}", path.display()))?;
        let mut sim =
            Simulation::build(&scene).with_context(|| format!("setting up {}", path.display()))?;
        let mut rec = Recorder {
            energy: Vec::new(),
            every: (sim.steps_total() / (PANELS - 1)).max(1),
            panels: Vec::new(),
            faces: sim.mesh().faces_usize(),
        };
        let t0 = Instant::now();
        let summary = sim
            .run(&mut rec, &stop)
            .with_context(|| format!("running {name}"))?;
        let wall = t0.elapsed().as_secs_f64();
        let x = sim.positions();
        let radius = x.iter().map(|p| p.norm()).sum::<f64>() / x.len() as f64;
        let min_z = x.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
        let energy = summary.final_energy.stretch + summary.final_energy.bend;
        let ms = 1e3 * wall / summary.steps.max(1) as f64;
        println!(
            "{name:<14} {:>6} {:>6} {wall:>9.2} {ms:>10.2} {energy:>12.4e} {radius:>12.5} {min_z:>10.4}",
            sim.mesh().n_faces(),
            summary.steps
        );
        rows.push(json!({
            "case": name,
            "faces": sim.mesh().n_faces(),
            "steps": summary.steps,
            "wall_s": wall,
            "ms_per_step": ms,
            "energy": energy,
            "mean_radius": radius,
            "newton_iterations": summary.newton_iterations,
        }));
        let stem = format!("bench-sphere-{}", name.replace(' ', "-"));
        let png = out.join(format!("{stem}.png"));
        let title = format!(
            "Unit sphere, {name} (seed's settings: implicit Euler, dt = 5e-6 s, no line search)"
        );
        save_panels(&rec.panels, &title, &png)?;
        println!("wrote {}", png.display());
        series.push(Series {
            name: name.into(),
            points: rec.energy,
            mark: Mark::Line,
        });
    }
    let json_path = out.join("bench-sphere.json");
    crate::common::write_json(&json_path, &rows)?;
    println!("wrote {}", json_path.display());
    let chart = Chart {
        title: "Elastic energy of the unit sphere under heat (seed's Figure 6)".into(),
        x_label: "time [s]".into(),
        y_label: "elastic energy [J]".into(),
        log_x: false,
        log_y: false,
        series,
    };
    for p in save(&chart, &out.join("bench-sphere-energy"))? {
        println!("wrote {}", p.display());
    }
    Ok(())
}
