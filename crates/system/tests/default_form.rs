//! The default bending form (`SffKind::default()`, edge directors with tan) gives the right
//! answer on the project's own alternating-diagonal grids (`generators::rectangle`), where the
//! paper's mid-edge average does not:
//!
//! - pure bending of a cylinder at 0°, 30° and 45° to the grid against the analytic energy;
//! - the lowest frequency of a simply supported square plate against the analytic value;
//! - explicit Euler with the director form (angles relaxed every step) against implicit Euler.
//!
//! Run with `--nocapture` to see the measured tables.
#![allow(clippy::unwrap_used)]

use faer::Par;
use nalgebra::Vector3;
use thinshell_energy::{
    Assembler, DirectorVariant, DofMap, EvalOutput, HessianMode, Material, RestState, SffKind,
    ShellModel, Terms, lumped_mass,
};
use thinshell_mesh::{Mesh, VertexId, generators};
use thinshell_solver::{ExplicitEuler, ImplicitEuler, Integrator, Ordering, SparseCholesky, State};
use thinshell_system::{AngleSettings, Boundary, Loads, ShellSystem};

const SIN: SffKind = SffKind::EdgeDirector(DirectorVariant::Sin);
const TAN: SffKind = SffKind::EdgeDirector(DirectorVariant::Tan);

#[test]
fn default_form_is_the_tan_edge_director() {
    assert_eq!(SffKind::default(), TAN);
}

fn bending_only(material: Material, sff: SffKind) -> ShellModel {
    ShellModel {
        material,
        terms: Terms {
            stretch: false,
            bend: true,
            damping: false,
        },
        sff,
    }
}

/// The flat point (x, y) mapped isometrically onto a cylinder of radius `r` whose axis lies in
/// the plane at angle `angle` (rad) to the x axis: arc length across the axis, distance along it.
fn on_cylinder(p: &Vector3<f64>, r: f64, angle: f64) -> Vector3<f64> {
    let (s, c) = angle.sin_cos();
    let along = p.x * c + p.y * s;
    let across = -p.x * s + p.y * c;
    let axis = Vector3::new(c, s, 0.0);
    let normal = Vector3::new(-s, c, 0.0);
    let t = across / r;
    axis * along + normal * (r * t.sin()) + Vector3::z() * (r * (1.0 - t.cos()))
}

/// Bending energy (J) of `mesh` (flat rest state) wrapped onto the cylinder, with the edge
/// angles minimised at fixed positions for a director form: (all faces, faces in the central
/// square [0.25, 0.75]² of the unit square) and the rest area (m²) of the latter.
fn cylinder_bending_energy(
    mesh: &Mesh,
    material: Material,
    sff: SffKind,
    r: f64,
    angle: f64,
) -> (f64, f64, f64) {
    let rest = RestState::from_mesh(mesh, mesh.positions(), sff).unwrap();
    let x: Vec<Vector3<f64>> = mesh
        .positions()
        .iter()
        .map(|p| on_cylinder(p, r, angle))
        .collect();
    let model = bending_only(material, sff);
    let mut sys = ShellSystem::new(
        mesh.clone(),
        model,
        rest.clone(),
        Boundary::default(),
        Loads::default(),
    )
    .unwrap();
    let mut phi = vec![0.0; sys.n_edge_angles()];
    if sys.has_edge_unknowns() {
        let settings = AngleSettings {
            tolerance: 1e-12,
            ..AngleSettings::default()
        };
        let report = sys
            .relax_edge_angles(&x, &mut phi, None, &settings, None)
            .unwrap();
        // A converged minimum: the final correction is below the tolerance.
        assert!(report.last_correction <= 1e-12, "{report:?}");
    }
    // Per-face energies from an assembler of our own (the system's is private).
    let mut dofs = DofMap::all_free(mesh.n_vertices());
    if sys.has_edge_unknowns() {
        dofs = dofs.with_edges(mesh.n_edges(), []).unwrap();
    }
    let mut asm = Assembler::for_model(mesh, &dofs, &model).unwrap();
    let total = asm
        .evaluate_with_angles(&model, &x, &phi, &rest, None, EvalOutput::default())
        .unwrap()
        .bend;
    let p = mesh.positions();
    let central = |v: &VertexId| {
        let q = p[v.idx()];
        (0.25 - 1e-9..=0.75 + 1e-9).contains(&q.x) && (0.25 - 1e-9..=0.75 + 1e-9).contains(&q.y)
    };
    let (mut interior, mut area) = (0.0, 0.0);
    for (f, e) in mesh.faces().iter().zip(asm.face_energies()) {
        if f.iter().all(central) {
            interior += e.bend;
            let [i, j, k] = [f[0].idx(), f[1].idx(), f[2].idx()];
            area += 0.5 * (p[j] - p[i]).cross(&(p[k] - p[i])).norm();
        }
    }
    (total, interior, area)
}

