//! External loads: gravity, point forces (constant forces, potential −F·x) and uniform
//! pressure (a follower load, potential −p·V(x)): the force vector, and the pressure's volume,
//! gradient and Hessian that the objectives and the explicit step add to the elastic terms.

use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{Assembler, EnergyError};
use thinshell_mesh::{Mesh, VertexId};

use crate::SolverError;

/// External loads: gravity and point forces (potential −F·x) and uniform pressure.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Loads {
    /// Gravitational acceleration (m/s²), applied to the lumped vertex masses.
    pub gravity: Vector3<f64>,
    /// Point forces (N) on vertices.
    pub point_forces: Vec<(VertexId, Vector3<f64>)>,
    /// Uniform pressure p (Pa) on the side the face normals point away from: potential
    /// `−p·V(x)` with the enclosed volume `V = Σ_f x_i·(x_j × x_k)/6` (for an open surface, the
    /// volume of the cone over the origin; the forces `p·∂V/∂x` are the same follower pressure
    /// loads `p·n·dA`). A positive p inflates a closed surface with outward normals.
    pub pressure: f64,
}

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

/// Enclosed volume `V(x) = Σ_f x_i·(x_j × x_k)/6` (m³) of positions `x` on `mesh`.
pub(crate) fn enclosed_volume(mesh: &Mesh, x: &[Vector3<f64>]) -> f64 {
    (0..mesh.n_faces())
        .map(|f| face_volume(corners(mesh, x, f)))
        .sum()
}

/// `g −= p ∂V/∂x` (N) into the first `3·n_vertices` entries of the full gradient `g`: the
/// pressure force `p ∂V/∂x` enters like an external force. Nothing is done for `p = 0`.
pub(crate) fn add_pressure_gradient(mesh: &Mesh, x: &[Vector3<f64>], p: f64, g: &mut [f64]) {
    if p == 0.0 {
        return;
    }
    for (f, face) in mesh.faces().iter().enumerate() {
        let gv = face_volume_gradient(corners(mesh, x, f));
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
    h: &mut SparseColMat<usize, f64>,
) -> Result<(), EnergyError> {
    if p == 0.0 {
        return Ok(());
    }
    assembler.add_face_blocks(|f| face_volume_hessian(corners(mesh, x, f.idx())) * -p, h)
}
