//! `cargo xtask verify`: the public verification suite (issue #16).
//!
//! Every case compares the model with a published or analytic answer: exact solutions of this
//! energy (sphere inflation, zero-energy rest shapes), linear Kirchhoff plates and the classic
//! linear shell benchmarks, and geometrically nonlinear load paths (Sze, Liu & Lo 2004). Each
//! case runs with every bending form ([`SffKind::ALL`]) on a refinement series (`--quick`: the
//! coarsest level only) and gets a verdict against a stated tolerance.
//!
//! Modules: [`solve`] (systems, static solves, load ramps), [`analytic`], [`linear`],
//! [`nonlinear`] (the cases, one file per group), [`report`] (`verification.md`, the plots, the
//! JSON). This file holds the case table, the shared records and [`run`].

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use thinshell_energy::SffKind;

mod analytic;
mod linear;
mod nonlinear;
mod report;
mod solve;

#[cfg(test)]
use report::mask_timings;

/// Where the suite writes and what it runs.
pub struct Options {
    /// Only the coarsest level of each case (a light run, used by the test).
    pub quick: bool,
    /// `verification.md` goes here, the plots into `<docs_dir>/verification/`.
    pub docs_dir: PathBuf,
    /// The JSON file with every run.
    pub json_path: PathBuf,
    /// Only the cases whose name or group contains this text.
    pub only: Option<String>,
}

/// One compared number: a measured value against its reference.
#[derive(Clone, Debug)]
pub(crate) struct Quantity {
    /// What it is (e.g. `w_c`, `W_A at P/Pmax = 0.2`).
    pub(crate) label: String,
    pub(crate) reference: f64,
    /// NaN when the run did not get there (a failed load step).
    pub(crate) measured: f64,
    /// The error is `|measured − reference| / scale` (the reference itself for single values,
    /// the largest reference value of the series for load paths).
    pub(crate) scale: f64,
}

impl Quantity {
    pub(crate) fn relative(label: impl Into<String>, reference: f64, measured: f64) -> Quantity {
        Quantity {
            label: label.into(),
            reference,
            measured,
            scale: reference.abs(),
        }
    }
    fn error(&self) -> f64 {
        let e = (self.measured - self.reference).abs() / self.scale;
        if e.is_finite() { e } else { f64::INFINITY }
    }
}

/// A load–displacement curve: (displacement, load factor) per point.
#[derive(Clone, Debug)]
pub(crate) struct Curve {
    pub(crate) name: String,
    pub(crate) points: Vec<(f64, f64)>,
}

/// What one run of a case on one mesh with one form produced.
#[derive(Clone, Debug)]
pub(crate) struct Outcome {
    /// The mesh in words (generator and resolution).
    pub(crate) mesh: String,
    pub(crate) faces: usize,
    pub(crate) quantities: Vec<Quantity>,
    /// Every static solve converged.
    pub(crate) converged: bool,
    /// Computed load paths (load-path cases only).
    pub(crate) curves: Vec<Curve>,
    /// A measured fact worth a sentence (e.g. where a load ramp stopped).
    pub(crate) note: Option<String>,
}

impl Outcome {
    /// The run's error: the largest error of its quantities (∞ if one is missing).
    pub(crate) fn error(&self) -> f64 {
        self.quantities
            .iter()
            .map(Quantity::error)
            .fold(0.0, f64::max)
    }
}

/// A case of the suite.
pub(crate) struct Spec {
    pub(crate) name: &'static str,
    pub(crate) group: &'static str,
    /// The reference, its source, the set-up and how the error is measured.
    pub(crate) description: &'static str,
    /// Tolerance on the error of the finest level.
    pub(crate) tolerance: f64,
    /// Tolerance on the error of the coarsest level (`--quick`).
    pub(crate) quick_tolerance: f64,
    /// Number of refinement levels of the full run (level 0 is the coarsest).
    pub(crate) levels: usize,
    /// Reference load paths to plot: (name, (displacement, load factor) points).
    pub(crate) reference_curves: fn() -> Vec<Curve>,
    /// Runs one level with one form.
    pub(crate) run: fn(SffKind, usize) -> Result<Outcome>,
}

/// One run of a case.
#[derive(Clone, Debug)]
pub(crate) struct Run {
    pub(crate) form: &'static str,
    pub(crate) level: usize,
    pub(crate) outcome: Outcome,
    /// Wall time of the run (building the system and every solve), s.
    pub(crate) wall_s: f64,
}

/// Every run of one case.
pub(crate) struct CaseResult {
    pub(crate) spec: &'static Spec,
    pub(crate) runs: Vec<Run>,
    /// The tolerance the verdict used (quick or full).
    pub(crate) tolerance: f64,
}

impl CaseResult {
    /// Per form: (form, error of its finest level, within the tolerance).
    pub(crate) fn finest(&self) -> Vec<(&'static str, f64, bool)> {
        SffKind::ALL
            .iter()
            .filter_map(|sff| {
                let form = sff.name();
                self.runs
                    .iter()
                    .filter(|r| r.form == form)
                    .max_by_key(|r| r.level)
                    .map(|r| {
                        let e = r.outcome.error();
                        (form, e, e <= self.tolerance)
                    })
            })
            .collect()
    }

