#![allow(clippy::unwrap_used, clippy::needless_range_loop)]
//! Finite-difference and analytic checks of the per-face kernels.
//! FD: central differences with step h = 1e-6 (positions are O(1)), tolerance 1e-6 relative
//! to the largest entry (FD truncation O(h²) ≈ 1e-12, round-off O(ε/h) ≈ 1e-10).

use nalgebra::{Matrix2, SMatrix, Vector3};
use proptest::prelude::*;
use thinshell_energy::sff::SecondFundamentalForm;
use thinshell_energy::*;
use thinshell_testkit::fd::{fd_gradient, fd_jacobian, rel_err_scaled};
use thinshell_testkit::fixtures::unit_material;
use thinshell_testkit::strategies::{cases_or, rest_strategy, stencil_strategy};

const FD_H: f64 = 1e-6;
const TOL: f64 = 1e-6;

fn flat(s: &FaceStencil) -> Vec<f64> {
    s.x.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
}

fn unflat(s: &FaceStencil, v: &[f64]) -> FaceStencil {
    let mut t = *s;
    for i in 0..6 {
        t.x[i] = Vector3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
    }
    t
}

/// Unit-ish material so that all terms have comparable size.
fn material() -> Material {
    unit_material(0.5)
}

fn b_vec(s: &FaceStencil) -> Vec<f64> {
    let b = MidEdgeAverage.b(s);
    vec![b[(0, 0)], b[(0, 1)], b[(1, 1)]]
}

fn eval(
    s: &FaceStencil,
    r: &FaceRest,
    d: Option<&FaceDamping>,
    t: Terms,
    mode: Option<HessianMode>,
) -> FaceEval {
    let mut out = FaceEval::default();
    eval_face(
        &MidEdgeAverage,
        &material(),
        s,
        r,
        d,
        t,
        Want {
            gradient: true,
            hessian: mode,
        },
        &mut out,
    );
    out
}

fn damping_of(s: &FaceStencil) -> FaceDamping {
    // Previous state: a slightly perturbed copy of the stencil.
    let mut p = *s;
    for (i, v) in p.x.iter_mut().enumerate() {
        *v += Vector3::new(0.01 * i as f64, -0.02, 0.015 * (i % 2) as f64);
    }
    let xs = [p.x[0], p.x[1], p.x[2]];
    FaceDamping {
        a_prev: membrane_strain::first_fundamental_form(&xs),
        b_prev: MidEdgeAverage.b(&p),
        dt: 0.1,
    }
}

/// Stencils of [`stencil_strategy`] whose free edges are mirror edges (model.md §1.4, each with
/// probability 1/2) on a plane through the edge at up to 1 rad from the plane perpendicular to
/// the face.
fn mirror_stencil_strategy() -> impl Strategy<Value = FaceStencil> {
    (
        stencil_strategy(),
        prop::array::uniform3(any::<bool>()),
        prop::array::uniform3(-1.0f64..1.0),
    )
        .prop_map(|(s, coin, tilt)| {
            let n = (s.x[1] - s.x[0]).cross(&(s.x[2] - s.x[0])).normalize();
            FaceStencil {
                clamp: std::array::from_fn(|e| {
                    (!s.flap[e] && coin[e]).then(|| {
                        let edge =
                            nalgebra::Unit::new_normalize(s.x[(e + 2) % 3] - s.x[(e + 1) % 3]);
                        let m = nalgebra::Rotation3::from_axis_angle(&edge, tilt[e]) * n;
                        EdgeClamp::Mirror(edge.cross(&m).normalize())
                    })
                }),
                ..s
            }
        })
}

