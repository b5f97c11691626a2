//! `steps.csv`: every column of the table, in order, in one place — the common columns
//! ([`STEPS_CSV_COLUMNS`]), then a path-following run's, then the contact term's — with the
//! header of a simulation and the row of a step.
//!
//! Floats are written with `{:e}` (the shortest text that reads back to the same f64); an empty
//! cell is a value that does not exist for that step (no active contact pair, a singular
//! Hessian).

use crate::sim::{ContactRecord, Monitor, PathRecord, Simulation, StepRecord};

/// One of the common columns of `steps.csv`: its name, whether it is a wall time (those vary
/// from run to run; every other column is deterministic) and its value in a step's row.
#[derive(Clone, Copy)]
pub struct Column {
    /// The header name (units as a suffix: `_J`, `_s`).
    pub name: &'static str,
    /// A wall time (not reproducible between runs).
    pub timing: bool,
    /// The cell of one step.
    pub value: fn(&StepRecord) -> String,
}

impl std::fmt::Debug for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Column")
            .field("name", &self.name)
            .field("timing", &self.timing)
            .finish()
    }
}

macro_rules! column {
    ($name:literal, $timing:literal, |$r:ident| $value:expr) => {
        Column {
            name: $name,
            timing: $timing,
            value: |$r: &StepRecord| $value,
        }
    };
}

/// The common columns of `steps.csv`, in order: the one table that names them and formats their
/// cells. Floats are written with `{:e}` (round-trip exact). `wall_s` = `assembly_s +
/// factorization_s + solve_s + line_search_s + growth_s + output_s + other_s`.
pub const STEPS_CSV_COLUMNS: [Column; 24] = [
    column!("step", false, |r| r.step.to_string()),
    column!("time_s", false, |r| format!("{:e}", r.time)),
    column!("stretch_J", false, |r| format!("{:e}", r.energy.stretch)),
    column!("bend_J", false, |r| format!("{:e}", r.energy.bend)),
    column!("damping_J", false, |r| format!("{:e}", r.energy.damping)),
    column!("kinetic_J", false, |r| format!("{:e}", r.kinetic)),
    column!("newton_iterations", false, |r| r
        .newton_iterations
        .to_string()),
    column!("backtracks", false, |r| r.backtracks.to_string()),
    column!("regularizations", false, |r| r.regularizations.to_string()),
    column!("residual", false, |r| format!("{:e}", r.residual)),
    column!("wall_s", true, |r| format!("{:e}", r.wall_s)),
    column!("assembly_s", true, |r| format!("{:e}", r.assembly_s)),
    column!("factorization_s", true, |r| format!(
        "{:e}",
        r.factorization_s
    )),
    column!("solve_s", true, |r| format!("{:e}", r.solve_s)),
    column!("load_factor", false, |r| r.load_factor.to_string()),
    column!("line_search_s", true, |r| format!("{:e}", r.line_search_s)),
    column!("growth_s", true, |r| format!("{:e}", r.growth_s)),
    column!("output_s", true, |r| format!("{:e}", r.output_s)),
    column!("other_s", true, |r| format!("{:e}", r.other_s)),
    column!("gauss_newton_iterations", false, |r| r
        .gauss_newton_iterations
        .to_string()),
    column!("shifted_iterations", false, |r| r
        .shifted_iterations
        .to_string()),
    column!("negative_curvature_iterations", false, |r| r
        .negative_curvature_iterations
        .to_string()),
    column!("rejected_steps", false, |r| r.rejected_steps.to_string()),
    column!("min_eigenvalue", false, |r| r
        .min_eigenvalue
        .map(|v| format!("{v:e}"))
        .unwrap_or_default()),
];

/// The common part of `steps.csv`'s header (the names of [`STEPS_CSV_COLUMNS`]).
pub fn steps_csv_header() -> String {
    STEPS_CSV_COLUMNS.map(|c| c.name).join(",")
}

/// The names of the common columns that are wall times.
pub fn steps_csv_timing_columns() -> Vec<&'static str> {
    STEPS_CSV_COLUMNS
        .iter()
        .filter(|c| c.timing)
        .map(|c| c.name)
        .collect()
}

/// The columns a path-following run (`[path]`) adds after the common ones (other runs add
/// none), before contact's: `stable` (1 / 0), `negative_eigenvalues` (of the Hessian at fixed
/// load; empty where singular), `load_increment`, `step_length`, `cutbacks`, `potential_J` and
/// one [`monitor_column`] per monitored coordinate.
const PATH_COLUMNS: [&str; 6] = [
    "stable",
    "negative_eigenvalues",
    "load_increment",
    "step_length",
    "cutbacks",
    "potential_J",
];

