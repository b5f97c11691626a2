//! Exact intersection tests of triangles with f64 vertices, independent of the contact code's
//! floating-point predicates (`thinshell_contact::intersection`): orientation signs from
//! a floating-point filter with a deliberately loose error bound, and from exact rational
//! arithmetic (`num-rational`'s `BigRational`, which holds every finite f64 exactly) whenever
//! the filter cannot decide. Closed sets: touching counts as intersecting, coplanar overlaps
//! included.

use nalgebra::Vector3;
use num_rational::BigRational;
use num_traits::{Signed, Zero};

type V = Vector3<f64>;

/// Relative error bound of the filters: far above the ~10⁻¹⁵ of Shewchuk's bounds, so a
/// filtered sign is certainly right; undecided cases go to exact arithmetic.
const FILTER: f64 = 1e-12;

fn q(x: f64) -> BigRational {
    BigRational::from_float(x).expect("finite coordinates")
}

fn sign(x: &BigRational) -> i8 {
    if x.is_zero() {
        0
    } else if x.is_positive() {
        1
    } else {
        -1
    }
}

/// The sign of det[b − a, c − a, d − a]: positive when d lies on the side of the plane (a, b, c)
/// that its normal (b − a) × (c − a) points to, 0 exactly when the four points are coplanar.
pub fn orient3d(a: &V, b: &V, c: &V, d: &V) -> i8 {
    let (u, v, w) = (b - a, c - a, d - a);
    let det = u.dot(&v.cross(&w));
    // The sum of the absolute values of the determinant's six products.
    let permanent = u.abs().dot(&V::new(
        v.y.abs() * w.z.abs() + v.z.abs() * w.y.abs(),
        v.z.abs() * w.x.abs() + v.x.abs() * w.z.abs(),
        v.x.abs() * w.y.abs() + v.y.abs() * w.x.abs(),
    ));
    let bound = FILTER * permanent;
    if permanent.is_finite() && permanent > 0.0 {
        if det > bound {
            return 1;
        }
        if det < -bound {
            return -1;
        }
    }
    let d3 = |p: &V, o: &V| [q(p.x) - q(o.x), q(p.y) - q(o.y), q(p.z) - q(o.z)];
    let (u, v, w) = (d3(b, a), d3(c, a), d3(d, a));
    let cx = &v[1] * &w[2] - &v[2] * &w[1];
    let cy = &v[2] * &w[0] - &v[0] * &w[2];
    let cz = &v[0] * &w[1] - &v[1] * &w[0];
    sign(&(&u[0] * cx + &u[1] * cy + &u[2] * cz))
}

/// The sign of the 2D orientation of (a, b, c) in the coordinates other than `drop`.
fn orient2d(a: &V, b: &V, c: &V, drop: usize) -> i8 {
    let (i, j) = ((drop + 1) % 3, (drop + 2) % 3);
    let det = (b[i] - a[i]) * (c[j] - a[j]) - (b[j] - a[j]) * (c[i] - a[i]);
    let permanent = ((b[i] - a[i]) * (c[j] - a[j])).abs() + ((b[j] - a[j]) * (c[i] - a[i])).abs();
    if permanent.is_finite() && permanent > 0.0 {
        if det > FILTER * permanent {
            return 1;
        }
        if det < -FILTER * permanent {
            return -1;
        }
    }
    let det = (q(b[i]) - q(a[i])) * (q(c[j]) - q(a[j])) - (q(b[j]) - q(a[j])) * (q(c[i]) - q(a[i]));
    sign(&det)
}

/// Whether the closed segments [p, r] and [s, t], all four points in one plane, meet (2D test in
/// the coordinates other than `drop`).
fn segments_meet_2d(p: &V, r: &V, s: &V, t: &V, drop: usize) -> bool {
    let (d1, d2) = (orient2d(p, r, s, drop), orient2d(p, r, t, drop));
    let (d3, d4) = (orient2d(s, t, p, drop), orient2d(s, t, r, drop));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    // A collinear end point meets the other segment iff it lies within its bounding box.
    let (i, j) = ((drop + 1) % 3, (drop + 2) % 3);
    let within = |a: &V, b: &V, c: &V| {
        a[i].min(b[i]) <= c[i]
            && c[i] <= a[i].max(b[i])
            && a[j].min(b[j]) <= c[j]
            && c[j] <= a[j].max(b[j])
    };
    (d1 == 0 && within(p, r, s))
        || (d2 == 0 && within(p, r, t))
        || (d3 == 0 && within(s, t, p))
        || (d4 == 0 && within(s, t, r))
}

