#![allow(clippy::unwrap_used)]
//! A closed sphere whose rest metric shrinks to a quarter (issue #30's "shrinking sphere that
//! dimples into self-contact"), with contact.
//!
//! docs/robustness.md's "Strong growth" case: a unit sphere of damped paper (h = 0.1 mm, η/E =
//! 1 ms), rest metric ā = 0.25 a⁰ on every face (b̄ = b⁰), implicit Euler at Δt = 1 ms. The
//! sphere of radius 1/2 fits the shrunk metric, and the perfect icosphere shrinks into it,
//! keeping its symmetry. The membrane, 10⁸ times stiffer than bending, contracts within the
//! first step (at hundreds of m/s), so the second step's inertial prediction x̃ = x + Δt v lies
//! far inside, through the centre. With an imperfection of the start (random offsets of up to
//! 5 mm per coordinate, under 3 % of an edge) that prediction passes through itself, and Newton,
//! which starts there, crumples the sphere: without contact its folds pass through each other
//! at the second step. With contact (its defaults: self-contact on, d̂ = 0.1 × the mean edge
//! length, adaptive κ, thickness offset; the solver's defaults, no fallbacks) Newton also starts
//! at x̃ whenever its energy is finite — no CCD guards the jump from xⁿ to x̃ — so it can start
//! from, and end in, a state whose faces cross (the ignored test below; docs/robustness.md).
//! Started from xⁿ instead, the imperfect sphere stays round (rms radius 0.5000 m) and never
//! comes into contact: the crumpling, and the contact it brings, come from the crossing start.
//!
//! Every step is checked independently of the contact code's broad phase and CCD, as in
//! `contact_sphere.rs`: the test kit's exact triangle–triangle test (no two faces sharing no
//! vertex meet) and a brute-force surface gap (every vertex–face and edge–edge distance of
//! pairs sharing no vertex above h, the two half-thicknesses).

use nalgebra::Vector3;
use thinshell_energy::{RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::generators;
use thinshell_solver::{
    Boundary, ContactSettings, ContactStats, ImplicitEuler, Integrator, Loads, ShellSystem, State,
};
use thinshell_testkit::contact::{brute_force_distance, face_edge_indices};
use thinshell_testkit::fixtures::damped_paper;
use thinshell_testkit::rng::Lcg64;

type V = Vector3<f64>;

/// The factor on every face's rest metric: ā = K a⁰ (edges towards √K = 0.5 of their length).
const K: f64 = 0.25;
/// η/E (s): the relaxation time of the damped paper.
const RELAXATION: f64 = 1e-3;
/// The start positions' random offsets: uniform in a cube of this side (m) about the
/// icosphere's vertices (the rest forms are the unperturbed sphere's).
const IMPERFECTION: f64 = 1e-2;

/// The unit sphere (icosphere of `level`) with ā = K a⁰, b̄ = b⁰, and its vertices.
fn shrinking_sphere(level: usize) -> (ShellSystem, Vec<V>) {
    let mesh = generators::icosphere(1.0, level).unwrap();
    let sff = SffKind::MidEdgeAverage;
    let x0 = mesh.positions().to_vec();
    let mut rest = RestState::from_mesh(&mesh, &x0, sff).unwrap();
    rest.a_bar.iter_mut().for_each(|a| *a *= K);
    let model = ShellModel {
        material: damped_paper(RELAXATION),
        terms: Terms {
            stretch: true,
            bend: true,
            damping: true,
        },
        sff,
    };
    let sys = ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default()).unwrap();
    (sys, x0)
}

/// What a run of the shrinking sphere did.
#[derive(Debug)]
struct Run {
    /// The first step whose faces meet (exact test), if any.
    first_meeting: Option<usize>,
    /// The smallest brute-force surface gap (distance − h) over all steps (m).
    min_surface_gap: f64,
    /// The first step with active contact pairs, and the most active pairs of any step.
    first_contact: Option<usize>,
    max_active: usize,
    /// The contact term at the end.
    end: Option<ContactStats>,
    /// Newton iterations over the run.
    iterations: usize,
    /// Mean edge length at the end over the start's (the metric's target: √K).
    edge_stretch: f64,
    /// Smallest and rms distance of the vertices from the centre at the end (m).
    min_radius: f64,
    rms_radius: f64,
}