/// The columns of a scene with the `contact` effect, last: `contact_pairs`, `contact_min_gap_m`
/// (empty without active self pairs and obstacles), `contact_energy_J`,
/// `contact_approximated_pairs`, `contact_pattern_rebuilds` ([`ContactRecord`]).
const CONTACT_COLUMNS: [&str; 5] = [
    "contact_pairs",
    "contact_min_gap_m",
    "contact_energy_J",
    "contact_approximated_pairs",
    "contact_pattern_rebuilds",
];

/// The column of a monitored vertex coordinate: `u_<vertex>_<x|y|z>_m`, its displacement (m)
/// from the start state of the path.
pub fn monitor_column(m: &Monitor) -> String {
    format!("u_{}_{}_m", m.vertex, ["x", "y", "z"][m.axis.min(2)])
}

/// The full header of `sim`'s `steps.csv` (no newline): the common columns, then path
/// following's and contact's when the simulation has them.
pub fn header(sim: &Simulation) -> String {
    let mut h = steps_csv_header();
    if sim.is_path_following() {
        for c in PATH_COLUMNS {
            h.push(',');
            h.push_str(c);
        }
        for m in sim.path_monitors() {
            h.push(',');
            h += &monitor_column(m);
        }
    }
    if sim.system().contact().is_some() {
        for c in CONTACT_COLUMNS {
            h.push(',');
            h.push_str(c);
        }
    }
    h
}

/// One step's row of `steps.csv` (no newline), matching [`header`].
pub fn row(r: &StepRecord) -> String {
    let mut row = STEPS_CSV_COLUMNS.map(|c| (c.value)(r)).join(",");
    if let Some(p) = &r.path {
        row += &path_cells(r.stable, p);
    }
    if let Some(c) = &r.contact {
        row += &contact_cells(c);
    }
    row
}

/// The cells of [`PATH_COLUMNS`] and the monitors (starting with a comma).
fn path_cells(stable: Option<bool>, p: &PathRecord) -> String {
    let stable = match stable {
        Some(true) => "1",
        Some(false) => "0",
        None => "",
    };
    let negative = p
        .negative_eigenvalues
        .map(|n| n.to_string())
        .unwrap_or_default();
    let mut row = format!(
        ",{stable},{negative},{:e},{:e},{},{:e}",
        p.load_increment, p.step_length, p.cutbacks, p.potential
    );
    for u in &p.monitors {
        row += &format!(",{u:e}");
    }
    row
}

/// The cells of [`CONTACT_COLUMNS`] (starting with a comma).
fn contact_cells(c: &ContactRecord) -> String {
    let gap = c.min_gap.map(|g| format!("{g:e}")).unwrap_or_default();
    format!(
        ",{},{gap},{:e},{},{}",
        c.active_pairs, c.energy, c.approximated_pairs, c.pattern_rebuilds
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header as it was written out by hand before the table (the format readers rely on).
    #[test]
    fn the_column_table_gives_the_documented_header() {
        assert_eq!(
            steps_csv_header(),
            "step,time_s,stretch_J,bend_J,damping_J,kinetic_J,newton_iterations,backtracks,regularizations,residual,wall_s,assembly_s,factorization_s,solve_s,load_factor,line_search_s,growth_s,output_s,other_s,gauss_newton_iterations,shifted_iterations,negative_curvature_iterations,rejected_steps,min_eigenvalue"
        );
        assert_eq!(
            steps_csv_timing_columns(),
            [
                "wall_s",
                "assembly_s",
                "factorization_s",
                "solve_s",
                "line_search_s",
                "growth_s",
                "output_s",
                "other_s"
            ]
        );
    }

    /// A path step's and a contact step's cells, as the columns name them.
    #[test]
    fn path_and_contact_cells_follow_their_columns() {
        let r = StepRecord {
            stable: Some(false),
            path: Some(PathRecord {
                load_increment: -0.5,
                step_length: 0.25,
                cutbacks: 1,
                negative_eigenvalues: None,
                potential: 2.0,
                monitors: vec![1e-3],
            }),
            contact: Some(ContactRecord {
                active_pairs: 3,
                min_gap: None,
                energy: 1.5,
                approximated_pairs: 0,
                pattern_rebuilds: 2,
            }),
            ..StepRecord::default()
        };
        let cells: Vec<String> = row(&r).split(',').map(str::to_string).collect();
        let common = STEPS_CSV_COLUMNS.len();
        assert_eq!(
            cells.len(),
            common + PATH_COLUMNS.len() + 1 + CONTACT_COLUMNS.len()
        );
        assert_eq!(
            cells[common..],
            [
                "0", "", "-5e-1", "2.5e-1", "1", "2e0", "1e-3", "3", "", "1.5e0", "0", "2"
            ]
        );
        assert_eq!(monitor_column(&Monitor { vertex: 7, axis: 2 }), "u_7_z_m");
    }
}
