//! A cantilever strip sagging under its own weight, built from Rust values with nothing but
//! `thinshell` (issue #42): what a user's own crate looks like. `cargo run --release -p
//! thinshell-rust-user` prints the tip deflection; the test builds the same strip from a scene
//! file and gets the same positions.

use std::sync::atomic::AtomicBool;

use thinshell::prelude::*;

/// Length, width (m) and cells of the strip.
pub const LENGTH: f64 = 0.05;
/// Width of the strip, m.
pub const WIDTH: f64 = 0.01;
/// Cells along the length and across.
pub const CELLS: (usize, usize) = (10, 2);

/// The strip's end `x = 0`, as a scene's `region = { box = … }`.
pub fn clamped_end() -> Region {
    Region::Box {
        min: Vector3::new(-1e-9, -1.0, -1.0),
        max: Vector3::new(1e-9, 1.0, 1.0),
    }
}

/// Runs the strip (paper, the default bending form, one static solve under gravity) and returns
/// the simulation at its equilibrium.
pub fn cantilever() -> Result<Simulation, Box<dyn std::error::Error>> {
    let mesh = generators::rectangle(LENGTH, WIDTH, CELLS.0, CELLS.1)?;
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff: SffKind::default(),
    };
    let end = clamped_end();
    let boundary = Supports::new(&mesh).pin(&end, "xyz")?.clamp(&end)?.build();
    let loads = Loads {
        gravity: Vector3::new(0.0, 0.0, -9.81),
        ..Loads::default()
    };
    let mut sim = SimulationBuilder::new(mesh, model)
        .name("cantilever")
        .boundary(boundary)
        .loads(loads)
        .static_solve()
        .build()?;
    sim.run(&mut NoObserver, &AtomicBool::new(false))?;
    Ok(sim)
}

/// The lowest z of the strip (m): the tip's sag.
pub fn sag(sim: &Simulation) -> f64 {
    sim.positions()
        .iter()
        .map(|x| x.z)
        .fold(f64::INFINITY, f64::min)
}
