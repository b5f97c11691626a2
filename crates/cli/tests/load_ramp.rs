//! Static load ramps (`[integrator] load_ramp`, docs/scenes.md): a clamped plate strip under a
//! tip load, against the elastica (the large-deflection cantilever, computed here by shooting
//! on the beam equation, independently of the shell code), a ramp against a one-shot solve, and
//! the `load_factor` column of `steps.csv`.
#![allow(clippy::unwrap_used)]

use std::path::Path;

use thinshell::scene::Scene;
use thinshell::scene::schema::LoadRamp;
use thinshell::sim::{Simulation, StepRecord};
use thinshell_solver::Static;

/// Free length L (m), width b (m), thickness h (m), Young's modulus E (Pa); ν = 0, so the
/// strip's plate stiffness D·b is the beam's E·I = E b h³/12 exactly.
const LENGTH: f64 = 1.0;
const THICKNESS: f64 = 0.01;
const YOUNG: f64 = 1e7;
/// Cells along the free length and across.
const NX: usize = 24;
const NY: usize = 2;

/// Cell length Δx (m): the mesh reaches Δx/2 behind the clamp line, because a clamp holds the
/// first cell flat and acts at Δx/2 (crates/solver/tests/clamps.rs).
fn dx() -> f64 {
    LENGTH / (NX as f64 - 0.5)
}

fn width() -> f64 {
    NY as f64 * dx()
}

fn bending_stiffness() -> f64 {
    YOUNG * width() * THICKNESS.powi(3) / 12.0
}

/// Tip load P (N) for the dimensionless load α = P L² / (E I).
fn tip_load(alpha: f64) -> f64 {
    alpha * bending_stiffness() / (LENGTH * LENGTH)
}

/// A static scene: the strip on x ∈ [−Δx/2, L] clamped along x = −Δx/2, a vertical tip load P
/// spread over the tip vertices (half on the corners), `steps` steps, optional `load_ramp`.
fn scene_text(alpha: f64, steps: usize, ramp: Option<&str>) -> String {
    let p = tip_load(alpha);
    let mut s = format!(
        "effects = [\"stretching\", \"bending\", \"point_loads\"]\n\
         [mesh]\ngenerator = \"rectangle\"\nwidth = {w}\nheight = {b}\nnx = {NX}\nny = {NY}\n\
         [material]\nthickness = {THICKNESS}\nyoung = {YOUNG}\npoisson = 0.0\n\
         [bending]\nform = \"mid_edge_average\"\n\
         [integrator]\nkind = \"static\"\nsteps = {steps}\n",
        w = LENGTH + 0.5 * dx(),
        b = width(),
    );
    if let Some(r) = ramp {
        s += &format!("load_ramp = \"{r}\"\n");
    }
    s += "[[boundary.clamps]]\nregion = { box = { min = [-1.0, -1.0, -1.0], max = [1e-9, 1.0, 1.0] } }\n";
    for j in 0..=NY {
        let weight = if j == 0 || j == NY { 0.5 } else { 1.0 };
        let f = -p * weight / NY as f64;
        s += &format!(
            "[[point_loads]]\nvertex = {}\nforce = [0.0, 0.0, {f:e}]\n",
            j * (NX + 1) + NX
        );
    }
    s
}

fn simulation(text: &str) -> Simulation {
    let scene = Scene::from_toml(text, "load_ramp.toml", Path::new(".")).unwrap();
    Simulation::build(&scene).unwrap()
}

/// Mean tip deflection (m, downwards positive) and mean horizontal tip position (m, from the
/// clamp line).
fn tip(sim: &Simulation) -> (f64, f64) {
    let x = sim.positions();
    let tip: Vec<usize> = (0..=NY).map(|j| j * (NX + 1) + NX).collect();
    let n = tip.len() as f64;
    let w = -tip.iter().map(|&v| x[v].z).sum::<f64>() / n;
    let u = tip.iter().map(|&v| x[v].x).sum::<f64>() / n - 0.5 * dx();
    (w, u)
}

