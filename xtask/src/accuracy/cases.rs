//! The cases with a known answer, each run under every knob the study varies.

use anyhow::{Result, anyhow, bail};
use nalgebra::Matrix2;
use std::time::Instant;

use thinshell::reference::{SquareCase, wrap_cylinder};
use thinshell::scene::integrator::run_loop_static;
use thinshell::{SimulationBuilder, StepFailure};
use thinshell_energy::{HessianMode, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::{FaceStimulus, Prescribed, Swelling};
use thinshell_mesh::{Mesh, generators};
use thinshell_solver::{ExplicitEuler, ImplicitEuler, NewtonSettings, State, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};

use super::runner::{
    Cost, Knobs, best_equilibrium, elastic, integrate, iterations_of, paper, rms, rms_rigid, shell,
    static_solve,
};
use super::study::{CASE_NAMES, Case, Refinement, Run, STATIC_MAX_ITERATIONS, V3};

/// The seed's three squares on the seed mesh: static knobs (tolerance × Hessian × line search),
/// dynamic relaxation with implicit Euler at several Δt, and (full study) the seed's own way.
pub(super) fn square(case: SquareCase, sff: SffKind, quick: bool) -> Result<Case> {
    let name = match case {
        SquareCase::Enlarged => CASE_NAMES[0],
        SquareCase::Rhombus => CASE_NAMES[1],
        SquareCase::Cylinder => CASE_NAMES[2],
    };
    let answer = match case {
        SquareCase::Cylinder => {
            "the radius-1 cylinder (exact in the continuum only: the discrete equilibrium differs \
             by the discretisation error)"
        }
        _ => {
            "the analytic flat equilibrium (an exact zero-energy state of the discrete energy too)"
        }
    };
    let mut out = Case::new(
        name,
        sff,
        format!(
            "seed mesh (184 faces), start = the seed's perturbed state; answer: {answer}; error = RMS \
             vertex distance after removing rigid motion"
        ),
        "m",
    );
    let mesh = generators::seed_square()?;
    let x0 = mesh.positions().to_vec();
    let (a, b) = case.planar_forms();
    let rest = RestState::from_planar(&mesh, a, b)?;
    let target = case.equilibrium(&x0);
    let start = case.seed_start(&x0);
    let material = Material::paper();
    let faces = mesh.n_faces();
    let mut sys = shell(
        mesh,
        rest,
        sff,
        material,
        Boundary::default(),
        Loads::default(),
    )?;

    // The discrete equilibrium: the tightest static solve (adaptive Hessian, line search).
    let mut x_eq = start.clone();
    if !static_solve(
        &mut sys,
        &mut x_eq,
        &mut Vec::new(),
        Knobs::tight(),
        STATIC_MAX_ITERATIONS,
    )
    .ok
    {
        bail!("{name}: the reference static solve failed");
    }

    // Static solve: tolerance × Hessian × line search.
    let tolerances: &[f64] = if quick {
        &[1e-5, 1e-11]
    } else {
        &[1e-3, 1e-5, 1e-7, 1e-9, 1e-11]
    };
    for &tolerance in tolerances {
        for hessian in [HessianMode::Exact, HessianMode::GaussNewton] {
            for line_search in [true, false] {
                let k = Knobs {
                    tolerance,
                    hessian,
                    line_search,
                };
                let mut x = start.clone();
                let mut phi = Vec::new();
                let c = static_solve(&mut sys, &mut x, &mut phi, k, STATIC_MAX_ITERATIONS);
                out.runs.push(Run {
                    family: format!(
                        "static, {} Hessian, line search {}",
                        k.hessian_name(),
                        if line_search { "on" } else { "off" }
                    ),
                    label: k.label(),
                    faces,
                    dt: None,
                    tolerance: Some(tolerance),
                    error: rms_rigid(&x, &target)?,
                    wall_s: c.wall_s,
                    newton_iterations: c.iterations,
                    steps: c.steps,
                    converged: c.ok,
                    energy: elastic(&mut sys, &x, &phi),
                    to_discrete: Some(rms_rigid(&x, &x_eq)?),
                });
            }
        }
    }

    // Dynamic relaxation: implicit Euler (its numerical damping relaxes the shell; no
    // Kelvin–Voigt term), error at checkpoints along the run.
    let dts: &[f64] = if quick { &[1e-2] } else { &[1e-3, 1e-2, 1e-1] };
    let checkpoints: &[usize] = if quick {
        &[5, 20, 50]
    } else {
        &[5, 10, 20, 50, 100, 200]
    };
    for &dt in dts {
        let mut ie = ImplicitEuler::new(dt);
        ie.force_scale = Some(sys.force_scale());
        let mut state = State::at_rest(start.clone());
        integrate(&mut sys, &mut ie, &mut state, checkpoints, |s, c| {
            out.runs.push(Run {
                family: format!("dynamic relaxation, implicit Euler dt={dt:.0e} s"),
                label: format!("dt {dt:.0e} s, {} steps", c.steps),
                faces,
                dt: Some(dt),
                tolerance: Some(NewtonSettings::default().gradient_tolerance),
                error: rms_rigid(&s.x, &target)?,
                to_discrete: Some(rms_rigid(&s.x, &x_eq)?),
                wall_s: c.wall_s,
                newton_iterations: c.iterations,
                steps: c.steps,
                converged: c.ok,
                energy: None,
            });
            Ok(())
        })?;
    }

    // The seed's way: Δt = 5e-6 s, no line search, 1000 steps (its damping is negligible).
    if !quick {
        let dt = 5e-6;
        let mut ie = ImplicitEuler::new(dt);
        ie.force_scale = Some(sys.force_scale());
        ie.newton.line_search = false;
        let mut state = State::at_rest(start.clone());
        integrate(&mut sys, &mut ie, &mut state, &[10, 100, 1000], |s, c| {
            out.runs.push(Run {
                family: "seed: implicit Euler dt=5e-6 s, no line search".into(),
                label: format!("dt 5e-6 s, no line search, {} steps", c.steps),
                faces,
                dt: Some(dt),
                tolerance: Some(NewtonSettings::default().gradient_tolerance),
                error: rms_rigid(&s.x, &target)?,
                to_discrete: Some(rms_rigid(&s.x, &x_eq)?),
                wall_s: c.wall_s,
                newton_iterations: c.iterations,
                steps: c.steps,
                converged: c.ok,
                energy: None,
            });
            Ok(())
        })?;
    }

    let best_static = out
        .runs
        .iter()
        .filter(|r| r.family.starts_with("static") && r.converged)
        .min_by(|a, b| a.error.total_cmp(&b.error))
        .cloned();
    if let Some(cheap) = out.cheapest_within(2.0) {
        out.verdict.push(format!(
            "{}: the cheapest run within 2× of the best error ({:.2e} m) is \"{}\" ({}), {:.3} s.",
            name, cheap.error, cheap.label, cheap.family, cheap.wall_s
        ));
    }
    if let Some(bs) = best_static {
        let relax_best = out
            .runs
            .iter()
            .filter(|r| !r.family.starts_with("static") && r.converged && r.steps > 0)
            .min_by(|a, b| a.error.total_cmp(&b.error));
        if let Some(rb) = relax_best {
            out.verdict.push(format!(
                "{}: best static solve {:.2e} m in {:.3} s; best dynamic run {:.2e} m in {:.3} s \
                 ({}; {:.1e} m from the discrete equilibrium).",
                name,
                bs.error,
                bs.wall_s,
                rb.error,
                rb.wall_s,
                rb.label,
                rb.to_discrete.unwrap_or(f64::NAN)
            ));
        }
    }
    Ok(out)
}

/// The cylinder case on the unit square under refinement, regular (alternating diagonals) and
/// irregular (jittered Delaunay) meshes; static solve, adaptive and Gauss–Newton Hessians.
pub(super) fn cylinder_refinement(sff: SffKind, quick: bool) -> Result<Case> {
    let mut out = Case::new(
        CASE_NAMES[3],
        sff,
        "unit square with ā^{xy} = I, b̄^{xy} = diag(1, 0), paper (h = 0.1 mm; a third series \
         h = 1 cm on the irregular meshes), started on a radius-2 cylinder; answer: \
         the radius-1 cylinder; error = RMS vertex distance after removing rigid motion; static \
         Newton to tolerance 1e-11"
            .into(),
        "m",
    );
    let levels: &[usize] = if quick { &[4, 8, 16] } else { &[4, 8, 16, 32] };
    let irregular_levels: &[usize] = if quick { &[4, 8, 16] } else { &[4, 8, 16, 32] };
    // Paper (h = 0.1 mm) on regular and irregular meshes, and a 1 cm shell on the irregular
    // ones: thin shells on irregular meshes add the linear membrane's locking (the mesh cannot
    // bend isometrically), which only a thicker shell or a finer mesh escapes.
    let paper_h = Material::paper().thickness;
    for (kind, lv, thickness) in [
        ("regular", levels, paper_h),
        ("irregular", irregular_levels, paper_h),
        ("irregular", irregular_levels, THICK_CYLINDER),
    ] {
        let mut series = Refinement {
            name: if thickness == paper_h {
                format!("cylinder, {kind} meshes")
            } else {
                format!("cylinder, {kind} meshes, h = {} cm", thickness * 1e2)
            },
            points: Vec::new(),
        };
        for &n in lv {
            let mesh = if kind == "regular" {
                generators::rectangle(1.0, 1.0, n, n)?
            } else {
                generators::irregular_rectangle(1.0, 1.0, n, 1)?
            };
            let x0 = mesh.positions().to_vec();
            let rest = RestState::from_planar(
                &mesh,
                Matrix2::identity(),
                Matrix2::new(1.0, 0.0, 0.0, 0.0),
            )?;
            let target = wrap_cylinder(&x0, 1.0, 0.5);
            let start = wrap_cylinder(&x0, 2.0, 0.5);
            let material = paper(thickness);
            let faces = mesh.n_faces();
            let mut sys = shell(
                mesh,
                rest,
                sff,
                material,
                Boundary::default(),
                Loads::default(),
            )?;
            for hessian in [HessianMode::Exact, HessianMode::GaussNewton] {
                let k = Knobs {
                    hessian,
                    ..Knobs::tight()
                };
                let mut x = start.clone();
                let mut phi = Vec::new();
                let c = static_solve(&mut sys, &mut x, &mut phi, k, STATIC_MAX_ITERATIONS);
                let error = rms_rigid(&x, &target)?;
                out.runs.push(Run {
                    family: format!(
                        "{kind} mesh, h = {thickness:e} m, {} Hessian",
                        k.hessian_name()
                    ),
                    label: format!("{kind} n={n}, h = {thickness:e} m, {}", k.label()),
                    faces,
                    dt: None,
                    tolerance: Some(k.tolerance),
                    error,
                    wall_s: c.wall_s,
                    newton_iterations: c.iterations,
                    steps: c.steps,
                    converged: c.ok,
                    energy: elastic(&mut sys, &x, &phi),
                    to_discrete: None,
                });
            }
            if let Some(e) = best_equilibrium(&out.runs[out.runs.len() - 2..]) {
                series.points.push((faces, e));
            }
        }
        out.refinement.push(series);
    }
    Ok(out)
}

/// Inverse stereographic projection of the plane z = 0 onto the sphere of radius `r` touching
/// it at the origin (centre (0, 0, r)): conformal with factor λ = 1/(1 + ρ²/(4r²)).
pub(super) fn stereographic(x: &[V3], r: f64) -> Vec<V3> {
    x.iter()
        .map(|p| {
            let rho = p.xy().norm();
            let phi = 2.0 * (rho / (2.0 * r)).atan();
            let s = if rho > 0.0 { r * phi.sin() / rho } else { 1.0 };
            V3::new(s * p.x, s * p.y, r * (1.0 - phi.cos()))
        })
        .collect()
}

/// A flat disc grown into a spherical cap of radius 1 m: isotropic growth with the conformal
/// factor of the stereographic map (ā^{xy} = λ²I) and isotropic natural curvature
/// (b̄^{xy} = λ²I / R), λ evaluated at each face centroid. With the faces' normals (+z) facing
/// the sphere's centre, b = +a/R on the cap, so it is a zero-energy state of the continuum.
pub(super) fn cap_refinement(sff: SffKind, quick: bool) -> Result<Case> {
    const R: f64 = 1.0;
    const DISC: f64 = 0.8;
    let mut out = Case::new(
        CASE_NAMES[4],
        sff,
        format!(
            "flat disc of radius {DISC} m grown into a sphere of radius {R} m: conformal growth by \
             the stereographic factor λ = 1/(1 + ρ²/4R²) (ā = the metric of each face of the \
             inscribed cap, so stretching vanishes exactly at the answer) and natural curvature \
             b̄ = ā/R; started from the answer shrunk by 10 % (in tension); answer: the cap \
             (inverse stereographic image of the disc); error = RMS vertex distance after removing \
             rigid motion; static Newton to tolerance 1e-11"
        ),
        "m",
    );
    let levels: &[usize] = if quick {
        &[4, 6, 8, 12]
    } else {
        &[4, 6, 8, 12, 16]
    };
    let mut series = Refinement {
        name: "spherical cap (disc meshes)".into(),
        points: Vec::new(),
    };
    for &n in levels {
        let mesh = generators::disc(DISC, n)?;
        let x0 = mesh.positions().to_vec();
        let target = stereographic(&x0, R);
        // ā: the metric of the cap's faces (the disc grown conformally by the stereographic
        // factor, sampled exactly at the vertices), so stretching has an exact zero at the
        // answer; b̄ = ā/R, the sphere's second fundamental form in any basis. All that keeps
        // the discrete equilibrium off the cap is then the bending discretisation.
        let mut rest = RestState::from_mesh(&mesh, &target, sff)?;
        for (b, a) in rest.b_bar.iter_mut().zip(&rest.a_bar) {
            *b = a / R;
        }
        rest.validate(&mesh)?;
        // Start in tension (the cap shrunk by 10 %): a start larger than the answer is under
        // compression and wrinkles into other local minima on the way.
        let start: Vec<V3> = target.iter().map(|p| p * 0.9).collect();
        let material = Material::paper();
        let faces = mesh.n_faces();
        let mut sys = shell(
            mesh,
            rest,
            sff,
            material,
            Boundary::default(),
            Loads::default(),
        )?;
        for hessian in [HessianMode::Exact, HessianMode::GaussNewton] {
            let k = Knobs {
                hessian,
                ..Knobs::tight()
            };
            let mut x = start.clone();
            let mut phi = Vec::new();
            let c = static_solve(&mut sys, &mut x, &mut phi, k, STATIC_MAX_ITERATIONS);
            let error = rms_rigid(&x, &target)?;
            out.runs.push(Run {
                family: format!("{} Hessian", k.hessian_name()),
                label: format!("{n} rings, {}", k.label()),
                faces,
                dt: None,
                tolerance: Some(k.tolerance),
                error,
                wall_s: c.wall_s,
                newton_iterations: c.iterations,
                steps: c.steps,
                converged: c.ok,
                energy: elastic(&mut sys, &x, &phi),
                to_discrete: None,
            });
        }
        if let Some(e) = best_equilibrium(&out.runs[out.runs.len() - 2..]) {
            series.points.push((faces, e));
        }
    }
    out.refinement.push(series);
    Ok(out)
}

/// Strip geometry of the swelling cases (model.md §4): 100 × 2 mm, h = 1 mm, c = 0.01, top
/// stimulus 1, bottom 0 (narrow-strip regime: w²κ₀/h ≈ 0.04–0.06, printed by the study).
pub(super) const STRIP_LENGTH: f64 = 0.1;
pub(super) const STRIP_WIDTH: f64 = 0.002;
pub(super) const STRIP_THICKNESS: f64 = 1e-3;
pub(super) const STRIP_C: f64 = 0.01;
/// Newton iterations per ramp step: converging solves need ≤ 30; the cap bounds the cost of
/// one that stalls.
pub(super) const STRIP_MAX_ITERATIONS: usize = 100;
/// The stimulus is ramped in this many quasi-static steps (continuation towards a curl of about
/// one radian).
pub(super) const STRIP_RAMP: usize = 4;

/// Mean signed curvature (1/m) of the middle 60 % of the strip's centre line (vertex row
/// `ny/2` of the `(nx + 1) × (ny + 1)` grid), positive when the top side is convex.
pub(super) fn centre_line_curvature(
    x: &[V3],
    x_ref: &[V3],
    mesh: &Mesh,
    nx: usize,
    ny: usize,
) -> f64 {
    let row: Vec<V3> = (0..=nx).map(|i| x[(ny / 2) * (nx + 1) + i]).collect();
    // The normal of the face whose reference centroid is nearest the strip's centre tells
    // which side is the top.
    let centre = V3::new(STRIP_LENGTH / 2.0, STRIP_WIDTH / 2.0, 0.0);
    let centroid = |f: &[thinshell_mesh::VertexId; 3], p: &[V3]| {
        (p[f[0].idx()] + p[f[1].idx()] + p[f[2].idx()]) / 3.0
    };
    let normal = mesh
        .faces()
        .iter()
        .min_by(|a, b| {
            (centroid(a, x_ref) - centre)
                .norm()
                .total_cmp(&(centroid(b, x_ref) - centre).norm())
        })
        .map(|f| {
            let q = |k: usize| x[f[k].idx()];
            (q(1) - q(0)).cross(&(q(2) - q(0))).normalize()
        })
        .unwrap_or_else(V3::z);
    let (lo, hi) = (nx / 5, nx - nx / 5);
    let mut sum = 0.0;
    for i in lo.max(1)..hi {
        let (a, b, c) = (row[i - 1], row[i], row[i + 1]);
        // Circumcircle curvature 2|ab × bc| / (|ab| |bc| |ca|).
        let k = 2.0 * (b - a).cross(&(c - b)).norm()
            / ((b - a).norm() * (c - b).norm() * (c - a).norm());
        // Towards the circle's centre is a + c − 2b; a convex top has it below the top side.
        sum += if (a + c - 2.0 * b).dot(&normal) < 0.0 {
            k
        } else {
            -k
        };
    }
    sum / (hi - lo.max(1)).max(1) as f64
}

/// Thickness (m) of the second irregular-mesh cylinder series.
pub(super) const THICK_CYLINDER: f64 = 1e-2;

/// A strip under through-thickness swelling relaxed statically; error = relative deviation of
/// the centre-line curvature from the natural curvature −tr(ā⁻¹b̄)/2 of the rest forms.
pub(super) fn strip(bilayer: bool, sff: SffKind, quick: bool) -> Result<Case> {
    let (name, formula) = if bilayer {
        (CASE_NAMES[6], "3c·Δm/(2h) (Timoshenko's equal bilayer)")
    } else {
        (CASE_NAMES[5], "c·Δm/h")
    };
    let mut out = Case::new(
        name,
        sff,
        format!(
            "{} × {} mm strip, h = {} mm, swelling c = {STRIP_C}, stimulus 1 on top and 0 below \
             (ramped in {STRIP_RAMP} static steps), free; answer: the natural curvature of the rest \
             forms −tr(ā⁻¹b̄)/2 ≈ {formula} (the narrow-strip answer, see the note on w²κ₀/h); error = |κ/κ₀ − 1| of the mean centre-line \
             curvature over the middle 60 %",
            STRIP_LENGTH * 1e3,
            STRIP_WIDTH * 1e3,
            STRIP_THICKNESS * 1e3
        ),
        "relative",
    );
    // Cells of aspect 4 (length / width) at every level. The edge-director forms stop one level
    // earlier in the full study: their 6 400-face strips would cost a minute each.
    let levels: &[(usize, usize)] = if quick || sff.director().is_some() {
        &[(25, 2), (50, 4), (100, 8)]
    } else {
        &[(25, 2), (50, 4), (100, 8), (200, 16)]
    };
    let model = if bilayer {
        Swelling::bilayer(STRIP_C)
    } else {
        Swelling::linear(STRIP_C)
    };
    let mut series = Refinement {
        name: format!(
            "strip, {} swelling",
            if bilayer { "bilayer" } else { "linear" }
        ),
        points: Vec::new(),
    };
    for &(nx, ny) in levels {
        let mesh = generators::rectangle(STRIP_LENGTH, STRIP_WIDTH, nx, ny)?;
        let x0 = mesh.positions().to_vec();
        let initial = RestState::from_mesh(&mesh, &x0, sff)?;
        let material = paper(STRIP_THICKNESS);
        let faces = mesh.n_faces();
        // The force scale of the knobs' gradient test (no loads: E·h·L).
        let force_scale = shell(
            mesh.clone(),
            initial.clone(),
            sff,
            material,
            Boundary::default(),
            Loads::default(),
        )?
        .force_scale();
        for hessian in [HessianMode::Exact, HessianMode::GaussNewton] {
            let k = Knobs {
                hessian,
                ..Knobs::tight()
            };
            // A simulation's step s solves against the stimulus at t = s − 1 (then advances it):
            // s/STRIP_RAMP of the full swelling at step s.
            let ramp = Prescribed::function(
                &mesh,
                &x0,
                Box::new(|t, _| FaceStimulus {
                    top: ((t + 1.0) / STRIP_RAMP as f64).min(1.0),
                    bottom: 0.0,
                }),
            )?;
            let integrator = Static {
                newton: k.settings(STRIP_MAX_ITERATIONS),
                force_scale: Some(force_scale),
                ..run_loop_static()
            };
            let shell_model = ShellModel {
                material,
                terms: Terms::ELASTIC,
                sff,
            };
            // Edge angles are carried from one ramp step to the next, like the positions.
            let mut sim = SimulationBuilder::new(mesh.clone(), shell_model)
                .rest(initial.clone())
                .growth(Box::new(model.clone()), Box::new(ramp), None)
                .integrator(integrator, 1.0)
                .steps(STRIP_RAMP)
                .build()?;
            let mut cost = Cost {
                ok: true,
                ..Cost::default()
            };
            for _ in 0..STRIP_RAMP {
                let t0 = Instant::now();
                let r = sim.step();
                cost.wall_s += t0.elapsed().as_secs_f64();
                cost.steps += 1;
                match r {
                    Ok(r) => cost.iterations += r.newton_iterations,
                    Err(e) => {
                        cost.ok = false;
                        if let StepFailure::Solver(s) = &e.source {
                            cost.iterations += iterations_of(s);
                        }
                        break;
                    }
                }
            }
            let x = sim.positions().to_vec();
            let phi = sim.edge_angles().to_vec();
            let f_mid = faces / 2;
            let rest = sim.system().rest();
            let ainv = rest.a_bar[f_mid]
                .try_inverse()
                .ok_or_else(|| anyhow!("singular rest metric"))?;
            let kappa0 = -(ainv * rest.b_bar[f_mid]).trace() / 2.0;
            let kappa = centre_line_curvature(&x, &x0, &mesh, nx, ny);
            let error = (kappa / kappa0 - 1.0).abs();
            if ny == 4 && hessian == HessianMode::Exact {
                let narrowness = STRIP_WIDTH.powi(2) * kappa0.abs() / STRIP_THICKNESS;
                out.notes.push(format!(
                    "Natural curvature of the rest forms κ₀ = {kappa0:.4} 1/m; relaxed strip \
                         with 4 cells across: {kappa:.4} 1/m. Narrowness w²κ₀/h = \
                         {narrowness:.3}: the strip curls along its length to κ₀ up to a \
                         finite-width correction of relative order (w²κ₀/h)² ≈ {:.0e}, an estimated \
                         floor for this error.",
                    narrowness * narrowness
                ));
            }
            out.runs.push(Run {
                family: format!("{} Hessian", k.hessian_name()),
                label: format!("{nx}×{ny} cells, {}", k.label()),
                faces,
                dt: None,
                tolerance: Some(k.tolerance),
                error,
                wall_s: cost.wall_s,
                newton_iterations: cost.iterations,
                steps: cost.steps,
                converged: cost.ok,
                energy: elastic(sim.system_mut(), &x, &phi),
                to_discrete: None,
            });
        }
        if let Some(e) = best_equilibrium(&out.runs[out.runs.len() - 2..]) {
            series.points.push((faces, e));
        }
    }
    out.refinement.push(series);
    Ok(out)
}

/// Newton tolerance of the dynamic runs, relative to the sheet's weight: tighter ones hit the
/// round-off floor of ∇Φ (see the tolerance rows of the study).
pub(super) const DYNAMIC_TOLERANCE: f64 = 1e-4;

/// A 100 × 20 mm paper cantilever clamped along x = 0 falling under gravity from rest: the
/// position at a fixed time T against a very-small-Δt reference run.
pub(super) fn cantilever(sff: SffKind, quick: bool) -> Result<Case> {
    let t_end = if quick { 0.005 } else { 0.02 };
    let ref_divisor = 4.0;
    let mut out = Case::new(CASE_NAMES[7], sff, String::new(), "m");
    let mesh = generators::rectangle(0.1, 0.02, 16, 4)?;
    let x0 = mesh.positions().to_vec();
    let rest = RestState::from_mesh(&mesh, &x0, sff)?;
    let topo = mesh.topology();
    let clamped = topo
        .boundary_edges()
        .iter()
        .copied()
        .filter(|&e| {
            let [a, b] = topo.edge(e).vertices;
            x0[a.idx()].x < 1e-12 && x0[b.idx()].x < 1e-12
        })
        .collect();
    let boundary = Boundary {
        clamped_edges: clamped,
        ..Boundary::default()
    };
    let loads = Loads {
        gravity: V3::new(0.0, 0.0, -9.81),
        ..Loads::default()
    };
    let faces = mesh.n_faces();
    let mut sys = shell(mesh, rest, sff, Material::paper(), boundary, loads)?;
    // Newton's residual is measured against the weight: the loads are far below E·h·L.
    let weight = sys.mass().iter().sum::<f64>() * 9.81;

    let explicit_run = |sys: &mut ShellSystem, dt: f64, steps: usize| -> Result<(State, Cost)> {
        let mut state = State::at_rest(x0.clone());
        let mut ee = ExplicitEuler { dt };
        let c = integrate(sys, &mut ee, &mut state, &[steps], |_, _| Ok(()))?;
        Ok((state, c))
    };
    // Stable = finite and within a strip length of the start after the probe horizon (an
    // unstable mode grows by orders of magnitude within a few hundred steps).
    let probe = |sys: &mut ShellSystem, dt: f64| -> Result<bool> {
        let steps = ((t_end / dt).ceil() as usize).min(2000);
        let (s, c) = explicit_run(sys, dt, steps)?;
        Ok(c.ok && s.x.iter().zip(&x0).all(|(p, q)| (p - q).norm() < 0.1))
    };
    // Largest stable explicit Δt by bisection (in log Δt) between a stable and an unstable
    // bracket found by halving/doubling from 1e-6 s.
    let (mut lo, mut hi) = (1e-6, 1e-6);
    if probe(&mut sys, lo)? {
        while probe(&mut sys, hi * 2.0)? {
            hi *= 2.0;
            if hi > t_end {
                bail!("explicit Euler stable at every Δt up to T: no bracket");
            }
        }
        lo = hi;
        hi *= 2.0;
    } else {
        while !probe(&mut sys, lo / 2.0)? {
            lo /= 2.0;
            if lo < 1e-12 {
                bail!("explicit Euler unstable at every Δt tried");
            }
        }
        hi = lo;
        lo /= 2.0;
    }
    for _ in 0..6 {
        let mid = (lo * hi).sqrt();
        if probe(&mut sys, mid)? {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let dt_max = lo;
    out.notes.push(format!(
        "Largest stable explicit Δt (bisection to {:.1} %, probe of min(T/Δt, 2000) steps): \
         {dt_max:.3e} s; unstable at {hi:.3e} s.",
        100.0 * (hi / lo - 1.0)
    ));

    // Reference: symplectic Euler at Δt_max / ref_divisor, and at twice that step to estimate
    // the reference's own error (first order: the difference ≈ its error).
    let n_ref = (t_end * ref_divisor / dt_max).ceil() as usize;
    let (reference, ref_cost) = explicit_run(&mut sys, t_end / n_ref as f64, n_ref)?;
    if !ref_cost.ok {
        bail!("the reference run failed");
    }
    let n_half = n_ref.div_ceil(2);
    let (coarser, _) = explicit_run(&mut sys, t_end / n_half as f64, n_half)?;
    let ref_error = rms(&coarser.x, &reference.x);
    let scale = rms(&reference.x, &x0);
    out.notes.push(format!(
        "Reference: symplectic Euler with {n_ref} steps (Δt = {:.3e} s, Δt_max/{ref_divisor}) in \
         {:.2} s; RMS displacement at T {scale:.3e} m; the same with half the steps differs by \
         {ref_error:.2e} m (≈ the reference's own error, first order).",
        t_end / n_ref as f64,
        ref_cost.wall_s
    ));
    out.answer = format!(
        "100 × 20 mm paper sheet (16 × 4 cells, {faces} faces) clamped along x = 0, released from \
         rest under gravity; answer: the positions at T = {t_end} s of a very-small-Δt run \
         (symplectic Euler at Δt_max/{ref_divisor}); error = RMS vertex distance at T (no rigid \
         motion removed: the sheet is clamped)"
    );

    // Explicit runs at the stability limit and below.
    let divisors: &[f64] = &[1.0, 2.0];
    for &d in divisors {
        let n = (t_end * d / dt_max).ceil() as usize;
        let (s, c) = explicit_run(&mut sys, t_end / n as f64, n)?;
        out.runs.push(Run {
            family: "explicit (symplectic) Euler".into(),
            label: format!("dt = dt_max/{d} = {:.2e} s", t_end / n as f64),
            faces,
            dt: Some(t_end / n as f64),
            tolerance: None,
            error: rms(&s.x, &reference.x),
            wall_s: c.wall_s,
            newton_iterations: 0,
            steps: c.steps,
            converged: c.ok,
            energy: None,
            to_discrete: None,
        });
    }

    // Implicit Euler: Δt × (Hessian, line search); tolerance at one Δt.
    let step_counts: &[usize] = if quick {
        &[4, 16, 64]
    } else {
        &[4, 8, 16, 32, 64, 128, 256, 512]
    };
    let variants = [
        (HessianMode::Exact, true),
        (HessianMode::GaussNewton, true),
        (HessianMode::Exact, false),
    ];
    let implicit_run = |sys: &mut ShellSystem, n: usize, k: Knobs| -> Result<(State, Cost)> {
        let mut ie = ImplicitEuler::new(t_end / n as f64);
        ie.newton = k.settings(NewtonSettings::default().max_iterations);
        ie.force_scale = Some(weight);
        let mut state = State::at_rest(x0.clone());
        let c = integrate(sys, &mut ie, &mut state, &[n], |_, _| Ok(()))?;
        Ok((state, c))
    };
    for &n in step_counts {
        for (hessian, line_search) in variants {
            let k = Knobs {
                tolerance: DYNAMIC_TOLERANCE,
                hessian,
                line_search,
            };
            let (s, c) = implicit_run(&mut sys, n, k)?;
            out.runs.push(Run {
                family: format!(
                    "implicit Euler, {} Hessian, line search {}",
                    k.hessian_name(),
                    if line_search { "on" } else { "off" }
                ),
                label: format!("dt = T/{n} = {:.2e} s, {}", t_end / n as f64, k.label()),
                faces,
                dt: Some(t_end / n as f64),
                tolerance: Some(k.tolerance),
                error: rms(&s.x, &reference.x),
                wall_s: c.wall_s,
                newton_iterations: c.iterations,
                steps: c.steps,
                converged: c.ok,
                energy: None,
                to_discrete: None,
            });
        }
    }
    let n_tol = if quick { 16 } else { 64 };
    let tolerances: &[f64] = if quick {
        &[1e-2, 1e-5]
    } else {
        &[1e-2, 1e-4, 1e-6]
    };
    for &tolerance in tolerances {
        let k = Knobs {
            tolerance,
            hessian: HessianMode::Exact,
            line_search: true,
        };
        let (s, c) = implicit_run(&mut sys, n_tol, k)?;
        out.runs.push(Run {
            family: "implicit Euler, Newton tolerance".into(),
            label: format!(
                "dt = T/{n_tol} = {:.2e} s, {}",
                t_end / n_tol as f64,
                k.label()
            ),
            faces,
            dt: Some(t_end / n_tol as f64),
            tolerance: Some(tolerance),
            error: rms(&s.x, &reference.x),
            wall_s: c.wall_s,
            newton_iterations: c.iterations,
            steps: c.steps,
            converged: c.ok,
            energy: None,
            to_discrete: None,
        });
    }

    // Time-step convergence of implicit Euler (adaptive Hessian, line search).
    let mut series = Refinement {
        name: "implicit Euler, error vs Δt".into(),
        points: Vec::new(),
    };
    for r in out
        .runs
        .iter()
        .filter(|r| r.family == "implicit Euler, adaptive Hessian, line search on")
    {
        series.points.push((r.steps, r.error));
    }
    let (order, _) = series.orders();
    // `orders` reads faces^(−1/2); with step counts in place of faces the slope is half the
    // order in Δt.
    if let Some(p) = order {
        out.notes.push(format!(
            "Implicit Euler (adaptive Hessian, line search): error ∝ Δt^{:.2} (least-squares fit over \
             all Δt).",
            p / 2.0
        ));
    }
    // Largest implicit Δt reaching each error level, and what explicit Euler needs.
    for eps_rel in [1e-1, 1e-2, 1e-3] {
        let eps = eps_rel * scale;
        let best = out
            .runs
            .iter()
            .filter(|r| r.family.starts_with("implicit Euler, adaptive") && r.converged)
            .filter(|r| r.error <= eps)
            // The largest Δt, and of the variants at that Δt the fastest.
            .max_by(|a, b| {
                a.dt.unwrap_or(0.0)
                    .total_cmp(&b.dt.unwrap_or(0.0))
                    .then(b.wall_s.total_cmp(&a.wall_s))
            });
        match best {
            Some(r) => out.verdict.push(format!(
                "dynamics at error ≤ {eps_rel:.0e} × displacement ({eps:.1e} m): implicit Euler \
                 up to Δt = {:.2e} s ({} steps, {:.3} s, {}).",
                r.dt.unwrap_or(0.0),
                r.steps,
                r.wall_s,
                r.family
            )),
            None => out.verdict.push(format!(
                "dynamics at error ≤ {eps_rel:.0e} × displacement ({eps:.1e} m): no implicit Euler \
                 run in this study is that accurate."
            )),
        }
    }
    if let Some(r) = out
        .runs
        .iter()
        .find(|r| r.family.starts_with("explicit") && r.label.starts_with("dt = dt_max/1 "))
    {
        out.verdict.push(format!(
            "explicit Euler at its stability limit: error {:.2e} m ({:.1e} × displacement) in \
             {:.3} s ({} steps).",
            r.error,
            r.error / scale,
            r.wall_s,
            r.steps
        ));
    }
    Ok(out)
}
