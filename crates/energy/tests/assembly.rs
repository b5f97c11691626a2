//! Whole-mesh assembly: derivatives against finite differences, invariants, pattern,
//! thread-count determinism and error reporting.
#![allow(clippy::unwrap_used)]

use nalgebra::{DMatrix, Rotation3, SMatrix, SymmetricEigen, Vector3};
use proptest::prelude::*;
use std::collections::BTreeSet;
use thinshell_energy::{
    Assembler, DampingState, DofMap, EnergyError, EnergyTerms, EvalOutput, HessianMode, Material,
    RestState, SffKind, ShellModel, Terms,
};
use thinshell_mesh::{FaceId, Mesh, VertexId, generators};
use thinshell_testkit::fd::dense_symmetric as dense;
use thinshell_testkit::fixtures::soft_material as material;
use thinshell_testkit::rng::SplitMix64;
use thinshell_testkit::strategies::cases_or;

fn model(terms: Terms) -> ShellModel {
    ShellModel {
        material: material(),
        terms,
        sff: SffKind::MidEdgeAverage,
    }
}

const ALL: Terms = Terms {
    stretch: true,
    bend: true,
    damping: true,
};
const ELASTIC: Terms = Terms::ELASTIC;

/// A curved rest shape (irregular rectangle bent into a bump), perturbed positions `x`, and
/// previous positions `x_prev` for damping.
struct Case {
    mesh: Mesh,
    rest: RestState,
    damping: DampingState,
    x: Vec<Vector3<f64>>,
}

fn case(seed: u64, n: usize) -> Case {
    let flat = generators::irregular_rectangle(1.0, 1.0, n, seed).unwrap();
    let bump: Vec<_> = flat
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x, p.y, 0.3 * (p.x * 2.0).sin() * (p.y * 1.5).cos()))
        .collect();
    let mesh = flat.with_positions(bump).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let mut rng = SplitMix64::new(seed ^ 0x5EED);
    let x_prev: Vec<_> = mesh
        .positions()
        .iter()
        .map(|p| p + rng.vector3(0.02))
        .collect();
    let x: Vec<_> = x_prev.iter().map(|p| p + rng.vector3(0.02)).collect();
    let damping =
        DampingState::from_positions(&mesh, &x_prev, SffKind::MidEdgeAverage, 0.05).unwrap();
    Case {
        mesh,
        rest,
        damping,
        x,
    }
}

fn flat(x: &[Vector3<f64>]) -> Vec<f64> {
    x.iter().flat_map(|p| [p.x, p.y, p.z]).collect()
}
fn unflat(q: &[f64]) -> Vec<Vector3<f64>> {
    q.chunks(3)
        .map(|c| Vector3::new(c[0], c[1], c[2]))
        .collect()
}

fn energy(asm: &mut Assembler, m: &ShellModel, c: &Case, x: &[Vector3<f64>]) -> f64 {
    asm.evaluate(m, x, &c.rest, Some(&c.damping), EvalOutput::default())
        .unwrap()
        .total()
}

fn gradient(asm: &mut Assembler, m: &ShellModel, c: &Case, x: &[Vector3<f64>]) -> Vec<f64> {
    let mut g = vec![0.0; 3 * x.len()];
    asm.evaluate(
        m,
        x,
        &c.rest,
        Some(&c.damping),
        EvalOutput {
            gradient: Some(&mut g),
            hessian: None,
        },
    )
    .unwrap();
    g
}

fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn pins(mesh: &Mesh) -> DofMap {
    // Vertex 0 fully, vertex 1 in z only, vertex 2 in x only.
    DofMap::with_pinned(
        mesh.n_vertices(),
        [
            (VertexId(0), 0),
            (VertexId(0), 1),
            (VertexId(0), 2),
            (VertexId(1), 2),
            (VertexId(2), 0),
        ],
    )
    .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(4)))]

    /// Assembled gradient (all coordinates, pinned included) vs central differences of the
    /// total energy, step 1e-7 m on edges of ≈ 0.2 m; tolerance 1e-6 of the largest entry.
    /// (With step 1e-6 seed 815 misses by 5e-6 and the miss scales exactly as step², i.e. it is
    /// the O(step²) truncation error of a strongly curved random configuration.)
    #[test]
    fn gradient_matches_finite_differences(seed in 0u64..1000) {
        let c = case(seed, 12);
        let m = model(ALL);
        let mut asm = Assembler::new(&c.mesh, &pins(&c.mesh), ALL).unwrap();
        let g = gradient(&mut asm, &m, &c, &c.x);
        let q = flat(&c.x);
        let cell = std::cell::RefCell::new(asm);
        let fd = thinshell_testkit::fd::fd_gradient(|y| energy(&mut cell.borrow_mut(), &m, &c, &unflat(y)), &q, 1e-7);
        let scale = max_abs(g.iter().copied());
        prop_assert!(scale > 0.0);
        let err = max_abs(g.iter().zip(&fd).map(|(a, b)| a - b));
        prop_assert!(err <= 1e-6 * scale, "gradient error {err:e}, scale {scale:e}");
    }

    /// Assembled exact Hessian (free dofs, lower triangle) vs central differences of the
    /// assembled gradient, step 1e-7 m (see above); tolerance 1e-6 of the largest entry. Entries outside
    /// the pattern must vanish in the finite-difference Hessian too.
    #[test]
    fn hessian_matches_finite_differences(seed in 0u64..1000) {
        let c = case(seed, 10);
        let m = model(ALL);
        let dofs = pins(&c.mesh);
        let mut asm = Assembler::new(&c.mesh, &dofs, ALL).unwrap();
        let mut h = asm.hessian_template();
        let mut g = vec![0.0; 3 * c.x.len()];
        asm.evaluate(&m, &c.x, &c.rest, Some(&c.damping), EvalOutput { gradient: Some(&mut g), hessian: Some((&mut h, HessianMode::Exact)) }).unwrap();
        let hd = dense(&h);
        let q = flat(&c.x);
        let step = 1e-7;
        let mut fd = DMatrix::zeros(dofs.n_free(), dofs.n_free());
        let mut gf = vec![0.0; dofs.n_free()];
        for (d, &coord) in dofs.free_coordinates().iter().enumerate() {
            let mut y = q.clone();
            y[coord] = q[coord] + step;
            dofs.restrict(&gradient(&mut asm, &m, &c, &unflat(&y)), &mut gf).unwrap();
            let gp = gf.clone();
            y[coord] = q[coord] - step;
            dofs.restrict(&gradient(&mut asm, &m, &c, &unflat(&y)), &mut gf).unwrap();
            for r in 0..dofs.n_free() {
                fd[(r, d)] = (gp[r] - gf[r]) / (2.0 * step);
            }
        }
        let scale = hd.amax();
        let err = (&hd - &fd).amax();
        prop_assert!(err <= 1e-6 * scale, "Hessian error {err:e}, scale {scale:e}");
    }
}

