//! Factorisation reuse (`integrator.newton.reuse_factor`, on by default for implicit steps): every
//! case is run without and with reuse, back to back in one process (A then B), and compared on
//! numeric factorisations, CG iterations, Newton iterations, wall time per step and the largest
//! distance between the two runs' final positions relative to the model size (bounding-box
//! diagonal).

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::{Context, Result};
use thinshell::scene::Scene;
use thinshell::sim::{Observer, Simulation, StepRecord};

/// One measured protocol: a scene file under `data/scenes` and its overrides.
pub(crate) struct Case {
    pub name: String,
    pub scene: &'static str,
    pub overrides: Vec<String>,
}

/// Totals of a run.
#[derive(Default)]
pub(crate) struct Totals {
    pub steps: usize,
    pub newton: usize,
    pub factorizations: usize,
    pub cg: usize,
    pub factorization_s: f64,
    pub solve_s: f64,
    pub iterative_steps: usize,
}

impl Observer for Totals {
    fn step(&mut self, _sim: &Simulation, r: &StepRecord) {
        self.steps += 1;
        self.newton += r.newton_iterations;
        self.factorizations += r.factorizations;
        self.cg += r.cg_iterations;
        self.factorization_s += r.factorization_s;
        self.solve_s += r.solve_s;
        self.iterative_steps += usize::from(r.iterative);
    }
}

/// Runs `case` with `extra` overrides; returns the totals, wall time (s) and the simulation.
pub(crate) fn run_case(case: &Case, extra: &[&str]) -> Result<(Totals, f64, Simulation)> {
    let path = crate::common::workspace_root()
        .join("data")
        .join("scenes")
        .join(case.scene);
    let mut overrides = case.overrides.clone();
    overrides.extend(extra.iter().map(|s| s.to_string()));
    overrides.push("output.every=1000000".into());
    let scene = Scene::load_with_overrides(&path, &overrides)
        .with_context(|| format!("loading {}", path.display()))?;
    let mut sim = Simulation::build(&scene).with_context(|| format!("setting up {}", case.name))?;
    let mut totals = Totals::default();
    let stop = AtomicBool::new(false);
    let t0 = Instant::now();
    sim.run(&mut totals, &stop)
        .with_context(|| format!("running {}", case.name))?;
    Ok((totals, t0.elapsed().as_secs_f64(), sim))
}

/// Bounding-box diagonal of the final positions of `a` (m).
fn size(a: &Simulation) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in a.positions() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let d = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    d.max(f64::MIN_POSITIVE)
}

/// Largest distance between two position sets, relative to the bounding-box diagonal of `a`.
pub(crate) fn relative_difference(a: &Simulation, b: &Simulation) -> f64 {
    let (pa, pb) = (a.positions(), b.positions());
    let diag = size(a);
    let d = pa
        .iter()
        .zip(pb)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max);
    d / diag
}

fn cases(quick: bool) -> Vec<Case> {
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    if quick {
        return vec![
            Case {
                name: "sphere uniform heat, seed protocol, 5 steps".into(),
                scene: "sphere_uniform_heat.toml",
                overrides: s(&["integrator.steps=5"]),
            },
            Case {
                name: "square cylinder, static Newton (bench-square fast)".into(),
                scene: "square_cylinder.toml",
                overrides: s(&[
                    "effects=[\"stretching\", \"bending\"]",
                    "integrator.kind=\"static\"",
                    "integrator.steps=1",
                    "integrator.newton.line_search=true",
                ]),
            },
        ];
    }
    let mut v = Vec::new();
    for (name, scene) in [
        ("square enlarged", "square_enlarged.toml"),
        ("square rhombus", "square_rhombus.toml"),
        ("square cylinder", "square_cylinder.toml"),
    ] {
        v.push(Case {
            name: format!("{name}, seed protocol (1000 steps of 5e-6 s)"),
            scene,
            overrides: Vec::new(),
        });
        v.push(Case {
            name: format!("{name}, static Newton (bench-square fast)"),
            scene,
            overrides: s(&[
                "effects=[\"stretching\", \"bending\"]",
                "integrator.kind=\"static\"",
                "integrator.steps=1",
                "integrator.newton.line_search=true",
            ]),
        });
        v.push(Case {
            name: format!("{name}, hard case dt = 1e-3 s, 20 steps"),
            scene,
            overrides: s(&[
                "integrator.dt=1e-3",
                "integrator.steps=20",
                "integrator.newton.line_search=true",
                "integrator.adaptive_dt=true",
            ]),
        });
    }
    for (name, scene) in [
        ("sphere uniform heat", "sphere_uniform_heat.toml"),
        ("sphere directed heat", "sphere_directed_heat.toml"),
    ] {
        v.push(Case {
            name: format!("{name}, seed protocol, 200 steps"),
            scene,
            overrides: s(&["integrator.steps=200"]),
        });
    }
    v.push(Case {
        name: "sphere uniform heat, 20 480 faces (level 5), 5 steps".into(),
        scene: "sphere_uniform_heat.toml",
        overrides: s(&["integrator.steps=5", "mesh.level=5"]),
    });
    // The library's default form (the seed's scenes name the average).
    v.push(Case {
        name: "sphere uniform heat, edge_director_tan, seed protocol, 200 steps".into(),
        scene: "sphere_uniform_heat.toml",
        overrides: s(&["integrator.steps=200", "bending.form=\"edge_director_tan\""]),
    });
    v.push(Case {
        name: "sphere uniform heat, edge_director_tan, 20 480 faces, 5 steps".into(),
        scene: "sphere_uniform_heat.toml",
        overrides: s(&[
            "integrator.steps=5",
            "mesh.level=5",
            "bending.form=\"edge_director_tan\"",
        ]),
    });
    v
}

/// The markdown section: a table of every case without and with reuse.
pub(crate) fn section(quick: bool) -> Result<String> {
    let mut md = String::from(
        "### Factor reuse\n\n`cargo xtask perf` (section `reuse`; `--quick`: two small cases). \
         Each case runs without, then with `integrator.newton.reuse_factor=true` (the default of \
         implicit steps since issue #31; static solves keep `false`) in one process; \
         Δx is the largest distance between the two final position sets over the bounding-box \
         diagonal.\n\n\
         | case | steps | Newton it. off / on | factorisations off / on | CG it. (on) | wall s/step off / on | ratio | Δx / size | rms Δx mod rigid / size |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for case in cases(quick) {
        let (a, wa, sa) = run_case(&case, &["integrator.newton.reuse_factor=false"])?;
        let (b, wb, sb) = run_case(&case, &["integrator.newton.reuse_factor=true"])?;
        let diff = relative_difference(&sa, &sb);
        let rigid = thinshell::reference::rms_distance_modulo_rigid(sa.positions(), sb.positions())
            .unwrap_or(f64::NAN)
            / size(&sa);
        let per = |w: f64, t: &Totals| w / t.steps.max(1) as f64;
        md += &format!(
            "| {} | {} | {} / {} | {} / {} | {} | {:.4} / {:.4} | {:.2} | {:.1e} | {:.1e} |\n",
            case.name,
            a.steps,
            a.newton,
            b.newton,
            a.factorizations,
            b.factorizations,
            b.cg,
            per(wa, &a),
            per(wb, &b),
            wa / wb.max(1e-12),
            diff,
            rigid
        );
    }
    Ok(md)
}
