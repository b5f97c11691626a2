//! Blocks of text and tables, stable or clock-dependent, and the number formats of the
//! report.

use std::fmt::Write as _;

/// A table cell or line: stable text, or text that depends on a clock.
#[derive(Clone, Debug)]
pub(super) enum Text {
    Stable(String),
    Timing(String),
}

impl Text {
    pub(super) fn render(&self, masked: bool) -> &str {
        match self {
            Text::Stable(s) => s,
            Text::Timing(s) if !masked => s,
            Text::Timing(_) => "·",
        }
    }
}

pub(super) fn s(t: impl Into<String>) -> Text {
    Text::Stable(t.into())
}

pub(super) fn t(t: impl Into<String>) -> Text {
    Text::Timing(t.into())
}

pub(super) enum Block {
    Line(Text),
    Table {
        header: Vec<String>,
        rows: Vec<Vec<Text>>,
    },
    /// Markdown from another module (replaced by a placeholder when masked).
    Extra(String),
}

pub(super) fn render(blocks: &[Block], masked: bool) -> String {
    let mut out = String::new();
    for b in blocks {
        match b {
            Block::Line(l) => {
                out.push_str(l.render(masked));
                out.push('\n');
            }
            Block::Table { header, rows } => {
                let _ = writeln!(out, "| {} |", header.join(" | "));
                let align: Vec<&str> = header
                    .iter()
                    .enumerate()
                    .map(|(k, _)| if k == 0 { "---" } else { "---:" })
                    .collect();
                let _ = writeln!(out, "|{}|", align.join("|"));
                for r in rows {
                    let cells: Vec<&str> = r.iter().map(|c| c.render(masked)).collect();
                    let _ = writeln!(out, "| {} |", cells.join(" | "));
                }
            }
            Block::Extra(text) => {
                if masked {
                    out.push_str("(section from another module)\n");
                } else {
                    out.push_str(text.trim_end());
                    out.push('\n');
                }
            }
        }
    }
    out
}

/// An integer with thin groups of three digits (`14 924`).
pub(crate) fn grouped(v: usize) -> String {
    let digits = v.to_string();
    let mut out = String::new();
    for (k, ch) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k) % 3 == 0 {
            out.push(' ');
        }
        out.push(ch);
    }
    out
}

/// A time in s as ms or s with three significant digits.
pub(super) fn time(secs: f64) -> String {
    if !secs.is_finite() {
        "—".to_string()
    } else if secs >= 1.0 {
        format!("{secs:.2} s")
    } else if secs >= 0.1 {
        format!("{:.0} ms", 1e3 * secs)
    } else if secs >= 0.01 {
        format!("{:.1} ms", 1e3 * secs)
    } else {
        format!("{:.2} ms", 1e3 * secs)
    }
}

/// Nanoseconds per face from seconds per face.
pub(super) fn ns(secs: f64) -> String {
    if secs.is_finite() {
        grouped((1e9 * secs).round() as usize)
    } else {
        "—".to_string()
    }
}

pub(super) fn ratio(r: f64) -> String {
    if r.is_finite() {
        format!("{r:.2}")
    } else {
        "—".to_string()
    }
}

pub(super) fn flops(f: f64) -> String {
    if f.is_finite() && f > 0.0 {
        let mut e = f.log10().floor() as i32;
        // 9.996e10 prints as 1.00e11, not 10.00e10.
        if (f / 10f64.powi(e) * 100.0).round() >= 1000.0 {
            e += 1;
        }
        format!("{:.2}e{e}", f / 10f64.powi(e))
    } else {
        "—".to_string()
    }
}

pub(super) fn bytes(b: u64) -> String {
    thinshell_solver::memory::human_bytes(b)
}
