//! Whole-mesh assembly with edge-director unknowns: gradient and Hessian over positions and edge
//! angles against finite differences (with damping, pins, fixed edges, all three Hessian
//! modes), agreement with the mid-edge average at zero angles, thread-count determinism and
//! typed errors on mismatched unknowns.
#![allow(clippy::unwrap_used)]

use faer::sparse::SparseColMat;
use nalgebra::{SymmetricEigen, Vector3};
use thinshell_energy::{
    Assembler, DampingState, DirectorVariant, DofMap, EnergyError, EvalOutput, HessianMode,
    RestState, SffKind, ShellModel, Stencils, Terms,
};
use thinshell_mesh::{EdgeId, Mesh, VertexId, generators};
use thinshell_testkit::fd::dense_symmetric as dense;
use thinshell_testkit::fixtures::soft_material as material;
use thinshell_testkit::rng::SplitMix64;

const ALL: Terms = Terms {
    stretch: true,
    bend: true,
    damping: true,
};

fn model(sff: SffKind, terms: Terms) -> ShellModel {
    ShellModel {
        material: material(),
        terms,
        sff,
    }
}

/// An irregular bumpy sheet (boundary edges included), its rest forms, a perturbed
/// configuration with random angles, and a previous configuration for damping.
struct Case {
    mesh: Mesh,
    rest: RestState,
    x: Vec<Vector3<f64>>,
    phi: Vec<f64>,
    x_prev: Vec<Vector3<f64>>,
    phi_prev: Vec<f64>,
}

fn case(seed: u64, sff: SffKind) -> Case {
    let flat = generators::irregular_rectangle(1.0, 1.0, 4, seed).unwrap();
    let bump: Vec<_> = flat
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x, p.y, 0.3 * (p.x * 2.0).sin() * (p.y * 1.5).cos()))
        .collect();
    let mesh = flat.with_positions(bump).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let mut rng = SplitMix64::new(seed ^ 0xD1EC);
    let x: Vec<_> = mesh
        .positions()
        .iter()
        .map(|p| p + rng.vector3(0.05))
        .collect();
    let x_prev: Vec<_> = mesh
        .positions()
        .iter()
        .map(|p| p + rng.vector3(0.02))
        .collect();
    let phi = (0..mesh.n_edges()).map(|_| 0.2 * rng.signed()).collect();
    let phi_prev = (0..mesh.n_edges()).map(|_| 0.1 * rng.signed()).collect();
    Case {
        mesh,
        rest,
        x,
        phi,
        x_prev,
        phi_prev,
    }
}

/// Full coordinates (positions then angles) → (positions, angles).
fn split(q: &[f64], n_vertices: usize) -> (Vec<Vector3<f64>>, Vec<f64>) {
    let x = q[..3 * n_vertices]
        .chunks(3)
        .map(|c| Vector3::new(c[0], c[1], c[2]))
        .collect();
    (x, q[3 * n_vertices..].to_vec())
}

fn full(x: &[Vector3<f64>], phi: &[f64]) -> Vec<f64> {
    x.iter()
        .flat_map(|p| p.iter().copied())
        .chain(phi.iter().copied())
        .collect()
}

/// Pins vertex 0 completely, vertex 5 in z, and fixes the angles of edges 0 and 7.
fn dofs(mesh: &Mesh) -> DofMap {
    DofMap::with_pinned(
        mesh.n_vertices(),
        [
            (VertexId::new(0), 0),
            (VertexId::new(0), 1),
            (VertexId::new(0), 2),
            (VertexId::new(5), 2),
        ],
    )
    .unwrap()
    .with_edges(mesh.n_edges(), [EdgeId::new(0), EdgeId::new(7)])
    .unwrap()
}

