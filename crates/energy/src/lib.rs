//! Discrete Kirchhoff–Love shell energies (model.md §1–2): stretching, bending and
//! Kelvin–Voigt damping of a triangle mesh, with exact gradients and Hessians.
//!
//! Two layers:
//! - **per-face kernels** — pure functions on fixed-size arrays: [`first_fundamental_form`],
//!   the [`SecondFundamentalForm`] trait ([`MidEdgeAverage`]), the quadratic energy densities
//!   ([`density`]) and [`eval_face`], which returns a face's energy, 18-gradient and 18×18
//!   Hessian (exact, Gauss–Newton or projected to PSD, [`HessianMode`]); the edge-director
//!   form [`EdgeDirector`] (model.md §1.1, one angle per edge) with its bending kernel
//!   [`eval_director_bend`] over 21 face dofs and the edge signs [`edge_signs`], selected for a
//!   whole mesh by [`SffKind::EdgeDirector`];
//! - **whole mesh** — [`RestState`] (ā, b̄ per face), [`DampingState`], [`lumped_mass`],
//!   [`DofMap`] (pinned coordinates; edge angles with [`DofMap::with_edges`]) and
//!   [`Assembler`] ([`Assembler::for_model`] for edge directors), which builds the lower-triangular
//!   Hessian pattern over the free dofs once and refills it in place at every evaluation,
//!   in parallel and bit-identically for any number of threads.
//!
//! Units are SI (m, Pa, kg, s, J); forms are 2×2 matrices in each face's barycentric basis
//! `(x_j − x_i, x_k − x_i)`; flat coordinate vectors are vertex-major (`x0, y0, z0, x1, …`).
//!
//! Energy, gradient and Hessian of a deformed sphere in a few lines:
//!
//! ```
//! use thinshell_energy::{
//!     Assembler, DofMap, EvalOutput, HessianMode, Material, RestState, SffKind, ShellModel, Terms,
//! };
//! use nalgebra::Vector3;
//! use thinshell_mesh::generators;
//!
//! let mesh = generators::icosphere(0.1, 2)?; // 162 vertices, 320 faces, radius 0.1 m
//! let sff = SffKind::MidEdgeAverage;
//! let rest = RestState::from_mesh(&mesh, mesh.positions(), sff)?; // stress-free as built
//! let terms = Terms { stretch: true, bend: true, damping: false };
//! let model = ShellModel { material: Material::paper(), terms, sff };
//! let mut assembler = Assembler::new(&mesh, &DofMap::all_free(mesh.n_vertices()), terms)?;
//!
//! // Squash the sphere by 10 % along z.
//! let x: Vec<_> = mesh.positions().iter().map(|p| Vector3::new(p.x, p.y, 0.9 * p.z)).collect();
//! let mut gradient = vec![0.0; 3 * mesh.n_vertices()];
//! let mut hessian = assembler.hessian_template(); // allocate once, refill every iteration
//! let energy = assembler.evaluate(&model, &x, &rest, None, EvalOutput {
//!     gradient: Some(&mut gradient),
//!     hessian: Some((&mut hessian, HessianMode::Exact)),
//! })?;
//! assert!(energy.stretch > 0.0 && energy.bend > 0.0);
//! assert_eq!(hessian.nrows(), 3 * mesh.n_vertices());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! One face on its own (the kernel layer):
//!
//! ```
//! use nalgebra::{Matrix2, Vector3};
//! use thinshell_energy::{eval_face, FaceEval, FaceRest, FaceStencil, HessianMode, Material, SffKind, Terms, Want};
//! let x = [Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::new(1.0, 1.0, 0.0),
//!          Vector3::new(-1.0, 1.0, 0.0), Vector3::new(1.0, -1.0, 0.0)];
//! let stencil = FaceStencil { x, flap: [true; 3] };
//! let rest = FaceRest { a_bar: Matrix2::identity(), b_bar: Matrix2::zeros() };
//! let mut out = FaceEval::default();
//! eval_face(SffKind::MidEdgeAverage.as_dyn(), &Material::paper(), &stencil, &rest, None, Terms::ALL,
//!           Want { gradient: true, hessian: Some(HessianMode::Exact) }, &mut out);
//! assert!(out.energy.total().abs() < 1e-12); // flat sheet at rest
//! ```

pub mod assembly;
pub mod density;
pub mod director;
pub mod dofs;
pub mod error;
pub mod forms;
pub mod kernel;
pub mod mass;
pub mod material;
pub mod rest;
pub mod sff;
pub mod shell;
pub mod stencils;

pub use assembly::{Assembler, EvalOutput};
pub use director::{DirectorFaceEval, edge_signs, eval_director_bend};
pub use dofs::DofMap;
pub use error::EnergyError;
pub use forms::first_fundamental_form;
pub use kernel::{
    EnergyTerms, FaceDamping, FaceEval, FaceRest, FaceStencil, HessianMode, Terms, Want, eval_face,
};
pub use mass::lumped_mass;
pub use material::Material;
pub use rest::{DampingState, RestState};
pub use sff::{
    DirectorVariant, EdgeAngles, EdgeDirector, MidEdgeAverage, SecondFundamentalForm, SffKind,
};
pub use shell::ShellModel;
pub use stencils::Stencils;

/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
