//! `cargo xtask contact-cost`: what the `contact` effect costs, on the scroll of
//! `solver/tests/contact.rs` at three sizes.
//!
//! The strip (20 cm × 2 cm, h = 0.2 mm, E = 1 MPa, rest shape rolled 1.5 turns) starts wound
//! as an Archimedean spiral whose layers are two mean edge lengths apart (near contact, not in
//! it); the implicit steps from there let it roll tighter. Measured, as medians over
//! interleaved rounds: the broad phase (candidate pairs, boxes grown by h + d̂), the CCD step
//! limit of the first step's displacement, the barrier energy, gradient and Hessian at the
//! spiral, and implicit steps (Δt = 1 ms) with and without contact. Prints a markdown table and
//! writes `target/xtask/contact-cost.json`. No pass/fail: timings on a shared machine vary.

use std::time::Instant;

use anyhow::{Context, Result};
use nalgebra::Vector3;
use thinshell_energy::contact::candidate_pairs;
use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{Mesh, generators};
use thinshell_solver::{ImplicitEuler, Integrator, State};
use thinshell_system::{Boundary, Contact, ContactSettings, Loads, ShellSystem};

use crate::common::{median, write_json};

type V = Vector3<f64>;

const LENGTH: f64 = 0.2;
const WIDTH: f64 = 0.02;
const THICKNESS: f64 = 2e-4;
const YOUNG: f64 = 1e6;

/// Options of the task.
pub struct Options {
    /// The smallest size only, one round.
    pub quick: bool,
    /// Interleaved rounds (medians over them).
    pub rounds: usize,
}

/// One size's medians (s) and counts.
struct Row {
    faces: usize,
    vertices: usize,
    candidates: usize,
    active_after: usize,
    broad_phase: f64,
    ccd: f64,
    energy: f64,
    gradient: f64,
    hessian: f64,
    step_without: f64,
    step_with: f64,
    iterations_without: usize,
    iterations_with: usize,
}

fn time<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let t = Instant::now();
    let out = f();
    (t.elapsed().as_secs_f64(), out)
}

/// The strip's mesh, its rolled rest positions (radius R = L/(3π)) and the spiral start whose
/// layers are `spacing` apart (innermost radius R).
fn scroll(ny: usize, spacing: f64) -> Result<(Mesh, Vec<V>, Vec<V>)> {
    let mesh = generators::rectangle(LENGTH, WIDTH, 10 * ny, ny)?;
    let r = LENGTH / (3.0 * std::f64::consts::PI);
    let rolled = mesh
        .positions()
        .iter()
        .map(|p| {
            let a = p.x / r;
            V::new(r * a.sin(), p.y, r * (1.0 - a.cos()))
        })
        .collect();
    // Arc length along r(θ) = R + bθ, tabulated finely enough for linear interpolation.
    let b = spacing / (2.0 * std::f64::consts::PI);
    let dtheta = 1e-4;
    let mut table = vec![(0.0, 0.0)];
    while table.last().map_or(0.0, |t| t.1) < LENGTH {
        let (theta, s) = table[table.len() - 1];
        let rr = r + b * (theta + 0.5 * dtheta);
        table.push((theta + dtheta, s + (rr * rr + b * b).sqrt() * dtheta));
    }
    let theta_of = |s: f64| {
        let k = table.partition_point(|t| t.1 < s).clamp(1, table.len() - 1);
        let ((t0, s0), (t1, s1)) = (table[k - 1], table[k]);
        t0 + (t1 - t0) * (s - s0) / (s1 - s0)
    };
    let spiral = mesh
        .positions()
        .iter()
        .map(|p| {
            let th = theta_of(p.x);
            let rr = r + b * th;
            V::new(rr * th.sin(), p.y, r - rr * th.cos())
        })
        .collect();
    Ok((mesh, rolled, spiral))
}

fn system(mesh: &Mesh, rolled: &[V]) -> Result<ShellSystem> {
    let sff = SffKind::MidEdgeAverage;
    let rest = RestState::from_mesh(mesh, rolled, sff)?;
    let model = ShellModel {
        material: Material {
            thickness: THICKNESS,
            young: YOUNG,
            poisson: 0.3,
            ..Material::paper()
        },
        terms: Terms::ELASTIC,
        sff,
    };
    Ok(ShellSystem::new(
        mesh.clone(),
        model,
        rest,
        Boundary::default(),
        Loads::default(),
    )?)
}

/// Two implicit steps from the spiral at rest: wall time per step and Newton iterations.
fn steps(mesh: &Mesh, rolled: &[V], spiral: &[V], contact: bool) -> Result<(f64, usize, State)> {
    let mut sys = system(mesh, rolled)?;
    if contact {
        sys.set_contact(&ContactSettings::default(), spiral)?;
    }
    let mut state = State::at_rest(spiral.to_vec());
    let mut ie = ImplicitEuler::new(1e-3);
    let (mut wall, mut iterations) = (0.0, 0);
    for _ in 0..2 {
        let (t, r) = time(|| ie.step(&mut sys, &mut state));
        let r = r.with_context(|| format!("implicit step (contact {contact})"))?;
        wall += 0.5 * t;
        iterations += r.newton.map_or(0, |n| n.iterations);
    }
    Ok((wall, iterations, state))
}

