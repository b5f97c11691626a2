//! `cargo xtask bench-square`: the seed's three square experiments (model.md §5), run the seed's
//! way and the fast way, compared on wall time and distance to the analytic equilibrium. The
//! seed's scenes use the paper's mid-edge average; the cylinder also gets a fast row with the
//! library's default form (edge directors, tan).

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::{Context, Result};
use serde_json::json;
use thinshell::reference::{SquareCase, rms_distance_modulo_rigid};
use thinshell::scene::Scene;
use thinshell::sim::{Observer, Simulation, StepRecord};

use crate::plot::{Chart, Mark, Series, save};

/// One way of solving a case.
struct Method {
    name: &'static str,
    overrides: &'static [&'static str],
    /// Skipped with `--quick`.
    slow: bool,
    /// Run on the cylinder only (the bending form matters only where the shell curves).
    cylinder_only: bool,
}

const METHODS: &[Method] = &[
    Method {
        name: "seed: implicit Euler, dt=5e-6 s, no line search, 1000 steps",
        overrides: &[],
        slow: true,
        cylinder_only: false,
    },
    Method {
        name: "fast: static Newton with line search",
        overrides: &[
            "effects=[\"stretching\", \"bending\"]",
            "integrator.kind=\"static\"",
            "integrator.steps=1",
            "integrator.newton.line_search=true",
        ],
        slow: false,
        cylinder_only: false,
    },
    // The seed's scenes name the paper's mid-edge average; this row shows the library's default
    // form (edge directors, tan) on the same mesh and solve.
    Method {
        name: "fast: static Newton, default form (edge_director_tan)",
        overrides: &[
            "effects=[\"stretching\", \"bending\"]",
            "integrator.kind=\"static\"",
            "integrator.steps=1",
            "integrator.newton.line_search=true",
            "bending.form=\"edge_director_tan\"",
        ],
        slow: false,
        cylinder_only: true,
    },
];

fn scene_file(case: SquareCase) -> &'static str {
    match case {
        SquareCase::Enlarged => "square_enlarged.toml",
        SquareCase::Rhombus => "square_rhombus.toml",
        SquareCase::Cylinder => "square_cylinder.toml",
    }
}

/// Records the elastic energy after every step.
#[derive(Default)]
struct EnergyTrace {
    points: Vec<(f64, f64)>,
}

impl Observer for EnergyTrace {
    fn step(&mut self, _sim: &Simulation, record: &StepRecord) {
        self.points
            .push((record.time, record.energy.stretch + record.energy.bend));
    }
}

/// Runs the task.
pub fn run(quick: bool) -> Result<()> {
    let out = crate::common::out_dir();
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let scenes = crate::common::workspace_root().join("data").join("scenes");
    let stop = AtomicBool::new(false);
    let mut rows = Vec::new();
    let mut traces = Vec::new();
    println!(
        "{:<18} {:<62} {:>6} {:>6} {:>10} {:>11} {:>11}",
        "case", "method", "faces", "steps", "wall [s]", "error [m]", "energy [J]"
    );
    for case in SquareCase::ALL {
        let methods = METHODS
            .iter()
            .filter(|m| !(quick && m.slow))
            .filter(|m| !m.cylinder_only || matches!(case, SquareCase::Cylinder));
        for method in methods {
            let path = scenes.join(scene_file(case));
            let overrides: Vec<String> = method.overrides.iter().map(|s| s.to_string()).collect();
            let scene = Scene::load_with_overrides(&path, &overrides)
                .with_context(|| format!("loading {}", path.display()))?;
            let mut sim = Simulation::build(&scene)
                .with_context(|| format!("setting up {}", path.display()))?;
            let mut trace = EnergyTrace::default();
            let t0 = Instant::now();
            let summary = sim
                .run(&mut trace, &stop)
                .with_context(|| format!("running {} ({})", case.name(), method.name))?;
            let wall = t0.elapsed().as_secs_f64();
            let target = case.equilibrium(sim.reference_positions());
            let error = rms_distance_modulo_rigid(sim.positions(), &target)
                .context("comparing with the analytic equilibrium")?;
            let energy = summary.final_energy.stretch + summary.final_energy.bend;
            println!(
                "{:<18} {:<62} {:>6} {:>6} {:>10.3} {:>11.3e} {:>11.3e}",
                case.name(),
                method.name,
                sim.mesh().n_faces(),
                summary.steps,
                wall,
                error,
                energy
            );
            rows.push(json!({
                "case": case.name(),
                "method": method.name,
                "bending_form": sim.model().sff.name(),
                "faces": sim.mesh().n_faces(),
                "steps": summary.steps,
                "wall_s": wall,
                "error": error,
                "energy": energy,
                "newton_iterations": summary.newton_iterations,
            }));
            if method.slow {
                traces.push((case, trace.points));
            }
        }
    }
    let json_path = out.join("bench-square.json");
    crate::common::write_json(&json_path, &rows)?;
    println!("\nwrote {}", json_path.display());
    if !traces.is_empty() {
        let chart = Chart {
            title: "Elastic energy of the unit square (seed's Figure 4)".into(),
            x_label: "time [s]".into(),
            y_label: "elastic energy [J]".into(),
            log_x: false,
            log_y: true,
            series: traces
                .into_iter()
                .map(|(case, points)| Series {
                    name: case.name().into(),
                    points,
                    mark: Mark::Line,
                })
                .collect(),
        };
        for p in save(&chart, &out.join("bench-square-energy"))? {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
