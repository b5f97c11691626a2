//! The shell's own fields of a frame, per face and per vertex, from each face's forms and the
//! elastic law's first derivatives ([`FaceForms`]): curvatures and principal curvature
//! directions, membrane strain, membrane stress resultants and bending moments. Pure functions
//! of plain data; the conventions are stated here once and listed for users in
//! `docs/scenes.md` (`[output] formats`).
//!
//! **Curvature.** A face's principal curvatures κ₁ ≥ κ₂ are the eigenvalues of the shape
//! operator −a⁻¹b (a, b the face's first and second fundamental forms in its barycentric basis,
//! b of the scene's bending form at the frame's edge angles, model.md §1), i.e. of −b
//! relative to a. The sign is that of the viewer and of ParaView's curvature filter: positive
//! where the surface bends away from its normal n = e1 × e2 (the face's orientation), so a
//! sphere of radius R with outward normals has κ₁ = κ₂ = 1/R. Mean curvature H = (κ₁ + κ₂)/2
//! (1/m), Gaussian curvature K = κ₁κ₂ = det b / det a (1/m², independent of the orientation).
//! The principal directions are the eigenvectors mapped to 3-D, d = v₁e1 + v₂e2, unit length
//! (vᵀav = 1); their sign is arbitrary, and where κ₁ = κ₂ (flat, umbilic) so is the pair.
//!
//! **Per vertex.** H and K are the averages of the incident faces' values weighted by their
//! current areas ½√det a; the principal directions are those of the area-weighted average of
//! the faces' curvature tensors κ₁d₁d₁ᵀ + κ₂d₂d₂ᵀ restricted to the vertex's tangent plane
//! (normal: the area-weighted face normal).
//!
//! **Membrane strain** (dimensionless): the principal values ε₁ ≥ ε₂ of the Green–Lagrange
//! strain ε = ½(a − ā) relative to the rest metric ā (eigenvalues of ā⁻¹ε).
//!
//! **Stress resultants** (N/m): the principal values N₁ ≥ N₂ of the second Piola–Kirchhoff
//! membrane stress resultant N = ∂W/∂ε (W the elastic energy per unit rest area, so
//! N^{ij} = 2/Ā · ∂E/∂a_ij with E the face's energy and Ā = ½√det ā its rest area), as a mixed
//! tensor in ā (eigenvalues of Nā): force per unit rest length. Taken from the law's own
//! gradient, so they are the StVK, neo-Hookean or bilayer resultants as the energy defines them
//! (for StVK exactly N₁ = Eh/(1−ν²)(ε₁ + νε₂)).
//!
//! **Bending moments** (N·m/m): the principal values M₁ ≥ M₂ of M = −∂W/∂b (M^{ij} =
//! −1/Ā · ∂E/∂b_ij), mixed in ā: the moment conjugate to the curvature as signed above, so
//! that a StVK plate bent from flat to principal curvatures κ₁, κ₂ has M = D(κ₁ + νκ₂),
//! D = Eh³/(12(1−ν²)).

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use thinshell_energy::FaceForms;
use thinshell_mesh::Mesh;

/// A pair of principal values (larger first) and their directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principal {
    /// The values, larger first.
    pub values: [f64; 2],
    /// Their directions in the face's barycentric coordinates.
    pub vectors: [Vector2<f64>; 2],
}

/// Eigen-decomposition of a symmetric 2×2 matrix: values larger first, unit eigenvectors
/// (the first at angle ½ atan2(2q, p − r); (1, 0) when the values are equal).
fn symmetric_eigen(c: &Matrix2<f64>) -> ([f64; 2], [Vector2<f64>; 2]) {
    let (p, q, r) = (c[(0, 0)], 0.5 * (c[(0, 1)] + c[(1, 0)]), c[(1, 1)]);
    let mean = 0.5 * (p + r);
    let d = (0.5 * (p - r)).hypot(q);
    let theta = 0.5 * q.atan2(0.5 * (p - r));
    let w = Vector2::new(theta.cos(), theta.sin());
    ([mean + d, mean - d], [w, Vector2::new(-w.y, w.x)])
}

