//! Exact answers of this energy: sphere inflation under pressure and two zero-energy rest
//! shapes (a helix from a flat strip, a spherical cap from a flat disc).

use anyhow::{Result, anyhow};
use nalgebra::Matrix2;
use thinshell::reference::{rms_distance_modulo_rigid, wrap_cylinder};
use thinshell_energy::{Material, RestState, SffKind};
use thinshell_mesh::generators;
use thinshell_system::{Boundary, Loads};

use super::case::{Curve, Outcome, Quantity, Spec};
use super::solve::{Config, V3, equilibrium, ramp, system};

/// Group name of these cases (the test checks their quick tolerances).
pub(crate) const GROUP: &str = "exact / analytic";

pub(crate) static SPECS: [Spec; 3] = [
    Spec {
        name: "sphere inflation p(λ)",
        group: GROUP,
        description: "Sphere of radius R₀ = 1, h = 0.05, E = 1e4, ν = 0.3 (consistent units), \
            rest shape = the icosphere, under internal pressure p (a follower load), ramped through \
            the pressures p(λ) of the closed form p(λ) = E h/((1−ν) R₀)·[(λ²−1)/λ + \
            (h²/(6R₀²))(λ−1)/λ²] for λ = 1.05, 1.1, 1.2, 1.5. Measured λ = mean distance of the \
            vertices from their centroid / R₀. Error = |λ_measured − λ| / (λ − 1) (relative to the \
            stretch), largest over the four pressures. Meshes: icosphere levels 1, 2, 3 (level 4 \
            takes minutes with the edge-director forms; the mid-edge average gives 0.11 % there).",
        tolerance: 0.01,
        quick_tolerance: 0.1,
        levels: 3,
        first_level: 0,
        reference_curves: inflation_reference,
        run: inflation,
    },
    Spec {
        name: "helix from a flat strip",
        group: GROUP,
        description: "Flat strip 3 × 0.3 (h = 0.01, E = 1e6, ν = 0.3), ā = I, b̄ = κ d⊗d with \
            κ = 1 and d at φ = 30° to the strip axis: its zero-energy shape is the strip wound \
            isometrically on a cylinder of radius 1/κ with d along the circumference, i.e. a \
            helix of radius 1/κ and pitch 2π tanφ/κ. Start: the same strip wound on a cylinder \
            of radius 1.5/κ; free edges. Error = RMS vertex distance to the exact shape after \
            removing rigid motion, × κ. Meshes: alternating-diagonal grids 30×3, 60×6, 120×12.",
        tolerance: 0.01,
        quick_tolerance: 0.05,
        levels: 3,
        first_level: 0,
        reference_curves: Vec::new,
        run: helix,
    },
    Spec {
        name: "spherical cap from a flat disc",
        group: GROUP,
        description: "Flat disc of radius 1 (h = 0.01, E = 1e6, ν = 0.3) with the \
            spherical-cap metric ds² = dr² + (sin(√K r)/√K)² dθ², K = 1 (per face: ā = the first \
            fundamental form of the triangle placed on the exact cap) and b̄ = √K ā: its \
            zero-energy shape is the cap of radius 1/√K over polar angles 0 … 1 rad. Start: the \
            flat disc lifted to z = r²/4; free edge. Error = RMS vertex distance to the exact \
            cap after removing rigid motion, × √K. Meshes: disc with 4, 8, 16 rings.",
        tolerance: 0.01,
        quick_tolerance: 0.05,
        levels: 3,
        first_level: 0,
        reference_curves: Vec::new,
        run: cap,
    },
];

const INFLATION: (f64, f64, f64, f64) = (1.0, 0.05, 1e4, 0.3);
const STRETCHES: [f64; 4] = [1.05, 1.1, 1.2, 1.5];

/// The closed-form pressure of a uniformly inflated sphere of this energy.
fn pressure(lambda: f64) -> f64 {
    let (r0, h, e, nu) = INFLATION;
    e * h / ((1.0 - nu) * r0)
        * ((lambda * lambda - 1.0) / lambda
            + h * h / (6.0 * r0 * r0) * (lambda - 1.0) / (lambda * lambda))
}

fn inflation_reference() -> Vec<Curve> {
    let pmax = pressure(STRETCHES[3]);
    vec![Curve {
        name: "λ − 1 (closed form)".into(),
        points: STRETCHES
            .iter()
            .map(|&l| (l - 1.0, pressure(l) / pmax))
            .collect(),
    }]
}

