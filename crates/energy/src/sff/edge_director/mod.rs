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
//! On a free edge with a fit (`stencil.ghost[i]`, model.md §1.2) θ_i/2 is replaced by
//! atan(II_i^fit / (2 d_i)), II_i^fit the second moment of the quadratic through the six stencil
//! points ([`boundary::fitted_edge_angle`]); on a clamped edge (`stencil.clamp[i]`, §1.3) by the
//! angle from the face normal to the clamp's director about the edge, on a mirror edge (§1.4)
//! likewise with the director in the symmetry plane across the edge. Their derivatives come
//! from dual numbers over the positions relative to x_0 (first order for gradients; for
//! Hessians the fit in two levels, see [`boundary::fitted_edge_angle_hessian`]), φ_i chained
//! by hand.
//!
//! Derivatives are taken per edge over 13 local dofs — the hinge vertices (p0, p1, p2, q) =
//! (x_i, x_{i+1}, x_{i+2}, x_{3+i}) and φ_i — and scattered into the 21 face dofs
//! (18 positions in stencil order, then φ_0, φ_1, φ_2). The dihedral angle's gradient and
//! Hessian are in closed form (`dihedral_derivatives`); the earlier chain rule through the
//! normalised normals is kept in the tests' `reference` module, which checks the closed form.

// Index loops over vertex blocks mirror the block formulas in the comments.
#![allow(clippy::needless_range_loop)]

use super::normals::{add_cross_hess, cross_normal, normalize_jac, skew};
use super::{SecondFundamentalForm, SffDerivatives};
use crate::face_stencil::{EdgeAngles, EdgeClamp, FaceStencil};
use crate::material::dual::{Dual1, DualN, Scalar};
use crate::real::Real;
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};

mod boundary;
pub(crate) use boundary::{fit_quality, fitted_edge_angle};

/// Number of face dofs of the director form: 18 positions, then the three edge angles.
pub const DIRECTOR_DOFS: usize = 21;

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

/// Local position dofs of one edge: the hinge vertices (p0, p1, p2, q), three coordinates each.
/// The edge angle φ_i, the 13th local dof, enters II_i only through α_i and is handled apart.
const POS: usize = 12;
type PVec = SVector<f64, POS>;
type PMat = SMatrix<f64, POS, POS>;
/// Hessian of the altitude: it depends on p0, p1, p2 only.
type M9 = SMatrix<f64, 9, 9>;

/// Adds `m` to the 3×3 block (a, b) of a local matrix.
#[inline]
fn add_block<const N: usize>(h: &mut SMatrix<f64, N, N>, a: usize, b: usize, m: &Matrix3<f64>) {
    let mut v = h.fixed_view_mut::<3, 3>(3 * a, 3 * b);
    v += m;
}

/// Adds `v` to block `a` of a local vector.
#[inline]
fn add_vec<const N: usize>(g: &mut SVector<f64, N>, a: usize, v: &Vector3<f64>) {
    let mut r = g.fixed_rows_mut::<3>(3 * a);
    r += v;
}

