#![allow(clippy::unwrap_used, clippy::needless_range_loop)]
//! Contact maths (layer 1): closest-feature distances against an independent reference, and
//! finite-difference checks of every gradient and Hessian (distance types, barrier, mollifier,
//! pair energies), including the degenerate configurations.
//! FD: central differences with h = 1e-6 on O(1) coordinates; tolerance 1e-6 relative to the
//! largest entry (truncation O(h²), round-off O(ε/h) ≈ 1e-10 relative).

mod common;

use common::{ref_edge_edge, ref_point_triangle};
use nalgebra::{SMatrix, Vector3};
use proptest::prelude::*;
use thinshell_contact::*;
use thinshell_testkit::fd::{fd_gradient, fd_jacobian, rel_err_scaled};
use thinshell_testkit::strategies::cases_or;

const H: f64 = 1e-6;
const TOL: f64 = 1e-6;

fn flat(x: &PairPoints) -> Vec<f64> {
    x.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
}

fn unflat(v: &[f64]) -> PairPoints {
    std::array::from_fn(|i| Vector3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2]))
}

fn points() -> impl Strategy<Value = PairPoints> {
    prop::array::uniform12(-1.0f64..1.0).prop_map(|v| unflat(&v))
}

fn hess_rows(h: &SMatrix<f64, 12, 12>) -> Vec<f64> {
    h.transpose().iter().copied().collect()
}

/// FD check of value → gradient and gradient → Hessian of one distance type at x.
fn check_type(x: &PairPoints, ty: DistanceType) -> Result<(), TestCaseError> {
    let d = distance2_derivatives(x, ty);
    prop_assert!((d.value - distance2_of_type(x, ty)).abs() <= 1e-12 * (1.0 + d.value));
    let g_fd = fd_gradient(|v| distance2_of_type(&unflat(v), ty), &flat(x), H);
    let e = rel_err_scaled(d.gradient.as_slice(), &g_fd, 1e-3);
    prop_assert!(e < TOL, "{ty:?} gradient error {e}");
    let h_fd = fd_jacobian(
        |v| {
            distance2_derivatives(&unflat(v), ty)
                .gradient
                .as_slice()
                .to_vec()
        },
        &flat(x),
        H,
    );
    let h_fd: Vec<f64> = h_fd.concat();
    let e = rel_err_scaled(&hess_rows(&d.hessian), &h_fd, 1e-3);
    prop_assert!(e < TOL, "{ty:?} Hessian error {e}");
    prop_assert!((d.hessian - d.hessian.transpose()).amax() <= 1e-12 * d.hessian.amax().max(1.0));
    Ok(())
}

const ALL_TYPES: [DistanceType; 6] = [
    DistanceType::PointPoint([0, 1]),
    DistanceType::PointPoint([2, 3]),
    DistanceType::PointEdge([0, 1, 2]),
    DistanceType::PointEdge([3, 0, 1]),
    DistanceType::PointTriangle,
    DistanceType::EdgeEdge,
];

/// Degenerate configurations, each named: point on the triangle (in its plane, inside), point
/// above an edge, above a vertex, on an edge's line outside the triangle, at a vertex; parallel,
/// collinear, crossing and touching edges.
fn degenerate() -> Vec<(&'static str, PairPoints, bool)> {
    let v = Vector3::new;
    let t = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
    let pt = |p: Vector3<f64>| [p, t[0], t[1], t[2]];
    vec![
        ("point in the face", pt(v(0.2, 0.3, 0.0)), true),
        ("point above the face", pt(v(0.2, 0.3, 0.4)), true),
        ("point above an edge", pt(v(0.5, 0.0, 0.3)), true),
        ("point above the hypotenuse", pt(v(0.5, 0.5, 0.2)), true),
        ("point above a vertex", pt(v(1.0, 0.0, 0.25)), true),
        (
            "point on an edge's line, outside",
            pt(v(1.5, 0.0, 0.0)),
            true,
        ),
        ("point at a vertex", pt(v(0.0, 1.0, 0.0)), true),
        ("point on an edge", pt(v(0.4, 0.0, 0.0)), true),
        ("point beyond a vertex", pt(v(-0.3, -0.2, 0.1)), true),
        (
            "parallel edges",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(0.3, 0.2, 0.1),
                v(1.3, 0.2, 0.1),
            ],
            false,
        ),
        (
            "parallel edges, no overlap",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(1.5, 0.2, 0.0),
                v(2.5, 0.2, 0.0),
            ],
            false,
        ),
        (
            "anti-parallel edges",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(0.7, 0.0, 0.3),
                v(-0.2, 0.0, 0.3),
            ],
            false,
        ),
        (
            "collinear edges",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(1.5, 0.0, 0.0),
                v(2.0, 0.0, 0.0),
            ],
            false,
        ),
        (
            "crossing edges",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(0.5, -0.5, 0.0),
                v(0.5, 0.5, 0.0),
            ],
            false,
        ),
        (
            "skew edges",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(0.5, -0.5, 0.2),
                v(0.5, 0.5, 0.2),
            ],
            false,
        ),
        (
            "edge end on the other edge",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(0.5, 0.0, 0.0),
                v(0.5, 0.5, 0.3),
            ],
            false,
        ),
        (
            "edges touching at end points",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(1.0, 1.0, 0.0),
            ],
            false,
        ),
        (
            "nearly parallel edges",
            [
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(0.0, 1e-7, 0.1),
                v(1.0, -1e-7, 0.1),
            ],
            false,
        ),
    ]
}