/// The elastica of a cantilever under a dead vertical tip load: E I θ'' = −P cos θ, θ(0) = 0,
/// θ'(L) = 0, by shooting on θ'(0) (bisection, RK4 with 4000 steps). Returns the tip deflection
/// and the horizontal tip position, both divided by L. The bracket [0, α] holds the stable
/// branch only for moderate loads (checked up to α = 20; at α = 100 it finds another root).
fn elastica(alpha: f64) -> (f64, f64) {
    let n = 4000;
    let h = 1.0 / n as f64;
    // State (θ, θ', y, x) in units of L; θ'' = −α cos θ.
    let rhs = |s: [f64; 4]| [s[1], -alpha * s[0].cos(), s[0].sin(), s[0].cos()];
    let shoot = |k0: f64| {
        let mut s = [0.0, k0, 0.0, 0.0];
        for _ in 0..n {
            let add = |a: [f64; 4], b: [f64; 4], c: f64| {
                [
                    a[0] + c * b[0],
                    a[1] + c * b[1],
                    a[2] + c * b[2],
                    a[3] + c * b[3],
                ]
            };
            let k1 = rhs(s);
            let k2 = rhs(add(s, k1, h / 2.0));
            let k3 = rhs(add(s, k2, h / 2.0));
            let k4 = rhs(add(s, k3, h));
            for i in 0..4 {
                s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        s
    };
    // θ'(L) < 0 at θ'(0) = 0 and ≥ 0 at θ'(0) = α (the root moment of the undeformed beam).
    let (mut lo, mut hi) = (0.0, alpha);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if shoot(mid)[1] < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let s = shoot(0.5 * (lo + hi));
    (s[2], s[3])
}

#[test]
fn elastica_reference_matches_small_deflection_beam_theory() {
    // α → 0: δ/L = α/3; the first correction is negative.
    let (w, _) = elastica(1e-4);
    assert!((w / (1e-4 / 3.0) - 1.0).abs() < 1e-6, "{w}");
}

/// Complete elliptic integrals K(p), E(p) of modulus p (composite Simpson, 2000 intervals on
/// smooth integrands: error far below 1e-10 for p ≤ 0.9).
fn elliptic_ke(p: f64) -> (f64, f64) {
    let n = 2000;
    let h = std::f64::consts::FRAC_PI_2 / n as f64;
    let (mut k, mut e) = (0.0, 0.0);
    for i in 0..=n {
        let t = i as f64 * h;
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let s = (1.0 - p * p * t.sin().powi(2)).sqrt();
        k += w / s;
        e += w * s;
    }
    (k * h / 3.0, e * h / 3.0)
}

/// Euler's elastica of a pinned–pinned column with end shortening Δ = `shortening`·L:
/// Δ/L = 2(1 − E(p)/K(p)), midspan deflection w/L = p/K(p), with p = sin(α/2) and α the end
/// slope. Returns (w/L, α).
fn pinned_elastica(shortening: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (0.0, 0.99);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        let (k, e) = elliptic_ke(mid);
        if 2.0 * (1.0 - e / k) < shortening {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let p = 0.5 * (lo + hi);
    let (k, _) = elliptic_ke(p);
    (p / k, 2.0 * p.asin())
}

/// A strip pinned along x = 0 and along x = L, the far end moved by −Δ in x over the steps, a
/// tiny upward force at midspan to choose the buckling direction.
fn buckling_scene(
    nx: usize,
    form: &str,
    shortening: f64,
    steps: usize,
    ramp: Option<&str>,
) -> String {
    let ny = 2;
    let dx = LENGTH / nx as f64;
    let b = ny as f64 * dx;
    let ei = YOUNG * b * THICKNESS.powi(3) / 12.0;
    // 10⁻⁴ of the Euler load π²EI/L² spread over the midspan line.
    let nudge = 1e-4 * std::f64::consts::PI.powi(2) * ei / (LENGTH * LENGTH) / (ny + 1) as f64;
    let mut s = format!(
        "effects = [\"stretching\", \"bending\", \"point_loads\"]\n\
         [mesh]\ngenerator = \"rectangle\"\nwidth = {LENGTH}\nheight = {b}\nnx = {nx}\nny = {ny}\n\
         [material]\nthickness = {THICKNESS}\nyoung = {YOUNG}\npoisson = 0.0\n\
         [bending]\nform = \"{form}\"\n\
         [integrator]\nkind = \"static\"\nsteps = {steps}\n"
    );
    if let Some(r) = ramp {
        s += &format!("load_ramp = \"{r}\"\n");
    }
    s += "[[boundary.pins]]\nregion = { box = { min = [-1.0, -1.0, -1.0], max = [1e-9, 1.0, 1.0] } }\n";
    s += &format!(
        "[[boundary.prescribed]]\nregion = {{ box = {{ min = [{x0}, -1.0, -1.0], max = [2.0, 1.0, 1.0] }} }}\nvelocity = [{v:e}, 0.0, 0.0]\n",
        x0 = LENGTH - 1e-9,
        v = -shortening * LENGTH / steps as f64,
    );
    for j in 0..=ny {
        s += &format!(
            "[[point_loads]]\nvertex = {}\nforce = [0.0, 0.0, {nudge:e}]\n",
            j * (nx + 1) + nx / 2
        );
    }
    s
}

/// Runs every remaining step; returns the step records.
fn run(sim: &mut Simulation) -> Vec<StepRecord> {
    let mut records = Vec::new();
    while sim.steps_done() < sim.steps_total() {
        records.push(sim.step().unwrap());
    }
    records
}

/// Midspan deflection (m) of the buckling strip with `nx` cells.
fn midspan(sim: &Simulation, nx: usize) -> f64 {
    sim.positions()[(nx + 1) + nx / 2].z
}

/// Large end shortening of a pinned–pinned strip (Δ = 0.2 L, far past buckling). Applied at
/// once, the moved end passes 3 cells of the strip: with the mid-edge average the start has
/// inverted faces (the library's one-shot solve fails), with the sin edge directors and fitted
/// free edges the one-shot solve converges to a stable state with the last cell folded back
/// (midspan deflection 0.155 L, checked to be a stable equilibrium below). The default ramp of
/// a static scene (linear over its 10 steps) follows the buckled path to the elastica.
#[test]
fn ramp_reaches_the_elastica_and_a_one_shot_solve_fails_or_agrees() {
    let shortening = 0.2;
    let nx = 16;
    let (exact, _) = pinned_elastica(shortening);
    for form in ["mid_edge_average", "edge_director_sin"] {
        // No `load_ramp` key: a static scene without growth ramps linearly by default.
        let mut sim = simulation(&buckling_scene(nx, form, shortening, 10, None));
        assert_eq!(sim.load_ramp(), LoadRamp::Linear);
        let records = run(&mut sim);
        let factors: Vec<f64> = records.iter().map(|r| r.load_factor).collect();
        let expected: Vec<f64> = (1..=10).map(|k| k as f64 / 10.0).collect();
        assert_eq!(factors, expected);
        // Either buckling direction is an equilibrium of the same shape (the midspan nudge,
        // 10⁻⁴ of the Euler load, does not decide which one Newton finds).
        let w = midspan(&sim, nx).abs() / LENGTH;
        let iterations: Vec<usize> = records.iter().map(|r| r.newton_iterations).collect();
        println!(
            "{form}: ramp midspan w/L {w:.6}, elastica {exact:.6}, rel {:+.2e}, iterations {iterations:?}",
            w / exact - 1.0
        );
        // Measured: +1.8e-3 (mid-edge average and sin) on 16 cells, +2.3e-4 on 32.
        assert!((w / exact - 1.0).abs() < 5e-3, "{form}: {w} vs {exact}");

        // The same end displacement at once, with the library's static solver.
        let mut once = simulation(&buckling_scene(nx, form, shortening, 1, None));
        let mut x = once.positions().to_vec();
        // Prescribed motion at λ = 1 of a one-step scene: time N·Δt = 1 s (x₀ − Δ).
        once.system()
            .boundary()
            .apply_prescribed(&mut x, 1.0)
            .unwrap();
        let mut solver = Static::default();
        solver.newton.max_iterations = 500;
        let mut phi = vec![0.0; once.system().n_edge_angles()];
        match solver.solve_with_angles(once.system_mut(), &mut x, &mut phi) {
            Err(e) => {
                println!("{form}: one-shot solve failed: {e}");
                // The scene runner retries a failed static step by continuation from λ = 0.
                let mut rescued = simulation(&buckling_scene(nx, form, shortening, 1, None));
                let r = run(&mut rescued);
                let w1 = midspan(&rescued, nx).abs() / LENGTH;
                println!(
                    "{form}: one step through the runner: {} iterations, midspan w/L {w1:.6}",
                    r[0].newton_iterations
                );
                assert!((w1 / exact - 1.0).abs() < 5e-3, "{form}: {w1} vs {exact}");
            }
            Ok(r) => {
                let w1 = x[(nx + 1) + nx / 2].z.abs() / LENGTH;
                println!(
                    "{form}: one-shot solve: {} iterations, midspan w/L {w1:.6}",
                    r.iterations
                );
                if (w1 / exact - 1.0).abs() < 5e-3 {
                    continue;
                }
                // Elsewhere, the solve may not claim convergence at a point that is not an
                // equilibrium (before: sin "converged" at w/L 0.0102). With the fitted free
                // edges (model.md §1.2) the sin one-shot solve ends with the last cell folded
                // flat onto its neighbour (a 180° hinge, whose sin moment is bounded: the
                // discrete sin energy has no cost growing with the fold) at w/L 0.155. Measured
                // (2026-12-02): restarted there the solve stops at once (0 iterations),
                // smallest eigenvalue +6.3e-6 (stable), elastic energy 0.1021 J against the
                // ramp's elastica 0.2155 J: a genuine, stable and lower minimum of the
                // discrete sin energy, not a false convergence. Not made by the fit: main
                // (free angles on free edges), restarted from this fold, stays folded too
                // (w/L 0.155, smallest eigenvalue +3.9e-5, 0.1008 J against its elastica's
                // 0.2146 J); its one-shot path merely did not reach it.
                assert_eq!(form, "edge_director_sin", "{form}: {w1} vs {exact}");
                let mut x2 = x.clone();
                let r2 = solver
                    .solve_with_angles(once.system_mut(), &mut x2, &mut phi)
                    .unwrap();
                let moved = x2
                    .iter()
                    .zip(&x)
                    .map(|(a, b)| (a - b).norm())
                    .fold(0.0, f64::max);
                assert!(
                    moved < 1e-9 * LENGTH,
                    "{form}: restarted solve moved {moved} m"
                );
                let stability = solver.stability(once.system_mut(), &x2, &phi).unwrap();
                assert!(stability.stable, "{form}: {}", stability.min_eigenvalue);
                let e_once = once.system_mut().energy_at(&x2, &phi).unwrap();
                let e_ramp = once
                    .system_mut()
                    .energy_at(sim.positions(), sim.edge_angles())
                    .unwrap();
                let (e1, e0) = (e_once.stretch + e_once.bend, e_ramp.stretch + e_ramp.bend);
                println!(
                    "{form}: restarted {} iterations, one-shot {e1:.6e} J, elastica {e0:.6e} J",
                    r2.iterations
                );
                // The fold's energy is below the elastica's (see above): the elastica is not
                // the discrete sin energy's lowest state on 16 cells. Asserted, so that a
                // change of the model that removes the fold shows here.
                assert!(e1 < e0, "{form}: {e1} vs {e0}");
            }
        }
    }
}

/// A moderate tip load (α = P L²/EI = 5, tip deflection 0.71 L): one-shot and a 5-step ramp
/// converge to the same equilibrium, and both to the elastica.
#[test]
fn ramp_and_one_shot_reach_the_same_equilibrium() {
    let alpha = 5.0;
    let (w_exact, u_exact) = elastica(alpha);
    let mut once = simulation(&scene_text(alpha, 1, None));
    let r1 = run(&mut once);
    assert_eq!(r1[0].load_factor, 1.0);
    let mut ramp = simulation(&scene_text(alpha, 5, Some("linear")));
    let records = run(&mut ramp);
    let factors: Vec<f64> = records.iter().map(|r| r.load_factor).collect();
    assert_eq!(factors, [0.2, 0.4, 0.6, 0.8, 1.0]);
    let diff = once
        .positions()
        .iter()
        .zip(ramp.positions())
        .map(|(a, b)| (a - b).norm())
        .fold(0.0f64, f64::max);
    println!("max distance one-shot vs ramp: {diff:e} m");
    assert!(diff < 1e-8 * LENGTH, "{diff}");
    for sim in [&once, &ramp] {
        let (w, u) = tip(sim);
        println!(
            "tip w/L {:.6} (elastica {w_exact:.6}), x/L {:.6} (elastica {u_exact:.6})",
            w / LENGTH,
            u / LENGTH
        );
        // Measured: −2.1e-4 and −5.1e-4 (24 cells).
        assert!((w / LENGTH / w_exact - 1.0).abs() < 2e-3, "{w}");
        assert!((u / LENGTH / u_exact - 1.0).abs() < 5e-3, "{u}");
    }
}

/// `load_ramp = "none"` keeps the full loads on every step; a static growth scene defaults to it.
#[test]
fn ramp_none_and_the_growth_default() {
    let mut sim = simulation(&scene_text(1.0, 3, Some("none")));
    let factors: Vec<f64> = run(&mut sim).iter().map(|r| r.load_factor).collect();
    assert_eq!(factors, [1.0, 1.0, 1.0]);
    let growth = scene_text(1.0, 2, None).replace(
        "\"point_loads\"]",
        "\"point_loads\", \"growth\"]\n[growth]\nmodel = \"isotropic\"\nstimulus = { kind = \"uniform\", value = 0.0 }",
    );
    let sim = simulation(&growth);
    assert_eq!(sim.load_ramp(), LoadRamp::None);
    assert_eq!(sim.load_factor_of_step(1), 1.0);
    let explicit =
        simulation(&growth.replace("steps = 2\n", "steps = 2\nload_ramp = \"linear\"\n"));
    assert_eq!(explicit.load_ramp(), LoadRamp::Linear);
    assert_eq!(explicit.load_factor_of_step(1), 0.5);
}

/// `thinshell run` writes the load factor in the `load_factor` column of `steps.csv`.
#[test]
fn steps_csv_has_the_load_factor_column() {
    let dir = std::env::temp_dir().join(format!("thinshell-load-ramp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("ramp.toml");
    std::fs::write(&scene, scene_text(1.0, 4, None)).unwrap();
    let out = dir.join("out");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_thinshell"))
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&scene)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[..3], ["step", "time_s", "stretch_J"]);
    let column = header.iter().position(|h| *h == "load_factor").unwrap();
    let factors: Vec<f64> = lines
        .map(|l| l.split(',').nth(column).unwrap().parse().unwrap())
        .collect();
    assert_eq!(factors, [0.25, 0.5, 0.75, 1.0]);
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("\"load_factor\": 1.0"), "{summary}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Uniform inflation of a closed sphere of radius R: the stretch λ at pressure p solves
/// (α + β)[2hλ(λ² − 1) + h³(λ − 1)/(3R²)] = pRλ² (stretching ‖(λ² − 1)I‖²_SV, bending
/// ‖(λ − 1)I/R‖²_SV, pressure work p·V₀λ³; Newton on the scalar equation).
fn inflation_stretch(p: f64, r: f64, h: f64, young: f64, nu: f64) -> f64 {
    let ab = young * nu / (1.0 - nu * nu) + young / (2.0 * (1.0 + nu));
    let f = |l: f64| {
        ab * (2.0 * h * l * (l * l - 1.0) + h.powi(3) * (l - 1.0) / (3.0 * r * r)) - p * r * l * l
    };
    let df =
        |l: f64| ab * (2.0 * h * (3.0 * l * l - 1.0) + h.powi(3) / (3.0 * r * r)) - 2.0 * p * r * l;
    // f(1) < 0 for p > 0 and f grows like λ³: bisect for the bracket, then polish by Newton.
    let (mut lo, mut hi) = (1.0, 2.0);
    while f(hi) < 0.0 {
        hi *= 2.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let mut l = 0.5 * (lo + hi);
    for _ in 0..3 {
        l -= f(l) / df(l);
    }
    l
}

/// A closed unit sphere inflated by pressure to nearly twice its radius over a 4-step linear
/// ramp (the default): after every step the mean radius matches the uniform-inflation stretch
/// at that step's pressure λ_k·p. Measured on the level-2 icosphere: −0.27, −0.51, −0.72,
/// −0.88 % (the inscribed polyhedron's volume-to-area ratio); on level 3 the first two steps
/// give −0.07 and −0.13 % (second order in the mesh size).
#[test]
fn pressure_ramp_follows_the_inflation_curve() {
    let (h, young, nu, p) = (0.01, 1e6, 0.3, 2.0e4);
    let text = format!(
        "effects = [\"stretching\", \"bending\", \"pressure\"]\n[mesh]\ngenerator = \"icosphere\"\nlevel = 2\n\
         [material]\nthickness = {h}\nyoung = {young}\npoisson = {nu}\n\
         [pressure]\nvalue = {p}\n[integrator]\nkind = \"static\"\nsteps = 4\n"
    );
    let mut sim = simulation(&text);
    while sim.steps_done() < sim.steps_total() {
        let r = sim.step().unwrap();
        let x = sim.positions();
        let centre = x.iter().sum::<nalgebra::Vector3<f64>>() / x.len() as f64;
        let mean = x.iter().map(|q| (q - centre).norm()).sum::<f64>() / x.len() as f64;
        let exact = inflation_stretch(r.load_factor * p, 1.0, h, young, nu);
        println!(
            "step {} λ = {}: mean radius {mean:.6}, uniform inflation {exact:.6}, rel {:+.2e}, {} iterations, {:.2} s",
            r.step,
            r.load_factor,
            mean / exact - 1.0,
            r.newton_iterations,
            r.wall_s
        );
        assert_eq!(r.load_factor, r.step as f64 / 4.0);
        assert!(
            (mean / exact - 1.0).abs() < 0.012,
            "step {}: {mean} vs {exact}",
            r.step
        );
    }
}
