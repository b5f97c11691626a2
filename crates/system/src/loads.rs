//! External loads: gravity, point forces (constant forces, potential −F·x) and uniform
//! pressure (a follower load, potential −p·V(x)): the force vector, and the pressure's volume,
//! gradient and Hessian that the objectives and the explicit step add to the elastic terms.

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{Assembler, EnergyError};
use thinshell_mesh::{Mesh, VertexId};

use thinshell_solver::SolverError;

/// External loads: gravity and point forces (potential −F·x) and uniform pressure.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Loads {
    /// Gravitational acceleration (m/s²), applied to the lumped vertex masses.
    pub gravity: Vector3<f64>,
    /// Point forces (N) on vertices.
    pub point_forces: Vec<(VertexId, Vector3<f64>)>,
    /// Uniform pressure p (Pa) on the side the face normals point away from: potential
    /// `−p·V(x)` with the enclosed volume `V = Σ_f x_i·(x_j × x_k)/6`. A positive p inflates a
    /// closed surface with outward normals. For an open surface V is the volume of the cone
    /// over the origin: its forces `p·∂V/∂x` are the follower loads `p·n·dA` at interior
    /// vertices and at held ones, but a free boundary vertex i also gets the origin-dependent
    /// `p·x_i × (x_a − x_b)/6` (a, b its boundary neighbours): hold the rim, close the
    /// surface, or, for a tube, set [`pressure_axis`](Self::pressure_axis).
    pub pressure: f64,
    /// The axis (through the origin; any length) of an open tube whose two ends stay in
    /// planes normal to it (their vertices held along the axis): the pressure's volume is then
    /// the tube's own, `V = Σ_f ½ (P c_f)·N_f` with `P = I − â âᵀ`, `c_f` the face's centroid
    /// and `N_f` its area vector — the flux of `½ P x`, which has divergence 1 and no flux
    /// through the end planes. The cone over the origin of [`pressure`](Self::pressure) would
    /// add the end caps' `x·n` terms, whose derivatives at the end rings are not pressure
    /// forces. `None`: the cone over the origin (closed surfaces).
    pub pressure_axis: Option<Vector3<f64>>,
}

/// The volume measure of a pressure load: the cone over the origin (`None`) or the flux of
/// `½ P x` about a unit axis ([`Loads::pressure_axis`]).
type Axis = Option<Vector3<f64>>;

/// Volume contribution `x_i·(x_j × x_k)/6` of a face (m³).
pub fn face_volume(x: [Vector3<f64>; 3]) -> f64 {
    x[0].dot(&x[1].cross(&x[2])) / 6.0
}

/// Gradient of [`face_volume`] with respect to the face's three vertices (m²).
pub fn face_volume_gradient(x: [Vector3<f64>; 3]) -> [Vector3<f64>; 3] {
    [
        x[1].cross(&x[2]) / 6.0,
        x[2].cross(&x[0]) / 6.0,
        x[0].cross(&x[1]) / 6.0,
    ]
}

/// Hessian of [`face_volume`] (9×9, symmetric, m): zero diagonal blocks,
/// `∂²V/∂x_a∂x_b = −[x_c]×/6` for (a, b, c) cyclic in (0, 1, 2) and the transpose for the
/// anticyclic pairs (`[v]×` is the cross-product matrix).
pub fn face_volume_hessian(x: [Vector3<f64>; 3]) -> nalgebra::SMatrix<f64, 9, 9> {
    let mut h = nalgebra::SMatrix::<f64, 9, 9>::zeros();
    for (a, b, c) in [(0, 1, 2), (1, 2, 0), (2, 0, 1)] {
        // ∂V/∂x_a = x_b × x_c / 6; ∂/∂x_b (x_b × x_c) = −[x_c]×.
        let k = -x[c].cross_matrix() / 6.0;
        h.fixed_view_mut::<3, 3>(3 * a, 3 * b).copy_from(&k);
        h.fixed_view_mut::<3, 3>(3 * b, 3 * a)
            .copy_from(&k.transpose());
    }
    h
}

/// The tube volume `½ (P c)·N` of a face about the unit axis `axis` (m³): `P = I − â âᵀ`,
/// `c` the centroid, `N = ½ (x₁ − x₀) × (x₂ − x₀)` the area vector ([`Loads::pressure_axis`]).
pub fn face_volume_about_axis(x: [Vector3<f64>; 3], axis: Vector3<f64>) -> f64 {
    let (c, n) = centroid_and_area_vector(&x);
    0.5 * project(axis, c).dot(&n)
}

