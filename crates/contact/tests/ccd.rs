#![allow(clippy::unwrap_used)]
//! Additive CCD (layer 2) against an independent reference: on random and adversarial
//! vertex–face and edge–edge steps (head-on, parallel, coplanar, touching exactly at t = 1,
//! near-misses at a few ulps to a few ξ, far from the origin), the distance stays above ξ/2
//! over [0, toi] — certified by a Lipschitz branch and bound on a classification-free distance
//! (`common`). The false-positive rate (toi < 1 although the distance never reaches ξ
//! over the whole step) is printed; run with `--nocapture` to see it.

mod common;

use common::{Verdict, first_contact};
use nalgebra::Vector3;
use thinshell_contact::*;
use thinshell_testkit::rng::SplitMix64;

type V = Vector3<f64>;

struct Query {
    family: &'static str,
    x: PairPoints,
    dx: PairPoints,
    point_triangle: bool,
}

fn kind(pt: bool) -> PairKind {
    if pt {
        PairKind::PointTriangle
    } else {
        PairKind::EdgeEdge {
            mollifier_threshold: 0.0,
        }
    }
}

fn tri(r: &mut SplitMix64) -> [V; 3] {
    [
        r.vector3(0.2),
        V::new(1.0, 0.0, 0.0) + r.vector3(0.2),
        V::new(0.0, 1.0, 0.0) + r.vector3(0.2),
    ]
}

/// The families of queries, `n` of each, from one seed.
fn queries(n: usize, seed: u64) -> Vec<Query> {
    let mut r = SplitMix64::new(seed);
    let mut out = Vec::new();
    let v = V::new;
    for _ in 0..n {
        // Random points and displacements.
        let x: PairPoints = std::array::from_fn(|_| r.vector3(1.0));
        let dx: PairPoints = std::array::from_fn(|_| r.vector3(2.0));
        let pt = r.unit() < 0.5;
        out.push(Query {
            family: "random",
            x,
            dx,
            point_triangle: pt,
        });

        // A point through the face, head-on, with the face moving too.
        let t = tri(&mut r);
        let p = v(0.3, 0.3, 0.5) + r.vector3(0.05);
        let x = [p, t[0], t[1], t[2]];
        let dx = [
            v(0.0, 0.0, -1.0) + r.vector3(0.1),
            r.vector3(0.1),
            r.vector3(0.1),
            r.vector3(0.1),
        ];
        out.push(Query {
            family: "point through face",
            x,
            dx,
            point_triangle: true,
        });

        // Touching exactly at t = 1: the point ends on the (fixed) flat face.
        let a = r.uniform(0.1, 0.4);
        let b = r.uniform(0.1, 0.4);
        let x = [
            v(a, b, r.uniform(0.1, 1.0)),
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(0.0, 1.0, 0.0),
        ];
        let dx = [
            v(r.signed() * 0.1, r.signed() * 0.1, -x[0].z),
            V::zeros(),
            V::zeros(),
            V::zeros(),
        ];
        out.push(Query {
            family: "touching at t = 1",
            x,
            dx,
            point_triangle: true,
        });

        // Coplanar: the point slides in the face's plane towards (and past) an edge.
        let x = [
            v(r.uniform(1.2, 2.0), r.uniform(0.0, 0.5), 0.0),
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(0.0, 1.0, 0.0),
        ];
        let dx = [
            v(-r.uniform(0.5, 2.0), r.signed() * 0.2, 0.0),
            V::zeros(),
            V::zeros(),
            V::zeros(),
        ];
        out.push(Query {
            family: "coplanar",
            x,
            dx,
            point_triangle: true,
        });

        // Near-miss: the point passes beside a vertex at a tiny gap (a few ulps up to 1e-5).
        let gap = 10f64.powf(r.uniform(-15.0, -5.0));
        let x = [
            v(-1.0, -gap, 0.3),
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(0.0, 1.0, 0.0),
        ];
        let dx = [v(2.0, 0.0, -0.6), V::zeros(), V::zeros(), V::zeros()];
        out.push(Query {
            family: "near-miss",
            x,
            dx,
            point_triangle: true,
        });

        // Parallel edges closing in (and sliding along each other).
        let d = v(1.0, 0.0, 0.0) + r.vector3(1e-9);
        let y0 = r.uniform(0.05, 0.5);
        let x = [
            v(0.0, 0.0, 0.0),
            d,
            v(r.signed() * 0.5, y0, 0.0),
            v(r.signed() * 0.5, y0, 0.0) + d,
        ];
        let s = r.uniform(0.5, 2.0);
        let dx = [
            V::zeros(),
            V::zeros(),
            v(r.signed(), -s * y0, 0.0),
            v(r.signed(), -s * y0, 0.0),
        ];
        out.push(Query {
            family: "parallel edges",
            x,
            dx,
            point_triangle: false,
        });

        // Crossing edges: one edge sweeps through the other.
        let x = [
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(0.5, -0.5, 0.3),
            v(0.5, 0.5, 0.3) + r.vector3(0.1),
        ];
        let dx = [
            V::zeros(),
            V::zeros(),
            v(0.0, 0.0, -0.6) + r.vector3(0.1),
            v(0.0, 0.0, -0.6) + r.vector3(0.1),
        ];
        out.push(Query {
            family: "crossing edges",
            x,
            dx,
            point_triangle: false,
        });

        // Edge–edge near-miss: passing over the other edge's end at a tiny gap.
        let gap = 10f64.powf(r.uniform(-15.0, -5.0));
        let x = [
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(1.0 + gap, -0.5, 0.3),
            v(1.0 + gap, 0.5, 0.3),
        ];
        let dx = [V::zeros(), V::zeros(), v(0.0, 0.0, -0.6), v(0.0, 0.0, -0.6)];
        out.push(Query {
            family: "edge near-miss",
            x,
            dx,
            point_triangle: false,
        });

        // Far from the origin (coordinates ~1e3, features ~1): rounding-sensitive.
        let o = v(1e3, -2e3, 1.5e3);
        let t = tri(&mut r);
        let x = [o + v(0.3, 0.3, 0.2), o + t[0], o + t[1], o + t[2]];
        let dx = [v(0.0, 0.0, -0.4), V::zeros(), V::zeros(), V::zeros()];
        out.push(Query {
            family: "far from origin",
            x,
            dx,
            point_triangle: true,
        });
    }
    out
}

