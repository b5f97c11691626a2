//! Rest states, mass and geometric checks of the assembled energy: sphere curvature, cylinder
//! bending energy under refinement.
#![allow(clippy::unwrap_used)]

use nalgebra::{Matrix2, Vector3};
use std::f64::consts::PI;
use thinshell_energy::first_fundamental_form;
use thinshell_energy::{
    Assembler, DampingState, DofMap, EnergyError, EvalOutput, Material, RestState, SffKind,
    ShellModel, Terms, lumped_mass,
};
use thinshell_mesh::{FaceId, Mesh, VertexId, generators, geometry};

const BEND: Terms = Terms {
    stretch: false,
    bend: true,
    damping: false,
};

fn bending_energy(mesh: &Mesh, x: &[Vector3<f64>], rest: &RestState, material: Material) -> f64 {
    let model = ShellModel {
        material,
        terms: BEND,
        sff: SffKind::MidEdgeAverage,
    };
    let mut asm = Assembler::new(mesh, &DofMap::all_free(mesh.n_vertices()), BEND).unwrap();
    asm.evaluate(&model, x, rest, None, EvalOutput::default())
        .unwrap()
        .bend
}

/// Continuum bending energy of a cylinder of radius r over `area`: (h³/12)(α/2 + β)/r²·area.
fn cylinder_energy(m: &Material, r: f64, area: f64) -> f64 {
    m.thickness.powi(3) / 12.0 * (0.5 * m.alpha() + m.beta()) / (r * r) * area
}

/// On an icosphere of radius r (outward normals) b ≈ −a/r. Per face the error is measured
/// invariantly as the curvature error r·‖a⁻¹(b + a/r)‖ (‖M‖² = tr(M²)/2: 1 for M = I): its
/// maximum and mean over the faces shrink about like the mesh size (measured rates 0.8–1.0,
/// printed; the mid-edge average is only first-order accurate per face here); at level 5
/// (20 480 faces) the mean is below 1.5 % and the maximum below 2.5 %.
#[test]
fn sphere_has_b_equal_minus_a_over_r() {
    let r = 2.0;
    let mut errors = Vec::new();
    for level in 2..=5 {
        let mesh = generators::icosphere(r, level).unwrap();
        let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
        let errs: Vec<f64> = rest
            .a_bar
            .iter()
            .zip(&rest.b_bar)
            .map(|(a, b)| {
                let m = a.try_inverse().unwrap() * (b + a / r) * r;
                ((m * m).trace() / 2.0).sqrt()
            })
            .collect();
        let max = errs.iter().copied().fold(0.0, f64::max);
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        println!("sphere level {level}: curvature error max {max:.3e}, mean {mean:.3e}");
        errors.push((max, mean));
    }
    for w in errors.windows(2) {
        let rates = ((w[0].0 / w[1].0).log2(), (w[0].1 / w[1].1).log2());
        println!("sphere: rates max {:.2}, mean {:.2}", rates.0, rates.1);
        assert!(rates.0 > 0.75 && rates.1 > 0.75, "{errors:?}");
    }
    let (max, mean) = errors[errors.len() - 1];
    assert!(max < 0.025 && mean < 0.015, "{errors:?}");
}