#[test]
fn gradient_and_hessian_match_finite_differences_over_positions_and_angles() {
    for (variant, seed) in [(DirectorVariant::Sin, 3), (DirectorVariant::Tan, 11)] {
        let sff = SffKind::EdgeDirector(variant);
        let c = case(seed, sff);
        let m = model(sff, ALL);
        let damping =
            DampingState::from_configuration(&c.mesh, &c.x_prev, &c.phi_prev, sff, 1e-2).unwrap();
        let d = dofs(&c.mesh);
        let mut asm = Assembler::for_model(&c.mesh, &d, &m).unwrap();
        assert!(asm.has_edge_unknowns());
        assert_eq!(asm.n_free(), d.n_free());
        let nv = c.mesh.n_vertices();
        let n = d.n_coordinates();
        assert_eq!(n, 3 * nv + c.mesh.n_edges());

        let mut energy_at = |q: &[f64]| {
            let (x, phi) = split(q, nv);
            asm.evaluate_with_angles(&m, &x, &phi, &c.rest, Some(&damping), EvalOutput::default())
                .unwrap()
                .total()
        };
        let q0 = full(&c.x, &c.phi);
        let fd: Vec<f64> = (0..q0.len())
            .map(|i| {
                let (mut qp, mut qm) = (q0.clone(), q0.clone());
                qp[i] += 1e-6;
                qm[i] -= 1e-6;
                (energy_at(&qp) - energy_at(&qm)) / 2e-6
            })
            .collect();
        let mut asm = Assembler::for_model(&c.mesh, &d, &m).unwrap();
        let mut g = vec![0.0; n];
        let mut h = asm.hessian_template();
        asm.evaluate_with_angles(
            &m,
            &c.x,
            &c.phi,
            &c.rest,
            Some(&damping),
            EvalOutput {
                gradient: Some(&mut g),
                hessian: Some((&mut h, HessianMode::Exact)),
            },
        )
        .unwrap();
        let gscale = g.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        // Angle gradients must be non-trivial for the check to mean anything.
        assert!(g[3 * nv..].iter().any(|v| v.abs() > 1e-3 * gscale));
        for (i, (a, b)) in g.iter().zip(&fd).enumerate() {
            assert!(
                (a - b).abs() <= 1e-6 * gscale,
                "{variant:?} coordinate {i}: analytic {a}, finite difference {b}"
            );
        }

        // Hessian over the free dofs against differences of the free gradient.
        let free = d.free_coordinates().to_vec();
        let mut grad_free = |q: &[f64]| {
            let (x, phi) = split(q, nv);
            let mut g = vec![0.0; n];
            asm.evaluate_with_angles(
                &m,
                &x,
                &phi,
                &c.rest,
                Some(&damping),
                EvalOutput {
                    gradient: Some(&mut g),
                    hessian: None,
                },
            )
            .unwrap();
            free.iter().map(|&k| g[k]).collect::<Vec<_>>()
        };
        let hd = dense(&h);
        let hscale = hd.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let eps = 1e-6;
        for (col, &k) in free.iter().enumerate().step_by(5) {
            let mut qp = q0.clone();
            qp[k] += eps;
            let mut qm = q0.clone();
            qm[k] -= eps;
            let (gp, gm) = (grad_free(&qp), grad_free(&qm));
            for row in 0..free.len() {
                let fdh = (gp[row] - gm[row]) / (2.0 * eps);
                assert!(
                    (fdh - hd[(row, col)]).abs() <= 1e-5 * hscale,
                    "{variant:?} H[{row},{col}]: analytic {}, finite difference {fdh}",
                    hd[(row, col)]
                );
            }
        }
    }
}

