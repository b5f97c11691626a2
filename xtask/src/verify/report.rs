//! The written results: `verification.md` (generated: timings are the only varying text, in the
//! runtime line and the last column, `wall (s)`, of the run tables), plots under
//! `verification/` and the JSON with every run.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use serde_json::{Value, json};
use thinshell_energy::SffKind;

use super::case::{CaseResult, Options, Run};
use crate::accuracy::{Refinement, machine, slug};
use crate::plot::{Chart, Mark, Series, save};

const RUNTIME: &str = "Measured runtime:";
const WALL: &str = "| wall (s) |";

/// The report with its timings masked: the runtime line and the last cell of every table
/// whose header ends in `wall (s)`. Two runs of the suite give the same masked text.
#[cfg(test)]
pub(super) fn mask_timings(md: &str) -> String {
    let mut out = String::new();
    let mut timed = false;
    for line in md.lines() {
        if line.starts_with(RUNTIME) {
            out.push_str(RUNTIME);
        } else if line.starts_with('|') {
            if line.ends_with(WALL) {
                timed = true;
            }
            let cut = if timed {
                line.trim_end_matches('|')
                    .rfind('|')
                    .map_or(line, |i| &line[..i])
            } else {
                line
            };
            out.push_str(cut);
        } else {
            timed = false;
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

fn sci(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4e}")
    } else {
        "—".into()
    }
}

fn pct(e: f64) -> String {
    if e.is_finite() {
        format!("{:.3} %", 100.0 * e)
    } else {
        "no answer".into()
    }
}

/// Observed order of each run against the previous level of the same form (— for the first).
fn orders(runs: &[&Run]) -> Vec<Option<f64>> {
    let r = Refinement {
        name: String::new(),
        points: runs
            .iter()
            .map(|r| (r.outcome.faces, r.outcome.error()))
            .collect(),
    };
    let (_, pairs) = r.orders();
    let mut out = vec![None];
    out.extend(pairs.into_iter().map(|p| p.is_finite().then_some(p)));
    out.resize(runs.len(), None);
    out
}

fn plot(c: &CaseResult, dir: &Path) -> Result<String> {
    let stem = slug(c.spec.name);
    let references = (c.spec.reference_curves)();
    let has_paths = c.runs.iter().any(|r| !r.outcome.curves.is_empty());
    let chart = if has_paths {
        let mut series: Vec<Series> = references
            .into_iter()
            .map(|r| Series {
                name: format!("reference: {}", r.name),
                points: r.points,
                mark: Mark::Points,
            })
            .collect();
        for sff in SffKind::ALL {
            if let Some(run) = c
                .runs
                .iter()
                .filter(|r| r.form == sff.name())
                .max_by_key(|r| r.level)
            {
                for curve in &run.outcome.curves {
                    series.push(Series {
                        name: format!(
                            "{} ({} faces): {}",
                            sff.name(),
                            run.outcome.faces,
                            curve.name
                        ),
                        points: curve.points.clone(),
                        mark: Mark::Line,
                    });
                }
            }
        }
        Chart {
            title: c.spec.name.to_string(),
            x_label: "displacement".into(),
            y_label: "load factor".into(),
            log_x: false,
            log_y: false,
            series,
        }
    } else {
        Chart {
            title: format!("{}: error under refinement", c.spec.name),
            x_label: "faces".into(),
            y_label: "error".into(),
            log_x: true,
            log_y: true,
            series: SffKind::ALL
                .iter()
                .map(|sff| Series {
                    name: sff.name().to_string(),
                    points: c
                        .runs
                        .iter()
                        .filter(|r| r.form == sff.name())
                        .map(|r| (r.outcome.faces as f64, r.outcome.error()))
                        .collect(),
                    mark: Mark::Line,
                })
                .collect(),
        }
    };
    save(&chart, &dir.join(&stem))?;
    Ok(format!("verification/{stem}.svg"))
}

fn case_markdown(md: &mut String, c: &CaseResult, plot: &str) {
    let s = c.spec;
    let _ = writeln!(
        md,
        "### {}\n\n{}\n\nVerdict: {}\n\nDefault form ({}): {}\n",
        s.name,
        s.description,
        c.verdict(),
        SffKind::default().name(),
        c.default_form()
    );
    let _ = writeln!(
        md,
        "| form | mesh | faces | worst quantity | measured | reference | error | order | converged {WALL}"
    );
    let _ = writeln!(md, "|---|---|---:|---|---:|---:|---:|---:|---|---:|");
    let mut notes = Vec::new();
    for sff in SffKind::ALL {
        let runs: Vec<&Run> = c.runs.iter().filter(|r| r.form == sff.name()).collect();
        for (r, order) in runs.iter().zip(orders(&runs)) {
            let o = &r.outcome;
            let worst = o.quantities.iter().max_by(|a, b| {
                let e = |q: &super::case::Quantity| {
                    let e = (q.measured - q.reference).abs() / q.scale;
                    if e.is_finite() { e } else { f64::INFINITY }
                };
                e(a).total_cmp(&e(b))
            });
            let (label, m, rf) = worst.map_or(("—".to_string(), f64::NAN, f64::NAN), |q| {
                (q.label.clone(), q.measured, q.reference)
            });
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} |",
                r.form,
                o.mesh,
                o.faces,
                label,
                sci(m),
                sci(rf),
                pct(o.error()),
                order.map_or("—".into(), |p| format!("{p:.2}")),
                if o.converged { "yes" } else { "no" },
                r.wall_s
            );
            if let Some(n) = &o.note {
                notes.push(format!("{} on {}: {n}", r.form, o.mesh));
            }
        }
    }
    md.push('\n');
    for n in notes {
        let _ = writeln!(md, "- {n}");
    }
    // Every quantity of the finest level per form (load paths: the whole tabulated path).
    let finest: Vec<&Run> = SffKind::ALL
        .iter()
        .filter_map(|sff| {
            c.runs
                .iter()
                .filter(|r| r.form == sff.name())
                .max_by_key(|r| r.level)
        })
        .collect();
    if finest.iter().any(|r| r.outcome.quantities.len() > 1) {
        let _ = write!(
            md,
            "\nFinest mesh per form, every compared value:\n\n| quantity | reference |"
        );
        for r in &finest {
            let _ = write!(md, " {} ({} faces) |", r.form, r.outcome.faces);
        }
        let _ = write!(md, "\n|---|---:|");
        for _ in &finest {
            md.push_str("---:|");
        }
        md.push('\n');
        if let Some(first) = finest.first() {
            for (i, q) in first.outcome.quantities.iter().enumerate() {
                let _ = write!(md, "| {} | {} |", q.label, sci(q.reference));
                for r in &finest {
                    let m = r.outcome.quantities.get(i).map_or(f64::NAN, |q| q.measured);
                    let _ = write!(md, " {} |", sci(m));
                }
                md.push('\n');
            }
        }
    }
    let _ = writeln!(md, "\n![{}]({plot})\n", s.name);
}