/// The mid-edge b's Jacobian and contracted Hessian Σ w_k ∇²b_k against central differences
/// (the Hessian as FD of the contracted gradient wᵀJ), its symmetry, and b against `b()`.
fn check_b_derivatives(s: &FaceStencil, w: [f64; 3]) -> Result<(), TestCaseError> {
    let w = Vector3::from(w);
    let mut h = SMatrix::<f64, 18, 18>::zeros();
    let d = MidEdgeAverage.b_derivatives(s, Some((&w, &mut h)));
    let x0 = flat(s);
    let jfd = fd_jacobian(|v| b_vec(&unflat(s, v)), &x0, FD_H);
    // Scale: the whole Jacobian (a row can vanish identically, e.g. b12 on symmetric stencils).
    // With all edges on the boundary b ≡ 0: floor 1e-3 (positions are O(1), FD noise ~1e-11).
    let jscale = jfd.iter().flatten().fold(1e-3f64, |m, v| m.max(v.abs()));
    for k in 0..3 {
        let row: Vec<f64> = (0..18).map(|c| d.jacobian[(k, c)]).collect();
        prop_assert!(rel_err_scaled(&row, &jfd[k], jscale) < TOL, "row {k}");
    }
    let hfd = fd_jacobian(
        |v| {
            let dd = MidEdgeAverage.b_derivatives(&unflat(s, v), None);
            (dd.jacobian.transpose() * w).iter().copied().collect()
        },
        &x0,
        FD_H,
    );
    let hfd: Vec<f64> = hfd.into_iter().flatten().collect();
    let han: Vec<f64> = (0..18)
        .flat_map(|r| (0..18).map(move |c| (r, c)))
        .map(|(r, c)| h[(r, c)])
        .collect();
    prop_assert!(rel_err_scaled(&han, &hfd, 1e-3) < TOL);
    prop_assert!((h - h.transpose()).abs().max() <= 1e-12 * h.abs().max().max(1.0));
    prop_assert!((MidEdgeAverage.b(s) - d.b).abs().max() < 1e-14);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(48)))]

    /// With mirror edges (model.md §1.4): Jacobian and contracted Hessian of b against central
    /// differences, and the bending gradient of the reverse-mode path against the forward one
    /// and FD; the sin edge-director form at φ = 0 is this b (as without mirrors).
    #[test]
    fn mirror_edges_match_fd(s in mirror_stencil_strategy(), r in rest_strategy(), w in prop::array::uniform3(-1.0f64..1.0)) {
        check_b_derivatives(&s, w)?;
        let x0 = flat(&s);
        let t = Terms { stretch: false, bend: true, damping: false };
        let out = eval(&s, &r, None, t, Some(HessianMode::Exact));
        let g = fd_gradient(|v| eval(&unflat(&s, v), &r, None, t, None).energy.total(), &x0, FD_H);
        let floor = 1e-2 * out.energy.total().abs();
        prop_assert!(rel_err_scaled(out.gradient.as_slice(), &g, floor) < TOL);
        let g_only = eval(&s, &r, None, t, None);
        prop_assert!(rel_err_scaled(g_only.gradient.as_slice(), out.gradient.as_slice(), floor) < 1e-10);
        let sin = EdgeDirector { variant: DirectorVariant::Sin };
        let (bs, bm) = (sin.b_with_angles(&s, &EdgeAngles::default()), MidEdgeAverage.b(&s));
        prop_assert!((bs - bm).abs().max() <= 1e-13 * bm.abs().max().max(1e-3), "{bs} vs {bm}");
    }

    /// Jacobian of b and contracted Hessian Σ w_k ∇²b_k vs central differences, all boundary masks.
    #[test]
    fn b_derivatives_match_fd(s in stencil_strategy(), w in prop::array::uniform3(-1.0f64..1.0)) {
        check_b_derivatives(&s, w)?;
    }

    /// eval_face gradient and exact Hessian vs FD for each term alone and all together.
    #[test]
    fn eval_face_matches_fd(s in stencil_strategy(), r in rest_strategy(), which in 0usize..4) {
        let t = match which {
            0 => Terms { stretch: true, bend: false, damping: false },
            1 => Terms { stretch: false, bend: true, damping: false },
            2 => Terms { stretch: false, bend: false, damping: true },
            _ => Terms::ALL,
        };
        let damp = damping_of(&s);
        let out = eval(&s, &r, Some(&damp), t, Some(HessianMode::Exact));
        let x0 = flat(&s);
        let g = fd_gradient(|v| eval(&unflat(&s, v), &r, Some(&damp), t, None).energy.total(), &x0, FD_H);
        // Floor 1e-2·|E| (positions O(1), so derivatives scale like E): a term can be constant,
        // e.g. bending with all edges on the boundary, leaving only FD round-off to compare.
        let floor = 1e-2 * out.energy.total().abs();
        prop_assert!(rel_err_scaled(out.gradient.as_slice(), &g, floor) < TOL);
        // The gradient-only path (reverse mode through b) equals the forward one to round-off.
        let g_only = eval(&s, &r, Some(&damp), t, None);
        prop_assert!(rel_err_scaled(g_only.gradient.as_slice(), out.gradient.as_slice(), floor) < 1e-10);
        prop_assert!((g_only.energy.total() - out.energy.total()).abs() <= 1e-14 * out.energy.total().abs());
        let hfd = fd_jacobian(|v| eval(&unflat(&s, v), &r, Some(&damp), t, None).gradient.iter().copied().collect(), &x0, FD_H);
        let hfd: Vec<f64> = hfd.into_iter().flatten().collect();
        let han: Vec<f64> = (0..18).flat_map(|r| (0..18).map(move |c| (r, c))).map(|(i, j)| out.hessian[(i, j)]).collect();
        prop_assert!(rel_err_scaled(&han, &hfd, floor) < TOL);
        if !t.bend && !t.damping {
            prop_assert!(out.gradient.rows(9, 9).amax() == 0.0);
        }
        // Energies against the SV-norm definition directly (model.md §2), tolerance 1e-12 relative.
        let m = material();
        let (al, be) = (m.alpha(), m.beta());
        let area = r.a_bar.determinant().sqrt();
        let ai = r.a_bar.try_inverse().unwrap();
        let a = membrane_strain::first_fundamental_form(&[s.x[0], s.x[1], s.x[2]]);
        let b = MidEdgeAverage.b(&s);
        let sv = |mm: Matrix2<f64>| { let tr = mm.trace(); 0.5 * al * tr * tr + be * (mm * mm).trace() };
        let h = m.thickness;
        let es = h / 8.0 * sv(ai * a - Matrix2::identity()) * area;
        let eb = h.powi(3) / 24.0 * sv(ai * (b - r.b_bar)) * area;
        let api = damp.a_prev.try_inverse().unwrap();
        let ed = m.viscosity / m.young * damp.dt * (h / 8.0 * sv(api * (a - damp.a_prev) / damp.dt)
            + h.powi(3) / 24.0 * sv(api * (b - damp.b_prev) / damp.dt)) * area;
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1e-300);
        let want_s = if t.stretch { es } else { 0.0 };
        let want_b = if t.bend { eb } else { 0.0 };
        let want_d = if t.damping { ed } else { 0.0 };
        prop_assert!(close(out.energy.stretch, want_s));
        prop_assert!(close(out.energy.bend, want_b));
        prop_assert!(close(out.energy.damping, want_d));
    }

    /// Gauss–Newton Hessian is PSD; equals the exact one when the rest state is the current state.
    #[test]
    fn gauss_newton_psd_and_exact_at_rest(s in stencil_strategy(), r in rest_strategy()) {
        let out = eval(&s, &r, None, Terms::ALL, Some(HessianMode::GaussNewton));
        let ev = out.hessian.symmetric_eigenvalues();
        prop_assert!(ev.min() >= -1e-10 * out.hessian.abs().max());
        let at_rest = FaceRest { a_bar: membrane_strain::first_fundamental_form(&[s.x[0], s.x[1], s.x[2]]), b_bar: MidEdgeAverage.b(&s) };
        let gn = eval(&s, &at_rest, None, Terms::ALL, Some(HessianMode::GaussNewton));
        let ex = eval(&s, &at_rest, None, Terms::ALL, Some(HessianMode::Exact));
        prop_assert!((gn.hessian - ex.hessian).abs().max() <= 1e-10 * ex.hessian.abs().max());
        // Zero energy and gradient at rest (scale: the gradient of a unit perturbation ~ ‖H‖).
        prop_assert!(ex.energy.total().abs() < 1e-14);
        prop_assert!(ex.gradient.amax() < 1e-12 * ex.hessian.abs().max());
        // Projected Hessian is PSD.
        let pp = eval(&s, &r, None, Terms::ALL, Some(HessianMode::ProjectedPsd));
        prop_assert!(pp.hessian.symmetric_eigenvalues().min() >= -1e-10 * pp.hessian.abs().max());
    }

    /// Rigid motions: energy invariant, gradient orthogonal to rigid modes, H·(rigid mode) ≈ 0 at rest.
    #[test]
    fn rigid_invariance(s in stencil_strategy(), r in rest_strategy(), ang in prop::array::uniform3(-3.0f64..3.0), tr in prop::array::uniform3(-2.0f64..2.0)) {
        let rot = nalgebra::Rotation3::new(Vector3::from(ang));
        let mut moved = s;
        for v in moved.x.iter_mut() { *v = rot * *v + Vector3::from(tr); }
        let e0 = eval(&s, &r, None, Terms::ALL, Some(HessianMode::Exact));
        let e1 = eval(&moved, &r, None, Terms::ALL, None);
        prop_assert!((e0.energy.total() - e1.energy.total()).abs() < 1e-10 * e0.energy.total().abs().max(1e-300));
        let at_rest = FaceRest { a_bar: membrane_strain::first_fundamental_form(&[s.x[0], s.x[1], s.x[2]]), b_bar: MidEdgeAverage.b(&s) };
        let er = eval(&s, &at_rest, None, Terms::ALL, Some(HessianMode::Exact));
        for axis in 0..3 {
            let mut tmode = nalgebra::SVector::<f64, 18>::zeros();
            let mut rmode = nalgebra::SVector::<f64, 18>::zeros();
            let mut ax = Vector3::zeros();
            ax[axis] = 1.0;
            for i in 0..6 {
                tmode[3 * i + axis] = 1.0;
                rmode.fixed_rows_mut::<3>(3 * i).copy_from(&ax.cross(&s.x[i]));
            }
            let gs = e0.gradient.amax() * 10.0;
            prop_assert!(e0.gradient.dot(&tmode).abs() < 1e-10 * gs.max(1e-300));
            prop_assert!(e0.gradient.dot(&rmode).abs() < 1e-10 * gs.max(1e-300));
            let hs = er.hessian.abs().max() * 10.0;
            prop_assert!((er.hessian * tmode).amax() < 1e-10 * hs);
            prop_assert!((er.hessian * rmode).amax() < 1e-10 * hs);
        }
    }
}