/// Lower Cholesky factor of a symmetric positive definite 2×2 matrix, `None` otherwise.
fn cholesky(m: &Matrix2<f64>) -> Option<Matrix2<f64>> {
    let l11 = m[(0, 0)].sqrt();
    let l21 = m[(1, 0)] / l11;
    let l22 = (m[(1, 1)] - l21 * l21).sqrt();
    (l11 > 0.0 && l22 > 0.0 && l21.is_finite()).then(|| Matrix2::new(l11, 0.0, l21, l22))
}

/// Principal values of a covariant symmetric form `s` relative to the metric `m` (the
/// eigenvalues of m⁻¹s) with eigenvectors normalised to vᵀmv = 1; `None` when `m` is not
/// positive definite.
pub fn principal_covariant(s: &Matrix2<f64>, m: &Matrix2<f64>) -> Option<Principal> {
    let l = cholesky(m)?;
    let l_inv = l.try_inverse()?;
    let (values, w) = symmetric_eigen(&(l_inv * s * l_inv.transpose()));
    let lt_inv = l_inv.transpose();
    Some(Principal {
        values,
        vectors: [lt_inv * w[0], lt_inv * w[1]],
    })
}

/// Principal values of a contravariant symmetric tensor `t` mixed with the metric `m` (the
/// eigenvalues of t·m), larger first; `None` when `m` is not positive definite.
pub fn principal_contravariant(t: &Matrix2<f64>, m: &Matrix2<f64>) -> Option<[f64; 2]> {
    let l = cholesky(m)?;
    Some(symmetric_eigen(&(l.transpose() * t * l)).0)
}

/// The symmetric tensor whose entries are the derivative `g` = ∂E/∂(m11, m12, m22) of a
/// function of a symmetric form (the shared off-diagonal entry split over both places).
fn tensor_of_derivative(g: &Vector3<f64>) -> Matrix2<f64> {
    Matrix2::new(g[0], 0.5 * g[1], 0.5 * g[1], g[2])
}

/// The fields of one face (see the module docs for conventions and units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceFields {
    /// Principal curvatures κ₁ ≥ κ₂, 1/m.
    pub curvatures: [f64; 2],
    /// Unit principal directions of κ₁ and κ₂ (3-D).
    pub directions: [Vector3<f64>; 2],
    /// Principal Green–Lagrange membrane strains ε₁ ≥ ε₂.
    pub strains: [f64; 2],
    /// Principal membrane stress resultants N₁ ≥ N₂, N/m.
    pub stress_resultants: [f64; 2],
    /// Principal bending moments M₁ ≥ M₂, N·m/m.
    pub moments: [f64; 2],
    /// Current area ½√det a, m².
    pub area: f64,
    /// Unit normal (e1 × e2)/|e1 × e2|.
    pub normal: Vector3<f64>,
}

impl FaceFields {
    /// Mean curvature H = (κ₁ + κ₂)/2, 1/m.
    pub fn mean_curvature(&self) -> f64 {
        0.5 * (self.curvatures[0] + self.curvatures[1])
    }

    /// Gaussian curvature K = κ₁κ₂, 1/m².
    pub fn gaussian_curvature(&self) -> f64 {
        self.curvatures[0] * self.curvatures[1]
    }
}

/// The fields of a face with edges `e1`, `e2` (m), forms and derivatives `forms` and rest
/// metric `a_bar` (m²); `None` for a degenerate face (a or ā not positive definite).
pub fn face_fields(
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
    forms: &FaceForms,
    a_bar: &Matrix2<f64>,
) -> Option<FaceFields> {
    let curvature = principal_covariant(&(-forms.b), &forms.a)?;
    let strain = principal_covariant(&(0.5 * (forms.a - a_bar)), a_bar)?;
    let rest_area = 0.5 * a_bar.determinant().sqrt();
    let n = tensor_of_derivative(&forms.de_da) * (2.0 / rest_area);
    let m = tensor_of_derivative(&forms.de_db) * (-1.0 / rest_area);
    let cross = e1.cross(e2);
    let to_3d = |v: &Vector2<f64>| e1 * v.x + e2 * v.y;
    Some(FaceFields {
        curvatures: curvature.values,
        directions: [to_3d(&curvature.vectors[0]), to_3d(&curvature.vectors[1])],
        strains: strain.values,
        stress_resultants: principal_contravariant(&n, a_bar)?,
        moments: principal_contravariant(&m, a_bar)?,
        area: 0.5 * cross.norm(),
        normal: cross.try_normalize(0.0)?,
    })
}

