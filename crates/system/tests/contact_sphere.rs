#![allow(clippy::unwrap_used)]
//! A closed spherical shell shrinking under external pressure dimples into self-contact (issue
//! #30's last zero-intersection case).
//!
//! A sphere of radius R and thickness h (R/h = 50) under a uniform external pressure p above
//! the classical buckling pressure p_c = 2E(h/R)²/√(3(1 − ν²)) has no equilibrium near its
//! spherical shape: started at rest, it shrinks and buckles into dimples that deepen until their
//! walls meet — two dimples, where two small equal and opposite point forces at antipodal
//! vertices (1 % of p πR², the imperfection that chooses where they form; their sum and moment
//! are 0) dent it, press together at the centre. Implicit Euler, contact with its defaults
//! (self-contact on, d̂ = 0.1 × the mean edge length, adaptive κ, thickness offset).
//!
//! Every step is checked independently of the contact code's broad phase and CCD: the test
//! kit's exact triangle–triangle test (no two faces sharing no vertex meet) and a brute-force
//! surface gap (every vertex–face and edge–edge distance of pairs sharing no vertex above h, the
//! two half-thicknesses). Without contact the same run passes through itself.

use nalgebra::Vector3;
use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::{VertexId, generators};
use thinshell_solver::{ImplicitEuler, Integrator, State};
use thinshell_system::loads::face_volume;
use thinshell_system::{Boundary, ContactSettings, Loads, ShellSystem};
use thinshell_testkit::contact::{brute_force_distance, face_edge_indices};

type V = Vector3<f64>;

const RADIUS: f64 = 0.05;
const THICKNESS: f64 = 1e-3;
const YOUNG: f64 = 1e6;
const POISSON: f64 = 0.3;

/// The classical buckling pressure of a complete spherical shell (Pa).
fn buckling_pressure() -> f64 {
    2.0 * YOUNG * (THICKNESS / RADIUS).powi(2) / (3.0 * (1.0 - POISSON * POISSON)).sqrt()
}

/// The sphere (icosphere of `level`) at rest under external pressure `p` (Pa) with the two
/// antipodal inward point forces; the start positions; the point forces' vertices and force.
fn sphere(level: usize, p: f64) -> (ShellSystem, Vec<V>, [(usize, V); 2]) {
    let mesh = generators::icosphere(RADIUS, level).unwrap();
    let sff = SffKind::MidEdgeAverage;
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).unwrap();
    let model = ShellModel {
        material: Material {
            thickness: THICKNESS,
            young: YOUNG,
            poisson: POISSON,
            ..Material::paper()
        },
        terms: Terms::ELASTIC,
        sff,
    };
    // Vertices 0 and 3 are antipodal corners of the icosahedron.
    let x0 = mesh.positions().to_vec();
    assert!((x0[0] + x0[3]).norm() < 1e-12 * RADIUS);
    let f = -x0[0].normalize() * (0.01 * p * std::f64::consts::PI * RADIUS * RADIUS);
    let pokes = [(0, f), (3, -f)];
    let loads = Loads {
        pressure: -p,
        point_forces: pokes.iter().map(|&(v, f)| (VertexId::new(v), f)).collect(),
        ..Loads::default()
    };
    let sys = ShellSystem::new(mesh, model, rest, Boundary::default(), loads).unwrap();
    (sys, x0, pokes)
}

/// What a run of the collapsing sphere did.
#[derive(Debug)]
struct Run {
    /// The first step whose faces meet (exact test), if any.
    first_meeting: Option<usize>,
    /// The smallest brute-force surface gap (distance − h) over all steps (m).
    min_surface_gap: f64,
    /// The largest rise of the total energy from one step to the next over the run (J), and
    /// the total energy at the start (J).
    max_rise: f64,
    start_energy: f64,
    /// The volume at the end over the start's.
    volume_ratio: f64,
    /// The contact term at the end, and d̂ (m).
    end: Option<thinshell_system::ContactStats>,
    activation: f64,
    /// The distance of the two poked vertices at the end (m).
    poles: f64,
}

