//! The Python stage of `cargo xtask test`: the `thinshell` Python package's pytest suite
//! (`python/tests`), in a project-local virtual environment.
//!
//! On first use (or when `python/requirements-test.txt` changed) it creates the environment
//! `<target dir>/python-venv` with `python3 -m venv` and installs the pinned requirements from
//! PyPI; then, every time, it builds the extension into it with `maturin develop --release`
//! using the workspace's target dir (so faer and the library crates are not compiled again),
//! and runs pytest with `THINSHELL_BIN` pointing at the CLI the tests compare against.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::common::{run_stage, workspace_root};

/// Python older than this cannot run the package (it uses `tomllib` and 3.11 typing).
const MIN_PYTHON: (u32, u32) = (3, 11);

/// Runs the stage.
pub fn stage() -> Result<()> {
    let start = std::time::Instant::now();
    let root = workspace_root();
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"));
    let target = if target.is_absolute() {
        target
    } else {
        root.join(target)
    };
    let venv = target.join("python-venv");
    ensure_venv(&root, &venv)?;

    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    // The test build's feature set (dev-dependencies included) builds the CLI as part of the
    // workspace tests; `cargo build -p thinshell` alone would resolve other features and
    // recompile thinshell and its dependencies (2 min on a fresh clone).
    run_stage(
        "cargo test --workspace --release --no-run   (the CLI the Python tests compare against; built by the Rust stage)",
        Command::new(&cargo)
            .args(["test", "--workspace", "--release", "--no-run"])
            .current_dir(&root),
    )?;
    let bin = venv.join("bin");
    let path = match std::env::var_os("PATH") {
        Some(p) => {
            let mut dirs = vec![bin.clone()];
            dirs.extend(std::env::split_paths(&p));
            std::env::join_paths(dirs).context("PATH")?
        }
        None => bin.clone().into_os_string(),
    };
    run_stage(
        "maturin develop --release   (the extension module, into the test environment)",
        Command::new(bin.join("maturin"))
            .args(["develop", "--release", "--quiet"])
            .current_dir(root.join("python"))
            .env("VIRTUAL_ENV", &venv)
            .env("PATH", &path)
            .env("CARGO_TARGET_DIR", &target)
            .env("CARGO", &cargo),
    )?;
    // From python/, as a developer of the package runs it: the `src` layout keeps the sources
    // from shadowing the installed package there (test_state.py also imports from there).
    run_stage(
        "pytest (in python/)",
        Command::new(bin.join("python"))
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .current_dir(root.join("python"))
            .env("THINSHELL_BIN", target.join("release").join("thinshell"))
            .env("CARGO_TARGET_DIR", &target),
    )?;
    println!(
        "xtask test: Python stage passed in {:.0} s",
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Creates (or recreates, when the requirements changed) the virtual environment.
fn ensure_venv(root: &Path, venv: &Path) -> Result<()> {
    let req_path = root.join("python").join("requirements-test.txt");
    let requirements = std::fs::read_to_string(&req_path)
        .with_context(|| format!("reading {}", req_path.display()))?;
    let stamp = venv.join("thinshell-requirements.txt");
    if std::fs::read_to_string(&stamp).ok().as_deref() == Some(requirements.as_str())
        && venv.join("bin").join("maturin").exists()
    {
        return Ok(());
    }
    let python = std::env::var("THINSHELL_PYTHON").unwrap_or_else(|_| "python3".to_string());
    check_python(&python)?;
    println!(
        "xtask test: creating the Python test environment {} (first use: a few minutes)",
        venv.display()
    );
    run_stage(
        &format!("{python} -m venv --clear {}", venv.display()),
        Command::new(&python)
            .args(["-m", "venv", "--clear"])
            .arg(venv),
    )?;
    let pip = venv.join("bin").join("pip");
    run_stage(
        "pip install -r python/requirements-test.txt",
        Command::new(&pip)
            .args(["install", "--quiet", "--disable-pip-version-check", "-r"])
            .arg(&req_path),
    )?;
    std::fs::write(&stamp, requirements).with_context(|| format!("writing {}", stamp.display()))?;
    Ok(())
}

/// Fails with a clear message when `python` is missing or older than [`MIN_PYTHON`].
fn check_python(python: &str) -> Result<()> {
    let out = Command::new(python)
        .args([
            "-c",
            "import sys; print(sys.version_info[0], sys.version_info[1])",
        ])
        .output();
    let need = format!("{}.{}", MIN_PYTHON.0, MIN_PYTHON.1);
    let out = match out {
        Ok(o) if o.status.success() => o,
        _ => bail!(
            "the Python tests need `{python}` (Python >= {need}, with the venv module) on PATH; \
             install it, point THINSHELL_PYTHON at one, or run `cargo xtask test --rust-only`"
        ),
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let v: Vec<u32> = text
        .split_whitespace()
        .filter_map(|s| s.parse().ok())
        .collect();
    match v.as_slice() {
        [major, minor] if (*major, *minor) >= MIN_PYTHON => Ok(()),
        _ => bail!(
            "`{python}` is Python {}, the Python tests need >= {need}; point THINSHELL_PYTHON at a newer one, or run `cargo xtask test --rust-only`",
            text.trim().replace(' ', ".")
        ),
    }
}
