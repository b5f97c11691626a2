//! Per-face and per-edge geometry of a configuration `x` (model.md §1).
//!
//! All functions take the positions separately from the mesh so that any configuration with
//! the mesh's connectivity (rest, current, previous) can be measured. They do not validate `x`:
//! a zero-area face gives a non-finite normal (use [`checked_face_normal`] where that matters).
//! `x` must hold one position per mesh vertex (e.g. validated by
//! [`Mesh::with_positions`](crate::Mesh::with_positions)); a shorter slice panics on indexing.

use nalgebra::Vector3;

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
        let [i, j, k] = f.map(VertexId::idx);
        let (u, v) = (x[j] - x[i], x[k] - x[i]);
        let twice_area = u.cross(&v).norm();
        let l2 = u
            .norm_squared()
            .max(v.norm_squared())
            .max((v - u).norm_squared());
        if !((twice_area * twice_area).is_normal() && (l2 * l2).is_finite()) {
            return Err(MeshError::OutOfScale { face, twice_area });
        }
    }
    Ok(())
}

/// Axis-aligned bounding box of a set of points (m).
///
/// ```
/// use thinshell_mesh::{generators, geometry::BoundingBox};
/// use thinshell_mesh::nalgebra::Vector3;
///
/// let mesh = generators::rectangle(2.0, 1.0, 4, 2)?;
/// let bb = mesh.bounding_box();
/// assert_eq!(bb.max, Vector3::new(2.0, 1.0, 0.0));
/// assert!((bb.diagonal() - 5f64.sqrt()).abs() < 1e-15);
/// assert_eq!(BoundingBox::from_points(&[]), None);
/// # Ok::<(), thinshell_mesh::MeshError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingBox {
    /// Smallest coordinate along each axis.
    pub min: Vector3<f64>,
    /// Largest coordinate along each axis.
    pub max: Vector3<f64>,
}

impl BoundingBox {
    /// The box of `points`, `None` if there are none. NaN coordinates are ignored (they
    /// cannot occur in a [`Mesh`], which checks its positions).
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vector3<f64>>) -> Option<Self> {
        let mut points = points.into_iter();
        let first = *points.next()?;
        let (min, max) = points.fold((first, first), |(lo, hi), p| {
            (lo.zip_map(p, f64::min), hi.zip_map(p, f64::max))
        });
        Some(BoundingBox { min, max })
    }

    /// `max − min` (m): the box's side lengths.
    pub fn extent(&self) -> Vector3<f64> {
        self.max - self.min
    }

    /// Length of the box's diagonal `|max − min|` (m): the length scale of a mesh.
    pub fn diagonal(&self) -> f64 {
        self.extent().norm()
    }

    /// The box's centre (m).
    pub fn center(&self) -> Vector3<f64> {
        0.5 * (self.min + self.max)
    }
}
