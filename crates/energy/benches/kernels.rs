//! Per-face kernel cost: `cargo bench -p thinshell-energy --bench kernels`.
#![allow(clippy::unwrap_used, missing_docs)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix2, Vector3};
use thinshell_energy::{
    DirectorVariant, EdgeAngles, EdgeClamp, EdgeDirector, EnergyConstants, FaceDamping, FaceEval,
    FaceRest, FaceStencil, HessianMode, Layer, Material, MaterialModel, MidEdgeAverage, Terms,
    Want, eval_face, eval_face_energy, first_fundamental_form,
};

/// An interior face of a gently curved sheet with its three flaps.
fn stencil() -> FaceStencil {
    let z = |x: f64, y: f64| 0.3 * x * x - 0.2 * x * y + 0.1 * y * y;
    let p = |x: f64, y: f64| Vector3::new(x, y, z(x, y));
    FaceStencil {
        x: [
            p(0.0, 0.0),
            p(0.1, 0.0),
            p(0.05, 0.09),
            p(0.11, 0.1),
            p(-0.05, 0.08),
            p(0.06, -0.09),
        ],
        flap: [true; 3],
        ghost: [false; 3],
        clamp: [None; 3],
        angles: EdgeAngles {
            phi: [0.05, -0.1, 0.02],
            sigma: [1.0, -1.0, 1.0],
        },
    }
}

fn bench(c: &mut Criterion) {
    let s = stencil();
    let a = first_fundamental_form(&[s.x[0], s.x[1], s.x[2]]);
    let rest = FaceRest {
        a_bar: a * 0.98,
        b_bar: Matrix2::new(0.1, 0.02, 0.02, -0.05),
    };
    let damping = FaceDamping {
        a_prev: a,
        b_prev: Matrix2::zeros(),
        dt: 1e-3,
    };
    let material = Material::paper();
    let sff = &MidEdgeAverage;
    let mut out = FaceEval::default();
    let mut g = c.benchmark_group("eval_face");
    g.sample_size(30);
    let cases: [(&str, Want, bool); 6] = [
        (
            "energy",
            Want {
                gradient: false,
                hessian: None,
            },
            false,
        ),
        (
            "energy+gradient",
            Want {
                gradient: true,
                hessian: None,
            },
            false,
        ),
        (
            "energy+gradient+hessian(exact)",
            Want {
                gradient: true,
                hessian: Some(HessianMode::Exact),
            },
            false,
        ),
        (
            "energy+gradient+hessian(gauss-newton)",
            Want {
                gradient: true,
                hessian: Some(HessianMode::GaussNewton),
            },
            false,
        ),
        (
            "energy+gradient+hessian(projected)",
            Want {
                gradient: true,
                hessian: Some(HessianMode::ProjectedPsd),
            },
            false,
        ),
        (
            "energy+gradient+hessian(exact)+damping",
            Want {
                gradient: true,
                hessian: Some(HessianMode::Exact),
            },
            true,
        ),
    ];
    for (name, want, damp) in cases {
        let terms = Terms {
            stretch: true,
            bend: true,
            damping: damp,
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                eval_face(
                    sff,
                    &material,
                    black_box(&s),
                    &rest,
                    damp.then_some(&damping),
                    terms,
                    want,
                    &mut out,
                );
                black_box(out.energy.total())
            })
        });
    }
    // The energy-only kernel of the assembler's energy path (issue #17).
    let constants = EnergyConstants::new(&material);
    g.bench_function("energy(eval_face_energy)", |b| {
        b.iter(|| {
            let e = eval_face_energy(
                sff,
                &material,
                &constants,
                black_box(&s),
                &rest,
                None,
                Terms::ELASTIC,
            );
            black_box(e.total())
        })
    });
    g.finish();

    // Bending alone, mid-edge average (18 dofs) vs edge directors (21 dofs), exact Hessian.
    let mut g = c.benchmark_group("bend_face");
    g.sample_size(30);
    let want = Want {
        gradient: true,
        hessian: Some(HessianMode::Exact),
    };
    let bend_only = Terms {
        stretch: false,
        bend: true,
        damping: false,
    };
    g.bench_function("mid-edge-average", |b| {
        b.iter(|| {
            eval_face(
                sff,
                &material,
                black_box(&s),
                &rest,
                None,
                bend_only,
                want,
                &mut out,
            );
            black_box(out.energy.bend)
        })
    });
    // Interior faces for both variants; then, default form, a face with one free edge (fitted
    // director, model.md §1.2) and one with a clamped edge (§1.3): their derivatives are the
    // boundary faces' whole cost.
    let mut dout = FaceEval::<21>::default();
    let (sin, tan) = (
        EdgeDirector {
            variant: DirectorVariant::Sin,
        },
        EdgeDirector::default(),
    );
    let mut free = s;
    free.flap[1] = false;
    free.ghost[1] = true;
    let mut clamped = s;
    clamped.flap[1] = false;
    clamped.clamp[1] = Some(EdgeClamp::Held(Vector3::new(-0.2, 0.1, 1.0).normalize()));
    let gradient_only = Want {
        gradient: true,
        hessian: None,
    };
    for (name, form, stencil, want) in [
        ("edge-director-sin", &sin, &s, want),
        ("edge-director-tan", &tan, &s, want),
        ("edge-director-tan/free-edge", &tan, &free, want),
        (
            "edge-director-tan/free-edge/gradient",
            &tan,
            &free,
            gradient_only,
        ),
        ("edge-director-tan/clamped-edge", &tan, &clamped, want),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                eval_face(
                    form,
                    &material,
                    black_box(stencil),
                    &rest,
                    None,
                    bend_only,
                    want,
                    &mut dout,
                );
                black_box(dout.energy.bend)
            })
        });
    }
    g.finish();

    // Stretching + bending with an exact Hessian for each material model and both forms.
    let mut g = c.benchmark_group("materials");
    g.sample_size(30);
    let layer = |thickness, eigenstrain| Layer {
        thickness,
        young: 2e9,
        poisson: 0.3,
        eigenstrain,
    };
    let models = [
        ("stvk", material),
        (
            "neo_hookean",
            material.with_model(MaterialModel::NeoHookean),
        ),
        (
            "bilayer",
            Material::bilayer(layer(4e-5, 0.0), layer(6e-5, 1e-3), 250.0, 0.0),
        ),
    ];
    let tan = EdgeDirector {
        variant: DirectorVariant::Tan,
    };
    for (name, m) in models {
        g.bench_function(format!("{name}/mid-edge-average"), |b| {
            b.iter(|| {
                eval_face(
                    sff,
                    &m,
                    black_box(&s),
                    &rest,
                    None,
                    Terms::ELASTIC,
                    want,
                    &mut out,
                );
                black_box(out.energy.total())
            })
        });
        g.bench_function(format!("{name}/edge-director-tan"), |b| {
            b.iter(|| {
                eval_face(
                    &tan,
                    &m,
                    black_box(&s),
                    &rest,
                    None,
                    Terms::ELASTIC,
                    want,
                    &mut dout,
                );
                black_box(dout.energy.total())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