fn markdown(results: &[CaseResult], quick: bool, total_s: f64, plots: &[String]) -> String {
    let (nproc, cpu) = machine();
    let mut md = String::new();
    md.push_str("# Verification\n\n");
    md.push_str(
        "Generated by `cargo xtask verify` (do not edit by hand). Every case compares the model \
         (discrete Kirchhoff–Love shell, St. Venant–Kirchhoff membrane and bending, model.md) with \
         an analytic or published answer, with each bending form (`SffKind`: the mid-edge \
         average and the sin / tan edge-director forms) on a refinement series.\n\n",
    );
    let _ = writeln!(
        md,
        "{RUNTIME} {total_s:.0} s on {nproc} cores ({cpu}){}.\n",
        if quick {
            ", quick run (coarsest level only)"
        } else {
            ""
        }
    );
    md.push_str(
        "How to read the tables: *error* is relative (|measured − reference| / reference for a \
         single value; for load paths the largest deviation over the tabulated load levels, \
         divided by the largest reference value of that series; for shape cases the RMS \
         distance after removing rigid motion, in units of the radius of curvature) and the \
         *worst quantity* is the one that sets it. *Order* is the observed convergence order \
         against the previous level, p = ln(e₁/e₂) / ln(h₁/h₂) with h ∝ faces^(−1/2) (it is \
         meaningless when the error changes sign or has reached the reference's own precision). \
         The verdict compares each form's error on its finest mesh with the case's tolerance. \
         *Extrapolated* is the error of the Richardson limit of the last three levels: each \
         compared value v fitted by v = L + C h^p through its three values (observed order p), \
         L taken where the three converge monotonically with 0.5 ≤ p ≤ 4 and the finest value \
         otherwise (\"k of n values\" says how many were extrapolated); where the reference is \
         itself a limit known to a few digits it says what this model converges to. \
         *Wall (s)* is the time of the whole run (set-up and every solve) on a shared 2-core \
         machine: the timings are the only text that changes from one run to the next.\n\n",
    );
    let _ = write!(
        md,
        "## Summary\n\n| case | group | tolerance | default form ({}): finest mesh | every form |\n\
         |---|---|---:|---|---|\n",
        SffKind::default().name()
    );
    for c in results {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            c.spec.name,
            c.spec.group,
            pct(c.tolerance),
            c.default_form(),
            c.verdict()
        );
    }
    md.push('\n');
    let mut group = "";
    for (c, p) in results.iter().zip(plots) {
        if c.spec.group != group {
            group = c.spec.group;
            let _ = writeln!(md, "## {group}\n");
        }
        case_markdown(&mut md, c, p);
    }
    md
}

