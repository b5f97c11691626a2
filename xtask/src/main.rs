//! Project tasks, run as `cargo xtask <task>` (an alias in `.cargo/config.toml` that builds in
//! release, sharing the test build).
//!
//! - `bench-square`: the seed's three square experiments, the seed's way and the fast way.
//! - `bench-sphere`: the seed's two sphere experiments with energy plots and rendered shapes.
//! - `hard-cases`: heavy variants of the numerical hard cases (docs/robustness.md).
//! - `accuracy`: error against known answers vs wall time for every accuracy knob.
//! - `verify`: the verification suite against analytic and published answers (docs/verification.md).
//! - `test`: every test of the project (the README's test command).
//! - `perf`: the performance table against libshell (docs/performance.md's generated section).
//! - `contact-cost`: what the `contact` effect costs on the scroll at three sizes.

mod accuracy;
mod bench_sphere;
mod bench_square;
mod common;
mod contact_cost;
mod hard_cases;
#[cfg(test)]
mod one_build;
mod perf;
mod plot;
mod render;
mod test;
mod verify;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use common::{out_dir, workspace_root};

#[derive(Parser)]
#[command(name = "cargo xtask", about = "thinshell project tasks")]
struct Args {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand)]
enum Task {
    /// The seed's square experiments (enlarged square, rhombus, cylindrical patch): the seed's
    /// way (implicit Euler, Δt = 5e-6 s, no line search, 1000 steps) against the fastest way to the
    /// analytic equilibrium. Writes target/xtask/bench-square.json and energy plots.
    BenchSquare {
        /// Only the fast methods (skips the 1000-step seed runs).
        #[arg(long)]
        quick: bool,
    },
    /// The seed's sphere experiments (uniform and directed heat, 2000 implicit steps of 5e-6 s):
    /// energy plot and rendered shapes at five times under target/xtask/.
    BenchSphere {
        /// 200 steps instead of 2000.
        #[arg(long)]
        quick: bool,
    },
    /// Heavy hard cases: the seed scenes at dt = 1e-3 and 1e-2 s, a 10^4-step damped
    /// run, strong growth on a finer sphere, the crawling swelling strip. Writes
    /// target/xtask/hard-cases.json; fails if a run breaks the stability contract.
    HardCases {
        /// Skip the 10^4-step run.
        #[arg(long)]
        quick: bool,
        /// Run only the parts whose name contains this: scenes, flag, growth, strip.
        #[arg(long)]
        only: Option<String>,
        /// Bending form of the solver-level parts (flag, growth, strip): mid_edge_average,
        /// edge_director_sin or edge_director_tan (default: the library's default form).
        #[arg(long, value_parser = hard_cases::parse_form)]
        form: Option<thinshell_energy::SffKind>,
    },
    /// What accuracy costs in time: cases with known answers under every accuracy knob.
    /// Writes docs/accuracy.md, plots under docs/accuracy/ and target/xtask/accuracy.json.
    Accuracy {
        /// Fewer knob values and coarser meshes (under a minute).
        #[arg(long)]
        quick: bool,
        /// Directory for accuracy.md and the accuracy/ plots (default: <workspace>/docs).
        #[arg(long)]
        docs_dir: Option<PathBuf>,
        /// The JSON file with every run (default: target/xtask/accuracy.json).
        #[arg(long)]
        json: Option<PathBuf>,
        /// Only the cases whose name contains this text.
        #[arg(long)]
        only: Option<String>,
    },
    /// The verification suite: analytic cases, Kirchhoff plates, linear shell
    /// benchmarks and nonlinear load paths with every bending form under refinement. Writes
    /// docs/verification.md, plots under docs/verification/ and target/xtask/verify.json.
    Verify {
        /// Only the coarsest level of each case (the test runs this).
        #[arg(long)]
        quick: bool,
        /// Directory for verification.md and the verification/ plots (default: <workspace>/docs).
        #[arg(long)]
        docs_dir: Option<PathBuf>,
        /// The JSON file with every run (default: target/xtask/verify.json).
        #[arg(long)]
        json: Option<PathBuf>,
        /// Only the cases whose name or group contains this text.
        #[arg(long)]
        only: Option<String>,
        /// Only the bending forms whose name contains this text (e.g. `tan`).
        #[arg(long)]
        form: Option<String>,
        /// Levels to run, `a..b` (0 is the coarsest; default: the case's own series). A study
        /// option: levels beyond a case's series are finer meshes of the same family.
        #[arg(long)]
        levels: Option<String>,
    },
    /// The performance figures against libshell (per-face evaluation, gather, factorisation, orderings,
    /// Newton iterations and their growth, implicit steps per form) in interleaved rounds.
    /// Rewrites the generated section of docs/performance.md and writes target/xtask/perf.json.
    Perf {
        /// Smallest sizes and one round (seconds; the test runs this).
        #[arg(long)]
        quick: bool,
        /// Also the 327 680-face (icosphere level 7) Newton iteration: time and peak memory,
        /// in a child process per thread count.
        #[arg(long)]
        big: bool,
        /// Interleaved rounds; the report quotes medians over them.
        #[arg(long, default_value_t = 7)]
        rounds: usize,
        /// The markdown file whose generated section is rewritten (default:
        /// <workspace>/docs/performance.md).
        #[arg(long)]
        docs: Option<PathBuf>,
        /// The JSON file with every sample (default: target/xtask/perf.json).
        #[arg(long)]
        json: Option<PathBuf>,
        /// Run only the extra sections whose title contains this text (`rate`, `reuse`, `fallback`):
        /// print their markdown and write it to target/xtask/perf-only.md, leaving the docs
        /// file unchanged.
        #[arg(long)]
        only: Option<String>,
    },
    /// What the `contact` effect costs: broad phase, CCD, barrier assembly and
    /// implicit steps with and without contact on the rolling scroll at three sizes. Prints a
    /// markdown table and writes target/xtask/contact-cost.json.
    ContactCost {
        /// The smallest size and one round.
        #[arg(long)]
        quick: bool,
        /// Interleaved rounds; the table quotes medians over them.
        #[arg(long, default_value_t = 3)]
        rounds: usize,
    },
    /// Internal: one `perf --big` measurement in its own process (peak memory = its VmHWM).
    #[command(hide = true)]
    PerfChild {
        #[arg(long)]
        level: usize,
        #[arg(long)]
        threads: usize,
        #[arg(long)]
        rounds: usize,
    },
    /// Every test of the project: the Rust tests, then the stages that need outside tools
    /// (installed on first use). The README's test command; `.ci/run` calls it.
    Test {
        /// Only the Rust tests.
        #[arg(long)]
        rust_only: bool,
    },
}

