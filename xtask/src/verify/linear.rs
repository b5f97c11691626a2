//! Linear benchmarks: Kirchhoff plates (Timoshenko & Woinowsky-Krieger), the pinched cylinder
//! with rigid end diaphragms and the pinched hemispheres (MacNeal & Harder 1985).
//!
//! Boundary conditions. Simply supported = every boundary vertex pinned (w = 0 and the in-plane
//! displacement held, which linear plate theory does not feel) with the rotation about the edge
//! free: for the edge-director forms the boundary edges' directors are extrapolated from the
//! interior (model.md §1.2), a consistent energy whose natural condition is a moment-free edge;
//! for the mid-edge average a boundary edge's normal is its face's normal (model.md §1), which is
//! not a moment-free edge — its simply supported plates are expected to be off. Clamped =
//! `Boundary::clamped_edges` on every boundary edge: boundary vertices and the edges' directors
//! held for the edge-director forms (model.md §1.3), two rows of vertices for the average.

use anyhow::Result;
use thinshell_energy::{Material, SffKind};
use thinshell_mesh::{Mesh, VertexId, generators};
use thinshell_system::{Boundary, Loads};

use super::case::{Curve, Outcome, Quantity, Spec};
use super::solve::{Config, V3, equilibrium, stress_free, unheld, uniform_nodal_forces, vertex_at};

const GROUP: &str = "linear plates and shells";

/// Plate: side (square) or radius (disc) a, thickness, Young's modulus, Poisson ratio, and the
/// load sizes: small enough for a linear response (centre deflection below 2e-3 h).
const PLATE: (f64, f64, f64, f64) = (1.0, 0.01, 1e7, 0.3);
const Q: f64 = 1e-3;
const P: f64 = 1e-3;

