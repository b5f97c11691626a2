//! The integrators' cached Newton workspace follows the settings: changing the ordering or the
//! parallelism after a first step takes effect at the next step (a workspace cached by the
//! number of unknowns only would silently ignore such changes).
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::generators;
use thinshell_solver::{ImplicitEuler, Integrator, Ordering, State, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};

fn sagging_sheet() -> (ShellSystem, Vec<Vector3<f64>>) {
    let mesh = generators::rectangle(1.0, 1.0, 8, 8).unwrap();
    let sff = SffKind::MidEdgeAverage;
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let boundary = Boundary {
        pinned_vertices: mesh.topology().boundary_vertices().to_vec(),
        ..Default::default()
    };
    let loads = Loads {
        gravity: Vector3::new(0.0, 0.0, -9.81),
        ..Default::default()
    };
    let x0 = mesh.positions().to_vec();
    let sys = ShellSystem::new(mesh, model, rest, boundary, loads).unwrap();
    (sys, x0)
}

#[test]
fn static_workspace_follows_ordering_and_parallelism() {
    let (mut sys, x0) = sagging_sheet();
    let mut st = Static::default();
    assert!(st.workspace().is_none());
    st.newton.ordering = Ordering::Amd;
    st.newton.parallel = false;
    let mut state = State::at_rest(x0);
    st.step(&mut sys, &mut state).unwrap();
    let ws = st.workspace().unwrap();
    assert_eq!(ws.ordering(), Ordering::Amd);
    assert_eq!(ws.factor_stats().ordering, Ordering::Amd);
    assert!(!ws.parallel());

    st.newton.ordering = Ordering::NestedDissection;
    st.newton.parallel = true;
    st.step(&mut sys, &mut state).unwrap();
    let ws = st.workspace().unwrap();
    assert_eq!(ws.ordering(), Ordering::NestedDissection);
    assert_eq!(ws.factor_stats().ordering, Ordering::NestedDissection);
    assert!(ws.parallel());
}

#[test]
fn implicit_workspace_follows_ordering() {
    let (mut sys, x0) = sagging_sheet();
    let mut ie = ImplicitEuler::new(1e-3);
    ie.newton.ordering = Ordering::NestedDissection;
    let mut state = State::at_rest(x0);
    ie.step(&mut sys, &mut state).unwrap();
    assert_eq!(
        ie.workspace().unwrap().factor_stats().ordering,
        Ordering::NestedDissection
    );
    ie.newton.ordering = Ordering::Amd;
    ie.step(&mut sys, &mut state).unwrap();
    assert_eq!(
        ie.workspace().unwrap().factor_stats().ordering,
        Ordering::Amd
    );
}
