//! A `Simulation`'s energy (value, gradient, Hessian) at its own state and its natural modes:
//! the Rust side of `Simulation.energy()` and `Simulation.modes()` (docs/modal.md).

use nalgebra::Vector3;
use thinshell::sim::Simulation;
use thinshell_energy::{EvalOutput, HessianMode, ShellModel, Terms};
use thinshell_solver::SolverError;
use thinshell_system::Modes;

/// Energy terms, full gradient and the Hessian as full symmetric COO triplets over all
/// coordinates (3·n_vertices, then one per edge with edge unknowns).
pub(crate) struct StateEnergy {
    pub stretch: f64,
    pub bend: f64,
    pub gradient: Vec<f64>,
    pub rows: Vec<i64>,
    pub cols: Vec<i64>,
    pub vals: Vec<f64>,
    pub n: usize,
    pub edge_angles: Vec<f64>,
}

/// The simulation's elastic energy (no damping, no loads) at its positions and edge angles
/// (the state's, when it has one per edge; else the minimising ones), with the gradient over
/// all coordinates and, when `hessian`, the Hessian over the unknowns (held coordinates' rows
/// and columns are empty), clamped directors held as the simulation holds them.
pub(crate) fn state_energy(
    sim: &mut Simulation,
    hessian: bool,
) -> Result<StateEnergy, SolverError> {
    let x: Vec<Vector3<f64>> = sim.positions().to_vec();
    let state_phi = sim.edge_angles().to_vec();
    let system = sim.system_mut();
    let phi = if !system.has_edge_unknowns() {
        Vec::new()
    } else if state_phi.len() == system.n_edge_angles() {
        state_phi
    } else {
        system.energy(&x)?;
        system.edge_angles().to_vec()
    };
    let model = ShellModel {
        terms: Terms {
            damping: false,
            ..system.model().terms
        },
        ..*system.model()
    };
    let mut assembler = system.assembler_for(&model)?;
    let mut gradient = vec![0.0; assembler.n_coordinates()];
    let mut h = assembler.hessian_template();
    let e = assembler.evaluate_with_angles(
        &model,
        &x,
        &phi,
        system.rest(),
        None,
        EvalOutput {
            gradient: Some(&mut gradient),
            hessian: hessian.then_some((&mut h, HessianMode::Exact)),
        },
    )?;
    let coords = system.dofs().free_coordinates();
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    if hessian {
        let (col_ptr, row_idx, values) = (h.col_ptr(), h.row_idx(), h.val());
        for c in 0..h.ncols() {
            for k in col_ptr[c]..col_ptr[c + 1] {
                let (i, j) = (coords[row_idx[k]] as i64, coords[c] as i64);
                rows.push(i);
                cols.push(j);
                vals.push(values[k]);
                if i != j {
                    rows.push(j);
                    cols.push(i);
                    vals.push(values[k]);
                }
            }
        }
    }
    let n = gradient.len();
    Ok(StateEnergy {
        stretch: e.stretch,
        bend: e.bend,
        gradient,
        rows,
        cols,
        vals,
        n,
        edge_angles: phi,
    })
}

/// The `count` lowest natural modes about the simulation's current state
/// ([`thinshell::modes::simulation_modes`]).
pub(crate) fn state_modes(sim: &mut Simulation, count: usize) -> Result<Modes, SolverError> {
    thinshell::modes::simulation_modes(sim, count)
}