/// Altitude d = |c_f| / |p2 − p1| from p0 onto the edge (m), its gradient on the local blocks
/// (p0, p1, p2, q) (zero on q) and, if `hess`, its Hessian on p0, p1, p2:
/// ∇²d = ∇²F/L − (∇F∇Lᵀ + ∇L∇Fᵀ)/L² − F∇²L/L² + 2F∇L∇Lᵀ/L³ for F = |c_f|, L = |p2 − p1|,
/// formed entry by entry on the 9 dofs it depends on.
fn altitude(p: [&Vector3<f64>; 3], hess: bool) -> (f64, PVec, Option<M9>) {
    let (cf, jc) = cross_normal(p);
    let (nf, pf, lf) = normalize_jac(&cf);
    let (eh, pe, le) = normalize_jac(&(p[2] - p[1]));
    let d = lf / le;
    let mut gf = SVector::<f64, 9>::zeros();
    for b in 0..3 {
        add_vec(&mut gf, b, &(jc[b].transpose() * nf));
    }
    let mut gl = SVector::<f64, 9>::zeros();
    add_vec(&mut gl, 1, &-eh);
    add_vec(&mut gl, 2, &eh);
    let le2 = le * le;
    let g9 = gf / le - gl * (lf / le2);
    let mut g = PVec::zeros();
    g.fixed_rows_mut::<9>(0).copy_from(&g9);
    if !hess {
        return (d, g, None);
    }
    // ∇²|c| = Jcᵀ (P/|c|) Jc + the bilinear term of c contracted with ∂|c|/∂c = n.
    let mut hf = M9::zeros();
    add_cross_hess(&mut hf, [0, 1, 2], &nf);
    for a in 0..3 {
        let left = jc[a].transpose() * pf;
        add_block(&mut hf, a, a, &(left * jc[a]));
        for b in a + 1..3 {
            let m = left * jc[b];
            add_block(&mut hf, a, b, &m);
            add_block(&mut hf, b, a, &m.transpose());
        }
    }
    let (inv_l, inv_l2) = (1.0 / le, 1.0 / le2);
    let c_ll = 2.0 * lf * inv_l2 * inv_l;
    let mut h = M9::from_fn(|i, j| {
        hf[(i, j)] * inv_l - (gf[i] * gl[j] + gl[i] * gf[j]) * inv_l2 + gl[i] * gl[j] * c_ll
    });
    // −F∇²L/L², ∇²L = [[P, −P], [−P, P]] on (p1, p2).
    let pl = pe * (lf / le2);
    add_block(&mut h, 1, 1, &-pl);
    add_block(&mut h, 2, 2, &-pl);
    add_block(&mut h, 1, 2, &pl);
    add_block(&mut h, 2, 1, &pl);
    (d, g, Some(h))
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

/// Signed dihedral angle θ = atan2((n_f × n_g)·ê, n_f·n_g) (rad) of the hinge (p0, p1, p2, q),
/// n_f the normal of (p0, p1, p2), n_g of (p2, p1, q), ê = (p2 − p1)/|p2 − p1|.
fn dihedral(p: [&Vector3<f64>; 4]) -> f64 {
    let nf = (p[1] - p[0]).cross(&(p[2] - p[0])).normalize();
    let ng = (p[1] - p[2]).cross(&(p[3] - p[2])).normalize();
    let eh = (p[2] - p[1]).normalize();
    nf.cross(&ng).dot(&eh).atan2(nf.dot(&ng))
}

/// θ with gradient and (if `hess`) Hessian on the local blocks (p0, p1, p2, q), in closed form.
///
/// With the edge e = p2 − p1 (length L), the unnormalised normals N_f = (p1 − p0) × (p2 − p0)
/// and N_g = (p1 − p2) × (q − p2), u_f = L N_f/|N_f|² = n_f/h_f (h_f the altitude from p0, m)
/// and likewise u_g, and the feet of the altitudes at t_f = (p0 − p1)·e/L², t_g = (q − p1)·e/L²
/// along the edge:
///
/// ∇_{p0}θ = −u_f, ∇_qθ = −u_g, ∇_{p1}θ = (1 − t_f) u_f + (1 − t_g) u_g,
/// ∇_{p2}θ = t_f u_f + t_g u_g
///
/// (Bridson et al. 2003 with this sign of θ). The Hessian differentiates these: ∂u/∂p =
/// (I − 2 n nᵀ) L/|N|² ∂N/∂p + u ∂L/∂p ᵀ/L, with ∂N/∂p_k = [p_{k+2} − p_{k+1}]× over the
/// face's vertices in order, ∂L/∂p2 = −∂L/∂p1 = ê, and ∂t_f/∂p0 = e/L², ∂t_f/∂p2 =
/// (p0 − p1 − 2 t_f e)/L², ∂t_f/∂p1 = −∂t_f/∂p0 − ∂t_f/∂p2 (t_g the same with q for p0). The
/// blocks are symmetrised (they are symmetric up to round-off). About 700 flops, against a
/// chain rule through the three normalised vectors (n_f, n_g, ê) that took ~8 000 instructions.
fn dihedral_derivatives(p: [&Vector3<f64>; 4], hess: bool) -> (f64, PVec, Option<PMat>) {
    let nf_raw = (p[1] - p[0]).cross(&(p[2] - p[0]));
    let ng_raw = (p[1] - p[2]).cross(&(p[3] - p[2]));
    let e = p[2] - p[1];
    let (lf, lg, le) = (nf_raw.norm(), ng_raw.norm(), e.norm());
    let (nf, ng, eh) = (nf_raw / lf, ng_raw / lg, e / le);
    let theta = nf.cross(&ng).dot(&eh).atan2(nf.dot(&ng));
    let inv_l2 = 1.0 / (le * le);
    let (kf, kg) = (le / (lf * lf), le / (lg * lg));
    let (uf, ug) = (nf_raw * kf, ng_raw * kg);
    let tf = (p[0] - p[1]).dot(&e) * inv_l2;
    let tg = (p[3] - p[1]).dot(&e) * inv_l2;
    let gb = [
        -uf,
        uf * (1.0 - tf) + ug * (1.0 - tg),
        uf * tf + ug * tg,
        -ug,
    ];
    let mut g = PVec::zeros();
    for (b, v) in gb.iter().enumerate() {
        add_vec(&mut g, b, v);
    }
    if !hess {
        return (theta, g, None);
    }
    // ∂u_f/∂p_b (b = 0, 1, 2) and ∂u_g/∂p_b (b = 1, 2, 3); zero blocks elsewhere.
    let mf = (Matrix3::identity() - nf * nf.transpose() * 2.0) * kf;
    let mg = (Matrix3::identity() - ng * ng.transpose() * 2.0) * kg;
    let (uf_l, ug_l) = (uf * eh.transpose() / le, ug * eh.transpose() / le);
    let du_f = [
        mf * skew(&e),
        mf * skew(&(p[0] - p[2])) - uf_l,
        mf * skew(&(p[1] - p[0])) + uf_l,
        Matrix3::zeros(),
    ];
    let du_g = [
        Matrix3::zeros(),
        mg * skew(&(p[2] - p[3])) - ug_l,
        mg * skew(&(p[3] - p[1])) + ug_l,
        mg * skew(&-e),
    ];
    // ∂t/∂p_b (zero on the other face's apex).
    let (a_f, a_g) = (e * inv_l2, e * inv_l2);
    let c_f = (p[0] - p[1] - e * (2.0 * tf)) * inv_l2;
    let c_g = (p[3] - p[1] - e * (2.0 * tg)) * inv_l2;
    let dt_f = [a_f, -(a_f + c_f), c_f, Vector3::zeros()];
    let dt_g = [Vector3::zeros(), -(a_g + c_g), c_g, a_g];
    let mut h = PMat::zeros();
    for b in 0..4 {
        let (tf_row, tg_row) = (dt_f[b].transpose(), dt_g[b].transpose());
        let rows = [
            -du_f[b],
            du_f[b] * (1.0 - tf) - uf * tf_row + du_g[b] * (1.0 - tg) - ug * tg_row,
            du_f[b] * tf + uf * tf_row + du_g[b] * tg + ug * tg_row,
            -du_g[b],
        ];
        for (a, m) in rows.iter().enumerate() {
            h.fixed_view_mut::<3, 3>(3 * a, 3 * b).copy_from(m);
        }
    }
    let h = (h + h.transpose()) * 0.5;
    (theta, g, Some(h))
}

/// How the director of boundary edge i is prescribed, if it is: held or mirrored.
#[inline]
fn clamp_of(s: &FaceStencil, i: usize) -> Option<EdgeClamp> {
    s.clamp[i].filter(|_| !s.flap[i])
}

/// II_i of a boundary edge (m), its gradient over the 19 local dofs (18 stencil positions, then
/// φ_i) and, if asked, its Hessian.
struct BoundaryMoment {
    v: f64,
    g: SVector<f64, 19>,
    h: Option<SMatrix<f64, 19, 19>>,
}

/// (d_i, β_i) of fitted free edge, clamped or mirror edge i, see [`boundary::fitted_edge_angle`],
/// [`boundary::clamped_edge_angle`] and [`boundary::mirrored_edge_angle`].
fn boundary_angle<T: Scalar>(s: &FaceStencil, i: usize, p: &[[T; 3]; 6]) -> (T, T) {
    match clamp_of(s, i) {
        Some(EdgeClamp::Held(n)) => boundary::clamped_edge_angle(p, i, [n.x, n.y, n.z]),
        Some(EdgeClamp::Mirror(n)) => boundary::mirrored_edge_angle(p, i, [n.x, n.y, n.z]),
        None => boundary::fitted_edge_angle(p, i),
    }
}

/// The stencil positions with the first N coordinates of x_1 … x_5 as dual variables and the
/// rest (x_0 always) constants: the boundary angles depend on differences only, so x_0's
/// derivatives follow from the others'; a clamp depends on the face (N = 6: x_1, x_2), a fit on
/// all six points (N = 15), and fewer variables cost (N/19)² of 19 in every second-order
/// operation.
fn relative_positions<T: Scalar>(
    s: &FaceStencil,
    n: usize,
    var: impl Fn(f64, usize) -> T,
) -> [[T; 3]; 6] {
    std::array::from_fn(|v| {
        std::array::from_fn(|c| {
            let k = (3 * v + c).wrapping_sub(3);
            if v > 0 && k < n {
                var(s.x[v][c], k)
            } else {
                T::cst(s.x[v][c])
            }
        })
    })
}

/// A gradient over x_1 … x_5 relative to x_0 as one over the 18 positions: x_0's entries are
/// minus the sum of the others' (translation invariance).
fn to_positions(g: &RVec) -> SVector<f64, 18> {
    let mut out = SVector::<f64, 18>::zeros();
    out.fixed_rows_mut::<REL>(3).copy_from(g);
    for a in 0..5 {
        let v = out.fixed_rows::<3>(3 + 3 * a).into_owned();
        let mut x0 = out.fixed_rows_mut::<3>(0);
        x0 -= v;
    }
    out
}

/// Relative coordinates of the boundary angles' derivatives (x_1 … x_5 minus x_0).
const REL: usize = 15;
type RVec = SVector<f64, REL>;
type RMat = SMatrix<f64, REL, REL>;

/// (d, ∇d, ∇²d, β, ∇β, ∇²β) of boundary edge i over the 15 relative coordinates, from dual
/// numbers in the first N of them (the others' derivatives are zero); Hessians only if `hess`.
#[allow(clippy::type_complexity)]
fn boundary_angle_derivatives<const N: usize>(
    s: &FaceStencil,
    i: usize,
    hess: bool,
) -> (f64, RVec, Option<RMat>, f64, RVec, Option<RMat>) {
    let pad_g = |g: &SVector<f64, N>| {
        let mut out = RVec::zeros();
        out.fixed_rows_mut::<N>(0).copy_from(g);
        out
    };
    let pad_h = |h: &SMatrix<f64, N, N>| {
        let mut out = RMat::zeros();
        out.fixed_view_mut::<N, N>(0, 0).copy_from(h);
        out
    };
    if hess {
        let p = relative_positions(s, N, DualN::<N>::variable);
        let (d, b) = boundary_angle(s, i, &p);
        let (hd, hb) = (Some(pad_h(&d.h)), Some(pad_h(&b.h)));
        (d.v, pad_g(&d.g), hd, b.v, pad_g(&b.g), hb)
    } else {
        let p = relative_positions(s, N, Dual1::<N>::variable);
        let (d, b) = boundary_angle(s, i, &p);
        (d.v, pad_g(&d.g), None, b.v, pad_g(&b.g), None)
    }
}

impl EdgeDirector {
    /// II_i (m) of fitted free edge, clamped or mirror edge i with its gradient and (if `hess`)
    /// Hessian over the 18 stencil positions and φ_i: II_i = 2 d_i f(α_i), α_i = β_i + σ_i φ_i,
    /// β_i from the fit (free edge) or the angle from the face normal to the prescribed director
    /// (clamp, mirror). d and β come from dual numbers over x_1 … x_5 relative to x_0 (first order
    /// without `hess`); φ_i enters through α only and is chained here:
    /// ∇II = 2 f ∇d + 2 d f′ ∇β, ∇²II = 2 f ∇²d + 2 f′ (∇d ∇βᵀ + ∇β ∇dᵀ) + 2 d f″ ∇β ∇βᵀ +
    /// 2 d f′ ∇²β, ∂II/∂φ = 2 d f′ σ, ∂²II/∂φ∂x = σ (2 f′ ∇d + 2 d f″ ∇β), ∂²II/∂φ² = 2 d f″ σ².
    fn boundary_moment(
        &self,
        s: &FaceStencil,
        angles: &EdgeAngles,
        i: usize,
        hess: bool,
    ) -> BoundaryMoment {
        const R: usize = REL;
        let (d, gd, hd, beta, gb, hb) = match clamp_of(s, i) {
            Some(_) => boundary_angle_derivatives::<6>(s, i, hess),
            None if hess => {
                let x = s.x.map(|v| [v.x, v.y, v.z]);
                let (d, gd, hd, b, gb, hb) = boundary::fitted_edge_angle_hessian(&x, i);
                (d, gd, Some(hd), b, gb, Some(hb))
            }
            None => boundary_angle_derivatives::<REL>(s, i, false),
        };
        let sigma = angles.sigma[i];
        let (f0, f1, f2) = self.variant.eval(beta + sigma * angles.phi[i]);
        let mut g = SVector::<f64, 19>::zeros();
        g.fixed_rows_mut::<18>(0)
            .copy_from(&to_positions(&(gd * (2.0 * f0) + gb * (2.0 * d * f1))));
        g[18] = 2.0 * d * f1 * sigma;
        let h = match (hd, hb) {
            (Some(hd), Some(hb)) => {
                let cross = gd * gb.transpose();
                let hr = hd * (2.0 * f0)
                    + (cross + cross.transpose()) * (2.0 * f1)
                    + gb * gb.transpose() * (2.0 * d * f2)
                    + hb * (2.0 * d * f1);
                let mixed = to_positions(&((gd * (2.0 * f1) + gb * (2.0 * d * f2)) * sigma));
                let mut h = SMatrix::<f64, 19, 19>::zeros();
                // x_0's blocks: minus the block sums over the others' (translation invariance).
                let mut col = SMatrix::<f64, 3, R>::zeros();
                for a in 0..5 {
                    col -= hr.fixed_rows::<3>(3 * a);
                }
                let mut corner = Matrix3::zeros();
                for b in 0..5 {
                    corner -= col.fixed_columns::<3>(3 * b);
                }
                h.fixed_view_mut::<R, R>(3, 3).copy_from(&hr);
                h.fixed_view_mut::<3, R>(0, 3).copy_from(&col);
                h.fixed_view_mut::<R, 3>(3, 0).copy_from(&col.transpose());
                h.fixed_view_mut::<3, 3>(0, 0).copy_from(&corner);
                h.fixed_view_mut::<18, 1>(0, 18).copy_from(&mixed);
                h.fixed_view_mut::<1, 18>(18, 0)
                    .copy_from(&mixed.transpose());
                h[(18, 18)] = 2.0 * d * f2 * sigma * sigma;
                Some(h)
            }
            _ => None,
        };
        BoundaryMoment {
            v: d * f0 * 2.0,
            g,
            h,
        }
    }

    /// II_i (m) of the three local edges.
    fn second_moments(&self, s: &FaceStencil, angles: &EdgeAngles) -> [f64; 3] {
        let x = &s.x;
        let area2 = (x[1] - x[0]).cross(&(x[2] - x[0])).norm();
        let p: [[f64; 3]; 6] = std::array::from_fn(|v| [x[v].x, x[v].y, x[v].z]);
        std::array::from_fn(|i| {
            if !s.flap[i] && (s.ghost[i] || s.clamp[i].is_some()) {
                let (d, beta) = boundary_angle(s, i, &p);
                let sigma_phi = angles.sigma[i] * angles.phi[i];
                return boundary::edge_moment(d, beta, sigma_phi, |a| self.variant.eval(a));
            }
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
    ///
    /// Per edge, with ω_i = Σ_k w_k C_ki (so Σ_k w_k b_k = −Σ_i ω_i II_i) and α's gradient
    /// u = ∇θ/2 on the positions (σ_i on φ_i), −ω_i ∇²II_i is assembled in one 12×12 pass:
    /// −ω_i (2 f ∇²d + 2 f′ (∇d uᵀ + u ∇dᵀ) + 2 d f″ u uᵀ + d f′ ∇²θ), the rank-two part as
    /// v uᵀ + u vᵀ with v = −ω_i (2 f′ ∇d + d f″ u); the φ_i row and column are the same
    /// terms with ∂α/∂φ_i = σ_i. An edge with ω_i = 0 contributes no Hessian and its second
    /// derivatives are not formed.
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
        let (w, mut h) = match hessian {
            Some((w, h)) => (Some(*w), Some(h)),
            None => (None, None),
        };
        let mut ii = [0.0; 3];
        let mut jac = SMatrix::<f64, 3, DIRECTOR_DOFS>::zeros();
        for i in 0..3 {
            let blk = hinge_blocks(i);
            let omega: f64 = w.map_or(0.0, |w| (0..3).map(|k| w[k] * C[k][i]).sum());
            let want_h = h.is_some() && omega != 0.0;
            if !s.flap[i] && (s.ghost[i] || s.clamp[i].is_some()) {
                let d = self.boundary_moment(s, angles, i, want_h);
                ii[i] = d.v;
                for k in 0..3 {
                    if C[k][i] != 0.0 {
                        for l in 0..18 {
                            jac[(k, l)] -= C[k][i] * d.g[l];
                        }
                        jac[(k, 18 + i)] -= C[k][i] * d.g[18];
                    }
                }
                if let (Some(h), Some(dh)) = (h.as_deref_mut(), &d.h) {
                    let dof = |l: usize| if l < 18 { l } else { 18 + i };
                    for r in 0..19 {
                        for c in 0..19 {
                            h[(dof(r), dof(c))] -= omega * dh[(r, c)];
                        }
                    }
                }
                continue;
            }
            let (d, gd, hd) = altitude([&x[blk[0]], &x[blk[1]], &x[blk[2]]], want_h);
            let (theta, gt, ht) = if s.flap[i] {
                dihedral_derivatives([&x[blk[0]], &x[blk[1]], &x[blk[2]], &x[blk[3]]], want_h)
            } else {
                (0.0, PVec::zeros(), None)
            };
            let sigma = angles.sigma[i];
            let alpha = 0.5 * theta + sigma * angles.phi[i];
            let (f0, f1, f2) = self.variant.eval(alpha);
            let u = gt * 0.5;
            ii[i] = 2.0 * d * f0;
            // ∇II_i = 2 f ∇d + 2 d f′ ∇α.
            let gii = gd * (2.0 * f0) + u * (2.0 * d * f1);
            let gphi = 2.0 * d * f1 * sigma;
            let map = local_to_face(i);
            for k in 0..3 {
                if C[k][i] != 0.0 {
                    for l in 0..POS {
                        jac[(k, map[l])] -= C[k][i] * gii[l];
                    }
                    jac[(k, map[POS])] -= C[k][i] * gphi;
                }
            }
            let Some(h) = h.as_deref_mut().filter(|_| want_h) else {
                continue;
            };
            let (c0, c1, c2, c3) = (
                -2.0 * omega * f0,
                -2.0 * omega * f1,
                -2.0 * omega * d * f2,
                -omega * d * f1,
            );
            let v = gd * c1 + u * (0.5 * c2);
            // By 3×3 vertex blocks straight into the face Hessian (the q block of a boundary
            // edge is zero and skipped).
            let n_blocks = if s.flap[i] { 4 } else { 3 };
            for bc in 0..n_blocks {
                let (uc, vc) = (u.fixed_rows::<3>(3 * bc), v.fixed_rows::<3>(3 * bc));
                for br in 0..n_blocks {
                    let (ur, vr) = (u.fixed_rows::<3>(3 * br), v.fixed_rows::<3>(3 * br));
                    let mut m = vr * uc.transpose() + ur * vc.transpose();
                    if let Some(ht) = &ht {
                        m += ht.fixed_view::<3, 3>(3 * br, 3 * bc) * c3;
                    }
                    if let (Some(hd), true) = (&hd, br < 3 && bc < 3) {
                        m += hd.fixed_view::<3, 3>(3 * br, 3 * bc) * c0;
                    }
                    add_block(h, blk[br], blk[bc], &m);
                }
            }
            let p = map[POS];
            for l in 0..POS {
                let val = sigma * (c1 * gd[l] + c2 * u[l]);
                h[(map[l], p)] += val;
                h[(p, map[l])] += val;
            }
            h[(p, p)] += c2 * sigma * sigma;
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
fn local_to_face(i: usize) -> [usize; POS + 1] {
    let blk = hinge_blocks(i);
    std::array::from_fn(|l| {
        if l < POS {
            3 * blk[l / 3] + l % 3
        } else {
            18 + i
        }
    })
}

/// b = −[[II_0 + II_1, II_0], [II_0, II_0 + II_2]].
#[inline]
fn form_of(ii: &[f64; 3]) -> Matrix2<f64> {
    let [b11, b12, b22] = b_of_moments(ii);
    Matrix2::new(b11, b12, b12, b22)
}

/// b's entries (b11, b12, b22) = −(II_0 + II_1, II_0, II_0 + II_2) over any [`Real`] (the
/// per-face form and the batched pass).
#[inline(always)]
pub(crate) fn b_of_moments<T: Real>(ii: &[T; 3]) -> [T; 3] {
    [-(ii[0] + ii[1]), -ii[0], -(ii[0] + ii[2])]
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

#[cfg(test)]
mod reference;

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random number in [−1, 1) (splitmix64 of `k`).
    fn rnd(k: u64) -> f64 {
        let mut z = k.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// The restructured derivatives equal the previous dense formulation (kept in `reference`)
    /// on random curved stencils, random angles, both variants, interior and boundary edges,
    /// with and without Hessian: b and Jacobian to 1e-13, Hessian to 1e-12 of its largest
    /// entry (round-off of differently ordered sums).
    #[test]
    fn fast_matches_reference() {
        let mut k = 0u64;
        let mut next = || {
            k += 1;
            rnd(k)
        };
        for case in 0..400 {
            let base = [
                Vector3::new(0.0, 0.0, 0.0),
                Vector3::new(1.0, 0.0, 0.0),
                Vector3::new(0.4, 0.9, 0.0),
                Vector3::new(1.2, 0.9, 0.3),
                Vector3::new(-0.5, 0.7, -0.2),
                Vector3::new(0.5, -0.8, 0.25),
            ];
            let x: [Vector3<f64>; 6] =
                std::array::from_fn(|v| base[v] + Vector3::new(next(), next(), next()) * 0.15);
            let flap = [case % 5 != 1, case % 7 != 2, case % 3 != 0];
            let angles = EdgeAngles {
                phi: [next() * 0.3, next() * 0.3, next() * 0.3],
                sigma: [1.0, -1.0, if case % 2 == 0 { 1.0 } else { -1.0 }],
            };
            let s = FaceStencil {
                x,
                flap,
                ghost: [false; 3],
                clamp: [None; 3],
                angles,
            };
            let w = Vector3::new(next(), next(), next());
            // Some cases with a zero weight per edge (ω_i = 0 skips its Hessian).
            let w = if case % 11 == 0 {
                Vector3::new(w[0], -w[0], 0.0)
            } else {
                w
            };
            for variant in [DirectorVariant::Sin, DirectorVariant::Tan] {
                let form = EdgeDirector { variant };
                let mut h = SMatrix::<f64, 21, 21>::zeros();
                let d = form.derivatives(&s, &angles, Some((&w, &mut h)));
                let mut h_ref = SMatrix::<f64, 21, 21>::zeros();
                let (b_ref, j_ref) =
                    reference::derivatives(variant, &s, &angles, Some((&w, &mut h_ref)));
                let d0 = form.derivatives(&s, &angles, None);
                let scale = j_ref.abs().max().max(1.0);
                assert!((d.b - b_ref).abs().max() <= 1e-13 * b_ref.abs().max().max(1.0));
                assert!((d.jacobian - j_ref).abs().max() <= 1e-13 * scale);
                assert!((d0.jacobian - j_ref).abs().max() <= 1e-13 * scale);
                let hs = h_ref.abs().max().max(1e-300);
                let err = (h - h_ref).abs().max();
                assert!(err <= 1e-12 * hs, "case {case} {variant:?}: {err} vs {hs}");
            }
        }
    }
}
