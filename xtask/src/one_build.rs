//! Checks that `cargo xtask` reuses the build of the README's test command.
//!
//! Cargo compiles a dependency once per feature set. `cargo test --workspace` resolves features
//! over every member with its dev-dependencies; `cargo xtask` (`cargo run -p xtask`) over xtask's
//! own dependencies. Where the two differ, the second command recompiles the dependency and
//! everything above it (faer, rayon, the thinshell crates: minutes). xtask's Cargo.toml asks
//! for the features the dev-dependencies add; this test fails when a new dependency brings
//! in another difference, naming the packages to add there.

use std::collections::BTreeSet;
use std::process::Command;

/// `cargo tree` lines `name vX.Y.Z features` (one per package and feature set).
fn feature_sets(args: &[&str]) -> Result<BTreeSet<String>, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(&cargo)
        .args([
            "tree",
            "--offline",
            "--prefix",
            "none",
            "--format",
            "{p} {f}",
        ])
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .map_err(|e| format!("running {cargo} tree: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{cargo} tree {args:?} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.replace(" (*)", "").replace(" (proc-macro)", ""))
        .filter(|l| !l.trim().is_empty())
        .collect())
}

/// The packages built on their own by a README command.
const ALONE: [&str; 3] = ["xtask", "thinshell-cli", "thinshell-python"];

#[test]
fn one_feature_set() -> Result<(), String> {
    let test_build = feature_sets(&["--workspace", "--edges", "normal,build,dev"])?;
    for package in ALONE {
        let alone = feature_sets(&["--package", package, "--edges", "normal,build"])?;
        let differ: Vec<&String> = alone.difference(&test_build).collect();
        assert!(
            differ.is_empty(),
            "building {package} alone would compile these with other features than \
             `cargo test --workspace` (add the test build's features to \
             crates/one-build/Cargo.toml):\n{differ:#?}"
        );
    }
    Ok(())
}