fn run_json(r: &Run) -> Value {
    let o = &r.outcome;
    json!({
        "form": r.form,
        "level": r.level,
        "mesh": o.mesh,
        "faces": o.faces,
        "error": o.error(),
        "converged": o.converged,
        "wall_s": r.wall_s,
        "note": o.note,
        "quantities": o.quantities.iter().map(|q| json!({
            "label": q.label,
            "reference": q.reference,
            "measured": q.measured,
            "scale": q.scale,
        })).collect::<Vec<_>>(),
        "curves": o.curves.iter().map(|c| json!({"name": c.name, "points": c.points}))
            .collect::<Vec<_>>(),
    })
}

/// Writes `verification.md`, the plots and the JSON.
pub(super) fn write(opts: &Options, results: &[CaseResult], total_s: f64) -> Result<()> {
    let plot_dir = opts.docs_dir.join("verification");
    std::fs::create_dir_all(&plot_dir)
        .with_context(|| format!("creating {}", plot_dir.display()))?;
    let plots = results
        .iter()
        .map(|c| plot(c, &plot_dir))
        .collect::<Result<Vec<_>>>()?;
    let md_path = opts.docs_dir.join("verification.md");
    std::fs::write(&md_path, markdown(results, opts.quick, total_s, &plots))
        .with_context(|| format!("writing {}", md_path.display()))?;
    let (nproc, cpu) = machine();
    let doc = json!({
        "quick": opts.quick,
        "nproc": nproc,
        "cpu": cpu,
        "total_wall_s": total_s,
        "cases": results.iter().map(|c| json!({
            "name": c.spec.name,
            "group": c.spec.group,
            "description": c.spec.description,
            "tolerance": c.tolerance,
            "verdict": c.verdict(),
            "runs": c.runs.iter().map(run_json).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    if let Some(dir) = opts.json_path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(&opts.json_path, serde_json::to_string_pretty(&doc)?)
        .with_context(|| format!("writing {}", opts.json_path.display()))?;
    println!(
        "wrote {}, {}/ and {} ({total_s:.1} s)",
        md_path.display(),
        plot_dir.display(),
        opts.json_path.display()
    );
    Ok(())
}
