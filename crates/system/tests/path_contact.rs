//! Arc length with contact: a shallow arch strip snaps through under a central point load onto
//! a plane below it. Every iterate of every path step is reached by collision-checked motion
//! (a corrector that would cross is cut back), so the path lands on the plane and the load
//! climbs again, where without contact the arch snaps through the plane.
//!
//! The plane is checked independently of the contact code: the shell's lower surface (mid-surface
//! minus h/2, the default thickness offset) of every vertex stays above it at every path point
//! (for a plane, the vertices bound the faces).

use thinshell_energy::SffKind;
use thinshell_mesh::VertexId;
use thinshell_solver::PathSettings;
use thinshell_solver::nalgebra::Vector3;
use thinshell_system::{ContactSettings, Obstacle, ShellPath, ShellSystem};

const RISE: f64 = 0.015;
const THICKNESS: f64 = 0.01;
/// The plane's height (m): the inverted arch's crown (−RISE) would put its lower surface
/// h/2 + 5 mm below it.
const PLANE_Z: f64 = -0.015;

/// The arch strip (span 1 m, width 0.1 m, rise 15 mm, h = 10 mm, E = 10 MPa, the default
/// bending form), both short ends pinned, 1 N down on the crown vertex at λ = 1; with a plane
/// obstacle at `PLANE_Z` (contact defaults) when `contact`.
fn arch(contact: bool) -> (ShellSystem, Vec<Vector3<f64>>, VertexId) {
    let (mut system, x, crown) =
        thinshell_testkit::fixtures::shallow_arch(RISE, 1.0, SffKind::default());
    if contact {
        let settings = ContactSettings {
            obstacles: vec![Obstacle::Plane {
                point: Vector3::new(0.0, 0.0, PLANE_Z),
                normal: Vector3::z(),
            }],
            ..Default::default()
        };
        system.set_contact(&settings, &x).expect("contact");
    }
    (system, x, crown)
}

/// The lowest point of the shell's lower surface above the plane (m; negative: crossed).
fn clearance(x: &[Vector3<f64>]) -> f64 {
    x.iter()
        .map(|p| p.z - 0.5 * THICKNESS - PLANE_Z)
        .fold(f64::INFINITY, f64::min)
}

/// What a traced path did: load factors, the crown's height (m) and the smallest clearance.
struct Trace {
    lambda: Vec<f64>,
    crown_z: Vec<f64>,
    min_clearance: f64,
}

fn trace(contact: bool, steps: usize) -> Trace {
    let (mut system, x0, crown) = arch(contact);
    let mut path = ShellPath::new(PathSettings {
        initial_load_increment: 0.02,
        ..Default::default()
    });
    let (mut x, mut phi) = (x0.clone(), Vec::new());
    let mut t = Trace {
        lambda: vec![0.0],
        crown_z: vec![x0[crown.idx()].z],
        min_clearance: clearance(&x0),
    };
    for step in 0..steps {
        let p = path
            .step(&mut system, &mut x, &mut phi)
            .unwrap_or_else(|e| panic!("contact {contact}, step {step}: {e}"));
        t.lambda.push(p.load_factor);
        t.crown_z.push(x[crown.idx()].z);
        t.min_clearance = t.min_clearance.min(clearance(&x));
        if t.crown_z.last().is_some_and(|z| *z < -RISE) {
            break;
        }
    }
    t
}

#[test]
fn arc_length_lands_on_a_plane_instead_of_passing_through() {
    const STEPS: usize = 60;
    let free = trace(false, STEPS);
    let touched = trace(true, STEPS);
    eprintln!(
        "without contact: {} steps, λ {:?}, crown z {:?}, clearance {:.3e}",
        free.lambda.len() - 1,
        free.lambda,
        free.crown_z,
        free.min_clearance
    );
    eprintln!(
        "with contact: λ {:?}, crown z {:?}, clearance {:.3e}",
        touched.lambda, touched.crown_z, touched.min_clearance
    );
    // The test can fail: without contact the arch snaps through the plane.
    assert!(free.min_clearance < 0.0, "{}", free.min_clearance);
    // With contact the lower surface never reaches the plane ...
    assert!(touched.min_clearance > 0.0, "{}", touched.min_clearance);
    // ... though it comes within d̂ = 0.1 × the mean edge (under 6 mm here) of it ...
    assert!(touched.min_clearance < 6e-3, "{}", touched.min_clearance);
    // ... and, resting on it, carries more than the limit load of the free snap-through.
    let limit = free.lambda.iter().copied().fold(0.0f64, f64::max);
    let last = touched.lambda.last().copied().unwrap_or(0.0);
    assert!(
        last > limit,
        "λ at the end {last} vs the limit load {limit}"
    );
}
