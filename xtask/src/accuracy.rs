//! `cargo xtask accuracy`: what accuracy costs in time (docs/accuracy.md).
//!
//! Runs cases with a known answer under one knob at a time (mesh resolution, Δt, Newton
//! tolerance, adaptive (default) vs Gauss–Newton Hessian, line search, implicit vs explicit Euler, static
//! solve vs dynamic relaxation), measures the error against the answer and the wall time of
//! every run, and writes `accuracy.md` with tables and log–log plots (Pareto front marked) plus
//! a JSON file with every run.
//!
//! The second-fundamental-form discretisation is one more dimension: every case runs once per
//! entry of [`FORMULATIONS`].
//!
//! Simulations are built through the library (`thinshell_solver::ShellSystem` and its
//! integrators), with the same force scale rule as the scene builder for static solves.
//!
//! Modules: [`cases`] (the cases with known answers), [`runner`] (building a system, static
//! solves and time stepping, the knobs), [`report`] (`accuracy.md` and the JSON),
//! [`plots`] (error–time and convergence plots), [`layout`] (the mesh layout × orientation ×
//! bending form study). This file holds the shared records ([`Run`], [`Case`],
//! [`Refinement`]) and [`run`], which runs the cases and writes the outputs.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use nalgebra::Vector3;
use serde_json::json;
use thinshell::reference::SquareCase;
use thinshell_energy::SffKind;

mod cases;
mod layout;
mod plots;
mod report;
mod runner;

use cases::{THICK_CYLINDER, cantilever, cap_refinement, cylinder_refinement, square, strip};
use plots::{plot_case, plot_refinement};
use report::{case_json, markdown, sff_name, summarise_knobs};
pub(crate) use report::{machine, slug};
pub(crate) use runner::shell;
use runner::{Knobs, paper, rms_rigid, static_solve};

type V3 = Vector3<f64>;

/// Second-fundamental-form discretisations compared by the study. Extend this list (e.g. with
/// the edge-director variants) and every case runs once more per entry.
pub const FORMULATIONS: &[SffKind] = &SffKind::ALL;

/// Names of the cases every study run must contain (checked by the test).
pub const CASE_NAMES: &[&str] = &[
    "enlarged square",
    "rhombus",
    "cylindrical patch",
    "cylinder under refinement",
    "spherical cap under refinement",
    "strip, linear swelling",
    "strip, bilayer swelling",
    "falling cantilever (dynamic)",
];

/// Name of the mesh layout × orientation × bending form section (for `--only`).
pub const LAYOUT_STUDY: &str = "mesh layout";

/// Where the study writes.
pub struct Options {
    /// Fewer knob values and coarser levels (< 1 minute).
    pub quick: bool,
    /// `accuracy.md` goes here, the plots into `<docs_dir>/accuracy/`.
    pub docs_dir: PathBuf,
    /// The JSON file with every run.
    pub json_path: PathBuf,
    /// Only the cases whose name contains this text (for working on one case).
    pub only: Option<String>,
}

/// The study's gradient tolerance knob for static solves (relative to the solver's force scale
/// `ShellSystem::force_scale`, E·h·L), on top of the solver's scale-free test.
const STATIC_TOLERANCE: f64 = 1e-11;
/// Static solves may take many iterations from a far start: the study's own cap, 5× the
/// solver's default `NewtonSettings::max_iterations` (100) that scenes use.
const STATIC_MAX_ITERATIONS: usize = 500;

/// One run: a point of the error–time plane.
#[derive(Clone, Debug)]
struct Run {
    /// The knob being varied (one plotted series).
    family: String,
    /// The knob values of this run.
    label: String,
    faces: usize,
    dt: Option<f64>,
    tolerance: Option<f64>,
    /// Error against the known answer (unit: the case's `error_unit`).
    error: f64,
    /// Wall time of the solve / time stepping, s (set-up of the system excluded, Newton
    /// workspace with its symbolic analysis included).
    wall_s: f64,
    newton_iterations: usize,
    steps: usize,
    /// False when Newton or the time stepping failed; the error is then that of the last
    /// accepted state.
    converged: bool,
    /// Elastic energy of the final state, J (static solves only: tells apart equilibria).
    energy: Option<f64>,
    /// Distance to the discrete equilibrium (the tightest static solve on the same mesh), same
    /// unit as `error`: the solver's share of the error (seed-mesh squares only).
    to_discrete: Option<f64>,
}

/// A convergence series under mesh refinement (also used by `cargo xtask verify`).
#[derive(Clone, Debug)]
pub(crate) struct Refinement {
    pub(crate) name: String,
    /// (faces, error).
    pub(crate) points: Vec<(usize, f64)>,
}

