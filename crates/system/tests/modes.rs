//! Modal analysis with the default bending form (docs/modal.md): natural
//! frequencies of a simply supported rectangular plate against the Kirchhoff solution, the six
//! rigid-motion modes of a free plate, and a shallow spherical cap under refinement.
//!
//! Run with `--nocapture` to see the measured tables.
#![allow(clippy::unwrap_used)]

use std::f64::consts::PI;

use nalgebra::Vector3;
use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{Mesh, VertexId, generators};
use thinshell_system::{Boundary, Loads, ModalSettings, Modes, ShellSystem};

/// Steel, every constant stated (`Material::stvk`): h = 0.05 m, E = 200 GPa, ν = 0.3,
/// ρ = 7850 kg/m³, undamped.
fn steel(h: f64) -> Material {
    Material::stvk(h, 2e11, 0.3, 7850.0, 0.0)
}

fn modes_of(
    mesh: Mesh,
    rest_x: &[Vector3<f64>],
    material: Material,
    pinned: Vec<VertexId>,
    count: usize,
) -> Modes {
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff: SffKind::default(),
    };
    let rest = RestState::for_model(&mesh, rest_x, &model).unwrap();
    let boundary = Boundary {
        pinned_vertices: pinned,
        ..Boundary::default()
    };
    let mut sys = ShellSystem::new(mesh, model, rest, boundary, Loads::default()).unwrap();
    let settings = ModalSettings {
        count,
        ..ModalSettings::default()
    };
    sys.natural_modes(rest_x, &[], &settings).unwrap()
}

/// Kirchhoff frequencies (Hz) of a simply supported a × b plate, lowest `count`:
/// ω_mn = π²(m²/a² + n²/b²)·√(D/(ρh)), D = Eh³/(12(1−ν²)).
fn kirchhoff(a: f64, b: f64, m: &Material, count: usize) -> Vec<f64> {
    let d = m.young * m.thickness.powi(3) / (12.0 * (1.0 - m.poisson * m.poisson));
    let mut f: Vec<f64> = (1..10)
        .flat_map(|i| (1..10).map(move |j| (i as f64, j as f64)))
        .map(|(i, j)| {
            PI * PI * (i * i / (a * a) + j * j / (b * b)) * (d / (m.density * m.thickness)).sqrt()
                / (2.0 * PI)
        })
        .collect();
    f.sort_by(f64::total_cmp);
    f.truncate(count);
    f
}

fn plate(a: f64, b: f64, nx: usize, ny: usize, m: Material) -> Vec<f64> {
    let mesh = generators::rectangle(a, b, nx, ny).unwrap();
    let pinned = mesh.topology().boundary_vertices().to_vec();
    let x = mesh.positions().to_vec();
    let modes = modes_of(mesh, &x, m, pinned, 6);
    assert!(modes.residuals.iter().all(|r| *r <= 1e-10));
    modes.frequencies
}

/// a/b = 1.5 (15 m × 10 m, h = 0.05 m steel) on alternating grids 15×10, 30×20, 60×40: the
/// first six frequencies within 1 % of Kirchhoff's on 60×40, the error falling with the
/// observed order printed and asserted above 1.5 (measured: docs/modal.md).
#[test]
fn simply_supported_plate_frequencies() {
    let (a, b) = (15.0, 10.0);
    let m = steel(0.05);
    let exact = kirchhoff(a, b, &m, 6);
    let mut errors = Vec::new();
    for (nx, ny) in [(15, 10), (30, 20), (60, 40)] {
        let f = plate(a, b, nx, ny, m);
        let err: Vec<f64> = f.iter().zip(&exact).map(|(f, e)| f / e - 1.0).collect();
        println!(
            "{nx}×{ny}: {}",
            f.iter()
                .zip(&err)
                .map(|(f, e)| format!("{f:.4} Hz ({:+.3} %)", 100.0 * e))
                .collect::<Vec<_>>()
                .join(", ")
        );
        errors.push(err);
    }
    println!("Kirchhoff: {exact:.4?} Hz");
    let last = &errors[2];
    for (i, e) in last.iter().enumerate() {
        assert!(
            e.abs() < 0.01,
            "mode {}: {:+.3} % on 60×40",
            i + 1,
            100.0 * e
        );
    }
    for (i, (coarse, fine)) in errors[1].iter().zip(&errors[2]).enumerate() {
        let order = (coarse.abs() / fine.abs()).log2();
        println!("mode {}: order {order:.2} (30×20 → 60×40)", i + 1);
        assert!(order > 1.5, "mode {}: order {order}", i + 1);
    }
}

/// A free 1.5 m × 1 m plate (h = 0.05 m): six rigid-motion modes, then the elastic ones; the
/// rigid eigenvalues ω² are below 1e-6 of the first elastic one (round-off in K, about
/// ε·max K_ii/m_i, sets their size; their frequencies are the square roots).
#[test]
fn free_plate_has_six_rigid_modes() {
    let mesh = generators::rectangle(1.5, 1.0, 12, 8).unwrap();
    let x = mesh.positions().to_vec();
    let modes = modes_of(mesh, &x, steel(0.05), Vec::new(), 9);
    let first_elastic = modes.eigenvalues[6];
    println!(
        "free plate ω² (rad²/s²): {:?}; frequencies (Hz): {:?}",
        modes.eigenvalues, modes.frequencies
    );
    for (i, l) in modes.eigenvalues[..6].iter().enumerate() {
        assert!(
            l.abs() < 1e-6 * first_elastic,
            "rigid mode {}: ω² = {l:e}",
            i + 1
        );
        assert!(
            modes.frequencies[i].abs() < 1e-3 * modes.frequencies[6],
            "rigid mode {}: {} Hz",
            i + 1,
            modes.frequencies[i]
        );
    }
    assert!(first_elastic > 0.0);
}

/// Shallow spherical cap (base radius 1 m, rise 0.1 m, h = 0.01 m steel, edge pinned) on
/// discs of 4, 8, 16 rings: the lowest four frequencies converge (changes shrink with the
/// observed order printed; asserted above 1).
#[test]
fn shallow_cap_frequencies_converge() {
    let (r0, rise) = (1.0, 0.1);
    let radius = (r0 * r0 + rise * rise) / (2.0 * rise);
    let mut all = Vec::new();
    for rings in [4, 8, 16] {
        let mesh = generators::disc(r0, rings).unwrap();
        let x: Vec<Vector3<f64>> = mesh
            .positions()
            .iter()
            .map(|p| {
                let r2 = p.x * p.x + p.y * p.y;
                Vector3::new(p.x, p.y, (radius * radius - r2).sqrt() - (radius - rise))
            })
            .collect();
        let pinned = mesh.topology().boundary_vertices().to_vec();
        let modes = modes_of(mesh, &x, steel(0.01), pinned, 4);
        println!("cap, {rings} rings: {:.4?} Hz", modes.frequencies);
        all.push(modes.frequencies);
    }
    for (i, ((f4, f8), f16)) in all[0].iter().zip(&all[1]).zip(&all[2]).enumerate() {
        let d1 = (f8 - f4).abs();
        let d2 = (f16 - f8).abs();
        let order = (d1 / d2).log2();
        println!(
            "mode {}: changes {d1:.3e}, {d2:.3e} Hz; order {order:.2}",
            i + 1
        );
        assert!(order > 1.0, "mode {}: order {order}", i + 1);
        assert!(d2 < 0.02 * f16, "mode {}: last change {d2} Hz", i + 1);
    }
}