pub(crate) static SPECS: [Spec; 8] = [
    Spec {
        name: "plate: simply supported square, uniform load",
        group: GROUP,
        description: concat!(
            "Reference w_c = 4.06235e-3 q a⁴/D (Timoshenko & Woinowsky-Krieger). ",
            "Meshes: alternating-diagonal grids 8×8 … 128×128 (5 levels). ",
            "Plate a = 1 (side or radius), h = 0.01, E = 1e7, ν = 0.3, D = E h³/(12(1 − ν²)); dead loads q = 1e-3 (nodal forces q·area/3 per face corner) or P = 1e-3 (centre vertex), w/h < 2e-3 (linear). Measured: the centre vertex's deflection. Simply supported: every boundary vertex pinned, rotation about the edge free (for the edge-director forms the boundary edges' directors are extrapolated from the interior, model.md §1.2, and the edge carries no moment in the limit); the mid-edge average has no such freedom (a boundary edge's normal is its face's normal), so its simply supported plates are not expected to converge to the reference. Clamped: `clamped_edges` on the whole boundary — for the edge-director forms the boundary vertices and the edges' directors held (model.md §1.3, second order); for the mid-edge average two rows of vertices held, the first row of cells rigid, an O(h) stiffening."
        ),
        tolerance: 0.02,
        quick_tolerance: 0.2,
        levels: 5,
        first_level: 0,
        reference_curves: Vec::new,
        run: ss_square_uniform,
    },
    Spec {
        name: "plate: simply supported square, central point load",
        group: GROUP,
        description: concat!(
            "Reference w_c = 0.01160 P a²/D (Timoshenko & Woinowsky-Krieger). ",
            "Meshes: alternating-diagonal grids 8×8 … 128×128 (5 levels). ",
            "Plate a = 1 (side or radius), h = 0.01, E = 1e7, ν = 0.3, D = E h³/(12(1 − ν²)); dead loads q = 1e-3 (nodal forces q·area/3 per face corner) or P = 1e-3 (centre vertex), w/h < 2e-3 (linear). Measured: the centre vertex's deflection. Simply supported: every boundary vertex pinned, rotation about the edge free (for the edge-director forms the boundary edges' directors are extrapolated from the interior, model.md §1.2, and the edge carries no moment in the limit); the mid-edge average has no such freedom (a boundary edge's normal is its face's normal), so its simply supported plates are not expected to converge to the reference. Clamped: `clamped_edges` on the whole boundary — for the edge-director forms the boundary vertices and the edges' directors held (model.md §1.3, second order); for the mid-edge average two rows of vertices held, the first row of cells rigid, an O(h) stiffening."
        ),
        tolerance: 0.02,
        quick_tolerance: 0.2,
        levels: 5,
        first_level: 0,
        reference_curves: Vec::new,
        run: ss_square_point,
    },
    Spec {
        name: "plate: clamped square, central point load",
        group: GROUP,
        description: concat!(
            "Reference w_c = 0.00560 P a²/D (Timoshenko & Woinowsky-Krieger). ",
            "Meshes: alternating-diagonal grids 16×16 … 256×256 (5 levels; `--quick`: 8×8): the point load and the clamp converge at order 1.6–1.8, so the series goes one level finer than the other plates' to get within 0.5 %. Timoshenko's coefficient has three digits; the Richardson limit of the edge-director forms is 0.2 % above it. ",
            "Plate a = 1 (side or radius), h = 0.01, E = 1e7, ν = 0.3, D = E h³/(12(1 − ν²)); dead loads q = 1e-3 (nodal forces q·area/3 per face corner) or P = 1e-3 (centre vertex), w/h < 2e-3 (linear). Measured: the centre vertex's deflection. Simply supported: every boundary vertex pinned, rotation about the edge free (for the edge-director forms the boundary edges' directors are extrapolated from the interior, model.md §1.2, and the edge carries no moment in the limit); the mid-edge average has no such freedom (a boundary edge's normal is its face's normal), so its simply supported plates are not expected to converge to the reference. Clamped: `clamped_edges` on the whole boundary — for the edge-director forms the boundary vertices and the edges' directors held (model.md §1.3, second order); for the mid-edge average two rows of vertices held, the first row of cells rigid, an O(h) stiffening."
        ),
        tolerance: 0.02,
        quick_tolerance: 0.2,
        levels: 6,
        first_level: 1,
        reference_curves: Vec::new,
        run: clamped_square_point,
    },
    Spec {
        name: "plate: clamped circle, uniform load",
        group: GROUP,
        description: concat!(
            "Reference w_c = q a⁴/(64 D). ",
            "Meshes: disc with 4 … 64 rings (5 levels). ",
            "Plate a = 1 (side or radius), h = 0.01, E = 1e7, ν = 0.3, D = E h³/(12(1 − ν²)); dead loads q = 1e-3 (nodal forces q·area/3 per face corner) or P = 1e-3 (centre vertex), w/h < 2e-3 (linear). Measured: the centre vertex's deflection. Simply supported: every boundary vertex pinned, rotation about the edge free (for the edge-director forms the boundary edges' directors are extrapolated from the interior, model.md §1.2, and the edge carries no moment in the limit); the mid-edge average has no such freedom (a boundary edge's normal is its face's normal), so its simply supported plates are not expected to converge to the reference. Clamped: `clamped_edges` on the whole boundary — for the edge-director forms the boundary vertices and the edges' directors held (model.md §1.3, second order); for the mid-edge average two rows of vertices held, the first row of cells rigid, an O(h) stiffening."
        ),
        tolerance: 0.02,
        quick_tolerance: 0.2,
        levels: 5,
        first_level: 0,
        reference_curves: Vec::new,
        run: clamped_circle_uniform,
    },
    Spec {
        name: "plate: simply supported circle, uniform load",
        group: GROUP,
        description: concat!(
            "Reference w_c = q a⁴ (5 + ν)/(64 D (1 + ν)). ",
            "Meshes: disc with 4 … 64 rings (5 levels). ",
            "Plate a = 1 (side or radius), h = 0.01, E = 1e7, ν = 0.3, D = E h³/(12(1 − ν²)); dead loads q = 1e-3 (nodal forces q·area/3 per face corner) or P = 1e-3 (centre vertex), w/h < 2e-3 (linear). Measured: the centre vertex's deflection. Simply supported: every boundary vertex pinned, rotation about the edge free (for the edge-director forms the boundary edges' directors are extrapolated from the interior, model.md §1.2, and the edge carries no moment in the limit); the mid-edge average has no such freedom (a boundary edge's normal is its face's normal), so its simply supported plates are not expected to converge to the reference. Clamped: `clamped_edges` on the whole boundary — for the edge-director forms the boundary vertices and the edges' directors held (model.md §1.3, second order); for the mid-edge average two rows of vertices held, the first row of cells rigid, an O(h) stiffening."
        ),
        tolerance: 0.02,
        quick_tolerance: 0.2,
        levels: 5,
        first_level: 0,
        reference_curves: Vec::new,
        run: ss_circle_uniform,
    },
    Spec {
        name: "pinched cylinder with rigid diaphragms",
        group: GROUP,
        description: "R = 300, L = 600, t = 3, E = 3e6, ν = 0.3, two opposite inward point loads \
            P = 1 at mid-length (the issue's load; w/t ≈ 6e-6, linear, not scaled). Full \
            cylinder (no symmetry planes), axis z; the diaphragms hold x and y of both end rings \
            (radial and circumferential displacement), axial displacement free; z of the two \
            mid-length vertices at 90° and 270° held (zero by symmetry) against the axial rigid \
            motion. Measured: radial displacement under the load = half the decrease of the \
            distance between the two loaded vertices. Reference 1.8248e-5 (MacNeal–Harder). \
            Meshes: uniform alternating-diagonal grids 32×16 … 256×128 (around × along); no \
            grading toward the singular point load.",
        tolerance: 0.05,
        quick_tolerance: 1.0,
        levels: 4,
        first_level: 0,
        reference_curves: Vec::new,
        run: pinched_cylinder,
    },
    Spec {
        name: "pinched hemisphere with 18° hole",
        group: GROUP,
        description: "R = 10, t = 0.04, E = 6.825e7, ν = 0.3, full hemisphere between polar \
            angles 18° and 90°, both edges free, four radial loads on the equator: outward at \
            0° and 180°, inward at 90° and 270°. The issue's load 2 gives w ≈ 2.4 t (not \
            linear), so the loads are scaled to 2e-3 and the displacements multiplied by 1e3. \
            Rigid motion removed by the 3-2-1 pins of `Boundary::rigid_motion_pins` (no \
            reactions: the loads are self-equilibrated). Measured: half the change of the \
            distance between opposite load points (pulled and pushed pair). Reference 0.094 \
            (MacNeal–Harder) at a load point. Meshes: 8×32, 16×64, 32×128 (rings × around).",
        tolerance: 0.05,
        quick_tolerance: 1.0,
        levels: 3,
        first_level: 0,
        reference_curves: Vec::new,
        run: hemisphere_hole,
    },
    Spec {
        name: "pinched hemisphere, closed",
        group: GROUP,
        description: "As the hemisphere with a hole but closed at the pole (the disc of 8, 16, \
            32 rings mapped onto the sphere; equator free). Loads 2e-3, displacements × 1e3. \
            Reference 0.0924.",
        tolerance: 0.05,
        quick_tolerance: 1.0,
        levels: 3,
        first_level: 0,
        reference_curves: Vec::new,
        run: hemisphere_closed,
    },
];

