//! A small Bowyer–Watson Delaunay triangulation of points in a rectangle, used by the
//! generators of irregular planar meshes. Quadratic in the number of points: meant for generator-sized
//! inputs (thousands of points), not for large meshes.

/// Circumcircle of a counter-clockwise triangle: centre and squared radius.
fn circumcircle(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> ([f64; 2], f64) {
    let (bx, by) = (b[0] - a[0], b[1] - a[1]);
    let (cx, cy) = (c[0] - a[0], c[1] - a[1]);
    let d = 2.0 * (bx * cy - by * cx);
    let b2 = bx * bx + by * by;
    let c2 = cx * cx + cy * cy;
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    ([a[0] + ux, a[1] + uy], ux * ux + uy * uy)
}

/// `(b − a) × (c − a)`: positive when `a, b, c` turn counter-clockwise.
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Delaunay triangulation of points filling an axis-aligned rectangle (counter-clockwise
/// triangles, indices into `points`).
///
/// The four corners of the points' bounding box must be among the points (`None`
/// otherwise); every other point lies inside or on a side. Starting from two triangles on the
/// corners, points are inserted one by one (Bowyer–Watson): the triangles whose circumcircle
/// contains the new point are removed and the cavity is re-triangulated from it. A point on a
/// side of the rectangle splits that side: the cavity edge it lies on gets no triangle. No
/// far-away "super-triangle" is needed, which keeps thin triangles at the sides correct.
pub(crate) fn triangulate(points: &[[f64; 2]]) -> Option<Vec<[usize; 3]>> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !(lo[0] < hi[0] && lo[1] < hi[1]) {
        return None;
    }
    let corner = |x: f64, y: f64| points.iter().position(|p| p[0] == x && p[1] == y);
    let c = [
        corner(lo[0], lo[1])?,
        corner(hi[0], lo[1])?,
        corner(hi[0], hi[1])?,
        corner(lo[0], hi[1])?,
    ];
    type Tri = ([usize; 3], [f64; 2], f64);
    let make = |t: [usize; 3]| -> Tri {
        let (cc, r2) = circumcircle(points[t[0]], points[t[1]], points[t[2]]);
        (t, cc, r2)
    };
    let mut tris: Vec<Tri> = vec![make([c[0], c[1], c[2]]), make([c[0], c[2], c[3]])];
    let mut cavity: Vec<(usize, usize)> = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        if c.contains(&i) {
            continue;
        }
        cavity.clear();
        let mut k = 0;
        while k < tris.len() {
            let (t, cc, r2) = tris[k];
            let d2 = (p[0] - cc[0]).powi(2) + (p[1] - cc[1]).powi(2);
            if d2 < r2 {
                for e in 0..3 {
                    cavity.push((t[e], t[(e + 1) % 3]));
                }
                tris.swap_remove(k);
            } else {
                k += 1;
            }
        }
        // Edges seen twice (in opposite directions) are inside the cavity; an edge the new
        // point lies on (a side of the rectangle) is split rather than triangulated.
        let boundary: Vec<(usize, usize)> = cavity
            .iter()
            .filter(|&&(a, b)| !cavity.contains(&(b, a)))
            .filter(|&&(a, b)| orient(points[a], points[b], p) > 0.0)
            .copied()
            .collect();
        for (a, b) in boundary {
            tris.push(make([a, b, i]));
        }
    }
    let mut out: Vec<[usize; 3]> = tris.into_iter().map(|(t, _, _)| t).collect();
    // Deterministic order independent of the removal history.
    for t in &mut out {
        let r = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
        t.rotate_left(r);
    }
    out.sort_unstable();
    Some(out)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Pseudo-random points in the unit square plus its four corners.
    fn points(n: usize, seed: u64) -> Vec<[f64; 2]> {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut p = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        p.extend((0..n).map(|_| [next(), next()]));
        // Points on the sides and one very close to a side (thin triangles there).
        p.extend([
            [0.5, 0.0],
            [1.0, 0.3],
            [0.25, 1.0],
            [0.0, 0.75],
            [0.6, 1e-9],
        ]);
        p
    }

    #[test]
    fn empty_circumcircles_and_full_cover() {
        for seed in 1..6 {
            let p = points(300, seed);
            let t = triangulate(&p).unwrap();
            // Euler: F = 2 n − h − 2 with h = 8 boundary vertices (4 corners, 4 on sides).
            assert_eq!(t.len(), 2 * p.len() - 8 - 2);
            let mut area = 0.0;
            for tri in &t {
                let [a, b, c] = tri.map(|i| p[i]);
                let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                assert!(cross > 0.0, "triangle {tri:?} is not counter-clockwise");
                area += 0.5 * cross;
                let (cc, r2) = circumcircle(a, b, c);
                for (i, q) in p.iter().enumerate() {
                    if tri.contains(&i) {
                        continue;
                    }
                    let d2 = (q[0] - cc[0]).powi(2) + (q[1] - cc[1]).powi(2);
                    assert!(
                        d2 >= r2 * (1.0 - 1e-9),
                        "point {i} inside circumcircle of {tri:?}"
                    );
                }
            }
            assert!((area - 1.0).abs() < 1e-12, "covered area {area}");
        }
    }
}
