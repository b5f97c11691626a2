//! The browser stage of `cargo xtask test`: the end-to-end tests of `thinshell view` in headless
//! Chromium (`crates/cli/tests/view_browser.rs`, `#[ignore]`d in plain `cargo test`).
//!
//! Debian's `chromium` is installed with apt-get when it is missing (as root; `apt-get update`
//! first); without root and without a browser the stage
//! fails with what to do. `CHROMIUM=/path` selects another binary. The tests run with
//! `--ignored`, so they fail, never pass, when the browser cannot start. The playback benchmark
//! (`bench_…`) is skipped.

use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::common::{run_stage, workspace_root};

/// Installs chromium if needed, then runs the browser tests.
pub fn stage() -> Result<()> {
    let chromium = ensure_chromium()?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    run_stage(
        "browser tests: cargo test --workspace --release --test view_browser -- --ignored --skip bench_",
        // `--workspace` as in the Rust stage: the same feature set, so nothing is rebuilt.
        Command::new(cargo)
            .args(["test", "--workspace", "--release", "--test", "view_browser"])
            .args(["--", "--ignored", "--skip", "bench_"])
            .env("CHROMIUM", chromium)
            .current_dir(workspace_root()),
    )
}

fn on_path(name: &str) -> Option<String> {
    let paths = std::env::var_os("PATH")?;
    std::env::split_paths(&paths)
        .map(|d| d.join(name))
        .find(|p| p.is_file())
        .map(|p| p.display().to_string())
}

fn find() -> Option<String> {
    if let Ok(p) = std::env::var("CHROMIUM") {
        return Some(p);
    }
    on_path("chromium").or_else(|| on_path("chromium-browser"))
}

/// The browser's path, installing Debian's chromium when there is none.
fn ensure_chromium() -> Result<String> {
    if let Some(p) = find() {
        return Ok(p);
    }
    let uid = Command::new("id")
        .arg("-u")
        .output()
        .context("could not run `id -u`")?;
    if String::from_utf8_lossy(&uid.stdout).trim() != "0" {
        bail!(
            "chromium is missing and this user is not root, so the browser stage cannot install it: \
             run `sudo apt-get install -y chromium` (or set CHROMIUM=/path/to/chromium)"
        );
    }
    let start = std::time::Instant::now();
    run_stage(
        "apt-get update (to install chromium for the browser tests)",
        Command::new("apt-get").args(["update", "-q"]),
    )?;
    run_stage(
        "apt-get install -y chromium",
        Command::new("apt-get")
            .args(["install", "-y", "-q", "chromium"])
            .env("DEBIAN_FRONTEND", "noninteractive"),
    )?;
    println!(
        "xtask test: chromium installed in {:.0} s",
        start.elapsed().as_secs_f64()
    );
    find().context("apt-get installed chromium but it is not on PATH")
}
