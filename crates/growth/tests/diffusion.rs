//! Through-thickness diffusion on the prism mesh (model.md §4.1).
#![allow(clippy::unwrap_used)]

use thinshell_energy::{RestState, SffKind};
use thinshell_growth::{
    Diffusion, DiffusionSettings, DiffusionSource, GrowthError, SourceKind, StimulusField, Surface,
};
use thinshell_mesh::{Mesh, generators};

const H: f64 = 1e-3;
const D: f64 = 1e-9;
/// Through-thickness time scale h²/D, s.
const TAU: f64 = H * H / D;

fn sheet(irregular: bool) -> (Mesh, RestState) {
    let mesh = if irregular {
        generators::irregular_rectangle(0.02, 0.01, 5, 7).unwrap()
    } else {
        generators::rectangle(0.02, 0.01, 4, 2).unwrap()
    };
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    (mesh, rest)
}

fn settings(layers: usize, initial: f64) -> DiffusionSettings {
    DiffusionSettings {
        diffusivity: D,
        thickness: H,
        layers,
        initial,
    }
}

fn whole(mesh: &Mesh, surface: Surface, kind: SourceKind) -> DiffusionSource {
    DiffusionSource {
        surface,
        faces: vec![true; mesh.n_faces()],
        kind,
    }
}

#[test]
fn total_is_conserved_without_sources() {
    let (mesh, rest) = sheet(true);
    let mut d = Diffusion::new(&mesh, &rest, settings(3, 0.0), &[]).unwrap();
    // A rough field: every node different.
    let init: Vec<f64> = (0..d.node_values().len())
        .map(|i| ((i * 7919) % 101) as f64 / 50.0 + 0.5)
        .collect();
    d.set_node_values(&init).unwrap();
    let total0 = d.total();
    for (k, dt) in [0.01, 0.01, 0.3, 0.3, 2.0].iter().enumerate() {
        d.step(dt * TAU).unwrap();
        let rel = (d.total() - total0).abs() / total0.abs();
        assert!(rel < 1e-12, "step {k}: {rel:e}");
    }
    assert_eq!(d.factorizations(), 3, "one factorisation per distinct Δt");
    // Long after the lateral time scale (0.02 m)²/D = 400 τ the field is its volume mean.
    for _ in 0..4 {
        d.step(1e5 * TAU).unwrap();
    }
    let volume = H * rest
        .a_bar
        .iter()
        .map(|a| 0.5 * a.determinant().sqrt())
        .sum::<f64>();
    let mean = total0 / volume;
    assert!(
        d.node_values().iter().all(|&v| (v - mean).abs() < 1e-6),
        "mean {mean}"
    );
    let drift = (d.total() - total0).abs() / total0.abs();
    // M/Δt is ~1e-10 of K at this Δt, so round-off is amplified by the conditioning.
    assert!(drift < 1e-8, "{drift:e}");
}

#[test]
fn uniform_field_stays_uniform() {
    let (mesh, rest) = sheet(true);
    let mut d = Diffusion::new(&mesh, &rest, settings(2, 0.3), &[]).unwrap();
    for _ in 0..10 {
        d.advance(0.0, 0.1 * TAU).unwrap();
    }
    assert!(d.node_values().iter().all(|&m| (m - 0.3).abs() < 1e-14));
    assert!(
        d.values()
            .iter()
            .all(|m| (m.top - 0.3).abs() < 1e-14 && (m.bottom - 0.3).abs() < 1e-14)
    );
}

/// Decay rate of the slowest mode, measured on the total between t = 0.5 τ and 0.6 τ.
fn measured_rate(layers: usize) -> f64 {
    let (mesh, rest) = sheet(false);
    let held = whole(&mesh, Surface::Bottom, SourceKind::Value(0.0));
    let mut d = Diffusion::new(&mesh, &rest, settings(layers, 1.0), &[held]).unwrap();
    let dt = 1e-4 * TAU;
    let (mut t, mut t1, mut m1) = (0.0, 0.0, 0.0);
    while t < 0.6 * TAU - 0.5 * dt {
        d.step(dt).unwrap();
        t += dt;
        if t1 == 0.0 && t >= 0.5 * TAU - 0.5 * dt {
            (t1, m1) = (t, d.total());
        }
    }
    (m1 / d.total()).ln() / (t - t1)
}