/// Flat stencil ⇒ b = 0 (round-off tolerance 1e-14).
#[test]
fn flat_gives_zero_b() {
    let x = [
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(1.0, 0.1, 0.0),
        Vector3::new(0.2, 0.9, 0.0),
        Vector3::new(1.1, 1.0, 0.0),
        Vector3::new(-0.8, 0.6, 0.0),
        Vector3::new(0.5, -0.7, 0.0),
    ];
    for mask in 0..8 {
        let s = FaceStencil::new(x, [mask & 1 != 0, mask & 2 != 0, mask & 4 != 0]);
        assert!(MidEdgeAverage.b(&s).abs().max() < 1e-14);
    }
}

/// Sphere of radius r, outward normals: b ≈ −a/r with relative error O(edge length).
#[test]
fn sphere_gives_minus_a_over_r() {
    let r = 2.0;
    let mut errs = vec![];
    for &d in &[0.1, 0.05, 0.025] {
        // Points from (θ, φ) offsets around the equator-ish point, mapped to the sphere.
        let p = |u: f64, v: f64| {
            let (th, ph) = (1.2 + v * d, 0.3 + u * d);
            Vector3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * r
        };
        // Face (0,0),(1,0),(0,1) in (φ, −θ) chosen so the normal points outward; check and flip.
        let mut x = [
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(0.0, -1.0),
            p(1.0, -1.0),
            p(-1.0, 0.0),
            p(1.0, 1.0),
        ];
        let n = (x[1] - x[0]).cross(&(x[2] - x[0]));
        if n.dot(&x[0]) < 0.0 {
            x.swap(1, 2);
            x.swap(4, 5);
        }
        let s = FaceStencil::new(x, [true; 3]);
        let a = membrane_strain::first_fundamental_form(&[x[0], x[1], x[2]]);
        let b = MidEdgeAverage.b(&s);
        errs.push((b + a / r).abs().max() / (a / r).abs().max());
    }
    assert!(errs[2] < 0.05, "{errs:?}");
    assert!(
        errs[2] < errs[0],
        "error must shrink under refinement: {errs:?}"
    );
}