fn classified(x: &PairPoints, point_triangle: bool) -> (f64, DistanceType) {
    if point_triangle {
        point_triangle_distance2(x)
    } else {
        edge_edge_distance2(x)
    }
}

#[test]
fn degenerate_configurations_distance_and_derivatives() {
    for (name, x, pt) in degenerate() {
        let (d2, ty) = classified(&x, pt);
        let r = if pt {
            ref_point_triangle(&x)
        } else {
            ref_edge_edge(&x)
        };
        assert!(
            (d2.sqrt() - r).abs() < 1e-9,
            "{name}: {ty:?} distance {} vs reference {r}",
            d2.sqrt()
        );
        // The realised type's derivatives, and every type that is well defined there.
        check_type(&x, ty)
            .map_err(|e| format!("{name}: {e}"))
            .unwrap();
        for ty in ALL_TYPES {
            let val = distance2_of_type(&x, ty);
            let d = distance2_derivatives(&x, ty);
            if val.is_finite() && d.hessian.iter().all(|h| h.is_finite()) && d.hessian.amax() < 1e6
            {
                check_type(&x, ty)
                    .map_err(|e| format!("{name}: {e}"))
                    .unwrap();
            }
        }
    }
}

#[test]
fn expected_types_of_named_configurations() {
    let cases = degenerate();
    let ty = |name: &str| {
        let (_, x, pt) = cases.iter().find(|c| c.0 == name).unwrap();
        classified(x, *pt).1
    };
    assert_eq!(ty("point above the face"), DistanceType::PointTriangle);
    // Exactly above a vertex the face and the vertex realise the same distance; either is right.
    assert!(matches!(
        ty("point above a vertex"),
        DistanceType::PointTriangle | DistanceType::PointPoint([0, 2])
    ));
    assert_eq!(
        ty("point beyond a vertex"),
        DistanceType::PointPoint([0, 1])
    );
    assert_eq!(
        ty("point on an edge's line, outside"),
        DistanceType::PointPoint([0, 2])
    );
    assert_eq!(ty("skew edges"), DistanceType::EdgeEdge);
    // Parallel edges fall back to an end point against the other edge.
    assert!(matches!(ty("parallel edges"), DistanceType::PointEdge(_)));
    assert!(matches!(
        ty("nearly parallel edges"),
        DistanceType::PointEdge(_) | DistanceType::PointPoint(_)
    ));
    assert!(matches!(
        ty("parallel edges, no overlap"),
        DistanceType::PointPoint(_)
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(64)))]

    #[test]
    fn classified_distances_match_the_reference(x in points()) {
        for pt in [true, false] {
            let (d2, ty) = classified(&x, pt);
            let r = if pt { ref_point_triangle(&x) } else { ref_edge_edge(&x) };
            prop_assert!((d2.sqrt() - r).abs() < 1e-9, "{ty:?}: {} vs {r}", d2.sqrt());
        }
    }

    #[test]
    fn every_distance_type_matches_fd(x in points()) {
        // Random points keep every type's denominator away from 0 (measure-zero degeneracy).
        for ty in ALL_TYPES {
            check_type(&x, ty)?;
        }
    }

    /// The classified distance is C¹: its FD gradient matches the realised type's gradient
    /// even at a point pushed onto a region boundary (the point projected onto an edge's
    /// normal plane through the edge: the face and edge regions meet there).
    #[test]
    fn classified_distance_is_c1_across_regions(x in points(), lift in 0.05f64..0.5) {
        let e = x[2] - x[1];
        let n = e.cross(&(x[3] - x[1]));
        prop_assume!(n.norm() > 0.2 && e.norm() > 0.2);
        // A point above the middle of edge 1–2, outside the triangle by 0: on the boundary.
        let inward = n.cross(&e).normalize();
        let side = if inward.dot(&(x[3] - x[1])) > 0.0 { 0.0 } else { 1e-300 };
        let mut y = x;
        y[0] = x[1] + e * 0.5 + n.normalize() * lift + inward * side;
        let (_, ty) = point_triangle_distance2(&y);
        let g = distance2_derivatives(&y, ty).gradient;
        let g_fd = fd_gradient(|v| point_triangle_distance2(&unflat(v)).0, &flat(&y), H);
        let err = rel_err_scaled(g.as_slice(), &g_fd, 1e-3);
        prop_assert!(err < 1e-5, "{ty:?}: {err}");
    }
}

