#![allow(clippy::unwrap_used)]
//! The adjoint gradient dJ/dp of J(x*(p)) against central finite differences of J(x*(p)) (each
//! a converged static solve), for every parametrisation × bending form × material, on a
//! cantilever sheet clamped along one edge with a pinned corner coordinate, gravity and an end
//! tension.
//! Tolerance: relative error ≤ 1e-6 on the three largest gradient entries (fourth-order central
//! difference with step 1e-5 in p; measured worst 4.5e-9; the error shrinks as δ² from δ = 1e-3,
//! i.e. the finite difference's own error: the forward solves are polished to the Newton step
//! tolerance).

use nalgebra::Vector3;
use thinshell_design::*;
use thinshell_energy::{Layer, Material, MaterialModel, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{VertexId, generators};
use thinshell_system::{Boundary, Loads, ShellSystem};

fn materials() -> Vec<Material> {
    let m = Material {
        thickness: 0.05,
        young: 1e4,
        poisson: 0.3,
        density: 100.0,
        viscosity: 0.0,
        model: MaterialModel::StVK,
    };
    let layer = |e: f64, eps: f64| Layer {
        thickness: 0.025,
        young: e,
        poisson: 0.3,
        eigenstrain: eps,
    };
    vec![
        m,
        m.with_model(MaterialModel::NeoHookean),
        Material::bilayer(layer(1.2e4, 0.0), layer(0.8e4, 0.01), 100.0, 0.0),
    ]
}

/// The problem: 1 × 0.5 m sheet (4 × 2 cells), clamped along x = 0, the far corner held in y,
/// gravity −z; target: the flat sheet rolled up a little and lifted.
fn design(material: Material, sff: SffKind, which: &str) -> (Design, Vec<f64>) {
    let mesh = generators::rectangle(1.0, 0.5, 4, 2).unwrap();
    let x0 = mesh.positions().to_vec();
    let rest = RestState::from_mesh(&mesh, &x0, sff).unwrap();
    let clamped: Vec<_> = mesh
        .topology()
        .boundary_edges()
        .iter()
        .copied()
        .filter(|&e| {
            let [a, b] = mesh.topology().edge(e).vertices;
            x0[a.idx()].x.abs() < 1e-9 && x0[b.idx()].x.abs() < 1e-9
        })
        .collect();
    let corner = (0..x0.len())
        .max_by(|&i, &j| (x0[i].x + x0[i].y).total_cmp(&(x0[j].x + x0[j].y)))
        .unwrap();
    let boundary = Boundary {
        clamped_edges: clamped,
        pinned_coordinates: vec![(VertexId::new(corner), 1)],
        ..Default::default()
    };
    // Tension on the free end (strain ~1e-3) keeps the growing sheet away from buckling,
    // where x*(p) would not be smooth.
    let far: Vec<_> = (0..x0.len())
        .filter(|&i| (x0[i].x - 1.0).abs() < 1e-9)
        .collect();
    let loads = Loads {
        gravity: Vector3::new(0.0, 0.0, -0.05),
        point_forces: far
            .iter()
            .map(|&i| {
                (
                    VertexId::new(i),
                    Vector3::new(0.25 / far.len() as f64, 0.0, 0.0),
                )
            })
            .collect(),
        ..Default::default()
    };
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff,
    };
    let target: Vec<Vector3<f64>> = x0
        .iter()
        .map(|p| Vector3::new(p.x, p.y, 0.15 * p.x * p.x + 0.05 * p.x * p.y))
        .collect();
    let system = ShellSystem::new(mesh.clone(), model, rest.clone(), boundary, loads).unwrap();
    let forward = Forward::new(system, x0).unwrap();
    // A well-conditioned point: a smooth, moderate growth pattern.
    let (param, p): (Box<dyn Parametrisation>, Vec<f64>) = match which {
        "isotropic" => {
            let param = Isotropic::new(&mesh, &rest, Support::Vertex);
            let p = mesh
                .positions()
                .iter()
                .map(|q| 2e-3 * q.x - 1e-3 * q.y)
                .collect();
            (Box::new(param), p)
        }
        "rest_forms" => {
            let param = RestForms::new(&rest);
            let mut p = param.initial();
            for (i, v) in p.iter_mut().enumerate() {
                *v += 1e-3 * ((i * 7 % 5) as f64 - 2.0) / 2.0;
            }
            (Box::new(param), p)
        }
        _ => {
            let param = BilayerGrowth::new(&rest, &material);
            let mut p = param.initial();
            for (i, v) in p.iter_mut().enumerate() {
                *v += 1e-3 * ((i * 5 % 7) as f64 - 3.0) / 3.0;
            }
            (Box::new(param), p)
        }
    };
    let objective = TargetPositions {
        target,
        rigid: false,
    };
    (Design::new(forward, param, Box::new(objective)), p)
}

#[test]
fn adjoint_gradient_matches_central_differences() {
    let delta = 1e-5;
    let mut worst = (0.0f64, String::new());
    for material in materials() {
        for sff in SffKind::ALL {
            for which in ["isotropic", "rest_forms", "bilayer"] {
                let (mut d, p) = design(material, sff, which);
                let eval = d.evaluate(&p).unwrap();
                // The three largest gradient entries.
                let mut order: Vec<usize> = (0..p.len()).collect();
                order.sort_by(|&i, &j| eval.gradient[j].abs().total_cmp(&eval.gradient[i].abs()));
                let gmax = eval.gradient[order[0]].abs();
                assert!(gmax > 0.0);
                for &k in &order[..3] {
                    let mut q = p.clone();
                    let mut j = |v: f64| {
                        q[k] = v;
                        d.value(&q).unwrap().0
                    };
                    let (jp, jm) = (j(p[k] + delta), j(p[k] - delta));
                    let (jp2, jm2) = (j(p[k] + 2.0 * delta), j(p[k] - 2.0 * delta));
                    // Fourth-order central difference.
                    let fd = (8.0 * (jp - jm) - (jp2 - jm2)) / (12.0 * delta);
                    let err = (fd - eval.gradient[k]).abs() / gmax;
                    let case = format!(
                        "{} {} {which}: dJ/dp[{k}] adjoint {:e} fd {fd:e}",
                        material.model.name(),
                        sff.name(),
                        eval.gradient[k]
                    );
                    assert!(err <= 1e-6, "{case}: rel err {err:e}");
                    if err > worst.0 {
                        worst = (err, case);
                    }
                }
            }
        }
    }
    eprintln!("worst relative error {:e} ({})", worst.0, worst.1);
}
