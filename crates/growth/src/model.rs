//! Growth models: rest forms (ā, b̄) of a face from its initial forms (a⁰, b⁰) and its stimulus
//! (model.md §4).
//!
//! Every form is a symmetric 2×2 matrix in the face's barycentric basis (e1, e2) = (x_j − x_i,
//! x_k − x_i) of the initial mesh (ā in m², b̄ in m). Sign convention of model.md §1: b = −drᵀdn̂,
//! z = +h/2 is the top surface, the rest metric through the thickness is ḡ(z) = ā − 2z b̄.

use nalgebra::{Matrix2, Vector2, Vector3};
use thinshell_energy::RestState;
use thinshell_energy::membrane_strain::{edges, first_fundamental_form};
use thinshell_mesh::{FaceId, Mesh};

use crate::error::{GrowthError, check, check_len};
use crate::stimulus::FaceStimulus;

/// A rule computing a face's rest forms from its initial forms and stimulus.
///
/// Implementations must give back `(a0, b0)` bit for bit when the stimulus is zero on both
/// surfaces, so that a scene with nothing switched on behaves exactly like no growth.
pub trait GrowthModel: Send + Sync {
    /// Rest forms `(ā, b̄)` of face `face` with initial forms `(a0, b0)`, stimulus `m` and shell
    /// thickness `thickness` (m). `Err` carries a reason when the stimulus collapses the face.
    fn face_rest(
        &self,
        face: usize,
        a0: &Matrix2<f64>,
        b0: &Matrix2<f64>,
        m: FaceStimulus,
        thickness: f64,
    ) -> Result<(Matrix2<f64>, Matrix2<f64>), &'static str>;

    /// Short name for reports (`"isotropic"`, `"linear swelling"`, …).
    fn name(&self) -> &'static str;
}

/// Rest forms of every face: `out[f] = model.face_rest(f, initial[f], stimulus[f])`.
///
/// Errors on length mismatches, a non-finite stimulus, or a face whose rest metric collapses;
/// `out` is resized to the face count. The result is validated (ā positive definite).
pub fn apply_growth(
    model: &dyn GrowthModel,
    initial: &RestState,
    stimulus: &[FaceStimulus],
    thickness: f64,
    out: &mut RestState,
) -> Result<(), GrowthError> {
    let n = initial.n_faces();
    check_len("initial b_bar", n, initial.b_bar.len())?;
    check_len("stimulus", n, stimulus.len())?;
    check("thickness", thickness, thickness > 0.0, "must be positive")?;
    out.a_bar.resize(n, Matrix2::zeros());
    out.b_bar.resize(n, Matrix2::zeros());
    // The grown forms are the initial ones rewritten: they keep the initial forms' bending
    // form (checked against the model's by `ShellSystem::new`).
    out.sff = initial.sff;
    for (f, &m) in stimulus.iter().enumerate() {
        let face = FaceId::new(f);
        if !m.is_finite() {
            return Err(GrowthError::NonFiniteStimulus {
                face,
                top: m.top,
                bottom: m.bottom,
            });
        }
        let collapsed = |reason| GrowthError::CollapsedRest {
            face,
            top: m.top,
            bottom: m.bottom,
            reason,
        };
        let (a, b) = model
            .face_rest(f, &initial.a_bar[f], &initial.b_bar[f], m, thickness)
            .map_err(collapsed)?;
        let det = a.determinant();
        if !(det.is_finite() && det > 0.0 && a[(0, 0)] > 0.0 && b.iter().all(|v| v.is_finite())) {
            return Err(collapsed("rest metric not positive definite"));
        }
        out.a_bar[f] = a;
        out.b_bar[f] = b;
    }
    Ok(())
}

/// No growth: ā = a⁰, b̄ = b⁰ whatever the stimulus.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoGrowth;

impl GrowthModel for NoGrowth {
    fn face_rest(
        &self,
        _face: usize,
        a0: &Matrix2<f64>,
        b0: &Matrix2<f64>,
        _m: FaceStimulus,
        _thickness: f64,
    ) -> Result<(Matrix2<f64>, Matrix2<f64>), &'static str> {
        Ok((*a0, *b0))
    }
    fn name(&self) -> &'static str {
        "none"
    }
}

/// Isotropic growth with conformal factor `s = coefficient · (m⁺ + m⁻)/2` per face:
/// ā = e^{2s} a⁰, b̄ = e^{p·s} b⁰ (model.md §4).
///
/// `p = 0` is the seed's rule (b̄ = b⁰), `p = 1` a similarity (a sphere of radius r grown by a
/// uniform s is at rest as a sphere of radius e^s·r), `p = 2` in-plane growth of every layer at
/// fixed thickness. With `coefficient = 1` the stimulus *is* s (the seed prescribes s directly).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Isotropic {
    /// Exponent p of b̄ (dimensionless).
    pub p: f64,
    /// s per unit stimulus (1 when the stimulus is s itself).
    pub coefficient: f64,
}

