//! Run output: what `thinshell run` and the Python package write while a [`Simulation`] runs.
//!
//! - [`writer`]: [`OutputWriter`], the one writer — an [`Observer`], so [`Simulation::run`]
//!   drives it, or a caller that steps the simulation itself calls [`OutputWriter::step`] after
//!   every step; `summary.json` ([`Summary`], the run [`Totals`]) and the [`Notice`]s it hands
//!   back to its caller (it prints nothing).
//! - [`csv`]: every column of `steps.csv`.
//! - `frames`: the OBJ/VTK frame files and `frames.pvd`; what a frame holds is computed by
//!   [`crate::fields`], the writer only writes it.
//! - [`checkpoint`]: `checkpoint.bin` ([`Simulation::save`], [`Simulation::restore`]) with the
//!   writer's [`RunRecord`], so that `thinshell resume` continues the same files.
//!
//! The command-line tool (crate `thinshell-cli`) adds the progress bar, Ctrl-C, `resume` and
//! the printing of notices on top of it.

pub mod checkpoint;
pub mod csv;
mod frames;
pub mod writer;

pub use checkpoint::{
    CHECKPOINT_FILE, CHECKPOINT_VERSION, CheckpointError, CheckpointEvery, CheckpointInfo,
    RunRecord, read_checkpoint_info, scene_hash,
};
pub use csv::{Column, STEPS_CSV_COLUMNS, steps_csv_header, steps_csv_timing_columns};
pub use writer::{Notice, OutputWriter, RunStatus, Summary, Totals, residual_history};

#[cfg(doc)]
use crate::sim::{Observer, Simulation};

/// Why writing a run (or the run itself) failed; the command-line tool maps it to its exit
/// code.
#[derive(Debug)]
pub enum Failure {
    /// Bad input: scene, mesh, arguments, an output directory that cannot be created (the
    /// command-line tool's exit code 2).
    BadInput(String),
    /// The simulation or its output failed after starting (exit code 1); the last good state
    /// was written.
    Simulation(String),
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::BadInput(m) | Failure::Simulation(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Failure {}