/// Gauss–Newton Hessian is positive semidefinite (smallest eigenvalue ≥ −1e-10 of the
/// largest) away from rest, and equals the exact Hessian at the rest state, where every
/// residual vanishes (to 1e-10 relative).
#[test]
fn gauss_newton_is_psd_and_exact_at_rest() {
    let c = case(7, 10);
    let m = model(ELASTIC);
    let mut asm = Assembler::new(&c.mesh, &DofMap::all_free(c.mesh.n_vertices()), ELASTIC).unwrap();
    let mut h = asm.hessian_template();
    let mut eval = |asm: &mut Assembler, x: &[Vector3<f64>], mode| {
        asm.evaluate(
            &m,
            x,
            &c.rest,
            None,
            EvalOutput {
                gradient: None,
                hessian: Some((&mut h, mode)),
            },
        )
        .unwrap();
        dense(&h)
    };
    let gn = eval(&mut asm, &c.x, HessianMode::GaussNewton);
    let ev = SymmetricEigen::new(gn.clone()).eigenvalues;
    assert!(ev.min() >= -1e-10 * ev.max(), "GN eigenvalue {}", ev.min());
    let exact = eval(&mut asm, &c.x, HessianMode::Exact);
    let ev = SymmetricEigen::new(exact).eigenvalues;
    println!(
        "away from rest: exact Hessian min/max eigenvalue {:e} / {:e}",
        ev.min(),
        ev.max()
    );
    let x0 = c.mesh.positions().to_vec();
    let gn0 = eval(&mut asm, &x0, HessianMode::GaussNewton);
    let ex0 = eval(&mut asm, &x0, HessianMode::Exact);
    assert!((&gn0 - &ex0).amax() <= 1e-10 * ex0.amax());
}

/// At the rest state energy and gradient vanish; a rigid motion of any configuration leaves
/// the energy unchanged (1e-12 relative); at rest, infinitesimal rigid motions lie in the
/// Hessian's null space (‖H v‖ ≤ 1e-9 ‖H‖ ‖v‖), translations also away from rest.
#[test]
fn rest_state_and_rigid_motions() {
    let c = case(3, 10);
    let m = model(ELASTIC);
    let n = c.mesh.n_vertices();
    let mut asm = Assembler::new(&c.mesh, &DofMap::all_free(n), ELASTIC).unwrap();
    let mut h = asm.hessian_template();
    let mut g = vec![0.0; 3 * n];
    let x0 = c.mesh.positions().to_vec();
    let e0 = asm
        .evaluate(
            &m,
            &x0,
            &c.rest,
            None,
            EvalOutput {
                gradient: Some(&mut g),
                hessian: Some((&mut h, HessianMode::Exact)),
            },
        )
        .unwrap();
    let e_ref = asm
        .evaluate(&m, &c.x, &c.rest, None, EvalOutput::default())
        .unwrap()
        .total();
    assert!(e0.total().abs() <= 1e-14 * e_ref, "rest energy {e0:?}");
    let mut g_ref = vec![0.0; 3 * n];
    asm.evaluate(
        &m,
        &c.x,
        &c.rest,
        None,
        EvalOutput {
            gradient: Some(&mut g_ref),
            hessian: None,
        },
    )
    .unwrap();
    assert!(max_abs(g.iter().copied()) <= 1e-10 * max_abs(g_ref.iter().copied()));

    let hd = dense(&h);
    let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    let shift = Vector3::new(0.5, -2.0, 1.0);
    let moved: Vec<_> = c.x.iter().map(|p| rot * p + shift).collect();
    let e_moved = asm
        .evaluate(&m, &moved, &c.rest, None, EvalOutput::default())
        .unwrap()
        .total();
    assert!((e_moved - e_ref).abs() <= 1e-12 * e_ref);

    let modes: Vec<Vec<f64>> = (0..3)
        .map(|a| flat(&vec![Vector3::ith(a, 1.0); n]))
        .chain((0..3).map(|a| {
            flat(
                &x0.iter()
                    .map(|p| Vector3::<f64>::ith(a, 1.0).cross(p))
                    .collect::<Vec<_>>(),
            )
        }))
        .collect();
    for v in &modes {
        let hv = &hd * nalgebra::DVector::from_column_slice(v);
        let vn = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(hv.amax() <= 1e-9 * hd.amax() * vn, "|Hv| = {:e}", hv.amax());
    }
    asm.evaluate(
        &m,
        &c.x,
        &c.rest,
        None,
        EvalOutput {
            gradient: None,
            hessian: Some((&mut h, HessianMode::Exact)),
        },
    )
    .unwrap();
    let hx = dense(&h);
    for v in &modes[..3] {
        let hv = &hx * nalgebra::DVector::from_column_slice(v);
        assert!(hv.amax() <= 1e-9 * hx.amax() * (n as f64).sqrt());
    }
}

