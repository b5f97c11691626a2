//! Independent references for the contact tests: distances by convex one-dimensional
//! minimisation (no closest-feature classification) and a certified time of first possible
//! contact along a linear step.
#![allow(dead_code)]

use nalgebra::Vector3;
use thinshell_contact::PairPoints;

pub type V = Vector3<f64>;

/// Distance from p to the segment [a, b] (the clamped foot; an error in the foot parameter
/// changes the distance only to second order).
pub fn point_segment(p: &V, a: &V, b: &V) -> f64 {
    let e = b - a;
    let ee = e.norm_squared();
    let u = if ee > 0.0 {
        ((p - a).dot(&e) / ee).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + e * u)).norm()
}

/// The minimum of a convex function on [0, 1] by golden-section search (100 iterations:
/// bracket 0.618¹⁰⁰ ≈ 1e-21), compared with both end points.
pub fn golden_min(f: impl Fn(f64) -> f64) -> f64 {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (0.0, 1.0);
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..100 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    fc.min(fd).min(f(0.0)).min(f(1.0))
}

/// Point–triangle distance of [p, t0, t1, t2]: the triangle is the union over u ∈ [0, 1] of
/// the segments from t0 + u e1 to t0 + u e1 + (1 − u) e2, and the distance to the slice is
/// convex in u (partial minimisation of a jointly convex function over a convex set).
pub fn ref_point_triangle(x: &PairPoints) -> f64 {
    let e1 = x[2] - x[1];
    let e2 = x[3] - x[1];
    golden_min(|u| {
        let a = x[1] + e1 * u;
        point_segment(&x[0], &a, &(a + e2 * (1.0 - u)))
    })
}

/// Segment–segment distance of [a0, a1, b0, b1]: convex in the parameter along the first.
pub fn ref_edge_edge(x: &PairPoints) -> f64 {
    golden_min(|s| point_segment(&(x[0] + (x[1] - x[0]) * s), &x[2], &x[3]))
}

pub fn ref_distance(x: &PairPoints, point_triangle: bool) -> f64 {
    if point_triangle {
        ref_point_triangle(x)
    } else {
        ref_edge_edge(x)
    }
}

/// The Lipschitz constant of the distance along x + t·dx: the largest relative speed of a point
/// of one primitive against a point of the other (each moves with a convex combination of its
/// vertices' displacements).
pub fn lipschitz(dx: &PairPoints, point_triangle: bool) -> f64 {
    let (a, b): (&[V], &[V]) = if point_triangle {
        (&dx[..1], &dx[1..])
    } else {
        (&dx[..2], &dx[2..])
    };
    let mut l = 0.0f64;
    for p in a {
        for q in b {
            l = l.max((p - q).norm());
        }
    }
    l
}

/// The reference's verdict on a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// distance > tol certified on all of [0, 1].
    Clear,
    /// distance > tol certified on [0, t) only: a contact (distance ≤ tol) is possible at t,
    /// within the bisection resolution.
    PossibleContact(f64),
}

/// Branch and bound over [0, 1]: on [a, b] the distance is at least
/// (d(a) + d(b) − L (b − a)) / 2; intervals that cannot be certified above `tol` are bisected
/// (earliest first) down to a width of 1e-13.
pub fn first_contact(x: &PairPoints, dx: &PairPoints, point_triangle: bool, tol: f64) -> Verdict {
    let l = lipschitz(dx, point_triangle);
    let at = |t: f64| {
        let y: PairPoints = std::array::from_fn(|i| x[i] + dx[i] * t);
        ref_distance(&y, point_triangle)
    };
    // Rounding allowance of the reference distance.
    let slack = 1e-13 * (1.0 + x.iter().map(|p| p.norm()).fold(0.0, f64::max));
    let mut stack = vec![(0.0, 1.0, at(0.0), at(1.0))];
    while let Some((a, b, da, db)) = stack.pop() {
        if 0.5 * (da + db - l * (b - a)) - slack > tol {
            continue;
        }
        if da - slack <= tol || b - a < 1e-13 {
            return Verdict::PossibleContact(a);
        }
        let m = 0.5 * (a + b);
        let dm = at(m);
        // Later half first onto the stack so that the earlier half is examined first.
        stack.push((m, b, dm, db));
        stack.push((a, m, da, dm));
    }
    Verdict::Clear
}
