#![allow(clippy::unwrap_used)]
//! The fast paths against the full kernel: the energy-only kernel
//! [`eval_face_energy`] and the reverse-mode gradient path of [`eval_face`] against the energy
//! and gradient that the exact-Hessian path computes, on random faces, for every second
//! fundamental form × material law × damping on/off. Tolerance 1e-12 relative (round-off of
//! differently ordered sums). The assembler's energy-only and gradient
//! evaluations are checked against its Hessian evaluation on an icosphere the same way.

use nalgebra::{Matrix2, Vector3};
use proptest::prelude::*;
use thinshell_energy::sff::SecondFundamentalForm;
use thinshell_energy::*;
use thinshell_mesh::generators;
use thinshell_testkit::fixtures::unit_material;
use thinshell_testkit::strategies::{cases_or, rest_strategy, stencil_strategy};

const TOL: f64 = 1e-12;

/// StVK, neo-Hookean, a bilayer with eigenstrains and the tension field, all unit-ish so every
/// term counts.
fn materials() -> [Material; 4] {
    let base = unit_material(0.5);
    let layer = |thickness, young, eigenstrain| Layer {
        thickness,
        young,
        poisson: 0.3,
        eigenstrain,
    };
    [
        base,
        base.with_model(MaterialModel::NeoHookean),
        Material::bilayer(layer(0.12, 3.0, -0.02), layer(0.18, 1.0, 0.03), 1.0, 0.5),
        base.with_model(MaterialModel::TensionField),
    ]
}

/// Energy from the energy-only kernel, from `eval_face` energy-only, with the gradient only,
/// and with the exact Hessian: (energies, gradient of the gradient path, of the Hessian path).
fn paths<const N: usize, F>(
    form: &F,
    material: &Material,
    s: &FaceStencil,
    r: &FaceRest,
    d: Option<&FaceDamping>,
    terms: Terms,
) -> ([EnergyTerms; 4], Vec<f64>, Vec<f64>)
where
    F: SecondFundamentalForm<N>,
    nalgebra::SMatrix<f64, N, N>: ProjectPsd,
{
    let fast = eval_face_energy(
        form,
        material,
        &EnergyConstants::new(material),
        s,
        r,
        d,
        terms,
    );
    let run = |gradient, hessian| {
        let mut out = FaceEval::<N>::default();
        eval_face(
            form,
            material,
            s,
            r,
            d,
            terms,
            Want { gradient, hessian },
            &mut out,
        );
        out
    };
    let e = run(false, None);
    let g = run(true, None);
    let h = run(true, Some(HessianMode::Exact));
    (
        [fast, e.energy, g.energy, h.energy],
        g.gradient.iter().copied().collect(),
        h.gradient.iter().copied().collect(),
    )
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= TOL * scale.max(1e-300)
}