/// Whether the point p (in the triangle's plane) lies in the closed triangle, 2D test.
fn in_triangle_2d(p: &V, tri: &[V; 3], drop: usize) -> bool {
    let s = [
        orient2d(&tri[0], &tri[1], p, drop),
        orient2d(&tri[1], &tri[2], p, drop),
        orient2d(&tri[2], &tri[0], p, drop),
    ];
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

/// Whether the closed segment [p, r] meets the closed, non-degenerate triangle `tri`.
pub fn segment_meets_triangle(p: &V, r: &V, tri: &[V; 3]) -> bool {
    let [a, b, c] = tri;
    let (sp, sr) = (orient3d(a, b, c, p), orient3d(a, b, c, r));
    if sp * sr > 0 {
        return false;
    }
    if sp == 0 && sr == 0 {
        // Coplanar: in a projection that keeps the triangle non-degenerate.
        let Some(drop) = (0..3).find(|&k| orient2d(a, b, c, k) != 0) else {
            return false;
        };
        return in_triangle_2d(p, tri, drop)
            || in_triangle_2d(r, tri, drop)
            || (0..3).any(|k| segments_meet_2d(p, r, &tri[k], &tri[(k + 1) % 3], drop));
    }
    // The segment meets the plane at one point; it is in the triangle iff the line p→r passes
    // on the same side of (or through) all three edges.
    let s = [
        orient3d(p, r, a, b),
        orient3d(p, r, b, c),
        orient3d(p, r, c, a),
    ];
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

/// Whether two closed triangles meet: for triangles, exactly when an edge of one meets the
/// other.
pub fn triangles_meet(t: &[V; 3], u: &[V; 3]) -> bool {
    (0..3).any(|i| segment_meets_triangle(&t[i], &t[(i + 1) % 3], u))
        || (0..3).any(|i| segment_meets_triangle(&u[i], &u[(i + 1) % 3], t))
}

/// The first pair of faces `[f, g]` (f < g) of a mesh at positions `x` that share no vertex and
/// meet (exactly, closed triangles), if any. Bounding boxes (exact f64 comparisons) filter the
/// pairs in a sweep along x. Faces sharing a vertex are not tested.
pub fn first_meeting_faces(x: &[V], faces: &[[usize; 3]]) -> Option<[usize; 2]> {
    let boxes: Vec<(V, V)> = faces
        .iter()
        .map(|f| {
            let p = f.map(|v| x[v]);
            (p[0].inf(&p[1]).inf(&p[2]), p[0].sup(&p[1]).sup(&p[2]))
        })
        .collect();
    let mut order: Vec<usize> = (0..faces.len()).collect();
    order.sort_by(|&i, &j| boxes[i].0.x.total_cmp(&boxes[j].0.x));
    let mut found: Option<[usize; 2]> = None;
    for (k, &f) in order.iter().enumerate() {
        for &g in &order[k + 1..] {
            if boxes[g].0.x > boxes[f].1.x {
                break;
            }
            let overlap =
                (0..3).all(|c| boxes[f].0[c] <= boxes[g].1[c] && boxes[g].0[c] <= boxes[f].1[c]);
            if !overlap || faces[f].iter().any(|v| faces[g].contains(v)) {
                continue;
            }
            if triangles_meet(&faces[f].map(|v| x[v]), &faces[g].map(|v| x[v])) {
                let pair = [f.min(g), f.max(g)];
                if found.is_none_or(|p| pair < p) {
                    found = Some(pair);
                }
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_predicates_on_touching_and_near_cases() {
        let tri = [V::zeros(), V::x(), V::y()];
        // Crossing, touching at an end point, coplanar overlap, coplanar apart, one ulp above.
        assert!(segment_meets_triangle(
            &V::new(0.2, 0.2, -1.0),
            &V::new(0.2, 0.2, 1.0),
            &tri
        ));
        assert!(segment_meets_triangle(
            &V::new(0.2, 0.2, 0.0),
            &V::new(0.2, 0.2, 1.0),
            &tri
        ));
        assert!(segment_meets_triangle(
            &V::new(-1.0, 0.3, 0.0),
            &V::new(2.0, 0.3, 0.0),
            &tri
        ));
        assert!(!segment_meets_triangle(
            &V::new(0.6, 0.6, 0.0),
            &V::new(2.0, 0.6, 0.0),
            &tri
        ));
        let up = f64::from_bits(1);
        assert!(!segment_meets_triangle(
            &V::new(0.2, 0.2, up),
            &V::new(0.2, 0.2, 1.0),
            &tri
        ));
        // On the hypotenuse exactly (0.5, 0.5) and a hair outside it.
        assert!(segment_meets_triangle(
            &V::new(0.5, 0.5, -1.0),
            &V::new(0.5, 0.5, 1.0),
            &tri
        ));
        let out = 0.5 + f64::EPSILON;
        assert!(!segment_meets_triangle(
            &V::new(out, 0.5, -1.0),
            &V::new(out, 0.5, 1.0),
            &tri
        ));
    }
}
