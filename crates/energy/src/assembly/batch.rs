//! The assembler's energy and energy + gradient passes for St. Venant–Kirchhoff with the mid-edge
//! average and with the edge-director forms (model.md §1–2), [`LANES`] faces at a time in
//! structure-of-arrays form.
//!
//! Every quantity of the scalar kernels ([`crate::eval_face_energy`], [`crate::eval_face`] with
//! the gradient: the mid-edge normals or the edge directors' second moments, b, the SV
//! quadratics, the reverse-mode pull-back through the normals or through the altitudes and
//! dihedral angles) is a [`Lanes`] here, one face per lane, so that each arithmetic operation
//! is one SIMD instruction. Lanes never mix: a face's result does not depend on its lane, on
//! the other faces of its batch or on the chunking, and only IEEE-exact operations are used
//! (no fused multiply-add; the edge angles' tan, sin and cos are the scalar libm calls, per
//! lane), so results are bit-identical whatever the instruction set and the thread count.
//! They equal the scalar kernels to round-off (the operation order differs slightly;
//! `tests/batch.rs` checks 1e-13 relative, for the director's gradient scaled by tan's
//! conditioning near a fold).
//! Edge-director faces with a fitted or clamped free edge (dual numbers, model.md §1.2–1.3),
//! and any face whose batched energy or gradient is not finite, are evaluated by the per-face
//! kernel.
//!
//! Branches of the scalar code become selects: a face without a flap across edge e (its
//! stencil slot repeats the opposite face vertex, which makes the neighbour normal's sum
//! vanish) computes the interior-edge quantities anyway and discards them by lane.
//!
//! The instruction set is chosen at run time through `pulp` (AVX2 where the CPU has it, the
//! build's baseline otherwise): the whole chunk loop is inlined into pulp's dispatch, whose
//! target features then apply to the plain array arithmetic below, which LLVM vectorises.

use crate::damping::FaceDamping;
use crate::face_stencil::EdgeAngles;
use crate::kernel::{FaceEval, FaceRest, Want, eval_face, eval_face_energy};
use crate::material::{EnergyConstants, Material, sv_energy_of};
use crate::membrane_strain::{metric_gradient_of, metric_of};
use crate::real::{Real, Vec3, cross, dot};
use crate::rest::{DampingState, RestState};
use crate::sff::edge_director::b_of_moments;
use crate::sff::mid_edge_average::b_of_products;
use crate::sff::normals::{cross_pullback_of, pull_of, unit_of};
use crate::sff::{DIRECTOR_DOFS, DirectorVariant, EdgeDirector};
use crate::stencil_table::Stencils;
use crate::stvk_quadratic::{sv_norm_sq_of, sv_quadratic_times_of};
use crate::terms::{EnergyTerms, Terms};
use nalgebra::{Matrix2, Vector3};
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// Faces per batch: four f64 lanes fill one AVX2 register.
pub(crate) const LANES: usize = 4;

/// Faces per work item of the parallel pass (a multiple of [`LANES`]).
pub(crate) const CHUNK: usize = 64;

/// A chunk's per-face outputs: energies and gradient slots (`grad_stride` entries a face).
pub(crate) type FaceSlots2<'a> = (&'a mut [EnergyTerms], &'a mut [f64]);

/// One f64 per face of a batch.
#[derive(Clone, Copy, Debug)]
struct Lanes([f64; LANES]);

impl Lanes {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Lanes([v; LANES])
    }

    #[inline(always)]
    fn zero() -> Self {
        Lanes([0.0; LANES])
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Lanes(std::array::from_fn(|i| f(self.0[i])))
    }

    /// `a` where `mask`, else `b`, lane by lane.
    #[inline(always)]
    fn select(mask: &[bool; LANES], a: Self, b: Self) -> Self {
        Lanes(std::array::from_fn(
            |i| if mask[i] { a.0[i] } else { b.0[i] },
        ))
    }
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $f(self, o: Lanes) -> Lanes {
                Lanes(std::array::from_fn(|i| self.0[i] $op o.0[i]))
            }
        }
    };
}
lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl Mul<f64> for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn mul(self, o: f64) -> Lanes {
        self * Lanes::splat(o)
    }
}

impl Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        self.map(|v| -v)
    }
}

impl Real for Lanes {
    #[inline(always)]
    fn cst(c: f64) -> Self {
        Lanes::splat(c)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
}

impl AddAssign for Lanes {
    #[inline(always)]
    fn add_assign(&mut self, o: Lanes) {
        *self = *self + o;
    }
}

/// A 3-vector per face of a batch.
#[derive(Clone, Copy, Debug)]
struct V3 {
    x: Lanes,
    y: Lanes,
    z: Lanes,
}

impl V3 {
    #[inline(always)]
    fn zero() -> Self {
        V3 {
            x: Lanes::zero(),
            y: Lanes::zero(),
            z: Lanes::zero(),
        }
    }

