//! Rigid, fixed obstacles of the contact term: their signed distance to a point with its exact
//! gradient and Hessian (model.md §7). A vertex's gap to an obstacle is this distance minus the
//! thickness offset.

use nalgebra::{Matrix3, Vector3};

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
}

/// The distance of a point to an obstacle's surface (m; negative inside), its gradient (a unit
/// vector, pointing away from the obstacle) and its Hessian (1/m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObstacleDistance {
    /// Signed distance (m).
    pub distance: f64,
    /// ∂d/∂y.
    pub normal: V,
    /// ∂²d/∂y² (symmetric, positive semi-definite outside a convex obstacle).
    pub hessian: Matrix3<f64>,
}

impl Obstacle {
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
        }
    }

    /// The signed distance of `y` (m) with its gradient and Hessian. Planes need a unit normal
    /// (as the contact term stores them). At a sphere's centre or inside a box the
    /// gradient is a valid unit vector but the point is far inside (the gap is negative).
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
        }
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
