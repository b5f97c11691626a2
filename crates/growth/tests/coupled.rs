//! Growth coupled with the elastic solver: natural curvature of swelling strips, the seed's
//! directed heat rule, and the coupling order.
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use thinshell_growth::{DirectedHeat, GrowthModel, Region, StimulusField, Swelling};
use thinshell_mesh::generators;
use thinshell_solver::Integrator;
use thinshell_testkit::fixtures::{SwellingStrip, swelling_strip};

const H: f64 = SwellingStrip::THICKNESS;
const C: f64 = 0.01;
const NX: usize = SwellingStrip::NX;

/// Relaxes a 100 × 2 mm strip (`ny` cells across) whose top is swollen by Δm = 1 (ramped over four quasi-static
/// steps) and returns the mean curvature (1/m) of the middle 60 % of its centre line, signed
/// positive when the top side is convex.
fn relaxed_strip_curvature(model: Swelling, ny: usize) -> f64 {
    let SwellingStrip {
        system: mut sys,
        mut growth,
        mut solver,
        mut state,
    } = swelling_strip(model, ny);
    for step in 0..5 {
        let mut rest = sys.rest().clone();
        growth.update_rest(&mut rest).unwrap();
        sys.set_rest(rest).unwrap();
        solver.step(&mut sys, &mut state).unwrap();
        state.t = step as f64 + 1.0;
        growth.advance(step as f64, 1.0).unwrap();
    }
    // The ramp changed the stimulus four times, then stayed: five rest updates in all.
    assert_eq!(growth.rest_updates(), 5);

    // Centre line: row j = 1 of the (NX + 1) × 3 vertex grid.
    let p: Vec<Vector3<f64>> = (0..=NX).map(|i| state.x[(ny / 2) * (NX + 1) + i]).collect();
    let normal = {
        let f = sys.mesh().faces()[NX]; // a face in the middle of the strip
        let q = |k: usize| state.x[f[k].idx()];
        (q(1) - q(0)).cross(&(q(2) - q(0))).normalize()
    };
    let (lo, hi) = (NX / 5, NX - NX / 5);
    let mut sum = 0.0;
    for i in lo..hi {
        let (a, b, c) = (p[i - 1], p[i], p[i + 1]);
        // Circumcircle curvature 4·area/(|ab||bc||ca|), signed by the side the centre is on.
        let k = 2.0 * (b - a).cross(&(c - b)).norm()
            / ((b - a).norm() * (c - b).norm() * (c - a).norm());
        let towards_centre = a + c - 2.0 * b;
        sum += if towards_centre.dot(&normal) < 0.0 {
            k
        } else {
            -k
        };
    }
    sum / (hi - lo) as f64
}

/// Isotropic natural curvature of the rest forms (model.md §4), with the swollen top convex.
fn natural(profile_factor: f64) -> f64 {
    let (lp, lm) = ((1.0 + C).powi(2), 1.0);
    profile_factor * (lp - lm) / (H * (lp + lm))
}

/// Relative curvature errors on 2 mm wide strips with 4 and 8 cells across.
fn strip_errors(model: Swelling, want: f64) -> [f64; 2] {
    [4, 8].map(|ny| (relaxed_strip_curvature(model.clone(), ny) / want - 1.0).abs())
}

// Measured: 2 / 4 / 6 / 8 cells across give +6.5 / +1.9 / +0.86 / +0.48 % for both profiles
// (the mid-edge average's free-boundary error, shrinking about as 1/n²); 16 cells across
// (aspect ratio 16 triangles) make Newton crawl — a hard case recorded for issue #8.

#[test]
fn linear_swelling_strip_relaxes_to_its_natural_curvature() {
    let [e4, e8] = strip_errors(Swelling::linear(C), natural(1.0)); // ≈ c·Δm/h = 10 1/m
    assert!(e4 < 0.03 && e8 < 0.01 && e8 < e4, "{e4} {e8}");
}

#[test]
fn bilayer_strip_relaxes_to_timoshenko_curvature() {
    let [e4, e8] = strip_errors(Swelling::bilayer(C), natural(1.5)); // ≈ 3c·Δm/(2h) = 15 1/m
    assert!(e4 < 0.03 && e8 < 0.01 && e8 < e4, "{e4} {e8}");
}

#[test]
fn directed_heat_spreads_between_the_hot_and_held_regions() {
    let mesh = generators::icosphere(1.0, 2).unwrap();
    let x = mesh.positions();
    let hot = Region::HalfSpace {
        point: Vector3::new(0.0, 0.0, 0.75),
        normal: Vector3::z(),
    };
    let held = Region::HalfSpace {
        point: Vector3::new(0.0, 0.0, 1e-9),
        normal: -Vector3::z(),
    };
    let s = 0.75f64.ln() / 2.0;
    let mut heat = DirectedHeat::new(&mesh, x, &hot, &held, s).unwrap();
    let hot_faces = hot.faces(&mesh, x).unwrap();
    let held_faces = held.faces(&mesh, x).unwrap();
    assert!(hot_faces.iter().filter(|&&h| h).count() >= 5);
    let reached = |h: &DirectedHeat| h.values().iter().filter(|m| m.top != 0.0).count();
    let mut last = reached(&heat);
    for _ in 0..20 {
        heat.advance(0.0, 5e-6).unwrap();
        let v = heat.values();
        for f in 0..mesh.n_faces() {
            if hot_faces[f] {
                assert_eq!(v[f].top, s);
            } else if held_faces[f] {
                assert_eq!(v[f].top, 0.0);
            }
            // An average of values in [s, 0] stays in [s, 0].
            assert!(v[f].top >= s && v[f].top <= 0.0 && v[f].top == v[f].bottom);
        }
        let now = reached(&heat);
        assert!(now >= last);
        last = now;
    }
    // The heat front moved beyond the hot cap but never into the held half.
    assert!(last > hot_faces.iter().filter(|&&h| h).count());
    // One face next to the cap, averaged with its neighbours once: (0 + k·s)/(1 + deg).
    let mut fresh = DirectedHeat::new(&mesh, x, &hot, &held, s).unwrap();
    fresh.advance(0.0, 1.0).unwrap();
    let topo = mesh.topology();
    let f = (0..mesh.n_faces())
        .find(|&f| {
            !hot_faces[f]
                && !held_faces[f]
                && topo
                    .face_neighbors(thinshell_mesh::FaceId::new(f))
                    .iter()
                    .flatten()
                    .any(|g| hot_faces[g.idx()])
        })
        .unwrap();
    let k = topo
        .face_neighbors(thinshell_mesh::FaceId::new(f))
        .iter()
        .flatten()
        .filter(|g| hot_faces[g.idx()])
        .count();
    assert!((fresh.values()[f].top - k as f64 * s / 4.0).abs() < 1e-16);
}

#[test]
fn models_have_names_for_reports() {
    assert_eq!(Swelling::bilayer(0.1).name(), "bilayer swelling");
}
