//! The meshes shipped in `data/meshes/` equal what the generators produce (so they cannot rot).
//! Regenerate them with `cargo run -p thinshell-mesh --example write_seed_meshes`.
#![allow(clippy::unwrap_used)]

use thinshell_mesh::{Mesh, generators, io};
use thinshell_testkit::fixtures::data_path;

fn shipped(name: &str) -> Mesh {
    let path = data_path(&format!("meshes/{name}"));
    io::load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn assert_same(file: &Mesh, generated: &Mesh) {
    assert_eq!(
        file.positions(),
        generated.positions(),
        "positions differ (bitwise)"
    );
    assert_eq!(file.faces(), generated.faces());
    assert_eq!(file.build_report().n_flipped(), 0);
    assert_eq!(file.build_report().n_dropped_vertices, 0);
}

#[test]
fn seed_square_file_matches_generator() {
    let m = shipped("seed_square.obj");
    assert_eq!((m.n_vertices(), m.n_faces()), (108, 184));
    assert_same(&m, &generators::seed_square().unwrap());
}

#[test]
fn seed_sphere_file_matches_generator() {
    let m = shipped("seed_sphere.obj");
    assert_eq!((m.n_vertices(), m.n_faces()), (162, 320));
    assert_same(&m, &generators::icosphere(1.0, 2).unwrap());
}
