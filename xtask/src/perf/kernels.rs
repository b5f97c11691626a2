//! Whole-mesh evaluation per face for every bending form, and the Hessian gather.
//!
//! One thread. The evaluation point is the perturbed one: the unit icosphere squashed
//! (y × 0.9) and rippled (z × (1 + 0.05 sin 7x)), rest state = the sphere itself, edge angles
//! φ_e = 0.01 cos(0.51 e) for the director forms (as in the `assembly` and `bending_forms`
//! benches), so nothing is trivially zero.

use std::cell::RefCell;
use std::rc::Rc;

use anyhow::{Context, Result};
use thinshell_energy::{
    Assembler, EvalOutput, HessianMode, Material, RestState, SffKind, ShellModel, Terms,
};
use thinshell_mesh::generators;
use thinshell_solver::faer::sparse::SparseColMat;
use thinshell_solver::nalgebra::Vector3;
use thinshell_system::{Boundary, Loads, ShellSystem};

use super::facts::Facts;
use super::measure::{Measure, Sizes, pool};

/// What each per-face measure evaluates: (id suffix, gradient, Hessian).
pub(crate) const EVALS: [(&str, bool, bool); 3] = [
    ("energy", false, false),
    ("energy_gradient", true, false),
    ("energy_gradient_hessian", true, true),
];

/// Id of a per-face measure.
pub(crate) fn id(sff: SffKind, what: &str) -> String {
    format!("per_face/{}/{what}", sff.name())
}

/// Id of the gather measure.
pub(crate) const GATHER: &str = "gather/mid_edge_average";

struct Eval {
    model: ShellModel,
    rest: RestState,
    x: Vec<Vector3<f64>>,
    phi: Vec<f64>,
    assembler: Assembler,
    gradient: Vec<f64>,
    hessian: SparseColMat<usize, f64>,
}

impl Eval {
    fn run(&mut self, gradient: bool, hessian: bool) -> Result<()> {
        let out = EvalOutput {
            gradient: if gradient {
                Some(&mut self.gradient)
            } else {
                None
            },
            hessian: if hessian {
                Some((&mut self.hessian, HessianMode::Exact))
            } else {
                None
            },
        };
        let e = self.assembler.evaluate_with_angles(
            &self.model,
            &self.x,
            &self.phi,
            &self.rest,
            None,
            out,
        )?;
        std::hint::black_box(e);
        Ok(())
    }
}

/// Adds the per-face and gather measures at `sizes.per_face`.
pub(crate) fn measures(sizes: &Sizes, out: &mut Vec<Measure>, facts: &mut Facts) -> Result<()> {
    let level = sizes.per_face;
    let one = pool(1)?;
    for sff in SffKind::ALL {
        let mesh = generators::icosphere(1.0, level)?;
        let faces = mesh.n_faces();
        let rest = RestState::from_mesh(&mesh, mesh.positions(), sff)?;
        let x: Vec<Vector3<f64>> = mesh
            .positions()
            .iter()
            .map(|p| Vector3::new(p.x, p.y * 0.9, p.z * (1.0 + 0.05 * (7.0 * p.x).sin())))
            .collect();
        let model = ShellModel {
            material: Material::paper(),
            terms: Terms::ELASTIC,
            sff,
        };
        let sys = ShellSystem::new(
            mesh,
            model,
            rest.clone(),
            Boundary::default(),
            Loads::default(),
        )
        .with_context(|| format!("sphere system ({})", sff.name()))?;
        let phi: Vec<f64> = (0..sys.n_edge_angles())
            .map(|e| 0.01 * (e as f64 * 0.51).cos())
            .collect();
        let assembler = Assembler::for_model(sys.mesh(), sys.dofs(), &model)?;
        let eval = Rc::new(RefCell::new(Eval {
            gradient: vec![0.0; assembler.n_coordinates()],
            hessian: assembler.hessian_template(),
            model,
            rest,
            x,
            phi,
            assembler,
        }));
        facts.per_face_faces = faces;
        facts.unknowns.insert(
            format!("per_face/{}", sff.name()),
            eval.borrow().assembler.n_free(),
        );
        for (what, g, h) in EVALS {
            let e = Rc::clone(&eval);
            let p = one.clone();
            out.push(Measure {
                id: id(sff, what),
                parts: vec!["total"],
                per: faces as f64,
                action: Box::new(move || {
                    let mut guard = e.borrow_mut();
                    let e: &mut Eval = &mut guard;
                    let t = std::time::Instant::now();
                    p.install(|| e.run(g, h))?;
                    Ok(vec![t.elapsed().as_secs_f64()])
                }),
            });
        }
        if sff == SffKind::MidEdgeAverage {
            // The gather alone (per-face blocks → matrix values), from the Hessian evaluation
            // above: the counterpart of libshell's triplets → sparse matrix.
            let e = Rc::clone(&eval);
            let p = one.clone();
            out.push(Measure {
                id: GATHER.to_string(),
                parts: vec!["total"],
                per: 1.0,
                action: Box::new(move || {
                    let mut e = e.borrow_mut();
                    let e = &mut *e;
                    let t = std::time::Instant::now();
                    p.install(|| e.assembler.gather_hessian(&mut e.hessian))?;
                    Ok(vec![t.elapsed().as_secs_f64()])
                }),
            });
        }
    }
    Ok(())
}