#[test]
fn barrier_derivatives_and_clamping() {
    let g_hat = 0.3;
    for &g in &[1e-4, 0.01, 0.1, 0.2, 0.29, 0.2999] {
        let (b, db, ddb) = barrier(g, g_hat);
        let fd1 = (barrier(g + 1e-8, g_hat).0 - barrier(g - 1e-8, g_hat).0) / 2e-8;
        let fd2 = (barrier(g + 1e-8, g_hat).1 - barrier(g - 1e-8, g_hat).1) / 2e-8;
        assert!(
            (db - fd1).abs() <= 1e-6 * (1.0 + db.abs()),
            "b' at {g}: {db} vs {fd1}"
        );
        assert!(
            (ddb - fd2).abs() <= 1e-5 * (1.0 + ddb.abs()),
            "b'' at {g}: {ddb} vs {fd2}"
        );
        assert!(b > 0.0 && db < 0.0 && ddb > 0.0);
    }
    // C² at the activation distance: all three vanish there and beyond.
    assert_eq!(barrier(g_hat, g_hat), (0.0, 0.0, 0.0));
    assert_eq!(barrier(1.0, g_hat), (0.0, 0.0, 0.0));
    let (b, db, ddb) = barrier(g_hat * (1.0 - 1e-6), g_hat);
    assert!(
        b < 1e-12 && db.abs() < 1e-6 && ddb.abs() < 1e-4,
        "{b} {db} {ddb}"
    );
    // Infinite at contact.
    assert_eq!(barrier(0.0, g_hat).0, f64::INFINITY);
    assert_eq!(barrier(-1.0, g_hat).0, f64::INFINITY);
    // Known value: b(ĝ/e) = (ĝ − ĝ/e)².
    let e = std::f64::consts::E;
    let want = (g_hat - g_hat / e).powi(2);
    assert!((barrier(g_hat / e, g_hat).0 - want).abs() < 1e-15);
}

#[test]
fn mollifier_derivatives_and_continuity() {
    let ex = 2.0;
    for &c in &[0.0, 0.3, 1.0, 1.9] {
        let (_, dm, ddm) = mollifier(c, ex);
        let h = 1e-6;
        let fd1 = (mollifier(c + h, ex).0 - mollifier((c - h).max(0.0), ex).0)
            / (c + h - (c - h).max(0.0));
        let fd2 = (mollifier(c + h, ex).1 - mollifier((c - h).max(0.0), ex).1)
            / (c + h - (c - h).max(0.0));
        assert!((dm - fd1).abs() < 1e-6, "m' at {c}");
        assert!((ddm - fd2).abs() < 1e-6, "m'' at {c}");
    }
    assert_eq!(mollifier(0.0, ex).0, 0.0);
    assert!((mollifier(ex * (1.0 - 1e-9), ex).0 - 1.0).abs() < 1e-12);
    assert!(mollifier(ex * (1.0 - 1e-9), ex).1.abs() < 1e-8);
    assert_eq!(mollifier(ex, ex), (1.0, 0.0, 0.0));
    let rest = [
        Vector3::zeros(),
        Vector3::new(2.0, 0.0, 0.0),
        Vector3::zeros(),
        Vector3::new(0.0, 3.0, 0.0),
    ];
    assert!((mollifier_threshold(&rest) - 1e-3 * 4.0 * 9.0).abs() < 1e-15);
}

