//! Growth models against closed-form rest forms (model.md §4).
#![allow(clippy::unwrap_used)]

use nalgebra::{Matrix2, Vector3};
use thinshell_energy::{
    Assembler, DofMap, EvalOutput, Material, RestState, SffKind, ShellModel, Terms,
};
use thinshell_growth::{
    Anisotropy, FaceStimulus, GrowthError, GrowthModel, Isotropic, NoGrowth, Swelling, apply_growth,
};
use thinshell_mesh::{Mesh, generators};
use thinshell_testkit::strategies::cases_or;

const H: f64 = 1e-3;

fn curved() -> (Mesh, RestState) {
    // A perturbed sphere: b⁰ ≠ 0 and every face different.
    let mesh = generators::icosphere(1.0, 2).unwrap();
    let x: Vec<_> = mesh
        .positions()
        .iter()
        .enumerate()
        .map(|(i, p)| p * (1.0 + 0.05 * ((i as f64) * 1.7).sin()))
        .collect();
    let rest = RestState::from_mesh(&mesh, &x, SffKind::MidEdgeAverage).unwrap();
    (mesh, rest)
}

fn flat_strip() -> (Mesh, RestState) {
    let mesh = generators::rectangle(0.1, 0.01, 20, 4).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    (mesh, rest)
}

fn all_models(mesh: &Mesh) -> Vec<Box<dyn GrowthModel>> {
    let mut aniso = Swelling::linear(0.3);
    aniso.anisotropy =
        Some(Anisotropy::along(mesh, mesh.positions(), Vector3::new(1.0, 0.2, 0.1), -0.1).unwrap());
    let mut aniso_bilayer = aniso.clone();
    aniso_bilayer.profile = thinshell_growth::Profile::PiecewiseConstant;
    vec![
        Box::new(NoGrowth),
        Box::new(Isotropic::SEED),
        Box::new(Isotropic {
            p: 1.0,
            coefficient: 0.7,
        }),
        Box::new(Isotropic {
            p: 2.0,
            coefficient: -2.0,
        }),
        Box::new(Swelling::linear(0.3)),
        Box::new(Swelling::bilayer(-0.2)),
        Box::new(aniso),
        Box::new(aniso_bilayer),
    ]
}

#[test]
fn zero_stimulus_gives_back_initial_forms_exactly() {
    let (mesh, initial) = curved();
    let zero = vec![FaceStimulus::default(); mesh.n_faces()];
    for model in all_models(&mesh) {
        let mut out = RestState {
            a_bar: vec![],
            b_bar: vec![],
            sff: None,
        };
        apply_growth(model.as_ref(), &initial, &zero, H, &mut out).unwrap();
        assert_eq!(out, initial, "{}", model.name());
    }
    // The same models do change the forms under a non-zero stimulus (the test can fail).
    let some = vec![
        FaceStimulus {
            top: 0.1,
            bottom: -0.05
        };
        mesh.n_faces()
    ];
    for model in all_models(&mesh).into_iter().skip(1) {
        let mut out = initial.clone();
        apply_growth(model.as_ref(), &initial, &some, H, &mut out).unwrap();
        assert_ne!(out, initial, "{}", model.name());
    }
}

/// ā⁻¹b̄ of every face; asserts it is κ·I (isotropic natural curvature) and returns κ (1/m).
fn natural_curvature(rest: &RestState) -> f64 {
    let mut kappa: Option<f64> = None;
    for (a, b) in rest.a_bar.iter().zip(&rest.b_bar) {
        let s = a.try_inverse().unwrap() * b;
        let k = 0.5 * (s[(0, 0)] + s[(1, 1)]);
        let scale = k.abs().max(1.0);
        assert!((s - Matrix2::identity() * k).norm() < 1e-9 * scale, "{s}");
        if let Some(k0) = kappa {
            assert!(((k - k0) / scale).abs() < 1e-9, "{k} vs {k0}");
        }
        kappa = Some(k);
    }
    kappa.unwrap()
}

