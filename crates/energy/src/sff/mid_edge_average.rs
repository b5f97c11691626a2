//! Mid-edge average second fundamental form (model.md §1).
//!
//! Local edge e of face (x0, x1, x2) is opposite vertex e; its neighbour face, in consistent
//! orientation, is (x_{e+2}, x_{e+1}, q_e) with q_e = flap vertex `x[3+e]`. With e1 = x1 − x0,
//! e2 = x2 − x0 and mid-edge unit normals n_e:
//!
//! b11 = 2 (n1 − n0)·e1,  b22 = 2 (n2 − n0)·e2,  b12 = (n1 − n0)·e2 + (n2 − n0)·e1,
//!
//! i.e. b_k = Σ_e n_e·(α_ke e1 + β_ke e2) with the coefficients in [`COEF`].

// Index loops over the stencil's vertex blocks mirror the block formulas in the comments.
#![allow(clippy::needless_range_loop)]

use super::normals::{
    add_cross_hess, cross_normal, cross_pullback_of, normalize_hess, normalize_jac, pull_of, unit,
};
use super::{SecondFundamentalForm, SffDerivatives};
use crate::face_stencil::{EdgeClamp, FaceStencil};
use crate::real::Real;
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};

/// Normalised average of the two unit face normals per interior edge; face normal on a boundary
/// edge, except on a mirror edge (model.md §1.4): there the average with the mirror image, the
/// face normal projected into the symmetry plane, normalised.
#[derive(Clone, Copy, Debug, Default)]
pub struct MidEdgeAverage;

/// (α_ke, β_ke): b_k = Σ_e n_e·(α_ke e1 + β_ke e2), k = (b11, b12, b22), e = local edge.
const COEF: [[(f64, f64); 3]; 3] = [
    [(-2.0, 0.0), (2.0, 0.0), (0.0, 0.0)],
    [(-1.0, -1.0), (0.0, 1.0), (1.0, 0.0)],
    [(0.0, -2.0), (0.0, 0.0), (0.0, 2.0)],
];

/// (A_e, B_e) = Σ_k w_k (α_ke, β_ke): Σ_k w_k b_k = Σ_e n_e·(A_e e1 + B_e e2).
#[inline]
fn edge_weights(w: &Vector3<f64>, e: usize) -> (f64, f64) {
    (0..3).fold((0.0, 0.0), |(a, b), k| {
        (a + w[k] * COEF[k][e].0, b + w[k] * COEF[k][e].1)
    })
}

/// b's entries from the products d1_e = n_e·e1, d2_e = n_e·e2 ([`COEF`] written out:
/// b11 = 2 (n1 − n0)·e1, b12 = (n1 − n0)·e2 + (n2 − n0)·e1, b22 = 2 (n2 − n0)·e2), over any
/// [`Real`] (the per-face form and the batched pass).
#[inline(always)]
pub(crate) fn b_of_products<T: Real>(d1: &[T; 3], d2: &[T; 3]) -> [T; 3] {
    [
        T::cst(2.0) * (d1[1] - d1[0]),
        (d2[1] - d2[0]) + (d1[2] - d1[0]),
        T::cst(2.0) * (d2[2] - d2[0]),
    ]
}

/// The unit normal p of the symmetry plane of boundary edge e when it is a mirror edge.
#[inline]
fn mirror_of(s: &FaceStencil, e: usize) -> Option<Vector3<f64>> {
    match s.clamp[e] {
        Some(EdgeClamp::Mirror(p)) if !s.flap[e] => Some(p),
        _ => None,
    }
}

/// (I − p pᵀ) v: `v` projected into the plane with unit normal `p`.
#[inline]
fn project(p: &Vector3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    v - p * p.dot(v)
}

/// Per mirror edge: (plane normal p, unit n_e, |P n_f|, I − n_e n_eᵀ).
type MirrorEdge = (Vector3<f64>, Vector3<f64>, f64, Matrix3<f64>);

/// Per interior edge: (unit n_e, |n_f + n_g|, unit n_g, |c_g|).
type InteriorEdge = (Vector3<f64>, f64, Vector3<f64>, f64);

/// 3×18 matrix stored as six 3×3 blocks (one per stencil vertex).
type Blocks = [Matrix3<f64>; 6];

