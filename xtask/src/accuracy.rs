//! `cargo xtask accuracy`: what accuracy costs in time (issue #7).
//!
//! Runs cases with a known answer under one knob at a time (mesh resolution, Δt, Newton
//! tolerance, adaptive (default) vs Gauss–Newton Hessian, line search, implicit vs explicit Euler, static
//! solve vs dynamic relaxation), measures the error against the answer and the wall time of
//! every run, and writes `accuracy.md` with tables and log–log plots (Pareto front marked) plus
//! a JSON file with every run.
//!
//! The second-fundamental-form discretisation is one more dimension: every case runs once per
//! entry of [`FORMULATIONS`].
//!
//! Simulations are built through the library (`thinshell_solver::ShellSystem` and its
//! integrators), with the same force scale rule as the scene builder for static solves.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use nalgebra::{Matrix2, Vector3};
use serde_json::{Value, json};
use thinshell::reference::{SquareCase, rms_distance_modulo_rigid, wrap_cylinder};
use thinshell_energy::{HessianMode, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::{FaceStimulus, Growth, Prescribed, Swelling};
use thinshell_mesh::{Mesh, generators};
use thinshell_solver::{
    Boundary, ExplicitEuler, ImplicitEuler, Integrator, Loads, NewtonSettings, ShellSystem,
    SolverError, State, Static,
};

use crate::plot::{Chart, Mark, Series, save};

mod layout;

type V3 = Vector3<f64>;

/// Second-fundamental-form discretisations compared by the study. Extend this list (e.g. with
/// the edge-director variants) and every case runs once more per entry.
pub const FORMULATIONS: &[SffKind] = &SffKind::ALL;

/// Names of the cases every study run must contain (checked by the test).
pub const CASE_NAMES: &[&str] = &[
    "enlarged square",
    "rhombus",
    "cylindrical patch",
    "cylinder under refinement",
    "spherical cap under refinement",
    "strip, linear swelling",
    "strip, bilayer swelling",
    "falling cantilever (dynamic)",
];

/// Name of the mesh layout × orientation × bending form section (for `--only`).
pub const LAYOUT_STUDY: &str = "mesh layout";

/// Where the study writes.
pub struct Options {
    /// Fewer knob values and coarser levels (< 1 minute).
    pub quick: bool,
    /// `accuracy.md` goes here, the plots into `<docs_dir>/accuracy/`.
    pub docs_dir: PathBuf,
    /// The JSON file with every run.
    pub json_path: PathBuf,
    /// Only the cases whose name contains this text (for working on one case).
    pub only: Option<String>,
}

/// The study's gradient tolerance knob for static solves (relative to the solver's force scale
/// `ShellSystem::force_scale`, E·h·L), on top of the solver's scale-free test.
const STATIC_TOLERANCE: f64 = 1e-11;
/// Static solves may take many iterations from a far start (the scene builder's cap).
const STATIC_MAX_ITERATIONS: usize = 500;

/// One run: a point of the error–time plane.
#[derive(Clone, Debug)]
struct Run {
    /// The knob being varied (one plotted series).
    family: String,
    /// The knob values of this run.
    label: String,
    faces: usize,
    dt: Option<f64>,
    tolerance: Option<f64>,
    /// Error against the known answer (unit: the case's `error_unit`).
    error: f64,
    /// Wall time of the solve / time stepping, s (set-up of the system excluded, Newton
    /// workspace with its symbolic analysis included).
    wall_s: f64,
    newton_iterations: usize,
    steps: usize,
    /// False when Newton or the time stepping failed; the error is then that of the last
    /// accepted state.
    converged: bool,
    /// Elastic energy of the final state, J (static solves only: tells apart equilibria).
    energy: Option<f64>,
    /// Distance to the discrete equilibrium (the tightest static solve on the same mesh), same
    /// unit as `error`: the solver's share of the error (seed-mesh squares only).
    to_discrete: Option<f64>,
}

/// A convergence series under mesh refinement.
#[derive(Clone, Debug)]
struct Refinement {
    name: String,
    /// (faces, error).
    points: Vec<(usize, f64)>,
}

impl Refinement {
    /// Observed order p of error ∝ h^p with h ∝ faces^(−1/2): least-squares slope over all
    /// levels, and per consecutive pair.
    fn orders(&self) -> (Option<f64>, Vec<f64>) {
        let pts: Vec<(f64, f64)> = self
            .points
            .iter()
            .filter(|(f, e)| *f > 0 && e.is_finite() && *e > 0.0)
            .map(|&(f, e)| (-0.5 * (f as f64).ln(), e.ln()))
            .collect();
        let pairs = pts
            .windows(2)
            .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
            .collect();
        if pts.len() < 2 {
            return (None, pairs);
        }
        let n = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        (Some(sxy / sxx), pairs)
    }
}

/// All runs of one case and one formulation.
struct Case {
    name: &'static str,
    sff: SffKind,
    /// The known answer and how the error is measured.
    answer: String,
    error_unit: &'static str,
    runs: Vec<Run>,
    refinement: Vec<Refinement>,
    /// Measured facts worth a sentence (reference quality, stability limit, …).
    notes: Vec<String>,
    /// Recommendation lines derived from this case's runs.
    verdict: Vec<String>,
}

impl Case {
    fn new(name: &'static str, sff: SffKind, answer: String, error_unit: &'static str) -> Case {
        Case {
            name,
            sff,
            answer,
            error_unit,
            runs: Vec::new(),
            refinement: Vec::new(),
            notes: Vec::new(),
            verdict: Vec::new(),
        }
    }

    /// Indices of the runs on the Pareto front of (wall time, error): no other run is both
    /// faster and more accurate. Failed runs are left out: they produced no answer.
    fn pareto(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.runs.len())
            .filter(|&i| {
                let r = &self.runs[i];
                r.converged && r.error.is_finite() && r.wall_s.is_finite()
            })
            .collect();
        idx.sort_by(|&a, &b| {
            let (ra, rb) = (&self.runs[a], &self.runs[b]);
            ra.wall_s
                .total_cmp(&rb.wall_s)
                .then(ra.error.total_cmp(&rb.error))
        });
        let mut front = Vec::new();
        let mut best = f64::INFINITY;
        for i in idx {
            if self.runs[i].error < best {
                best = self.runs[i].error;
                front.push(i);
            }
        }
        front
    }

    /// The cheapest run whose error is within `factor` of the best error of the case.
    fn cheapest_within(&self, factor: f64) -> Option<&Run> {
        let best = self
            .runs
            .iter()
            .map(|r| r.error)
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        self.runs
            .iter()
            .filter(|r| r.converged && r.error <= factor * best.max(1e-300))
            .min_by(|a, b| a.wall_s.total_cmp(&b.wall_s))
    }
}