/// The spiral's layer spacing: `SPACING_EDGES` mean edge lengths (10 d̂ per edge length).
fn spacing(d_hat: f64) -> f64 {
    SPACING_EDGES * 10.0 * d_hat
}

/// Layer spacing of the start spiral, in mean edge lengths: near contact (a few edge lengths
/// apart) without being in it.
const SPACING_EDGES: f64 = 2.0;

fn measure(ny: usize, rounds: usize) -> Result<Row> {
    // d̂ of the default (0.1 × mean edge length), for the layer spacing.
    let (mesh0, _, _) = scroll(ny, 1.0)?;
    let probe = Contact::new(&mesh0, THICKNESS, YOUNG, &ContactSettings::default())?;
    let d_hat = probe.activation;
    let (mesh, rolled, spiral) = scroll(ny, spacing(d_hat))?;
    let contact = Contact::new(&mesh, THICKNESS, YOUNG, &ContactSettings::default())?;
    contact.check(&spiral)?;
    let faces = mesh.faces_usize();
    let edges: Vec<[usize; 2]> = mesh
        .topology()
        .edges()
        .iter()
        .map(|e| e.vertices.map(|v| v.idx()))
        .collect();
    let sys = system(&mesh, &rolled)?;
    let dofs = sys.dofs().clone();
    let (_, _, after) = steps(&mesh, &rolled, &spiral, false)?;
    let (mut bp, mut ccd, mut en, mut gr, mut he, mut s0, mut s1) =
        (vec![], vec![], vec![], vec![], vec![], vec![], vec![]);
    let (mut candidates, mut it0, mut it1, mut active_after) = (0, 0, 0, 0);
    for _ in 0..rounds {
        let (t, c) = time(|| candidate_pairs(&spiral, None, &faces, &edges, THICKNESS + d_hat));
        candidates = c.point_triangle.len() + c.edge_edge.len();
        bp.push(t);
        let (t, a) = time(|| contact.max_step(&spiral, &after.x));
        a?;
        ccd.push(t);
        en.push(time(|| contact.energy(&spiral)).0);
        let mut g = vec![0.0; 3 * spiral.len()];
        gr.push(time(|| contact.add_gradient(&spiral, &mut g)).0);
        let mut h = sys.hessian_template();
        he.push(time(|| contact.add_hessian(&spiral, &dofs, &mut h, false)).0);
        let (t, n, _) = steps(&mesh, &rolled, &spiral, false)?;
        s0.push(t);
        it0 = n;
        let (t, n, st) = steps(&mesh, &rolled, &spiral, true)?;
        s1.push(t);
        it1 = n;
        active_after = contact.stats(&st.x).active_pairs;
    }
    Ok(Row {
        faces: faces.len(),
        vertices: spiral.len(),
        candidates,
        active_after,
        broad_phase: median(&bp),
        ccd: median(&ccd),
        energy: median(&en),
        gradient: median(&gr),
        hessian: median(&he),
        step_without: median(&s0),
        step_with: median(&s1),
        iterations_without: it0,
        iterations_with: it1,
    })
}

/// Runs the measurements and prints the table.
pub fn run(o: &Options) -> Result<()> {
    let sizes: &[usize] = if o.quick { &[10] } else { &[10, 18, 32] };
    let rounds = if o.quick { 1 } else { o.rounds.max(1) };
    let mut rows = Vec::new();
    for &ny in sizes {
        eprintln!("contact-cost: strip with {} × {ny} cells…", 10 * ny);
        rows.push(measure(ny, rounds)?);
    }
    let ms = |s: f64| s * 1e3;
    println!(
        "| faces | candidates | broad phase (ms) | per face (µs) | CCD (ms) | energy (ms) | gradient (ms) | Hessian (ms) | step without (ms, its.) | step with (ms, its.) | active pairs after 2 steps |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} ({}) | {:.0} ({}) | {} |",
            r.faces,
            r.candidates,
            ms(r.broad_phase),
            r.broad_phase * 1e6 / r.faces as f64,
            ms(r.ccd),
            ms(r.energy),
            ms(r.gradient),
            ms(r.hessian),
            ms(r.step_without),
            r.iterations_without,
            ms(r.step_with),
            r.iterations_with,
            r.active_after
        );
    }
    let json: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            serde_json::json!({
                "faces": r.faces, "vertices": r.vertices, "candidates": r.candidates,
                "broad_phase_s": r.broad_phase, "ccd_s": r.ccd, "energy_s": r.energy,
                "gradient_s": r.gradient, "hessian_s": r.hessian,
                "step_without_s": r.step_without, "step_with_s": r.step_with,
                "iterations_without": r.iterations_without, "iterations_with": r.iterations_with,
                "active_pairs_after": r.active_after,
            })
        })
        .collect();
    let path = crate::common::out_dir().join("contact-cost.json");
    write_json(&path, &json)?;
    eprintln!("contact-cost: wrote {}", path.display());
    Ok(())
}
