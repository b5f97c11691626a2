//! `ShellSystem::set_load_factor`: gravity, point forces and pressure scale with λ, the mass
//! update keeps λ, a bad λ is refused without changing anything, and in the linear regime the
//! static response scales with λ.
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use thinshell_energy::{RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{VertexId, generators};
use thinshell_solver::{SolverError, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};
use thinshell_testkit::fixtures::BEAM_MATERIAL;

fn system(loads: Loads, boundary: Boundary) -> ShellSystem {
    let mesh = generators::rectangle(1.0, 0.25, 8, 2).unwrap();
    let sff = SffKind::MidEdgeAverage;
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let model = ShellModel {
        material: BEAM_MATERIAL,
        terms: Terms::ELASTIC,
        sff,
    };
    ShellSystem::new(mesh, model, rest, boundary, loads).unwrap()
}

#[test]
fn forces_and_pressure_scale_with_the_load_factor() {
    let loads = Loads {
        gravity: Vector3::new(0.0, 0.0, -9.81),
        point_forces: vec![(VertexId::new(5), Vector3::new(0.1, -0.2, 0.3))],
        pressure: 40.0,
        pressure_axis: None,
    };
    let mut sys = system(loads, Boundary::default());
    let full = sys.external_forces().to_vec();
    assert_eq!(sys.load_factor(), 1.0);
    sys.set_load_factor(0.25).unwrap();
    for (a, b) in sys.external_forces().iter().zip(&full) {
        assert_eq!(*a, 0.25 * b);
    }
    assert_eq!(sys.pressure(), 10.0);
    assert_eq!(sys.loads().pressure, 40.0);
    // New masses (a stimulus adding mass): gravity is recomputed at the same λ.
    let mass: Vec<f64> = sys.mass().iter().map(|m| 2.0 * m).collect();
    sys.set_mass(mass.clone()).unwrap();
    for (v, m) in mass.iter().enumerate() {
        let point = if v == 5 { 0.3 } else { 0.0 };
        let want = 0.25 * (m * -9.81 + point);
        assert!((sys.external_forces()[3 * v + 2] - want).abs() <= 1e-15 * want.abs());
    }
    // A non-finite λ is refused and changes nothing.
    let before = sys.external_forces().to_vec();
    let e = sys.set_load_factor(f64::NAN).unwrap_err();
    assert!(matches!(
        e,
        SolverError::InvalidSetting {
            name: "load_factor",
            ..
        }
    ));
    assert_eq!(sys.load_factor(), 0.25);
    assert_eq!(sys.external_forces(), &before[..]);
}

/// A clamped strip under a small end load (linear regime, w/L ≈ 10⁻⁵): the deflection at
/// λ = 0.5 is half of that at λ = 1 (to 10⁻⁴ relative: the geometric nonlinearity is of order
/// (w/L)²).
#[test]
fn static_response_is_linear_in_the_load_factor_for_small_loads() {
    let probe = system(Loads::default(), Boundary::default());
    let topo = probe.mesh().topology();
    let p = probe.mesh().positions();
    let clamped = topo
        .boundary_edges()
        .iter()
        .copied()
        .filter(|&e| {
            let [a, b] = topo.edge(e).vertices;
            p[a.idx()].x == 0.0 && p[b.idx()].x == 0.0
        })
        .collect();
    let tip: Vec<VertexId> = (0..p.len())
        .filter(|&v| p[v].x == 1.0)
        .map(VertexId::new)
        .collect();
    let loads = Loads {
        point_forces: tip
            .iter()
            .map(|&v| (v, Vector3::new(0.0, 0.0, -1e-6)))
            .collect(),
        ..Loads::default()
    };
    let boundary = Boundary {
        clamped_edges: clamped,
        ..Boundary::default()
    };
    let mut sys = system(loads, boundary);
    let mut deflection = |lambda: f64| {
        sys.set_load_factor(lambda).unwrap();
        let mut st = Static {
            force_scale: Some(3e-6),
            ..Static::default()
        };
        let mut x = sys.mesh().positions().to_vec();
        st.solve(&mut sys, &mut x).unwrap();
        -tip.iter().map(|v| x[v.idx()].z).sum::<f64>() / tip.len() as f64
    };
    let w1 = deflection(1.0);
    let w_half = deflection(0.5);
    println!("w(λ=1) = {w1:e} m, w(λ=0.5) = {w_half:e} m");
    assert!(w1 > 0.0);
    assert!((w_half / w1 - 0.5).abs() < 1e-4 * 0.5, "{w_half} vs {w1}");
}