/// Checks all paths of one face for one form; returns a message on failure.
fn check<const N: usize, F>(
    form: &F,
    s: &FaceStencil,
    r: &FaceRest,
    d: &FaceDamping,
) -> Result<(), String>
where
    F: SecondFundamentalForm<N>,
    nalgebra::SMatrix<f64, N, N>: ProjectPsd,
{
    for material in materials() {
        for terms in [Terms::ELASTIC, Terms::ALL] {
            let (e, g, gh) = paths(form, &material, s, r, Some(d), terms);
            let full = e[3];
            let scale = full.stretch.abs() + full.bend.abs() + full.damping.abs();
            for (name, x) in ["eval_face_energy", "energy only", "gradient path"]
                .iter()
                .zip(&e)
            {
                let ok = close(x.stretch, full.stretch, scale)
                    && close(x.bend, full.bend, scale)
                    && close(x.damping, full.damping, scale);
                if !ok {
                    return Err(format!(
                        "{} {terms:?} {name}: {x:?} vs {full:?}",
                        material.model.name()
                    ));
                }
            }
            let gs = gh.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let gerr = g
                .iter()
                .zip(&gh)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            if gerr > TOL * gs.max(1e-300) {
                return Err(format!(
                    "{} {terms:?} gradient: {gerr} of {gs}",
                    material.model.name()
                ));
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(64)))]

    #[test]
    fn fast_paths_match_full_kernel(
        s in stencil_strategy(),
        r in rest_strategy(),
        phi in prop::array::uniform3(-0.4f64..0.4),
        dt in 0.05f64..1.0,
    ) {
        let s = FaceStencil {
            angles: EdgeAngles { phi, sigma: [1.0, -1.0, 1.0] },
            ..s
        };
        // Previous-step forms: a bit off the current ones, so every damping term is nonzero.
        let e1 = s.x[1] - s.x[0];
        let e2 = s.x[2] - s.x[0];
        let a = Matrix2::new(e1.dot(&e1), e1.dot(&e2), e1.dot(&e2), e2.dot(&e2));
        let d = FaceDamping {
            a_prev: a * 0.97,
            b_prev: Matrix2::new(0.05, -0.02, -0.02, 0.1),
            dt,
        };
        check::<18, _>(&MidEdgeAverage, &s, &r, &d).map_err(TestCaseError::fail)?;
        for variant in [DirectorVariant::Sin, DirectorVariant::Tan] {
            check::<21, _>(&EdgeDirector { variant }, &s, &r, &d).map_err(TestCaseError::fail)?;
        }
    }
}

/// Whole mesh: the assembler's energy-only and energy+gradient evaluations give the energy
/// (and gradient) of its exact-Hessian evaluation, for every form, on a deformed icosphere
/// with damping on (1e-12 relative).
#[test]
fn assembler_paths_agree() {
    let mesh = generators::icosphere(1.0, 2).unwrap();
    let x: Vec<Vector3<f64>> = mesh
        .positions()
        .iter()
        .map(|p| {
            Vector3::new(
                p.x * 1.05,
                p.y * 0.9,
                p.z * (1.0 + 0.05 * (7.0 * p.x).sin()),
            )
        })
        .collect();
    for sff in SffKind::ALL {
        for material in materials() {
            let model = ShellModel {
                material,
                terms: Terms::ALL,
                sff,
            };
            let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
            let damping = DampingState::from_positions(&mesh, mesh.positions(), sff, 0.1).unwrap();
            let director = sff.director().is_some();
            let phi: Vec<f64> = if director {
                (0..mesh.n_edges())
                    .map(|e| 0.05 * (e as f64).sin())
                    .collect()
            } else {
                Vec::new()
            };
            let mut dofs = DofMap::all_free(mesh.n_vertices());
            if director {
                dofs = dofs.with_edges(mesh.n_edges(), []).unwrap();
            }
            let mut asm = Assembler::for_model(&mesh, &dofs, &model).unwrap();
            let n = asm.n_coordinates();
            let (mut g1, mut g2) = (vec![0.0; n], vec![0.0; n]);
            let mut h = asm.hessian_template();
            let mut eval = |out| {
                asm.evaluate_with_angles(&model, &x, &phi, &rest, Some(&damping), out)
                    .unwrap()
                    .total()
            };
            let e0 = eval(EvalOutput::default());
            let e1 = eval(EvalOutput {
                gradient: Some(&mut g1),
                hessian: None,
            });
            let e2 = eval(EvalOutput {
                gradient: Some(&mut g2),
                hessian: Some((&mut h, HessianMode::Exact)),
            });
            let what = format!("{} {}", sff.name(), material.model.name());
            assert!((e0 - e2).abs() <= TOL * e2.abs(), "{what}: {e0} vs {e2}");
            assert!((e1 - e2).abs() <= TOL * e2.abs(), "{what}: {e1} vs {e2}");
            let gs = g2.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let gerr = g1
                .iter()
                .zip(&g2)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(gerr <= TOL * gs, "{what}: gradient {gerr} of {gs}");
        }
    }
}
