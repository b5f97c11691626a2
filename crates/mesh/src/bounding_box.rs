//! The axis-aligned bounding box (m), public as
//! [`geometry::BoundingBox`](crate::geometry::BoundingBox).

use nalgebra::Vector3;

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
    /// cannot occur in a [`Mesh`](crate::Mesh), which checks its positions).
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
