//! Regions of the shell selecting faces (where a stimulus is applied or held).

use nalgebra::Vector3;
use thinshell_mesh::Mesh;

use crate::error::{GrowthError, check_len};

/// A region of space or of the mesh. A face belongs to a geometric region when all three of its
/// vertices do (positions of the configuration passed to [`Region::faces`], usually the
/// initial mesh).
#[derive(Clone, Debug, PartialEq)]
pub enum Region {
    /// Every face.
    All,
    /// Points with `(x − point)·normal > 0` (m; `normal` need not be unit).
    HalfSpace {
        /// A point on the plane, m.
        point: Vector3<f64>,
        /// Normal pointing into the region.
        normal: Vector3<f64>,
    },
    /// Points with `|x − center| < radius` (m).
    Ball {
        /// Centre, m.
        center: Vector3<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// Points with `min ≤ x ≤ max` componentwise (m).
    Box {
        /// Lower corner, m.
        min: Vector3<f64>,
        /// Upper corner, m.
        max: Vector3<f64>,
    },
    /// Faces whose three vertices are all in this list (0-based vertex indices).
    Vertices(Vec<usize>),
    /// These faces (0-based face indices).
    Faces(Vec<usize>),
}

impl Region {
    /// Whether point `p` (m) lies in a geometric region; `All` contains everything, index-based
    /// regions nothing.
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        match self {
            Region::All => true,
            Region::HalfSpace { point, normal } => (p - point).dot(normal) > 0.0,
            Region::Ball { center, radius } => (p - center).norm() < *radius,
            Region::Box { min, max } => (0..3).all(|k| min[k] <= p[k] && p[k] <= max[k]),
            Region::Vertices(_) | Region::Faces(_) => false,
        }
    }

    /// Per face of `mesh`, whether it lies in the region for vertex positions `x` (m). Errors
    /// on an index out of range or a length mismatch.
    pub fn faces(&self, mesh: &Mesh, x: &[Vector3<f64>]) -> Result<Vec<bool>, GrowthError> {
        check_len("positions", mesh.n_vertices(), x.len())?;
        let nf = mesh.n_faces();
        let out_of_range = |name: &'static str, i: usize| GrowthError::InvalidParameter {
            name,
            value: i as f64,
            reason: "index out of range",
        };
        match self {
            Region::Faces(list) => {
                let mut sel = vec![false; nf];
                for &f in list {
                    *sel.get_mut(f)
                        .ok_or_else(|| out_of_range("region face", f))? = true;
                }
                Ok(sel)
            }
            Region::Vertices(list) => {
                let mut inside = vec![false; mesh.n_vertices()];
                for &v in list {
                    *inside
                        .get_mut(v)
                        .ok_or_else(|| out_of_range("region vertex", v))? = true;
                }
                Ok(mesh
                    .faces()
                    .iter()
                    .map(|f| f.iter().all(|v| inside[v.idx()]))
                    .collect())
            }
            _ => {
                let inside: Vec<bool> = x.iter().map(|p| self.contains(p)).collect();
                Ok(mesh
                    .faces()
                    .iter()
                    .map(|f| f.iter().all(|v| inside[v.idx()]))
                    .collect())
            }
        }
    }
}
