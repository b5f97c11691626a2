//! The strip built from Rust values (`Supports`, the builder) equals the strip of a scene file
//! with the same keys (`region = { box = … }`): the same equilibrium, bit for bit.
#![allow(clippy::unwrap_used)]

use thinshell::{Scene, Simulation};
use thinshell_rust_user::{CELLS, LENGTH, WIDTH, cantilever, sag};

#[test]
fn the_rust_strip_is_the_scene_strip() {
    let text = format!(
        r#"
        effects = ["stretching", "bending", "gravity"]
        [mesh]
        generator = "rectangle"
        width = {LENGTH:?}
        height = {WIDTH:?}
        nx = {}
        ny = {}
        [integrator]
        kind = "static"
        [gravity]
        acceleration = [0.0, 0.0, -9.81]
        [[boundary.pins]]
        region = {{ box = {{ min = [-1e-9, -1.0, -1.0], max = [1e-9, 1.0, 1.0] }} }}
        [[boundary.clamps]]
        region = {{ box = {{ min = [-1e-9, -1.0, -1.0], max = [1e-9, 1.0, 1.0] }} }}
        "#,
        CELLS.0, CELLS.1
    );
    let scene = Scene::from_toml(&text, "cantilever.toml", std::path::Path::new(".")).unwrap();
    let mut from_scene = Simulation::build(&scene).unwrap();
    from_scene
        .run(
            &mut thinshell::NoObserver,
            &std::sync::atomic::AtomicBool::new(false),
        )
        .unwrap();
    let from_rust = cantilever().unwrap();
    assert_eq!(from_rust.positions(), from_scene.positions());
    // It sags (downwards, by less than its length).
    let s = sag(&from_rust);
    assert!(s < 0.0 && s > -LENGTH, "{s}");
}
