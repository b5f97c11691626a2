//! Building the systems of the cases, static equilibria and load ramps that restart each load
//! level from the previous equilibrium.

use anyhow::Result;
use nalgebra::Vector3;
use thinshell_energy::{Material, RestState, SffKind};
use thinshell_mesh::{Mesh, VertexId};
use thinshell_solver::Static;
use thinshell_system::{Boundary, Loads, ShellSystem};

pub(crate) type V3 = Vector3<f64>;

pub(crate) use crate::accuracy::shell as system;

/// The shell of `mesh` whose rest shape is its stored shape (b̄ of the chosen form at φ = 0).
pub(crate) fn stress_free(
    mesh: Mesh,
    sff: SffKind,
    material: Material,
    boundary: Boundary,
    loads: Loads,
) -> Result<ShellSystem> {
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff)?;
    system(mesh, rest, sff, material, boundary, loads)
}

/// [`stress_free`] held only against rigid motion (the 3-2-1 pins of
/// `Boundary::rigid_motion_pins` at vertex 0, no reactions in a linear analysis) under point
/// forces (N) that must be self-equilibrated. Under large displacements these pins turn the
/// deformed shell against the dead loads and carry forces: see [`held_by_pins`].
pub(crate) fn unheld(
    mesh: Mesh,
    sff: SffKind,
    material: Material,
    point_forces: Vec<(VertexId, V3)>,
) -> Result<ShellSystem> {
    let pins = Boundary::rigid_motion_pins(&mesh, VertexId::new(0))?;
    held_by_pins(mesh, sff, material, pins, point_forces)
}

/// [`stress_free`] held only by the pinned coordinates `pins` (vertex, axis 0/1/2) under point
/// forces (N). Dead loads that sum to zero still have a moment about the deformed shape unless
/// that shape keeps the loads' symmetry and placement: pins that a symmetric state satisfies
/// without turning (coordinates that vanish on the symmetry planes) carry no force on the
/// symmetric branch, whereas 3-2-1 pins at arbitrary vertices turn the deformed shape as
/// far as the pinned vertices move relative to each other.
pub(crate) fn held_by_pins(
    mesh: Mesh,
    sff: SffKind,
    material: Material,
    pins: Vec<(VertexId, usize)>,
    point_forces: Vec<(VertexId, V3)>,
) -> Result<ShellSystem> {
    let boundary = Boundary {
        pinned_coordinates: pins,
        ..Boundary::default()
    };
    let loads = Loads {
        point_forces,
        ..Loads::default()
    };
    stress_free(mesh, sff, material, boundary, loads)
}

/// A configuration: positions and (edge-director forms) edge angles.
#[derive(Clone, Debug)]
pub(crate) struct Config {
    pub(crate) x: Vec<V3>,
    pub(crate) phi: Vec<f64>,
}

impl Config {
    pub(crate) fn of(sys: &ShellSystem, x: Vec<V3>) -> Config {
        Config {
            x,
            phi: vec![0.0; sys.n_edge_angles()],
        }
    }
}

/// Newton iterations per static solve before the ramp halves the load step.
const MAX_ITERATIONS: usize = 60;

/// The static equilibrium at the system's current load factor from `c` (overwritten by the
/// solution, or left unchanged on failure). Convergence is the solver's scale-free test on the
/// Newton correction (1e-12 of the model size), which is independent of the load size, so small
/// linear loads are solved as accurately as large ones. Returns whether it converged.
pub(crate) fn equilibrium(sys: &mut ShellSystem, c: &mut Config) -> bool {
    let mut st = Static::default();
    st.newton.max_iterations = MAX_ITERATIONS;
    let mut trial = c.clone();
    let ok = st
        .solve_with_angles(sys, &mut trial.x, &mut trial.phi)
        .is_ok()
        && trial.x.iter().all(|p| p.iter().all(|v| v.is_finite()));
    if ok {
        *c = trial;
    }
    ok
}

/// Static load stepping: equilibria at the load factors `levels` (ascending, > 0), each from
/// the previous equilibrium, with steps of at most `max_step` in between; a failed step is
/// halved (down to `max_step / 256`). `at(λ, config)` is called at every level reached.
/// Returns the load factor of the last equilibrium if the ramp stopped before the last level.
pub(crate) fn ramp(
    sys: &mut ShellSystem,
    c: &mut Config,
    levels: &[f64],
    max_step: f64,
    mut at: impl FnMut(&mut ShellSystem, f64, &Config) -> Result<()>,
) -> Result<Option<f64>> {
    let mut lambda = 0.0;
    let mut step = max_step;
    for &target in levels {
        while lambda < target - 1e-12 {
            let next = (lambda + step).min(target);
            sys.set_load_factor(next)?;
            if equilibrium(sys, c) {
                lambda = next;
                step = (2.0 * step).min(max_step);
            } else {
                step *= 0.5;
                if step < max_step / 256.0 {
                    sys.set_load_factor(lambda)?;
                    return Ok(Some(lambda));
                }
            }
        }
        at(sys, target, c)?;
    }
    Ok(None)
}

/// Consistent nodal forces (N) of a uniform pressure `q` (Pa) on a flat mesh: each face's
/// `q·area` shared equally by its three vertices, along `direction`.
pub(crate) fn uniform_nodal_forces(mesh: &Mesh, q: f64, direction: V3) -> Vec<(VertexId, V3)> {
    let x = mesh.positions();
    let mut f = vec![0.0; mesh.n_vertices()];
    for face in mesh.faces() {
        let p = |k: usize| x[face[k].idx()];
        let area = 0.5 * (p(1) - p(0)).cross(&(p(2) - p(0))).norm();
        for v in face {
            f[v.idx()] += q * area / 3.0;
        }
    }
    f.into_iter()
        .enumerate()
        .map(|(i, s)| (VertexId::new(i), direction * s))
        .collect()
}

/// The vertex of `mesh` at `p` (within 1e-9 of the mesh size), or an error naming the point.
pub(crate) fn vertex_at(mesh: &Mesh, p: V3) -> Result<VertexId> {
    let v = mesh.nearest_vertex(&p);
    let d = (mesh.positions()[v.idx()] - p).norm();
    if d > 1e-9 * mesh.bounding_box().diagonal() {
        anyhow::bail!("no vertex at {p:?} (nearest {d:.3e} away)");
    }
    Ok(v)
}