/// A flat sheet (b̄ = 0) stretched arbitrarily in its plane has zero bending energy
/// (≤ 1e-25 J against a stretching energy of order 1e-2 J) but positive stretching energy.
#[test]
fn flat_sheet_has_no_bending_energy() {
    let mesh = generators::irregular_rectangle(1.0, 0.7, 20, 11).unwrap();
    let rest = RestState::from_planar(
        &mesh,
        nalgebra::Matrix2::identity(),
        nalgebra::Matrix2::zeros(),
    )
    .unwrap();
    let mut rng = SplitMix64::new(5);
    let x: Vec<_> = mesh
        .positions()
        .iter()
        .map(|p| {
            let d = rng.vector3(0.003);
            Vector3::new(1.2 * p.x + d.x, 0.9 * p.y + d.y, 0.0)
        })
        .collect();
    let m = model(ELASTIC);
    let mut asm = Assembler::new(&mesh, &DofMap::all_free(mesh.n_vertices()), ELASTIC).unwrap();
    let e = asm
        .evaluate(&m, &x, &rest, None, EvalOutput::default())
        .unwrap();
    assert!(e.bend.abs() <= 1e-25, "bend {e:?}");
    assert!(e.stretch > 1e-3, "stretch {e:?}");
}

/// Same energies, gradient and Hessian bits with 1 and 2 rayon threads.
#[test]
fn bit_identical_for_any_thread_count() {
    let mesh = generators::icosphere(1.0, 3).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let mut rng = SplitMix64::new(99);
    let x_prev: Vec<_> = mesh
        .positions()
        .iter()
        .map(|p| p + rng.vector3(0.01))
        .collect();
    let x: Vec<_> = x_prev
        .iter()
        .map(|p| p * 0.97 + rng.vector3(0.01))
        .collect();
    let damping =
        DampingState::from_positions(&mesh, &x_prev, SffKind::MidEdgeAverage, 1e-3).unwrap();
    let dofs = DofMap::with_pinned_vertices(mesh.n_vertices(), [VertexId(0), VertexId(5)]).unwrap();
    let m = model(ALL);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut asm = Assembler::new(&mesh, &dofs, ALL).unwrap();
            let mut h = asm.hessian_template();
            let mut g = vec![0.0; 3 * mesh.n_vertices()];
            let e = asm
                .evaluate(
                    &m,
                    &x,
                    &rest,
                    Some(&damping),
                    EvalOutput {
                        gradient: Some(&mut g),
                        hessian: Some((&mut h, HessianMode::Exact)),
                    },
                )
                .unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            (
                bits(&[e.stretch, e.bend, e.damping]),
                bits(&g),
                bits(h.val()),
            )
        })
    };
    let (one, two) = (run(1), run(2));
    assert!(one.0.iter().all(|&b| f64::from_bits(b) != 0.0));
    assert_eq!(one, two);
}

