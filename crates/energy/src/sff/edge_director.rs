//! Edge-director second fundamental form (model.md §1.1).
//!
//! Every edge carries an angle φ_e (rad) that rotates its normal director about the edge. For
//! local edge i of face f (opposite vertex i, running from x_{i+1} to x_{i+2}):
//!
//! - d_i = |(x1 − x0) × (x2 − x0)| / |x_{i+2} − x_{i+1}|, the altitude from vertex i (m);
//! - θ_i = atan2((n_f × n_g)·ê, n_f·n_g), ê = (x_{i+2} − x_{i+1})/|·|, the signed dihedral
//!   angle (rad) to the neighbour g = (x_{i+2}, x_{i+1}, q_i); 0 on a boundary edge;
//! - α_i = θ_i/2 + σ_i φ_i with σ_i = ±1 the edge's orientation seen from f;
//! - II_i = 2 d_i sin α_i ([`DirectorVariant::Sin`]) or 2 d_i tan α_i ([`DirectorVariant::Tan`]) (m),
//!
//! and b = −[[II_0 + II_1, II_0], [II_0, II_0 + II_2]] (m) in the basis (e1, e2) =
//! (x1 − x0, x2 − x0). With all φ = 0 the sin variant equals [`MidEdgeAverage`](super::MidEdgeAverage).
//!
//! Derivatives are taken per edge over 13 local dofs — the hinge vertices (p0, p1, p2, q) =
//! (x_i, x_{i+1}, x_{i+2}, x_{3+i}) and φ_i — and scattered into the 21 face dofs
//! (18 positions in stencil order, then φ_0, φ_1, φ_2).

// Index loops over vertex blocks mirror the block formulas in the comments.
#![allow(clippy::needless_range_loop)]

use super::mid_edge_average::{cross_normal, normalize_hess, normalize_jac, skew};
use super::{SecondFundamentalForm, SffDerivatives};
use crate::stencil::{EdgeAngles, FaceStencil};
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};

/// Number of face dofs of the director form: 18 positions, then the three edge angles.
pub const DIRECTOR_DOFS: usize = 21;

/// Local dofs of one edge: four hinge vertices (12) and the edge angle.
const LOCAL: usize = 13;
type LVec = SVector<f64, LOCAL>;
type LMat = SMatrix<f64, LOCAL, LOCAL>;

/// How the director angle enters II_i (default `Tan`, see [`SffKind`](super::SffKind)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectorVariant {
    /// II_i = 2 d_i sin α_i (Weischedel's discrete shell; equals the mid-edge average at φ = 0).
    Sin,
    /// II_i = 2 d_i tan α_i (energy barrier as a hinge folds towards 180°).
    Tan,
}

impl DirectorVariant {
    /// (f(α), f′(α), f″(α)) of the variant's angle function.
    #[inline]
    fn eval(self, a: f64) -> (f64, f64, f64) {
        match self {
            DirectorVariant::Sin => {
                let (s, c) = a.sin_cos();
                (s, c, -s)
            }
            DirectorVariant::Tan => {
                let t = a.tan();
                let sec2 = 1.0 + t * t;
                (t, sec2, 2.0 * t * sec2)
            }
        }
    }
}

/// Output of [`EdgeDirector::derivatives`]: b and its Jacobian over the 21 dofs (18 positions,
/// dimensionless; 3 angles, m/rad).
pub type DirectorDerivatives = SffDerivatives<DIRECTOR_DOFS>;

/// Edge-director second fundamental form; as a [`SecondFundamentalForm`] it is evaluated at
/// φ = 0 (where σ does not matter).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EdgeDirector {
    /// sin or tan of the director angle.
    pub variant: DirectorVariant,
}

/// Stencil blocks of the hinge (p0, p1, p2, q) of local edge i.
#[inline]
fn hinge_blocks(i: usize) -> [usize; 4] {
    [i, (i + 1) % 3, (i + 2) % 3, 3 + i]
}

/// C with II-weights b_k = −Σ_i C_ki II_i, k = (b11, b12, b22).
const C: [[f64; 3]; 3] = [[1.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 1.0]];

/// Adds `m` to the 3×3 block (a, b) of a local matrix.
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

