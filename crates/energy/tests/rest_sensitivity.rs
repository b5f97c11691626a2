#![allow(clippy::unwrap_used)]
//! The rest-form mixed derivatives ∂²E/∂x∂m̄ (crate::rest_sensitivity) against central
//! differences of the gradients in the rest-form entries m̄ = (ā11, ā12, ā22, b̄11, b̄12, b̄22)
//! (ā12 moves both off-diagonal entries): per law, per face for every form × material, and the
//! whole-mesh product with pins and a clamped edge. Step 1e-6 on O(1) entries;
//! tolerance 1e-6 relative to the largest entry (truncation ~1e-12, round-off ~1e-10).

use nalgebra::{Matrix2, Matrix6, SMatrix, Vector3};
use proptest::prelude::*;
use thinshell_energy::small_matrix::{inv2, sym_entries};
use thinshell_energy::*;
use thinshell_mesh::{EdgeId, VertexId, generators};
use thinshell_testkit::fd::{fd_jacobian, rel_err_scaled};
use thinshell_testkit::fixtures::unit_material;
use thinshell_testkit::strategies::{cases_or, rest_strategy, stencil_strategy};

const FD_H: f64 = 1e-6;
const TOL: f64 = 1e-6;

/// The three laws: StVK, neo-Hookean and a bilayer with unequal layers and eigenstrains.
fn materials() -> [Material; 3] {
    let m = unit_material(0.0);
    let bottom = Layer {
        thickness: 0.12,
        young: 1.3,
        poisson: 0.25,
        eigenstrain: 0.04,
    };
    let top = Layer {
        thickness: 0.18,
        young: 0.8,
        poisson: 0.35,
        eigenstrain: -0.03,
    };
    [
        m,
        m.with_model(MaterialModel::NeoHookean),
        Material::bilayer(bottom, top, 1.0, 0.0),
    ]
}

fn forms() -> [SffKind; 3] {
    SffKind::ALL
}

fn rest_of(v: &[f64]) -> FaceRest {
    FaceRest {
        a_bar: Matrix2::new(v[0], v[1], v[1], v[2]),
        b_bar: Matrix2::new(v[3], v[4], v[4], v[5]),
    }
}

fn rest_vec(r: &FaceRest) -> Vec<f64> {
    let (a, b) = (sym_entries(&r.a_bar), sym_entries(&r.b_bar));
    vec![a[0], a[1], a[2], b[0], b[1], b[2]]
}

/// The law's (∂W/∂a, ∂W/∂b) at forms (a, b) and rest entries `r`.
fn law_gradient(m: &Material, a: &Vector3<f64>, b: &Vector3<f64>, r: &[f64]) -> Vec<f64> {
    let rest = rest_of(r);
    let face = FaceGeometry {
        a_bar: sym_entries(&rest.a_bar),
        b_bar: sym_entries(&rest.b_bar),
        a_bar_inv: inv2(&rest.a_bar),
        area: rest.a_bar.determinant().sqrt(),
    };
    let mut le = LawEval::default();
    m.model
        .law()
        .eval(m, &face, a, b, Terms::ELASTIC, Order::Gradient, &mut le);
    le.ga.iter().chain(le.gb.iter()).copied().collect()
}

