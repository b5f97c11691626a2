//! `cargo xtask hard-cases`: the heavy variants of the hard-case tests
//! (crates/solver/tests/hard_cases.rs; outcomes in docs/robustness.md).
//!
//! 1. The seed's square and sphere scenes (data/scenes) through the scene pipeline at Δt = 1e-3
//!    and 1e-2 s for 0.1 s of simulated time, as the scene files say (no line search) and with
//!    line search plus `adaptive_dt` (Gauss–Newton retry, then Δt halving).
//! 2. A 10⁴-step damped run of a hanging 8 × 8 flag: the total energy must never rise.
//! 3. Strong uniform growth (ā = 0.25 a⁰ and 4 a⁰) on a level-3 icosphere at Δt = 1e-2 s.
//! 4. The swelling strip whose static Newton crawled, at 4 to 32 cells across, with the default
//!    (adaptive) Newton, and for comparison the exact Hessian (`HessianPolicy::Fixed`), a
//!    smaller first regularisation shift, and the Gauss–Newton fallback.
//! 5. The conformal cones (c = −0.3, −0.5; h = 10⁻², 10⁻³; 16 × 64 annulus from flat,
//!    `thinshell_testkit::fixtures::conformal_cone`): the default static step, the same without its
//!    rest-state continuation, and `HessianPolicy::AdaptivePsd` without it; each against the round
//!    cone's equilibrium energy and the half-angle 1 + c.
//! 6. Just past a critical load at 20 000 faces: the pinned–pinned strut
//!    (1 m × 5 cm × 2 mm, 1000 × 10), the simply supported square plate (0.2 m, 2 mm,
//!    100 × 100) and the plane-strain tube under external pressure (R = 0.1 m, h = 1 mm,
//!    1000 × 10) of `crates/solver/tests/critical_loads.rs` at 1.05 of the analytic critical
//!    load, an imperfection of 10⁻⁶ of the load, one default static step from the unbuckled
//!    start: iterations, wall time, stability, largest displacement (`CRITICAL_SCALE=k` divides
//!    the cells per side by k).
//! 7. `moisture_curl.toml` refined to 4× and 16× the shipped faces: every step converges.
//!
//! `--quick` skips the 10⁴-step run, the cones, the critical loads and the refined scene.
//!
//! The solver-level parts (2–4) use the library's default bending form unless `--form` names
//! another; every case of parts 1, 3 and 4 also runs with `HessianPolicy::AdaptivePsd` (scene
//! key `hessian = "adaptive_psd"`), the policy without the indefinite-Hessian handling, for a
//! before/after in one run (docs/robustness.md, "Indefinite Hessians near critical points").
//! `--only PART` runs the parts whose name contains PART (scenes, flag, growth, strip, cone,
//! critical, refined);
//! `VERBOSE=1` prints every Newton iteration of the strip.
//!
//! Every run checks that positions stay finite, and the solver-level runs that the potential
//! never rises within a Newton solve. Failures of a run are outcomes (reported, with the error);
//! a broken contract makes the task fail. Writes `target/xtask/hard-cases.json`.

use std::time::Instant;