#[test]
fn gauss_newton_and_projected_hessians_are_psd() {
    let sff = SffKind::EdgeDirector(DirectorVariant::Tan);
    let c = case(5, sff);
    let m = model(
        sff,
        Terms {
            damping: false,
            ..ALL
        },
    );
    let d = dofs(&c.mesh);
    let mut asm = Assembler::for_model(&c.mesh, &d, &m).unwrap();
    let mut exact = asm.hessian_template();
    let mut g = vec![0.0; d.n_coordinates()];
    asm.evaluate_with_angles(
        &m,
        &c.x,
        &c.phi,
        &c.rest,
        None,
        EvalOutput {
            gradient: Some(&mut g),
            hessian: Some((&mut exact, HessianMode::Exact)),
        },
    )
    .unwrap();
    let min_eig = |h: &SparseColMat<usize, f64>| {
        let e = SymmetricEigen::new(dense(h)).eigenvalues;
        let scale = e.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        e.iter().fold(f64::INFINITY, |s, v| s.min(*v)) / scale
    };
    // The perturbed configuration is far from equilibrium: the exact Hessian is indefinite,
    // so the PSD checks below are not vacuous.
    assert!(min_eig(&exact) < -1e-6, "{}", min_eig(&exact));
    for mode in [HessianMode::GaussNewton, HessianMode::ProjectedPsd] {
        let mut h = asm.hessian_template();
        asm.evaluate_with_angles(
            &m,
            &c.x,
            &c.phi,
            &c.rest,
            None,
            EvalOutput {
                gradient: None,
                hessian: Some((&mut h, mode)),
            },
        )
        .unwrap();
        assert!(min_eig(&h) > -1e-12, "{mode:?}: {}", min_eig(&h));
    }
}

/// Away from fitted free edges (model.md §1.2) the sin variant at φ = 0 is the mid-edge average:
/// equal face energies on every face without a fitted free edge and equal gradients on every
/// vertex outside those faces' stencils. (On a fitted free edge the director is the extrapolated
/// one, the average's is the face normal.)
#[test]
fn sin_at_zero_angles_equals_the_mid_edge_average() {
    let c = case(9, SffKind::MidEdgeAverage);
    let terms = Terms {
        damping: false,
        ..ALL
    };
    let avg = model(SffKind::MidEdgeAverage, terms);
    let sin = model(SffKind::EdgeDirector(DirectorVariant::Sin), terms);
    let nv = c.mesh.n_vertices();
    let d_avg = DofMap::all_free(nv);
    let d_sin = DofMap::all_free(nv)
        .with_edges(c.mesh.n_edges(), [])
        .unwrap();
    let mut a_avg = Assembler::new(&c.mesh, &d_avg, terms).unwrap();
    let mut a_sin = Assembler::for_model(&c.mesh, &d_sin, &sin).unwrap();
    let mut g_avg = vec![0.0; 3 * nv];
    let mut g_sin = vec![0.0; d_sin.n_coordinates()];
    let e_avg = a_avg
        .evaluate(
            &avg,
            &c.x,
            &c.rest,
            None,
            EvalOutput {
                gradient: Some(&mut g_avg),
                hessian: None,
            },
        )
        .unwrap();
    let zeros = vec![0.0; c.mesh.n_edges()];
    let e_sin = a_sin
        .evaluate_with_angles(
            &sin,
            &c.x,
            &zeros,
            &c.rest,
            None,
            EvalOutput {
                gradient: Some(&mut g_sin),
                hessian: None,
            },
        )
        .unwrap();
    assert_eq!(e_avg.stretch, e_sin.stretch);
    let stencils = Stencils::new(&c.mesh);
    let fitted: Vec<bool> = (0..c.mesh.n_faces())
        .map(|f| stencils.ghost(f).contains(&true))
        .collect();
    assert!(fitted.contains(&true) && fitted.contains(&false));
    let mut near_fit = vec![false; nv];
    for f in (0..c.mesh.n_faces()).filter(|&f| fitted[f]) {
        for v in stencils.vertices(f) {
            near_fit[v.idx()] = true;
        }
    }
    let (fa, fs) = (a_avg.face_energies(), a_sin.face_energies());
    for f in (0..c.mesh.n_faces()).filter(|&f| !fitted[f]) {
        let (ea, es) = (fa[f].bend, fs[f].bend);
        assert!(
            (ea - es).abs() <= 1e-12 * e_avg.bend,
            "face {f}: {ea} vs {es}"
        );
    }
    let scale = g_avg.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    for (i, (a, b)) in g_avg.iter().zip(&g_sin[..3 * nv]).enumerate() {
        if !near_fit[i / 3] {
            assert!((a - b).abs() <= 1e-11 * scale, "{a} vs {b}");
        }
    }
}