#[test]
fn flat_strip_natural_curvature() {
    let (mesh, initial) = flat_strip();
    let (c, dm) = (0.01, 1.0);
    let m = vec![
        FaceStimulus {
            top: dm,
            bottom: 0.0
        };
        mesh.n_faces()
    ];
    let mut rest = initial.clone();

    apply_growth(&Swelling::linear(c), &initial, &m, H, &mut rest).unwrap();
    let k_lin = natural_curvature(&rest);
    let (lp, lm) = ((1.0 + c * dm).powi(2), 1.0f64);
    let exact = (lm - lp) / (H * (lp + lm));
    assert!((k_lin / exact - 1.0).abs() < 1e-12, "{k_lin} vs {exact}");
    // Small-strain value −c·Δm/h (the swollen top is convex: b = −a/r, model.md §1); the
    // relative difference is O(c·Δm) = 1 %.
    let approx = -c * dm / H;
    assert!((k_lin / approx - 1.0).abs() < c * dm, "{k_lin} vs {approx}");

    apply_growth(&Swelling::bilayer(c), &initial, &m, H, &mut rest).unwrap();
    let k_bi = natural_curvature(&rest);
    assert!((k_bi / (1.5 * exact) - 1.0).abs() < 1e-12, "{k_bi}");
    assert!((k_bi / (1.5 * approx) - 1.0).abs() < c * dm);

    // The mean metric is the mean of the two surface metrics.
    let a0 = initial.a_bar[3];
    assert!((rest.a_bar[3] - a0 * (0.5 * (lp + lm))).norm() < 1e-15 * a0.norm());
}

#[test]
fn uniform_stimulus_is_pure_isotropic_growth() {
    let (mesh, initial) = flat_strip();
    let m = vec![FaceStimulus::uniform(0.5); mesh.n_faces()];
    for model in [Swelling::linear(0.1), Swelling::bilayer(0.1)] {
        let mut rest = initial.clone();
        apply_growth(&model, &initial, &m, H, &mut rest).unwrap();
        for (f, (a, b)) in rest.a_bar.iter().zip(&rest.b_bar).enumerate() {
            assert!((a - initial.a_bar[f] * 1.05f64.powi(2)).norm() < 1e-15 * a.norm());
            assert_eq!(*b, Matrix2::zeros(), "face {f}");
        }
    }
}

#[test]
fn anisotropic_swelling_stretches_along_the_material_direction() {
    // Flat square, direction x: uniform m = 1 with c_md = 0.1, c_cd = −0.05 is the planar rest
    // metric diag(1.1², 0.95²) in xy, i.e. ā = Tᵀ diag(..) T per face (T the xy edge matrix).
    let mesh = generators::irregular_rectangle(1.0, 1.0, 6, 3).unwrap();
    let x = mesh.positions();
    let initial = RestState::from_mesh(&mesh, x, SffKind::MidEdgeAverage).unwrap();
    let model = Swelling {
        anisotropy: Some(Anisotropy::along(&mesh, x, Vector3::new(2.0, 0.0, 0.0), -0.05).unwrap()),
        ..Swelling::linear(0.1)
    };
    let m = vec![FaceStimulus::uniform(1.0); mesh.n_faces()];
    let mut rest = initial.clone();
    apply_growth(&model, &initial, &m, H, &mut rest).unwrap();
    let want = RestState::from_planar(
        &mesh,
        Matrix2::new(1.1f64.powi(2), 0.0, 0.0, 0.95f64.powi(2)),
        Matrix2::zeros(),
    )
    .unwrap();
    for (f, (a, w)) in rest.a_bar.iter().zip(&want.a_bar).enumerate() {
        assert!((a - w).norm() < 1e-12 * w.norm(), "face {f}: {a} vs {w}");
        assert!(rest.b_bar[f].norm() < 1e-12);
    }
    // A direction normal to the sheet has no in-plane component.
    assert!(matches!(
        Anisotropy::along(&mesh, x, Vector3::z(), 0.0),
        Err(GrowthError::CollapsedRest { .. })
    ));
}

#[test]
fn similarity_growth_of_a_sphere_costs_no_energy() {
    // p = 1, uniform s: the sphere scaled by e^s has a = e^{2s} a⁰ and b = e^s b⁰ exactly.
    let mesh = generators::icosphere(1.0, 2).unwrap();
    let sff = SffKind::MidEdgeAverage;
    let initial = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let s = 0.1;
    let m = vec![FaceStimulus::uniform(s); mesh.n_faces()];
    let material = Material {
        thickness: H,
        ..Material::paper()
    };
    let terms = Terms::ELASTIC;
    let model = ShellModel {
        material,
        terms,
        sff,
    };
    let mut asm = Assembler::new(&mesh, &DofMap::all_free(mesh.n_vertices()), terms).unwrap();
    let x: Vec<_> = mesh.positions().iter().map(|p| p * s.exp()).collect();
    let mut eval = |p: f64| {
        let mut rest = initial.clone();
        let growth = Isotropic {
            p,
            coefficient: 1.0,
        };
        apply_growth(&growth, &initial, &m, H, &mut rest).unwrap();
        let mut g = vec![0.0; 3 * x.len()];
        let e = asm
            .evaluate(
                &model,
                &x,
                &rest,
                None,
                EvalOutput {
                    gradient: Some(&mut g),
                    hessian: None,
                },
            )
            .unwrap();
        (e, g.iter().fold(0.0f64, |a, v| a.max(v.abs())))
    };
    let (e1, g1) = eval(1.0);
    let (e0, g0) = eval(0.0);
    // With p = 0 the scaled sphere is bent against b̄ = b⁰: a reference for the scales.
    assert!(e0.bend > 1e-6 && g0 > 1e-4, "{e0:?} {g0}");
    assert!(e1.total() < 1e-24 * e0.total().max(1.0) + 1e-20, "{e1:?}");
    // Round-off of a − ā is ~1e-16·|a|, i.e. forces ~1e-16·E·h·ℓ (ℓ ≈ 0.2 m edge length).
    let membrane = material.young * material.thickness * 0.2;
    assert!(
        g1 < 1e-13 * membrane && g1 < 1e-6 * g0,
        "{g1} vs {g0}, {membrane}"
    );
}