fn types_nearby_agree(x: &PairPoints, pt: bool) -> bool {
    let ty = classified(x, pt).1;
    let v = flat(x);
    (0..12).all(|i| {
        [-2.0 * H, 2.0 * H].iter().all(|&s| {
            let mut w = v.clone();
            w[i] += s;
            classified(&unflat(&w), pt).1 == ty
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(64)))]

    /// Pair barrier energies (point–triangle; edge–edge with the mollifier active or not),
    /// with a thickness offset, against FD of the energy and of the gradient.
    #[test]
    fn pair_barrier_matches_fd(
        x in points(),
        pt in any::<bool>(),
        offset_frac in 0.0f64..0.5,
        act in 1.05f64..3.0,
        moll in prop_oneof![Just(0.0), 1.1f64..4.0],
    ) {
        prop_assume!(types_nearby_agree(&x, pt));
        let d = classified(&x, pt).0.sqrt();
        prop_assume!(d > 1e-3);
        let offset = offset_frac * d;
        let geometry = BarrierGeometry { activation: act * (d - offset), offset };
        let c = (x[1] - x[0]).cross(&(x[3] - x[2])).norm_squared();
        let kind = if pt {
            PairKind::PointTriangle
        } else {
            PairKind::EdgeEdge { mollifier_threshold: moll * c }
        };
        let PairBarrier::Active(e) = pair_barrier(&x, kind, geometry, false) else {
            return Err(TestCaseError::fail("pair should be active"));
        };
        prop_assert!((e.value - pair_energy(&x, kind, geometry)).abs() <= 1e-12 * e.value.abs().max(1e-12));
        // The barrier varies on the scale of the gap and of its distance to d̂ (down to 5 % of
        // a gap of 10⁻³ here): the FD step is 10⁻³ of the smaller, so that the truncation error
        // O((h/scale)²) stays far below the tolerance (a fixed h = 10⁻⁶ failed at 3.4·10⁻⁵).
        let gap = d - offset;
        let h = H.min(1e-3 * gap.min(geometry.activation - gap));
        let g_fd = fd_gradient(|v| pair_energy(&unflat(v), kind, geometry), &flat(&x), h);
        let err = rel_err_scaled(e.gradient.as_slice(), &g_fd, 1e-6);
        prop_assert!(err < TOL, "gradient error {err}");
        let h_fd = fd_jacobian(
            |v| match pair_barrier(&unflat(v), kind, geometry, false) {
                PairBarrier::Active(e) => e.gradient.as_slice().to_vec(),
                _ => vec![f64::NAN; 12],
            },
            &flat(&x),
            h,
        )
        .concat();
        let err = rel_err_scaled(&hess_rows(&e.hessian), &h_fd, 1e-6);
        prop_assert!(err < TOL, "Hessian error {err}");
        // The PSD projection: no negative eigenvalue left, and the same matrix when already PSD.
        let PairBarrier::Active(p) = pair_barrier(&x, kind, geometry, true) else {
            return Err(TestCaseError::fail("pair should be active"));
        };
        let eig = p.hessian.symmetric_eigenvalues();
        prop_assert!(eig.min() >= -1e-10 * eig.amax().max(1e-300));
        let exact = e.hessian.symmetric_eigenvalues();
        if exact.min() >= 0.0 {
            prop_assert!((p.hessian - e.hessian).amax() <= 1e-10 * e.hessian.amax());
        }
    }
}

#[test]
fn pair_activity_and_penetration() {
    let v = Vector3::new;
    let x = [
        v(0.2, 0.2, 0.1),
        v(0.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(0.0, 1.0, 0.0),
    ];
    let kind = PairKind::PointTriangle;
    let far = BarrierGeometry {
        activation: 0.05,
        offset: 0.0,
    };
    assert_eq!(pair_barrier(&x, kind, far, true), PairBarrier::Inactive);
    assert_eq!(pair_energy(&x, kind, far), 0.0);
    let thick = BarrierGeometry {
        activation: 0.05,
        offset: 0.1,
    };
    assert_eq!(pair_barrier(&x, kind, thick, true), PairBarrier::Penetrated);
    assert_eq!(pair_energy(&x, kind, thick), f64::INFINITY);
    assert!((pair_gap(&x, kind, 0.03) - 0.07).abs() < 1e-15);
    // Gap 0.02 under d̂ = 0.05: b = −(0.02 − 0.05)² ln(0.4).
    let near = BarrierGeometry {
        activation: 0.05,
        offset: 0.08,
    };
    let want = -(0.03f64).powi(2) * (0.4f64).ln();
    let PairBarrier::Active(e) = pair_barrier(&x, kind, near, true) else {
        panic!()
    };
    assert!((e.value - want).abs() < 1e-15 && (pair_energy(&x, kind, near) - want).abs() < 1e-15);
    // The force pushes the point away from the face (+z) and the face down.
    assert!(e.gradient[2] < 0.0 && e.gradient[5] > 0.0);
}
