//! Mixed second derivatives of the laws in the forms and the rest forms, ∂²W/∂m∂m̄ with
//! m = (a11, a12, a22, b11, b12, b22) and m̄ = (ā11, ā12, ā22, b̄11, b̄12, b̄22): what the
//! adjoint of a static equilibrium needs to differentiate it in its rest forms
//! ([`crate::rest_sensitivity`]).
//!
//! Entry convention: each form is a symmetric 2×2 matrix with the three independent entries
//! (m11, m12, m22) of [`crate::small_matrix::sym_entries`]; a derivative in m12 moves both
//! off-diagonal entries together (the same convention as the laws' gradients).
//!
//! Each law's energy is written once more here over second-order dual numbers in the twelve
//! entries (m, m̄): its rest dependence runs through ā⁻¹, A = √det ā, b̄ and (bilayer) the
//! layers' stress-free metrics, and the dual numbers carry all of it exactly. The laws' own
//! `eval` (fast, in m only) and these functions are tested against each other
//! (`crates/energy/tests/rest_sensitivity.rs`: FD of the law gradient in m̄).

use super::dual::{DualN, Scalar};
use super::{Bilayer, Material};
use crate::terms::Terms;
use nalgebra::{Matrix6, Vector3};

type D = DualN<12>;
type M2 = [[D; 2]; 2];

/// The twelve variables (a, b, ā, b̄) as dual numbers, in that order.
fn variables(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    a_bar: &Vector3<f64>,
    b_bar: &Vector3<f64>,
) -> [D; 12] {
    std::array::from_fn(|i| {
        let v = match i / 3 {
            0 => a[i % 3],
            1 => b[i % 3],
            2 => a_bar[i % 3],
            _ => b_bar[i % 3],
        };
        D::variable(v, i)
    })
}

/// The four forms of the twelve variables, with ā⁻¹ and A = √det ā.
struct Forms {
    am: M2,
    bm: M2,
    abar: M2,
    bbar: M2,
    ai: M2,
    area: D,
}

impl Forms {
    fn new(
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        a_bar: &Vector3<f64>,
        b_bar: &Vector3<f64>,
    ) -> Forms {
        let v = variables(a, b, a_bar, b_bar);
        let abar = sym(&v[6..9]);
        Forms {
            am: sym(&v[0..3]),
            bm: sym(&v[3..6]),
            ai: inv(&abar),
            area: det(&abar).sqrt(),
            abar,
            bbar: sym(&v[9..12]),
        }
    }
}

/// The (m, m̄) block of the 12×12 Hessian.
fn mixed_block(e: &D) -> Matrix6<f64> {
    e.h.fixed_view::<6, 6>(0, 6).into_owned()
}

fn sym(v: &[D]) -> M2 {
    [[v[0], v[1]], [v[1], v[2]]]
}

fn det(m: &M2) -> D {
    m[0][0] * m[1][1] - m[0][1] * m[1][0]
}

fn inv(m: &M2) -> M2 {
    let r = det(m).recip();
    [
        [m[1][1] * r, (m[0][1] * r).scale(-1.0)],
        [(m[1][0] * r).scale(-1.0), m[0][0] * r],
    ]
}

fn mul(p: &M2, q: &M2) -> M2 {
    std::array::from_fn(|i| std::array::from_fn(|j| p[i][0] * q[0][j] + p[i][1] * q[1][j]))
}

fn lin(p: &M2, cp: f64, q: &M2, cq: f64) -> M2 {
    std::array::from_fn(|i| std::array::from_fn(|j| p[i][j].scale(cp) + q[i][j].scale(cq)))
}

fn trace(p: &M2) -> D {
    p[0][0] + p[1][1]
}

/// The SV bilinear form α/2 tr(P) tr(Q) + β tr(PQ) of two general 2×2 matrices (for P = Q,
/// ‖P‖²_SV of `crate::stvk_quadratic`).
fn sv_bilinear(p: &M2, q: &M2, alpha: f64, beta: f64) -> D {
    (trace(p) * trace(q)).scale(0.5 * alpha) + trace(&mul(p, q)).scale(beta)
}