/// Observed orders log₂(e_n / e_2n) of a halving series.
fn orders(errors: &[f64]) -> Vec<f64> {
    errors
        .windows(2)
        .map(|w| (w[0].abs() / w[1].abs()).log2())
        .collect()
}

fn fmt(v: &[f64], f: impl Fn(f64) -> String) -> String {
    v.iter().map(|&x| f(x)).collect::<Vec<_>>().join(", ")
}

/// A unit square on alternating-diagonal grids bent onto a cylinder of radius 1 (flat rest
/// state, positions held, edge angles optimised). Continuum energy: density (h³/12)‖S‖²_SV with
/// the shape operator S = diag(1/R, 0), ‖S‖²_SV = (α/2 + β)/R² = E/(2(1 − ν²)R²), so
/// E_bend = A·E h³/(24(1 − ν²)R²) = A·D/(2R²) over any area A.
///
/// Measured (n = 8, 16, 32, 64 cells per side; relative error of the energy):
/// - central square [0.25, 0.75]² (away from the free edges): sin and tan directors converge
///   at order 2 at 0°, 30° and 45°; the mid-edge average is right at 0° but +49 % at 30° and
///   +65 % at 45° at every n — no convergence;
/// - all faces: the mid-edge average's free edges (face normal for the edge's) add an O(h)
///   boundary-layer error, so it approaches its interior error at order 1; the directors, whose
///   free-edge directors come from the fit of model.md §1.2, converge at order 2 over all faces
///   too (last step: tan 2.21 at every angle, sin 1.84, 1.91, 1.93 at 0°, 30°, 45°; with a free
///   angle on free edges it was order 1).
#[test]
fn cylinder_bending_on_alternating_grids_converges_with_directors_only() {
    let material = Material {
        thickness: 1e-2,
        young: 1e6,
        poisson: 0.3,
        ..Material::paper()
    };
    let r = 1.0;
    let m = &material;
    let d = m.young * m.thickness.powi(3) / (12.0 * (1.0 - m.poisson * m.poisson));
    let density = d / (2.0 * r * r);
    let ns = [8usize, 16, 32, 64];
    println!("cylinder R = {r} on generators::rectangle(1, 1, n, n), n = {ns:?}");
    for sff in [SffKind::MidEdgeAverage, SIN, TAN] {
        for deg in [0.0f64, 30.0, 45.0] {
            let (mut total, mut interior) = (Vec::new(), Vec::new());
            for &n in &ns {
                let mesh = generators::rectangle(1.0, 1.0, n, n).unwrap();
                let (e, e_in, a_in) =
                    cylinder_bending_energy(&mesh, material, sff, r, deg.to_radians());
                total.push(e / density - 1.0);
                interior.push(e_in / (density * a_in) - 1.0);
            }
            let (o_total, o_in) = (orders(&total), orders(&interior));
            let e3 = |x: f64| format!("{x:+.2e}");
            let o2 = |x: f64| format!("{x:.2}");
            println!(
                "{:>18} {deg:>2}°: interior {} (orders {}); all faces {} (orders {})",
                sff.name(),
                fmt(&interior, e3),
                fmt(&o_in, o2),
                fmt(&total, e3),
                fmt(&o_total, o2)
            );
            let finest = *interior.last().unwrap();
            match sff {
                SffKind::MidEdgeAverage if deg == 0.0 => {
                    // Along the grid the average is consistent in the interior.
                    assert!(finest.abs() < 1e-3, "average at 0°: {finest}");
                }
                SffKind::MidEdgeAverage => {
                    // Across the grid it overestimates by a fixed fraction at every resolution.
                    let expected = if deg == 45.0 { 0.65 } else { 0.49 };
                    for e in &interior {
                        assert!(
                            (e - expected).abs() < 0.03,
                            "average at {deg}°: error {e}, documented ≈ {expected}"
                        );
                    }
                }
                _ => {
                    assert!(finest.abs() < 1e-3, "{} at {deg}°: {finest}", sff.name());
                    let last = o_in[o_in.len() - 1];
                    assert!(
                        last > 1.7,
                        "{} at {deg}°: interior order {last}",
                        sff.name()
                    );
                    // With the free-edge strip: second order (model.md §1.2).
                    let last = o_total[o_total.len() - 1];
                    assert!(last > 1.8, "{} at {deg}°: order {last}", sff.name());
                }
            }
        }
    }
}