impl Isotropic {
    /// The seed's isotropic growth: p = 0, the stimulus is s.
    pub const SEED: Isotropic = Isotropic {
        p: 0.0,
        coefficient: 1.0,
    };

    /// Checks that p and the coefficient are finite.
    pub fn validate(&self) -> Result<(), GrowthError> {
        check("p", self.p, true, "must be finite")?;
        check("coefficient", self.coefficient, true, "must be finite")
    }
}

impl GrowthModel for Isotropic {
    fn face_rest(
        &self,
        _face: usize,
        a0: &Matrix2<f64>,
        b0: &Matrix2<f64>,
        m: FaceStimulus,
        _thickness: f64,
    ) -> Result<(Matrix2<f64>, Matrix2<f64>), &'static str> {
        let s = self.coefficient * m.mean();
        let a = (2.0 * s).exp();
        if !(a.is_finite() && a > 0.0) {
            return Err("e^{2s} overflows or underflows");
        }
        Ok((a0 * a, b0 * (self.p * s).exp()))
    }
    fn name(&self) -> &'static str {
        "isotropic"
    }
}

/// How the stimulus varies through the thickness between its surface values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Profile {
    /// Linear from m⁻ at the bottom to m⁺ at the top.
    Linear,
    /// m⁺ throughout the top half, m⁻ throughout the bottom half (a bilayer); the rest metric is
    /// the L² projection of the resulting step onto metrics linear in z.
    PiecewiseConstant,
}

/// Per-face material direction for anisotropic swelling ("machine direction" of paper).
#[derive(Clone, Debug, PartialEq)]
pub struct Anisotropy {
    /// Swelling coefficient across the material direction, per unit stimulus.
    pub cross_coefficient: f64,
    /// Per face, the direction δ in barycentric coordinates, unit length in the initial metric
    /// a⁰ (δᵀ a⁰ δ = 1), so that the 3-D direction is δ₁ e1 + δ₂ e2.
    pub directions: Vec<Vector2<f64>>,
}

impl Anisotropy {
    /// Directions from one 3-D vector `d` projected onto every face's plane of the configuration
    /// `x` (the configuration whose forms are a⁰). Errors when `d` is (nearly) normal to a face
    /// or not finite.
    pub fn along(
        mesh: &Mesh,
        x: &[Vector3<f64>],
        d: Vector3<f64>,
        cross_coefficient: f64,
    ) -> Result<Anisotropy, GrowthError> {
        check_len("positions", mesh.n_vertices(), x.len())?;
        check(
            "cross_coefficient",
            cross_coefficient,
            true,
            "must be finite",
        )?;
        if !d.iter().all(|c| c.is_finite()) || d.norm() == 0.0 {
            return Err(GrowthError::InvalidParameter {
                name: "direction",
                value: d.norm(),
                reason: "must be a finite non-zero vector",
            });
        }
        let d = d.normalize();
        let mut directions = Vec::with_capacity(mesh.n_faces());
        for (f, face) in mesh.faces().iter().enumerate() {
            let corners = [x[face[0].idx()], x[face[1].idx()], x[face[2].idx()]];
            let (e1, e2) = edges(&corners);
            let a = first_fundamental_form(&corners);
            // Least-squares barycentric coordinates of d: its projection onto the face plane.
            let rhs = Vector2::new(e1.dot(&d), e2.dot(&d));
            let delta = a.try_inverse().map(|ai| ai * rhs);
            let norm2 = delta.map_or(0.0, |dl| dl.dot(&(a * dl)));
            // |projection| < 1e-3 means d is within 0.06° of the normal: no usable direction.
            match delta {
                Some(dl) if norm2.is_finite() && norm2 > 1e-6 => {
                    directions.push(dl / norm2.sqrt());
                }
                _ => {
                    return Err(GrowthError::CollapsedRest {
                        face: FaceId::new(f),
                        top: f64::NAN,
                        bottom: f64::NAN,
                        reason: "material direction is normal to the face (or the face is degenerate)",
                    });
                }
            }
        }
        Ok(Anisotropy {
            cross_coefficient,
            directions,
        })
    }
}

/// Swelling by a stimulus with surface values m± (model.md §4): the stretch of the material
/// at the top/bottom surface is `1 + c·m±`, applied to the surface metrics a⁰ ∓ h b⁰, and the
/// rest forms are the metric linear in z that matches them (linear profile) or the L²
/// projection of the bilayer step (piecewise-constant profile).
///
/// For a flat initial sheet the natural curvature ā⁻¹b̄ is isotropic,
/// `−((1+cm⁺)² − (1+cm⁻)²) / (h ((1+cm⁺)² + (1+cm⁻)²))` ≈ `−c(m⁺ − m⁻)/h` (linear), 3/2 of that
/// for the bilayer (Timoshenko's equal bilayer); the more swollen side is convex.
#[derive(Clone, Debug, PartialEq)]
pub struct Swelling {
    /// Profile through the thickness.
    pub profile: Profile,
    /// Swelling coefficient c (stretch per unit stimulus; along the material direction when
    /// `anisotropy` is set). Negative values shrink.
    pub coefficient: f64,
    /// Different coefficient across a per-face material direction, or `None` (isotropic).
    pub anisotropy: Option<Anisotropy>,
}

