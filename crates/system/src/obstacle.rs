//! Rigid, fixed obstacles of the contact term: their signed distance to a point with its exact
//! gradient and Hessian (model.md §7). A vertex's gap to an analytic obstacle (plane, sphere,
//! box) is this distance minus the thickness offset; a triangle-mesh obstacle instead enters
//! the contact term by IPC pairs (shell vertex–obstacle face, obstacle vertex–shell face and
//! edge–edge), as the shell's own faces do.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};
use thinshell_energy::contact::{distance2_derivatives, point_triangle_distance2};
use thinshell_mesh::DEGENERATE_TOLERANCE;

type V = Vector3<f64>;

/// A rigid, fixed obstacle.
#[derive(Clone, Debug, PartialEq)]
pub enum Obstacle {
    /// The half-space on the side of `normal` of the plane through `point` (m); the shell stays
    /// on that side.
    Plane {
        /// A point of the plane (m).
        point: V,
        /// The normal pointing towards the shell's side (any length > 0).
        normal: V,
    },
    /// A ball (m); the shell stays outside it.
    Sphere {
        /// Centre (m).
        center: V,
        /// Radius (m, > 0).
        radius: f64,
    },
    /// An axis-aligned box `[min, max]` (m); the shell stays outside it.
    Box {
        /// The lower corner (m).
        min: V,
        /// The upper corner (m), above `min` on every axis.
        max: V,
    },
    /// A fixed triangle mesh (m), e.g. read from an OBJ file ([`Obstacle::mesh_from_obj`]).
    /// Neither closed nor oriented need it be: the shell is kept from crossing any of its
    /// faces, from either side. Unreferenced vertices are ignored.
    Mesh {
        /// Vertex positions (m).
        vertices: Vec<V>,
        /// Triangles as 0-based indices into `vertices`.
        faces: Vec<[usize; 3]>,
    },
}

/// The distance of a point to an obstacle's surface (m; negative inside), its gradient (a unit
/// vector, pointing away from the obstacle) and its Hessian (1/m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObstacleDistance {
    /// Signed distance (m; unsigned for a mesh).
    pub distance: f64,
    /// ∂d/∂y.
    pub normal: V,
    /// ∂²d/∂y² (symmetric, positive semi-definite outside a convex obstacle).
    pub hessian: Matrix3<f64>,
}

impl Obstacle {
    /// One line naming the obstacle and its geometry (m), e.g. for `thinshell check`.
    pub fn describe(&self) -> String {
        let v = |p: &V| format!("({:e}, {:e}, {:e})", p.x, p.y, p.z);
        match self {
            Obstacle::Plane { point, normal } => {
                format!("plane through {} m, normal {}", v(point), v(normal))
            }
            Obstacle::Sphere { center, radius } => {
                format!("sphere, centre {} m, radius {radius:e} m", v(center))
            }
            Obstacle::Box { min, max } => format!("box from {} to {} m", v(min), v(max)),
            Obstacle::Mesh { vertices, faces } => format!(
                "triangle mesh, {} vertices, {} faces",
                vertices.len(),
                faces.len()
            ),
        }
    }

    /// A mesh obstacle from an OBJ file (positions and triangles; polygons are fan-triangulated,
    /// everything else is ignored, see [`thinshell_mesh::io`]). The error names the file and
    /// what is wrong with it (missing, malformed, no faces, a degenerate face, …).
    pub fn mesh_from_obj(path: &Path) -> Result<Obstacle, String> {
        let file = std::fs::File::open(path)
            .map_err(|e| format!("obstacle mesh {}: {e}", path.display()))?;
        let (vertices, faces) = thinshell_mesh::io::read_obj_raw(std::io::BufReader::new(file))
            .map_err(|e| format!("obstacle mesh {}: {e}", path.display()))?;
        let mesh = Obstacle::Mesh { vertices, faces };
        mesh.validated()
            .map_err(|e| format!("obstacle mesh {}: {e}", path.display()))
    }