fn ln(x: D) -> D {
    let v = x.value();
    x.apply(v.ln(), 1.0 / v, -1.0 / (v * v))
}

/// ∂²W/∂m∂m̄ of [`StVK`](super::StVK) (rows m, columns m̄).
pub(crate) fn stvk(
    m: &Material,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    a_bar: &Vector3<f64>,
    b_bar: &Vector3<f64>,
    terms: Terms,
) -> Matrix6<f64> {
    let Forms {
        am,
        bm,
        abar,
        bbar,
        ai,
        area,
    } = Forms::new(a, b, a_bar, b_bar);
    let (h, alpha, beta) = (m.thickness, m.alpha(), m.beta());
    let mut e = D::constant(0.0);
    if terms.stretch {
        let s = mul(&ai, &lin(&am, 1.0, &abar, -1.0));
        e = e + (sv_bilinear(&s, &s, alpha, beta) * area).scale(h / 8.0);
    }
    if terms.bend {
        let s = mul(&ai, &lin(&bm, 1.0, &bbar, -1.0));
        e = e + (sv_bilinear(&s, &s, alpha, beta) * area).scale(h * h * h / 24.0);
    }
    mixed_block(&e)
}

/// ∂²W/∂m∂m̄ of [`NeoHookean`](super::NeoHookean) (rows m, columns m̄).
pub(crate) fn neo_hookean(
    m: &Material,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    a_bar: &Vector3<f64>,
    b_bar: &Vector3<f64>,
    terms: Terms,
) -> Matrix6<f64> {
    let Forms {
        am,
        bm,
        abar,
        bbar,
        ai,
        area,
    } = Forms::new(a, b, a_bar, b_bar);
    let (h, alpha, beta) = (m.thickness, m.alpha(), m.beta());
    let mut e = D::constant(0.0);
    if terms.stretch {
        let tr = trace(&mul(&ai, &am));
        let ln_j = (ln(det(&am)) - ln(det(&abar))).scale(0.5);
        let psi =
            (tr - D::constant(2.0) - ln_j.scale(2.0)).scale(beta) + (ln_j * ln_j).scale(alpha);
        e = e + (psi * area).scale(h / 4.0);
    }
    if terms.bend {
        let s = lin(&mul(&inv(&am), &bm), 1.0, &mul(&ai, &bbar), -1.0);
        e = e + (sv_bilinear(&s, &s, alpha, beta) * area).scale(h * h * h / 24.0);
    }
    mixed_block(&e)
}

/// ∂²W/∂m∂m̄ of a [`Bilayer`] (rows m, columns m̄): per layer l, with U_l = a − ā − s_l ā and
/// V = b − b̄, m0 ‖ā⁻¹U_l‖² − 4 m1 ⟨ā⁻¹U_l, ā⁻¹V⟩ + 4 m2 ‖ā⁻¹V‖² in the layer's SV product,
/// times A/8.
pub(crate) fn bilayer(
    layers: &Bilayer,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    a_bar: &Vector3<f64>,
    b_bar: &Vector3<f64>,
    terms: Terms,
) -> Matrix6<f64> {
    let Forms {
        am,
        bm,
        abar,
        bbar,
        ai,
        area,
    } = Forms::new(a, b, a_bar, b_bar);
    let vv = mul(&ai, &lin(&bm, 1.0, &bbar, -1.0));
    let mut e = D::constant(0.0);
    for ([m0, m1, m2], alpha, beta, s) in layers.layers() {
        let u = mul(&ai, &lin(&am, 1.0, &abar, -(1.0 + s)));
        if terms.stretch {
            e = e + sv_bilinear(&u, &u, alpha, beta).scale(m0);
        }
        if terms.bend {
            e = e + sv_bilinear(&vv, &vv, alpha, beta).scale(4.0 * m2);
        }
        if terms.stretch && terms.bend {
            e = e - sv_bilinear(&u, &vv, alpha, beta).scale(4.0 * m1);
        }
    }
    mixed_block(&(e * area).scale(1.0 / 8.0))
}