/// Gradient of [`face_volume_about_axis`] with respect to the three vertices (m²):
/// `∂V/∂x_a = P N / 6 + ¼ (x_b − x_c) × (P c)` for (a, b, c) cyclic.
pub fn face_volume_about_axis_gradient(
    x: [Vector3<f64>; 3],
    axis: Vector3<f64>,
) -> [Vector3<f64>; 3] {
    let (c, n) = centroid_and_area_vector(&x);
    let pn = project(axis, n) / 6.0;
    let pc = project(axis, c);
    std::array::from_fn(|a| pn + (x[(a + 1) % 3] - x[(a + 2) % 3]).cross(&pc) / 4.0)
}

/// Hessian of [`face_volume_about_axis`] (9×9, symmetric, m): with `e_a = x_b − x_c`,
/// `∂²V/∂x_a∂x_d = −P[e_d]×/12 + [e_a]×P/12 − s_ad [P c]×/4`, `s_ad = +1` for d = b,
/// `−1` for d = c, 0 for d = a.
pub fn face_volume_about_axis_hessian(
    x: [Vector3<f64>; 3],
    axis: Vector3<f64>,
) -> nalgebra::SMatrix<f64, 9, 9> {
    let (c, _) = centroid_and_area_vector(&x);
    let proj = nalgebra::Matrix3::identity() - axis * axis.transpose();
    let pc = (proj * c).cross_matrix();
    let e: [Vector3<f64>; 3] = std::array::from_fn(|a| x[(a + 1) % 3] - x[(a + 2) % 3]);
    let mut h = nalgebra::SMatrix::<f64, 9, 9>::zeros();
    for a in 0..3 {
        for d in 0..3 {
            let s = if d == (a + 1) % 3 {
                1.0
            } else if d == (a + 2) % 3 {
                -1.0
            } else {
                0.0
            };
            let block = -proj * e[d].cross_matrix() / 12.0 + e[a].cross_matrix() * proj / 12.0
                - pc * (s / 4.0);
            h.fixed_view_mut::<3, 3>(3 * a, 3 * d).copy_from(&block);
        }
    }
    h
}

fn centroid_and_area_vector(x: &[Vector3<f64>; 3]) -> (Vector3<f64>, Vector3<f64>) {
    (
        (x[0] + x[1] + x[2]) / 3.0,
        (x[1] - x[0]).cross(&(x[2] - x[0])) / 2.0,
    )
}

/// `P v = v − â (â·v)` for a unit axis â.
fn project(axis: Vector3<f64>, v: Vector3<f64>) -> Vector3<f64> {
    v - axis * axis.dot(&v)
}

impl Loads {
    /// The external force per coordinate (N), vertex-major, for lumped masses `mass` (kg).
    pub fn forces(&self, mass: &[f64]) -> Result<Vec<f64>, SolverError> {
        let mut f = vec![0.0; 3 * mass.len()];
        for (v, m) in mass.iter().enumerate() {
            for a in 0..3 {
                f[3 * v + a] = m * self.gravity[a];
            }
        }
        for (v, force) in &self.point_forces {
            if v.idx() >= mass.len() {
                return Err(SolverError::InvalidSetting {
                    name: "point_forces",
                    value: v.idx() as f64,
                    requirement: "vertex out of range",
                });
            }
            for a in 0..3 {
                f[3 * v.idx() + a] += force[a];
            }
        }
        if !self.pressure.is_finite() {
            return Err(SolverError::InvalidSetting {
                name: "pressure",
                value: self.pressure,
                requirement: "must be finite",
            });
        }
        if let Some(axis) = self.pressure_axis {
            let norm = axis.norm();
            if !(norm.is_finite() && norm > 0.0) {
                return Err(SolverError::InvalidSetting {
                    name: "pressure_axis",
                    value: norm,
                    requirement: "must be a finite, nonzero vector",
                });
            }
        }
        if let Some(dof) = f.iter().position(|v| !v.is_finite()) {
            return Err(SolverError::NonFiniteCoordinate { dof });
        }
        Ok(f)
    }
}

/// The three corner positions of face `f`.
fn corners(mesh: &Mesh, x: &[Vector3<f64>], f: usize) -> [Vector3<f64>; 3] {
    let face = mesh.faces()[f];
    [x[face[0].idx()], x[face[1].idx()], x[face[2].idx()]]
}

/// The unit axis of `loads`' tube volume, if any ([`Loads::pressure_axis`]; validated by
/// [`Loads::forces`]).
pub(crate) fn unit_axis(loads: &Loads) -> Axis {
    loads.pressure_axis.map(|a| a / a.norm())
}