#[test]
fn bit_identical_for_any_thread_count() {
    let sff = SffKind::EdgeDirector(DirectorVariant::Sin);
    let c = case(2, sff);
    let m = model(sff, ALL);
    let damping =
        DampingState::from_configuration(&c.mesh, &c.x_prev, &c.phi_prev, sff, 1e-2).unwrap();
    let d = dofs(&c.mesh);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut asm = Assembler::for_model(&c.mesh, &d, &m).unwrap();
            let mut g = vec![0.0; d.n_coordinates()];
            let mut h = asm.hessian_template();
            let e = asm
                .evaluate_with_angles(
                    &m,
                    &c.x,
                    &c.phi,
                    &c.rest,
                    Some(&damping),
                    EvalOutput {
                        gradient: Some(&mut g),
                        hessian: Some((&mut h, HessianMode::Exact)),
                    },
                )
                .unwrap();
            let bits: Vec<u64> = std::iter::once(e.total())
                .chain(g)
                .chain(h.val().iter().copied())
                .map(f64::to_bits)
                .collect();
            bits
        })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

#[test]
fn mismatched_edge_unknowns_are_typed_errors() {
    let sff = SffKind::EdgeDirector(DirectorVariant::Sin);
    let c = case(4, sff);
    let m = model(sff, ALL);
    let nv = c.mesh.n_vertices();
    // A director model needs edge angles in the dof map.
    let e = Assembler::for_model(&c.mesh, &DofMap::all_free(nv), &m).unwrap_err();
    assert!(matches!(e, EnergyError::EdgeUnknownsMismatch { .. }), "{e}");
    // A position-only assembler refuses a director model.
    let mut plain = Assembler::new(&c.mesh, &DofMap::all_free(nv), ALL).unwrap();
    let e = plain
        .evaluate(&m, &c.x, &c.rest, None, EvalOutput::default())
        .unwrap_err();
    assert!(e.to_string().contains("edge_director") || e.to_string().contains("EdgeDirector"));
    // Angles of the wrong length.
    let d = DofMap::all_free(nv)
        .with_edges(c.mesh.n_edges(), [])
        .unwrap();
    let mut asm = Assembler::for_model(&c.mesh, &d, &m).unwrap();
    let damping = DampingState::from_positions(&c.mesh, &c.x_prev, sff, 1e-2).unwrap();
    let e = asm
        .evaluate_with_angles(
            &m,
            &c.x,
            &c.phi[1..],
            &c.rest,
            Some(&damping),
            EvalOutput::default(),
        )
        .unwrap_err();
    assert!(matches!(e, EnergyError::LengthMismatch { .. }), "{e}");
    // A fixed edge out of range.
    let e = DofMap::all_free(nv)
        .with_edges(c.mesh.n_edges(), [EdgeId::new(c.mesh.n_edges())])
        .unwrap_err();
    assert!(matches!(e, EnergyError::InvalidEdge { .. }), "{e}");
    // Without bending the angles do not enter: no edge unknowns.
    let no_bend = model(sff, Terms { bend: false, ..ALL });
    let a = Assembler::for_model(&c.mesh, &DofMap::all_free(nv), &no_bend).unwrap();
    assert!(!a.has_edge_unknowns());
}