#[test]
fn slowest_mode_decays_at_the_analytic_rate() {
    // Bottom held at 0, top insulated: m ∝ sin(π(z + h/2)/(2h)) e^{−π²Dt/(4h²)}.
    let exact = std::f64::consts::PI.powi(2) * D / (4.0 * H * H);
    let errors: Vec<f64> = [1, 2, 4, 8]
        .iter()
        .map(|&l| (measured_rate(l) / exact - 1.0).abs())
        .collect();
    eprintln!("relative rate errors for L = 1, 2, 4, 8: {errors:?}");
    // Linear elements: error O(1/L²) (measured 0.22, 0.052, 0.013, 0.0032 for L = 1, 2, 4, 8);
    // backward Euler at Δt = 1e-4 h²/D adds ~1e-4.
    for w in errors.windows(2) {
        assert!(w[1] < w[0] / 3.0, "{errors:?}");
    }
    assert!(errors[3] < 0.005, "{errors:?}");
}

#[test]
fn flux_adds_exactly_what_flows_in() {
    let (mesh, rest) = sheet(true);
    let q = 2e-7; // stimulus·m/s
    let src = whole(&mesh, Surface::Top, SourceKind::Flux(q));
    let mut d = Diffusion::new(&mesh, &rest, settings(2, 0.0), &[src]).unwrap();
    let area: f64 = rest
        .a_bar
        .iter()
        .map(|a| 0.5 * a.determinant().sqrt())
        .sum();
    let dt = 0.05 * TAU;
    for k in 1..=5 {
        d.step(dt).unwrap();
        let want = q * area * dt * k as f64;
        assert!(
            (d.total() / want - 1.0).abs() < 1e-12,
            "{} vs {want}",
            d.total()
        );
    }
    // Inflow at the top: the top is wetter than the bottom.
    assert!(
        d.values()
            .iter()
            .all(|m| m.top > m.bottom && m.bottom > 0.0)
    );
}

#[test]
fn fixed_value_on_one_face_soaks_through() {
    let (mesh, rest) = sheet(false);
    let src = whole(&mesh, Surface::Top, SourceKind::Value(1.0));
    let mut d = Diffusion::new(&mesh, &rest, settings(4, 0.0), &[src]).unwrap();
    assert!(
        d.values().iter().all(|m| m.top == 0.0),
        "sources act from the first step on"
    );
    d.step(0.05 * TAU).unwrap();
    let m = d.values()[0];
    assert_eq!(m.top, 1.0);
    assert!(m.bottom > 0.0 && m.bottom < 0.2, "{m:?}");
    for _ in 0..100 {
        d.step(0.1 * TAU).unwrap();
    }
    // Steady state: uniform at the held value.
    assert!(d.node_values().iter().all(|&v| (v - 1.0).abs() < 1e-6));
}

#[test]
fn bad_settings_are_refused() {
    let (mesh, rest) = sheet(false);
    let bad = [
        (settings(0, 0.0), "layers"),
        (
            DiffusionSettings {
                diffusivity: f64::NAN,
                ..settings(1, 0.0)
            },
            "diffusivity",
        ),
        (
            DiffusionSettings {
                thickness: 0.0,
                ..settings(1, 0.0)
            },
            "thickness",
        ),
        (settings(1, f64::INFINITY), "initial"),
    ];
    for (s, name) in bad {
        let e = Diffusion::new(&mesh, &rest, s, &[]).unwrap_err();
        assert!(matches!(e, GrowthError::InvalidParameter { .. }), "{e}");
        assert!(e.to_string().contains(name), "{e}");
    }
    let mut d = Diffusion::new(&mesh, &rest, settings(1, 0.0), &[]).unwrap();
    assert!(d.step(-1.0).is_err());
    let short = DiffusionSource {
        surface: Surface::Top,
        faces: vec![true; 3],
        kind: SourceKind::Flux(1.0),
    };
    assert!(matches!(
        Diffusion::new(&mesh, &rest, settings(1, 0.0), &[short]),
        Err(GrowthError::LengthMismatch { .. })
    ));
}