/// Enclosed volume `V(x)` (m³) of positions `x` on `mesh`: `Σ_f x_i·(x_j × x_k)/6`, or the
/// tube volume about `axis`.
pub(crate) fn enclosed_volume(mesh: &Mesh, x: &[Vector3<f64>], axis: Axis) -> f64 {
    (0..mesh.n_faces())
        .map(|f| match axis {
            None => face_volume(corners(mesh, x, f)),
            Some(a) => face_volume_about_axis(corners(mesh, x, f), a),
        })
        .sum()
}

/// `g −= p ∂V/∂x` (N) into the first `3·n_vertices` entries of the full gradient `g`: the
/// pressure force `p ∂V/∂x` enters like an external force. Nothing is done for `p = 0`.
pub(crate) fn add_pressure_gradient(
    mesh: &Mesh,
    x: &[Vector3<f64>],
    p: f64,
    axis: Axis,
    g: &mut [f64],
) {
    if p == 0.0 {
        return;
    }
    for (f, face) in mesh.faces().iter().enumerate() {
        let gv = match axis {
            None => face_volume_gradient(corners(mesh, x, f)),
            Some(a) => face_volume_about_axis_gradient(corners(mesh, x, f), a),
        };
        for (s, v) in face.iter().enumerate() {
            let base = 3 * v.idx();
            for (gc, gvc) in g[base..base + 3].iter_mut().zip(gv[s].iter()) {
                *gc -= p * gvc;
            }
        }
    }
}

/// `H −= p ∂²V/∂x²` into a Hessian with `assembler`'s pattern (free dofs only; the pattern is
/// checked once, so the cost is linear in the number of faces). Nothing is done for `p = 0`.
pub(crate) fn add_pressure_hessian(
    mesh: &Mesh,
    assembler: &Assembler,
    x: &[Vector3<f64>],
    p: f64,
    axis: Axis,
    h: &mut SparseColMat<usize, f64>,
) -> Result<(), EnergyError> {
    if p == 0.0 {
        return Ok(());
    }
    assembler.add_face_blocks(
        |f| {
            let c = corners(mesh, x, f.idx());
            match axis {
                None => face_volume_hessian(c) * -p,
                Some(a) => face_volume_about_axis_hessian(c, a) * -p,
            }
        },
        h,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tube volume's gradient and Hessian against central differences, on a skew face and
    /// a skew axis; and its sum over a closed tube against the cross-section area × length.
    #[test]
    fn tube_volume_derivatives_match_differences() {
        let x = [
            Vector3::new(0.9, 0.2, -0.3),
            Vector3::new(0.1, 1.1, 0.4),
            Vector3::new(-0.7, 0.3, 0.8),
        ];
        let axis = Vector3::new(0.3, -0.2, 1.0).normalize();
        let h = 1e-6;
        let g = face_volume_about_axis_gradient(x, axis);
        let hess = face_volume_about_axis_hessian(x, axis);
        for a in 0..3 {
            for k in 0..3 {
                let shifted = |s: f64| {
                    let mut y = x;
                    y[a][k] += s;
                    y
                };
                let fd = (face_volume_about_axis(shifted(h), axis)
                    - face_volume_about_axis(shifted(-h), axis))
                    / (2.0 * h);
                assert!(
                    (fd - g[a][k]).abs() < 1e-9,
                    "gradient {a} {k}: {fd} vs {}",
                    g[a][k]
                );
                let gp = face_volume_about_axis_gradient(shifted(h), axis);
                let gm = face_volume_about_axis_gradient(shifted(-h), axis);
                for b in 0..3 {
                    for l in 0..3 {
                        let fd = (gp[b][l] - gm[b][l]) / (2.0 * h);
                        let exact = hess[(3 * b + l, 3 * a + k)];
                        assert!(
                            (fd - exact).abs() < 1e-8,
                            "hessian {b}{l},{a}{k}: {fd} vs {exact}"
                        );
                    }
                }
            }
        }
        assert!((hess - hess.transpose()).abs().max() < 1e-15);
        // An open tube of radius 1.5 and length 2 around z (outward normals): π r² L up to the
        // polygon's area, n r² sin(2π/n)/2 · L.
        let n = 48;
        let mesh =
            thinshell_mesh::generators::cylinder_patch(1.5, std::f64::consts::TAU, 2.0, n, 3)
                .expect("tube");
        let v = enclosed_volume(&mesh, mesh.positions(), Some(Vector3::z()));
        let polygon =
            n as f64 * 1.5f64.powi(2) * (std::f64::consts::TAU / n as f64).sin() / 2.0 * 2.0;
        assert!((v / polygon - 1.0).abs() < 1e-12, "{v} vs {polygon}");
        // The cone over the origin misses the caps.
        let cone = enclosed_volume(&mesh, mesh.positions(), None);
        assert!((cone / polygon - 1.0).abs() > 0.1, "{cone}");
    }
}