#[derive(Clone, Copy)]
enum Support {
    Simple,
    Clamped,
}

fn boundary(mesh: &Mesh, support: Support) -> Boundary {
    match support {
        Support::Simple => Boundary {
            pinned_vertices: mesh.topology().boundary_vertices().to_vec(),
            ..Boundary::default()
        },
        Support::Clamped => Boundary {
            clamped_edges: mesh.topology().boundary_edges().to_vec(),
            ..Boundary::default()
        },
    }
}

/// Centre deflection of a plate (centre vertex at `centre`), point load or uniform load.
fn plate(
    (mesh, label, centre): (Mesh, String, V3),
    support: Support,
    point_load: bool,
    coefficient: f64,
    sff: SffKind,
) -> Result<Outcome> {
    let (a, h, e, nu) = PLATE;
    let d = e * h.powi(3) / (12.0 * (1.0 - nu * nu));
    let faces = mesh.n_faces();
    let c = vertex_at(&mesh, centre)?;
    let down = V3::new(0.0, 0.0, -1.0);
    let (point_forces, reference) = if point_load {
        (vec![(c, down * P)], coefficient * P * a * a / d)
    } else {
        (
            uniform_nodal_forces(&mesh, Q, down),
            coefficient * Q * a.powi(4) / d,
        )
    };
    let bc = boundary(&mesh, support);
    let x0 = mesh.positions().to_vec();
    let loads = Loads {
        point_forces,
        ..Loads::default()
    };
    let mut sys = stress_free(
        mesh,
        sff,
        Material {
            thickness: h,
            young: e,
            poisson: nu,
            ..Material::paper()
        },
        bc,
        loads,
    )?;
    let mut cfg = Config::of(&sys, x0.clone());
    let converged = equilibrium(&mut sys, &mut cfg);
    Ok(Outcome {
        mesh: label,
        faces,
        quantities: vec![Quantity::relative(
            "w_c",
            reference,
            x0[c.idx()].z - cfg.x[c.idx()].z,
        )],
        converged,
        curves: Vec::new(),
        note: (!converged).then(|| "static solve did not converge".to_string()),
    })
}