/// Lowest eigenfrequency (Hz) of `mesh` at its flat rest state with every boundary vertex
/// held (x, y and z: a simple support — the edge angles and interior vertices are free, so
/// the plate rotates freely about its supported edges; in-plane holding does not change the
/// linear bending modes of a flat plate). K φ = ω² M φ with the lumped mass on positions and
/// massless angles, by inverse iteration on [Kxx Kxφ; Kφx Kφφ][x; φ] = [M x_prev; 0].
fn lowest_frequency(mesh: &Mesh, material: Material, sff: SffKind) -> f64 {
    let n = mesh.n_vertices();
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff,
    };
    let rest = RestState::from_mesh(mesh, mesh.positions(), sff).unwrap();
    let boundary: Vec<VertexId> = mesh.topology().boundary_vertices().to_vec();
    let mut dofs = DofMap::with_pinned_vertices(n, boundary.iter().copied()).unwrap();
    if sff.director().is_some() {
        dofs = dofs.with_edges(mesh.n_edges(), []).unwrap();
    }
    let mut asm = Assembler::for_model(mesh, &dofs, &model).unwrap();
    let mut h = asm.hessian_template();
    let phi = vec![0.0; dofs.n_edges()];
    asm.evaluate_with_angles(
        &model,
        mesh.positions(),
        &phi,
        &rest,
        None,
        EvalOutput {
            gradient: None,
            hessian: Some((&mut h, HessianMode::Exact)),
        },
    )
    .unwrap();
    let mut chol = SparseCholesky::new(h.symbolic(), Ordering::Amd, None, Par::Seq).unwrap();
    chol.factorize(h.as_ref()).unwrap();
    let mass = lumped_mass(mesh, &rest, &material).unwrap();
    let coords = dofs.free_coordinates().to_vec();
    let n3 = 3 * n;
    let m_of = |c: usize| if c < n3 { mass[c / 3] } else { 0.0 };
    // Start: a bump in z plus a little of everything (so that no mode is missing).
    let mut x: Vec<f64> = coords
        .iter()
        .enumerate()
        .map(|(d, &c)| {
            if c >= n3 {
                0.0
            } else if c % 3 == 2 {
                let p = mesh.positions()[c / 3];
                (p.x * 0.3).sin() * (p.y * 0.3).sin() + 1e-3 * ((d as f64) * 0.37).sin()
            } else {
                1e-3 * ((d as f64) * 0.61).cos()
            }
        })
        .collect();
    let mut lambda = 0.0;
    for it in 0..200 {
        let mut y: Vec<f64> = coords.iter().zip(&x).map(|(&c, v)| m_of(c) * v).collect();
        chol.solve_in_place(&mut y).unwrap();
        // Rayleigh quotient of M⁻¹S (S the Schur complement on the positions): xᵀMx / xᵀMy.
        let xmx: f64 = coords.iter().zip(&x).map(|(&c, v)| m_of(c) * v * v).sum();
        let xmy: f64 = coords
            .iter()
            .zip(x.iter().zip(&y))
            .map(|(&c, (a, b))| m_of(c) * a * b)
            .sum();
        let next = xmx / xmy;
        let norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
        x = y.into_iter().map(|v| v / norm).collect();
        if it > 3 && (next - lambda).abs() < 1e-12 * next {
            lambda = next;
            break;
        }
        lambda = next;
    }
    lambda.sqrt() / (2.0 * std::f64::consts::PI)
}

