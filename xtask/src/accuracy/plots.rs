//! Error–time and convergence plots.

use std::path::Path;

use anyhow::Result;

use crate::plot::{Chart, Mark, Series, save};

use super::study::{CASE_NAMES, Case, sff_name};
use crate::common::slug;

pub(super) fn plot_case(c: &Case, dir: &Path) -> Result<String> {
    let mut families: Vec<&str> = Vec::new();
    for r in &c.runs {
        if !families.contains(&r.family.as_str()) {
            families.push(&r.family);
        }
    }
    let mut series: Vec<Series> = families
        .iter()
        .map(|f| Series {
            name: (*f).to_string(),
            points: c
                .runs
                .iter()
                .filter(|r| r.family == *f)
                .map(|r| (r.wall_s, r.error))
                .collect(),
            mark: Mark::Points,
        })
        .collect();
    series.push(Series {
        name: "Pareto front".into(),
        points: c
            .pareto()
            .iter()
            .map(|&i| (c.runs[i].wall_s, c.runs[i].error))
            .collect(),
        mark: Mark::Line,
    });
    let stem = slug(&format!("{} {}", c.name, sff_name(c.sff)));
    let chart = Chart {
        title: format!("{} ({}): error vs wall time", c.name, sff_name(c.sff)),
        x_label: "wall time [s]".into(),
        y_label: format!("error [{}]", c.error_unit),
        log_x: true,
        log_y: true,
        series,
    };
    save(&chart, &dir.join(&stem))?;
    Ok(stem)
}

pub(super) fn plot_refinement(cases: &[Case], dir: &Path) -> Result<String> {
    let series = cases
        .iter()
        .filter(|c| c.name != CASE_NAMES[7])
        .flat_map(|c| {
            c.refinement.iter().map(move |s| Series {
                name: format!("{} [{}] ({})", s.name, c.error_unit, sff_name(c.sff)),
                points: s.points.iter().map(|&(f, e)| (f as f64, e)).collect(),
                mark: Mark::Line,
            })
        })
        .collect();
    let stem = "convergence".to_string();
    let chart = Chart {
        title: "Error under mesh refinement".into(),
        x_label: "faces".into(),
        y_label: "error (m, or relative for the strips)".into(),
        log_x: true,
        log_y: true,
        series,
    };
    save(&chart, &dir.join(&stem))?;
    Ok(stem)
}