fn square(level: usize) -> Result<(Mesh, String, V3)> {
    let n = 8 << level;
    Ok((
        generators::rectangle(PLATE.0, PLATE.0, n, n)?,
        format!("rectangle {n}×{n}"),
        V3::new(PLATE.0 / 2.0, PLATE.0 / 2.0, 0.0),
    ))
}

fn circle(level: usize) -> Result<(Mesh, String, V3)> {
    let rings = 4 << level;
    Ok((
        generators::disc(PLATE.0, rings)?,
        format!("disc, {rings} rings"),
        V3::zeros(),
    ))
}

fn ss_square_uniform(sff: SffKind, level: usize) -> Result<Outcome> {
    let m = square(level)?;
    plate(m, Support::Simple, false, 4.06235e-3, sff)
}

fn ss_square_point(sff: SffKind, level: usize) -> Result<Outcome> {
    let m = square(level)?;
    plate(m, Support::Simple, true, 0.01160, sff)
}

fn clamped_square_point(sff: SffKind, level: usize) -> Result<Outcome> {
    let m = square(level)?;
    plate(m, Support::Clamped, true, 0.00560, sff)
}

fn clamped_circle_uniform(sff: SffKind, level: usize) -> Result<Outcome> {
    let m = circle(level)?;
    plate(m, Support::Clamped, false, 1.0 / 64.0, sff)
}

fn ss_circle_uniform(sff: SffKind, level: usize) -> Result<Outcome> {
    let m = circle(level)?;
    let nu = PLATE.3;
    plate(
        m,
        Support::Simple,
        false,
        (5.0 + nu) / (64.0 * (1.0 + nu)),
        sff,
    )
}

fn pinched_cylinder(sff: SffKind, level: usize) -> Result<Outcome> {
    let (r, len, t, e, nu, p) = (300.0, 600.0, 3.0, 3e6, 0.3, 1.0);
    let (around, along) = (32 << level, 16 << level);
    let mesh = generators::cylinder_patch(r, std::f64::consts::TAU, len, around, along)?;
    let faces = mesh.n_faces();
    let mid = len / 2.0;
    let a = vertex_at(&mesh, V3::new(r, 0.0, mid))?;
    let b = vertex_at(&mesh, V3::new(-r, 0.0, mid))?;
    let mut pinned_coordinates = Vec::new();
    for (i, q) in mesh.positions().iter().enumerate() {
        if q.z.abs() < 1e-9 * len || (q.z - len).abs() < 1e-9 * len {
            let v = VertexId::new(i);
            pinned_coordinates.push((v, 0));
            pinned_coordinates.push((v, 1));
        }
    }
    for y in [r, -r] {
        pinned_coordinates.push((vertex_at(&mesh, V3::new(0.0, y, mid))?, 2));
    }
    let loads = Loads {
        point_forces: vec![(a, V3::new(-p, 0.0, 0.0)), (b, V3::new(p, 0.0, 0.0))],
        ..Loads::default()
    };
    let bc = Boundary {
        pinned_coordinates,
        ..Boundary::default()
    };
    let x0 = mesh.positions().to_vec();
    let mut sys = stress_free(
        mesh,
        sff,
        Material {
            thickness: t,
            young: e,
            poisson: nu,
            ..Material::paper()
        },
        bc,
        loads,
    )?;
    let mut cfg = Config::of(&sys, x0.clone());
    let converged = equilibrium(&mut sys, &mut cfg);
    let w = 0.5 * ((x0[a.idx()] - x0[b.idx()]).norm() - (cfg.x[a.idx()] - cfg.x[b.idx()]).norm());
    Ok(Outcome {
        mesh: format!("cylinder {around}×{along}"),
        faces,
        quantities: vec![Quantity::relative("w under the load", 1.8248e-5, w)],
        converged,
        curves: Vec::new(),
        note: (!converged).then(|| "static solve did not converge".to_string()),
    })
}