/// `steps` implicit Euler steps of `dt` (s) on an icosphere of `level` whose start has the
/// imperfection drawn with `seed`, with or without contact; stops at the first meeting faces.
fn shrink(level: usize, seed: u64, dt: f64, steps: usize, contact: bool) -> Run {
    let (mut sys, mut x0) = shrinking_sphere(level);
    // The imperfection: without it the icosphere's symmetry holds and it shrinks into a round
    // sphere of radius 1/2 (the only surface of the shrunk metric), never touching itself.
    let mut rng = Lcg64::new(seed);
    for p in x0.iter_mut() {
        *p += IMPERFECTION * V::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
    }
    if contact {
        sys.set_contact(&ContactSettings::default(), &x0).unwrap();
    }
    let activation = sys.contact.as_ref().map_or(0.0, |c| c.activation);
    let h = sys.model().material.thickness;
    let (faces, edges) = face_edge_indices(sys.mesh());
    let mean_edge = |x: &[V]| {
        edges
            .iter()
            .map(|e| (x[e[0]] - x[e[1]]).norm())
            .sum::<f64>()
            / edges.len() as f64
    };
    let l0 = mean_edge(&x0);
    let mut state = State::at_rest(x0);
    let mut run = Run {
        first_meeting: None,
        min_surface_gap: f64::INFINITY,
        first_contact: None,
        max_active: 0,
        end: None,
        iterations: 0,
        edge_stretch: 1.0,
        min_radius: 1.0,
        rms_radius: 1.0,
    };
    let mut ie = ImplicitEuler::new(dt);
    for step in 0..steps {
        let r = ie
            .step(&mut sys, &mut state)
            .unwrap_or_else(|e| panic!("step {step}: {e}"));
        run.iterations += r.newton.as_ref().map_or(0, |n| n.iterations);
        if thinshell_testkit::exact::first_meeting_faces(&state.x, &faces).is_some() {
            run.first_meeting = Some(step);
            break;
        }
        let d = brute_force_distance(&state.x, &faces, &edges, 2.0 * h + activation);
        run.min_surface_gap = run.min_surface_gap.min(d - h);
        if let Some(c) = r.contact {
            if c.active_pairs > 0 && run.first_contact.is_none() {
                run.first_contact = Some(step);
            }
            run.max_active = run.max_active.max(c.active_pairs);
        }
        run.end = r.contact;
    }
    run.edge_stretch = mean_edge(&state.x) / l0;
    run.min_radius = state
        .x
        .iter()
        .map(|p| p.norm())
        .fold(f64::INFINITY, f64::min);
    run.rms_radius =
        (state.x.iter().map(|p| p.norm_squared()).sum::<f64>() / state.x.len() as f64).sqrt();
    run
}

/// 320 faces, 30 steps of 1 ms (docs/robustness.md's case, with the imperfection of seed 7):
/// with contact no faces cross and the surface gap stays positive; without, they cross at the
/// second step. (It comes into contact from step 2 on, 239 active pairs at the end, smallest
/// gap 1.16·10⁻² m = 0.39 d̂, rms radius 0.378 m — but only because Newton starts at the crossing
/// prediction x̃: see the module documentation. So neither the contact nor the crumpling is
/// asserted.)
#[test]
fn shrinking_sphere_with_contact_does_not_cross() {
    let free = shrink(2, 7, 1e-3, 30, false);
    eprintln!("without contact: {free:?}");
    assert!(
        free.first_meeting.is_some(),
        "without contact the folds should pass through each other"
    );
    let run = shrink(2, 7, 1e-3, 30, true);
    eprintln!("with contact: {run:?}");
    assert_eq!(run.first_meeting, None);
    assert!(run.min_surface_gap > 0.0, "{run:?}");
    // Contact does not stop the membrane from following its metric: the mean edge within 5 %
    // of √K = 1/2 of its start (measured 0.49995).
    assert!((run.edge_stretch / K.sqrt() - 1.0).abs() < 0.05, "{run:?}");
}

/// Other imperfections, and the same on 1280 faces: here contact does NOT keep the faces apart.
/// Seed 1: the 6th step's prediction x̃ has two faces sharing no vertex crossing (an edge
/// pierces a face: every vertex–face and edge–edge distance positive, so the barrier is finite
/// there); Newton starts at x̃ and converges (9 iterations) to a state where they still cross.
/// The predictions of steps 3 and 5 crossed too, and their solves ended apart only by chance.
/// Kept as the reproducer of the unguarded start (`cargo test --release -p thinshell-solver
/// --test contact_shrink -- --ignored`; fails at seed 1 within seconds). With Newton started at
/// xⁿ under contact, seeds 1–3 pass (and stay round: no contact); 1280 faces then fails to
/// converge at the second step (100 iterations, relative residual 1.2·10⁻³ → 2.8·10⁻³).
#[test]
#[ignore = "fails: Newton starts at a crossing prediction x̃ (issue #30, docs/robustness.md)"]
fn shrinking_sphere_other_imperfections_without_crossing() {
    for (level, seed) in [(2, 1), (2, 2), (2, 3), (3, 7)] {
        let run = shrink(level, seed, 1e-3, 30, true);
        eprintln!("level {level}, seed {seed}, with contact: {run:?}");
        assert_eq!(run.first_meeting, None, "level {level}, seed {seed}");
        assert!(run.min_surface_gap > 0.0, "{run:?}");
    }
}
