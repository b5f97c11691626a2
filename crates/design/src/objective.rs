//! Shape objectives J(x) (m²) with their gradients in the positions, and the smoothness
//! regulariser of the parameters.

use nalgebra::{Matrix3, Vector3};
use thinshell_mesh::Mesh;

use crate::param::Support;

/// A scalar objective of the equilibrium positions: value (m² for the distances here) and
/// gradient ∂J/∂x (m, one per vertex), plus the target's size (m) that residuals are reported
/// against.
pub trait ShapeObjective: Send + Sync {
    /// J(x) and ∂J/∂x (`grad` overwritten, one entry per vertex).
    fn evaluate(&self, x: &[Vector3<f64>], grad: &mut [Vector3<f64>]) -> f64;

    /// The target's size (m, e.g. its bounding-box diagonal).
    fn size(&self) -> f64;

    /// The root-mean-square distance (m) that value `j` means (√(2J) for the distances here).
    fn rms(&self, j: f64) -> f64 {
        (2.0 * j).max(0.0).sqrt()
    }
}

fn diagonal(points: &[Vector3<f64>]) -> f64 {
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for p in points {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (hi - lo).norm()
}

/// Distance to target positions on the same connectivity: J = 1/(2n) Σ_v |x_v − y_v|², or with
/// `rigid`, the same after the best rigid motion of x onto y (Kabsch; the gradient by the
/// envelope theorem, the optimal motion held fixed).
#[derive(Clone, Debug)]
pub struct TargetPositions {
    /// Target position per vertex (m).
    pub target: Vec<Vector3<f64>>,
    /// Measure modulo rigid motion.
    pub rigid: bool,
}

/// The rotation R and translation t minimising Σ |R x_v + t − y_v|².
pub fn best_rigid_motion(x: &[Vector3<f64>], y: &[Vector3<f64>]) -> (Matrix3<f64>, Vector3<f64>) {
    let n = x.len().max(1) as f64;
    let cx = x.iter().sum::<Vector3<f64>>() / n;
    let cy = y.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    for (p, q) in x.iter().zip(y) {
        cov += (q - cy) * (p - cx).transpose();
    }
    let svd = cov.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return (Matrix3::identity(), cy - cx);
    };
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = u * d * vt;
    (r, cy - r * cx)
}

impl ShapeObjective for TargetPositions {
    fn evaluate(&self, x: &[Vector3<f64>], grad: &mut [Vector3<f64>]) -> f64 {
        let n = x.len().max(1) as f64;
        let (r, t) = if self.rigid {
            best_rigid_motion(x, &self.target)
        } else {
            (Matrix3::identity(), Vector3::zeros())
        };
        let mut j = 0.0;
        for ((p, q), g) in x.iter().zip(&self.target).zip(grad.iter_mut()) {
            let d = r * p + t - q;
            j += d.norm_squared();
            *g = r.transpose() * d / n;
        }
        0.5 * j / n
    }

    fn size(&self) -> f64 {
        diagonal(&self.target)
    }
}

/// Distance to a target surface of any connectivity: J = 1/(2n) Σ_v |x_v − c(x_v)|², c the
/// closest point of the target triangles (gradient (x_v − c)/n: the closest point moves
/// tangentially to first order). Brute force over the target's faces per vertex: for the
/// coarse meshes of a design loop.
#[derive(Clone, Debug)]
pub struct ClosestPoint {
    triangles: Vec<[Vector3<f64>; 3]>,
    size: f64,
}

impl ClosestPoint {
    /// The target surface `target` (its positions).
    pub fn new(target: &Mesh) -> ClosestPoint {
        let p = target.positions();
        ClosestPoint {
            triangles: target
                .faces()
                .iter()
                .map(|f| [p[f[0].idx()], p[f[1].idx()], p[f[2].idx()]])
                .collect(),
            size: diagonal(p),
        }
    }

    /// The closest point of the target to `q`.
    pub fn closest(&self, q: &Vector3<f64>) -> Vector3<f64> {
        let mut best = (f64::INFINITY, *q);
        for t in &self.triangles {
            let c = closest_on_triangle(q, t);
            let d = (c - q).norm_squared();
            if d < best.0 {
                best = (d, c);
            }
        }
        best.1
    }
}

impl ShapeObjective for ClosestPoint {
    fn evaluate(&self, x: &[Vector3<f64>], grad: &mut [Vector3<f64>]) -> f64 {
        let n = x.len().max(1) as f64;
        let mut j = 0.0;
        for (p, g) in x.iter().zip(grad.iter_mut()) {
            let d = p - self.closest(p);
            j += d.norm_squared();
            *g = d / n;
        }
        0.5 * j / n
    }

    fn size(&self) -> f64 {
        self.size
    }
}

/// Closest point of triangle `t` to `p` (Ericson, Real-Time Collision Detection §5.1.5).
fn closest_on_triangle(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> Vector3<f64> {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// The objective function type of [`UserObjective`]: positions → (value, gradient per vertex).
pub type UserFn = dyn Fn(&[Vector3<f64>]) -> (f64, Vec<Vector3<f64>>) + Send + Sync;

/// A user-supplied objective: value and gradient in the positions from a closure.
pub struct UserObjective {
    /// The objective.
    pub f: Box<UserFn>,
    /// Size (m) residuals are reported against.
    pub size: f64,
}

impl std::fmt::Debug for UserObjective {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UserObjective")
            .field("size", &self.size)
            .finish_non_exhaustive()
    }
}

impl ShapeObjective for UserObjective {
    fn evaluate(&self, x: &[Vector3<f64>], grad: &mut [Vector3<f64>]) -> f64 {
        let (j, g) = (self.f)(x);
        for (o, v) in grad.iter_mut().zip(g) {
            *o = v;
        }
        j
    }

    fn size(&self) -> f64 {
        self.size
    }
}

/// The graph Laplacian smoothness term R(p) = μ/2 Σ_{(i,j)} Σ_k (p_ik − p_jk)² over mesh edges
/// (vertex support) or pairs of faces sharing an edge (face support), `per` parameters per item.
#[derive(Clone, Debug)]
pub struct Smoothness {
    pairs: Vec<(usize, usize)>,
    per: usize,
    /// Weight μ (units of J per unit parameter²).
    pub weight: f64,
}

impl Smoothness {
    /// The regulariser of a parametrisation with `layout` on `mesh`, weight `weight`.
    pub fn new(mesh: &Mesh, layout: (Support, usize), weight: f64) -> Smoothness {
        let edges = mesh.topology().edges();
        let pairs = match layout.0 {
            Support::Vertex => edges
                .iter()
                .map(|e| (e.vertices[0].idx(), e.vertices[1].idx()))
                .collect(),
            Support::Face => edges
                .iter()
                .filter_map(|e| e.right.map(|r| (e.left.idx(), r.idx())))
                .collect(),
        };
        Smoothness {
            pairs,
            per: layout.1,
            weight,
        }
    }

    /// R(p), adding ∂R/∂p to `grad`.
    pub fn evaluate(&self, p: &[f64], grad: &mut [f64]) -> f64 {
        let mut r = 0.0;
        for &(i, j) in &self.pairs {
            for k in 0..self.per {
                let (a, b) = (self.per * i + k, self.per * j + k);
                let d = p[a] - p[b];
                r += d * d;
                grad[a] += self.weight * d;
                grad[b] -= self.weight * d;
            }
        }
        0.5 * self.weight * r
    }
}
