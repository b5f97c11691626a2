//! `thinshell info` end to end: statistics of good meshes, one clear error line and exit code 2
//! for bad ones.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::Command;

use thinshell_testkit::fixtures::{data_path as data, temp_dir};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_thinshell"))
}

fn tmp(name: &str, content: &str) -> PathBuf {
    let p = temp_dir("cli-info").join(name);
    std::fs::write(&p, content).unwrap();
    p
}

#[test]
fn info_reports_the_seed_meshes() {
    let out = bin()
        .arg("info")
        .arg(data("meshes/seed_square.obj"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("vertices 108  faces 184"), "{s}");
    assert!(s.contains("Euler characteristic 1"), "{s}");
    assert!(s.contains("problems: none"), "{s}");
    let out = bin()
        .arg("info")
        .arg(data("meshes/seed_sphere.obj"))
        .output()
        .unwrap();
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(
        s.contains("vertices 162  faces 320") && s.contains("(closed)"),
        "{s}"
    );
}

#[test]
fn info_reports_flipped_faces() {
    // Two triangles of a square, the second with the opposite orientation.
    let p = tmp(
        "flipped.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 4 3\n",
    );
    let out = bin().arg("info").arg(&p).output().unwrap();
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("1 face(s) had the opposite orientation"), "{s}");
}

#[test]
fn bad_meshes_give_one_line_and_exit_code_2() {
    let cases = [
        ("missing.obj", None),
        (
            "nonmanifold.obj",
            Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n"),
        ),
        ("range.obj", Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")),
        (
            "degenerate.obj",
            Some("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"),
        ),
        ("empty.obj", Some("# nothing\n")),
        ("nan.obj", Some("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")),
    ];
    for (name, content) in cases {
        let p = match content {
            Some(c) => tmp(name, c),
            None => PathBuf::from("/nonexistent/missing.obj"),
        };
        let out = bin().arg("info").arg(&p).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{name}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{name}: {err}");
        assert!(err.starts_with("thinshell: error: "), "{name}: {err}");
    }
}

/// `info` lists every problem of a broken mesh with its 1-based OBJ lines (not only the first),
/// and the statistics of the faces without problems.
#[test]
fn info_lists_every_problem_with_its_obj_lines() {
    let p = tmp(
        "several.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 1 1 0\nv 2 0 0\n\
         f 1 2 3\nf 2 1 4\nf 1 2 5\nf 2 6 3\nf 1 2 7\nf 3 2 6\n",
    );
    let out = bin().arg("info").arg(&p).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let s = String::from_utf8(out.stdout).unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    // Faces on lines 8–10 share edge 1–2, line 12 is degenerate, line 13 repeats line 11.
    for expect in [
        "statistics of the 1 of 6 faces without problems",
        "vertices 3  faces 1",
        "OBJ line 12: face 4 is degenerate",
        "OBJ lines 11, 13: face 5 duplicates face 3",
        "OBJ lines 8, 9, 10: edge (0, 1) is non-manifold: shared by 3 faces [0, 1, 2]",
    ] {
        assert!(s.contains(expect), "expected `{expect}` in\n{s}");
    }
    assert!(
        err.contains("OBJ line 12: face 4 is degenerate") && err.contains("2 more problems"),
        "{err}"
    );
}