/// Unit cylinder, b̄ = 0: bending energy ≈ (h³/24)(α/2 + β)·√det a (b ≈ diag in the curved direction).
#[test]
fn cylinder_bending_energy_close_to_exact() {
    let d = 0.05;
    let p = |u: f64, v: f64| Vector3::new((u * d).cos(), (u * d).sin(), v * d);
    let mut x = [
        p(0.0, 0.0),
        p(1.0, 0.0),
        p(0.0, 1.0),
        p(1.0, 1.0),
        p(-1.0, 1.0),
        p(1.0, -1.0),
    ];
    if (x[1] - x[0]).cross(&(x[2] - x[0])).dot(&x[0]) < 0.0 {
        x.swap(1, 2);
        x.swap(4, 5);
    }
    let s = FaceStencil::new(x, [true; 3]);
    let a = membrane_strain::first_fundamental_form(&[x[0], x[1], x[2]]);
    let rest = FaceRest {
        a_bar: a,
        b_bar: Matrix2::zeros(),
    };
    let m = material();
    let mut out = FaceEval::default();
    eval_face(
        &MidEdgeAverage,
        &m,
        &s,
        &rest,
        None,
        Terms {
            stretch: false,
            bend: true,
            damping: false,
        },
        Want {
            gradient: false,
            hessian: None,
        },
        &mut out,
    );
    // ā⁻¹b has eigenvalues (−1, 0) on the exact cylinder: ‖·‖²_SV = α/2 + β.
    let exact = m.thickness.powi(3) / 24.0 * (0.5 * m.alpha() + m.beta()) * a.determinant().sqrt();
    let rel = (out.energy.bend - exact).abs() / exact;
    assert!(rel < 0.5, "relative discretisation error {rel}");
}