/// Free-edge fits (model.md §1.2) couple a boundary face to its outer vertices: the assembled
/// Hessian columns of every outer vertex (all free dofs, exact mode, bending only) match
/// differences of the assembled gradient, to 1e-6 of each column's largest entry.
#[test]
fn fitted_outer_vertices_are_in_the_assembled_hessian() {
    let sff = SffKind::EdgeDirector(DirectorVariant::Tan);
    let c = case(5, sff);
    let bend = Terms {
        stretch: false,
        bend: true,
        damping: false,
    };
    let m = model(sff, bend);
    let stencils = Stencils::new(&c.mesh);
    let mut outer: Vec<usize> = (0..c.mesh.n_faces())
        .flat_map(|f| {
            let (g, v) = (stencils.ghost(f), *stencils.vertices(f));
            (0..3).filter(move |&e| g[e]).map(move |e| v[3 + e].idx())
        })
        .collect();
    outer.sort_unstable();
    outer.dedup();
    assert!(!outer.is_empty());
    let nv = c.mesh.n_vertices();
    let d = DofMap::all_free(nv)
        .with_edges(
            c.mesh.n_edges(),
            thinshell_energy::fitted_free_edges(&c.mesh),
        )
        .unwrap();
    let mut asm = Assembler::for_model(&c.mesh, &d, &m).unwrap();
    let n = d.n_coordinates();
    let mut g = vec![0.0; n];
    let mut h = asm.hessian_template();
    asm.evaluate_with_angles(
        &m,
        &c.x,
        &c.phi,
        &c.rest,
        None,
        EvalOutput {
            gradient: Some(&mut g),
            hessian: Some((&mut h, HessianMode::Exact)),
        },
    )
    .unwrap();
    let hd = dense(&h);
    let free = d.free_coordinates().to_vec();
    let q0 = full(&c.x, &c.phi);
    let mut grad_free = |q: &[f64]| {
        let (x, phi) = split(q, nv);
        let mut g = vec![0.0; n];
        asm.evaluate_with_angles(
            &m,
            &x,
            &phi,
            &c.rest,
            None,
            EvalOutput {
                gradient: Some(&mut g),
                hessian: None,
            },
        )
        .unwrap();
        free.iter().map(|&k| g[k]).collect::<Vec<_>>()
    };
    let eps = 1e-6;
    for &v in &outer {
        for axis in 0..3 {
            let k = 3 * v + axis;
            let col = free.iter().position(|&c| c == k).unwrap();
            let (mut qp, mut qm) = (q0.clone(), q0.clone());
            qp[k] += eps;
            qm[k] -= eps;
            let (gp, gm) = (grad_free(&qp), grad_free(&qm));
            let fd: Vec<f64> = (0..free.len())
                .map(|r| (gp[r] - gm[r]) / (2.0 * eps))
                .collect();
            let scale = fd.iter().fold(0.0f64, |s, x| s.max(x.abs()));
            assert!(scale > 0.0);
            for (row, f) in fd.iter().enumerate() {
                assert!(
                    (f - hd[(row, col)]).abs() <= 1e-6 * scale,
                    "outer vertex {v} axis {axis}, row {row}: {} vs {f}",
                    hd[(row, col)]
                );
            }
        }
    }
}

/// Clamped edges (model.md §1.3) enter the damping forms as they enter b: with the assembler's
/// own damping state, the Kelvin–Voigt energy of a configuration against itself is 0 on a
/// deformed mesh with clamped boundary edges; the same forms without the clamps (the mesh-only
/// `DampingState::from_configuration`) would charge the clamped faces.
#[test]
fn damping_forms_follow_the_clamps() {
    let sff = SffKind::EdgeDirector(DirectorVariant::Tan);
    let c = case(4, sff);
    let terms = Terms {
        stretch: false,
        bend: true,
        damping: true,
    };
    let m = model(sff, terms);
    let nv = c.mesh.n_vertices();
    let clamped: Vec<EdgeId> = c.mesh.topology().boundary_edges().to_vec();
    let d = DofMap::all_free(nv)
        .with_edges(c.mesh.n_edges(), clamped.iter().copied())
        .unwrap();
    let mut asm = Assembler::for_model(&c.mesh, &d, &m).unwrap();
    asm.clamp_edges(&clamped, c.mesh.positions()).unwrap();
    let own = asm.damping_state(&c.x, &c.phi, sff, 1e-2).unwrap();
    let e_own = asm
        .evaluate_with_angles(&m, &c.x, &c.phi, &c.rest, Some(&own), EvalOutput::default())
        .unwrap()
        .damping;
    let mesh_only = DampingState::from_configuration(&c.mesh, &c.x, &c.phi, sff, 1e-2).unwrap();
    let e_mesh = asm
        .evaluate_with_angles(
            &m,
            &c.x,
            &c.phi,
            &c.rest,
            Some(&mesh_only),
            EvalOutput::default(),
        )
        .unwrap()
        .damping;
    assert!(e_mesh > 0.0, "{e_mesh}");
    assert!(e_own <= 1e-12 * e_mesh, "{e_own} vs {e_mesh}");
}
