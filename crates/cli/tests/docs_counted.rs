//! Docs counted, not typed (issue #42): lists in the docs that a directory or the test suite
//! determines are checked here, so they cannot go stale.
#![allow(clippy::unwrap_used)]

use std::collections::BTreeSet;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `docs/scenes.md` lists exactly the scenes in `data/scenes/` (between its markers, one table
/// row per scene), and every listed scene passes `thinshell check`'s loading.
#[test]
fn scenes_md_lists_exactly_the_shipped_scenes() {
    let doc = std::fs::read_to_string(root().join("docs/scenes.md")).unwrap();
    let begin = doc.find("<!-- shipped-scenes:begin -->").unwrap();
    let end = doc.find("<!-- shipped-scenes:end -->").unwrap();
    let listed: Vec<String> = doc[begin..end]
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split('`').next())
        .map(str::to_string)
        .collect();
    let listed_set: BTreeSet<String> = listed.iter().cloned().collect();
    assert_eq!(listed.len(), listed_set.len(), "a scene is listed twice");
    let shipped: BTreeSet<String> = std::fs::read_dir(root().join("data/scenes"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    assert_eq!(
        listed_set, shipped,
        "docs/scenes.md's list of shipped scenes differs from data/scenes/"
    );
    for name in &shipped {
        thinshell::Scene::load(&root().join("data/scenes").join(name))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// The README states no test counts (they went stale): the number of tests is what the test
/// command prints.
#[test]
fn readme_has_no_typed_test_counts() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let words: Vec<&str> = readme.split_whitespace().collect();
    let counts: Vec<String> = words
        .windows(3)
        .filter(|w| {
            let n = w[0].trim_start_matches('(').replace(['\u{a0}', ','], "");
            n.parse::<u32>().is_ok()
                && (w[1].starts_with("test")
                    || (["Rust", "Python", "browser", "Rust,", "Python,"].contains(&w[1])
                        && w[2].starts_with("test")))
        })
        .map(|w| w.join(" "))
        .collect();
    assert!(
        counts.is_empty(),
        "README.md types test counts (they go stale): {counts:?}"
    );
}