fn check_matrix(exact: &[Vec<f64>], fd: &[Vec<f64>], what: &str) -> Result<(), TestCaseError> {
    let scale = fd.iter().flatten().fold(1e-6f64, |m, v| m.max(v.abs()));
    for (i, (e, f)) in exact.iter().zip(fd).enumerate() {
        prop_assert!(
            rel_err_scaled(e, f, scale) < TOL,
            "{what}: row {i}: exact {e:?} fd {f:?}"
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(24)))]

    /// ∂²W/∂m∂m̄ of every law against FD of its gradient in m̄ (with stretching, bending and,
    /// for the bilayer and neo-Hookean, the a–b coupling).
    #[test]
    fn law_rest_mixed_matches_fd(
        rest in rest_strategy(),
        da in prop::array::uniform3(-0.2f64..0.2),
        b in prop::array::uniform3(-1.0f64..1.0),
    ) {
        let r0 = rest_vec(&rest);
        let a = Vector3::new(r0[0] + da[0], r0[1] + da[1], r0[2] + da[2]);
        let b = Vector3::from(b);
        for m in materials() {
            let exact: Matrix6<f64> = m
                .model
                .law()
                .rest_mixed(&m, &a, &b, &Vector3::new(r0[0], r0[1], r0[2]),
                    &Vector3::new(r0[3], r0[4], r0[5]), Terms::ELASTIC)
                .unwrap();
            // fd[i][j] = ∂g_i/∂m̄_j.
            let fd = fd_jacobian(|v| law_gradient(&m, &a, &b, v), &r0, FD_H);
            let fd_rows = fd;
            let exact_rows: Vec<Vec<f64>> =
                (0..6).map(|i| (0..6).map(|j| exact[(i, j)]).collect()).collect();
            check_matrix(&exact_rows, &fd_rows, m.model.name())?;
        }
    }

    /// ∂²E_face/∂x∂m̄ for every form × material against FD of eval_face's gradient in m̄,
    /// on random stencils (any boundary mask) and, for the directors, random edge angles.
    #[test]
    fn face_rest_mixed_matches_fd(
        s in stencil_strategy(),
        rest in rest_strategy(),
        phi in prop::array::uniform3(-0.5f64..0.5),
    ) {
        let r0 = rest_vec(&rest);
        let mut s = s;
        s.angles.phi = phi;
        for m in materials() {
            for sff in forms() {
                match sff.director() {
                    None => check_face::<18, _>(&MidEdgeAverage, &m, &s, &r0, sff)?,
                    Some(d) => check_face::<21, _>(&d, &m, &s, &r0, sff)?,
                }
            }
        }
    }
}

fn check_face<const N: usize, F>(
    form: &F,
    m: &Material,
    s: &FaceStencil,
    r0: &[f64],
    sff: SffKind,
) -> Result<(), TestCaseError>
where
    F: SecondFundamentalForm<N>,
    SMatrix<f64, N, N>: ProjectPsd,
{
    let exact: SMatrix<f64, N, 6> =
        face_rest_mixed(form, m, s, &rest_of(r0), Terms::ELASTIC).unwrap();
    let grad = |v: &[f64]| {
        let mut out = FaceEval::<N>::default();
        let want = Want {
            gradient: true,
            hessian: None,
        };
        eval_face(
            form,
            m,
            s,
            &rest_of(v),
            None,
            Terms::ELASTIC,
            want,
            &mut out,
        );
        out.gradient.iter().copied().collect::<Vec<_>>()
    };
    let fd = fd_jacobian(grad, r0, FD_H);
    // fd[i][j] = ∂g_i/∂m̄_j, row i a face dof.
    let exact_rows: Vec<Vec<f64>> = (0..N)
        .map(|i| (0..6).map(|j| exact[(i, j)]).collect())
        .collect();
    check_matrix(
        &exact_rows,
        &fd,
        &format!("{} {}", m.model.name(), sff.name()),
    )
}