impl Refinement {
    /// Observed order p of error ∝ h^p with h ∝ faces^(−1/2): least-squares slope over all
    /// levels, and per consecutive pair.
    pub(crate) fn orders(&self) -> (Option<f64>, Vec<f64>) {
        let pts: Vec<(f64, f64)> = self
            .points
            .iter()
            .filter(|(f, e)| *f > 0 && e.is_finite() && *e > 0.0)
            .map(|&(f, e)| (-0.5 * (f as f64).ln(), e.ln()))
            .collect();
        let pairs = pts
            .windows(2)
            .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
            .collect();
        if pts.len() < 2 {
            return (None, pairs);
        }
        let n = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        (Some(sxy / sxx), pairs)
    }
}

/// All runs of one case and one formulation.
struct Case {
    name: &'static str,
    sff: SffKind,
    /// The known answer and how the error is measured.
    answer: String,
    error_unit: &'static str,
    runs: Vec<Run>,
    refinement: Vec<Refinement>,
    /// Measured facts worth a sentence (reference quality, stability limit, …).
    notes: Vec<String>,
    /// Recommendation lines derived from this case's runs.
    verdict: Vec<String>,
}

impl Case {
    fn new(name: &'static str, sff: SffKind, answer: String, error_unit: &'static str) -> Case {
        Case {
            name,
            sff,
            answer,
            error_unit,
            runs: Vec::new(),
            refinement: Vec::new(),
            notes: Vec::new(),
            verdict: Vec::new(),
        }
    }

    /// Indices of the runs on the Pareto front of (wall time, error): no other run is both
    /// faster and more accurate. Failed runs are left out: they produced no answer.
    fn pareto(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.runs.len())
            .filter(|&i| {
                let r = &self.runs[i];
                r.converged && r.error.is_finite() && r.wall_s.is_finite()
            })
            .collect();
        idx.sort_by(|&a, &b| {
            let (ra, rb) = (&self.runs[a], &self.runs[b]);
            ra.wall_s
                .total_cmp(&rb.wall_s)
                .then(ra.error.total_cmp(&rb.error))
        });
        let mut front = Vec::new();
        let mut best = f64::INFINITY;
        for i in idx {
            if self.runs[i].error < best {
                best = self.runs[i].error;
                front.push(i);
            }
        }
        front
    }

    /// The cheapest run whose error is within `factor` of the best error of the case.
    fn cheapest_within(&self, factor: f64) -> Option<&Run> {
        let best = self
            .runs
            .iter()
            .map(|r| r.error)
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        self.runs
            .iter()
            .filter(|r| r.converged && r.error <= factor * best.max(1e-300))
            .min_by(|a, b| a.wall_s.total_cmp(&b.wall_s))
    }
}