use anyhow::{Context, Result, bail};
use nalgebra::Vector3;
use serde_json::{Value, json};
use thinshell::scene::Scene;
use thinshell::sim::{Simulation, SimulationBuilder};
use thinshell_energy::{HessianMode, Material, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::{FaceStimulus, Prescribed, Swelling};
use thinshell_mesh::{VertexId, generators};
use thinshell_solver::{
    HessianPolicy, ImplicitEuler, Integrator, NewtonReport, NewtonSettings, SolverError, State,
    Static,
};
use thinshell_system::{Boundary, Loads, ShellSystem};

/// Options of `cargo xtask hard-cases`.
#[derive(Clone, Debug)]
pub struct Options {
    /// Skip the 10⁴-step run.
    pub quick: bool,
    /// Run only the parts whose name contains this (`scenes`, `flag`, `growth`, `strip`).
    pub only: Option<String>,
    /// Bending form of the solver-level parts (the scene files name their own).
    pub form: SffKind,
}

/// The Newton policies each solver-level case runs with: the default, and
/// `HessianPolicy::AdaptivePsd` (the "before" column of docs/robustness.md).
const POLICIES: [(HessianPolicy, &str); 2] = [
    (HessianPolicy::Adaptive, "default"),
    (HessianPolicy::AdaptivePsd, "adaptive_psd (before #26)"),
];

const SCENES: [&str; 5] = [
    "square_enlarged.toml",
    "square_rhombus.toml",
    "square_cylinder.toml",
    "sphere_uniform_heat.toml",
    "sphere_directed_heat.toml",
];

/// Errors unless the potential obeyed the line search's contract
/// ([`NewtonReport::descent_violation`]) and every recorded number is finite.
fn check_newton(r: &NewtonReport, what: &str) -> Result<()> {
    if !r.values.iter().chain(&r.residuals).all(|v| v.is_finite()) {
        bail!("{what}: non-finite value or residual in a Newton report");
    }
    if let Some(i) = r.descent_violation(NewtonSettings::default().watchdog) {
        bail!(
            "{what}: potential rose within a Newton solve and did not recover (iterate {i}): {:?}",
            r.values
        );
    }
    Ok(())
}

fn finite(x: &[Vector3<f64>]) -> bool {
    x.iter().all(|p| p.iter().all(|c| c.is_finite()))
}

/// The last residuals of a failed Newton solve (to tell a crawl from a round-off plateau).
fn residual_tail(e: &SolverError) -> String {
    match e {
        SolverError::NewtonDidNotConverge { residuals, .. }
        | SolverError::LineSearchFailed { residuals, .. } => {
            let tail = &residuals[residuals.len().saturating_sub(5)..];
            let t: Vec<String> = tail.iter().map(|r| format!("{r:.2e}")).collect();
            format!(" (last residuals {})", t.join(" "))
        }
        _ => String::new(),
    }
}

/// [`residual_tail`] of a failed simulation step's Newton solve.
fn step_residual_tail(e: &thinshell::StepError) -> String {
    match &e.source {
        thinshell::StepFailure::Solver(s) => residual_tail(s),
        _ => String::new(),
    }
}

/// One row of the report, printed and kept for the JSON file.
fn row(rows: &mut Vec<Value>, case: String, outcome: &str, detail: Value) {
    println!("{case:<62} {outcome}");
    rows.push(json!({ "case": case, "outcome": outcome, "detail": detail }));
}

/// With `VERBOSE` set, `st` prints every Newton iteration (which Hessian each used).
fn verbose(st: &mut Static) {
    if std::env::var("VERBOSE").is_ok() {
        st.cache.set_progress(Some(std::sync::Arc::new(
            |p: &thinshell_solver::NewtonProgress| {
                println!(
                    "  it {:3} {:?} residual {:.3e} step {:.3e} at {:.1} s",
                    p.iteration,
                    p.hessian,
                    p.residual,
                    p.step_length,
                    p.elapsed.as_secs_f64()
                );
            },
        )));
    }
}

/// Part 1: the seed scenes at large time steps.
fn scenes(rows: &mut Vec<Value>) -> Result<()> {
    let dir = crate::common::workspace_root().join("data").join("scenes");
    for file in SCENES {
        for dt in [1e-3, 1e-2] {
            let steps = (0.1f64 / dt).round() as usize;
            for (robust, policy) in [
                (false, "adaptive"),
                (false, "adaptive_psd"),
                (true, "adaptive"),
            ] {
                let mut set = vec![
                    format!("integrator.newton.hessian={policy}"),
                    format!("integrator.dt={dt:e}"),
                    format!("integrator.steps={steps}"),
                ];
                if robust {
                    set.push("integrator.newton.line_search=true".into());
                    set.push("integrator.adaptive_dt=true".into());
                }
                let path = dir.join(file);
                let scene = Scene::load_with_overrides(&path, &set)
                    .with_context(|| format!("loading {}", path.display()))?;
                let mut sim = Simulation::build(&scene)
                    .with_context(|| format!("setting up {}", path.display()))?;
                let t0 = Instant::now();
                let (mut its, mut regs, mut failure) = (0, 0, None);
                while sim.steps_done() < steps {
                    match sim.step() {
                        Ok(r) => {
                            its += r.newton_iterations;
                            regs += r.regularizations;
                        }
                        Err(e) => {
                            failure = Some(e.to_string());
                            break;
                        }
                    }
                    if !finite(sim.positions()) {
                        bail!(
                            "{file}: non-finite positions after step {}",
                            sim.steps_done()
                        );
                    }
                }
                // A failed step keeps the last good state: it must be finite too.
                if !finite(sim.positions()) {
                    bail!("{file}: non-finite last good state");
                }
                let variant = match (robust, policy) {
                    (true, _) => "line search + adaptive_dt".to_string(),
                    (false, "adaptive") => "as in the file".to_string(),
                    (false, p) => format!("as in the file, hessian = {p} (before #26)"),
                };
                let case = format!("{file}, dt = {dt:e} s, {variant}");
                let outcome = match &failure {
                    None => format!(
                        "{steps} steps, {its} Newton iterations, {regs} regularised factorisations, \
                         E = {:.3e} J",
                        sim.energy().stretch + sim.energy().bend
                    ),
                    Some(e) => format!("failed after {} steps: {e}", sim.steps_done()),
                };
                let detail = json!({
                    "steps_done": sim.steps_done(), "steps": steps, "newton_iterations": its,
                    "regularizations": regs, "failure": failure,
                    "wall_s": t0.elapsed().as_secs_f64(),
                });
                row(rows, case, &outcome, detail);
            }
        }
    }
    Ok(())
}

fn model(material: Material, damping: bool, sff: SffKind) -> ShellModel {
    ShellModel {
        material,
        terms: Terms {
            stretch: true,
            bend: true,
            damping,
        },
        sff,
    }
}

/// Part 2: a 0.2 m paper flag (8 × 8 cells) pinned along x = 0 under gravity, η/E = 1 ms,
/// 10⁴ steps of 1 ms; the total energy (elastic + kinetic + gravity) is checked every step.
fn long_run(rows: &mut Vec<Value>, form: SffKind) -> Result<()> {
    let n = 8;
    let mesh = generators::rectangle(0.2, 0.2, n, n)?;
    let x0 = mesh.positions().to_vec();
    let rest = RestState::from_mesh(&mesh, &x0, form)?;
    let material = Material {
        viscosity: 2e9 * 1e-3,
        ..Material::paper()
    };
    let boundary = Boundary {
        pinned_vertices: (0..=n).map(|j| VertexId::new(j * (n + 1))).collect(),
        ..Default::default()
    };
    let loads = Loads {
        gravity: Vector3::new(0.0, 0.0, -9.81),
        ..Default::default()
    };
    let mut sys = ShellSystem::new(
        mesh.clone(),
        model(material, true, form),
        rest.clone(),
        boundary,
        loads,
    )?;
    // Energies without damping (it needs a previous state): a second system for evaluation.
    let mut probe = ShellSystem::new(
        mesh,
        model(material, false, form),
        rest,
        Boundary::default(),
        Loads::default(),
    )?;
    let weight = sys.mass().iter().sum::<f64>() * 9.81;
    // The solver's scale-free convergence test (Newton correction below 1e-9 of the size).
    let mut ie = ImplicitEuler::new(1e-3);
    let mut state = State::at_rest(x0);
    let mut energy = |sys: &ShellSystem, s: &State| -> Result<f64> {
        let kinetic: f64 = sys
            .mass()
            .iter()
            .zip(&s.v)
            .map(|(m, v)| 0.5 * m * v.norm_squared())
            .sum();
        let gravity: f64 =
            s.x.iter()
                .flat_map(|p| p.iter())
                .zip(sys.external_forces())
                .map(|(x, f)| -x * f)
                .sum();
        Ok(probe.energy(&s.x)?.total() + kinetic + gravity)
    };
    let e0 = energy(&sys, &state)?;
    let (mut last, mut its, mut max_rise) = (e0, 0, 0.0f64);
    let t0 = Instant::now();
    let steps = 10_000;
    for step in 0..steps {
        let r = ie
            .step(&mut sys, &mut state)
            .with_context(|| format!("flag, step {step}"))?;
        if let Some(n) = &r.newton {
            check_newton(n, "flag")?;
            its += n.iterations;
        }
        if !finite(&state.x) {
            bail!("flag: non-finite positions at step {step}");
        }
        let e = energy(&sys, &state)?;
        max_rise = max_rise.max(e - last);
        last = e;
    }
    // Round-off of the energy sum: ~1e-12 of the weight × size.
    if max_rise > 1e-9 * weight * 0.2 {
        bail!("flag: total energy rose by {max_rise:e} J in one step");
    }
    let outcome = format!(
        "{steps} steps, {its} Newton iterations, energy {e0:.3e} -> {last:.3e} J, largest \
         one-step rise {max_rise:.1e} J"
    );
    let detail = json!({
        "steps": steps, "newton_iterations": its, "energy_start": e0, "energy_end": last,
        "max_rise": max_rise, "wall_s": t0.elapsed().as_secs_f64(),
    });
    row(
        rows,
        "damped flag 8 x 8, dt = 1e-3 s".into(),
        &outcome,
        detail,
    );
    Ok(())
}

/// Runs `steps` implicit steps; returns (steps done, Newton iterations, fallback steps,
/// halvings, failure).
fn run_implicit(
    ie: &mut ImplicitEuler,
    sys: &mut ShellSystem,
    state: &mut State,
    steps: usize,
    what: &str,
) -> Result<(usize, usize, usize, usize, Option<SolverError>)> {
    let own = ie.newton.own_hessian;
    let (mut its, mut fb, mut halvings) = (0, 0, 0);
    for step in 0..steps {
        match ie.step(sys, state) {
            Ok(r) => {
                if let Some(n) = &r.newton {
                    check_newton(n, what)?;
                    its += n.iterations;
                }
                fb += usize::from(r.hessian != own);
                halvings += r.halvings;
                if !finite(&state.x) {
                    bail!("{what}: non-finite positions");
                }
            }
            Err(e) => return Ok((step, its, fb, halvings, Some(e))),
        }
    }
    Ok((steps, its, fb, halvings, None))
}

/// Part 3: uniform growth ā = k a⁰ (b̄ = b⁰) on a level-3 icosphere (642 vertices).
fn growth(rows: &mut Vec<Value>, form: SffKind) -> Result<()> {
    for k in [0.25, 4.0] {
        for (robust, (policy, pname)) in [
            (false, POLICIES[0]),
            (false, POLICIES[1]),
            (true, POLICIES[0]),
        ] {
            let mesh = generators::icosphere(1.0, 3)?;
            let x0 = mesh.positions().to_vec();
            let mut rest = RestState::from_mesh(&mesh, &x0, form)?;
            rest.a_bar.iter_mut().for_each(|a| *a *= k);
            let material = Material {
                viscosity: 2e9 * 1e-3,
                ..Material::paper()
            };
            let mut sys = ShellSystem::new(
                mesh,
                model(material, true, form),
                rest,
                Boundary::default(),
                Loads::default(),
            )?;
            let mut ie = ImplicitEuler::new(1e-2);
            ie.newton.hessian = policy;
            if robust {
                ie.newton.fallback_hessian = Some(HessianMode::GaussNewton);
                ie.max_halvings = 8;
            }
            let mut state = State::at_rest(x0);
            let t0 = Instant::now();
            let what = format!("icosphere level 3, a_bar = {k} a0, dt = 1e-2 s, 20 steps");
            let (done, its, fb, halvings, failure) =
                run_implicit(&mut ie, &mut sys, &mut state, 20, &what)?;
            let variant = if robust {
                format!("with fallbacks, {pname}")
            } else {
                format!("plain, {pname}")
            };
            let outcome = match &failure {
                None => format!(
                    "{done} steps, {its} Newton iterations, {fb} Gauss-Newton steps, {halvings} \
                     halvings"
                ),
                Some(e) => format!("failed at step {}: {e}{}", done + 1, residual_tail(e)),
            };
            let detail = json!({
                "steps_done": done, "newton_iterations": its, "fallback_steps": fb,
                "halvings": halvings, "failure": failure.map(|e| e.to_string()),
                "wall_s": t0.elapsed().as_secs_f64(),
            });
            row(rows, format!("{what}, {variant}"), &outcome, detail);
        }
    }
    Ok(())
}

/// Part 4: the swelling strip (100 × 2 mm, h = 1 mm, `ny` cells across) of
/// crates/growth/tests/coupled.rs, four quasi-static ramp steps.
fn strip(rows: &mut Vec<Value>, form: SffKind) -> Result<()> {
    for ny in [4, 8, 16, 32] {
        for variant in [
            "default (adaptive)",
            "adaptive_psd (before #26)",
            "exact",
            "exact, first shift 1e-9",
            "Gauss-Newton fallback",
        ] {
            let mesh = generators::rectangle(0.1, 0.002, 50, ny)?;
            let x0 = mesh.positions().to_vec();
            let material = Material {
                thickness: 1e-3,
                ..Material::paper()
            };
            // A simulation's step k solves against the stimulus at t = k − 1 (then advances
            // it): (k/4 of the full swelling at step k).
            let ramp = Prescribed::function(
                &mesh,
                &x0,
                Box::new(|t, _| FaceStimulus {
                    top: ((t + 1.0) / 4.0).min(1.0),
                    bottom: 0.0,
                }),
            )?;
            let swelling = Box::new(Swelling::linear(0.01));
            // The run loop's static solver (the scenes' settings: its failures are continued
            // by `Simulation::step` from the previous step's rest forms).
            let mut st = thinshell::scene::integrator::run_loop_static();
            match variant {
                "default (adaptive)" => {}
                "adaptive_psd (before #26)" => st.newton.hessian = HessianPolicy::AdaptivePsd,
                // The exact variants document the former default: no watchdog either.
                "exact" => {
                    st.newton.hessian = HessianPolicy::Fixed;
                    st.newton.watchdog = 0;
                }
                "exact, first shift 1e-9" => {
                    st.newton.hessian = HessianPolicy::Fixed;
                    st.newton.watchdog = 0;
                    st.newton.regularization = Some(thinshell_solver::RegularizationParams {
                        initial: 1e-9,
                        ..Default::default()
                    });
                }
                _ => {
                    st.newton.hessian = HessianPolicy::Fixed;
                    st.newton.watchdog = 0;
                    st.newton.fallback_hessian = Some(HessianMode::GaussNewton);
                }
            }
            verbose(&mut st);
            let mut sim = SimulationBuilder::new(mesh, model(material, false, form))
                .name("swelling strip")
                .growth(swelling, Box::new(ramp), None)
                .integrator(st, 1.0)
                .steps(4)
                .build()?;
            let mut its = Vec::new();
            let mut failure = None;
            let t0 = Instant::now();
            for _ in 1..=4 {
                match sim.step() {
                    Ok(r) => {
                        if !(r.energy.total().is_finite() && r.residual.is_finite()) {
                            bail!("strip: non-finite energy or residual in step {}", r.step);
                        }
                        its.push(r.newton_iterations);
                    }
                    Err(e) => {
                        failure = Some(e);
                        break;
                    }
                }
            }
            // Cells of 2 mm × 2/ny mm: triangles of aspect about ny.
            let case = format!("swelling strip, {ny} cells across, {variant}");
            let outcome = match &failure {
                None => format!("4 steps, Newton iterations {its:?}"),
                Some(e) => format!("iterations {its:?}, then: {e}{}", step_residual_tail(e)),
            };
            let detail = json!({
                "newton_iterations": its, "failure": failure.map(|e| e.to_string()),
                "wall_s": t0.elapsed().as_secs_f64(),
            });
            row(rows, case, &outcome, detail);
        }
    }
    Ok(())
}

/// Part 5: the conformal cones from flat (module docs).
fn cones(rows: &mut Vec<Value>, form: SffKind) -> Result<()> {
    use thinshell_testkit::fixtures::conformal_cone;
    for c in [-0.3, -0.5] {
        for h in [1e-2, 1e-3] {
            let mut round = conformal_cone(c, h, 16, 64, form);
            let mut at_round = State::at_rest(round.round_cone());
            let e_round = Static::default()
                .step(&mut round.system, &mut at_round)?
                .energies
                .total();
            for variant in [
                "default",
                "no continuation",
                "adaptive_psd (before #26), no continuation",
            ] {
                let mut cone = conformal_cone(c, h, 16, 64, form);
                let mut st = Static {
                    continuation: variant == "default",
                    ..Static::default()
                };
                if variant.starts_with("adaptive_psd") {
                    st.newton.hessian = HessianPolicy::AdaptivePsd;
                }
                let mut state = State::at_rest(cone.start.clone());
                let t0 = Instant::now();
                let result = st.step(&mut cone.system, &mut state);
                let wall = t0.elapsed().as_secs_f64();
                let case = format!("conformal cone c = {c}, h = {h}, 16x64, {variant}");
                let (outcome, detail) = match result {
                    Ok(r) => {
                        let n = r
                            .newton
                            .as_ref()
                            .context("a static step has a Newton report")?;
                        check_newton(n, "cone")?;
                        let e = r.energies.total();
                        let sin_error = cone.sin_error(&state.x);
                        (
                            format!(
                                "{} iterations ({} continuation stages{}), stable {:?}, \
                                 E/E_round - 1 = {:+.2e}, sin error {:.2} %, {wall:.1} s",
                                n.iterations,
                                r.continuation_stages,
                                if r.continuation_checked {
                                    ", checked"
                                } else {
                                    ""
                                },
                                r.stable,
                                e / e_round - 1.0,
                                100.0 * sin_error
                            ),
                            json!({
                                "newton_iterations": n.iterations,
                                "continuation_stages": r.continuation_stages,
                                "continuation_checked": r.continuation_checked,
                                "stable": r.stable, "energy": e, "round_cone_energy": e_round,
                                "sin_error": sin_error, "wall_s": wall,
                            }),
                        )
                    }
                    Err(e) => (
                        format!("fails after {wall:.1} s: {e}{}", residual_tail(&e)),
                        json!({ "failure": e.to_string(), "wall_s": wall }),
                    ),
                };
                row(rows, case, &outcome, detail);
            }
        }
    }
    Ok(())
}

/// Part 6: just past a critical load at 20 000 faces (module docs). The default form: the
/// fixtures'.
fn past_critical(rows: &mut Vec<Value>) -> Result<()> {
    use std::f64::consts::PI;
    use thinshell_testkit::fixtures::{compressed_plate, pressurised_tube};
    let (h, young): (f64, f64) = (0.002, 1e9);
    // CRITICAL_SCALE=k divides the cells per side by k (a quicker look at the same cases).
    let k: usize = std::env::var("CRITICAL_SCALE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let strut_ei = young * 0.05 * h.powi(3) / 12.0;
    let plate_d = young * h.powi(3) / (12.0 * (1.0 - 0.3f64.powi(2)));
    // The tube of `critical_loads.rs` (R = 0.1 m, h = 1 mm, ν = 0, plane strain), 1000 × 10.
    let tube_d = young * 1e-3f64.powi(3) / 12.0;
    type Build = Box<dyn Fn(usize) -> (ShellSystem, Vec<Vector3<f64>>)>;
    let cases: [(&str, Build); 3] = [
        (
            "pinned-pinned strut",
            Box::new(move |k| {
                let p = 1.05 * PI * PI * strut_ei;
                compressed_plate(
                    1.0,
                    0.05,
                    1000 / k,
                    (10 / k).max(1),
                    h,
                    young,
                    0.0,
                    false,
                    p,
                    1e-6 * p,
                )
            }),
        ),
        (
            "simply supported plate",
            Box::new(move |k| {
                let p = 1.05 * 4.0 * PI * PI * plate_d / 0.2;
                compressed_plate(0.2, 0.2, 100 / k, 100 / k, h, young, 0.3, true, p, 1e-6 * p)
            }),
        ),
        (
            "tube under external pressure",
            Box::new(move |k| {
                let p = 1.05 * 3.0 * tube_d / 0.1f64.powi(3);
                // The imperfection: 1e-6 of the pressure's force on one cell.
                let cell = 2.0 * PI * 0.1 / 1000.0 * k as f64;
                let n_around = (1000 / k) / 4 * 4;
                pressurised_tube(
                    0.1,
                    n_around,
                    (10 / k).max(1),
                    1e-3,
                    young,
                    0.0,
                    p,
                    1e-6 * p * cell * cell,
                )
            }),
        ),
    ];
    for (name, build) in cases {
        let (mut sys, x0) = build(k);
        let faces = sys.mesh().n_faces();
        let mut state = State::at_rest(x0.clone());
        let mut st = Static::default();
        verbose(&mut st);
        let t0 = Instant::now();
        let result = st.step(&mut sys, &mut state);
        let wall = t0.elapsed().as_secs_f64();
        let case =
            format!("{name}, {faces} faces, 1.05 of the critical load, from the unbuckled start");
        let (outcome, detail) = match result {
            Ok(r) => {
                let n = r
                    .newton
                    .as_ref()
                    .context("a static step has a Newton report")?;
                check_newton(n, "past critical")?;
                let w = state
                    .x
                    .iter()
                    .zip(&x0)
                    .fold(0.0f64, |m, (x, x0)| m.max((x - x0).norm()));
                (
                    format!(
                        "{} iterations{}, stable {:?}, largest displacement {w:.3e} m, {wall:.1} s",
                        n.iterations,
                        if r.continuation_checked {
                            " (checked by continuation)"
                        } else {
                            ""
                        },
                        r.stable
                    ),
                    json!({
                        "newton_iterations": n.iterations, "stable": r.stable,
                        "continuation_checked": r.continuation_checked,
                        "continuation_stages": r.continuation_stages,
                        "extrapolated_steps": n.extrapolated_steps,
                        "displacement": w, "wall_s": wall, "faces": faces,
                    }),
                )
            }
            Err(e) => (
                format!("fails after {wall:.1} s: {e}{}", residual_tail(&e)),
                json!({ "failure": e.to_string(), "wall_s": wall, "faces": faces }),
            ),
        };
        row(rows, case, &outcome, detail);
    }
    Ok(())
}

/// Part 7: `moisture_curl.toml` refined to 4× and 16× the shipped faces (100×8 and 200×16
/// cells) with the scene's defaults otherwise: every step converges.
fn refined_scene(rows: &mut Vec<Value>) -> Result<()> {
    let path = crate::common::workspace_root()
        .join("data")
        .join("scenes")
        .join("moisture_curl.toml");
    for (factor, nx, ny) in [(4, 100, 8), (16, 200, 16)] {
        let set = [format!("mesh.nx={nx}"), format!("mesh.ny={ny}")];
        let scene = Scene::load_with_overrides(&path, &set)
            .with_context(|| format!("loading {}", path.display()))?;
        let mut sim =
            Simulation::build(&scene).with_context(|| format!("setting up {}", path.display()))?;
        let steps = scene.file.integrator.steps.unwrap_or(1);
        let t0 = Instant::now();
        let (mut its, mut worst, mut failure) = (0, 0, None);
        while sim.steps_done() < steps {
            match sim.step() {
                Ok(r) => {
                    its += r.newton_iterations;
                    worst = worst.max(r.newton_iterations);
                }
                Err(e) => {
                    failure = Some(e.to_string());
                    break;
                }
            }
        }
        let wall = t0.elapsed().as_secs_f64();
        let case = format!("moisture_curl.toml at {factor}x the faces ({nx}x{ny} cells)");
        let outcome = match &failure {
            None => format!(
                "{steps} steps, {its} Newton iterations (at most {worst} per step), {wall:.1} s"
            ),
            Some(e) => format!("failed after {} steps: {e}", sim.steps_done()),
        };
        let detail = json!({
            "steps_done": sim.steps_done(), "steps": steps, "newton_iterations": its,
            "max_per_step": worst, "failure": failure, "wall_s": wall,
        });
        row(rows, case, &outcome, detail);
    }
    Ok(())
}

/// Runs the task; `quick` skips the 10⁴-step run, the cones, the refined scene and the
/// critical loads.
pub fn run(opts: &Options) -> Result<()> {
    let out = crate::common::out_dir();
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let mut rows = Vec::new();
    let t0 = Instant::now();
    let wanted = |part: &str| opts.only.as_deref().is_none_or(|o| part.contains(o));
    println!("solver-level parts with the {} form", opts.form.name());
    if wanted("scenes") {
        scenes(&mut rows)?;
    }
    if !opts.quick && wanted("flag") {
        long_run(&mut rows, opts.form)?;
    }
    if wanted("growth") {
        growth(&mut rows, opts.form)?;
    }
    if wanted("strip") {
        strip(&mut rows, opts.form)?;
    }
    if !opts.quick && wanted("cone") {
        cones(&mut rows, opts.form)?;
    }
    if !opts.quick && wanted("refined") {
        refined_scene(&mut rows)?;
    }
    if !opts.quick && wanted("critical") {
        past_critical(&mut rows)?;
    }
    println!("hard cases: {:.1} s", t0.elapsed().as_secs_f64());
    let path = out.join("hard-cases.json");
    crate::common::write_json(&path, &rows)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// The bending form named `name` ([`SffKind::name`]).
pub fn parse_form(name: &str) -> Result<SffKind, String> {
    SffKind::ALL
        .into_iter()
        .find(|k| k.name() == name)
        .ok_or_else(|| {
            let names: Vec<&str> = SffKind::ALL.iter().map(|k| k.name()).collect();
            format!(
                "unknown bending form '{name}' (one of {})",
                names.join(", ")
            )
        })
}
