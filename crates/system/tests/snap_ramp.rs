//! A static load ramp through a limit point with the default form and
//! `Static::default()` lands on the far stable branch — the pull-out of an open-ended cylinder
//! (Sze, Liu & Lo 2004; `cargo xtask verify` traces it by arc length): at the full load the ramp's
//! equilibrium matches the arc-length path's point at the same load on the same mesh.
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use thinshell_energy::{Material, MaterialModel, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{VertexId, generators};
use thinshell_solver::{Integrator, PathSettings, State, Static};
use thinshell_system::{Boundary, Loads, ShellPath, ShellSystem};

type V3 = Vector3<f64>;

#[test]
fn pullout_load_ramp_passes_the_snap() {
    let (r, len, h, e, nu, pmax) = (4.953, 10.35, 0.094, 10.5e6, 0.3125, 40_000.0);
    let (around, along) = (32, 12);
    let mesh = generators::cylinder_patch(r, std::f64::consts::TAU, len, around, along).unwrap();
    let at = |p: V3| mesh.nearest_vertex(&p);
    let a = [
        at(V3::new(0.0, r, 0.5 * len)),
        at(V3::new(0.0, -r, 0.5 * len)),
    ];
    let sff = SffKind::default();
    let x0 = mesh.positions().to_vec();
    let rest = RestState::from_mesh(&mesh, &x0, sff).unwrap();
    let boundary = Boundary {
        pinned_coordinates: Boundary::rigid_motion_pins(&mesh, VertexId::new(0)).unwrap(),
        ..Boundary::default()
    };
    let loads = Loads {
        point_forces: vec![
            (a[0], V3::new(0.0, pmax, 0.0)),
            (a[1], V3::new(0.0, -pmax, 0.0)),
        ],
        ..Loads::default()
    };
    let material = Material {
        thickness: h,
        young: e,
        poisson: nu,
        density: 1000.0,
        viscosity: 0.0,
        model: MaterialModel::StVK,
    };
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff,
    };
    let mut sys = ShellSystem::new(mesh, model, rest, boundary, loads).unwrap();
    // Half the change of the distance between the pulled points (outward positive), m.
    let w_a = |x: &[V3]| 0.5 * ((x[a[0].idx()] - x[a[1].idx()]).norm() - 2.0 * r);

    // The static ramp: 20 equal load steps, each from the last equilibrium, default settings.
    let mut state = State::at_rest(x0.clone());
    let mut st = Static::default();
    let mut iterations = 0;
    let mut ramp = Vec::new();
    for k in 1..=20 {
        let lambda = k as f64 / 20.0;
        sys.set_load_factor(lambda).unwrap();
        let report = st.step(&mut sys, &mut state).unwrap();
        iterations += report.newton.as_ref().unwrap().iterations;
        assert_eq!(report.stable, Some(true), "load step {k}");
        ramp.push((lambda, w_a(&state.x)));
    }

    // Arc length from the unloaded state to λ = 0.85, past the limit point at λ ≈ 0.72 (on this
    // mesh the path fails to converge near a second one at λ ≈ 0.87, where the ramp snaps again).
    sys.set_load_factor(0.0).unwrap();
    let mut tracer = ShellPath::new(PathSettings {
        initial_load_increment: 0.025,
        ..PathSettings::default()
    });
    let (mut x, mut phi) = (x0.clone(), vec![0.0; sys.n_edge_angles()]);
    let mut path = vec![(0.0, 0.0)];
    let mut stopped = None;
    while path.last().unwrap().0 < 0.85 && path.len() < 400 {
        match tracer.step(&mut sys, &mut x, &mut phi) {
            Ok(p) => path.push((p.load_factor, w_a(&x))),
            Err(e) => {
                stopped = Some(e.to_string());
                break;
            }
        }
    }
    // The limit point: λ falls somewhere along the path (the snap of the free edges).
    let limit = path
        .windows(2)
        .position(|w| w[1].0 < w[0].0)
        .expect("the arc-length path was expected to pass a limit point");
    let lambda_limit = path[limit].0;
    // Compare at the ramp's highest level the path reached past the limit point: the path's
    // first point at that load after the limit (load control's view), interpolated.
    let reached = path.iter().fold(0.0f64, |m, p| m.max(p.0));
    let &(level, w) = ramp.iter().rev().find(|(l, _)| *l <= reached).unwrap();
    let i = limit + path[limit..].iter().position(|p| p.0 >= level).unwrap();
    let (p, q) = (path[i - 1], path[i]);
    let reference = p.1 + (level - p.0) / (q.0 - p.0) * (q.1 - p.1);
    println!(
        "pull-out {around}x{along}: arc length {} points, limit point at λ = {lambda_limit:.3}, \
         reached λ = {reached:.3} ({}); static ramp {iterations} iterations; at λ = {level}: \
         w_A ramp {w:.5} m, arc length {reference:.5} m ({:+.3} %); ramp {ramp:.4?}",
        path.len() - 1,
        stopped.as_deref().unwrap_or("completed"),
        100.0 * (w / reference - 1.0)
    );
    assert!(
        level > lambda_limit,
        "compared at {level}, limit at {lambda_limit}"
    );
    assert!((w / reference - 1.0).abs() < 0.01, "{w} vs {reference}");
}
