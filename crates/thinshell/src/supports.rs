//! Boundary conditions by region from Rust: [`Supports`] pins, clamps and mirrors the parts of a
//! mesh that a [`Region`] selects, exactly as a scene's `[boundary]` does with
//! `region = { box = … }` (the same code selects them).

use thinshell_growth::Region;
use thinshell_mesh::Mesh;
use thinshell_system::Boundary;

use crate::scene::boundary::{clamp_edges, mirror_plane, pin_vertices, region_vertices};

/// A region that selects nothing the condition can hold.
#[derive(Debug, thiserror::Error)]
#[error("{what}: {message}")]
pub struct SupportError {
    /// The condition: "pin", "clamp" or "symmetry".
    pub what: &'static str,
    /// What is wrong (e.g. "contains no vertex of the mesh").
    pub message: String,
}

/// Builds a [`Boundary`] for `mesh` from regions of its reference (own) positions, as a scene's
/// `[boundary]` table does: [`Supports::pin`] is `[[boundary.pins]]`, [`Supports::clamp`]
/// `[[boundary.clamps]]`, [`Supports::symmetry`] `[[boundary.symmetry]]`.
///
/// ```
/// use thinshell::prelude::*;
///
/// // A 1 m × 0.2 m strip: its end x = 0 clamped (pinned and its edge directors held).
/// let mesh = generators::rectangle(1.0, 0.2, 10, 2)?;
/// let end = Region::Box {
///     min: Vector3::new(-1e-9, -1.0, -1.0),
///     max: Vector3::new(1e-9, 1.0, 1.0),
/// };
/// let boundary = Supports::new(&mesh).pin(&end, "xyz")?.clamp(&end)?.build();
/// assert_eq!(boundary.pinned_coordinates.len(), 3 * 3); // 3 vertices on x = 0, 3 axes each
/// assert_eq!(boundary.clamped_edges.len(), 2);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Supports<'m> {
    mesh: &'m Mesh,
    boundary: Boundary,
}

impl<'m> Supports<'m> {
    /// No conditions yet.
    pub fn new(mesh: &'m Mesh) -> Self {
        Supports {
            mesh,
            boundary: Boundary::default(),
        }
    }

    /// Pins the coordinates `axes` (letters of "xyz", e.g. "z") of every vertex in `region`.
    pub fn pin(mut self, region: &Region, axes: &str) -> Result<Self, SupportError> {
        let inside = region_vertices(region, self.mesh.positions()).map_err(|(_, message)| {
            SupportError {
                what: "pin",
                message,
            }
        })?;
        pin_vertices(&mut self.boundary, &inside, axes);
        Ok(self)
    }

    /// Clamps the boundary edges with both ends in `region` (their edge directors are held as
    /// at the start; pin the vertices too for a built-in end).
    pub fn clamp(mut self, region: &Region) -> Result<Self, SupportError> {
        let err = |message| SupportError {
            what: "clamp",
            message,
        };
        let inside = region_vertices(region, self.mesh.positions()).map_err(|(_, m)| err(m))?;
        clamp_edges(&mut self.boundary, self.mesh, &inside).map_err(err)?;
        Ok(self)
    }

    /// Makes the boundary edges on the plane `x[axis] = value` (axis 0, 1, 2; m) mirror edges
    /// of a symmetry plane, within 1e-9 of the mesh's bounding-box diagonal.
    pub fn symmetry(mut self, axis: usize, value: f64) -> Result<Self, SupportError> {
        mirror_plane(&mut self.boundary, self.mesh, axis, value, None).map_err(|message| {
            SupportError {
                what: "symmetry",
                message,
            }
        })?;
        Ok(self)
    }

    /// The boundary, for [`crate::SimulationBuilder::boundary`].
    pub fn build(self) -> Boundary {
        self.boundary
    }
}