/// Every path (energy only, energy + gradient, with the Hessian) gives the same bits on one
/// rayon thread — where the assembler runs on the calling thread — and on two, on a mesh large
/// enough (20 480 faces) for each path to go parallel there.
#[test]
fn calling_thread_and_pool_paths_agree_bit_for_bit() {
    let mesh = generators::icosphere(1.0, 5).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let mut rng = SplitMix64::new(7);
    let x: Vec<_> = mesh
        .positions()
        .iter()
        .map(|p| p * 0.98 + rng.vector3(0.005))
        .collect();
    let dofs = DofMap::all_free(mesh.n_vertices());
    let m = model(ELASTIC);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut asm = Assembler::new(&mesh, &dofs, ELASTIC).unwrap();
            let e = asm
                .evaluate(&m, &x, &rest, None, EvalOutput::default())
                .unwrap();
            let mut g = vec![0.0; 3 * mesh.n_vertices()];
            let eg = asm
                .evaluate(
                    &m,
                    &x,
                    &rest,
                    None,
                    EvalOutput {
                        gradient: Some(&mut g),
                        hessian: None,
                    },
                )
                .unwrap();
            let mut gh = vec![0.0; 3 * mesh.n_vertices()];
            let mut h = asm.hessian_template();
            let egh = asm
                .evaluate(
                    &m,
                    &x,
                    &rest,
                    None,
                    EvalOutput {
                        gradient: Some(&mut gh),
                        hessian: Some((&mut h, HessianMode::Exact)),
                    },
                )
                .unwrap();
            (
                bits(&[
                    e.stretch,
                    e.bend,
                    eg.stretch,
                    eg.bend,
                    egh.stretch,
                    egh.bend,
                ]),
                bits(&g),
                bits(&gh),
                bits(h.val()),
            )
        })
    };
    let one = run(1);
    assert!(one.1.iter().any(|&b| f64::from_bits(b) != 0.0));
    assert_eq!(one, run(2));
}

/// The pattern is exactly the union of the stencils' dof pairs (lower triangle, free dofs),
/// with every diagonal present and `diagonal_offsets` pointing at it; stretching only uses
/// the face vertices.
#[test]
fn pattern_is_union_of_stencils() {
    let c = case(21, 8);
    let dofs = pins(&c.mesh);
    for (terms, flaps) in [
        (ELASTIC, true),
        (
            Terms {
                stretch: true,
                bend: false,
                damping: false,
            },
            false,
        ),
    ] {
        let asm = Assembler::new(&c.mesh, &dofs, terms).unwrap();
        let mut expected = BTreeSet::new();
        for (f, face) in c.mesh.faces().iter().enumerate() {
            let mut vs: Vec<VertexId> = face.to_vec();
            if flaps {
                vs.extend(
                    c.mesh
                        .topology()
                        .flap_vertices(FaceId::new(f))
                        .into_iter()
                        .flatten(),
                );
            }
            for &v in &vs {
                for &w in &vs {
                    for (a, b) in (0..3).flat_map(|a| (0..3).map(move |b| (a, b))) {
                        if let (Some(r), Some(col)) = (dofs.dof(v, a), dofs.dof(w, b)) {
                            if r >= col {
                                expected.insert((col, r));
                            }
                        }
                    }
                }
            }
        }
        for d in 0..dofs.n_free() {
            expected.insert((d, d));
        }
        let h = asm.hessian_template();
        let s = h.symbolic();
        let mut got = BTreeSet::new();
        for col in 0..h.ncols() {
            let rows = &s.row_idx()[s.col_ptr()[col]..s.col_ptr()[col + 1]];
            assert!(rows.windows(2).all(|w| w[0] < w[1]));
            got.extend(rows.iter().map(|&r| (col, r)));
        }
        assert_eq!(got, expected);
        for (d, &o) in asm.diagonal_offsets().iter().enumerate() {
            assert_eq!(s.row_idx()[o], d);
            assert!(s.col_ptr()[d] <= o && o < s.col_ptr()[d + 1]);
        }
    }
}