/// Runs every query with minimum separation ξ; returns (queries, false positives, contacts).
fn run(xi: f64, n: usize, seed: u64) -> (usize, usize, usize) {
    let settings = CcdSettings {
        min_separation: xi,
        ..CcdSettings::default()
    };
    let mut false_positives = 0;
    let mut contacts = 0;
    let qs = queries(n, seed);
    for q in &qs {
        let toi = additive_ccd(&q.x, &q.dx, kind(q.point_triangle), 1.0, &settings);
        assert!((0.0..=1.0).contains(&toi), "{}: toi {toi}", q.family);
        let d0 = if q.point_triangle {
            point_triangle_distance2(&q.x).0.sqrt()
        } else {
            edge_edge_distance2(&q.x).0.sqrt()
        };
        if d0 <= xi {
            assert_eq!(toi, 0.0, "{}: starts within ξ", q.family);
            continue;
        }
        assert!(
            toi > 0.0,
            "{}: a pair starting outside ξ may move",
            q.family
        );
        // No false negative: the distance stays above ξ/2 on [0, toi].
        let scaled: PairPoints = std::array::from_fn(|i| q.dx[i] * toi);
        let verdict = first_contact(&q.x, &scaled, q.point_triangle, 0.5 * xi);
        assert_eq!(
            verdict,
            Verdict::Clear,
            "{}: toi {toi} passes a contact; x {:?} dx {:?}",
            q.family,
            q.x,
            q.dx
        );
        let full = first_contact(&q.x, &q.dx, q.point_triangle, xi);
        if full == Verdict::Clear {
            if toi < 1.0 {
                false_positives += 1;
            }
        } else {
            contacts += 1;
            assert!(toi < 1.0, "{}: a contact within ξ needs toi < 1", q.family);
        }
    }
    (qs.len(), false_positives, contacts)
}

#[test]
fn additive_ccd_has_no_false_negative() {
    for (xi, seed) in [(1e-6, 1), (1e-9, 2), (1e-4, 3)] {
        let (n, fp, contacts) = run(xi, 120, seed);
        let clear = n - contacts;
        eprintln!(
            "ξ = {xi:e}: {n} queries, {contacts} contacts within ξ, {fp} of {clear} clear steps shortened \
             (false-positive rate {:.1} %)",
            100.0 * fp as f64 / clear.max(1) as f64
        );
        assert!(contacts > n / 4, "the families must include real contacts");
    }
}

#[test]
fn additive_ccd_special_cases() {
    let v = V::new;
    let s = CcdSettings {
        min_separation: 1e-6,
        ..CcdSettings::default()
    };
    let x = [
        v(0.2, 0.2, 0.5),
        v(0.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(0.0, 1.0, 0.0),
    ];
    let pt = PairKind::PointTriangle;
    // A rigid translation never collides; neither does a step moving away.
    let tr = [v(0.3, -1.0, 2.0); 4];
    assert_eq!(additive_ccd(&x, &tr, pt, 1.0, &s), 1.0);
    let away = [v(0.0, 0.0, 1.0), V::zeros(), V::zeros(), V::zeros()];
    assert_eq!(additive_ccd(&x, &away, pt, 0.7, &s), 0.7);
    // Head-on at speed 1 from 0.5: contact at t = 0.5; the returned time is before it and
    // leaves at least s = 10 % of the gap, and is not needlessly short.
    let down = [v(0.0, 0.0, -1.0), V::zeros(), V::zeros(), V::zeros()];
    let t = additive_ccd(&x, &down, pt, 1.0, &s);
    assert!((0.3..0.5).contains(&t), "{t}");
    // Starting within ξ: no motion allowed.
    let touching = [v(0.2, 0.2, 1e-7), x[1], x[2], x[3]];
    assert_eq!(additive_ccd(&touching, &down, pt, 1.0, &s), 0.0);
    // Non-finite input: no motion, never a panic.
    let nan = [v(f64::NAN, 0.0, 0.0), V::zeros(), V::zeros(), V::zeros()];
    assert_eq!(additive_ccd(&x, &nan, pt, 1.0, &s), 0.0);
}
