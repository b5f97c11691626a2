//! What an explicit Euler step costs with the default (edge-director) form, whose massless edge
//! angles are relaxed at every step (`ShellSystem::relax_edge_angles`), against the mid-edge
//! average, whose step is one gradient evaluation.
//!
//! Case: a simply supported plate (`generators::rectangle(1, 1, 64, 64)`, 8 192 faces, all
//! boundary vertices pinned) vibrating from an initial velocity bump, Δt = 2e-5 s (below the
//! stability limit of every form), one step per iteration with the state carried on as in a
//! running simulation.
//!
//! Run: `cargo bench -p thinshell-solver --bench explicit_step`
//! Besides criterion's medians it prints, per director form, the angle relaxation's gradient
//! evaluations and factorisations per step.
#![allow(clippy::unwrap_used, missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use thinshell_energy::{DirectorVariant, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{VertexId, generators};
use thinshell_solver::{ExplicitEuler, Integrator, State};
use thinshell_system::{Boundary, Loads, ShellSystem};

const DT: f64 = 2e-5;

fn setup(sff: SffKind) -> (ShellSystem, State) {
    let mesh = generators::rectangle(1.0, 1.0, 64, 64).unwrap();
    let x = mesh.positions().to_vec();
    let rest = RestState::from_mesh(&mesh, &x, sff).unwrap();
    let model = ShellModel {
        material: Material {
            thickness: 1e-2,
            young: 1e7,
            poisson: 0.3,
            density: 1000.0,
            viscosity: 0.0,
            model: thinshell_energy::MaterialModel::StVK,
        },
        terms: Terms::ELASTIC,
        sff,
    };
    let boundary = Boundary {
        pinned_vertices: mesh.topology().boundary_vertices().to_vec(),
        ..Default::default()
    };
    let sys = ShellSystem::new(mesh, model, rest, boundary, Loads::default()).unwrap();
    let mut state = State::at_rest(x.clone());
    for (i, v) in state.v.iter_mut().enumerate() {
        if sys.dofs().dof(VertexId::new(i), 2).is_some() {
            let p = x[i];
            v.z = 0.1 * (std::f64::consts::PI * p.x).sin() * (std::f64::consts::PI * p.y).sin();
        }
    }
    (sys, state)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("explicit_step");
    group.sample_size(20);
    for sff in [
        SffKind::MidEdgeAverage,
        SffKind::EdgeDirector(DirectorVariant::Sin),
        SffKind::EdgeDirector(DirectorVariant::Tan),
    ] {
        let (mut sys, mut state) = setup(sff);
        let mut ex = ExplicitEuler { dt: DT };
        // Warm up: the first step builds the angle sub-problem and factorises it.
        for _ in 0..20 {
            ex.step(&mut sys, &mut state).unwrap();
        }
        let before = sys.angle_relaxation_totals();
        let mut steps = 0usize;
        group.bench_function(format!("{}/{}", sff.name(), sys.mesh().n_faces()), |b| {
            b.iter(|| {
                ex.step(&mut sys, &mut state).unwrap();
                steps += 1;
            })
        });
        let after = sys.angle_relaxation_totals();
        if sys.has_edge_unknowns() && steps > 0 {
            eprintln!(
                "{:>18}: {steps} steps, per step {:.2} gradient evaluations, {:.4} \
                 factorisations, {:.2} line-search evaluations",
                sff.name(),
                (after.gradient_evaluations - before.gradient_evaluations) as f64 / steps as f64,
                (after.factorizations - before.factorizations) as f64 / steps as f64,
                (after.value_evaluations - before.value_evaluations) as f64 / steps as f64,
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