/// Per-vertex curvature fields (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexCurvatures {
    /// Mean curvature H, 1/m.
    pub mean: Vec<f64>,
    /// Gaussian curvature K, 1/m².
    pub gaussian: Vec<f64>,
    /// Unit principal directions of the larger and the smaller principal curvature.
    pub directions: [Vec<Vector3<f64>>; 2],
}

/// Area-weighted vertex averages of the faces' curvatures (`faces` in mesh face order).
pub fn vertex_curvatures(mesh: &Mesh, faces: &[FaceFields]) -> VertexCurvatures {
    let n = mesh.n_vertices();
    let mut weight = vec![0.0; n];
    let mut mean = vec![0.0; n];
    let mut gaussian = vec![0.0; n];
    let mut tensor = vec![Matrix3::zeros(); n];
    let mut normal = vec![Vector3::zeros(); n];
    for (f, ff) in mesh.faces().iter().zip(faces) {
        let w = ff.area;
        let t = ff.curvatures[0] * ff.directions[0] * ff.directions[0].transpose()
            + ff.curvatures[1] * ff.directions[1] * ff.directions[1].transpose();
        for v in f {
            let i = v.idx();
            weight[i] += w;
            mean[i] += w * ff.mean_curvature();
            gaussian[i] += w * ff.gaussian_curvature();
            tensor[i] += w * t;
            normal[i] += w * ff.normal;
        }
    }
    let mut out = VertexCurvatures {
        mean: Vec::with_capacity(n),
        gaussian: Vec::with_capacity(n),
        directions: [Vec::with_capacity(n), Vec::with_capacity(n)],
    };
    for i in 0..n {
        out.mean.push(mean[i] / weight[i]);
        out.gaussian.push(gaussian[i] / weight[i]);
        let nrm = normal[i].try_normalize(0.0).unwrap_or_else(Vector3::z);
        // Any unit vector perpendicular to the normal, then the right-handed second one.
        let helper = if nrm.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let t1 = (helper - nrm * nrm.dot(&helper)).normalize();
        let t2 = nrm.cross(&t1);
        let t = tensor[i] / weight[i];
        let c = Matrix2::new(
            t1.dot(&(t * t1)),
            t1.dot(&(t * t2)),
            t2.dot(&(t * t1)),
            t2.dot(&(t * t2)),
        );
        let (_, w) = symmetric_eigen(&c);
        out.directions[0].push(t1 * w[0].x + t2 * w[0].y);
        out.directions[1].push(t1 * w[1].x + t2 * w[1].y);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Principal values of m⁻¹s against a hand case: s = diag(2, 3), m = diag(1, 4) → 2 and
    /// 0.75, eigenvectors normalised in m.
    #[test]
    fn generalised_eigenvalues_by_hand() {
        let p = principal_covariant(
            &Matrix2::new(2.0, 0.0, 0.0, 3.0),
            &Matrix2::new(1.0, 0.0, 0.0, 4.0),
        )
        .expect("spd");
        assert!((p.values[0] - 2.0).abs() < 1e-15 && (p.values[1] - 0.75).abs() < 1e-15);
        let m = Matrix2::new(1.0, 0.0, 0.0, 4.0);
        for v in p.vectors {
            assert!((v.dot(&(m * v)) - 1.0).abs() < 1e-15);
        }
        // A full metric: the values are those of m⁻¹s (trace and determinant).
        let (s, m) = (
            Matrix2::new(1.0, 0.3, 0.3, -2.0),
            Matrix2::new(2.0, 0.5, 0.5, 1.0),
        );
        let p = principal_covariant(&s, &m).expect("spd");
        let ms = m.try_inverse().expect("inv") * s;
        assert!((p.values[0] + p.values[1] - ms.trace()).abs() < 1e-14);
        assert!((p.values[0] * p.values[1] - ms.determinant()).abs() < 1e-14);
        let q = principal_contravariant(&s, &m).expect("spd");
        let sm = s * m;
        assert!((q[0] + q[1] - sm.trace()).abs() < 1e-14);
        assert!((q[0] * q[1] - sm.determinant()).abs() < 1e-14);
        assert!(principal_covariant(&s, &Matrix2::new(1.0, 2.0, 2.0, 1.0)).is_none());
    }
}