    /// Checks the obstacle's numbers and normalises a plane's normal; the error says what is
    /// wrong.
    pub(crate) fn validated(&self) -> Result<Obstacle, String> {
        let finite = |v: &V| v.iter().all(|c| c.is_finite());
        match self {
            Obstacle::Plane { point, normal } => {
                let n = normal.norm();
                if !(n > 0.0 && n.is_finite() && finite(point)) {
                    return Err(format!(
                        "plane needs a finite point and a non-zero normal, got {point:?}, {normal:?}"
                    ));
                }
                Ok(Obstacle::Plane {
                    point: *point,
                    normal: normal / n,
                })
            }
            Obstacle::Sphere { center, radius } => {
                if !(*radius > 0.0 && radius.is_finite() && finite(center)) {
                    return Err(format!(
                        "sphere needs a finite centre and a positive radius, got {center:?}, {radius}"
                    ));
                }
                Ok(self.clone())
            }
            Obstacle::Box { min, max } => {
                if !(finite(min) && finite(max) && (0..3).all(|k| min[k] < max[k])) {
                    return Err(format!(
                        "box needs finite corners with min < max on every axis, got {min:?}, {max:?}"
                    ));
                }
                Ok(self.clone())
            }
            Obstacle::Mesh { vertices, faces } => validated_mesh(vertices, faces),
        }
    }

    /// The signed distance of `y` (m) with its gradient and Hessian. Planes need a unit normal
    /// (as the contact term stores them). At a sphere's centre or inside a box the
    /// gradient is a valid unit vector but the point is far inside (the gap is negative). A
    /// mesh's distance is unsigned, to its nearest face by brute force (the contact term does
    /// not use it).
    pub fn distance(&self, y: &V) -> ObstacleDistance {
        match self {
            Obstacle::Plane { point, normal } => ObstacleDistance {
                distance: normal.dot(&(y - point)),
                normal: *normal,
                hessian: Matrix3::zeros(),
            },
            Obstacle::Sphere { center, radius } => {
                let r = y - center;
                let n = r.norm();
                let u = if n > 0.0 { r / n } else { V::z() };
                ObstacleDistance {
                    distance: n - radius,
                    normal: u,
                    // The gradient r/|r| turns with y across r: (I − u uᵀ)/|r|.
                    hessian: if n > 0.0 {
                        (Matrix3::identity() - u * u.transpose()) / n
                    } else {
                        Matrix3::zeros()
                    },
                }
            }
            Obstacle::Box { min, max } => box_distance(min, max, y),
            Obstacle::Mesh { vertices, faces } => mesh_distance(vertices, faces, y),
        }
    }
}

/// A mesh obstacle with at least one face, every index in range, no face repeating a vertex,
/// finite positions of its vertices, no degenerate face (relative area below
/// [`DEGENERATE_TOLERANCE`], as for the shell's meshes), and its unreferenced vertices dropped.
fn validated_mesh(vertices: &[V], faces: &[[usize; 3]]) -> Result<Obstacle, String> {
    if faces.is_empty() {
        return Err("a mesh obstacle needs at least one face".into());
    }
    let mut new_index = vec![usize::MAX; vertices.len()];
    let mut kept = Vec::new();
    let mut out = Vec::with_capacity(faces.len());
    for (k, f) in faces.iter().enumerate() {
        if let Some(&v) = f.iter().find(|&&v| v >= vertices.len()) {
            return Err(format!(
                "face {k} refers to vertex {v}, but there are {} vertices",
                vertices.len()
            ));
        }
        if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
            return Err(format!("face {k} repeats a vertex: {f:?}"));
        }
        let p = f.map(|v| vertices[v]);
        if let Some(q) = p.iter().find(|q| !q.iter().all(|c| c.is_finite())) {
            return Err(format!(
                "face {k} has a vertex at a non-finite position {q:?}"
            ));
        }
        let (e1, e2, e3) = (p[1] - p[0], p[2] - p[0], p[2] - p[1]);
        let l2 = e1
            .norm_squared()
            .max(e2.norm_squared())
            .max(e3.norm_squared());
        let relative_area = e1.cross(&e2).norm() / l2;
        // NaN-explicit: a NaN area is degenerate too.
        if relative_area.is_nan() || relative_area <= DEGENERATE_TOLERANCE {
            return Err(format!(
                "face {k} is degenerate: |e1 × e2| / l_max² = {relative_area:e}"
            ));
        }
        out.push(f.map(|v| {
            if new_index[v] == usize::MAX {
                new_index[v] = kept.len();
                kept.push(vertices[v]);
            }
            new_index[v]
        }));
    }
    Ok(Obstacle::Mesh {
        vertices: kept,
        faces: out,
    })
}

