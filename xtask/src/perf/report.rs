//! The outputs of `cargo xtask perf`: `perf.json` (every raw sample, the facts of the symbolic
//! analyses, the generated section with and without timings) and the generated section of the
//! docs file between [`BEGIN`](super::BEGIN) and [`END`](super::END).
//!
//! The section is built from blocks whose cells are either *stable* (sizes, flops, Newton
//! iterations, targets, the libshell figures) or *timings* (everything measured with a clock,
//! and what is derived from it: ratios, verdicts, the machine line). With the timings masked the
//! section is byte-identical between runs on one revision; the JSON carries that masked text so
//! that a test can check it.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use anyhow::{Context, Result, bail};
use serde_json::json;
use thinshell_energy::SffKind;

use super::{
    BEGIN, END, Options, Samples, Sizes, faces_at, kernels, linear, loglog_slope, med, median,
    newton,
};

/// Sizes and symbolic-analysis figures of one level of the Newton problem (default ordering).
#[derive(Clone, Debug)]
pub(crate) struct LevelFacts {
    pub(crate) faces: usize,
    pub(crate) unknowns: usize,
    pub(crate) nnz: usize,
    pub(crate) ordering: String,
    pub(crate) flops: f64,
    pub(crate) factor_len: usize,
    pub(crate) memory_estimate: u64,
}

/// The symbolic analysis of one ordering at one level.
#[derive(Clone, Debug)]
pub(crate) struct OrderingFacts {
    pub(crate) level: usize,
    pub(crate) asked: String,
    pub(crate) used: String,
    pub(crate) flops: f64,
    pub(crate) factor_len: usize,
    pub(crate) memory_estimate: u64,
    /// A timing.
    pub(crate) symbolic_s: f64,
}

/// What the set-up learned (deterministic, except `OrderingFacts::symbolic_s`).
#[derive(Clone, Debug, Default)]
pub(crate) struct Facts {
    pub(crate) per_face_faces: usize,
    /// Unknowns of the per-face systems, by `per_face/<form>`.
    pub(crate) unknowns: BTreeMap<String, usize>,
    /// Unknowns of the implicit-step systems, by form name.
    pub(crate) step_unknowns: BTreeMap<String, usize>,
    pub(crate) levels: BTreeMap<usize, LevelFacts>,
    pub(crate) orderings: Vec<OrderingFacts>,
}

/// The `--big` Newton iteration, run in a child process.
#[derive(Clone, Debug)]
pub(crate) struct BigRun {
    pub(crate) level: usize,
    pub(crate) threads: usize,
    pub(crate) faces: usize,
    pub(crate) unknowns: usize,
    pub(crate) ordering: String,
    pub(crate) flops: f64,
    pub(crate) memory_estimate: u64,
    /// VmHWM of the child (bytes), if /proc told.
    pub(crate) peak_rss: Option<u64>,
    /// Mesh, pattern and symbolic analysis (s).
    pub(crate) setup_s: f64,
    /// Per part of [`newton::PARTS`], one value per iteration (s).
    pub(crate) samples: BTreeMap<String, Vec<f64>>,
    /// The child's whole wall time (s).
    pub(crate) wall_s: f64,
}

/// Everything a run produced.
pub(crate) struct Run {
    pub(crate) quick: bool,
    pub(crate) big: bool,
    pub(crate) rounds: usize,
    pub(crate) sizes: Sizes,
    pub(crate) samples: Samples,
    pub(crate) facts: Facts,
    pub(crate) big_runs: Vec<BigRun>,
    /// Sections of [`super::extra_sections`], in order (markdown).
    pub(crate) extra: Vec<String>,
    pub(crate) total_s: f64,
    /// The 1-minute load average when the run started.
    pub(crate) load_start: Option<f64>,
}

/// The sizes of the issue's figures.
const K20: &str = "20 480 faces";
const K80: &str = "81 920 faces";

/// Where a libshell figure comes from.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Source {
    /// Issue #31's side-by-side rerun (the current figures).
    Issue31,
    /// Issue #17's figures (an earlier libshell build on another CPU model), for the rows
    /// issue #31 did not remeasure.
    Issue17,
}

/// Issue #31's libshell figures: rerun side by side with thinshell on this machine kind (the
/// 2-core VM), interleaved, 7 rounds, medians; libshell built `-O3 -march=native -DNDEBUG`,
/// CHOLMOD supernodal with METIS capped to one OpenMP thread, OpenBLAS with its AVX-512
/// kernels; one thread. Cited, not re-measured.
mod libshell31 {
    pub(super) const ENERGY_NS: f64 = 106.0;
    pub(super) const ENERGY_GRADIENT_NS: f64 = 476.0;
    pub(super) const HESSIAN_NS: f64 = 10_600.0;
    pub(super) const FACTOR_20K_S: f64 = 0.246;
    pub(super) const NEWTON_20K_S: f64 = 0.594;
    pub(super) const NEWTON_80K_S: f64 = 3.13;
    pub(super) const GROWTH: f64 = 1.18;
    /// METIS (CHOLMOD) factorisation flops at 20 480 faces.
    pub(super) const METIS_FLOPS_20K: f64 = 6.39e9;
}