// ---------------------------------------------------------------------------------------------
// Building and solving

#[derive(Clone, Copy, Debug)]
struct Knobs {
    tolerance: f64,
    hessian: HessianMode,
    line_search: bool,
}

impl Knobs {
    fn tight() -> Knobs {
        Knobs {
            tolerance: STATIC_TOLERANCE,
            hessian: HessianMode::Exact,
            line_search: true,
        }
    }
    fn hessian_name(&self) -> &'static str {
        match self.hessian {
            // The solver's default policy with the exact Hessian as its own: exact where it
            // factorises and its steps hold, Gauss–Newton elsewhere.
            HessianMode::Exact => "adaptive",
            HessianMode::GaussNewton => "Gauss-Newton",
            HessianMode::ProjectedPsd => "projected",
        }
    }
    fn label(&self) -> String {
        format!(
            "tol {:.0e}, {} Hessian, line search {}",
            self.tolerance,
            self.hessian_name(),
            if self.line_search { "on" } else { "off" }
        )
    }
    fn settings(&self, max_iterations: usize) -> NewtonSettings {
        NewtonSettings {
            gradient_tolerance: self.tolerance,
            line_search: self.line_search,
            max_iterations,
            ..NewtonSettings::default()
        }
    }
}

/// What a solve or a run of steps cost.
#[derive(Clone, Copy, Debug, Default)]
struct Cost {
    wall_s: f64,
    iterations: usize,
    steps: usize,
    ok: bool,
}

fn paper(thickness: f64) -> Material {
    Material {
        thickness,
        ..Material::paper()
    }
}

fn shell(
    mesh: Mesh,
    rest: RestState,
    sff: SffKind,
    material: Material,
    boundary: Boundary,
    loads: Loads,
) -> Result<ShellSystem> {
    let model = ShellModel {
        material,
        terms: Terms {
            stretch: true,
            bend: true,
            damping: false,
        },
        sff,
    };
    Ok(ShellSystem::new(mesh, model, rest, boundary, loads)?)
}

fn iterations_of(e: &SolverError) -> usize {
    match e {
        SolverError::NewtonDidNotConverge { iterations, .. } => *iterations,
        _ => 0,
    }
}

/// Static equilibrium from `x` and, for edge-director forms, the edge angles `phi` (both
/// overwritten by the solution, or the last accepted iterate on failure; an empty `phi` starts
/// from zero angles).
fn static_solve(
    sys: &mut ShellSystem,
    x: &mut [V3],
    phi: &mut Vec<f64>,
    k: Knobs,
    max_iterations: usize,
) -> Cost {
    sys.hessian_mode = k.hessian;
    let mut st = Static {
        newton: k.settings(max_iterations),
        // The knob's tolerance is a gradient test against the solver's one force scale, on top
        // of the solver's scale-free convergence test.
        force_scale: Some(sys.force_scale()),
        ..Static::default()
    };
    phi.resize(sys.n_edge_angles(), 0.0);
    let t0 = Instant::now();
    let r = st.solve_with_angles(sys, x, phi);
    let wall_s = t0.elapsed().as_secs_f64();
    match r {
        Ok(rep) => Cost {
            wall_s,
            iterations: rep.iterations,
            steps: 1,
            ok: true,
        },
        Err(e) => Cost {
            wall_s,
            iterations: iterations_of(&e),
            steps: 1,
            ok: false,
        },
    }
}

/// Steps `state` with `integrator`, stopping at each of `checkpoints` (step counts, ascending)
/// to call `at` with the cost so far (step time only). Stops at the first failed step.
fn integrate(
    sys: &mut ShellSystem,
    integrator: &mut dyn Integrator,
    state: &mut State,
    checkpoints: &[usize],
    mut at: impl FnMut(&State, Cost) -> Result<()>,
) -> Result<Cost> {
    let mut cost = Cost {
        ok: true,
        ..Cost::default()
    };
    let last = checkpoints.last().copied().unwrap_or(0);
    let mut next = 0;
    while cost.steps < last {
        let t0 = Instant::now();
        let r = integrator.step(sys, state);
        cost.wall_s += t0.elapsed().as_secs_f64();
        match r {
            Ok(rep) => {
                cost.iterations += rep.newton.map_or(0, |n| n.iterations);
                cost.steps += 1;
            }
            Err(e) => {
                cost.iterations += iterations_of(&e);
                cost.ok = false;
                at(state, cost)?;
                return Ok(cost);
            }
        }
        if !state.x.iter().all(|p| p.iter().all(|c| c.is_finite())) {
            cost.ok = false;
            at(state, cost)?;
            return Ok(cost);
        }
        if next < checkpoints.len() && cost.steps == checkpoints[next] {
            at(state, cost)?;
            next += 1;
        }
    }
    Ok(cost)
}