    /// The one-line verdict.
    pub(crate) fn verdict(&self) -> String {
        let finest = self.finest();
        let pct = |e: f64| {
            if e.is_finite() && e >= 1e-4 {
                format!("{:.2} %", 100.0 * e)
            } else if e.is_finite() {
                format!("{:.1e} %", 100.0 * e)
            } else {
                "no answer".to_string()
            }
        };
        let tol = pct(self.tolerance);
        if finest.iter().all(|f| f.2) {
            format!("**pass**: every form within {tol} on the finest mesh")
        } else {
            let within: Vec<String> = finest
                .iter()
                .filter(|f| f.2)
                .map(|f| format!("{} ({})", f.0, pct(f.1)))
                .collect();
            let missed: Vec<String> = finest
                .iter()
                .filter(|f| !f.2)
                .map(|f| format!("{} ({})", f.0, pct(f.1)))
                .collect();
            format!(
                "**miss** (tolerance {tol}): {}{}",
                missed.join(", "),
                if within.is_empty() {
                    String::new()
                } else {
                    format!("; within: {}", within.join(", "))
                }
            )
        }
    }
}

/// The cases, in the report's order.
pub(crate) fn specs() -> Vec<&'static Spec> {
    let mut all: Vec<&'static Spec> = Vec::new();
    all.extend(analytic::SPECS.iter());
    all.extend(linear::SPECS.iter());
    all.extend(nonlinear::SPECS.iter());
    all
}

/// Runs the suite and writes `verification.md`, the plots and the JSON.
pub fn run(opts: &Options) -> Result<()> {
    let t0 = Instant::now();
    let mut results = Vec::new();
    for spec in specs() {
        if !opts
            .only
            .as_ref()
            .is_none_or(|o| spec.name.contains(o.as_str()) || spec.group.contains(o.as_str()))
        {
            continue;
        }
        let levels = if opts.quick { 1 } else { spec.levels };
        let mut runs = Vec::new();
        for sff in SffKind::ALL {
            for level in 0..levels {
                let t = Instant::now();
                let outcome = (spec.run)(sff, level)
                    .with_context(|| format!("{} ({}, level {level})", spec.name, sff.name()))?;
                let wall_s = t.elapsed().as_secs_f64();
                println!(
                    "{:<44} {:<26} {:>6} faces  error {:>9.3e}  {:>7.2} s  ({:.0} s so far)",
                    spec.name,
                    sff.name(),
                    outcome.faces,
                    outcome.error(),
                    wall_s,
                    t0.elapsed().as_secs_f64()
                );
                runs.push(Run {
                    form: sff.name(),
                    level,
                    outcome,
                    wall_s,
                });
            }
        }
        results.push(CaseResult {
            spec,
            runs,
            tolerance: if opts.quick {
                spec.quick_tolerance
            } else {
                spec.tolerance
            },
        });
    }
    let total_s = t0.elapsed().as_secs_f64();
    report::write(opts, &results, total_s)
}

#[cfg(test)]
mod tests {
    use anyhow::anyhow;
    use serde_json::Value;

    use super::*;

    /// The quick suite runs into a temporary directory: every case is there with every form
    /// and the analytic cases meet their quick tolerances. The analytic group then runs twice
    /// more and the two reports are the same text once the timings are masked (the whole quick
    /// suite twice would make the test too heavy for the default test run).
    #[test]
    fn quick_suite_covers_every_case_and_regenerates() -> Result<()> {
        let base = std::env::temp_dir().join(format!("thinshell-verify-{}", std::process::id()));
        let opts = |k: usize, only: Option<&str>| Options {
            quick: true,
            docs_dir: base.join(format!("run{k}")).join("docs"),
            json_path: base.join(format!("run{k}")).join("verify.json"),
            only: only.map(str::to_string),
        };
        let all = opts(0, None);
        run(&all)?;
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&all.json_path)?)?;
        let cases = doc["cases"].as_array().ok_or_else(|| anyhow!("no cases"))?;
        for spec in specs() {
            let c = cases
                .iter()
                .find(|c| c["name"] == spec.name)
                .ok_or_else(|| anyhow!("missing case {}", spec.name))?;
            let runs = c["runs"].as_array().ok_or_else(|| anyhow!("no runs"))?;
            assert_eq!(runs.len(), SffKind::ALL.len(), "{}", spec.name);
            for r in runs {
                let w = r["wall_s"].as_f64().unwrap_or(f64::NAN);
                assert!(w.is_finite() && w >= 0.0, "{}: wall {w}", spec.name);
                if spec.group == analytic::GROUP {
                    let e = r["error"].as_f64().unwrap_or(f64::INFINITY);
                    assert!(
                        e <= spec.quick_tolerance,
                        "{} ({}): error {e} > {}",
                        spec.name,
                        r["form"],
                        spec.quick_tolerance
                    );
                }
            }
        }
        assert!(all.docs_dir.join("verification.md").is_file());
        let mut reports = Vec::new();
        for k in 1..3 {
            let o = opts(k, Some(analytic::GROUP));
            run(&o)?;
            reports.push(std::fs::read_to_string(o.docs_dir.join("verification.md"))?);
        }
        assert!(reports[0].contains("| wall (s) |"));
        assert_eq!(mask_timings(&reports[0]), mask_timings(&reports[1]));
        std::fs::remove_dir_all(&base)?;
        Ok(())
    }

    /// Masking removes exactly the runtime line and the timing column.
    #[test]
    fn masking_keeps_everything_but_timings() {
        let a = "x\nMeasured runtime: 12 s\n| a | wall (s) |\n|---|---:|\n| 1 | 0.50 |\n\n| b | c |\n| 2 | 3 |\n";
        let b = a.replace("12 s", "13 s").replace("0.50", "0.61");
        assert_eq!(mask_timings(a), mask_timings(&b));
        let c = a.replace("| 2 | 3 |", "| 2 | 4 |");
        assert_ne!(mask_timings(a), mask_timings(&c));
        let d = a.replace("| 1 | 0.50 |", "| 9 | 0.50 |");
        assert_ne!(mask_timings(a), mask_timings(&d));
    }
}