/// Vertex-block indices of the triangle (p0, p1, p2) whose normal is the neighbour across edge e.
#[inline]
fn neighbour_blocks(e: usize) -> [usize; 3] {
    [(e + 2) % 3, (e + 1) % 3, 3 + e]
}

/// Adds Jᵀ M J for J given as blocks on `idx` (3×3 each) and symmetric M.
#[inline]
fn add_jt_m_j<const N: usize>(
    h: &mut SMatrix<f64, 18, 18>,
    idx: &[usize; N],
    jac: &[Matrix3<f64>; N],
    m: &Matrix3<f64>,
) {
    for (i, &bi) in idx.iter().enumerate() {
        let left = jac[i].transpose() * m;
        for (j, &bj) in idx.iter().enumerate() {
            let mut v = h.fixed_view_mut::<3, 3>(3 * bi, 3 * bj);
            v += left * jac[j];
        }
    }
}

impl SecondFundamentalForm<18> for MidEdgeAverage {
    /// b from the six products n_e·e1, n_e·e2 (the coefficients `COEF` written out:
    /// b11 = 2 (n1 − n0)·e1, b12 = (n1 − n0)·e2 + (n2 − n0)·e1, b22 = 2 (n2 − n0)·e2), one
    /// reciprocal per normalisation. This is the energy-only path's form, so it is kept lean.
    fn b(&self, s: &FaceStencil) -> Matrix2<f64> {
        let x = &s.x;
        let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
        let (nf, _) = unit(&e1.cross(&e2));
        let mut d1 = [0.0; 3];
        let mut d2 = [0.0; 3];
        for e in 0..3 {
            let n = if s.flap[e] {
                let [i0, i1, i2] = neighbour_blocks(e);
                let (ng, _) = unit(&(x[i1] - x[i0]).cross(&(x[i2] - x[i0])));
                unit(&(nf + ng)).0
            } else if let Some(p) = mirror_of(s, e) {
                unit(&project(&p, &nf)).0
            } else {
                nf
            };
            d1[e] = n.dot(&e1);
            d2[e] = n.dot(&e2);
        }
        let [b11, b12, b22] = b_of_products(&d1, &d2);
        Matrix2::new(b11, b12, b12, b22)
    }

    /// Reverse mode: with p_e = Σ_k w_k (α_ke e1 + β_ke e2), w·b = Σ_e n_e·p_e. The adjoint p_e
    /// of each mid-edge normal is pulled back through the normalisation of n_f + n_g, the
    /// neighbour's normal and its cross product; the face normal's adjoints are summed first and
    /// pulled back once. Costs a few 3×3 matrix-vector products instead of the 3×18 Jacobian.
    fn b_and_weighted_gradient(
        &self,
        s: &FaceStencil,
        weights: &dyn Fn(&Matrix2<f64>) -> Vector3<f64>,
    ) -> (Matrix2<f64>, Vector3<f64>, SVector<f64, 18>) {
        let x = &s.x;
        let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
        let (nf, lf) = unit(&e1.cross(&e2));
        // Interior edges: (s = n_f + n_g, |s|, n_g, |c_g|).
        let mut inner: [Option<InteriorEdge>; 3] = [None; 3];
        // Mirror edges: (plane normal p, |P n_f|).
        let mut mirrored: [Option<(Vector3<f64>, f64)>; 3] = [None; 3];
        let mut n = [nf; 3];
        for e in 0..3 {
            if let Some(p) = mirror_of(s, e) {
                let (ne, ls) = unit(&project(&p, &nf));
                n[e] = ne;
                mirrored[e] = Some((p, ls));
            }
            if s.flap[e] {
                let gi = neighbour_blocks(e);
                let (ng, lg) = unit(&(x[gi[1]] - x[gi[0]]).cross(&(x[gi[2]] - x[gi[0]])));
                let (ne, ls) = unit(&(nf + ng));
                n[e] = ne;
                inner[e] = Some((n[e], ls, ng, lg));
            }
        }
        // b from n_e·e1, n_e·e2 as in `b` ([`COEF`] written out).
        let d1: [f64; 3] = std::array::from_fn(|e| n[e].dot(&e1));
        let d2: [f64; 3] = std::array::from_fn(|e| n[e].dot(&e2));
        let [b11, b12, b22] = b_of_products(&d1, &d2);
        let b = Matrix2::new(b11, b12, b12, b22);
        let w = weights(&b);
        let mut g = SVector::<f64, 18>::zeros();
        let add = |g: &mut SVector<f64, 18>, blk: usize, v: &Vector3<f64>| {
            let mut r = g.fixed_rows_mut::<3>(3 * blk);
            r += v;
        };
        let pull = |m: &Vector3<f64>, len: f64, v: &Vector3<f64>| {
            Vector3::from(pull_of(&(*m).into(), len, &(*v).into()))
        };
        let cross_pullback = |q: [&Vector3<f64>; 3], nu: &Vector3<f64>| {
            cross_pullback_of(
                [&(*q[0]).into(), &(*q[1]).into(), &(*q[2]).into()],
                &(*nu).into(),
            )
            .map(Vector3::from)
        };
        let mut mu_f = Vector3::zeros();
        for e in 0..3 {
            let (ca, cb) = edge_weights(&w, e);
            if ca == 0.0 && cb == 0.0 {
                continue;
            }
            let p = e1 * ca + e2 * cb;
            // Direct dependence of p_e on x0, x1, x2.
            add(&mut g, 0, &(n[e] * -(ca + cb)));
            add(&mut g, 1, &(n[e] * ca));
            add(&mut g, 2, &(n[e] * cb));
            match inner[e] {
                None => match mirrored[e] {
                    // n_e = N(P n_f): pulled back through the normalisation, then P.
                    Some((pl, ls)) => mu_f += project(&pl, &pull(&n[e], ls, &p)),
                    None => mu_f += p,
                },
                Some((m, ls, ng, lg)) => {
                    let mu_s = pull(&m, ls, &p);
                    mu_f += mu_s;
                    let nu = pull(&ng, lg, &mu_s);
                    let gi = neighbour_blocks(e);
                    let dq = cross_pullback([&x[gi[0]], &x[gi[1]], &x[gi[2]]], &nu);
                    for (&blk, v) in gi.iter().zip(&dq) {
                        add(&mut g, blk, v);
                    }
                }
            }
        }
        let nu = pull(&nf, lf, &mu_f);
        for (blk, v) in cross_pullback([&x[0], &x[1], &x[2]], &nu)
            .iter()
            .enumerate()
        {
            add(&mut g, blk, v);
        }
        (b, w, g)
    }

