//! The `thinshell` command-line tool's commands, as library functions so that they can be
//! tested without spawning processes: [`commands`] (`run`, `resume`, `check`, `info`), [`modes`], the
//! progress display and resume bookkeeping ([`mod@resume`]), and the browser viewer ([`view`]).
//!
//! Everything that writes a run's outputs lives in the library (`thinshell::output`), shared
//! with the Python package; this crate adds the terminal (progress bar, Ctrl-C, exit codes) and
//! the viewer.

pub mod commands;
pub mod design;
mod load;
pub mod modes;
pub mod resume;
pub mod view;

pub use commands::{RunEnd, RunOptions, check, info, resume, run, run_with};
pub use thinshell::output::{
    CHECKPOINT_FILE, CheckpointEvery, Failure, steps_csv_header, steps_csv_timing_columns,
};