/// Simply supported steel plate a = 10 m, h = 0.05 m: f₁₁ = (π/a²)·√(D/(ρh)) = 2.3766 Hz,
/// D = E h³/(12(1 − ν²)). On a 40×40 alternating grid the default form is within 1 %
/// (measured 2.375 Hz, −0.1 %); the mid-edge average gives 3.05 Hz (+28 %).
#[test]
fn simply_supported_plate_frequency_with_the_default_form() {
    let a = 10.0;
    let material = Material {
        thickness: 0.05,
        young: 2e11,
        poisson: 0.3,
        density: 8000.0,
        viscosity: 0.0,
        model: thinshell_energy::MaterialModel::StVK,
    };
    let m = &material;
    let d = m.young * m.thickness.powi(3) / (12.0 * (1.0 - m.poisson * m.poisson));
    let exact = std::f64::consts::PI / (a * a) * (d / (m.density * m.thickness)).sqrt();
    let mesh = generators::rectangle(a, a, 40, 40).unwrap();
    let f_default = lowest_frequency(&mesh, material, SffKind::default());
    let f_sin = lowest_frequency(&mesh, material, SIN);
    let f_avg = lowest_frequency(&mesh, material, SffKind::MidEdgeAverage);
    println!(
        "plate 40×40: analytic {exact:.4} Hz; default (tan) {f_default:.4} Hz ({:+.2} %), \
         sin {f_sin:.4} Hz ({:+.2} %), mid-edge average {f_avg:.4} Hz ({:+.2} %)",
        100.0 * (f_default / exact - 1.0),
        100.0 * (f_sin / exact - 1.0),
        100.0 * (f_avg / exact - 1.0)
    );
    assert!((exact - 2.3766).abs() < 1e-3, "analytic value {exact}");
    assert!(
        (f_default / exact - 1.0).abs() < 0.01,
        "default form: {f_default} Hz vs {exact} Hz"
    );
    assert!((f_sin / exact - 1.0).abs() < 0.01, "sin: {f_sin} Hz");
    // The average is documented as wrong on this grid, not hidden: more than 20 % high.
    assert!(f_avg / exact > 1.2, "mid-edge average: {f_avg} Hz");
}

/// Kinetic energy ½ Σ m |v|² (J).
fn kinetic(mass: &[f64], v: &[Vector3<f64>]) -> f64 {
    mass.iter()
        .zip(v)
        .map(|(m, v)| 0.5 * m * v.norm_squared())
        .sum()
}

