//! Per-face and per-edge geometry of a configuration `x` (model.md §1).
//!
//! All functions take the positions separately from the mesh so that any configuration with
//! the mesh's connectivity (rest, current, previous) can be measured. They do not validate `x`:
//! a zero-area face gives a non-finite normal (use [`checked_face_normal`] where that matters).
//! `x` must hold one position per mesh vertex (e.g. validated by
//! [`Mesh::with_positions`](crate::Mesh::with_positions)); a shorter slice panics on indexing.

use nalgebra::Vector3;

// Its public path; defined in a module of its own so that `mesh` can use it without depending on
// this module, which depends on `Mesh`.
pub use crate::bounding_box::BoundingBox;

use crate::error::MeshError;
use crate::ids::VertexId;
use crate::mesh::Mesh;

/// `(x_j − x_i) × (x_k − x_i)` of face `f = [i, j, k]`: twice the area (m²) times the unit normal.
#[inline]
pub fn face_area_vector(x: &[Vector3<f64>], f: [VertexId; 3]) -> Vector3<f64> {
    let [i, j, k] = f.map(VertexId::idx);
    (x[j] - x[i]).cross(&(x[k] - x[i]))
}

/// Unit normal `n_f = (e1 × e2)/|e1 × e2|` of face `f = [i, j, k]`, `e1 = x_j − x_i`,
/// `e2 = x_k − x_i`. Non-finite for a zero-area face.
#[inline]
pub fn face_normal(x: &[Vector3<f64>], f: [VertexId; 3]) -> Vector3<f64> {
    let n = face_area_vector(x, f);
    n / n.norm()
}

/// Unit normal of face `f`, or `None` if its area is zero (or `x` is not finite).
#[inline]
pub fn checked_face_normal(x: &[Vector3<f64>], f: [VertexId; 3]) -> Option<Vector3<f64>> {
    let n = face_area_vector(x, f);
    let len = n.norm();
    (len > 0.0 && len.is_finite()).then(|| n / len)
}

/// Unit normals of all faces of `mesh` in configuration `x` (length `n_faces`).
pub fn face_normals(mesh: &Mesh, x: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    mesh.faces().iter().map(|&f| face_normal(x, f)).collect()
}

/// Areas (m²) of all faces of `mesh` in configuration `x`.
pub fn face_areas(mesh: &Mesh, x: &[Vector3<f64>]) -> Vec<f64> {
    mesh.faces()
        .iter()
        .map(|&f| 0.5 * face_area_vector(x, f).norm())
        .collect()
}

/// Mid-edge normals per global edge ([`Topology::edges`](crate::Topology::edges) order):
/// `(n_f + n_g)/|n_f + n_g|` of the two incident unit face normals on an interior edge, the
/// face normal `n_f` on a boundary edge.
///
/// Non-finite where an incident face has zero area or the two faces are folded flat onto each
/// other (`n_f = −n_g`).
pub fn mid_edge_normals(mesh: &Mesh, x: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let normals = face_normals(mesh, x);
    mesh.topology()
        .edges()
        .iter()
        .map(|edge| {
            let nl = normals[edge.left.idx()];
            match edge.right {
                Some(g) => {
                    let s = nl + normals[g.idx()];
                    s / s.norm()
                }
                None => nl,
            }
        })
        .collect()
}

/// Checks that every face of `mesh` in configuration `x` can be measured in `f64`: `|e1 × e2|²`
/// (the determinant of the first fundamental form) is a normal number and `ℓ_max⁴` is finite.
///
/// [`Mesh::new`] judges faces by shape only, so a mesh with edges of 1e-200 or 1e200 is valid
/// connectivity; but its fundamental forms under- or overflow and every energy built on them is
/// `inf` or `NaN`. Callers that compute forms run this check first. The first failing face is
/// reported as [`MeshError::OutOfScale`].
pub fn check_scale(mesh: &Mesh, x: &[Vector3<f64>]) -> Result<(), MeshError> {
    for (face, &f) in mesh.faces().iter().enumerate() {
        if let Some(twice_area) = out_of_scale(x, f.map(VertexId::idx)) {
            return Err(MeshError::OutOfScale { face, twice_area });
        }
    }
    Ok(())
}

/// `Some(|e1 × e2|)` when the triangle's squared area or squared edge lengths under- or
/// overflow f64 (see [`check_scale`]).
pub(crate) fn out_of_scale(x: &[Vector3<f64>], [i, j, k]: [usize; 3]) -> Option<f64> {
    let (u, v) = (x[j] - x[i], x[k] - x[i]);
    let twice_area = u.cross(&v).norm();
    let l2 = u
        .norm_squared()
        .max(v.norm_squared())
        .max((v - u).norm_squared());
    (!((twice_area * twice_area).is_normal() && (l2 * l2).is_finite())).then_some(twice_area)
}

/// Mean edge length (m) of `mesh` at positions `x`: the length scale of the mesh (contact's
/// default activation distance, the edge angles' scaling); 0 for a mesh without edges.
pub fn mean_edge_length(mesh: &Mesh, x: &[Vector3<f64>]) -> f64 {
    let edges = mesh.topology().edges();
    let sum: f64 = edges
        .iter()
        .map(|e| (x[e.vertices[1].idx()] - x[e.vertices[0].idx()]).norm())
        .sum();
    sum / edges.len().max(1) as f64
}