/// Elastic energy (J) of `x` and edge angles `phi` (empty: none or all 0), `None` if it cannot
/// be evaluated.
fn elastic(sys: &mut ShellSystem, x: &[V3], phi: &[f64]) -> Option<f64> {
    sys.energy_at(x, phi).ok().map(|e| e.stretch + e.bend)
}

/// Of the converged runs on one mesh, the error of the one with the lowest final energy (the
/// equilibrium shape is the energy minimiser; different Hessians may stop at different
/// stationary points).
fn best_equilibrium(runs: &[Run]) -> Option<f64> {
    runs.iter()
        .filter(|r| r.converged)
        .min_by(|a, b| {
            a.energy
                .unwrap_or(f64::INFINITY)
                .total_cmp(&b.energy.unwrap_or(f64::INFINITY))
        })
        .map(|r| r.error)
}

fn rms_rigid(x: &[V3], y: &[V3]) -> Result<f64> {
    rms_distance_modulo_rigid(x, y).ok_or_else(|| anyhow!("cannot compare positions"))
}

/// RMS distance between corresponding points (no rigid motion removed), m.
fn rms(x: &[V3], y: &[V3]) -> f64 {
    let s: f64 = x.iter().zip(y).map(|(p, q)| (p - q).norm_squared()).sum();
    (s / x.len().max(1) as f64).sqrt()
}

// ---------------------------------------------------------------------------------------------
// Cases

