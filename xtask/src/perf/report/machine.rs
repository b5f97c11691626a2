//! The run's circumstances: machine, load, revision, date and the command that reproduces it.

pub(super) use crate::common::today;
use crate::common::{cpu_model, load_average};
use std::fmt::Write as _;

use super::format::bytes;
use crate::perf::facts::Run;

/// The machine line: CPU model, cores, memory, date, git revision, load average.
pub(super) fn machine() -> String {
    let cpu = cpu_model().unwrap_or_else(|| "unknown CPU".to_string());
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

/// A warning when other work ran: a load average above half the cores when the run starts
/// means the timings are inflated and the ratios noisy. The load at the end is not judged: it
/// includes the run's own two-thread measures and `--big` child.
pub(super) fn load_warning(start: Option<f64>) -> Option<String> {
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
pub(super) fn git_rev() -> String {
    let root = crate::common::workspace_root();
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

/// The command that reproduces the run.
pub(super) fn command(run: &Run) -> String {
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
