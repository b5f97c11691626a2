//! Scene files and the library share one generator table: every generator of
//! `thinshell_mesh::generators::Generator` is accepted by name, builds the same mesh as the
//! library with the same defaults, and rejects the keys of other generators.
#![allow(clippy::unwrap_used)]

use std::path::Path;

use thinshell::scene::Scene;
use thinshell::sim::Simulation;
use thinshell_mesh::generators::{Generator, Value};

fn scene(mesh_keys: &str) -> String {
    format!(
        "effects = [\"stretching\", \"bending\"]\n[mesh]\n{mesh_keys}\n[integrator]\nkind = \"static\"\n"
    )
}

#[test]
fn every_generator_builds_from_a_scene_as_from_the_library() {
    for g in Generator::ALL {
        let text = scene(&format!("generator = \"{}\"", g.name()));
        let scene = Scene::from_toml(&text, "g.toml", Path::new(".")).unwrap();
        let sim = Simulation::build(&scene).unwrap();
        let lib = g.build(|_| None).unwrap();
        assert_eq!(sim.mesh().faces(), lib.faces(), "{}", g.name());
        assert_eq!(sim.mesh().positions(), lib.positions(), "{}", g.name());
    }
}

#[test]
fn given_keys_reach_the_generator() {
    let text = scene("generator = \"icosphere_recursive\"\nradius = 0.5\nlevel = 3");
    let scene = Scene::from_toml(&text, "g.toml", Path::new(".")).unwrap();
    let sim = Simulation::build(&scene).unwrap();
    let lib = Generator::IcosphereRecursive
        .build(|k| match k {
            "radius" => Some(Value::Real(0.5)),
            "level" => Some(Value::Int(3)),
            _ => None,
        })
        .unwrap();
    assert_eq!(sim.mesh().n_faces(), 1280);
    assert_eq!(sim.mesh().positions(), lib.positions());
}

#[test]
fn keys_of_other_generators_do_not_apply() {
    let text = scene("generator = \"icosphere_recursive\"\nnx = 4");
    let e = Scene::from_toml(&text, "g.toml", Path::new(".")).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("`mesh.nx` does not apply to generator `icosphere_recursive`"),
        "{msg}"
    );
    let text = scene("generator = \"sphere\"");
    let msg = Scene::from_toml(&text, "g.toml", Path::new("."))
        .unwrap_err()
        .to_string();
    let known: Vec<&str> = Generator::ALL.iter().map(|g| g.name()).collect();
    assert!(
        msg.contains(&format!("known: {}", known.join(", "))),
        "{msg}"
    );
}
