//! `cargo xtask verify`: the public verification suite (issue #16).
//!
//! Every case compares the model with a published or analytic answer: exact solutions of this
//! energy (sphere inflation, zero-energy rest shapes), linear Kirchhoff plates and the classic
//! linear shell benchmarks, and geometrically nonlinear load paths (Sze, Liu & Lo 2004). Each
//! case runs with every bending form ([`SffKind::ALL`]) on a refinement series (`--quick`: the
//! coarsest level only) and gets a verdict against a stated tolerance.
//!
//! Modules: [`case`] (the shared records: options, case specs, runs, verdicts), [`solve`]
//! (systems, static solves, load ramps), [`analytic`], [`linear`], [`nonlinear`] (the cases, one
//! file per group), [`report`] (`verification.md`, the plots, the JSON). This file holds the
//! case table and [`run`].

use std::time::Instant;

use anyhow::{Context, Result};
use thinshell_energy::SffKind;

mod analytic;
mod case;
#[cfg(test)]
mod hemisphere_study;
mod linear;
mod nonlinear;
mod report;
mod solve;

pub(crate) use case::{CaseResult, Run, Spec};
pub use case::{Options, parse_levels};
#[cfg(test)]
use report::mask_timings;

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
        let levels = match &opts.levels {
            Some(r) => r.clone(),
            None if opts.quick => 0..1,
            None => spec.first_level..spec.levels,
        };
        let mut runs = Vec::new();
        for sff in SffKind::ALL {
            if !opts
                .form
                .as_ref()
                .is_none_or(|f| sff.name().contains(f.as_str()))
            {
                continue;
            }
            for level in levels.clone() {
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

    use super::case::richardson;
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
            form: None,
            levels: None,
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

    /// Richardson extrapolation recovers the limit and order of v = L + C h^p from three
    /// unevenly refined levels, and declines non-monotone or out-of-range sequences.
    #[test]
    fn richardson_recovers_limit_and_order() {
        let v = |h: f64| 2.0 + 3.0 * h.powf(1.7);
        let hs = [0.3, 0.2, 0.13];
        let pts = hs.map(|h| (h, v(h)));
        let (limit, p) = richardson(pts).expect("monotone sequence");
        assert!((limit - 2.0).abs() < 1e-9, "limit {limit}");
        assert!((p - 1.7).abs() < 1e-9, "order {p}");
        // A sign change of the differences: no extrapolation.
        assert!(richardson([(0.3, 1.0), (0.2, 1.1), (0.1, 1.05)]).is_none());
        // Order beyond 4 (differences falling by far more than h^4 predicts): declined.
        assert!(richardson([(0.2, 1.0), (0.1, 1.001), (0.05, 1.001_000_01)]).is_none());
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