    #[inline(always)]
    fn dot(&self, o: &V3) -> Lanes {
        dot(&self.arr(), &o.arr())
    }

    #[inline(always)]
    fn cross(&self, o: &V3) -> V3 {
        V3::from_arr(cross(&self.arr(), &o.arr()))
    }

    #[inline(always)]
    fn scale(&self, s: Lanes) -> V3 {
        V3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    /// (self/|self|, |self|) ([`unit_of`]).
    #[inline(always)]
    fn unit(&self) -> (V3, Lanes) {
        let (m, len) = unit_of(&self.arr());
        (V3::from_arr(m), len)
    }

    #[inline(always)]
    fn norm(&self) -> Lanes {
        self.dot(self).sqrt()
    }

    /// The entries as a [`Vec3`] (for the formulas written over [`Real`]).
    #[inline(always)]
    fn arr(&self) -> Vec3<Lanes> {
        [self.x, self.y, self.z]
    }

    #[inline(always)]
    fn from_arr([x, y, z]: Vec3<Lanes>) -> V3 {
        V3 { x, y, z }
    }

    #[inline(always)]
    fn select(mask: &[bool; LANES], a: &V3, b: &V3) -> V3 {
        V3 {
            x: Lanes::select(mask, a.x, b.x),
            y: Lanes::select(mask, a.y, b.y),
            z: Lanes::select(mask, a.z, b.z),
        }
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

impl AddAssign for V3 {
    #[inline(always)]
    fn add_assign(&mut self, o: V3) {
        *self = *self + o;
    }
}

/// The entries (m11, m12, m22) of a symmetric 2×2 matrix per face.
type Sym = [Lanes; 3];

/// Material constants of the batched kernels (per mesh evaluation).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Constants {
    /// h/8 (m), h³/24 (m³).
    h_8: f64,
    h3_24: f64,
    /// α/2, α, β (Pa).
    half_alpha: f64,
    alpha: f64,
    beta: f64,
    /// (η/E)/Δt (1/s; 0 without damping).
    damping: f64,
}

impl Constants {
    pub(crate) fn new(material: &Material, damping: Option<&DampingState>) -> Self {
        let h = material.thickness;
        Constants {
            h_8: h / 8.0,
            h3_24: h * h * h / 24.0,
            half_alpha: 0.5 * material.alpha(),
            alpha: material.alpha(),
            beta: material.beta(),
            damping: damping.map_or(0.0, |d| material.viscosity / material.young / d.dt),
        }
    }
}

/// Everything a chunk of faces reads.
pub(crate) struct Inputs<'a> {
    pub(crate) constants: Constants,
    /// The second fundamental form.
    pub(crate) form: Form<'a>,
    /// The material and its constants, for faces the batch hands back to the per-face kernel.
    pub(crate) material: &'a Material,
    pub(crate) energy_constants: EnergyConstants,
    pub(crate) terms: Terms,
    pub(crate) stencils: &'a Stencils,
    pub(crate) x: &'a [Vector3<f64>],
    pub(crate) rest: &'a RestState,
    pub(crate) damping: Option<&'a DampingState>,
    /// Vertex slots per face (3, or 6 with flap vertices) and the gradient buffer's stride
    /// (3 per slot: the vertex slots, then with edge unknowns one slot per edge angle).
    pub(crate) slots: usize,
    pub(crate) grad_stride: usize,
}

/// The bending form of a batched pass.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Form<'a> {
    /// [`crate::MidEdgeAverage`].
    MidEdgeAverage,
    /// [`crate::EdgeDirector`] with the edge angles `phi` (rad, one per edge; empty when the
    /// assembler has no edge unknowns: all 0).
    EdgeDirector(DirectorVariant, &'a [f64]),
}

/// One batch's rest (and damping) data: ā⁻¹ entries, A = √det ā, b̄, ā, and per damping
/// a_prev⁻¹, a_prev, b_prev.
struct Rest {
    a_bar: Sym,
    b_bar: Sym,
    a_bar_inv: Sym,
    area: Lanes,
    prev: Option<(Sym, Sym, Sym)>,
}

/// Entries of a symmetric matrix per face, off-diagonal averaged (as `sym_entries`).
#[inline(always)]
fn sym(ms: &[Matrix2<f64>; LANES]) -> Sym {
    let mut out = [Lanes::zero(); 3];
    for (l, m) in ms.iter().enumerate() {
        out[0].0[l] = m[(0, 0)];
        out[1].0[l] = 0.5 * (m[(0, 1)] + m[(1, 0)]);
        out[2].0[l] = m[(1, 1)];
    }
    out
}

/// The entries m00, m01, m10, m11 of each face's matrix, one lane per face.
#[inline(always)]
fn entries(ms: &[Matrix2<f64>; LANES]) -> [Lanes; 4] {
    let mut g = [Lanes::zero(); 4];
    for (l, m) in ms.iter().enumerate() {
        g[0].0[l] = m[(0, 0)];
        g[1].0[l] = m[(0, 1)];
        g[2].0[l] = m[(1, 0)];
        g[3].0[l] = m[(1, 1)];
    }
    g
}

/// Entries (p, q, r) of m⁻¹ per face, q averaged (as `inv2` then `sym_entries`).
#[inline(always)]
fn inv_sym(ms: &[Matrix2<f64>; LANES]) -> Sym {
    let [m00, m01, m10, m11] = entries(ms);
    let det = m00 * m11 - m01 * m10;
    let inv = det.recip();
    [m11 * inv, (-m01 * inv + -m10 * inv) * 0.5, m00 * inv]
}

/// √det m per face, with nalgebra's 2×2 determinant order (m00 m11 − m10 m01), as the scalar
/// kernels' A = √det ā.
#[inline(always)]
fn sqrt_det(ms: &[Matrix2<f64>; LANES]) -> Lanes {
    let [m00, m01, m10, m11] = entries(ms);
    (m00 * m11 - m10 * m01).sqrt()
}

#[inline(always)]
fn sub3(a: &Sym, b: &Sym) -> Sym {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Stencil blocks (p0, p1, p2) of the neighbour across local edge e (`neighbour_blocks`).
const NEIGHBOUR: [[usize; 3]; 3] = [[2, 1, 3], [0, 2, 4], [1, 0, 5]];

/// One batch of faces: positions of the six stencil slots, flap masks per local edge.
struct Batch {
    x: [V3; 6],
    flap: [[bool; LANES]; 3],
    /// Edge-director form, per local edge: tan(σφ) (tan) or sin(σφ) (sin), and cos(σφ) (sin).
    angle: [[Lanes; 2]; 3],
    /// Edge-director form, per local edge: the orientation sign σ (±1).
    sigma: [Lanes; 3],
    /// Faces the batch hands back to the per-face kernel (edge-director faces with a fitted
    /// or clamped free edge, whose director comes from dual numbers).
    special: [bool; LANES],
}

impl Batch {
    fn new() -> Self {
        Batch {
            x: [V3::zero(); 6],
            flap: [[false; LANES]; 3],
            angle: [[Lanes::zero(); 2]; 3],
            sigma: [Lanes::zero(); 3],
            special: [false; LANES],
        }
    }
}

/// The mid-edge normals and b of a batch, with what the reverse pass reuses.
struct Normals {
    /// Unit face normal and |e1 × e2|.
    nf: V3,
    lf: Lanes,
    /// Per edge: mid-edge normal n_e, |n_f + n_g|, unit neighbour normal n_g, |c_g|.
    n: [V3; 3],
    ls: [Lanes; 3],
    ng: [V3; 3],
    lg: [Lanes; 3],
    b: Sym,
}

/// b of the mid-edge average (`MidEdgeAverage::b`, written out per lane).
#[inline(always)]
fn normals(s: &Batch) -> Normals {
    let x = &s.x;
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    let (nf, lf) = e1.cross(&e2).unit();
    let mut n = [nf; 3];
    let mut ls = [Lanes::zero(); 3];
    let mut ng = [nf; 3];
    let mut lg = [Lanes::zero(); 3];
    for e in 0..3 {
        let [i0, i1, i2] = NEIGHBOUR[e];
        (ng[e], lg[e]) = (x[i1] - x[i0]).cross(&(x[i2] - x[i0])).unit();
        let sum;
        (sum, ls[e]) = (nf + ng[e]).unit();
        n[e] = V3::select(&s.flap[e], &sum, &nf);
    }
    let d1: [Lanes; 3] = std::array::from_fn(|e| n[e].dot(&e1));
    let d2: [Lanes; 3] = std::array::from_fn(|e| n[e].dot(&e2));
    let b = b_of_products(&d1, &d2);
    Normals {
        nf,
        lf,
        n,
        ls,
        ng,
        lg,
        b,
    }
}

/// Metric entries (e1·e1, e1·e2, e2·e2) ([`metric_of`]).
#[inline(always)]
fn metric(e1: &V3, e2: &V3) -> Sym {
    metric_of(&e1.arr(), &e2.arr())
}

/// Faces `first + lane` of a chunk of `count` faces (lanes past the end repeat its last face,
/// and are discarded).
#[inline(always)]
fn faces(first: usize, start: usize, count: usize) -> [usize; LANES] {
    std::array::from_fn(|l| first + (start + l).min(count - 1))
}

/// Gathers the stencil positions, flap masks, edge angles and rest (and damping) forms of
/// faces `f`.
#[inline(always)]
fn load(inp: &Inputs<'_>, f: &[usize; LANES], batch: &mut Batch) -> Rest {
    let st = inp.stencils;
    let Batch {
        x,
        flap,
        angle,
        sigma,
        special,
    } = batch;
    let mut a_bar = [Matrix2::zeros(); LANES];
    let mut b_bar = [Matrix2::zeros(); LANES];
    for (l, &fl) in f.iter().enumerate() {
        let v = st.vertices(fl);
        for (s, xs) in x.iter_mut().enumerate() {
            let p = &inp.x[v[s].idx()];
            xs.x.0[l] = p.x;
            xs.y.0[l] = p.y;
            xs.z.0[l] = p.z;
        }
        let fp = st.flap(fl);
        for e in 0..3 {
            flap[e][l] = fp[e];
        }
        a_bar[l] = inp.rest.a_bar[fl];
        b_bar[l] = inp.rest.b_bar[fl];
        if let Form::EdgeDirector(variant, phi) = inp.form {
            special[l] = st.has_boundary_director(fl);
            let ang = if phi.is_empty() {
                EdgeAngles::default()
            } else {
                st.angles(fl, phi)
            };
            for (e, slot) in angle.iter_mut().enumerate() {
                sigma[e].0[l] = ang.sigma[e];
                let a = ang.sigma[e] * ang.phi[e];
                match variant {
                    DirectorVariant::Tan => slot[0].0[l] = a.tan(),
                    DirectorVariant::Sin => {
                        let (sn, cs) = a.sin_cos();
                        slot[0].0[l] = sn;
                        slot[1].0[l] = cs;
                    }
                }
            }
        }
    }
    let prev = inp.damping.map(|d| {
        let mut ap = [Matrix2::zeros(); LANES];
        let mut bp = [Matrix2::zeros(); LANES];
        for (l, &fl) in f.iter().enumerate() {
            ap[l] = d.a_prev[fl];
            bp[l] = d.b_prev[fl];
        }
        (inv_sym(&ap), sym(&ap), sym(&bp))
    });
    Rest {
        a_bar: sym(&a_bar),
        b_bar: sym(&b_bar),
        a_bar_inv: inv_sym(&a_bar),
        area: sqrt_det(&a_bar),
        prev,
    }
}

/// The edge-director form's b with what its reverse pass reuses (`EdgeDirector::b_with_angles`
/// away from fitted and clamped free edges).
struct Director {
    /// Unit face normal n_f and 1/|c_f|, c_f = (x1 − x0) × (x2 − x0).
    nf: V3,
    inv_area2: Lanes,
    edge: [DirectorEdge; 3],
    b: Sym,
}

/// Local edge i (opposite vertex i) of [`Director`]: II_i = 2 d_i f(α_i), α_i = θ_i/2 + σ_i φ_i.
struct DirectorEdge {
    /// Unit edge ê (from x_{i+1} to x_{i+2}), its length L and 1/L, the altitude d = |c_f|/L.
    eh: V3,
    le: Lanes,
    inv_le: Lanes,
    d: Lanes,
    /// Unit neighbour normal n_g and 1/|c_g| (NaN without a flap, discarded by lane).
    ng: V3,
    inv_lg: Lanes,
    /// f(α) and f′(α).
    f: Lanes,
    df: Lanes,
}

/// b of the edge-director form (`EdgeDirector::b_with_angles` away from fitted and clamped
/// free edges): II_i = 2 d_i f(θ_i/2 + σ_i φ_i), b = −[[II_0 + II_1, II_0], [II_0, II_0 + II_2]].
/// The half dihedral angle enters through half-angle identities instead of atan2 (which does
/// not vectorise): with s = (n_f × n_g)·ê, c = n_f·n_g and r = √(s² + c²), r + c (written
/// s²/(r − c) for c < 0, free of cancellation near a fold) gives tan(θ/2) = s/(r + c),
/// cos(θ/2) = √((r + c)/2r) and sin(θ/2) = s/√(2r(r + c)); the addition formulas take the
/// angle's tan, sin and cos from the batch (and f′ = 1 + f² for tan, the cosine of the sum
/// for sin). A hinge folded completely flat (r + c = 0) gives NaN here, and the face goes
/// back to the per-face kernel.
#[inline(always)]
fn director(s: &Batch, variant: DirectorVariant) -> Director {
    let x = &s.x;
    let (nf, area2) = (x[1] - x[0]).cross(&(x[2] - x[0])).unit();
    let inv_area2 = area2.recip();
    // Written out per edge: `from_fn` with this closure is not inlined.
    let edge = [
        director_edge(s, variant, &nf, area2, 0),
        director_edge(s, variant, &nf, area2, 1),
        director_edge(s, variant, &nf, area2, 2),
    ];
    let ii = edge.each_ref().map(|e| e.d * 2.0 * e.f);
    Director {
        nf,
        inv_area2,
        b: b_of_moments(&ii),
        edge,
    }
}

/// Local edge i of [`director`], with the face's unit normal `nf` and |c_f| = `area2`.
#[inline(always)]
fn director_edge(
    s: &Batch,
    variant: DirectorVariant,
    nf: &V3,
    area2: Lanes,
    i: usize,
) -> DirectorEdge {
    let x = &s.x;
    let (b, c, q) = ((i + 1) % 3, (i + 2) % 3, 3 + i);
    let e = x[c] - x[b];
    let le = e.norm();
    let inv_le = le.recip();
    let (ng, lg) = (x[b] - x[c]).cross(&(x[q] - x[c])).unit();
    let inv_lg = lg.recip();
    let eh = e.scale(inv_le);
    let sn = nf.cross(&ng).dot(&eh);
    let cs = nf.dot(&ng);
    let r = (sn * sn + cs * cs).sqrt();
    let non_negative: [bool; LANES] = std::array::from_fn(|l| cs.0[l] >= 0.0);
    let r_plus_c = Lanes::select(&non_negative, r + cs, sn * sn / (r - cs));
    let flap = &s.flap[i];
    let [u, cos_u] = s.angle[i];
    let (f, df) = match variant {
        DirectorVariant::Tan => {
            let t = Lanes::select(flap, sn / r_plus_c, Lanes::zero());
            let f = (t + u) / (Lanes::splat(1.0) - t * u);
            (f, Lanes::splat(1.0) + f * f)
        }
        DirectorVariant::Sin => {
            let half_sin = sn / (r * r_plus_c * 2.0).sqrt();
            let half_cos = (r_plus_c / (r * 2.0)).sqrt();
            let half_sin = Lanes::select(flap, half_sin, Lanes::zero());
            let half_cos = Lanes::select(flap, half_cos, Lanes::splat(1.0));
            (
                half_sin * cos_u + half_cos * u,
                half_cos * cos_u - half_sin * u,
            )
        }
    };
    DirectorEdge {
        eh,
        le,
        inv_le,
        d: area2 * inv_le,
        ng,
        inv_lg,
        f,
        df,
    }
}

/// Adds the gradient of w·b (w = ∂E/∂(b11, b12, b22)) of the edge-director form to the
/// position blocks `g[..6]` and writes its edge-angle derivatives ∂E/∂φ_i to `g[6 + i].x`
/// (`EdgeDirector::derivatives` contracted with w, per lane). With ω = (w11 + w12 + w22,
/// w11, w22), ∂E/∂II_i = −ω_i; II_i = 2 d_i f(α_i) gives ∂E/∂d_i = −2 ω_i f and ∂E/∂α_i =
/// −2 ω_i d_i f′ (∂α/∂φ_i = σ_i, ∂α/∂θ_i = 1/2). The altitude d = |c_f|/L pulls back through
/// |c_f| (once for the three edges) and L; the dihedral angle through Bridson's closed form
/// (`dihedral_derivatives`): with u_f = n_f L/|c_f|, u_g = n_g L/|c_g| and the feet of the
/// altitudes t_f = (p0 − p1)·e/L², t_g = (q − p1)·e/L², ∇_{p0}θ = −u_f, ∇_qθ = −u_g,
/// ∇_{p2}θ = t_f u_f + t_g u_g and ∇_{p1}θ = u_f + u_g − ∇_{p2}θ; zero on a lane without
/// a flap (θ = 0 there).
#[inline(always)]
fn director_reverse(s: &Batch, dr: &Director, w: &Sym, g: &mut [V3; 9]) {
    let x = &s.x;
    let omega = [w[0] + w[1] + w[2], w[0], w[2]];
    let mut g_area = Lanes::zero();
    for (i, de) in dr.edge.iter().enumerate() {
        let (a, b, c, q) = (i, (i + 1) % 3, (i + 2) % 3, 3 + i);
        let (d, le, inv_le) = (de.d, de.le, de.inv_le);
        let g_ii = -omega[i];
        let g_d = g_ii * de.f * 2.0;
        let g_alpha = g_ii * d * de.df * 2.0;
        g[6 + i].x = g_alpha * s.sigma[i];
        // d = |c_f| / L.
        g_area += g_d * inv_le;
        let v = de.eh.scale(-(g_d * d * inv_le));
        g[c] += v;
        g[b] = g[b] - v;
        // θ_i, whose NaN terms on a lane without a flap are discarded by the selects.
        let flap = &s.flap[i];
        let g_theta = Lanes::select(flap, g_alpha * 0.5, Lanes::zero());
        let uf = dr.nf.scale(g_theta * le * dr.inv_area2);
        let ug = V3::select(flap, &de.ng.scale(g_theta * le * de.inv_lg), &V3::zero());
        let e = x[c] - x[b];
        let inv_l2 = inv_le * inv_le;
        let tf = (x[a] - x[b]).dot(&e) * inv_l2;
        let tg = (x[q] - x[b]).dot(&e) * inv_l2;
        let w2 = uf.scale(tf) + ug.scale(tg);
        g[a] = g[a] - uf;
        g[q] = g[q] - ug;
        g[c] += w2;
        g[b] += uf + ug - w2;
    }
    let nu = dr.nf.scale(g_area);
    add_cross_pullback(x, [0, 1, 2], &nu, g);
}

/// Energies of a batch (`eval_face_energy` for StVK and the mid-edge average).
#[inline(always)]
fn energy(inp: &Inputs<'_>, s: &Batch, r: &Rest) -> [Lanes; 3] {
    let k = &inp.constants;
    let t = inp.terms;
    let (e1, e2) = (s.x[1] - s.x[0], s.x[2] - s.x[0]);
    let a = metric(&e1, &e2);
    let b = if !(t.bend || r.prev.is_some()) {
        r.b_bar
    } else {
        match inp.form {
            Form::MidEdgeAverage => normals(s).b,
            Form::EdgeDirector(variant, _) => director(s, variant).b,
        }
    };
    let (ha, beta) = (k.half_alpha, k.beta);
    let stretch = if t.stretch {
        sv_energy_of(k.h_8, r.area, &r.a_bar_inv, ha, beta, &sub3(&a, &r.a_bar))
    } else {
        Lanes::zero()
    };
    let bend = if t.bend {
        sv_energy_of(k.h3_24, r.area, &r.a_bar_inv, ha, beta, &sub3(&b, &r.b_bar))
    } else {
        Lanes::zero()
    };
    // `damping_energy`'s order.
    let damping = match &r.prev {
        Some((inv, ap, bp)) => {
            let c = Lanes::splat(k.damping) * r.area;
            c * (Lanes::splat(k.h_8) * sv_norm_sq_of(inv, ha, beta, &sub3(&a, ap))
                + Lanes::splat(k.h3_24) * sv_norm_sq_of(inv, ha, beta, &sub3(&b, bp)))
        }
        None => Lanes::zero(),
    };
    [stretch, bend, damping]
}

/// Energy d·Kd of one SV quadratic (scale `c`); adds its gradient 2Kd to `g`.
#[inline(always)]
fn quadratic(k: &Constants, inv: &Sym, c: Lanes, d: &Sym, g: &mut Sym) -> Lanes {
    let kd = sv_quadratic_times_of(inv, k.alpha, k.beta, c, d);
    for i in 0..3 {
        g[i] += kd[i] * 2.0;
    }
    d[0] * kd[0] + d[1] * kd[1] + d[2] * kd[2]
}

/// Pull a vector back through m = u/|u|: (I − m mᵀ) v / |u| ([`pull_of`]).
#[inline(always)]
fn pull(m: &V3, len: Lanes, v: &V3) -> V3 {
    V3::from_arr(pull_of(&m.arr(), len, &v.arr()))
}

/// ∇ of ν·((q1 − q0) × (q2 − q0)) added to the blocks `idx` of `g` ([`cross_pullback_of`]).
#[inline(always)]
fn add_cross_pullback(x: &[V3; 6], idx: [usize; 3], nu: &V3, g: &mut [V3; 9]) {
    let q = idx.map(|i| x[i].arr());
    let d = cross_pullback_of([&q[0], &q[1], &q[2]], &nu.arr());
    for (&i, v) in idx.iter().zip(d) {
        g[i] += V3::from_arr(v);
    }
}

/// A bending form's forward pass, kept for its reverse pass.
trait Forward {
    /// b (m).
    fn b(&self) -> Sym;
    /// Adds the gradient of w·b, w = ∂E/∂(b11, b12, b22), to the stencil blocks `g[..6]` (and
    /// for the edge-director form writes ∂E/∂φ_i to `g[6 + i].x`).
    fn reverse(&self, s: &Batch, w: &Sym, g: &mut [V3; 9]);
}

impl Forward for Normals {
    #[inline(always)]
    fn b(&self) -> Sym {
        self.b
    }

    /// Reverse mode through the mid-edge normals: w·b = Σ_e n_e·p_e, p_e = A_e e1 + B_e e2
    /// (the coefficients of `edge_weights`).
    #[inline(always)]
    fn reverse(&self, s: &Batch, w: &Sym, g: &mut [V3; 9]) {
        let x = &s.x;
        let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
        let coef = [
            (-(w[0] * 2.0) - w[1], -w[1] - w[2] * 2.0),
            (w[0] * 2.0, w[1]),
            (w[1], w[2] * 2.0),
        ];
        let mut mu_f = V3::zero();
        for (e, &(ca, cb)) in coef.iter().enumerate() {
            let p = e1.scale(ca) + e2.scale(cb);
            let n = &self.n[e];
            g[0] += n.scale(-(ca + cb));
            g[1] += n.scale(ca);
            g[2] += n.scale(cb);
            let mu_s = pull(n, self.ls[e], &p);
            let nu = pull(&self.ng[e], self.lg[e], &mu_s);
            let flap = &s.flap[e];
            mu_f += V3::select(flap, &mu_s, &p);
            let nu = V3::select(flap, &nu, &V3::zero());
            add_cross_pullback(x, NEIGHBOUR[e], &nu, g);
        }
        let nu = pull(&self.nf, self.lf, &mu_f);
        add_cross_pullback(x, [0, 1, 2], &nu, g);
    }
}

impl Forward for Director {
    #[inline(always)]
    fn b(&self) -> Sym {
        self.b
    }

    #[inline(always)]
    fn reverse(&self, s: &Batch, w: &Sym, g: &mut [V3; 9]) {
        director_reverse(s, self, w, g);
    }
}

/// Energies and the gradient blocks of a batch (`eval_face` with the gradient: the law's 2Kd,
/// reverse mode through the mid-edge normals or the edge directors' second moments, J_aᵀ
/// ∂E/∂a): one block per stencil slot, then with the edge-director form ∂E/∂φ_i in
/// `g[6 + i].x` (zero y, z, as the assembler's edge slots).
#[inline(always)]
fn energy_gradient(inp: &Inputs<'_>, s: &Batch, r: &Rest, g: &mut [V3; 9]) -> [Lanes; 3] {
    // One instantiation per form, and no closures (they are not inlined, and their large
    // results are copied through memory).
    let uses_b = inp.terms.bend || r.prev.is_some();
    match inp.form {
        Form::MidEdgeAverage => {
            let fwd = if uses_b { Some(normals(s)) } else { None };
            energy_gradient_with(inp, s, r, g, fwd)
        }
        Form::EdgeDirector(variant, _) => {
            let fwd = if uses_b {
                Some(director(s, variant))
            } else {
                None
            };
            energy_gradient_with(inp, s, r, g, fwd)
        }
    }
}

/// [`energy_gradient`] with the bending form's forward pass `fwd` (`None` when b is not used).
#[inline(always)]
fn energy_gradient_with<F: Forward>(
    inp: &Inputs<'_>,
    s: &Batch,
    r: &Rest,
    g: &mut [V3; 9],
    fwd: Option<F>,
) -> [Lanes; 3] {
    let k = &inp.constants;
    let t = inp.terms;
    let x = &s.x;
    let uses_a = t.stretch || r.prev.is_some();
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    let a = metric(&e1, &e2);
    let b = fwd.as_ref().map_or(r.b_bar, F::b);
    let mut energies = [Lanes::zero(); 3];
    let mut ga = [Lanes::zero(); 3];
    let mut gb = [Lanes::zero(); 3];
    if t.stretch {
        let c = r.area * k.h_8;
        energies[0] = quadratic(k, &r.a_bar_inv, c, &sub3(&a, &r.a_bar), &mut ga);
    }
    if t.bend {
        let c = r.area * k.h3_24;
        energies[1] = quadratic(k, &r.a_bar_inv, c, &sub3(&b, &r.b_bar), &mut gb);
    }
    if let Some((inv, ap, bp)) = &r.prev {
        let c = r.area * k.damping;
        energies[2] = quadratic(k, inv, c * k.h_8, &sub3(&a, ap), &mut ga)
            + quadratic(k, inv, c * k.h3_24, &sub3(&b, bp), &mut gb);
    }

    *g = [V3::zero(); 9];
    if let Some(fwd) = &fwd {
        fwd.reverse(s, &gb, g);
    }
    if uses_a {
        let [g0, g1, g2] = metric_gradient_of(&ga, &e1.arr(), &e2.arr());
        g[0] += V3::from_arr(g0);
        g[1] += V3::from_arr(g1);
        g[2] += V3::from_arr(g2);
    }
    energies
}

/// Energies (and, with `gradient`, the per-face gradient slots) of the faces of one chunk,
/// `first..first + energies.len()`; returns the lowest face with a non-finite result.
#[inline(always)]
pub(crate) fn run_chunk(
    inp: &Inputs<'_>,
    first: usize,
    (energies, grad): FaceSlots2<'_>,
    gradient: bool,
) -> Option<usize> {
    let count = energies.len();
    let mut bad = None;
    let mut start = 0;
    let mut batch = Batch::new();
    let mut g = [V3::zero(); 9];
    // The vertex slots, then the edge slots of the edge-director form's angle unknowns: those
    // exist only with bending on, hence after all six vertex slots, as `g` has them.
    let slots = inp.grad_stride / 3;
    while start < count {
        let f = faces(first, start, count);
        let rest = load(inp, &f, &mut batch);
        let live = (count - start).min(LANES);
        if gradient {
            let e = energy_gradient(inp, &batch, &rest, &mut g);
            for l in 0..live {
                let i = start + l;
                energies[i] = EnergyTerms {
                    stretch: e[0].0[l],
                    bend: e[1].0[l],
                    damping: e[2].0[l],
                };
                let out = &mut grad[i * inp.grad_stride..(i + 1) * inp.grad_stride];
                let mut finite = energies[i].total().is_finite();
                for (sl, v) in g.iter().enumerate().take(slots) {
                    let c = [v.x.0[l], v.y.0[l], v.z.0[l]];
                    finite &= (c[0] * 0.0 + c[1] * 0.0 + c[2] * 0.0) == 0.0;
                    out[3 * sl..3 * sl + 3].copy_from_slice(&c);
                }
                if batch.special[l] || !finite {
                    energies[i] = face_energy_gradient(inp, first + i, out);
                    finite =
                        energies[i].total().is_finite() && out.iter().all(|v| (v * 0.0) == 0.0);
                }
                if !finite && bad.is_none() {
                    bad = Some(first + i);
                }
            }
        } else {
            let e = energy(inp, &batch, &rest);
            for l in 0..live {
                let i = start + l;
                energies[i] = EnergyTerms {
                    stretch: e[0].0[l],
                    bend: e[1].0[l],
                    damping: e[2].0[l],
                };
                if batch.special[l] || !energies[i].total().is_finite() {
                    energies[i] = face_energy(inp, first + i);
                }
                if !energies[i].total().is_finite() && bad.is_none() {
                    bad = Some(first + i);
                }
            }
        }
        start += LANES;
    }
    bad
}

/// The energies of face `f` by the per-face kernel ([`eval_face_energy`]): for faces the batch
/// does not cover, and to tell a face's own non-finite result from a batched formula's.
#[inline(never)]
fn face_energy(inp: &Inputs<'_>, f: usize) -> EnergyTerms {
    let st = inp.stencils;
    let rest = FaceRest {
        a_bar: inp.rest.a_bar[f],
        b_bar: inp.rest.b_bar[f],
    };
    let damping = inp.damping.map(|d| FaceDamping {
        a_prev: d.a_prev[f],
        b_prev: d.b_prev[f],
        dt: d.dt,
    });
    let (m, k, t) = (inp.material, &inp.energy_constants, inp.terms);
    match inp.form {
        Form::MidEdgeAverage => {
            let s = st.stencil(f, inp.x);
            eval_face_energy(&crate::MidEdgeAverage, m, k, &s, &rest, damping.as_ref(), t)
        }
        Form::EdgeDirector(variant, phi) => {
            let s = if phi.is_empty() {
                st.stencil(f, inp.x)
            } else {
                st.stencil_at(f, inp.x, phi)
            };
            let form = EdgeDirector { variant };
            eval_face_energy(&form, m, k, &s, &rest, damping.as_ref(), t)
        }
    }
}

/// The energies and gradient slots (`out`, the assembler's layout: vertex slots, then one
/// slot per edge angle on axis 0) of face `f` by the per-face kernel ([`eval_face`]), for the
/// faces the batch does not cover and those whose batched result is not finite.
#[inline(never)]
fn face_energy_gradient(inp: &Inputs<'_>, f: usize, out: &mut [f64]) -> EnergyTerms {
    let st = inp.stencils;
    let rest = FaceRest {
        a_bar: inp.rest.a_bar[f],
        b_bar: inp.rest.b_bar[f],
    };
    let damping = inp.damping.map(|d| FaceDamping {
        a_prev: d.a_prev[f],
        b_prev: d.b_prev[f],
        dt: d.dt,
    });
    let want = Want {
        gradient: true,
        hessian: None,
    };
    let (m, t) = (inp.material, inp.terms);
    let vertex_slots = inp.slots;
    match inp.form {
        Form::MidEdgeAverage => {
            let s = st.stencil(f, inp.x);
            let mut fe = FaceEval::<18>::default();
            eval_face(
                &crate::MidEdgeAverage,
                m,
                &s,
                &rest,
                damping.as_ref(),
                t,
                want,
                &mut fe,
            );
            out[..3 * vertex_slots].copy_from_slice(&fe.gradient.as_slice()[..3 * vertex_slots]);
            fe.energy
        }
        Form::EdgeDirector(variant, phi) => {
            let s = if phi.is_empty() {
                st.stencil(f, inp.x)
            } else {
                st.stencil_at(f, inp.x, phi)
            };
            let form = EdgeDirector { variant };
            let mut fe = FaceEval::<DIRECTOR_DOFS>::default();
            eval_face(&form, m, &s, &rest, damping.as_ref(), t, want, &mut fe);
            let g = fe.gradient.as_slice();
            out[..3 * vertex_slots].copy_from_slice(&g[..3 * vertex_slots]);
            for (e, slot) in out[3 * vertex_slots..].chunks_exact_mut(3).enumerate() {
                slot.copy_from_slice(&[g[18 + e], 0.0, 0.0]);
            }
            fe.energy
        }
    }
}

/// A chunk of faces as a `pulp` operation: [`run_chunk`] inlined into the dispatched
/// instruction set's context.
pub(crate) struct ChunkOp<'a, 'b> {
    pub(crate) inputs: &'a Inputs<'a>,
    pub(crate) first: usize,
    pub(crate) slots: FaceSlots2<'b>,
    pub(crate) gradient: bool,
}

impl pulp::WithSimd for ChunkOp<'_, '_> {
    type Output = Option<usize>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Option<usize> {
        run_chunk(self.inputs, self.first, self.slots, self.gradient)
    }
}
