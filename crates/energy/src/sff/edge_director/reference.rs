//! The previous edge-director derivatives (dense 13×13 per-edge matrices, composed term by
//! term), kept as a test oracle for the restructured kernel in `edge_director.rs`: both must
//! agree to round-off on random stencils (unit test `fast_matches_reference` there).

#![allow(clippy::needless_range_loop)]

use super::{C, DirectorVariant, hinge_blocks, local_to_face};
use crate::face_stencil::{EdgeAngles, FaceStencil};
use crate::sff::normals::{add_cross_hess, cross_normal, normalize_hess, normalize_jac, skew};
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};

const LOCAL: usize = 13;
type LVec = SVector<f64, LOCAL>;
type LMat = SMatrix<f64, LOCAL, LOCAL>;

#[inline]
fn add_block(h: &mut LMat, a: usize, b: usize, m: &Matrix3<f64>) {
    let mut v = h.fixed_view_mut::<3, 3>(3 * a, 3 * b);
    v += m;
}

/// Adds `v` to block `a` of a local vector.
#[inline]
fn add_vec(g: &mut LVec, a: usize, v: &Vector3<f64>) {
    let mut r = g.fixed_rows_mut::<3>(3 * a);
    r += v;
}

/// Adds the Hessian of the composite w·N(c(p)) for the normal N(c) = c/|c| of the triangle
/// with cross product c = (p1 − p0) × (p2 − p0) on local blocks `idx`: Jcᵀ ∇²N[w] Jc plus
/// the bilinear term of c contracted with ν = (I − n nᵀ) w / |c|.
fn add_normal_hess(
    h: &mut LMat,
    idx: [usize; 3],
    jc: &[Matrix3<f64>; 3],
    n: &Vector3<f64>,
    len: f64,
    p_over_len: &Matrix3<f64>,
    w: &Vector3<f64>,
) {
    let hn = normalize_hess(n, len, w);
    for a in 0..3 {
        let left = jc[a].transpose() * hn;
        for b in 0..3 {
            add_block(h, idx[a], idx[b], &(left * jc[b]));
        }
    }
    add_cross_hess(h, idx, &(p_over_len * w));
}

