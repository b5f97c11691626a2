//! Whole-mesh evaluation loop for instruction counting (callgrind) of the assembly paths.
//!
//! `face_cost FORM WHAT REPS`: FORM = `mid_edge_average` | `edge_director_sin` |
//! `edge_director_tan`; WHAT = `e` (energy), `eg` (energy + gradient), `egh` (energy +
//! gradient + exact Hessian); REPS evaluations of the 20 480-face icosphere at the assembly
//! bench's deformed configuration (StVK, paper material, stretching + bending, one thread).
//! Instructions per face = (Ir(REPS = 3) − Ir(REPS = 1)) / (2 · 20 480), e.g.
//!
//! ```text
//! RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!     target/release/examples/face_cost mid_edge_average e 3
//! ```
#![allow(clippy::unwrap_used, missing_docs)]

use nalgebra::Vector3;
use std::hint::black_box;
use thinshell_energy::{
    Assembler, DofMap, EvalOutput, HessianMode, Material, RestState, SffKind, ShellModel, Terms,
};
use thinshell_mesh::generators;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let sff = SffKind::from_name(&args[1]).expect("form name");
    let what = args[2].as_str();
    let reps: usize = args[3].parse().expect("reps");
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let mesh = generators::icosphere(1.0, 5).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let x: Vec<Vector3<f64>> = mesh
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x, p.y * 0.9, p.z * (1.0 + 0.05 * (7.0 * p.x).sin())))
        .collect();
    let director = sff.director().is_some();
    let phi: Vec<f64> = if director {
        (0..mesh.n_edges())
            .map(|e| 0.01 * (e as f64).sin())
            .collect()
    } else {
        Vec::new()
    };
    let dofs = if director {
        DofMap::all_free(mesh.n_vertices())
            .with_edges(mesh.n_edges(), [])
            .unwrap()
    } else {
        DofMap::all_free(mesh.n_vertices())
    };
    let mut asm = Assembler::for_model(&mesh, &dofs, &model).unwrap();
    let mut g = vec![0.0; asm.n_coordinates()];
    let mut h = asm.hessian_template();
    let mut total = 0.0;
    for _ in 0..reps {
        let out = EvalOutput {
            gradient: (what != "e").then_some(&mut g[..]),
            hessian: (what == "egh").then_some((&mut h, HessianMode::Exact)),
        };
        total += asm
            .evaluate_with_angles(&model, black_box(&x), &phi, &rest, None, out)
            .unwrap()
            .total();
    }
    println!("{total:.17e} {:.17e}", g.iter().sum::<f64>());
}
