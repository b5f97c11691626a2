//! The `thinshell` command-line tool: `run`, `resume`, `check`, `view`, `modes`, `design` and
//! `info`.
//!
//! Exit codes: 0 success, 2 bad input (scene, mesh, arguments), 1 a simulation that failed (the
//! last good state is written), 130 a run stopped by Ctrl-C (SIGINT; its state is kept and the
//! `thinshell resume` command printed), as shells report a process ended by SIGINT.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::{Parser, Subcommand};
use thinshell_cli::{self as cli, Failure};

#[derive(Parser)]
#[command(
    name = "thinshell",
    version,
    about = "Thin elastic shells with environmentally driven rest shapes"
)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene: progress bar, frames (VTK/OBJ), steps.csv and summary.json.
    Run {
        /// The scene file (TOML, see docs/scenes.md).
        scene: PathBuf,
        /// Output directory (default: out/<scene name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a scene value, e.g. `--set integrator.dt=1e-4` (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Print every Newton iteration (residual, step length, Hessian, time) to stderr.
        #[arg(long)]
        verbose: bool,
        /// Write OUT/checkpoint.bin every N steps (`100`) or seconds (`30s`), for `resume`.
        #[arg(long, value_name = "N|Ns")]
        checkpoint_every: Option<cli::CheckpointEvery>,
    },
    /// Continue an interrupted run from OUT_DIR/checkpoint.bin (frames, steps.csv and
    /// summary.json continue as if it had never stopped).
    Resume {
        /// The run's output directory.
        out_dir: PathBuf,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Print every Newton iteration to stderr.
        #[arg(long)]
        verbose: bool,
        /// Checkpoint interval (default: the interrupted run's).
        #[arg(long, value_name = "N|Ns")]
        checkpoint_every: Option<cli::CheckpointEvery>,
    },
    /// Validate a scene and print what would be simulated, without running it.
    Check {
        /// The scene file.
        scene: PathBuf,
        /// Override a scene value (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Show one or two run output directories in the browser (served on 127.0.0.1), or write
    /// one self-contained HTML file with `--html`.
    View {
        /// The run output directory (what `thinshell run --out` wrote).
        dir: PathBuf,
        /// A second run, shown side by side with linked cameras and timelines.
        dir2: Option<PathBuf>,
        /// Port on 127.0.0.1 (0: any free port; the address is printed).
        #[arg(long, default_value_t = 8080)]
        port: u16,
        /// Write a self-contained HTML file (all frames embedded) instead of serving.
        #[arg(long, value_name = "FILE")]
        html: Option<PathBuf>,
    },
    /// Natural frequencies and mode shapes of a scene about its start state: OUT/modes.json
    /// (Hz, ascending) and one VTK frame per mode (docs/modal.md).
    Modes {
        /// The scene file.
        scene: PathBuf,
        /// Number of modes (the lowest).
        #[arg(long, default_value_t = 10)]
        count: usize,
        /// Output directory (default: out/<scene name>-modes).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a scene value (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Inverse design: the rest forms (growth pattern) whose static equilibrium takes the
    /// target's shape; writes OUT/scene.toml (rerun it with `thinshell run`), design.json,
    /// achieved.obj, history.csv (docs/design.md).
    Design {
        /// The scene file (static; its rest forms are what is designed).
        scene: PathBuf,
        /// The target shape (OBJ; same connectivity: per-vertex distance modulo rigid motion).
        #[arg(long)]
        target: PathBuf,
        /// isotropic, isotropic_face, rest_forms or bilayer.
        #[arg(long, default_value = "isotropic")]
        parametrisation: String,
        /// Output directory (default: out/<scene name>-design).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Reached when the rms distance ≤ TOL × the target's size.
        #[arg(long, default_value_t = 1e-3)]
        tolerance: f64,
        /// Weight of the Laplacian smoothness term of the pattern.
        #[arg(long, default_value_t = 0.0)]
        smoothness: f64,
        /// Growth factor bounds MIN,MAX (isotropic, bilayer).
        #[arg(long, value_name = "MIN,MAX", value_parser = cli::design::parse_bounds)]
        growth_bounds: Option<(f64, f64)>,
        /// Override a scene value (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Print statistics of a mesh (OBJ) and the problems found in it.
    Info {
        /// The mesh file (OBJ).
        mesh: PathBuf,
    },
}

/// A flag set by Ctrl-C; a second Ctrl-C while stopping exits at once (130).
fn stop_flag() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
    stop
}

/// Whether a run ended by Ctrl-C (exit code 130).
fn interrupted(end: cli::RunEnd) -> bool {
    end == cli::RunEnd::Interrupted
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            // clap prints help/version to stdout with success, usage errors to stderr.
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let result = match args.command {
        Command::Run {
            scene,
            out,
            set,
            quiet,
            verbose,
            checkpoint_every,
        } => {
            let options = cli::RunOptions {
                quiet,
                verbose,
                checkpoint_every,
            };
            cli::run_with(&scene, out.as_deref(), &set, &options, &stop_flag()).map(interrupted)
        }
        Command::Resume {
            out_dir,
            quiet,
            verbose,
            checkpoint_every,
        } => {
            let options = cli::RunOptions {
                quiet,
                verbose,
                checkpoint_every,
            };
            cli::resume(&out_dir, &options, &stop_flag()).map(interrupted)
        }
        Command::Check { scene, set } => cli::check(&scene, &set).map(|()| false),
        Command::Info { mesh } => cli::info(&mesh).map(|()| false),
        Command::Design {
            scene,
            target,
            parametrisation,
            out,
            tolerance,
            smoothness,
            growth_bounds,
            set,
        } => {
            let options = cli::design::DesignOptions {
                parametrisation,
                tolerance,
                smoothness,
                growth_bounds,
            };
            let stem = scene
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy());
            let out = out.unwrap_or_else(|| PathBuf::from("out").join(format!("{stem}-design")));
            cli::design::design_command(&scene, &target, &out, &set, &options).map(|()| false)
        }
        Command::Modes {
            scene,
            count,
            out,
            set,
        } => cli::modes::modes_command(&scene, count, out.as_deref(), &set).map(|()| false),
        Command::View {
            dir,
            dir2,
            port,
            html,
        } => {
            let dirs: Vec<&std::path::Path> = std::iter::once(dir.as_path())
                .chain(dir2.as_deref())
                .collect();
            thinshell_cli::view::view(&dirs, port, html.as_deref()).map(|()| false)
        }
    };
    match result {
        Ok(false) => ExitCode::SUCCESS,
        Ok(true) => ExitCode::from(130),
        Err(Failure::BadInput(msg)) => {
            eprintln!("thinshell: error: {msg}");
            ExitCode::from(2)
        }
        Err(Failure::Simulation(msg)) => {
            eprintln!("thinshell: simulation failed: {msg}");
            ExitCode::from(1)
        }
    }
}