/// The seed's three squares on the seed mesh: static knobs (tolerance × Hessian × line search),
/// dynamic relaxation with implicit Euler at several Δt, and (full study) the seed's own way.
fn square(case: SquareCase, sff: SffKind, quick: bool) -> Result<Case> {
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
    sys.hessian_mode = HessianMode::Exact;
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
fn cylinder_refinement(sff: SffKind, quick: bool) -> Result<Case> {
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
fn stereographic(x: &[V3], r: f64) -> Vec<V3> {
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
fn cap_refinement(sff: SffKind, quick: bool) -> Result<Case> {
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
const STRIP_LENGTH: f64 = 0.1;
const STRIP_WIDTH: f64 = 0.002;
const STRIP_THICKNESS: f64 = 1e-3;
const STRIP_C: f64 = 0.01;
/// Newton iterations per ramp step: converging solves need ≤ 30; the cap bounds the cost of
/// one that stalls.
const STRIP_MAX_ITERATIONS: usize = 100;
/// The stimulus is ramped in this many quasi-static steps (continuation towards a curl of about
/// one radian).
const STRIP_RAMP: usize = 4;

/// Mean signed curvature (1/m) of the middle 60 % of the strip's centre line (vertex row
/// `ny/2` of the `(nx + 1) × (ny + 1)` grid), positive when the top side is convex.
fn centre_line_curvature(x: &[V3], x_ref: &[V3], mesh: &Mesh, nx: usize, ny: usize) -> f64 {
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
const THICK_CYLINDER: f64 = 1e-2;

/// A strip under through-thickness swelling relaxed statically; error = relative deviation of
/// the centre-line curvature from the natural curvature −tr(ā⁻¹b̄)/2 of the rest forms.
fn strip(bilayer: bool, sff: SffKind, quick: bool) -> Result<Case> {
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
        let mesh_copy = mesh.clone();
        let mut sys = shell(
            mesh,
            initial.clone(),
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
            let mut x = x0.clone();
            // Edge angles are carried from one ramp step to the next, like the positions.
            let mut phi = Vec::new();
            let mut cost = Cost {
                ok: true,
                ..Cost::default()
            };
            for step in 1..=STRIP_RAMP {
                let m = FaceStimulus {
                    top: step as f64 / STRIP_RAMP as f64,
                    bottom: 0.0,
                };
                let field = Prescribed::uniform(faces, m)?;
                let mut growth = Growth::new(
                    Box::new(model.clone()),
                    Box::new(field),
                    initial.clone(),
                    STRIP_THICKNESS,
                )?;
                growth.update_rest(&mut sys.rest)?;
                let c = static_solve(&mut sys, &mut x, &mut phi, k, STRIP_MAX_ITERATIONS);
                cost.wall_s += c.wall_s;
                cost.iterations += c.iterations;
                cost.steps += 1;
                cost.ok &= c.ok;
            }
            let f_mid = faces / 2;
            let ainv = sys.rest.a_bar[f_mid]
                .try_inverse()
                .ok_or_else(|| anyhow!("singular rest metric"))?;
            let kappa0 = -(ainv * sys.rest.b_bar[f_mid]).trace() / 2.0;
            let kappa = centre_line_curvature(&x, &x0, &mesh_copy, nx, ny);
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

/// Newton tolerance of the dynamic runs, relative to the sheet's weight: tighter ones hit the
/// round-off floor of ∇Φ (see the tolerance rows of the study).
const DYNAMIC_TOLERANCE: f64 = 1e-4;

/// A 100 × 20 mm paper cantilever clamped along x = 0 falling under gravity from rest: the
/// position at a fixed time T against a very-small-Δt reference run.
fn cantilever(sff: SffKind, quick: bool) -> Result<Case> {
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
        sys.hessian_mode = k.hessian;
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

// ---------------------------------------------------------------------------------------------
// Output

fn machine() -> (usize, String) {
    let nproc = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    (nproc, cpu)
}

/// Today's date (UTC) as YYYY-MM-DD, from the system clock (days-to-civil conversion of the
/// proleptic Gregorian calendar).
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

fn slug(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_matches('-').to_string()
}

fn sff_name(sff: SffKind) -> String {
    sff.name().to_string()
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or("—".into(), |v| format!("{v:.1e}"))
}

fn case_json(c: &Case) -> Value {
    let front = c.pareto();
    json!({
        "case": c.name,
        "formulation": sff_name(c.sff),
        "answer": c.answer,
        "error_unit": c.error_unit,
        "notes": c.notes,
        "verdict": c.verdict,
        "runs": c.runs.iter().enumerate().map(|(i, r)| json!({
            "family": r.family,
            "label": r.label,
            "faces": r.faces,
            "dt_s": r.dt,
            "tolerance": r.tolerance,
            "error": r.error,
            "wall_s": r.wall_s,
            "newton_iterations": r.newton_iterations,
            "steps": r.steps,
            "converged": r.converged,
            "energy_j": r.energy,
            "to_discrete_equilibrium": r.to_discrete,
            "pareto": front.contains(&i),
        })).collect::<Vec<_>>(),
        "refinement": c.refinement.iter().map(|s| {
            let (fit, pairs) = s.orders();
            json!({
                "series": s.name,
                "faces": s.points.iter().map(|p| p.0).collect::<Vec<_>>(),
                "error": s.points.iter().map(|p| p.1).collect::<Vec<_>>(),
                "order_fit": fit,
                "order_pairs": pairs,
            })
        }).collect::<Vec<_>>(),
    })
}

fn plot_case(c: &Case, dir: &Path) -> Result<String> {
    let mut families: Vec<&str> = Vec::new();
    for r in &c.runs {
        if !families.contains(&r.family.as_str()) {
            families.push(&r.family);
        }
    }
    let mut series: Vec<Series> = families
        .iter()
        .map(|f| Series {
            name: (*f).to_string(),
            points: c
                .runs
                .iter()
                .filter(|r| r.family == *f)
                .map(|r| (r.wall_s, r.error))
                .collect(),
            mark: Mark::Points,
        })
        .collect();
    series.push(Series {
        name: "Pareto front".into(),
        points: c
            .pareto()
            .iter()
            .map(|&i| (c.runs[i].wall_s, c.runs[i].error))
            .collect(),
        mark: Mark::Line,
    });
    let stem = slug(&format!("{} {}", c.name, sff_name(c.sff)));
    let chart = Chart {
        title: format!("{} ({}): error vs wall time", c.name, sff_name(c.sff)),
        x_label: "wall time [s]".into(),
        y_label: format!("error [{}]", c.error_unit),
        log_x: true,
        log_y: true,
        series,
    };
    save(&chart, &dir.join(&stem))?;
    Ok(stem)
}

fn plot_refinement(cases: &[Case], dir: &Path) -> Result<String> {
    let series = cases
        .iter()
        .filter(|c| c.name != CASE_NAMES[7])
        .flat_map(|c| {
            c.refinement.iter().map(move |s| Series {
                name: format!("{} [{}] ({})", s.name, c.error_unit, sff_name(c.sff)),
                points: s.points.iter().map(|&(f, e)| (f as f64, e)).collect(),
                mark: Mark::Line,
            })
        })
        .collect();
    let stem = "convergence".to_string();
    let chart = Chart {
        title: "Error under mesh refinement".into(),
        x_label: "faces".into(),
        y_label: "error (m, or relative for the strips)".into(),
        log_x: true,
        log_y: true,
        series,
    };
    save(&chart, &dir.join(&stem))?;
    Ok(stem)
}

fn markdown(
    cases: &[Case],
    quick: bool,
    total_s: f64,
    plots: &[(usize, String)],
    conv: &str,
    layouts: Option<(&layout::LayoutStudy, &str)>,
) -> String {
    let (nproc, cpu) = machine();
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "unknown".into());
    let mut md = String::new();
    let cmd = if quick {
        "cargo xtask accuracy --quick"
    } else {
        "cargo xtask accuracy"
    };
    let _ = writeln!(md, "# What accuracy costs in time\n");
    let _ = writeln!(
        md,
        "Generated by `{cmd}` on {} (`nproc` = {nproc}, CPU \"{cpu}\"); the whole study took \
         {total_s:.0} s. Do not edit by hand: rerun the command. Every number below comes from that \
         run; the JSON with every run is `target/xtask/accuracy.json`.\n",
        today()
    );
    let _ = writeln!(
        md,
        "Wall times are single measurements on a shared 2-core machine where other builds may be \
         running: treat them as ±30 % (more for runs under a millisecond). Wall time covers the \
         solve or the time stepping (Newton workspace and symbolic analysis included, building \
         the mesh and the system excluded); the 1-minute load average when the study ended was \
         {load} (above 2, other jobs shared the cores). \"To discrete eq.\" is the distance to the \
         tightest static solution on the same mesh, the solver's share of the error (seed-mesh \
         squares). Second-fundamental-form formulations compared: {}.\n",
        FORMULATIONS
            .iter()
            .map(|s| format!("`{}`", sff_name(*s)))
            .collect::<Vec<_>>()
            .join(", ")
    );

    let _ = writeln!(md, "## Recommendation\n");
    let _ = writeln!(
        md,
        "Derived from the runs below (\"within 2× of the best error\" picks the cheapest run that \
         is about as accurate as anything tried on that case; failed runs never count).\n"
    );
    // Headline for equilibrium shapes: which kind of run was cheapest at the best accuracy.
    let equilibrium: Vec<&Case> = cases.iter().filter(|c| c.name != CASE_NAMES[7]).collect();
    let picks: Vec<&Run> = equilibrium
        .iter()
        .filter_map(|c| c.cheapest_within(2.0))
        .collect();
    let statics = picks.iter().filter(|r| r.dt.is_none()).count();
    let gn = picks
        .iter()
        .filter(|r| r.dt.is_none() && r.label.contains("Gauss-Newton"))
        .count();
    let _ = writeln!(
        md,
        "**Equilibrium shapes**: use a static Newton solve. Over the {} equilibrium cases, the \
         cheapest run within 2× of the best error was a static solve in {statics}, with the \
         Gauss–Newton Hessian in {gn} of those; dynamic relaxation was never cheaper at that \
         accuracy{}. Loose gradient tolerances (relative to E·h·L) are unsafe for bending-dominated shapes \
         (see the tolerance note of the cylindrical patch). **Dynamics**: see the Δt lines of the \
         falling cantilever below.\n",
        picks.len(),
        if statics == picks.len() {
            ""
        } else {
            " except where listed below"
        }
    );
    bending_form_advice(&mut md, cases);
    if let Some((study, _)) = layouts {
        let _ = writeln!(md, "{}\n", layout::advice(study));
    }
    for c in cases {
        for v in &c.verdict {
            let _ = writeln!(md, "- ({}) {v}", sff_name(c.sff));
        }
    }
    // Refinement verdicts.
    for c in cases {
        for s in &c.refinement {
            if c.name == CASE_NAMES[7] {
                continue;
            }
            let (fit, pairs) = s.orders();
            let last = pairs.last().copied();
            let conv = match (fit, last) {
                (Some(p), Some(l)) if p > 0.5 && l > 0.5 => {
                    format!("converges, order ≈ {p:.2} (last refinement {l:.2})")
                }
                (Some(p), Some(l)) => format!(
                    "does not converge in this range: fitted order {p:.2}, last refinement {l:.2} — {}",
                    if c.sff.director().is_some() {
                        "the consistent director bending levels off at the thin membrane's locking \
                         on irregular meshes (see Bending forms compared)"
                    } else {
                        "the error levels off at the formulation's consistency error"
                    }
                ),
                _ => "too few levels for an order".into(),
            };
            let _ = writeln!(md, "- ({}) {}: {conv}.", sff_name(c.sff), s.name);
        }
    }
    // Where the mid-edge average stops converging: the irregular-mesh cylinder series.
    for c in cases.iter().filter(|c| c.sff == SffKind::MidEdgeAverage) {
        for s in c
            .refinement
            .iter()
            .filter(|s| s.name == "cylinder, irregular meshes")
        {
            if let (Some(first), Some(last)) = (s.points.first(), s.points.last()) {
                let _ = writeln!(
                    md,
                    "\nWhere the mid-edge average stops converging: on irregular meshes its bending \
                     is not consistent (docs/model.md §1.1), so the {} error goes from {:.2e} at {} \
                     faces to {:.2e} at {} faces ({:.1}× for {:.0}× the faces) and then levels \
                     off: refining such a mesh buys time, not accuracy. On the alternating-diagonal \
                     grids the same case converges with its curvature along the grid (table \
                     below){}. Results on a mesh of unknown quality are only as good as its \
                     coarsest level that already sits on the floor.",
                    s.name,
                    first.1,
                    first.0,
                    last.1,
                    last.0,
                    first.1 / last.1,
                    last.0 as f64 / first.0 as f64,
                    layouts.map_or(String::new(), |(study, _)| layout::alternating_note(study))
                );
            }
        }
    }
    forms_compared(&mut md, cases);
    let _ = writeln!(md);
    if let Some((study, plot)) = layouts {
        layout::markdown(study, &mut md, plot);
    }
    let _ = writeln!(md, "## Convergence under mesh refinement\n");
    let _ = writeln!(
        md,
        "Order p of error ∝ h^p with h ∝ faces^(−1/2) (least-squares fit over all levels; per \
         refinement step in brackets). Static tolerance 1e-11 with line search; per level the \
         converged run (adaptive or Gauss–Newton Hessian) with the lower final energy.\n"
    );
    let _ = writeln!(
        md,
        "| formulation | series | faces | error | order fit | order per step |"
    );
    let _ = writeln!(md, "|---|---|---|---|---:|---|");
    for c in cases.iter().filter(|c| c.name != CASE_NAMES[7]) {
        for s in &c.refinement {
            let (fit, pairs) = s.orders();
            let _ = writeln!(
                md,
                "| {} | {} [{}] | {} | {} | {} | {} |",
                sff_name(c.sff),
                s.name,
                c.error_unit,
                s.points
                    .iter()
                    .map(|p| p.0.to_string())
                    .collect::<Vec<_>>()
                    .join(" / "),
                s.points
                    .iter()
                    .map(|p| format!("{:.2e}", p.1))
                    .collect::<Vec<_>>()
                    .join(" / "),
                fit.map_or("—".into(), |p| format!("{p:.2}")),
                pairs
                    .iter()
                    .map(|p| format!("{p:.2}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let _ = writeln!(
        md,
        "\n![error under refinement](accuracy/{conv}.png) ([SVG](accuracy/{conv}.svg))\n"
    );

    let _ = writeln!(md, "## Cases\n");
    for (i, c) in cases.iter().enumerate() {
        let _ = writeln!(md, "### {} ({})\n", c.name, sff_name(c.sff));
        let _ = writeln!(md, "{}.\n", c.answer);
        for n in &c.notes {
            let _ = writeln!(md, "- {n}");
        }
        if !c.notes.is_empty() {
            let _ = writeln!(md);
        }
        if let Some((_, stem)) = plots.iter().find(|(j, _)| *j == i) {
            let _ = writeln!(
                md,
                "![{}](accuracy/{stem}.png) ([SVG](accuracy/{stem}.svg))\n",
                c.name
            );
        }
        let front = c.pareto();
        let _ = writeln!(
            md,
            "| knob | run | faces | Δt [s] | tol | steps | Newton its | wall [s] | error [{}] | energy [J] | Pareto |",
            c.error_unit
        );
        let _ = writeln!(
            md,
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|:---:|"
        );
        for (j, r) in c.runs.iter().enumerate() {
            let _ = writeln!(
                md,
                "| {} | {}{} | {} | {} | {} | {} | {} | {:.4} | {:.2e} | {} | {} | {} |",
                r.family,
                r.label,
                if r.converged { "" } else { " (**failed**)" },
                r.faces,
                fmt_opt(r.dt),
                fmt_opt(r.tolerance),
                r.steps,
                r.newton_iterations,
                r.wall_s,
                r.error,
                r.to_discrete.map_or("—".into(), |e| format!("{e:.1e}")),
                r.energy.map_or("—".into(), |e| format!("{e:.2e}")),
                if front.contains(&j) { "★" } else { "" }
            );
        }
        let _ = writeln!(md);
    }
    md
}

/// Adds to `c.notes` how the adaptive (default) and Gauss–Newton Hessians fared over the case's Newton runs
/// (converged count, median iterations, total wall time), and, where the Newton tolerance was
/// varied, the error at the loosest and the tightest tolerance.
fn summarise_knobs(c: &mut Case) {
    for h in ["adaptive", "Gauss-Newton"] {
        let tag = format!("{h} Hessian");
        let runs: Vec<&Run> = c
            .runs
            .iter()
            .filter(|r| r.label.contains(&tag) && !r.family.contains("tolerance"))
            .collect();
        if runs.is_empty() {
            continue;
        }
        let ok = runs.iter().filter(|r| r.converged).count();
        let mut its: Vec<usize> = runs.iter().map(|r| r.newton_iterations).collect();
        its.sort_unstable();
        let wall: f64 = runs.iter().map(|r| r.wall_s).sum();
        c.notes.push(format!(
            "{tag}: {ok} of {} runs converged, median {} Newton iterations, {wall:.2} s in all.",
            runs.len(),
            its[its.len() / 2]
        ));
    }
    let tol_runs: Vec<&Run> = c
        .runs
        .iter()
        .filter(|r| r.family == "static, adaptive Hessian, line search on")
        .collect();
    let loose = tol_runs.iter().max_by(|a, b| {
        a.tolerance
            .unwrap_or(0.0)
            .total_cmp(&b.tolerance.unwrap_or(0.0))
    });
    let tight = tol_runs.iter().min_by(|a, b| {
        a.tolerance
            .unwrap_or(0.0)
            .total_cmp(&b.tolerance.unwrap_or(0.0))
    });
    if let (Some(l), Some(t)) = (loose, tight) {
        if l.tolerance != t.tolerance {
            c.notes.push(format!(
                "Newton tolerance (adaptive Hessian, line search; relative to E·h·L): {:.0e} stops \
                 after {} iterations at error {:.2e}, {:.0e} after {} at {:.2e}.",
                l.tolerance.unwrap_or(0.0),
                l.newton_iterations,
                l.error,
                t.tolerance.unwrap_or(0.0),
                t.newton_iterations,
                t.error
            ));
        }
    }
}

/// The bending forms side by side: finest-level error of every refinement series, the coarsest
/// level at which each form is at least as accurate as the mid-edge average's finest level,
/// and the wall time of all runs of each case.
fn forms_compared(md: &mut String, cases: &[Case]) {
    if FORMULATIONS.len() < 2 {
        return;
    }
    let names: Vec<String> = FORMULATIONS.iter().map(|f| sff_name(*f)).collect();
    let _ = writeln!(md, "\n## Bending forms compared\n");
    let _ = writeln!(
        md,
        "Error at the finest level of every refinement series, and (in brackets) the faces of the \
         coarsest level at which the form is at least as accurate as the mid-edge average at its \
         finest level. The edge-director forms carry one extra unknown per edge and cost about 3× \
         per Newton iteration on the same mesh (`docs/performance.md`).\n"
    );
    let _ = writeln!(md, "| series | finest faces | {} |", names.join(" | "));
    let _ = writeln!(md, "|---|---:|{}", "---:|".repeat(names.len()));
    let series_of = |sff: SffKind, name: &str| -> Option<&Refinement> {
        cases
            .iter()
            .filter(|c| c.sff == sff)
            .flat_map(|c| c.refinement.iter())
            .find(|s| s.name == name)
    };
    for base in cases
        .iter()
        .filter(|c| c.sff == SffKind::MidEdgeAverage)
        .flat_map(|c| c.refinement.iter())
    {
        let Some(&(faces, target)) = base.points.last() else {
            continue;
        };
        let cells: Vec<String> = FORMULATIONS
            .iter()
            .map(|&f| {
                match series_of(f, &base.name).and_then(|s| s.points.last().map(|p| (s, p))) {
                    Some((s, &(_, e))) => {
                        let reach = s.points.iter().find(|p| p.1 <= target).map(|p| p.0);
                        match reach {
                            Some(n) => format!("{e:.2e} ({n})"),
                            None => format!("{e:.2e} (—)"),
                        }
                    }
                    None => "—".into(),
                }
            })
            .collect();
        let _ = writeln!(md, "| {} | {faces} | {} |", base.name, cells.join(" | "));
    }
    // Thin shells on irregular meshes: is the directors' remaining error membrane locking?
    for &f in FORMULATIONS.iter().filter(|f| f.director().is_some()) {
        let thin = series_of(f, "cylinder, irregular meshes");
        let thick = cases
            .iter()
            .filter(|c| c.sff == f)
            .flat_map(|c| c.refinement.iter())
            .find(|s| s.name.starts_with("cylinder, irregular meshes, h ="));
        if let (Some(thin), Some(thick)) = (thin, thick) {
            let last = |s: &Refinement| s.orders().1.last().copied().unwrap_or(f64::NAN);
            let _ = writeln!(
                md,
                "\n({}) On the irregular cylinder meshes the paper shell's error falls to {:.2e} and \
                 its last refinement has order {:.2}; the same meshes with {} converge with order \
                 {:.2} (fit {:.2}) to {:.2e}. The director bending is consistent; what remains for \
                 the paper shell is the linear membrane's locking on irregular meshes (the mesh \
                 cannot bend isometrically, and a 0.1 mm membrane is 10⁴× stiffer than it bends), \
                 which only finer meshes or thicker shells leave behind. The mid-edge average \
                 ends at {:.2e} (paper) and {:.2e} ({}): its floor is its inconsistency.",
                sff_name(f),
                thin.points.last().map_or(f64::NAN, |p| p.1),
                last(thin),
                thick
                    .name
                    .trim_start_matches("cylinder, irregular meshes, "),
                last(thick),
                thick.orders().0.unwrap_or(f64::NAN),
                thick.points.last().map_or(f64::NAN, |p| p.1),
                final_error(series_of(
                    SffKind::MidEdgeAverage,
                    "cylinder, irregular meshes"
                )),
                final_error(series_of(SffKind::MidEdgeAverage, &thick.name)),
                thick
                    .name
                    .trim_start_matches("cylinder, irregular meshes, "),
            );
        }
    }
    let _ = writeln!(
        md,
        "\nWall time of all runs of a case (s; every knob, every level), per form:\n"
    );
    let _ = writeln!(md, "| case | {} |", names.join(" | "));
    let _ = writeln!(md, "|---|{}", "---:|".repeat(names.len()));
    for name in CASE_NAMES {
        let cells: Vec<String> = FORMULATIONS
            .iter()
            .map(|&f| {
                cases
                    .iter()
                    .find(|c| c.sff == f && c.name == *name)
                    .map_or("—".into(), |c| {
                        format!("{:.2}", c.runs.iter().map(|r| r.wall_s).sum::<f64>())
                    })
            })
            .collect();
        let _ = writeln!(md, "| {name} | {} |", cells.join(" | "));
    }
    let _ = writeln!(
        md,
        "\n(— in the dynamic case: its reference is a very-small-Δt explicit run, and explicit \
         Euler with a director form relaxes the massless angles every step (5–6× the average's \
         step cost, `cargo bench -p thinshell-solver --bench explicit_step`), so it compares time \
         steps for the average only. \
         The directors' strips stop at 1 600 faces to keep the study under 10 minutes.)"
    );
}

/// One generated paragraph: which bending form to use, from the refinement series of every form.
fn bending_form_advice(md: &mut String, cases: &[Case]) {
    // The default form when it is a director form, else the first director form studied.
    let Some(director) = Some(SffKind::default())
        .filter(|f| f.director().is_some() && FORMULATIONS.contains(f))
        .or_else(|| {
            FORMULATIONS
                .iter()
                .copied()
                .find(|f| f.director().is_some())
        })
    else {
        return;
    };
    let (mut series, mut beaten_at_coarsest, mut ratio_sum) = (0, 0, 0.0);
    for base in cases
        .iter()
        .filter(|c| c.sff == SffKind::MidEdgeAverage)
        .flat_map(|c| c.refinement.iter())
    {
        let other = cases
            .iter()
            .filter(|c| c.sff == director)
            .flat_map(|c| c.refinement.iter())
            .find(|s| s.name == base.name);
        let (Some(&(_, avg)), Some(other)) = (base.points.last(), other) else {
            continue;
        };
        let Some(&(_, dir_finest)) = other.points.last() else {
            continue;
        };
        series += 1;
        ratio_sum += (avg / dir_finest).log10();
        if other.points.first().is_some_and(|p| p.1 <= avg) {
            beaten_at_coarsest += 1;
        }
    }
    if series == 0 {
        return;
    }
    let _ = writeln!(
        md,
        "**Bending form**: for accuracy, use an edge-director form, here `{}` (a scene without \
         `[bending]` gets the default, `{}`). In {beaten_at_coarsest} \
         of {series} refinement series its *coarsest* mesh is already at least as accurate as the \
         mid-edge average's *finest*, and at the finest level its error is on average {:.0}× \
         smaller (geometric mean), for about 3× the cost per Newton iteration on the same mesh. \
         (On the regular meshes of these series — the cylinder's and the strips' — the curvature \
         runs along the grid lines; the next paragraph varies the mesh layout and the direction \
         of the curvature.)\n",
        sff_name(director),
        sff_name(SffKind::default()),
        10f64.powf(ratio_sum / series as f64)
    );
}

/// Error at the finest level of a series (NaN if absent).
fn final_error(s: Option<&Refinement>) -> f64 {
    s.and_then(|s| s.points.last()).map_or(f64::NAN, |p| p.1)
}

/// Runs the study and writes `accuracy.md`, the plots and the JSON.
pub fn run(opts: &Options) -> Result<()> {
    let t0 = Instant::now();
    let mut cases = Vec::new();
    for &sff in FORMULATIONS {
        let name = sff_name(sff);
        let mut add = |c: Result<Case>, what: &str| -> Result<()> {
            let c = c.with_context(|| format!("{what} ({name})"))?;
            println!(
                "{:<34} {:<16} {:>4} runs, {:>7.1} s so far",
                c.name,
                name,
                c.runs.len(),
                t0.elapsed().as_secs_f64()
            );
            cases.push(c);
            Ok(())
        };
        let want = |n: &str| opts.only.as_ref().is_none_or(|o| n.contains(o.as_str()));
        for case in SquareCase::ALL {
            if want(case.name()) {
                add(square(case, sff, opts.quick), case.name())?;
            }
        }
        if want(CASE_NAMES[3]) {
            add(cylinder_refinement(sff, opts.quick), CASE_NAMES[3])?;
        }
        if want(CASE_NAMES[4]) {
            add(cap_refinement(sff, opts.quick), CASE_NAMES[4])?;
        }
        if want(CASE_NAMES[5]) {
            add(strip(false, sff, opts.quick), CASE_NAMES[5])?;
        }
        if want(CASE_NAMES[6]) {
            add(strip(true, sff, opts.quick), CASE_NAMES[6])?;
        }
        // The dynamic case's reference and its explicit runs need explicit Euler, whose
        // director steps relax the angles (5–6× the cost): it compares time steps for the
        // average only, to keep the study short.
        if want(CASE_NAMES[7]) && sff.director().is_none() {
            add(cantilever(sff, opts.quick), CASE_NAMES[7])?;
        }
    }
    cases.iter_mut().for_each(summarise_knobs);
    let layouts = if opts
        .only
        .as_ref()
        .is_none_or(|o| LAYOUT_STUDY.contains(o.as_str()))
    {
        Some(layout::run(opts.quick).context("mesh layout study")?)
    } else {
        None
    };
    let total_s = t0.elapsed().as_secs_f64();

    let plot_dir = opts.docs_dir.join("accuracy");
    std::fs::create_dir_all(&plot_dir)
        .with_context(|| format!("creating {}", plot_dir.display()))?;
    let mut plots = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        plots.push((i, plot_case(c, &plot_dir)?));
    }
    let conv = plot_refinement(&cases, &plot_dir)?;
    let layout_plot = match &layouts {
        Some(study) => Some(layout::plot(study, &plot_dir)?),
        None => None,
    };
    let md_path = opts.docs_dir.join("accuracy.md");
    std::fs::write(
        &md_path,
        markdown(
            &cases,
            opts.quick,
            total_s,
            &plots,
            &conv,
            layouts.as_ref().zip(layout_plot.as_deref()),
        ),
    )
    .with_context(|| format!("writing {}", md_path.display()))?;
    println!("wrote {} and {}/", md_path.display(), plot_dir.display());

    let (nproc, cpu) = machine();
    let doc = json!({
        "quick": opts.quick,
        "nproc": nproc,
        "cpu": cpu,
        "total_wall_s": total_s,
        "cases": cases.iter().map(case_json).collect::<Vec<_>>(),
        "layout_study": layouts.as_ref().map(layout::json),
    });
    if let Some(dir) = opts.json_path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(&opts.json_path, serde_json::to_string_pretty(&doc)?)
        .with_context(|| format!("writing {}", opts.json_path.display()))?;
    println!("wrote {} ({total_s:.1} s)", opts.json_path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick study runs end to end into a temporary directory and its JSON has every case,
    /// for every formulation, with finite errors and times.
    #[test]
    fn quick_study_covers_every_case() -> Result<()> {
        let dir = std::env::temp_dir().join(format!("thinshell-accuracy-{}", std::process::id()));
        let opts = Options {
            quick: true,
            docs_dir: dir.join("docs"),
            json_path: dir.join("accuracy.json"),
            only: None,
        };
        run(&opts)?;
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&opts.json_path)?)?;
        let cases = doc["cases"].as_array().ok_or_else(|| anyhow!("no cases"))?;
        for sff in FORMULATIONS {
            for name in CASE_NAMES {
                if *name == CASE_NAMES[7] && sff.director().is_some() {
                    continue;
                }
                let c = cases
                    .iter()
                    .find(|c| c["case"] == *name && c["formulation"] == sff_name(*sff))
                    .ok_or_else(|| anyhow!("missing case {name}"))?;
                let runs = c["runs"].as_array().ok_or_else(|| anyhow!("no runs"))?;
                assert!(!runs.is_empty(), "{name}: no runs");
                for r in runs {
                    let e = r["error"].as_f64().unwrap_or(f64::NAN);
                    let w = r["wall_s"].as_f64().unwrap_or(f64::NAN);
                    assert!(e.is_finite() && e >= 0.0, "{name}: error {e}");
                    assert!(w.is_finite() && w >= 0.0, "{name}: wall {w}");
                }
            }
        }
        // The mesh layout study: every layout × angle × form, finite numbers.
        let layouts = doc["layout_study"]["series"]
            .as_array()
            .ok_or_else(|| anyhow!("no layout study"))?;
        assert_eq!(
            layouts.len(),
            layout::Layout::ALL.len() * layout::ANGLES_DEG.len() * FORMULATIONS.len()
        );
        for s in layouts {
            for key in ["energy", "shape"] {
                let points = s[key].as_array().ok_or_else(|| anyhow!("no {key}"))?;
                assert!(points.len() >= 2, "{key}: {} levels", points.len());
                for p in points {
                    let e = p["relative_error"]
                        .as_f64()
                        .or_else(|| p["error_m"].as_f64())
                        .unwrap_or(f64::NAN);
                    assert!(e.is_finite(), "{key}: error {e}");
                }
            }
        }
        assert!(opts.docs_dir.join("accuracy.md").is_file());
        assert!(
            opts.docs_dir
                .join("accuracy")
                .join("convergence.png")
                .is_file()
        );
        std::fs::remove_dir_all(&dir)?;
        Ok(())
    }
}
