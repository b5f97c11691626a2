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
//! Simulations are built through the library (`thinshell_system::ShellSystem` and its
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
use serde_json::json;
use thinshell::reference::SquareCase;

mod cases;
mod layout;
mod plots;
mod report;
mod runner;
mod study;

pub(crate) use crate::common::{machine, slug};
use cases::{cantilever, cap_refinement, cylinder_refinement, square, strip};
use plots::{plot_case, plot_refinement};
use report::{case_json, markdown, summarise_knobs};
pub(crate) use runner::shell;
pub(crate) use study::Refinement;
use study::{CASE_NAMES, Case, FORMULATIONS, sff_name};

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
    crate::common::write_json(&opts.json_path, &doc)?;
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