/// A flat sheet (b̄ = 0) rolled onto a cylinder of radius r, and a closed tube with its own
/// metric as rest state: the bending energy approaches (h³/12)(α/2 + β)/r²·area; the relative
/// error shrinks under refinement (rates printed; < 5 % on the finest meshes).
#[test]
fn cylinder_bending_energy_converges() {
    let m = Material::paper();
    let r = 1.0;
    let (width, length) = (2.0, 1.0);
    let mut sheet = Vec::new();
    let mut tube = Vec::new();
    for n in [4usize, 8, 16, 32] {
        let flat = generators::rectangle(width, length, 2 * n, n).unwrap();
        let rest = RestState::from_planar(&flat, Matrix2::identity(), Matrix2::zeros()).unwrap();
        let rolled: Vec<_> = flat
            .positions()
            .iter()
            .map(|p| Vector3::new(r * (p.x / r).sin(), p.y, r * (1.0 - (p.x / r).cos())))
            .collect();
        let e = bending_energy(&flat, &rolled, &rest, m);
        sheet.push((n, (e / cylinder_energy(&m, r, width * length) - 1.0).abs()));

        let tube_mesh = generators::cylinder_patch(r, 2.0 * PI, length, 4 * n, n).unwrap();
        let mut rest =
            RestState::from_mesh(&tube_mesh, tube_mesh.positions(), SffKind::MidEdgeAverage)
                .unwrap();
        rest.b_bar.iter_mut().for_each(|b| *b = Matrix2::zeros());
        let e = bending_energy(&tube_mesh, tube_mesh.positions(), &rest, m);
        tube.push((
            n,
            (e / cylinder_energy(&m, r, 2.0 * PI * r * length) - 1.0).abs(),
        ));
    }
    for (name, errs) in [("rolled sheet", &sheet), ("closed tube", &tube)] {
        for w in errs.windows(2) {
            let rate = (w[0].1 / w[1].1).log2();
            println!(
                "{name}: n = {:>2} -> {:>2}: relative error {:.3e} -> {:.3e}, rate {rate:.2}",
                w[0].0, w[1].0, w[0].1, w[1].1
            );
            assert!(w[1].1 < w[0].1, "{name}: error does not shrink: {errs:?}");
        }
        assert!(errs[errs.len() - 1].1 < 0.05, "{name}: {errs:?}");
    }
}

/// Lumped masses sum to ρ·h·area (1e-12 relative) and each vertex carries a third of its
/// faces' rest masses (checked against mesh face areas).
#[test]
fn lumped_mass_sums_to_total_mass() {
    let m = Material::paper();
    let flat = generators::rectangle(1.5, 0.5, 9, 4).unwrap();
    let rest = RestState::from_planar(&flat, Matrix2::identity() * 4.0, Matrix2::zeros()).unwrap();
    let mass = lumped_mass(&flat, &rest, &m).unwrap();
    // ā = 4 I in the plane doubles both lengths: rest area 4·(1.5·0.5).
    let total = m.density * m.thickness * 4.0 * 0.75;
    assert!((mass.iter().sum::<f64>() - total).abs() <= 1e-12 * total);

    let sphere = generators::icosphere(1.0, 2).unwrap();
    let rest = RestState::from_mesh(&sphere, sphere.positions(), SffKind::MidEdgeAverage).unwrap();
    let mass = lumped_mass(&sphere, &rest, &m).unwrap();
    let areas = geometry::face_areas(&sphere, sphere.positions());
    let mut expected = vec![0.0; sphere.n_vertices()];
    for (face, a) in sphere.faces().iter().zip(&areas) {
        for v in face {
            expected[v.idx()] += m.density * m.thickness * a / 3.0;
        }
    }
    for (got, want) in mass.iter().zip(&expected) {
        assert!((got - want).abs() <= 1e-12 * want);
    }
    let area: f64 = areas.iter().sum();
    assert!((mass.iter().sum::<f64>() - m.density * m.thickness * area).abs() <= 1e-12 * area);
    assert!(matches!(
        lumped_mass(
            &sphere,
            &RestState {
                a_bar: vec![],
                b_bar: vec![],
                sff: None,
            },
            &m
        ),
        Err(EnergyError::LengthMismatch { .. })
    ));
}