/// A plate (simply supported as above, 1 m, 8×8) set vibrating by an initial velocity bump,
/// with the default form. Explicit Euler (angles relaxed every step) and implicit Euler at the
/// same small Δt agree to 0.1 % of the motion over ≈ 0.2 periods (measured 5e-5: both first
/// order, Δt·ω ≈ 1e-3), and explicit Euler keeps kinetic + elastic energy to 0.2 % (measured
/// 2.3e-4; symplectic: bounded oscillation, no drift).
#[test]
fn explicit_euler_with_the_default_form_matches_implicit() {
    let mesh = generators::rectangle(1.0, 1.0, 8, 8).unwrap();
    let sff = SffKind::default();
    let material = Material {
        thickness: 1e-2,
        young: 1e7,
        poisson: 0.3,
        density: 1000.0,
        viscosity: 0.0,
        model: thinshell_energy::MaterialModel::StVK,
    };
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff,
    };
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let boundary = Boundary {
        pinned_vertices: mesh.topology().boundary_vertices().to_vec(),
        ..Default::default()
    };
    let mut sys = ShellSystem::new(mesh, model, rest, boundary, Loads::default()).unwrap();
    let x0 = sys.mesh().positions().to_vec();
    let mut start = State::at_rest(x0.clone());
    for (i, v) in start.v.iter_mut().enumerate() {
        if sys.dofs().dof(VertexId::new(i), 2).is_some() {
            let p = x0[i];
            v.z = 0.1 * (std::f64::consts::PI * p.x).sin() * (std::f64::consts::PI * p.y).sin();
        }
    }
    // f₁₁ = (π/a²)√(D/ρh) ≈ 2.9 Hz (period ≈ 0.34 s); 0.2 periods in 1 000 steps.
    let dt = 7e-5;
    let steps = 1000;
    let mass = sys.mass().to_vec();
    let e0 = kinetic(&mass, &start.v);
    let mut explicit = start.clone();
    let mut ex = ExplicitEuler { dt };
    let mut implicit = start.clone();
    let mut im = ImplicitEuler::new(dt);
    let mut worst_energy = 0.0f64;
    for _ in 0..steps {
        ex.step(&mut sys, &mut explicit).unwrap();
        im.step(&mut sys, &mut implicit).unwrap();
        let elastic = sys.energy_at(&explicit.x, &explicit.phi).unwrap().total();
        let total = kinetic(&mass, &explicit.v) + elastic;
        worst_energy = worst_energy.max((total - e0).abs() / e0);
    }
    let moved = explicit
        .x
        .iter()
        .zip(&x0)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    let diff = explicit
        .x
        .iter()
        .zip(&implicit.x)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    let totals = sys.angle_relaxation_totals();
    println!(
        "explicit vs implicit, {steps} steps of {dt} s: moved {moved:.3e} m, differ {diff:.3e} m; \
         explicit energy error ≤ {:.2e} (relative); angle relaxation per step: {:.2} gradient \
         evaluations, {:.3} factorisations",
        worst_energy,
        totals.gradient_evaluations as f64 / steps as f64,
        totals.factorizations as f64 / steps as f64
    );
    assert!(moved > 1e-3, "nothing moved: {moved}");
    assert!(
        diff < 1e-3 * moved,
        "explicit/implicit differ by {diff} for motion {moved}"
    );
    assert!(worst_energy < 2e-3, "explicit energy error {worst_energy}");
    // The angles moved with the plate (they are not stuck at 0).
    assert!(explicit.phi.iter().any(|p| p.abs() > 1e-6));
}

/// Bad input to the angle relaxation gets a typed error, never a panic.
#[test]
fn relax_edge_angles_checks_its_input() {
    let mesh = generators::rectangle(1.0, 1.0, 3, 3).unwrap();
    let material = Material::paper();
    let x = mesh.positions().to_vec();
    let build = |sff: SffKind| {
        let rest = RestState::from_mesh(&mesh, &x, sff).unwrap();
        ShellSystem::new(
            mesh.clone(),
            bending_only(material, sff),
            rest,
            Boundary::default(),
            Loads::default(),
        )
        .unwrap()
    };
    let s = AngleSettings::default();
    // No edge unknowns with the average.
    let mut avg = build(SffKind::MidEdgeAverage);
    let e = avg
        .relax_edge_angles(&x, &mut [], None, &s, None)
        .unwrap_err();
    assert!(
        matches!(e, thinshell_solver::SolverError::InvalidSetting { .. }),
        "{e:?}"
    );
    let mut sys = build(TAN);
    let mut short = vec![0.0; sys.n_edge_angles() - 1];
    let e = sys
        .relax_edge_angles(&x, &mut short, None, &s, None)
        .unwrap_err();
    assert!(
        matches!(e, thinshell_solver::SolverError::DimensionMismatch { .. }),
        "{e:?}"
    );
    let mut phi = vec![0.0; sys.n_edge_angles()];
    let bad = AngleSettings {
        tolerance: -1.0,
        ..s
    };
    let e = sys
        .relax_edge_angles(&x, &mut phi, None, &bad, None)
        .unwrap_err();
    assert!(
        matches!(e, thinshell_solver::SolverError::InvalidSetting { .. }),
        "{e:?}"
    );
    // At the flat rest state the angles are already optimal: one evaluation, nothing moves.
    let r = sys.relax_edge_angles(&x, &mut phi, None, &s, None).unwrap();
    assert_eq!(r.gradient_evaluations, 1);
    assert!(phi.iter().all(|p| *p == 0.0));
}