/// Altitude d = |c_f| / |p2 − p1| from p0 onto the edge (m), with gradient and (if `hess`)
/// Hessian on the local blocks p0, p1, p2:
/// ∇²d = ∇²F/L − (∇F∇Lᵀ + ∇L∇Fᵀ)/L² − F∇²L/L² + 2F∇L∇Lᵀ/L³ for F = |c_f|, L = |p2 − p1|.
fn altitude(p: [&Vector3<f64>; 3], hess: bool) -> (f64, LVec, LMat) {
    let (cf, jc) = cross_normal(p);
    let (nf, pf, lf) = normalize_jac(&cf);
    let (eh, pe, le) = normalize_jac(&(p[2] - p[1]));
    let d = lf / le;
    let mut gf = LVec::zeros();
    for b in 0..3 {
        add_vec(&mut gf, b, &(jc[b].transpose() * nf));
    }
    let mut gl = LVec::zeros();
    add_vec(&mut gl, 1, &-eh);
    add_vec(&mut gl, 2, &eh);
    let g = gf / le - gl * (lf / (le * le));
    let mut h = LMat::zeros();
    if hess {
        // ∇²|c| = Jcᵀ (P/|c|) Jc + the bilinear term of c contracted with ∂|c|/∂c = n.
        let mut hf = LMat::zeros();
        add_cross_hess(&mut hf, [0, 1, 2], &nf);
        for a in 0..3 {
            let left = jc[a].transpose() * pf;
            for b in 0..3 {
                add_block(&mut hf, a, b, &(left * jc[b]));
            }
        }
        let mut hl = LMat::zeros();
        add_block(&mut hl, 1, 1, &pe);
        add_block(&mut hl, 2, 2, &pe);
        add_block(&mut hl, 1, 2, &-pe);
        add_block(&mut hl, 2, 1, &-pe);
        let fgl = gf * gl.transpose();
        h = hf / le - (fgl + fgl.transpose()) / (le * le) - hl * (lf / (le * le))
            + gl * gl.transpose() * (2.0 * lf / (le * le * le));
    }
    (d, g, h)
}
/// θ with gradient and (if `hess`) Hessian on the local blocks (p0, p1, p2, q).
///
/// θ = atan2(S, C) of y = (n_f, n_g, ê) ∈ R⁹ with S = (n_f × n_g)·ê, C = n_f·n_g. Chain rule:
/// ∇θ = Jyᵀ θ_y, ∇²θ = Jyᵀ θ_yy Jy + Σ (θ_y-contracted second derivatives of the three
/// normalisations and two cross products), where
///
/// θ_yy = θ_SS ∇S∇Sᵀ + θ_SC (∇S∇Cᵀ + ∇C∇Sᵀ) + θ_CC ∇C∇Cᵀ + θ_S ∇²S + θ_C ∇²C,
///
/// θ_S = C/r², θ_C = −S/r², θ_SS = −θ_CC = −2SC/r⁴, θ_SC = (S² − C²)/r⁴, r² = S² + C².
fn dihedral_derivatives(p: [&Vector3<f64>; 4], hess: bool) -> (f64, LVec, LMat) {
    let (cf, jcf) = cross_normal([p[0], p[1], p[2]]);
    let (nf, pf, lf) = normalize_jac(&cf);
    let (cg, jcg) = cross_normal([p[2], p[1], p[3]]);
    let (ng, pg, lg) = normalize_jac(&cg);
    let (eh, pe, le) = normalize_jac(&(p[2] - p[1]));
    let s = nf.cross(&ng).dot(&eh);
    let c = nf.dot(&ng);
    let theta = s.atan2(c);
    let r2 = s * s + c * c;
    let (ts, tc) = (c / r2, -s / r2);
    // ∇S and ∇C w.r.t. (n_f, n_g, ê).
    let ds = [ng.cross(&eh), eh.cross(&nf), nf.cross(&ng)];
    let dc = [ng, nf, Vector3::zeros()];
    let mu: [Vector3<f64>; 3] = std::array::from_fn(|j| ds[j] * ts + dc[j] * tc);
    // Jy: 9×12, rows (n_f, n_g, ê), columns local blocks p0, p1, p2, q.
    let mut jy = SMatrix::<f64, 9, 12>::zeros();
    let gidx = [2usize, 1, 3];
    for b in 0..3 {
        jy.fixed_view_mut::<3, 3>(0, 3 * b)
            .copy_from(&(pf * jcf[b]));
        let mut v = jy.fixed_view_mut::<3, 3>(3, 3 * gidx[b]);
        v += pg * jcg[b];
    }
    jy.fixed_view_mut::<3, 3>(6, 3).copy_from(&-pe);
    jy.fixed_view_mut::<3, 3>(6, 6).copy_from(&pe);
    let mut ty = SVector::<f64, 9>::zeros();
    for j in 0..3 {
        ty.fixed_rows_mut::<3>(3 * j).copy_from(&mu[j]);
    }
    let g12 = jy.transpose() * ty;
    let mut g = LVec::zeros();
    g.fixed_rows_mut::<12>(0).copy_from(&g12);
    let mut h = LMat::zeros();
    if hess {
        let r4 = r2 * r2;
        let (tss, tsc) = (-2.0 * s * c / r4, (s * s - c * c) / r4);
        let mut vs = SVector::<f64, 9>::zeros();
        let mut vc = SVector::<f64, 9>::zeros();
        for j in 0..3 {
            vs.fixed_rows_mut::<3>(3 * j).copy_from(&ds[j]);
            vc.fixed_rows_mut::<3>(3 * j).copy_from(&dc[j]);
        }
        let sc = vs * vc.transpose();
        let mut tyy =
            (vs * vs.transpose() - vc * vc.transpose()) * tss + (sc + sc.transpose()) * tsc;
        // ∇²S: (n_f, n_g) −[ê]×, (n_f, ê) [n_g]×, (n_g, ê) −[n_f]×; ∇²C: (n_f, n_g) I.
        let hfg = skew(&eh) * -ts + Matrix3::identity() * tc;
        let hfe = skew(&ng) * ts;
        let hge = skew(&nf) * -ts;
        for (a, b, m) in [(0, 1, hfg), (0, 2, hfe), (1, 2, hge)] {
            let mut v = tyy.fixed_view_mut::<3, 3>(3 * a, 3 * b);
            v += m;
            let mut v = tyy.fixed_view_mut::<3, 3>(3 * b, 3 * a);
            v += m.transpose();
        }
        let h12 = jy.transpose() * tyy * jy;
        h.fixed_view_mut::<12, 12>(0, 0).copy_from(&h12);
        add_normal_hess(&mut h, [0, 1, 2], &jcf, &nf, lf, &pf, &mu[0]);
        add_normal_hess(&mut h, gidx, &jcg, &ng, lg, &pg, &mu[1]);
        let he = normalize_hess(&eh, le, &mu[2]);
        add_block(&mut h, 1, 1, &he);
        add_block(&mut h, 2, 2, &he);
        add_block(&mut h, 1, 2, &-he);
        add_block(&mut h, 2, 1, &-he);
    }
    (theta, g, h)
}