/// Issue #17's libshell figures (an earlier libshell build on another CPU model; cited, not
/// re-measured): the old column, and the reference of the rows issue #31 did not remeasure
/// (assembly; factorisation time and flops at 81 920 faces).
mod libshell {
    pub(super) const ENERGY_NS: f64 = 188.0;
    pub(super) const ENERGY_GRADIENT_NS: f64 = 619.0;
    pub(super) const HESSIAN_NS: f64 = 14_924.0;
    pub(super) const ASSEMBLY_S: f64 = 0.151;
    pub(super) const FACTOR_20K_S: f64 = 0.279;
    pub(super) const NEWTON_20K_S: f64 = 0.757;
    pub(super) const FACTOR_80K_S: f64 = 2.03;
    pub(super) const NEWTON_80K_S: f64 = 4.14;
    pub(super) const GROWTH: f64 = 1.14;
    /// METIS (CHOLMOD) factorisation flops at 20 480 and 81 920 faces.
    pub(super) const METIS_FLOPS_20K: f64 = 6.4e9;
    pub(super) const METIS_FLOPS_80K: f64 = 5.65e10;
}

/// A table cell or line: stable text, or text that depends on a clock.
#[derive(Clone, Debug)]
enum Text {
    Stable(String),
    Timing(String),
}

impl Text {
    fn render(&self, masked: bool) -> &str {
        match self {
            Text::Stable(s) => s,
            Text::Timing(s) if !masked => s,
            Text::Timing(_) => "·",
        }
    }
}

fn s(t: impl Into<String>) -> Text {
    Text::Stable(t.into())
}

fn t(t: impl Into<String>) -> Text {
    Text::Timing(t.into())
}

enum Block {
    Line(Text),
    Table {
        header: Vec<String>,
        rows: Vec<Vec<Text>>,
    },
    /// Markdown from another module (replaced by a placeholder when masked).
    Extra(String),
}