fn inflation(sff: SffKind, level: usize) -> Result<Outcome> {
    let (r0, h, e, nu) = INFLATION;
    let mesh = generators::icosphere(r0, level + 1)?;
    let faces = mesh.n_faces();
    let pmax = pressure(STRETCHES[3]);
    let loads = Loads {
        pressure: pmax,
        ..Loads::default()
    };
    let x0 = mesh.positions().to_vec();
    let mut sys = super::solve::stress_free(
        mesh,
        sff,
        Material {
            thickness: h,
            young: e,
            poisson: nu,
            ..Material::paper()
        },
        Boundary::default(),
        loads,
    )?;
    let mut c = Config::of(&sys, x0);
    let levels: Vec<f64> = STRETCHES.iter().map(|&l| pressure(l) / pmax).collect();
    let mut measured = Vec::new();
    let stopped = ramp(&mut sys, &mut c, &levels, 0.25, |_, _, c| {
        let n = c.x.len() as f64;
        let centre = c.x.iter().fold(V3::zeros(), |s, p| s + p) / n;
        measured.push(c.x.iter().map(|p| (p - centre).norm()).sum::<f64>() / n / r0);
        Ok(())
    })?;
    let quantities = STRETCHES
        .iter()
        .enumerate()
        .map(|(i, &l)| Quantity {
            label: format!("λ at p(λ = {l})"),
            reference: l,
            measured: measured.get(i).copied().unwrap_or(f64::NAN),
            scale: l - 1.0,
        })
        .collect();
    Ok(Outcome {
        mesh: format!("icosphere level {}", level + 1),
        faces,
        quantities,
        converged: stopped.is_none(),
        curves: vec![Curve {
            name: "λ − 1".into(),
            points: measured
                .iter()
                .zip(&levels)
                .map(|(&m, &f)| (m - 1.0, f))
                .collect(),
        }],
        note: stopped.map(|l| format!("load ramp stopped at p/p_max = {l:.4}")),
    })
}

fn rms_rigid(x: &[V3], y: &[V3]) -> Result<f64> {
    rms_distance_modulo_rigid(x, y).ok_or_else(|| anyhow!("cannot compare positions"))
}

fn helix(sff: SffKind, level: usize) -> Result<Outcome> {
    let (kappa, phi) = (1.0f64, 30f64.to_radians());
    let n = 30 << level;
    let mesh = generators::rectangle(3.0, 0.3, n, n / 10)?;
    let faces = mesh.n_faces();
    let d = nalgebra::Vector2::new(phi.cos(), phi.sin());
    let rest = RestState::from_planar(&mesh, Matrix2::identity(), kappa * d * d.transpose())?;
    // Strip coordinates turned so that d is the x axis: wrap_cylinder rolls x onto the circle.
    let turned: Vec<V3> = mesh
        .positions()
        .iter()
        .map(|p| {
            V3::new(
                p.x * phi.cos() + p.y * phi.sin(),
                -p.x * phi.sin() + p.y * phi.cos(),
                0.0,
            )
        })
        .collect();
    let exact = wrap_cylinder(&turned, 1.0 / kappa, 1.5);
    let start = wrap_cylinder(&turned, 1.5 / kappa, 1.5);
    let mut sys = system(
        mesh,
        rest,
        sff,
        Material {
            thickness: 0.01,
            young: 1e6,
            poisson: 0.3,
            ..Material::paper()
        },
        Boundary::default(),
        Loads::default(),
    )?;
    let mut c = Config::of(&sys, start);
    let converged = equilibrium(&mut sys, &mut c);
    Ok(Outcome {
        mesh: format!("rectangle {n}×{}", n / 10),
        faces,
        quantities: vec![Quantity {
            label: "RMS distance to the helix × κ".into(),
            reference: 0.0,
            measured: rms_rigid(&c.x, &exact)? * kappa,
            scale: 1.0,
        }],
        converged,
        curves: Vec::new(),
        note: (!converged).then(|| "static solve did not converge".to_string()),
    })
}

fn cap(sff: SffKind, level: usize) -> Result<Outcome> {
    let k_gauss = 1.0f64;
    let sk = k_gauss.sqrt();
    let rings = 4 << level;
    let mesh = generators::disc(1.0, rings)?;
    let faces = mesh.n_faces();
    let exact: Vec<V3> = mesh
        .positions()
        .iter()
        .map(|p| {
            let r = (p.x * p.x + p.y * p.y).sqrt();
            let s = if r > 0.0 {
                (sk * r).sin() / (sk * r)
            } else {
                1.0
            };
            V3::new(p.x * s, p.y * s, (1.0 - (sk * r).cos()) / sk)
        })
        .collect();
    let metric = RestState::from_mesh(&mesh, &exact, sff)?;
    let rest = RestState {
        b_bar: metric.a_bar.iter().map(|a| a * sk).collect(),
        a_bar: metric.a_bar,
        sff: None,
    };
    let start: Vec<V3> = mesh
        .positions()
        .iter()
        .map(|p| V3::new(p.x, p.y, 0.25 * (p.x * p.x + p.y * p.y)))
        .collect();
    let mut sys = system(
        mesh,
        rest,
        sff,
        Material {
            thickness: 0.01,
            young: 1e6,
            poisson: 0.3,
            ..Material::paper()
        },
        Boundary::default(),
        Loads::default(),
    )?;
    let mut c = Config::of(&sys, start);
    let converged = equilibrium(&mut sys, &mut c);
    Ok(Outcome {
        mesh: format!("disc, {rings} rings"),
        faces,
        quantities: vec![Quantity {
            label: "RMS distance to the cap × √K".into(),
            reference: 0.0,
            measured: rms_rigid(&c.x, &exact)? * sk,
            scale: 1.0,
        }],
        converged,
        curves: Vec::new(),
        note: (!converged).then(|| "static solve did not converge".to_string()),
    })
}
