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

#[test]
fn one_feature_set() -> Result<(), String> {
    let test_build = feature_sets(&["--workspace", "--edges", "normal,build,dev"])?;
    let xtask_build = feature_sets(&["--package", "xtask", "--edges", "normal,build"])?;
    let differ: Vec<&String> = xtask_build.difference(&test_build).collect();
    assert!(
        differ.is_empty(),
        "`cargo xtask` would compile these with other features than `cargo test --workspace` \
         (add the test build's features to xtask/Cargo.toml):\n{differ:#?}"
    );
    Ok(())
}