/// `steps` implicit Euler steps of `dt` (s) at twice the buckling pressure on an icosphere of
/// `level`, with or without contact; stops at the first meeting faces without contact.
fn collapse(level: usize, dt: f64, steps: usize, contact: bool) -> Run {
    let p = 2.0 * buckling_pressure();
    let (mut sys, x0, pokes) = sphere(level, p);
    if contact {
        sys.set_contact(&ContactSettings::default(), &x0).unwrap();
    }
    let activation = sys.contact().map_or(0.0, |c| c.activation);
    let (faces, edges) = face_edge_indices(sys.mesh());
    let volume = |x: &[V]| {
        faces
            .iter()
            .map(|f| face_volume(f.map(|v| x[v])))
            .sum::<f64>()
    };
    // Kinetic, elastic and barrier energy, and the loads' potential p·V − Σ F·x (J).
    let total = |sys: &mut ShellSystem, s: &State, barrier: f64| {
        let kinetic: f64 =
            s.v.iter()
                .zip(sys.mass())
                .map(|(v, m)| 0.5 * m * v.norm_squared())
                .sum();
        let loads = p * volume(&s.x) - pokes.iter().map(|&(v, f)| f.dot(&s.x[v])).sum::<f64>();
        kinetic + sys.energy(&s.x).unwrap().total() + barrier + loads
    };
    let mut state = State::at_rest(x0);
    let v0 = volume(&state.x);
    let start_energy = total(&mut sys, &state, 0.0);
    let mut last = start_energy;
    let mut run = Run {
        first_meeting: None,
        min_surface_gap: f64::INFINITY,
        max_rise: f64::NEG_INFINITY,
        start_energy,
        volume_ratio: 1.0,
        end: None,
        activation,
        poles: 0.0,
    };
    let mut ie = ImplicitEuler::new(dt);
    for step in 0..steps {
        let r = ie
            .step(&mut sys, &mut state)
            .unwrap_or_else(|e| panic!("step {step}: {e}"));
        if thinshell_testkit::exact::first_meeting_faces(&state.x, &faces).is_some() {
            run.first_meeting = Some(step);
            break;
        }
        let d = brute_force_distance(&state.x, &faces, &edges, 2.0 * THICKNESS);
        run.min_surface_gap = run.min_surface_gap.min(d - THICKNESS);
        let e = total(&mut sys, &state, r.contact.map_or(0.0, |c| c.energy));
        run.max_rise = run.max_rise.max(e - last);
        last = e;
        run.end = r.contact;
    }
    run.volume_ratio = volume(&state.x) / v0;
    run.poles = (state.x[pokes[0].0] - state.x[pokes[1].0]).norm();
    run
}

/// No faces met and the gap stayed positive at every step; at the end pairs are active, their
/// smallest gap positive and below d̂.
fn assert_in_contact_without_crossing(run: &Run) {
    assert_eq!(run.first_meeting, None);
    assert!(run.min_surface_gap > 0.0, "{run:?}");
    let end = run.end.as_ref().unwrap();
    assert!(
        end.active_pairs > 0 && end.min_gap > 0.0 && end.min_gap < run.activation,
        "{end:?}"
    );
}

/// The same collapse on 5120 faces (`cargo test --release -p thinshell-solver --test
/// contact_sphere -- --ignored`; minutes).
#[test]
#[ignore = "minutes: the 5120-face version of the default test"]
fn finer_sphere_under_pressure_dimples_into_self_contact_without_crossing() {
    let run = collapse(4, 2e-4, 50, true);
    eprintln!("with contact: {run:?}");
    assert_in_contact_without_crossing(&run);
    assert!(run.volume_ratio < 0.3, "{run:?}");
    assert!(run.max_rise < 1e-9 * run.start_energy.abs(), "{run:?}");
}

/// 1280 faces, 45 steps of 0.2 ms: the dimples touch at about step 29 and their bottoms meet
/// at the centre at about step 38. Without contact the faces meet by step 40.
#[test]
fn sphere_under_pressure_dimples_into_self_contact_without_crossing() {
    let free = collapse(3, 2e-4, 45, false);
    eprintln!("without contact: {free:?}");
    assert!(
        free.first_meeting.is_some(),
        "without contact the dimples should pass through each other"
    );
    let run = collapse(3, 2e-4, 45, true);
    eprintln!("with contact: {run:?}");
    assert_in_contact_without_crossing(&run);
    // Collapsed: most of the volume is gone, and the two dimples' bottoms press against each
    // other at the centre: the poked vertices' mid-surfaces a thickness plus a gap below d̂
    // apart (measured 1.69 mm = h + 0.92 d̂).
    assert!(run.volume_ratio < 0.3, "{run:?}");
    assert!(
        run.poles > THICKNESS && run.poles < THICKNESS + run.activation,
        "{run:?}"
    );
    // Implicit Euler dissipates: the total energy (kinetic, elastic, barrier, loads) never
    // rises from one step to the next beyond round-off.
    assert!(run.max_rise < 1e-9 * run.start_energy.abs(), "{run:?}");
}
