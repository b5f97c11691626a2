//! Known answers: analytic equilibria of the seed's experiments and distances that ignore rigid
//! motion.
//!
//! The enlarged square and the rhombus are exact zero-energy states of the discrete energy, so a
//! solver must reach them to round-off; the cylinder is exact only in the continuum
//! (`docs/model.md` §5).

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

/// The seed's square experiments (model.md §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SquareCase {
    /// ā^{xy} = 4I, b̄ = 0: a flat square of side 2.
    Enlarged,
    /// ā^{xy} = `[[2,1],[1,2]]`, b̄ = 0: the rhombus spanned by ½(√3+1, √3−1), ½(√3−1, √3+1).
    Rhombus,
    /// ā^{xy} = I, b̄^{xy} = diag(1,0): a cylinder of radius 1 with axis ∥ y.
    Cylinder,
}

/// The linear map of the rhombus case, columns ½(√3+1, √3−1) and ½(√3−1, √3+1).
pub fn rhombus_map() -> Matrix2<f64> {
    let s = 3f64.sqrt();
    Matrix2::new(s + 1.0, s - 1.0, s - 1.0, s + 1.0) * 0.5
}

/// Rolls points of the xy-plane onto a cylinder of radius `r`, axis ∥ y, with the seed's map
/// θ = (x − center_x)/r − π/2, (x, z) ↦ (r cos θ, r sin θ); y is kept.
pub fn wrap_cylinder(x: &[Vector3<f64>], r: f64, center_x: f64) -> Vec<Vector3<f64>> {
    x.iter()
        .map(|p| {
            let theta = (p.x - center_x) / r - std::f64::consts::FRAC_PI_2;
            Vector3::new(r * theta.cos(), p.y, r * theta.sin())
        })
        .collect()
}

/// Applies a 2×2 map to the (x, y) coordinates, keeping z.
pub fn map_xy(x: &[Vector3<f64>], m: &Matrix2<f64>) -> Vec<Vector3<f64>> {
    x.iter()
        .map(|p| {
            let q = m * Vector2::new(p.x, p.y);
            Vector3::new(q.x, q.y, p.z)
        })
        .collect()
}

impl SquareCase {
    /// All three, in the seed's order.
    pub const ALL: [SquareCase; 3] = [
        SquareCase::Enlarged,
        SquareCase::Rhombus,
        SquareCase::Cylinder,
    ];

    /// Short name used in tables and files.
    pub fn name(self) -> &'static str {
        match self {
            SquareCase::Enlarged => "enlarged square",
            SquareCase::Rhombus => "rhombus",
            SquareCase::Cylinder => "cylindrical patch",
        }
    }

    /// Planar rest forms (ā^{xy}, b̄^{xy}).
    pub fn planar_forms(self) -> (Matrix2<f64>, Matrix2<f64>) {
        match self {
            SquareCase::Enlarged => (Matrix2::identity() * 4.0, Matrix2::zeros()),
            SquareCase::Rhombus => (Matrix2::new(2.0, 1.0, 1.0, 2.0), Matrix2::zeros()),
            SquareCase::Cylinder => (Matrix2::identity(), Matrix2::new(1.0, 0.0, 0.0, 0.0)),
        }
    }

    /// The analytic equilibrium of the reference mesh `x0` (points of the unit square, z = 0).
    pub fn equilibrium(self, x0: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        match self {
            SquareCase::Enlarged => x0.iter().map(|p| p * 2.0).collect(),
            SquareCase::Rhombus => map_xy(x0, &rhombus_map()),
            SquareCase::Cylinder => wrap_cylinder(x0, 1.0, 0.5),
        }
    }

    /// The seed's perturbed start state (Appendix B): side 1.95, 0.9 × the rhombus map, radius 2.
    pub fn seed_start(self, x0: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        match self {
            SquareCase::Enlarged => x0.iter().map(|p| p * 1.95).collect(),
            SquareCase::Rhombus => map_xy(x0, &(rhombus_map() * 0.9)),
            SquareCase::Cylinder => wrap_cylinder(x0, 2.0, 0.5),
        }
    }
}

/// Root-mean-square distance between corresponding points after the best rigid motion
/// (rotation + translation, no reflection, no scaling) of `x` onto `y` (Kabsch), in the units of
/// the points. Returns `None` for empty or mismatched inputs.
pub fn rms_distance_modulo_rigid(x: &[Vector3<f64>], y: &[Vector3<f64>]) -> Option<f64> {
    if x.is_empty() || x.len() != y.len() {
        return None;
    }
    let n = x.len() as f64;
    let cx = x.iter().sum::<Vector3<f64>>() / n;
    let cy = y.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (p, q) in x.iter().zip(y) {
        h += (p - cx) * (q - cy).transpose();
    }
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut d = Matrix3::identity();
    if (v_t.transpose() * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = v_t.transpose() * d * u.transpose();
    let sum: f64 = x
        .iter()
        .zip(y)
        .map(|(p, q)| (r * (p - cx) + cy - q).norm_squared())
        .sum();
    Some((sum / n).sqrt())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn grid() -> Vec<Vector3<f64>> {
        let mut v = Vec::new();
        for i in 0..=4 {
            for j in 0..=4 {
                v.push(Vector3::new(i as f64 / 4.0, j as f64 / 4.0, 0.0));
            }
        }
        v
    }

    #[test]
    fn rigid_motion_is_invisible() {
        let x = SquareCase::Cylinder.equilibrium(&grid());
        let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let y: Vec<_> = x
            .iter()
            .map(|p| rot * p + Vector3::new(1.0, -2.0, 0.5))
            .collect();
        assert!(rms_distance_modulo_rigid(&x, &y).unwrap() < 1e-14);
    }

    #[test]
    fn reflection_and_scaling_are_not_rigid() {
        let x = SquareCase::Cylinder.equilibrium(&grid());
        let mirrored: Vec<_> = x.iter().map(|p| Vector3::new(-p.x, p.y, p.z)).collect();
        assert!(rms_distance_modulo_rigid(&x, &mirrored).unwrap() > 1e-3);
        // Uniform scaling by 1.95/2 about the centroid: rms distance is 0.025 × rms radius.
        let x = grid();
        let y = SquareCase::Enlarged.equilibrium(&x);
        let z = SquareCase::Enlarged.seed_start(&x);
        let c = y.iter().sum::<Vector3<f64>>() / y.len() as f64;
        let rms_r = (y.iter().map(|p| (p - c).norm_squared()).sum::<f64>() / y.len() as f64).sqrt();
        let d = rms_distance_modulo_rigid(&z, &y).unwrap();
        assert!(
            (d - 0.025 * rms_r).abs() < 1e-12,
            "{d} vs {}",
            0.025 * rms_r
        );
    }

    #[test]
    fn equilibria_have_the_rest_metric() {
        // T^T T of each equilibrium map equals ā^{xy} (so the discrete stretching energy vanishes).
        let t = rhombus_map();
        let (a, _) = SquareCase::Rhombus.planar_forms();
        assert!((t.transpose() * t - a).norm() < 1e-14);
        // Cylinder: arc length along x is preserved: neighbours at distance 1/4 along x stay at
        // chord 2 sin(1/8) on the unit circle.
        let x = SquareCase::Cylinder.equilibrium(&grid());
        let chord = (x[5] - x[0]).norm();
        assert!((chord - 2.0 * (0.125f64).sin()).abs() < 1e-14);
        assert!((x[0].xz().norm() - 1.0).abs() < 1e-14);
    }
}