    fn b_derivatives(
        &self,
        s: &FaceStencil,
        hessian: Option<(&Vector3<f64>, &mut SMatrix<f64, 18, 18>)>,
    ) -> SffDerivatives<18> {
        let x = &s.x;
        let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
        let face_idx = [0usize, 1, 2];
        let (cf, jcf) = cross_normal([&x[0], &x[1], &x[2]]);
        let (nf, pf, lf) = normalize_jac(&cf);
        let jnf = [pf * jcf[0], pf * jcf[1], pf * jcf[2]];

        // Per edge: unit normal n_e and its Jacobian blocks; interior-edge data for the Hessian.
        let mut n = [nf; 3];
        let mut jn: [Blocks; 3] = [[Matrix3::zeros(); 6]; 3];
        let mut js: [Blocks; 3] = [[Matrix3::zeros(); 6]; 3];
        struct Interior {
            s_m: Vector3<f64>,
            s_len: f64,
            s_p: Matrix3<f64>,
            g_m: Vector3<f64>,
            g_len: f64,
            g_p: Matrix3<f64>,
            jcg: [Matrix3<f64>; 3],
        }
        let mut interior: [Option<Interior>; 3] = [None, None, None];
        let mut mirrored: [Option<MirrorEdge>; 3] = [None; 3];
        for e in 0..3 {
            if s.flap[e] {
                let gi = neighbour_blocks(e);
                let (cg, jcg) = cross_normal([&x[gi[0]], &x[gi[1]], &x[gi[2]]]);
                let (ng, pg, lg) = normalize_jac(&cg);
                let (sm, ps, ls) = normalize_jac(&(nf + ng));
                n[e] = sm;
                for b in 0..3 {
                    js[e][b] += jnf[b];
                    js[e][gi[b]] += pg * jcg[b];
                }
                for b in 0..6 {
                    jn[e][b] = ps * js[e][b];
                }
                interior[e] = Some(Interior {
                    s_m: sm,
                    s_len: ls,
                    s_p: ps * ls,
                    g_m: ng,
                    g_len: lg,
                    g_p: pg * lg,
                    jcg,
                });
            } else if let Some(p) = mirror_of(s, e) {
                let proj = Matrix3::identity() - p * p.transpose();
                let (sm, ps, ls) = normalize_jac(&(proj * nf));
                n[e] = sm;
                for b in 0..3 {
                    js[e][b] = proj * jnf[b];
                    jn[e][b] = ps * js[e][b];
                }
                mirrored[e] = Some((p, sm, ls, ps * ls));
            } else {
                jn[e][..3].copy_from_slice(&jnf);
            }
        }

        // b and its Jacobian.
        let mut bk = [0.0; 3];
        let mut jac = SMatrix::<f64, 3, 18>::zeros();
        for (k, row) in COEF.iter().enumerate() {
            for (e, &(al, be)) in row.iter().enumerate() {
                if al == 0.0 && be == 0.0 {
                    continue;
                }
                let v = e1 * al + e2 * be;
                bk[k] += n[e].dot(&v);
                let vt = v.transpose();
                for b in 0..6 {
                    let mut r = jac.fixed_view_mut::<1, 3>(k, 3 * b);
                    r += vt * jn[e][b];
                }
                // n_e · dv with v = α e1 + β e2.
                let nt = n[e].transpose();
                let mut r = jac.fixed_view_mut::<1, 3>(k, 0);
                r -= nt * (al + be);
                let mut r = jac.fixed_view_mut::<1, 3>(k, 3);
                r += nt * al;
                let mut r = jac.fixed_view_mut::<1, 3>(k, 6);
                r += nt * be;
            }
        }

        if let Some((w, h)) = hessian {
            // Σ_k w_k b_k = Σ_e n_e·p_e, p_e = A_e e1 + B_e e2 (linear in positions).
            let mut mu_f = Vector3::zeros();
            for e in 0..3 {
                let (ca, cb) = edge_weights(w, e);
                let p = e1 * ca + e2 * cb;
                // Mixed term J_neᵀ J_pe + J_peᵀ J_ne; J_pe blocks: x0 −(A+B) I, x1 A I, x2 B I.
                let cp = [-(ca + cb), ca, cb];
                for b in 0..6 {
                    let jt = jn[e][b].transpose();
                    for (c, &coef) in cp.iter().enumerate() {
                        if coef != 0.0 {
                            let t = jt * coef;
                            let mut v = h.fixed_view_mut::<3, 3>(3 * b, 3 * c);
                            v += t;
                            let mut v = h.fixed_view_mut::<3, 3>(3 * c, 3 * b);
                            v += t.transpose();
                        }
                    }
                }
                match &interior[e] {
                    None => match mirrored[e] {
                        // n_e = N(s), s = P n_f: the normalisation's Hessian on s's
                        // Jacobian, and the adjoint of n_f through P.
                        Some((pl, sm, ls, sp)) => {
                            let hs = normalize_hess(&sm, ls, &p);
                            let jse = [js[e][0], js[e][1], js[e][2]];
                            add_jt_m_j(h, &face_idx, &jse, &hs);
                            mu_f += project(&pl, &(sp * p / ls));
                        }
                        None => mu_f += p,
                    },
                    Some(it) => {
                        // n_e = N(s), s = n_f + n_g.
                        let hs = normalize_hess(&it.s_m, it.s_len, &p);
                        let gi = neighbour_blocks(e);
                        let idx = [0usize, 1, 2, gi[2]];
                        let jse = [js[e][0], js[e][1], js[e][2], js[e][gi[2]]];
                        add_jt_m_j(h, &idx, &jse, &hs);
                        let mu = it.s_p * p / it.s_len;
                        mu_f += mu;
                        // n_g = N(c_g) contracted with μ.
                        let hg = normalize_hess(&it.g_m, it.g_len, &mu);
                        add_jt_m_j(h, &gi, &it.jcg, &hg);
                        let nu = it.g_p * mu / it.g_len;
                        add_cross_hess(h, gi, &nu);
                    }
                }
            }
            // Face normal once, with the accumulated adjoint μ_f.
            let hf = normalize_hess(&nf, lf, &mu_f);
            add_jt_m_j(h, &face_idx, &jcf, &hf);
            let nu = pf * mu_f;
            add_cross_hess(h, face_idx, &nu);
        }

        SffDerivatives {
            b: Matrix2::new(bk[0], bk[1], bk[1], bk[2]),
            jacobian: jac,
        }
    }
}