/// Point forces: (vertex, force in N).
pub(crate) type PointForces = Vec<(VertexId, V3)>;

/// The hemisphere load case: outward at 0° and 180°, inward at 90° and 270° on the equator
/// (radius `r`), each of size `p`. Returns the loads and the four vertices.
pub(crate) fn hemisphere_loads(
    mesh: &Mesh,
    r: f64,
    p: f64,
) -> Result<(PointForces, [VertexId; 4])> {
    let v = [
        vertex_at(mesh, V3::new(r, 0.0, 0.0))?,
        vertex_at(mesh, V3::new(-r, 0.0, 0.0))?,
        vertex_at(mesh, V3::new(0.0, r, 0.0))?,
        vertex_at(mesh, V3::new(0.0, -r, 0.0))?,
    ];
    let forces = vec![
        (v[0], V3::new(p, 0.0, 0.0)),
        (v[1], V3::new(-p, 0.0, 0.0)),
        (v[2], V3::new(0.0, -p, 0.0)),
        (v[3], V3::new(0.0, p, 0.0)),
    ];
    Ok((forces, v))
}

/// (pulled, pushed) radial displacements: half the change of the distance between the two
/// pulled (resp. pushed) load points; rigid motions do not change them.
pub(crate) fn hemisphere_displacements(x0: &[V3], x: &[V3], v: [VertexId; 4]) -> (f64, f64) {
    let dist = |y: &[V3], i: usize, j: usize| (y[v[i].idx()] - y[v[j].idx()]).norm();
    (
        0.5 * (dist(x, 0, 1) - dist(x0, 0, 1)),
        0.5 * (dist(x0, 2, 3) - dist(x, 2, 3)),
    )
}

fn hemisphere(mesh: Mesh, label: String, reference: f64, sff: SffKind) -> Result<Outcome> {
    let (r, t, e, nu, scale) = (10.0, 0.04, 6.825e7, 0.3, 1e-3);
    let faces = mesh.n_faces();
    let (point_forces, v) = hemisphere_loads(&mesh, r, 2.0 * scale)?;
    let x0 = mesh.positions().to_vec();
    let mut sys = unheld(
        mesh,
        sff,
        Material {
            thickness: t,
            young: e,
            poisson: nu,
            ..Material::paper()
        },
        point_forces,
    )?;
    let mut cfg = Config::of(&sys, x0.clone());
    let converged = equilibrium(&mut sys, &mut cfg);
    let (pulled, pushed) = hemisphere_displacements(&x0, &cfg.x, v);
    Ok(Outcome {
        mesh: label,
        faces,
        quantities: vec![
            Quantity::relative("pulled point (outward)", reference, pulled / scale),
            Quantity::relative("pushed point (inward)", reference, pushed / scale),
        ],
        converged,
        curves: Vec::<Curve>::new(),
        note: (!converged).then(|| "static solve did not converge".to_string()),
    })
}

fn hemisphere_hole(sff: SffKind, level: usize) -> Result<Outcome> {
    let (rings, around) = (8 << level, 32 << level);
    let mesh = generators::hemisphere_with_hole(10.0, 18f64.to_radians(), rings, around)?;
    hemisphere(
        mesh,
        format!("hemisphere with hole {rings}×{around}"),
        0.094,
        sff,
    )
}

fn hemisphere_closed(sff: SffKind, level: usize) -> Result<Outcome> {
    let rings = 8 << level;
    let mesh = generators::hemisphere(10.0, rings)?;
    hemisphere(mesh, format!("hemisphere, {rings} rings"), 0.0924, sff)
}