impl Swelling {
    /// Isotropic linear swelling with coefficient `c`.
    pub fn linear(c: f64) -> Swelling {
        Swelling {
            profile: Profile::Linear,
            coefficient: c,
            anisotropy: None,
        }
    }

    /// Isotropic piecewise-constant (bilayer) swelling with coefficient `c`.
    pub fn bilayer(c: f64) -> Swelling {
        Swelling {
            profile: Profile::PiecewiseConstant,
            coefficient: c,
            anisotropy: None,
        }
    }

    /// Checks the coefficients, and the direction count against `n_faces`.
    pub fn validate(&self, n_faces: usize) -> Result<(), GrowthError> {
        check("coefficient", self.coefficient, true, "must be finite")?;
        if let Some(an) = &self.anisotropy {
            check(
                "cross_coefficient",
                an.cross_coefficient,
                true,
                "must be finite",
            )?;
            check_len("material directions", n_faces, an.directions.len())?;
        }
        Ok(())
    }

    /// The 2×2 stretch T (barycentric coordinates) of the material at stimulus `m`.
    fn stretch(
        &self,
        face: usize,
        a0: &Matrix2<f64>,
        m: f64,
    ) -> Result<Matrix2<f64>, &'static str> {
        let along = 1.0 + self.coefficient * m;
        if along.is_nan() || along <= 0.0 {
            return Err("swelling stretch 1 + c·m is not positive");
        }
        match &self.anisotropy {
            None => Ok(Matrix2::identity() * along),
            Some(an) => {
                let across = 1.0 + an.cross_coefficient * m;
                if across.is_nan() || across <= 0.0 {
                    return Err("cross-direction stretch 1 + c_cd·m is not positive");
                }
                let d = an
                    .directions
                    .get(face)
                    .ok_or("no material direction for this face")?;
                // Stretch `along` on δ and `across` on its a⁰-orthogonal complement.
                Ok(Matrix2::identity() * across + (d * (d.transpose() * a0)) * (along - across))
            }
        }
    }
}

fn congruence(t: &Matrix2<f64>, m: &Matrix2<f64>) -> Matrix2<f64> {
    let r = t.transpose() * m * t;
    // Round-off makes TᵀMT slightly asymmetric; rest forms must be symmetric.
    let off = 0.5 * (r[(0, 1)] + r[(1, 0)]);
    Matrix2::new(r[(0, 0)], off, off, r[(1, 1)])
}

impl GrowthModel for Swelling {
    fn face_rest(
        &self,
        face: usize,
        a0: &Matrix2<f64>,
        b0: &Matrix2<f64>,
        m: FaceStimulus,
        thickness: f64,
    ) -> Result<(Matrix2<f64>, Matrix2<f64>), &'static str> {
        let h = thickness;
        let tp = self.stretch(face, a0, m.top)?;
        let tm = self.stretch(face, a0, m.bottom)?;
        // Surface metrics are ḡ± = A± ∓ h B± with A± = T±ᵀa⁰T±, B± = T±ᵀb⁰T±. The formulas
        // below are arranged so that T± = I gives (a⁰, b⁰) without rounding.
        let (ap, am) = (congruence(&tp, a0), congruence(&tm, a0));
        let (bp, bm) = (congruence(&tp, b0), congruence(&tm, b0));
        Ok(match self.profile {
            // ā = (ḡ⁺ + ḡ⁻)/2, b̄ = (ḡ⁻ − ḡ⁺)/(2h).
            Profile::Linear => (
                (ap + am) * 0.5 - (bp - bm) * (0.5 * h),
                (am - ap) / (2.0 * h) + (bp + bm) * 0.5,
            ),
            // L² projection of ḡ(z) = A± − 2z B± (z ≷ 0) onto ā − 2z b̄ over [−h/2, h/2].
            Profile::PiecewiseConstant => (
                (ap + am) * 0.5 - (bp - bm) * (0.25 * h),
                (am - ap) * (3.0 / (4.0 * h)) + (bp + bm) * 0.5,
            ),
        })
    }
    fn name(&self) -> &'static str {
        match (self.profile, self.anisotropy.is_some()) {
            (Profile::Linear, false) => "linear swelling",
            (Profile::PiecewiseConstant, false) => "bilayer swelling",
            (Profile::Linear, true) => "anisotropic linear swelling",
            (Profile::PiecewiseConstant, true) => "anisotropic bilayer swelling",
        }
    }
}