fn main() -> ExitCode {
    let args = Args::parse();
    let result = match args.task {
        Task::BenchSquare { quick } => bench_square::run(quick),
        Task::BenchSphere { quick } => bench_sphere::run(quick),
        Task::HardCases { quick, only, form } => hard_cases::run(&hard_cases::Options {
            quick,
            only,
            form: form.unwrap_or_default(),
        }),
        Task::Accuracy {
            quick,
            docs_dir,
            json,
            only,
        } => accuracy::run(&accuracy::Options {
            quick,
            docs_dir: docs_dir.unwrap_or_else(|| workspace_root().join("docs")),
            json_path: json.unwrap_or_else(|| out_dir().join("accuracy.json")),
            only,
        }),
        Task::Verify {
            quick,
            docs_dir,
            json,
            only,
            form,
            levels,
        } => verify::parse_levels(levels.as_deref()).and_then(|levels| {
            verify::run(&verify::Options {
                quick,
                docs_dir: docs_dir.unwrap_or_else(|| workspace_root().join("docs")),
                json_path: json.unwrap_or_else(|| out_dir().join("verify.json")),
                only,
                form,
                levels,
            })
        }),
        Task::Perf {
            quick,
            big,
            rounds,
            docs,
            json,
            only,
        } => perf::run(&perf::Options {
            quick,
            big,
            rounds,
            docs_path: docs.unwrap_or_else(|| workspace_root().join("docs").join("performance.md")),
            json_path: json.unwrap_or_else(|| out_dir().join("perf.json")),
            only,
        }),
        Task::PerfChild {
            level,
            threads,
            rounds,
        } => perf::child_main(level, threads, rounds),
        Task::Test { rust_only } => test::run(&test::Options { rust_only }),
        Task::ContactCost { quick, rounds } => {
            contact_cost::run(&contact_cost::Options { quick, rounds })
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