/// Planar rest forms are ā = Tᵀ ā^{xy} T: for ā^{xy} = [[2,1],[1,2]] compare with the first
/// fundamental form of the mesh mapped by the matrix square root of ā^{xy} (1e-13 relative);
/// b̄ = Tᵀ b̄^{xy} T likewise.
#[test]
fn planar_rest_forms_map_through_t() {
    let mesh = generators::seed_square().unwrap();
    let a_xy = Matrix2::new(2.0, 1.0, 1.0, 2.0);
    let b_xy = Matrix2::new(1.0, 0.0, 0.0, 0.0);
    let rest = RestState::from_planar(&mesh, a_xy, b_xy).unwrap();
    // S with SᵀS = ā^{xy}: the map x ↦ S x realises the rest metric.
    // Eigenvectors (1, 1)/√2 (eigenvalue 3) and (1, −1)/√2 (eigenvalue 1): S = Q diag(√3, 1) Q.
    let q = Matrix2::new(1.0, 1.0, 1.0, -1.0) * 0.5f64.sqrt();
    let s = q * Matrix2::new(3f64.sqrt(), 0.0, 0.0, 1.0) * q;
    assert!((s.transpose() * s - a_xy).norm() < 1e-14);
    let x = mesh.positions();
    for (f, face) in mesh.faces().iter().enumerate() {
        let p = face.map(|v| {
            let q = s * x[v.idx()].xy();
            Vector3::new(q.x, q.y, 0.0)
        });
        let a = first_fundamental_form(&p);
        assert!((rest.a_bar[f] - a).norm() <= 1e-13 * a.norm());
        let e1 = (x[face[1].idx()] - x[face[0].idx()]).xy();
        let e2 = (x[face[2].idx()] - x[face[0].idx()]).xy();
        let b = Matrix2::new(e1.x * e1.x, e1.x * e2.x, e1.x * e2.x, e2.x * e2.x);
        assert!((rest.b_bar[f] - b).norm() <= 1e-13 * a.norm());
    }
    let sphere = generators::icosphere(1.0, 1).unwrap();
    assert!(matches!(
        RestState::from_planar(&sphere, a_xy, b_xy),
        Err(EnergyError::NotPlanar { .. })
    ));
    assert!(matches!(
        RestState::from_planar(&mesh, -a_xy, b_xy),
        Err(EnergyError::InvalidParameter { name: "a_xy", .. })
    ));
}

/// `validate` names the first bad face; damping-state construction rejects bad input.
#[test]
fn rest_and_damping_validation() {
    let mesh = generators::icosphere(1.0, 1).unwrap();
    let mut rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    assert!(rest.validate(&mesh).is_ok());
    rest.a_bar[7] = -rest.a_bar[7];
    rest.b_bar[3][(0, 1)] = f64::NAN;
    match rest.validate(&mesh) {
        Err(EnergyError::InvalidRestForm { face, form, .. }) => {
            assert_eq!((face, form), (FaceId(3), "b_bar"));
        }
        other => panic!("{other:?}"),
    }
    rest.b_bar[3][(0, 1)] = rest.b_bar[3][(1, 0)];
    assert!(matches!(
        rest.validate(&mesh),
        Err(EnergyError::InvalidRestForm {
            face: FaceId(7),
            form: "a_bar",
            ..
        })
    ));
    rest.a_bar.pop();
    assert!(matches!(
        rest.validate(&mesh),
        Err(EnergyError::LengthMismatch { .. })
    ));

    let x = mesh.positions();
    assert!(matches!(
        DampingState::from_positions(&mesh, x, SffKind::MidEdgeAverage, 0.0),
        Err(EnergyError::InvalidParameter { name: "dt", .. })
    ));
    let mut bad = x.to_vec();
    bad[4].z = f64::INFINITY;
    assert!(matches!(
        DampingState::from_positions(&mesh, &bad, SffKind::MidEdgeAverage, 0.1),
        Err(EnergyError::NonFiniteVertex {
            vertex: VertexId(4)
        })
    ));
    assert!(matches!(
        RestState::from_mesh(&mesh, &x[1..], SffKind::MidEdgeAverage),
        Err(EnergyError::LengthMismatch { .. })
    ));
    let d = DampingState::from_positions(&mesh, x, SffKind::MidEdgeAverage, 0.1).unwrap();
    let r = RestState::from_mesh(&mesh, x, SffKind::MidEdgeAverage).unwrap();
    assert_eq!((d.a_prev, d.b_prev), (r.a_bar, r.b_bar));
}