/// Runs the study and writes `accuracy.md`, the plots and the JSON.
pub fn run(opts: &Options) -> Result<()> {
    let t0 = Instant::now();
    let mut cases = Vec::new();
    for &sff in FORMULATIONS {
        let name = sff_name(sff);
        let mut add = |c: Result<Case>, what: &str| -> Result<()> {
            let c = c.with_context(|| format!("{what} ({name})"))?;
            println!(
                "{:<34} {:<16} {:>4} runs, {:>7.1} s so far",
                c.name,
                name,
                c.runs.len(),
                t0.elapsed().as_secs_f64()
            );
            cases.push(c);
            Ok(())
        };
        let want = |n: &str| opts.only.as_ref().is_none_or(|o| n.contains(o.as_str()));
        for case in SquareCase::ALL {
            if want(case.name()) {
                add(square(case, sff, opts.quick), case.name())?;
            }
        }
        if want(CASE_NAMES[3]) {
            add(cylinder_refinement(sff, opts.quick), CASE_NAMES[3])?;
        }
        if want(CASE_NAMES[4]) {
            add(cap_refinement(sff, opts.quick), CASE_NAMES[4])?;
        }
        if want(CASE_NAMES[5]) {
            add(strip(false, sff, opts.quick), CASE_NAMES[5])?;
        }
        if want(CASE_NAMES[6]) {
            add(strip(true, sff, opts.quick), CASE_NAMES[6])?;
        }
        // The dynamic case's reference and its explicit runs need explicit Euler, whose
        // director steps relax the angles (5–6× the cost): it compares time steps for the
        // average only, to keep the study short.
        if want(CASE_NAMES[7]) && sff.director().is_none() {
            add(cantilever(sff, opts.quick), CASE_NAMES[7])?;
        }
    }
    cases.iter_mut().for_each(summarise_knobs);
    let layouts = if opts
        .only
        .as_ref()
        .is_none_or(|o| LAYOUT_STUDY.contains(o.as_str()))
    {
        Some(layout::run(opts.quick).context("mesh layout study")?)
    } else {
        None
    };
    let total_s = t0.elapsed().as_secs_f64();

    let plot_dir = opts.docs_dir.join("accuracy");
    std::fs::create_dir_all(&plot_dir)
        .with_context(|| format!("creating {}", plot_dir.display()))?;
    let mut plots = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        plots.push((i, plot_case(c, &plot_dir)?));
    }
    let conv = plot_refinement(&cases, &plot_dir)?;
    let layout_plot = match &layouts {
        Some(study) => Some(layout::plot(study, &plot_dir)?),
        None => None,
    };
    let md_path = opts.docs_dir.join("accuracy.md");
    std::fs::write(
        &md_path,
        markdown(
            &cases,
            opts.quick,
            total_s,
            &plots,
            &conv,
            layouts.as_ref().zip(layout_plot.as_deref()),
        ),
    )
    .with_context(|| format!("writing {}", md_path.display()))?;
    println!("wrote {} and {}/", md_path.display(), plot_dir.display());

    let (nproc, cpu) = machine();
    let doc = json!({
        "quick": opts.quick,
        "nproc": nproc,
        "cpu": cpu,
        "total_wall_s": total_s,
        "cases": cases.iter().map(case_json).collect::<Vec<_>>(),
        "layout_study": layouts.as_ref().map(layout::json),
    });
    if let Some(dir) = opts.json_path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(&opts.json_path, serde_json::to_string_pretty(&doc)?)
        .with_context(|| format!("writing {}", opts.json_path.display()))?;
    println!("wrote {} ({total_s:.1} s)", opts.json_path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use anyhow::anyhow;
    use serde_json::Value;

    use super::*;

    /// The quick study runs end to end into a temporary directory and its JSON has every case,
    /// for every formulation, with finite errors and times.
    #[test]
    fn quick_study_covers_every_case() -> Result<()> {
        let dir = std::env::temp_dir().join(format!("thinshell-accuracy-{}", std::process::id()));
        let opts = Options {
            quick: true,
            docs_dir: dir.join("docs"),
            json_path: dir.join("accuracy.json"),
            only: None,
        };
        run(&opts)?;
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&opts.json_path)?)?;
        let cases = doc["cases"].as_array().ok_or_else(|| anyhow!("no cases"))?;
        for sff in FORMULATIONS {
            for name in CASE_NAMES {
                if *name == CASE_NAMES[7] && sff.director().is_some() {
                    continue;
                }
                let c = cases
                    .iter()
                    .find(|c| c["case"] == *name && c["formulation"] == sff_name(*sff))
                    .ok_or_else(|| anyhow!("missing case {name}"))?;
                let runs = c["runs"].as_array().ok_or_else(|| anyhow!("no runs"))?;
                assert!(!runs.is_empty(), "{name}: no runs");
                for r in runs {
                    let e = r["error"].as_f64().unwrap_or(f64::NAN);
                    let w = r["wall_s"].as_f64().unwrap_or(f64::NAN);
                    assert!(e.is_finite() && e >= 0.0, "{name}: error {e}");
                    assert!(w.is_finite() && w >= 0.0, "{name}: wall {w}");
                }
            }
        }
        // The mesh layout study: every layout × angle × form, finite numbers.
        let layouts = doc["layout_study"]["series"]
            .as_array()
            .ok_or_else(|| anyhow!("no layout study"))?;
        assert_eq!(
            layouts.len(),
            layout::Layout::ALL.len() * layout::ANGLES_DEG.len() * FORMULATIONS.len()
        );
        for s in layouts {
            for key in ["energy", "shape"] {
                let points = s[key].as_array().ok_or_else(|| anyhow!("no {key}"))?;
                assert!(points.len() >= 2, "{key}: {} levels", points.len());
                for p in points {
                    let e = p["relative_error"]
                        .as_f64()
                        .or_else(|| p["error_m"].as_f64())
                        .unwrap_or(f64::NAN);
                    assert!(e.is_finite(), "{key}: error {e}");
                }
            }
        }
        assert!(opts.docs_dir.join("accuracy.md").is_file());
        assert!(
            opts.docs_dir
                .join("accuracy")
                .join("convergence.png")
                .is_file()
        );
        std::fs::remove_dir_all(&dir)?;
        Ok(())
    }
}
