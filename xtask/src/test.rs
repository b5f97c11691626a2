//! `cargo xtask test`: every test of the project, in one command (the README's test command and
//! what `.ci/run` calls after fmt and clippy).
//!
//! Stages run in order and the first failure stops the run with a non-zero exit:
//! 1. `cargo test --workspace --release`: the Rust tests (unit, integration, doc, property).
//! 2. the Python package's pytest suite ([`python`]).
//! 3. browser: `thinshell view` end to end in headless Chromium ([`browser`]).
//!
//! A stage that needs something from outside the Rust toolchain (a Python environment, a browser)
//! installs it itself on first use, from the package registries, into project-local folders (Chromium: system-wide, with apt-get), so a
//! fresh clone needs nothing installed by hand.

use std::process::Command;

use anyhow::Result;

use crate::common::{run_stage, workspace_root};

mod browser;
mod python;

/// Options of `cargo xtask test`.
pub struct Options {
    /// Only the Rust tests (skip the stages that install outside tools).
    pub rust_only: bool,
}

/// Runs every stage; stops at the first that fails.
pub fn run(opts: &Options) -> Result<()> {
    rust_stage()?;
    if opts.rust_only {
        println!("xtask test: --rust-only: the other stages were skipped");
        return Ok(());
    }
    python::stage()?;
    browser::stage()?;
    println!("xtask test: all stages passed");
    Ok(())
}

/// The Rust tests, exactly as before this command existed.
fn rust_stage() -> Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    run_stage(
        "cargo test --workspace --release",
        Command::new(cargo)
            .args(["test", "--workspace", "--release"])
            .current_dir(workspace_root()),
    )
}
