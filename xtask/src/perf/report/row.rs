//! A row of the main table: a measure, libshell's figure, the target and the verdict.

use super::format::{Text, ratio, s, t};
use super::sources::Source;

/// The target of a row.
#[derive(Clone, Copy)]
pub(super) enum Target {
    /// ratio (libshell / thinshell, or the row's own ratio) ≥ this.
    AtLeast(f64),
    /// the measured value (or ratio) ≤ this.
    AtMost(f64),
    /// the row's ratio (1-thread time / 2-thread time) > 1: faster with two threads.
    SpeedUp,
    /// recorded (the big run).
    Recorded,
    /// a figure for information (its ratio is the row's own), not judged.
    Info,
}

impl Target {
    pub(super) fn text(self) -> String {
        match self {
            Target::AtLeast(1.0) => "ratio ≥ 1 (ahead)".to_string(),
            Target::AtLeast(x) => format!("ratio ≥ {x}"),
            Target::AtMost(x) => format!("≤ {x}"),
            Target::SpeedUp => "ratio > 1 (faster with 2 threads)".to_string(),
            Target::Recorded => "runs; time and peak memory recorded".to_string(),
            Target::Info => "— (information)".to_string(),
        }
    }

    /// Verdict on `value` (the ratio for `AtLeast`, the value for `AtMost`).
    pub(super) fn verdict(self, value: f64) -> String {
        match self {
            Target::AtLeast(x) if value.is_finite() => {
                if value >= x {
                    "met".to_string()
                } else {
                    format!("gap: {:.2}× short", x / value)
                }
            }
            Target::AtMost(x) if value.is_finite() => {
                if value <= x {
                    "met".to_string()
                } else {
                    format!("gap: {:.2} over", value - x)
                }
            }
            Target::SpeedUp if value.is_finite() => {
                if value > 1.0 {
                    "met".to_string()
                } else {
                    format!("gap: 2 threads {:.2}× slower", 1.0 / value)
                }
            }
            Target::Recorded if value.is_finite() => "met".to_string(),
            Target::Info => "—".to_string(),
            _ => "not measured".to_string(),
        }
    }
}

/// A row of the main table.
pub(super) struct Row {
    pub(super) measure: String,
    /// libshell's figure and its value (for the ratio libshell / thinshell): the rerun's where
    /// it has one, else the first cited figure ([`Source`]).
    pub(super) libshell: Option<(String, f64)>,
    /// Where `libshell` comes from.
    pub(super) source: Source,
    /// The first cited figure of the row (the old column), if any.
    pub(super) libshell17: Option<String>,
    pub(super) thinshell: String,
    /// thinshell's value in libshell's unit.
    pub(super) value: f64,
    /// The row's own ratio when there is no libshell figure (e.g. director / average).
    pub(super) own_ratio: Option<f64>,
    pub(super) target: Target,
    /// Sizes differ from the issue's (quick run): no libshell ratio or verdict.
    pub(super) comparable: bool,
    /// The size the libshell figure was measured at (named in quick runs).
    pub(super) issue_size: Option<&'static str>,
    /// Why the target is missed, listed under the table when it is (measured facts, see
    /// [`why`]).
    pub(super) why: &'static str,
}

impl Row {
    /// The ratio column: libshell / thinshell when the row has a libshell figure and a
    /// ratio target, else the row's own ratio (if any).
    pub(super) fn ratio(&self) -> Option<f64> {
        match (&self.libshell, self.own_ratio, self.target) {
            (_, Some(r), _) => Some(r),
            (_, None, Target::Info) => None,
            (Some((_, l)), None, Target::AtLeast(_)) => Some(l / self.value),
            _ => None,
        }
    }

    /// Whether the row is judged and misses its target.
    pub(super) fn gap(&self) -> bool {
        let comparable = self.comparable || self.libshell.is_none();
        comparable && self.target.verdict(self.judged()).starts_with("gap")
    }

    /// The value the target judges: `AtLeast` the ratio; `AtMost` the ratio if there is one,
    /// else the value.
    pub(super) fn judged(&self) -> f64 {
        let r = self.ratio();
        match self.target {
            Target::AtLeast(_) | Target::SpeedUp => r.unwrap_or(f64::NAN),
            Target::AtMost(_) => r.unwrap_or(self.value),
            Target::Recorded | Target::Info => self.value,
        }
    }

    pub(super) fn cells(&self) -> Vec<Text> {
        let r = self.ratio();
        let judged = self.judged();
        // Quick runs use other sizes: nothing is judged against the issue's libshell figures.
        let comparable = self.comparable || self.libshell.is_none();
        let at = |text: &String| match (&self.issue_size, self.comparable) {
            (Some(size), false) => format!("{text} (at {size})"),
            _ => text.clone(),
        };
        let current = match (&self.libshell, self.source) {
            (Some((text, _)), Source::Issue31) => at(text),
            _ => "—".to_string(),
        };
        let old = self
            .libshell17
            .as_ref()
            .or(match (&self.libshell, self.source) {
                (Some((text, _)), Source::Issue17) => Some(text),
                _ => None,
            })
            .map_or("—".to_string(), at);
        let against_17 =
            self.libshell.is_some() && self.source == Source::Issue17 && self.own_ratio.is_none();
        vec![
            s(self.measure.clone()),
            s(current),
            s(old),
            t(self.thinshell.clone()),
            match r {
                None => s("—"),
                Some(_) if !comparable => s("— (quick: other sizes)"),
                Some(r) if against_17 => t(format!("{} (vs #17)", ratio(r))),
                Some(r) => t(ratio(r)),
            },
            s(self.target.text()),
            if comparable {
                t(self.target.verdict(judged))
            } else {
                s("— (quick)")
            },
        ]
    }
}
