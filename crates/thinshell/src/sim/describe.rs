//! [`Simulation::describe`]: what `thinshell check` prints.

use crate::scene::schema::{IntegratorKind, LoadRamp};
use crate::sim::Simulation;

impl Simulation {
    /// A few lines saying what a simulation will compute.
    pub fn describe(&self) -> String {
        let sim = self;
        let mesh = sim.mesh();
        let terms = sim.model().terms;
        let effects: Vec<&str> = sim.effects().iter().map(|e| e.key()).collect();
        let mut on = Vec::new();
        if terms.stretch {
            on.push("stretching");
        }
        let bending = format!("bending ({})", sim.model().sff.name().replace('_', " "));
        if terms.bend {
            on.push(&bending);
        }
        if terms.damping {
            on.push("Kelvin-Voigt damping");
        }
        let n_angles = sim.system().n_edge_angles();
        let n_coordinates = 3 * mesh.n_vertices() + n_angles;
        let mut text = format!(
            "scene: {}\nmesh: {} vertices, {} faces, {} edges\neffects: {}\nenergy terms evaluated: {}\nunknowns: {} (of {} coordinates; {} held){}\nintegrator: {:?}, dt = {:e} s, {} steps\n",
            sim.name(),
            mesh.n_vertices(),
            mesh.n_faces(),
            mesh.n_edges(),
            effects.join(", "),
            on.join(", "),
            sim.n_unknowns(),
            n_coordinates,
            n_coordinates - sim.n_unknowns(),
            if n_angles > 0 {
                let dofs = sim.system().dofs();
                let free_angles = dofs.n_free() - dofs.n_free_positions();
                if free_angles == n_angles {
                    format!(", including {n_angles} edge-director angles")
                } else {
                    // Free and clamped edges' directors are not unknowns (model.md §1.2-1.3).
                    format!(
                        ", including {free_angles} edge-director angles (the other {} edges are free or clamped: their directors are not unknowns)",
                        n_angles - free_angles
                    )
                }
            } else {
                String::new()
            },
            sim.integrator(),
            sim.dt(),
            sim.steps_total(),
        );
        let system = sim.system();
        let has_loads = *system.loads() != thinshell_system::Loads::default()
            || !system.boundary().prescribed.is_empty();
        if sim.is_path_following() {
            text += &format!(
                "path following: {} steps from load factor 0 (docs/path_following.md)\n",
                sim.steps_total()
            );
        } else if sim.integrator() == IntegratorKind::Static && has_loads {
            let ramp = sim.load_ramp();
            let n = sim.steps_total();
            let factors = match ramp {
                _ if n == 1 => "one step at full load".to_string(),
                LoadRamp::Linear => {
                    format!("load factor 1/{n}, 2/{n}, …, 1 over the {n} steps")
                }
                LoadRamp::None => "full loads from the first step".to_string(),
            };
            text += &format!("load ramp: {} ({factors})\n", ramp.key());
        }
        if let Some(c) = system.contact() {
            text += &c.describe();
        }
        let elastic = |e: thinshell_energy::EnergyTerms| e.stretch + e.bend;
        match sim.initial_energy_grown() {
            // With growth the first step solves against the grown rest forms, not those before
            // growth: the energy the first step starts from is the one that says how far it has to go.
            Some(grown) => {
                text += &format!(
                    "initial elastic energy at the grown rest state (what step 1 starts from): {:e} J\ninitial elastic energy against the rest forms before growth: {:e} J\n",
                    elastic(grown),
                    elastic(sim.energy()),
                );
            }
            None => text += &format!("initial elastic energy: {:e} J\n", elastic(sim.energy())),
        }
        text
    }
}