/// The unsigned distance to the nearest face of a mesh, by brute force over its faces (O(faces);
/// the contact term does not use it, it keeps a mesh obstacle apart by IPC pairs), with the
/// gradient and Hessian of that face's closest feature: ∇d = ∇(d²)/(2d) and
/// ∇²d = ∇²(d²)/(2d) − ∇(d²)∇(d²)ᵀ/(4d³) in the point's three coordinates.
fn mesh_distance(vertices: &[V], faces: &[[usize; 3]], y: &V) -> ObstacleDistance {
    let mut best: Option<(f64, [V; 4])> = None;
    for f in faces {
        let pts = [*y, vertices[f[0]], vertices[f[1]], vertices[f[2]]];
        let d2 = point_triangle_distance2(&pts).0;
        if best.is_none_or(|(b, _)| d2 < b) {
            best = Some((d2, pts));
        }
    }
    let Some((d2, pts)) = best else {
        return ObstacleDistance {
            distance: f64::INFINITY,
            normal: V::z(),
            hessian: Matrix3::zeros(),
        };
    };
    let d = d2.sqrt();
    if d == 0.0 {
        return ObstacleDistance {
            distance: 0.0,
            normal: V::z(),
            hessian: Matrix3::zeros(),
        };
    }
    let der = distance2_derivatives(&pts, point_triangle_distance2(&pts).1);
    let g = V::new(der.gradient[0], der.gradient[1], der.gradient[2]);
    let h = der.hessian.fixed_view::<3, 3>(0, 0).into_owned();
    ObstacleDistance {
        distance: d,
        normal: g / (2.0 * d),
        hessian: h / (2.0 * d) - g * g.transpose() / (4.0 * d * d * d),
    }
}

/// Outside: r = y − clamp(y, min, max), d = |r|; the closest point follows y along the axes
/// where y lies within the box's slab (D_kk = 0 there, 1 where clamped), so ∇d = r/d and
/// ∇²d = (D − n nᵀ)/d — a face's plane, an edge's cylinder or a corner's sphere. Inside: minus
/// the distance to the nearest face, whose outward normal is the gradient.
fn box_distance(min: &V, max: &V, y: &V) -> ObstacleDistance {
    let c = y.sup(min).inf(max);
    let r = y - c;
    let d = r.norm();
    if d > 0.0 {
        let n = r / d;
        let clamped = Matrix3::from_diagonal(&V::from_fn(|k, _| f64::from(u8::from(r[k] != 0.0))));
        return ObstacleDistance {
            distance: d,
            normal: n,
            hessian: (clamped - n * n.transpose()) / d,
        };
    }
    let mut best = (f64::INFINITY, V::z());
    for k in 0..3 {
        for (depth, sign) in [(y[k] - min[k], -1.0), (max[k] - y[k], 1.0)] {
            if depth < best.0 {
                let mut n = V::zeros();
                n[k] = sign;
                best = (depth, n);
            }
        }
    }
    ObstacleDistance {
        distance: -best.0,
        normal: best.1,
        hessian: Matrix3::zeros(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box's distance gradient and Hessian against central differences in its face, edge
    /// and corner regions.
    #[test]
    fn box_distance_derivatives_match_finite_differences() {
        let b = Obstacle::Box {
            min: V::new(-1.0, -0.5, 0.0),
            max: V::new(1.0, 0.5, 0.3),
        };
        let eps = 1e-6;
        for y in [
            V::new(0.2, 0.1, 0.7),   // above the top face
            V::new(1.3, 0.1, 0.5),   // beside an edge
            V::new(1.2, -0.9, -0.4), // beside a corner
        ] {
            let o = b.distance(&y);
            for k in 0..3 {
                let mut e = V::zeros();
                e[k] = eps;
                let (p, m) = (b.distance(&(y + e)), b.distance(&(y - e)));
                let g = (p.distance - m.distance) / (2.0 * eps);
                assert!(
                    (g - o.normal[k]).abs() < 1e-8,
                    "{y:?} ∂{k}: {g} vs {}",
                    o.normal[k]
                );
                let h = (p.normal - m.normal) / (2.0 * eps);
                for i in 0..3 {
                    assert!(
                        (h[i] - o.hessian[(i, k)]).abs() < 1e-6,
                        "{y:?} H[{i},{k}]: {} vs {}",
                        h[i],
                        o.hessian[(i, k)]
                    );
                }
            }
        }
        // Inside: minus the depth below the nearest face (the top, 0.1 below it).
        let inside = b.distance(&V::new(0.0, 0.0, 0.2));
        assert!((inside.distance + 0.1).abs() < 1e-15 && inside.normal == V::z());
    }
}