fn render(blocks: &[Block], masked: bool) -> String {
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
fn time(secs: f64) -> String {
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
fn ns(secs: f64) -> String {
    if secs.is_finite() {
        grouped((1e9 * secs).round() as usize)
    } else {
        "—".to_string()
    }
}

fn ratio(r: f64) -> String {
    if r.is_finite() {
        format!("{r:.2}")
    } else {
        "—".to_string()
    }
}

fn flops(f: f64) -> String {
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

fn bytes(b: u64) -> String {
    thinshell_solver::memory::human_bytes(b)
}

/// Why a target is missed: what was measured about the cause (shown only for rows that miss).
mod why {
    /// The per-face reason of an evaluation kind of the first table.
    pub(super) fn per_face(what: &str) -> &'static str {
        match what {
            "energy" => ENERGY,
            "energy_gradient" => ENERGY_GRADIENT,
            _ => "",
        }
    }
    pub(super) const ENERGY: &str = "*Energy only*: this path has no gradient or Hessian \
        buffers since #17 (`eval_face_energy`: closed-form StVK, constants hoisted; 1 180 → 757 \
        instructions per face, callgrind, docs/performance.md \"#17 kernels\"). What is left is \
        the scalar arithmetic of b (three normalised flap normals) and the law, one face at a \
        time; evaluating several faces per SIMD lane (a structure-of-arrays layout) is untried.";
    pub(super) const ENERGY_GRADIENT: &str = "*Energy + gradient*: one law evaluation and \
        reverse mode through b (2 786 → 2 526 instructions per face); the rest is the scalar \
        derivative of the flap normals and the scatter of 18 entries per face, not vectorised \
        across faces.";
    pub(super) const FACTOR: &str = "*Factorisation*: see the ordering row (more flops than \
        METIS).";
    pub(super) const THREADS: &str = "*Two threads*: the split factorises the two halves of the \
        top separator concurrently, then the separator densely; its predicted critical path is \
        0.63 of the one-thread flops at 20 480 faces, so small factors gain little.";
    pub(super) const ORDERING: &str = "*Ordering flops*: the dissection is our own loop around \
        METIS's multilevel bisection with minimum vertex-cover separators (the `metis` crate has \
        no safe wrapper of METIS_NodeND, and unsafe code is forbidden here); METIS's own nested \
        dissection also refines each separator, which ours does not (four bisections per split \
        gained 3–5 % for 3× the ordering time, not kept).";
    pub(super) const NEWTON: &str = "*Newton iteration ≥ 4× libshell on 2 threads*: 4× needs \
        ≤ 149 ms (issue #31's libshell: 594 ms) for assembly, factorisation and solve, and the \
        two-thread factorisation alone takes about that (Factorisation table); closing it needs \
        fewer flops (the ordering row), faster supernodal kernels, or skipped factorisations \
        (factor reuse, below: the default of implicit steps since issue #31, which this row, \
        one factorisation per iteration, does not count).";
    pub(super) const GROWTH: &str = "*Growth exponent*: nested dissection factorises a 2-D mesh \
        of n unknowns in O(n^1.5) flops, and the factorisation is most of an iteration from \
        20 480 faces up, so the slope rises with size; two threads pull it down (the split \
        pays more on larger factors: speed-up 1.30 at 20 480, 1.68 at 81 920 faces).";
    pub(super) const DIRECTOR_FACE: &str = "*Director forms per face*: 21 dofs per face (the \
        three edge angles) against 18, and 45 vertex/edge block pairs gathered against 21; the \
        dihedral angle's Hessian is in closed form since issue #31 (Bridson's gradient \
        differentiated, instead of the chain rule through three normalised vectors); what \
        remains is the altitude's Hessian, the fitted/clamped edges' dual numbers and the larger \
        gather.";
    pub(super) const DIRECTOR_STEP: &str = "*Director forms per implicit step*: twice the \
        unknowns (one angle per edge) and about 2.2× the predicted factorisation flops with \
        METIS (1.53e10 against 7.03e9 at 20 480 faces), on top of the per-face cost.";
}

/// The target of a row.
#[derive(Clone, Copy)]
enum Target {
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
    fn text(self) -> String {
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
    fn verdict(self, value: f64) -> String {
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
struct Row {
    measure: String,
    /// libshell's figure and its value (for the ratio libshell / thinshell): issue #31's where
    /// it has one, else issue #17's ([`Source`]).
    libshell: Option<(String, f64)>,
    /// Where `libshell` comes from.
    source: Source,
    /// Issue #17's figure of the row (the old column), if any.
    libshell17: Option<String>,
    thinshell: String,
    /// thinshell's value in libshell's unit.
    value: f64,
    /// The row's own ratio when there is no libshell figure (e.g. director / average).
    own_ratio: Option<f64>,
    target: Target,
    /// Sizes differ from the issue's (quick run): no libshell ratio or verdict.
    comparable: bool,
    /// The size the libshell figure was measured at (named in quick runs).
    issue_size: Option<&'static str>,
    /// Why the target is missed, listed under the table when it is (measured facts, see
    /// [`why`]).
    why: &'static str,
}

impl Row {
    /// The ratio column: libshell / thinshell when the row has a libshell figure and a
    /// ratio target, else the row's own ratio (if any).
    fn ratio(&self) -> Option<f64> {
        match (&self.libshell, self.own_ratio, self.target) {
            (_, Some(r), _) => Some(r),
            (_, None, Target::Info) => None,
            (Some((_, l)), None, Target::AtLeast(_)) => Some(l / self.value),
            _ => None,
        }
    }

    /// Whether the row is judged and misses its target.
    fn gap(&self) -> bool {
        let comparable = self.comparable || self.libshell.is_none();
        comparable && self.target.verdict(self.judged()).starts_with("gap")
    }

    /// The value the target judges: `AtLeast` the ratio; `AtMost` the ratio if there is one,
    /// else the value.
    fn judged(&self) -> f64 {
        let r = self.ratio();
        match self.target {
            Target::AtLeast(_) | Target::SpeedUp => r.unwrap_or(f64::NAN),
            Target::AtMost(_) => r.unwrap_or(self.value),
            Target::Recorded | Target::Info => self.value,
        }
    }

    fn cells(&self) -> Vec<Text> {
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

/// The machine line: CPU model, cores, memory, date, git revision, load average.
fn machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .map_or("unknown CPU".to_string(), |m| m.trim().to_string());
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let mem = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| {
            m.lines()
                .find(|l| l.starts_with("MemTotal:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or("unknown memory".to_string(), |kb| bytes(kb * 1024));
    let load = load_average().map_or("?".to_string(), |l| format!("{l:.2}"));
    format!(
        "Machine: {cpu}, {cores} cores, {mem} RAM; {} UTC; git {}; load average {load} at the end of the run.",
        today(),
        git_rev()
    )
}

/// The 1-minute load average (/proc/loadavg).
pub(crate) fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// A warning when other work ran: a load average above half the cores when the run starts
/// means the timings are inflated and the ratios noisy. The load at the end is not judged: it
/// includes the run's own two-thread measures and `--big` child.
fn load_warning(start: Option<f64>) -> Option<String> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from) as f64;
    let worst = start.unwrap_or(f64::NAN);
    (worst > 0.5 * cores).then(|| {
        format!(
            "**Loaded machine**: load average {worst:.1} on {cores} cores when this run started, \
             so the timings are inflated (other processes shared the cores) and single ratios are \
             noisy; quote figures from a run on a quiet machine."
        )
    })
}

/// `git rev-parse --short=12 HEAD`, plus a note when tracked files other than the docs differ.
fn git_rev() -> String {
    let root = crate::workspace_root();
    let rev = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .current_dir(&root)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    let Some(rev) = rev else {
        return "unknown revision".to_string();
    };
    let dirty = std::process::Command::new("git")
        .args([
            "diff",
            "--quiet",
            "HEAD",
            "--",
            ".",
            ":(exclude)docs/performance.md",
        ])
        .current_dir(&root)
        .status()
        .map(|s| !s.success())
        .unwrap_or(false);
    if dirty {
        format!("`{rev}` + uncommitted changes")
    } else {
        format!("`{rev}`")
    }
}

/// Today's UTC date (YYYY-MM-DD) from the system clock (civil-from-days, proleptic Gregorian).
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The command that reproduces the run.
fn command(run: &Run) -> String {
    let mut c = "cargo xtask perf".to_string();
    if run.quick {
        c.push_str(" --quick");
    } else {
        let _ = write!(c, " --rounds {}", run.rounds);
    }
    if run.big {
        c.push_str(" --big");
    }
    c
}

/// The generated section as blocks.
fn blocks(run: &Run) -> Vec<Block> {
    let sm = &run.samples;
    let sz = &run.sizes;
    let mut b = Vec::new();
    let line = |b: &mut Vec<Block>, text: String| b.push(Block::Line(Text::Stable(text)));
    let pf = faces_at(sz.per_face);
    let comparable = !run.quick;
    let two = sz.threads.contains(&2);

    line(
        &mut b,
        "## Issue #17 targets (generated by `cargo xtask perf`)".into(),
    );
    line(&mut b, String::new());
    line(
        &mut b,
        format!(
            "Regenerated by `{}` (everything between the `perf:begin` / `perf:end` markers; do \
             not edit it by hand). Raw samples: `target/xtask/perf.json`.",
            command(run)
        ),
    );
    line(&mut b, String::new());
    b.push(Block::Line(t(machine())));
    line(&mut b, String::new());
    // Always one line (masked comparisons see the same text whatever the load).
    b.push(Block::Line(t(load_warning(run.load_start).unwrap_or_else(
        || "Quiet machine: load average below half the cores when the run started.".to_string(),
    ))));
    line(&mut b, String::new());
    line(
        &mut b,
        format!(
            "Protocol: unit icospheres (`generators::icosphere`), StVK (`Material::paper()`), \
             stretching + bending, one thread unless the row says otherwise; every measure set \
             up once, then {} interleaved round(s) (each round runs every measure once, after \
             one untimed warm-up), medians. Per-face figures: whole-mesh evaluation at the \
             squashed and rippled sphere / faces. Factorisation, Newton iteration: the shrinking \
             sphere of the `newton_iteration` bench (ā = 0.9 a⁰, implicit Euler Δt = 1e-3 s, \
             exact Hessian + Λ/Δt²), with the library's default `NewtonSettings` (ordering, \
             regularisation, `parallel = true`: the split factorisation, whose results do not \
             depend on the thread count) on pools of 1 and 2 threads; the factorisation rows \
             force faer's unsplit factorisation on 1 thread (`parallel = false`), and the split \
             on 1 and 2 threads. libshell columns, cited, not re-measured: issue #31's \
             side-by-side rerun on this machine kind (2-core VM; libshell -O3 -march=native \
             -DNDEBUG, CHOLMOD supernodal with METIS on one OpenMP thread, OpenBLAS AVX-512 \
             kernels; one thread; interleaved, 7 rounds, medians), and issue #17's figures (an \
             earlier libshell build on another CPU model), the reference only where #31 has no \
             figure (ratio marked \"vs #17\"); ratio = libshell / thinshell (> 1: thinshell \
             faster) unless the row says otherwise.",
            run.rounds
        ),
    );
    if run.quick {
        line(&mut b, String::new());
        line(
            &mut b,
            "**Quick run** (`--quick`): the smallest sizes and one round, a smoke test of the \
             command; the sizes differ from the issue's, so no ratio against libshell and no \
             verdict is given."
                .into(),
        );
    }
    line(&mut b, String::new());

    // The main table.
    let avg = SffKind::MidEdgeAverage;
    let per_face = |sff: SffKind, what: &str| med(sm, &kernels::id(sff, what), "total");
    let mut rows = Vec::new();
    let pf_label = format!("{} faces, 1 thread", grouped(pf));
    for (what, label, lib, old, target) in [
        (
            "energy",
            "energy only, ns/face",
            libshell31::ENERGY_NS,
            libshell::ENERGY_NS,
            Target::AtLeast(1.5),
        ),
        (
            "energy_gradient",
            "energy + gradient, ns/face",
            libshell31::ENERGY_GRADIENT_NS,
            libshell::ENERGY_GRADIENT_NS,
            Target::AtLeast(3.0),
        ),
        (
            "energy_gradient_hessian",
            "energy + gradient + exact Hessian, ns/face",
            libshell31::HESSIAN_NS,
            libshell::HESSIAN_NS,
            Target::AtLeast(1.0),
        ),
    ] {
        let v = per_face(avg, what);
        rows.push(Row {
            measure: format!("{label} ({pf_label})"),
            libshell: Some((grouped(lib as usize), lib * 1e-9)),
            source: Source::Issue31,
            libshell17: Some(grouped(old as usize)),
            thinshell: ns(v),
            value: v,
            own_ratio: None,
            target,
            comparable,
            issue_size: Some(K20),
            why: why::per_face(what),
        });
    }
    let gather = med(sm, kernels::GATHER, "total");
    rows.push(Row {
        measure: format!("assembly: triplets → matrix vs the gather ({pf_label})"),
        libshell: Some(("151 ms".into(), libshell::ASSEMBLY_S)),
        source: Source::Issue17,
        libshell17: None,
        thinshell: time(gather),
        value: gather,
        own_ratio: None,
        target: Target::AtLeast(1.0),
        comparable,
        issue_size: Some(K20),
        why: "",
    });
    // (level, libshell time, libshell flops, their source, #17's time and flops).
    type FactorRef = (usize, f64, f64, Source, f64, f64);
    let factor_levels: Vec<FactorRef> = sz
        .factor
        .iter()
        .enumerate()
        .map(|(k, &l)| {
            if k == 0 {
                (
                    l,
                    libshell31::FACTOR_20K_S,
                    libshell31::METIS_FLOPS_20K,
                    Source::Issue31,
                    libshell::FACTOR_20K_S,
                    libshell::METIS_FLOPS_20K,
                )
            } else {
                (
                    l,
                    libshell::FACTOR_80K_S,
                    libshell::METIS_FLOPS_80K,
                    Source::Issue17,
                    libshell::FACTOR_80K_S,
                    libshell::METIS_FLOPS_80K,
                )
            }
        })
        .collect();
    for (k, &(level, lib_t, lib_f, source, old_t, old_f)) in factor_levels.iter().enumerate() {
        let f = faces_at(level);
        let t1 = med(sm, &linear::id(level, 1), "total");
        let old_t = (source == Source::Issue31).then(|| time(old_t));
        let old_f = (source == Source::Issue31).then(|| flops(old_f));
        rows.push(Row {
            measure: format!(
                "factorisation ({} faces, 1 thread, unsplit: `parallel = false`)",
                grouped(f)
            ),
            libshell: Some((time(lib_t), lib_t)),
            source,
            libshell17: old_t.clone(),
            thinshell: time(t1),
            value: t1,
            own_ratio: None,
            target: Target::AtLeast(1.0),
            comparable,
            issue_size: Some(if k == 0 { K20 } else { K80 }),
            why: why::FACTOR,
        });
        let t1s = med(sm, &linear::split_one_id(level), "total");
        rows.push(Row {
            measure: format!(
                "factorisation ({} faces, 1 thread, split: the default `parallel = true` on one thread, same bits as 2 threads); ratio = unsplit / split",
                grouped(f)
            ),
            libshell: None,
            source,
            libshell17: None,
            thinshell: time(t1s),
            value: t1s,
            own_ratio: Some(t1 / t1s),
            target: Target::Info,
            comparable: true,
            issue_size: None,
            why: "",
        });
        if two {
            let t2 = med(sm, &linear::id(level, 2), "total");
            rows.push(Row {
                measure: format!(
                    "factorisation with 2 threads ({} faces); ratio = 1-thread unsplit time / 2-thread time",
                    grouped(f)
                ),
                libshell: None,
                source,
                libshell17: None,
                thinshell: time(t2),
                value: t2,
                own_ratio: Some(t1 / t2),
                target: Target::SpeedUp,
                comparable: true,
                issue_size: None,
                why: why::THREADS,
            });
        }
        if let Some(lf) = run.facts.levels.get(&level) {
            rows.push(Row {
                measure: format!(
                    "predicted factorisation flops, default ordering ({}; {} faces); libshell = METIS",
                    lf.ordering,
                    grouped(f)
                ),
                libshell: Some((flops(lib_f), lib_f)),
                source,
                libshell17: old_f.clone(),
                thinshell: flops(lf.flops),
                value: lf.flops,
                own_ratio: None,
                target: Target::AtLeast(1.0),
                comparable,
                issue_size: Some(if k == 0 { K20 } else { K80 }),
                why: why::ORDERING,
            });
        }
    }
    let newton_at = |level: usize, threads: usize| med(sm, &newton::id(level, threads), "total");
    for (k, &level) in sz.factor.iter().enumerate() {
        let (lib, old) = if k == 0 {
            (libshell31::NEWTON_20K_S, libshell::NEWTON_20K_S)
        } else {
            (libshell31::NEWTON_80K_S, libshell::NEWTON_80K_S)
        };
        for &threads in &sz.threads {
            let v = newton_at(level, threads);
            let target = match (k, threads) {
                (0, 2) => Target::AtLeast(4.0),
                (_, 2) => Target::AtLeast(3.0),
                _ => Target::AtLeast(1.0),
            };
            rows.push(Row {
                measure: format!(
                    "one Newton iteration ({} faces, thinshell {threads} thread{}; libshell 1 thread)",
                    grouped(faces_at(level)),
                    if threads == 1 { "" } else { "s" }
                ),
                libshell: Some((time(lib), lib)),
                source: Source::Issue31,
                libshell17: Some(time(old)),
                thinshell: time(v),
                value: v,
                own_ratio: None,
                target,
                comparable,
                issue_size: Some(if k == 0 { K20 } else { K80 }),
                why: why::NEWTON,
            });
        }
    }
    let growth: Vec<(usize, f64)> = sz
        .threads
        .iter()
        .map(|&th| {
            let pts: Vec<(f64, f64)> = sz
                .newton
                .iter()
                .map(|&l| (faces_at(l) as f64, newton_at(l, th)))
                .collect();
            (th, loglog_slope(&pts))
        })
        .collect();
    let span = format!(
        "{} → {} faces",
        grouped(faces_at(sz.newton[0])),
        grouped(faces_at(sz.newton[sz.newton.len() - 1]))
    );
    for &(th, g) in &growth {
        rows.push(Row {
            measure: format!(
                "growth exponent of a Newton iteration, {span}, {th} thread{} (least-squares log-log slope)",
                if th == 1 { "" } else { "s" }
            ),
            libshell: Some((format!("{:.2}", libshell31::GROWTH), libshell31::GROWTH)),
            source: Source::Issue31,
            libshell17: Some(format!("{:.2}", libshell::GROWTH)),
            thinshell: format!("{g:.2}"),
            value: g,
            own_ratio: None,
            target: Target::AtMost(1.2),
            comparable,
            issue_size: Some("1 280 → 81 920 faces"),
            why: why::GROWTH,
        });
    }
    for sff in SffKind::ALL.into_iter().filter(|k| k.director().is_some()) {
        let d = per_face(sff, "energy_gradient_hessian");
        let a = per_face(avg, "energy_gradient_hessian");
        rows.push(Row {
            measure: format!(
                "{}: energy + gradient + Hessian per face ({pf_label}); ratio = director / average",
                sff.name()
            ),
            libshell: None,
            source: Source::Issue31,
            libshell17: None,
            thinshell: format!("{} ns", ns(d)),
            value: d,
            own_ratio: Some(d / a),
            target: Target::AtMost(1.5),
            comparable: true,
            issue_size: None,
            why: why::DIRECTOR_FACE,
        });
    }
    for sff in SffKind::ALL.into_iter().filter(|k| k.director().is_some()) {
        let d = med(sm, &newton::step_id(sff), "total");
        let a = med(sm, &newton::step_id(avg), "total");
        rows.push(Row {
            measure: format!(
                "{}: implicit step ({} faces, 1 thread); ratio = director / average",
                sff.name(),
                grouped(pf)
            ),
            libshell: None,
            source: Source::Issue31,
            libshell17: None,
            thinshell: time(d),
            value: d,
            own_ratio: Some(d / a),
            target: Target::AtMost(1.4),
            comparable: true,
            issue_size: None,
            why: why::DIRECTOR_STEP,
        });
    }
    if run.big {
        for br in &run.big_runs {
            let v = median(&br.samples["total"]);
            rows.push(Row {
                measure: format!(
                    "one Newton iteration, {} faces (icosphere level {}), {} thread{}: time, peak memory",
                    grouped(br.faces),
                    br.level,
                    br.threads,
                    if br.threads == 1 { "" } else { "s" }
                ),
                libshell: None,
                source: Source::Issue31,
                libshell17: None,
                thinshell: format!(
                    "{}, {}",
                    time(v),
                    br.peak_rss.map_or("peak unknown".to_string(), bytes)
                ),
                value: v,
                own_ratio: None,
                target: Target::Recorded,
                comparable: true,
                issue_size: None,
                why: "",
            });
        }
    } else {
        rows.push(Row {
            measure: format!(
                "one Newton iteration, {} faces (icosphere level {}): time, peak memory",
                grouped(faces_at(sz.big)),
                sz.big
            ),
            libshell: None,
            source: Source::Issue31,
            libshell17: None,
            thinshell: "not run (`--big`)".into(),
            value: f64::NAN,
            own_ratio: None,
            target: Target::Recorded,
            comparable: false,
            issue_size: None,
            why: "",
        });
    }
    b.push(Block::Table {
        header: [
            "measure",
            "libshell (issue #31)",
            "libshell (issue #17)",
            "thinshell",
            "ratio",
            "target",
            "met / gap",
        ]
        .map(String::from)
        .to_vec(),
        rows: rows.iter().map(Row::cells).collect(),
    });
    let gaps: Vec<&Row> = rows
        .iter()
        .filter(|r| r.gap() && !r.why.is_empty())
        .collect();
    if !gaps.is_empty() {
        line(&mut b, String::new());
        line(&mut b, "Why the targets not met are missed:".to_string());
        line(&mut b, String::new());
        let mut seen = Vec::new();
        for r in gaps {
            if !seen.contains(&r.why) {
                seen.push(r.why);
                line(&mut b, format!("- {}", r.why));
            }
        }
    }
    line(&mut b, String::new());

    // Per face, every form.
    line(
        &mut b,
        format!("### Per face, every form ({pf_label}), ns per face"),
    );
    line(&mut b, String::new());
    let mut header = vec!["evaluation".to_string()];
    for sff in SffKind::ALL {
        let n = run
            .facts
            .unknowns
            .get(&format!("per_face/{}", sff.name()))
            .copied()
            .unwrap_or(0);
        header.push(format!("{} ({} unknowns)", sff.name(), grouped(n)));
    }
    for sff in SffKind::ALL.into_iter().filter(|k| k.director().is_some()) {
        header.push(format!("{} / average", sff.name()));
    }
    let mut rows = Vec::new();
    for (what, _, _) in kernels::EVALS {
        let mut r = vec![s(what.replace('_', " + "))];
        for sff in SffKind::ALL {
            r.push(t(ns(per_face(sff, what))));
        }
        for sff in SffKind::ALL.into_iter().filter(|k| k.director().is_some()) {
            r.push(t(ratio(per_face(sff, what) / per_face(avg, what))));
        }
        rows.push(r);
    }
    b.push(Block::Table { header, rows });
    line(&mut b, String::new());

    // Factorisation and orderings.
    line(&mut b, "### Factorisation".into());
    line(&mut b, String::new());
    let mut rows = Vec::new();
    for &(level, ..) in &factor_levels {
        let Some(lf) = run.facts.levels.get(&level) else {
            continue;
        };
        let t1 = med(sm, &linear::id(level, 1), "total");
        let t2 = med(sm, &linear::id(level, 2), "total");
        rows.push(vec![
            s(grouped(lf.faces)),
            s(grouped(lf.unknowns)),
            s(grouped(lf.nnz)),
            s(lf.ordering.clone()),
            s(flops(lf.flops)),
            s(bytes(lf.memory_estimate)),
            t(time(t1)),
            t(if two { time(t2) } else { "—".into() }),
            t(if two { ratio(t1 / t2) } else { "—".into() }),
            t(format!("{:.1}", lf.flops / t1 / 1e9)),
        ]);
    }
    b.push(Block::Table {
        header: [
            "faces",
            "unknowns",
            "Hessian entries (lower)",
            "default ordering",
            "predicted flops",
            "factor memory (estimate)",
            "1 thread",
            "2 threads",
            "speed-up",
            "GFlop/s, 1 thread",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    line(&mut b, String::new());
    line(
        &mut b,
        "Predicted flops (Σ over columns of the squared column counts of L) of every ordering \
         the library has; METIS needs 6.4e9 at 20 480 faces and 5.65e10 at 81 920 (the issue):"
            .into(),
    );
    line(&mut b, String::new());
    let rows = run
        .facts
        .orderings
        .iter()
        .map(|o| {
            vec![
                s(grouped(faces_at(o.level))),
                s(o.asked.clone()),
                s(o.used.clone()),
                s(flops(o.flops)),
                s(grouped(o.factor_len)),
                s(bytes(o.memory_estimate)),
                t(time(o.symbolic_s)),
            ]
        })
        .collect();
    b.push(Block::Table {
        header: [
            "faces",
            "ordering",
            "used",
            "predicted flops",
            "factor values",
            "factor memory (estimate)",
            "ordering + symbolic analysis",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    line(&mut b, String::new());

    // Newton iterations.
    line(
        &mut b,
        "### One Newton iteration (library defaults), per size and thread count".into(),
    );
    line(&mut b, String::new());
    let mut rows = Vec::new();
    for &th in &sz.threads {
        for &level in &sz.newton {
            let id = newton::id(level, th);
            let total = med(sm, &id, "total");
            // Shares of the sum of the stage medians (the median of the totals is another
            // round's sum in general).
            let sum: f64 = newton::PARTS[1..].iter().map(|p| med(sm, &id, p)).sum();
            let part = |p: &str| {
                let v = med(sm, &id, p);
                t(format!("{} ({:.0} %)", time(v), 100.0 * v / sum))
            };
            let lf = run.facts.levels.get(&level);
            rows.push(vec![
                s(grouped(faces_at(level))),
                s(lf.map_or("?".into(), |l| grouped(l.unknowns))),
                s(th.to_string()),
                t(time(total)),
                part("assembly"),
                part("factorisation"),
                part("solve"),
            ]);
        }
    }
    b.push(Block::Table {
        header: [
            "faces",
            "unknowns",
            "threads",
            "iteration (median)",
            "assembly",
            "factorisation",
            "solve",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    line(&mut b, String::new());
    let fits: Vec<String> = growth
        .iter()
        .map(|(th, g)| {
            format!(
                "faces^{g:.2} with {th} thread{}",
                if *th == 1 { "" } else { "s" }
            )
        })
        .collect();
    b.push(Block::Line(t(format!(
        "Growth ({span}, least-squares fit of the iteration time): {}.",
        fits.join(", ")
    ))));
    line(&mut b, String::new());

    // Implicit steps.
    line(
        &mut b,
        format!(
            "### One implicit step per form ({} faces, 1 thread, library defaults)",
            grouped(pf)
        ),
    );
    line(&mut b, String::new());
    let a = med(sm, &newton::step_id(avg), "total");
    let rows = SffKind::ALL
        .iter()
        .map(|&sff| {
            let id = newton::step_id(sff);
            let v = med(sm, &id, "total");
            vec![
                s(sff.name()),
                s(run
                    .facts
                    .step_unknowns
                    .get(sff.name())
                    .map_or("?".into(), |n| grouped(*n))),
                s(format!("{:.0}", med(sm, &id, "newton_iterations"))),
                t(time(v)),
                t(ratio(v / a)),
            ]
        })
        .collect();
    b.push(Block::Table {
        header: [
            "form",
            "unknowns",
            "Newton iterations",
            "step",
            "step / average's",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    line(&mut b, String::new());

    // The big run.
    line(
        &mut b,
        format!(
            "### {} faces (icosphere level {}): one Newton iteration in a child process",
            grouped(faces_at(sz.big)),
            sz.big
        ),
    );
    line(&mut b, String::new());
    if run.big_runs.is_empty() {
        line(
            &mut b,
            "Not run: `cargo xtask perf --big` runs it (one child process per thread count; \
             peak memory = the child's VmHWM)."
                .into(),
        );
    } else {
        let rows = run
            .big_runs
            .iter()
            .map(|br| {
                let part = |p: &str| br.samples.get(p).map_or(f64::NAN, |v| median(v));
                vec![
                    s(grouped(br.faces)),
                    s(grouped(br.unknowns)),
                    s(br.threads.to_string()),
                    s(br.ordering.clone()),
                    s(flops(br.flops)),
                    s(bytes(br.memory_estimate)),
                    t(br.peak_rss.map_or("unknown".into(), bytes)),
                    t(time(part("total"))),
                    t(time(part("assembly"))),
                    t(time(part("factorisation"))),
                    t(time(part("solve"))),
                    t(time(br.setup_s)),
                ]
            })
            .collect();
        b.push(Block::Table {
            header: [
                "faces",
                "unknowns",
                "threads",
                "ordering",
                "predicted flops",
                "factor memory (estimate)",
                "peak memory (VmHWM)",
                "iteration (median)",
                "assembly",
                "factorisation",
                "solve",
                "set-up (mesh, pattern, symbolic)",
            ]
            .map(String::from)
            .to_vec(),
            rows,
        });
        line(&mut b, String::new());
        line(
            &mut b,
            format!(
                "Each row is one child process (`xtask perf-child`) running {} iteration(s) after \
                 its set-up; peak memory is its VmHWM, i.e. everything the process held at once \
                 (mesh, assembler buffers, Hessian, factor, scratch).",
                run.big_runs
                    .first()
                    .map_or(0, |r| r.samples.get("total").map_or(0, Vec::len))
            ),
        );
    }
    for extra in &run.extra {
        line(&mut b, String::new());
        b.push(Block::Extra(extra.clone()));
    }
    b
}

/// Replaces the text between the markers of `docs` by `section`; errors if they are missing.
pub(crate) fn splice(docs: &str, section: &str) -> Result<String> {
    let (Some(a), Some(z)) = (docs.find(BEGIN), docs.find(END)) else {
        bail!("the docs file has no `{BEGIN}` … `{END}` markers to write between");
    };
    if z < a {
        bail!("`{END}` comes before `{BEGIN}` in the docs file");
    }
    let head = &docs[..a + BEGIN.len()];
    let tail = &docs[z..];
    Ok(format!("{head}\n{section}{tail}"))
}

/// Writes the JSON and the docs section.
pub(crate) fn write(opts: &Options, run: &Run, docs: &str) -> Result<()> {
    let blocks = blocks(run);
    let section = render(&blocks, false);
    let masked = render(&blocks, true);
    let new_docs = splice(docs, &section)?;
    std::fs::write(&opts.docs_path, new_docs)
        .with_context(|| format!("writing {}", opts.docs_path.display()))?;

    let levels: BTreeMap<String, serde_json::Value> = run
        .facts
        .levels
        .iter()
        .map(|(l, f)| {
            (
                l.to_string(),
                json!({
                    "faces": f.faces, "unknowns": f.unknowns, "nnz_lower": f.nnz,
                    "ordering": f.ordering, "flops": f.flops, "factor_len": f.factor_len,
                    "memory_estimate": f.memory_estimate,
                }),
            )
        })
        .collect();
    let orderings: Vec<serde_json::Value> = run
        .facts
        .orderings
        .iter()
        .map(|o| {
            json!({
                "level": o.level, "faces": faces_at(o.level), "ordering": o.asked, "used": o.used,
                "flops": o.flops, "factor_len": o.factor_len,
                "memory_estimate": o.memory_estimate, "symbolic_s": o.symbolic_s,
            })
        })
        .collect();
    let big: Vec<serde_json::Value> = run
        .big_runs
        .iter()
        .map(|b| {
            json!({
                "level": b.level, "threads": b.threads, "faces": b.faces, "unknowns": b.unknowns,
                "ordering": b.ordering, "flops": b.flops, "memory_estimate": b.memory_estimate,
                "peak_rss": b.peak_rss, "setup_s": b.setup_s, "samples": b.samples,
                "wall_s": b.wall_s,
            })
        })
        .collect();
    let doc = json!({
        "command": command(run),
        "quick": run.quick,
        "rounds": run.rounds,
        "sizes": {
            "per_face_level": run.sizes.per_face,
            "factor_levels": run.sizes.factor,
            "newton_levels": run.sizes.newton,
            "big_level": run.sizes.big,
            "threads": run.sizes.threads,
        },
        "units": "seconds; per_face/* in seconds per face; newton_iterations a count",
        "samples": run.samples,
        "levels": levels,
        "orderings": orderings,
        "unknowns": run.facts.unknowns,
        "big": big,
        "total_s": run.total_s,
        "section": section,
        "section_masked": masked,
    });
    if let Some(dir) = opts.json_path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(&opts.json_path, serde_json::to_string_pretty(&doc)?)
        .with_context(|| format!("writing {}", opts.json_path.display()))?;
    println!(
        "perf: wrote {} and {} ({:.0} s)",
        opts.docs_path.display(),
        opts.json_path.display(),
        run.total_s
    );
    print!("{section}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splice_rewrites_only_between_the_markers() -> Result<()> {
        let docs = format!("# T\n\nintro\n\n{BEGIN}\nold\n{END}\n\n## history\n");
        let new = splice(&docs, "new\n")?;
        assert_eq!(
            new,
            format!("# T\n\nintro\n\n{BEGIN}\nnew\n{END}\n\n## history\n")
        );
        assert_eq!(splice(&new, "new\n")?, new);
        assert!(splice("# no markers\n", "x").is_err());
        assert!(splice(&format!("{END}\n{BEGIN}\n"), "x").is_err());
        Ok(())
    }

    #[test]
    fn numbers_are_formatted_as_in_the_issue() {
        assert_eq!(grouped(14_924), "14 924");
        assert_eq!(grouped(188), "188");
        assert_eq!(grouped(1_234_567), "1 234 567");
        assert_eq!(time(0.279), "279 ms");
        assert_eq!(time(2.031), "2.03 s");
        assert_eq!(flops(6.4e9), "6.40e9");
        assert_eq!(flops(9.996e10), "1.00e11");
        assert_eq!(flops(5.65e10), "5.65e10");
        assert_eq!(Target::AtLeast(1.5).verdict(1.6), "met");
        assert_eq!(Target::AtLeast(2.0).verdict(1.0), "gap: 2.00× short");
        assert_eq!(Target::AtMost(1.2).verdict(1.28), "gap: 0.08 over");
        assert!(today().len() == 10 && today().starts_with("20"));
    }
}