/// Adds the Hessian of ν·((p1 − p0) × (p2 − p0)) on local blocks `idx`:
/// ∂²/∂p_a∂p_b = K_ab [ν]×, K = [[0, −1, 1], [1, 0, −1], [−1, 1, 0]].
fn add_cross_hess(h: &mut LMat, idx: [usize; 3], nu: &Vector3<f64>) {
    const K: [[f64; 3]; 3] = [[0.0, -1.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 1.0, 0.0]];
    let s = skew(nu);
    for a in 0..3 {
        for b in 0..3 {
            if K[a][b] != 0.0 {
                add_block(h, idx[a], idx[b], &(s * K[a][b]));
            }
        }
    }
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

/// Signed dihedral angle θ = atan2((n_f × n_g)·ê, n_f·n_g) (rad) of the hinge (p0, p1, p2, q),
/// n_f the normal of (p0, p1, p2), n_g of (p2, p1, q), ê = (p2 − p1)/|p2 − p1|.
fn dihedral(p: [&Vector3<f64>; 4]) -> f64 {
    let nf = (p[1] - p[0]).cross(&(p[2] - p[0])).normalize();
    let ng = (p[1] - p[2]).cross(&(p[3] - p[2])).normalize();
    let eh = (p[2] - p[1]).normalize();
    nf.cross(&ng).dot(&eh).atan2(nf.dot(&ng))
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

impl EdgeDirector {
    /// II_i (m) of the three local edges.
    fn second_moments(&self, s: &FaceStencil, angles: &EdgeAngles) -> [f64; 3] {
        let x = &s.x;
        let area2 = (x[1] - x[0]).cross(&(x[2] - x[0])).norm();
        std::array::from_fn(|i| {
            let [a, b, c, q] = hinge_blocks(i);
            let d = area2 / (x[c] - x[b]).norm();
            let theta = if s.flap[i] {
                dihedral([&x[a], &x[b], &x[c], &x[q]])
            } else {
                0.0
            };
            let alpha = 0.5 * theta + angles.sigma[i] * angles.phi[i];
            2.0 * d * self.variant.eval(alpha).0
        })
    }

    /// b (m) of the face at edge angles `angles`; `s.x[3 + e]` is ignored when `!s.flap[e]`.
    pub fn b_with_angles(&self, s: &FaceStencil, angles: &EdgeAngles) -> Matrix2<f64> {
        let ii = self.second_moments(s, angles);
        form_of(&ii)
    }

    /// b, its Jacobian w.r.t. the 21 dofs (positions in stencil order, then φ_0, φ_1, φ_2) and,
    /// when `hessian` is `Some((w, h))`, ADDS Σ_k w_k ∇²b_k (21×21, w = (w11, w12, w22)) to `h`.
    pub fn derivatives(
        &self,
        s: &FaceStencil,
        angles: &EdgeAngles,
        hessian: Option<(
            &Vector3<f64>,
            &mut SMatrix<f64, DIRECTOR_DOFS, DIRECTOR_DOFS>,
        )>,
    ) -> DirectorDerivatives {
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
            let (f0, f1, f2) = self.variant.eval(alpha);
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
        let mut jac = SMatrix::<f64, 3, DIRECTOR_DOFS>::zeros();
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
        DirectorDerivatives {
            b: form_of(&ii),
            jacobian: jac,
        }
    }
}

/// Face dof of each of the 13 local dofs of edge i (a boundary edge's q block maps onto its
/// flap slot too, where all its derivatives are zero).
#[inline]
fn local_to_face(i: usize) -> [usize; LOCAL] {
    let blk = hinge_blocks(i);
    std::array::from_fn(|l| {
        if l < 12 {
            3 * blk[l / 3] + l % 3
        } else {
            18 + i
        }
    })
}

/// b = −[[II_0 + II_1, II_0], [II_0, II_0 + II_2]].
#[inline]
fn form_of(ii: &[f64; 3]) -> Matrix2<f64> {
    let b12 = -ii[0];
    Matrix2::new(-(ii[0] + ii[1]), b12, b12, -(ii[0] + ii[2]))
}

impl SecondFundamentalForm<DIRECTOR_DOFS> for EdgeDirector {
    fn b(&self, s: &FaceStencil) -> Matrix2<f64> {
        self.b_with_angles(s, &s.angles)
    }

    fn b_derivatives(
        &self,
        s: &FaceStencil,
        hessian: Option<(
            &Vector3<f64>,
            &mut SMatrix<f64, DIRECTOR_DOFS, DIRECTOR_DOFS>,
        )>,
    ) -> DirectorDerivatives {
        self.derivatives(s, &s.angles, hessian)
    }
}