/// Stretching-only and bending-only assemblers reproduce the corresponding terms of the
/// full one (1e-12 relative), and their gradients add up to the full gradient.
#[test]
fn terms_evaluate_separately() {
    let c = case(4, 10);
    let n = c.mesh.n_vertices();
    let dofs = DofMap::all_free(n);
    let run = |terms: Terms| {
        let mut asm = Assembler::new(&c.mesh, &dofs, terms).unwrap();
        let mut g = vec![0.0; 3 * n];
        let e = asm
            .evaluate(
                &model(terms),
                &c.x,
                &c.rest,
                Some(&c.damping),
                EvalOutput {
                    gradient: Some(&mut g),
                    hessian: None,
                },
            )
            .unwrap();
        (e, g)
    };
    let (all, g_all) = run(ALL);
    let (s, g_s) = run(Terms {
        stretch: true,
        bend: false,
        damping: false,
    });
    let (b, g_b) = run(Terms {
        stretch: false,
        bend: true,
        damping: false,
    });
    let (d, g_d) = run(Terms {
        stretch: false,
        bend: false,
        damping: true,
    });
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1e-300);
    assert!(close(s.stretch, all.stretch) && s.bend == 0.0 && s.damping == 0.0);
    assert!(close(b.bend, all.bend) && b.stretch == 0.0);
    assert!(close(d.damping, all.damping) && d.stretch == 0.0 && d.bend == 0.0);
    assert!(all.stretch > 0.0 && all.bend > 0.0 && all.damping > 0.0);
    let scale = max_abs(g_all.iter().copied());
    for i in 0..3 * n {
        assert!((g_s[i] + g_b[i] + g_d[i] - g_all[i]).abs() <= 1e-10 * scale);
    }
}

/// `add_face_block` adds the symmetric part of a 9×9 block at the face's dofs (pinned
/// coordinates skipped), checked against a dense scatter.
#[test]
fn add_face_block_scatters_symmetric_part() {
    let c = case(8, 6);
    let dofs = pins(&c.mesh);
    let asm = Assembler::new(&c.mesh, &dofs, ELASTIC).unwrap();
    let mut h = asm.hessian_template();
    let mut rng = SplitMix64::new(1);
    let mut expected = DMatrix::zeros(dofs.n_free(), dofs.n_free());
    for f in [0, 3, c.mesh.n_faces() - 1] {
        let b = SMatrix::<f64, 9, 9>::from_fn(|_, _| rng.signed());
        asm.add_face_block(FaceId::new(f), &b, &mut h).unwrap();
        let face = c.mesh.faces()[f];
        let sym = (b + b.transpose()) * 0.5;
        for i in 0..9 {
            for j in 0..9 {
                if let (Some(r), Some(col)) =
                    (dofs.dof(face[i / 3], i % 3), dofs.dof(face[j / 3], j % 3))
                {
                    expected[(r, col)] += sym[(i, j)];
                }
            }
        }
    }
    assert!((dense(&h) - expected).amax() <= 1e-14);
    assert!(matches!(
        asm.add_face_block(FaceId::new(c.mesh.n_faces()), &SMatrix::zeros(), &mut h),
        Err(EnergyError::FaceOutOfRange { .. })
    ));
}

/// `add_face_blocks` (all faces, one pattern check) gives exactly what one `add_face_block`
/// call per face gives, and refuses a Hessian of another pattern.
#[test]
fn add_face_blocks_equals_one_call_per_face() {
    let c = case(8, 6);
    let dofs = pins(&c.mesh);
    let asm = Assembler::new(&c.mesh, &dofs, ELASTIC).unwrap();
    let mut rng = SplitMix64::new(2);
    let blocks: Vec<SMatrix<f64, 9, 9>> = (0..c.mesh.n_faces())
        .map(|_| SMatrix::from_fn(|_, _| rng.signed()))
        .collect();
    let mut one_by_one = asm.hessian_template();
    for (f, b) in blocks.iter().enumerate() {
        asm.add_face_block(FaceId::new(f), b, &mut one_by_one)
            .unwrap();
    }
    let mut at_once = asm.hessian_template();
    asm.add_face_blocks(|f| blocks[f.idx()], &mut at_once)
        .unwrap();
    assert_eq!(at_once.val(), one_by_one.val());
    let small = case(4, 3).mesh;
    let other = Assembler::new(&small, &DofMap::all_free(small.n_vertices()), ELASTIC).unwrap();
    let mut wrong = other.hessian_template();
    assert!(matches!(
        asm.add_face_blocks(|f| blocks[f.idx()], &mut wrong),
        Err(EnergyError::HessianPatternMismatch)
    ));
}

