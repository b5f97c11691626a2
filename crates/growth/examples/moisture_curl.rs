//! A paper strip wetted on its top face curls while the moisture diffuses through it.
//!
//! Diffusion through the thickness (4 prism layers, fixed value 1 on the top face), linear
//! swelling (c = 0.002 per unit moisture), one static equilibrium per diffusion step. Prints the
//! surface moisture, the natural curvature of the rest forms and the strip's tip rotation.
//!
//! `cargo run --release -p thinshell-growth --example moisture_curl`

use nalgebra::Vector3;
use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::{
    Diffusion, DiffusionSettings, DiffusionSource, Growth, Region, SourceKind, Surface, Swelling,
};
use thinshell_mesh::generators;
use thinshell_solver::{Integrator, Origin, State, Static};
use thinshell_system::{Boundary, Loads, ShellProblem, ShellSystem};

/// A static solve for the current rest forms; when Newton fails (a large change of the natural
/// curvature in one step), the rest forms are moved there from `previous` in smaller fractions.
/// Returns the Newton iterations spent.
fn solve_with_continuation(
    solver: &mut Static,
    system: &mut ShellSystem,
    state: &mut State,
    previous: &RestState,
) -> Result<usize, Box<dyn std::error::Error>> {
    // The solver walks from the previous step's problem when the one-shot solve fails.
    let origin = Origin {
        problem: ShellProblem {
            rest: Some(previous.clone()),
            load_factor: system.load_factor(),
        },
        t: state.t,
    };
    let report = solver.step_from(system, state, Some(&origin))?;
    Ok(report.newton.map_or(0, |n| n.iterations))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (h, c, d) = (1e-4, 0.002, 1e-9); // thickness (m), swelling coefficient, diffusivity (m²/s)
    // Narrow (w²κ₀/h = 0.8 at the largest κ₀ = c/h): it curls along its length.
    let mesh = generators::rectangle(0.1, 0.002, 50, 2)?;
    let x0 = mesh.positions().to_vec();
    let sff = SffKind::MidEdgeAverage;
    let initial = RestState::from_mesh(&mesh, &x0, sff)?;

    let wet_top = DiffusionSource {
        surface: Surface::Top,
        faces: Region::All.faces(&mesh, &x0)?,
        kind: SourceKind::Value(1.0),
    };
    let settings = DiffusionSettings {
        diffusivity: d,
        thickness: h,
        layers: 4,
        initial: 0.0,
    };
    let moisture = Diffusion::new(&mesh, &initial, settings, &[wet_top])?;
    let mut growth = Growth::new(
        Box::new(Swelling::linear(c)),
        Box::new(moisture),
        initial.clone(),
        h,
    )?;

    // Clamp the edge x = 0.
    let topo = mesh.topology();
    let clamped_edges = topo
        .boundary_edges()
        .iter()
        .copied()
        .filter(|&e| topo.edge(e).vertices.iter().all(|v| x0[v.idx()].x < 1e-9))
        .collect();
    let boundary = Boundary {
        clamped_edges,
        ..Boundary::default()
    };
    let material = Material {
        thickness: h,
        ..Material::paper()
    };
    let terms = Terms::ELASTIC;
    let model = ShellModel {
        material,
        terms,
        sff,
    };
    let mut system = ShellSystem::new(mesh, model, initial, boundary, Loads::default())?;
    let mut solver = Static {
        // Residuals relative to 1e-2 N: the round-off floor of the gradient is ~1e-16·E·h·ℓ ≈ 1e-10 N.
        force_scale: Some(1e-2),
        ..Static::default()
    };
    solver.newton.max_iterations = 300;
    let mut state = State::at_rest(x0);

    let dt = 0.5; // s; through-thickness time h²/D = 10 s
    println!("  t (s)   m_top  m_bottom  natural κ (1/m)  tip angle (deg)  Newton");
    for step in 0..40 {
        let t = step as f64 * dt;
        let previous = system.rest().clone();
        let mut rest = system.rest().clone();
        growth.update_rest(&mut rest)?;
        system.set_rest(rest)?;
        let iterations = solve_with_continuation(&mut solver, &mut system, &mut state, &previous)?;
        if step % 4 == 0 {
            let m = growth.stimulus()[0];
            let (a, b) = (system.rest().a_bar[0], system.rest().b_bar[0]);
            let kappa = a
                .try_inverse()
                .map_or(f64::NAN, |ai| -(ai * b).trace() / 2.0);
            // Tangent at the free end along the strip's centre line (row 1 of 3).
            let (p, q) = (state.x[51 + 49], state.x[51 + 50]);
            let tangent: Vector3<f64> = (q - p).normalize();
            let angle = tangent.z.atan2(tangent.x).to_degrees();
            println!(
                "{t:7.1} {:7.3} {:9.3} {kappa:16.2} {angle:16.1} {iterations:6}",
                m.top, m.bottom
            );
        }
        growth.advance(t, dt)?;
    }
    Ok(())
}
