//! The suite's records, shared by the cases and the report: the options, what a case is
//! ([`Spec`]), what a run measured ([`Quantity`], [`Outcome`], [`Run`]), the verdict of a case
//! ([`CaseResult`]) and Richardson extrapolation of a refinement series. A leaf module: it uses
//! no other part of `verify`.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use thinshell_energy::SffKind;

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
    /// Only the bending forms whose name contains this text.
    pub form: Option<String>,
    /// Levels `a..b` instead of each case's series (a study option; `None`: the series).
    pub levels: Option<std::ops::Range<usize>>,
}

/// Parses `--levels a..b` (or a single level `a`).
pub fn parse_levels(text: Option<&str>) -> Result<Option<std::ops::Range<usize>>> {
    let Some(text) = text else { return Ok(None) };
    let parse = |t: &str| {
        t.trim()
            .parse::<usize>()
            .with_context(|| format!("--levels {text:?}: {t:?} is not a level number"))
    };
    let range = match text.split_once("..") {
        Some((a, b)) => parse(a)?..parse(b)?,
        None => {
            let a = parse(text)?;
            a..a + 1
        }
    };
    anyhow::ensure!(!range.is_empty(), "--levels {text:?} selects no level");
    Ok(Some(range))
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

/// Richardson extrapolation of one quantity from its last three levels, (h, value) with
/// h ∝ faces^(−1/2) decreasing: the limit L of v = L + C h^p with the observed order p fitted
/// to the three values (ratios of h need not be equal). `None` unless the differences keep
/// their sign (monotone convergence) and 0.5 ≤ p ≤ 4: outside that range the three values are
/// not in the asymptotic regime and an extrapolation would be a guess.
pub(crate) fn richardson(points: [(f64, f64); 3]) -> Option<(f64, f64)> {
    let [(h1, v1), (h2, v2), (h3, v3)] = points;
    let (d12, d23) = (v1 - v2, v2 - v3);
    let refined = h1 > h2 && h2 > h3 && h3 > 0.0;
    // False for NaN too: a missing value is not extrapolated.
    let monotone = d12 * d23 > 0.0 && d12.is_finite();
    if !(refined && monotone) {
        return None;
    }
    // (v1 − v2)/(v2 − v3) = (h1^p − h2^p)/(h2^p − h3^p) is increasing in p: bisect.
    let target = d12 / d23;
    let ratio = |p: f64| (h1.powf(p) - h2.powf(p)) / (h2.powf(p) - h3.powf(p));
    let (mut lo, mut hi) = (0.5_f64, 4.0_f64);
    let bracketed = ratio(lo) <= target && target <= ratio(hi);
    if !bracketed {
        return None;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if ratio(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let p = 0.5 * (lo + hi);
    let limit = v3 - d23 * h3.powf(p) / (h2.powf(p) - h3.powf(p));
    Some((limit, p))
}

/// The Richardson-extrapolated error of one form's series (its last three levels): the largest
/// error over the quantities, each quantity taken at its extrapolated limit where
/// [`richardson`] gives one and at its finest value otherwise. Returns (error, number of
/// quantities extrapolated, number of quantities); `None` with fewer than three levels or a
/// missing value.
pub(crate) fn extrapolated_error(runs: &[&Run]) -> Option<(f64, usize, usize)> {
    let last: Vec<&&Run> = runs.iter().rev().take(3).collect();
    if last.len() < 3 {
        return None;
    }
    let (r3, r2, r1) = (last[0], last[1], last[2]);
    let n = r3.outcome.quantities.len();
    if n == 0 || [r1, r2].iter().any(|r| r.outcome.quantities.len() != n) {
        return None;
    }
    let h = |r: &Run| (r.outcome.faces as f64).powf(-0.5);
    let (mut worst, mut extrapolated) = (0.0_f64, 0);
    for i in 0..n {
        let q = &r3.outcome.quantities[i];
        let v = |r: &Run| r.outcome.quantities[i].measured;
        if !(v(r1).is_finite() && v(r2).is_finite() && q.measured.is_finite()) {
            return None;
        }
        let value = match richardson([(h(r1), v(r1)), (h(r2), v(r2)), (h(r3), q.measured)]) {
            Some((limit, _)) => {
                extrapolated += 1;
                limit
            }
            None => q.measured,
        };
        worst = worst.max((value - q.reference).abs() / q.scale);
    }
    Some((worst, extrapolated, n))
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
    /// The full run's levels are `first_level..levels` (level 0 is the coarsest, the only one
    /// of `--quick`): a case whose coarse meshes are far from the asymptotic range starts finer.
    pub(crate) levels: usize,
    /// The first level of the full run (see `levels`).
    pub(crate) first_level: usize,
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

    /// The default form's line of the summary: its error on the finest mesh against the
    /// tolerance, and the Richardson-extrapolated error of its last three levels beside it.
    pub(crate) fn default_form(&self) -> String {
        let form = SffKind::default().name();
        let runs: Vec<&Run> = self.runs.iter().filter(|r| r.form == form).collect();
        let Some(finest) = runs.last() else {
            return "not run".into();
        };
        let e = finest.outcome.error();
        let mut line = format!(
            "{} {}",
            if e <= self.tolerance {
                "**pass**"
            } else {
                "**miss**"
            },
            percent(e)
        );
        if let Some((x, k, n)) = extrapolated_error(&runs) {
            let _ = write!(line, "; extrapolated {}", percent(x));
            if k < n {
                let _ = write!(line, " ({k} of {n} values)");
            }
        }
        line
    }

    /// The one-line verdict.
    pub(crate) fn verdict(&self) -> String {
        let finest = self.finest();
        let pct = percent;
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

/// An error in percent for the verdicts (two decimals, or one significant digit below 0.01 %).
fn percent(e: f64) -> String {
    if e.is_finite() && e >= 1e-4 {
        format!("{:.2} %", 100.0 * e)
    } else if e.is_finite() {
        format!("{:.1e} %", 100.0 * e)
    } else {
        "no answer".to_string()
    }
}