/// Bad input gives typed errors naming the problem, never a panic or a silent NaN.
#[test]
fn errors_are_typed() {
    let c = case(2, 6);
    let n = c.mesh.n_vertices();
    let mut asm = Assembler::new(&c.mesh, &DofMap::all_free(n), ELASTIC).unwrap();
    let out = || EvalOutput::default();
    assert!(matches!(
        asm.evaluate(&model(ALL), &c.x, &c.rest, None, out()),
        Err(EnergyError::TermsMismatch { .. })
    ));
    let mut all = Assembler::new(&c.mesh, &DofMap::all_free(n), ALL).unwrap();
    assert!(matches!(
        all.evaluate(&model(ALL), &c.x, &c.rest, None, out()),
        Err(EnergyError::MissingDamping)
    ));
    assert!(matches!(
        asm.evaluate(&model(ELASTIC), &c.x[1..], &c.rest, None, out()),
        Err(EnergyError::LengthMismatch {
            what: "positions",
            ..
        })
    ));
    // A NaN at vertex v: the lowest face whose stencil contains v is reported.
    let v = n / 2;
    let mut bad = c.x.clone();
    bad[v].y = f64::NAN;
    let first = (0..c.mesh.n_faces())
        .find(|&f| {
            asm.stencil_vertices(FaceId::new(f))
                .unwrap()
                .contains(&VertexId::new(v))
        })
        .unwrap();
    match asm.evaluate(&model(ELASTIC), &bad, &c.rest, None, out()) {
        Err(EnergyError::NonFinite { face }) => assert_eq!(face, FaceId::new(first)),
        other => panic!("expected NonFinite, got {other:?}"),
    }
    // A Hessian of another pattern.
    let other = Assembler::new(&c.mesh, &pins(&c.mesh), ELASTIC).unwrap();
    let mut h = other.hessian_template();
    assert!(matches!(
        asm.evaluate(
            &model(ELASTIC),
            &c.x,
            &c.rest,
            None,
            EvalOutput {
                gradient: None,
                hessian: Some((&mut h, HessianMode::Exact))
            }
        ),
        Err(EnergyError::HessianPatternMismatch)
    ));
    let mut h = asm.hessian_template();
    assert!(matches!(
        asm.gather_hessian(&mut h),
        Err(EnergyError::NoHessianEvaluated)
    ));
    assert!(matches!(
        Assembler::new(&c.mesh, &DofMap::all_free(n + 1), ELASTIC),
        Err(EnergyError::LengthMismatch { .. })
    ));
    let bad_material = ShellModel {
        material: Material {
            thickness: -1.0,
            ..material()
        },
        ..model(ELASTIC)
    };
    assert!(matches!(
        asm.evaluate(&bad_material, &c.x, &c.rest, None, out()),
        Err(EnergyError::InvalidParameter {
            name: "thickness",
            ..
        })
    ));
    let _: EnergyTerms = asm
        .evaluate(&model(ELASTIC), &c.x, &c.rest, None, out())
        .unwrap();
}

/// `gather_hessian` alone reproduces the Hessian of the last evaluation bit for bit.
#[test]
fn gather_alone_reproduces_hessian() {
    let c = case(5, 8);
    let mut asm = Assembler::new(&c.mesh, &DofMap::all_free(c.mesh.n_vertices()), ALL).unwrap();
    let mut h = asm.hessian_template();
    asm.evaluate(
        &model(ALL),
        &c.x,
        &c.rest,
        Some(&c.damping),
        EvalOutput {
            gradient: None,
            hessian: Some((&mut h, HessianMode::GaussNewton)),
        },
    )
    .unwrap();
    let mut h2 = asm.hessian_template();
    asm.gather_hessian(&mut h2).unwrap();
    assert_eq!(h.val(), h2.val());
    assert!(h.val().iter().any(|&v| v != 0.0));
}