/// b, its Jacobian w.r.t. the 21 dofs (positions in stencil order, then φ_0, φ_1, φ_2) and,
/// when `hessian` is `Some((w, h))`, ADDS Σ_k w_k ∇²b_k (21×21, w = (w11, w12, w22)) to `h`.
pub(super) fn derivatives(
    variant: DirectorVariant,
    s: &FaceStencil,
    angles: &EdgeAngles,
    hessian: Option<(&Vector3<f64>, &mut SMatrix<f64, 21, 21>)>,
) -> (Matrix2<f64>, SMatrix<f64, 3, 21>) {
    let x = &s.x;
    let want_h = hessian.is_some();
    let mut ii = [0.0; 3];
    let mut gii = [LVec::zeros(); 3];
    let mut hii = [LMat::zeros(); 3];
    for i in 0..3 {
        let blk = hinge_blocks(i);
        let (d, gd, hd) = altitude([&x[blk[0]], &x[blk[1]], &x[blk[2]]], want_h);
        let (theta, gt, ht) = if s.flap[i] {
            dihedral_derivatives([&x[blk[0]], &x[blk[1]], &x[blk[2]], &x[blk[3]]], want_h)
        } else {
            (0.0, LVec::zeros(), LMat::zeros())
        };
        let sigma = angles.sigma[i];
        let alpha = 0.5 * theta + sigma * angles.phi[i];
        let (f0, f1, f2) = variant.eval(alpha);
        let mut ga = gt * 0.5;
        ga[12] = sigma;
        ii[i] = 2.0 * d * f0;
        gii[i] = gd * (2.0 * f0) + ga * (2.0 * d * f1);
        if want_h {
            let dga = gd * ga.transpose();
            hii[i] = hd * (2.0 * f0)
                + (dga + dga.transpose()) * (2.0 * f1)
                + ga * ga.transpose() * (2.0 * d * f2)
                + ht * (d * f1);
        }
    }
    let mut jac = SMatrix::<f64, 3, 21>::zeros();
    for i in 0..3 {
        let map = local_to_face(i);
        for k in 0..3 {
            if C[k][i] != 0.0 {
                for (l, &gdof) in map.iter().enumerate() {
                    jac[(k, gdof)] -= C[k][i] * gii[i][l];
                }
            }
        }
    }
    if let Some((w, h)) = hessian {
        for i in 0..3 {
            // Σ_k w_k b_k = −Σ_i ω_i II_i, ω_i = Σ_k w_k C_ki.
            let omega: f64 = (0..3).map(|k| w[k] * C[k][i]).sum();
            if omega == 0.0 {
                continue;
            }
            let map = local_to_face(i);
            for (l, &gl) in map.iter().enumerate() {
                for (m, &gm) in map.iter().enumerate() {
                    h[(gl, gm)] -= omega * hii[i][(l, m)];
                }
            }
        }
    }
    (
        Matrix2::new(-(ii[0] + ii[1]), -ii[0], -ii[0], -(ii[0] + ii[2])),
        jac,
    )
}