#[test]
fn bad_stimulus_is_refused() {
    let (mesh, initial) = flat_strip();
    let mut rest = initial.clone();
    let mut m = vec![FaceStimulus::default(); mesh.n_faces()];
    m[5].top = f64::NAN;
    let e = apply_growth(&Swelling::linear(0.1), &initial, &m, H, &mut rest).unwrap_err();
    assert!(matches!(e, GrowthError::NonFiniteStimulus { .. }), "{e}");
    assert!(e.to_string().contains("face f5"), "{e}");

    m[5].top = 2.0; // 1 + c·m = 0
    let e = apply_growth(&Swelling::linear(-0.5), &initial, &m, H, &mut rest).unwrap_err();
    assert!(matches!(e, GrowthError::CollapsedRest { .. }), "{e}");

    let e = apply_growth(&NoGrowth, &initial, &m[1..], H, &mut rest).unwrap_err();
    assert!(matches!(e, GrowthError::LengthMismatch { .. }), "{e}");
    let e = apply_growth(&NoGrowth, &initial, &m, -1.0, &mut rest).unwrap_err();
    assert!(e.to_string().contains("thickness"), "{e}");
    let e = apply_growth(
        &Isotropic::SEED,
        &initial,
        &vec![FaceStimulus::uniform(800.0); mesh.n_faces()],
        H,
        &mut rest,
    )
    .unwrap_err();
    assert!(matches!(e, GrowthError::CollapsedRest { .. }), "{e}");
}

fn spd(p: f64, q: f64, r: f64) -> Matrix2<f64> {
    // LLᵀ with a positive diagonal: symmetric positive definite.
    let l = Matrix2::new(p.abs() + 0.1, 0.0, q, r.abs() + 0.1);
    l * l.transpose()
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(cases_or(64)))]

    /// The exact-at-zero arrangement of the swelling formulas equals model.md §4's surface-metric
    /// form ḡ± = (1 + c m±)² (a⁰ ∓ h b⁰), ā = (ḡ⁺ + ḡ⁻)/2, b̄ = (ḡ⁻ − ḡ⁺)/(2h), on random forms.
    #[test]
    fn linear_swelling_matches_surface_metric_form(
        p in -2.0..2.0f64, q in -2.0..2.0f64, r in -2.0..2.0f64,
        b11 in -50.0..50.0f64, b12 in -50.0..50.0f64, b22 in -50.0..50.0f64,
        c in -0.2..0.2f64, mp in -1.0..1.0f64, mm in -1.0..1.0f64,
    ) {
        let a0 = spd(p, q, r);
        let b0 = Matrix2::new(b11, b12, b12, b22) * 1e-3;
        let m = FaceStimulus { top: mp, bottom: mm };
        let (a, b) = Swelling::linear(c).face_rest(0, &a0, &b0, m, H).unwrap();
        let gp = (a0 - b0 * H) * (1.0 + c * mp).powi(2);
        let gm = (a0 + b0 * H) * (1.0 + c * mm).powi(2);
        let scale = a0.norm();
        proptest::prop_assert!((a - (gp + gm) * 0.5).norm() < 1e-13 * scale);
        proptest::prop_assert!((b - (gm - gp) / (2.0 * H)).norm() < 1e-10 * scale / H);
        // Bilayer: for a flat sheet, 3/2 of the linear b̄ and the same ā.
        let (ab, bb) = Swelling::bilayer(c).face_rest(0, &a0, &Matrix2::zeros(), m, H).unwrap();
        let (al, bl) = Swelling::linear(c).face_rest(0, &a0, &Matrix2::zeros(), m, H).unwrap();
        proptest::prop_assert!((ab - al).norm() < 1e-14 * scale);
        proptest::prop_assert!((bb - bl * 1.5).norm() < 1e-10 * scale / H);
    }
}
