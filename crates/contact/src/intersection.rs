//! Whether a segment crosses a triangle, and whether two triangles intersect: the check of an
//! intersection-free state (an edge piercing a face has no vertex–face or edge–edge pair at
//! distance 0, so the distances alone cannot see it).
//!
//! Floating-point orientation tests (signed volumes in f64): a configuration within rounding of
//! touching may be reported either way; the contact code keeps pairs at least a minimum
//! separation apart, far above that.

use nalgebra::Vector3;

type V = Vector3<f64>;

fn orient(a: &V, b: &V, c: &V, d: &V) -> f64 {
    (b - a).cross(&(c - a)).dot(&(d - a))
}

/// Whether the closed segment [p, q] meets the closed triangle (a, b, c) at a single point
/// crossing its plane (a segment lying in the triangle's plane is not reported: coplanar
/// contact shows as a zero point–triangle or edge–edge distance instead).
pub fn segment_crosses_triangle(p: &V, q: &V, tri: &[V; 3]) -> bool {
    let [a, b, c] = tri;
    let sp = orient(a, b, c, p);
    let sq = orient(a, b, c, q);
    if (sp > 0.0 && sq > 0.0) || (sp < 0.0 && sq < 0.0) || (sp == 0.0 && sq == 0.0) {
        return false;
    }
    // The line p→q passes inside the triangle iff the three edge volumes share a sign.
    let s1 = orient(p, q, a, b);
    let s2 = orient(p, q, b, c);
    let s3 = orient(p, q, c, a);
    (s1 >= 0.0 && s2 >= 0.0 && s3 >= 0.0) || (s1 <= 0.0 && s2 <= 0.0 && s3 <= 0.0)
}

/// Whether two triangles that share no vertex intersect: an edge of one crosses the other.
pub fn triangles_intersect(t: &[V; 3], u: &[V; 3]) -> bool {
    (0..3).any(|i| segment_crosses_triangle(&t[i], &t[(i + 1) % 3], u))
        || (0..3).any(|i| segment_crosses_triangle(&u[i], &u[(i + 1) % 3], t))
}