/// The whole-mesh product λᵀ ∂²E/∂x∂m̄ against FD of λ·∇E in each face's rest entries, and
/// against the assembled sparse matrix, on a 4×3 sheet with pinned vertices, a clamped edge
/// (directors), for every form × material.
#[test]
fn assembled_product_matches_fd_and_matrix() {
    let mesh = generators::rectangle(1.0, 0.8, 4, 3).unwrap();
    let nv = mesh.n_vertices();
    // A bent, sheared configuration.
    let x: Vec<Vector3<f64>> = mesh
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x + 0.05 * p.y, p.y, 0.3 * p.x * p.x - 0.2 * p.x * p.y))
        .collect();
    let boundary_edges: Vec<EdgeId> = mesh.topology().boundary_edges().to_vec();
    for m in materials() {
        for sff in forms() {
            let model = ShellModel {
                material: m,
                terms: Terms::ELASTIC,
                sff,
            };
            let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
            let pinned = [VertexId::new(0), VertexId::new(1)];
            let mut dofs = DofMap::with_pinned_vertices(nv, pinned).unwrap();
            let director = model.has_edge_unknowns();
            let clamped = vec![boundary_edges[0]];
            if director {
                let mut fixed = fitted_free_edges(&mesh);
                fixed.extend(clamped.iter().copied());
                fixed.sort();
                fixed.dedup();
                dofs = dofs.with_edges(mesh.n_edges(), fixed).unwrap();
            }
            let mut asm = Assembler::for_model(&mesh, &dofs, &model).unwrap();
            if director {
                asm.clamp_edges(&clamped, mesh.positions()).unwrap();
            }
            let n = asm.n_coordinates();
            let phi: Vec<f64> = (0..asm.n_coordinates() - 3 * nv)
                .map(|e| 0.1 * ((e * 7 % 5) as f64 - 2.0))
                .collect();
            let lambda: Vec<f64> = (0..n)
                .map(|i| {
                    let free = if i < 3 * nv {
                        dofs.coordinate_dof(i).is_some()
                    } else {
                        dofs.edge_dof(EdgeId::new(i - 3 * nv)).is_some()
                    };
                    if free {
                        ((i * 37 % 11) as f64 - 5.0) / 5.0
                    } else {
                        0.0
                    }
                })
                .collect();
            let w = asm
                .rest_adjoint_product(&model, &x, &phi, &rest, &lambda)
                .unwrap();
            let k = asm.rest_mixed_matrix(&model, &x, &phi, &rest).unwrap();
            let dense = dense_general(&k);
            let lambda_dot = |r: &RestState, asm: &mut Assembler| {
                let mut g = vec![0.0; n];
                asm.evaluate_with_angles(
                    &model,
                    &x,
                    &phi,
                    r,
                    None,
                    EvalOutput {
                        gradient: Some(&mut g),
                        hessian: None,
                    },
                )
                .unwrap();
                g.iter().zip(&lambda).map(|(a, b)| a * b).sum::<f64>()
            };
            let mut worst = 0.0f64;
            let mut scale = 1e-9f64;
            for f in [0usize, 5, mesh.n_faces() - 1] {
                for j in 0..6 {
                    let mut fd = 0.0;
                    for sgn in [1.0, -1.0] {
                        let mut r = rest.clone();
                        let (mut a, mut b) = (r.a_bar[f], r.b_bar[f]);
                        let h = FD_H * sgn;
                        match j {
                            0 => a[(0, 0)] += h,
                            1 => {
                                a[(0, 1)] += h;
                                a[(1, 0)] += h
                            }
                            2 => a[(1, 1)] += h,
                            3 => b[(0, 0)] += h,
                            4 => {
                                b[(0, 1)] += h;
                                b[(1, 0)] += h
                            }
                            _ => b[(1, 1)] += h,
                        }
                        r.a_bar[f] = a;
                        r.b_bar[f] = b;
                        fd += sgn * lambda_dot(&r, &mut asm) / (2.0 * FD_H);
                    }
                    let from_matrix: f64 = (0..n).map(|i| dense[(i, 6 * f + j)] * lambda[i]).sum();
                    scale = scale.max(fd.abs());
                    worst = worst
                        .max((w[f][j] - fd).abs())
                        .max((from_matrix - w[f][j]).abs());
                }
            }
            assert!(
                worst < TOL * scale,
                "{} {}: worst {worst:e} scale {scale:e}",
                m.model.name(),
                sff.name()
            );
        }
    }
}

fn dense_general(k: &faer::sparse::SparseColMat<usize, f64>) -> nalgebra::DMatrix<f64> {
    let mut d = nalgebra::DMatrix::zeros(k.nrows(), k.ncols());
    let s = k.symbolic();
    for c in 0..k.ncols() {
        for p in s.col_ptr()[c]..s.col_ptr()[c + 1] {
            d[(s.row_idx()[p], c)] += k.val()[p];
        }
    }
    d
}
