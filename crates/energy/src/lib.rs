//! Discrete Kirchhoff–Love shell energies (model.md §1–2): stretching, bending and
//! Kelvin–Voigt damping of a triangle mesh, with exact gradients and Hessians.
//!
//! Two layers:
//! - **per-face kernels** — pure functions on fixed-size arrays, in dependency order:
//!   [`face_stencil`] (the plain face data: [`FaceStencil`] with positions, flap flags and
//!   [`EdgeAngles`]); one file per formula: [`membrane_strain`] (the metric a and its
//!   derivatives), [`stvk_quadratic`] (the St. Venant–Kirchhoff quadratic: matrix, K·d, value),
//!   [`damping`] (Kelvin–Voigt); [`sff`] (the [`SecondFundamentalForm`]`<N>` trait giving b,
//!   its 3×N Jacobian and contracted Hessian over a face's N dofs: [`MidEdgeAverage`], N = 18,
//!   and the edge directors [`EdgeDirector`], N = 21 with one angle per edge, model.md §1.1;
//!   chosen by [`SffKind`]); [`material`] (the [`ElasticLaw`] trait — energy, 6-gradient and
//!   6×6 Hessian in the form entries a, b — with [`StVK`], [`NeoHookean`], [`Bilayer`] and [`TensionField`],
//!   chosen by [`MaterialModel`]; every law is evaluated through it); and [`eval_face`], the
//!   one chain rule from (form, law) to a face's energy, N-gradient and N×N Hessian (exact,
//!   Gauss–Newton or projected to PSD, [`HessianMode`]);
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
//! let terms = Terms::ELASTIC;
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
//! use thinshell_energy::{
//!     eval_face, DirectorVariant, EdgeDirector, FaceEval, FaceRest, FaceStencil, HessianMode,
//!     Material, MaterialModel, MidEdgeAverage, Terms, Want,
//! };
//! let x = [Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::new(1.0, 1.0, 0.0),
//!          Vector3::new(-1.0, 1.0, 0.0), Vector3::new(1.0, -1.0, 0.0)];
//! let stencil = FaceStencil::new(x, [true; 3]);
//! let rest = FaceRest { a_bar: Matrix2::identity(), b_bar: Matrix2::zeros() };
//! let want = Want { gradient: true, hessian: Some(HessianMode::Exact) };
//! // Mid-edge average form (18 dofs), neo-Hookean material.
//! let material = Material::paper().with_model(MaterialModel::NeoHookean);
//! let mut out = FaceEval::default();
//! eval_face(&MidEdgeAverage, &material, &stencil, &rest, None, Terms::ELASTIC, want, &mut out);
//! assert!(out.energy.total().abs() < 1e-12); // flat sheet at rest
//! // Edge-director form (21 dofs: positions, then the three edge angles).
//! let mut out21 = FaceEval::<21>::default();
//! let form = EdgeDirector { variant: DirectorVariant::Tan };
//! eval_face(&form, &Material::paper(), &stencil, &rest, None, Terms::ELASTIC, want, &mut out21);
//! assert!(out21.gradient.norm() < 1e-9);
//! ```

pub mod assembly;
pub mod damping;
pub mod dofs;
pub mod error;
pub mod face_stencil;
pub mod kernel;
pub mod mass;
pub mod material;
pub mod membrane_strain;
pub mod model;
pub(crate) mod real;
pub mod rest;
pub mod rest_sensitivity;
pub mod sff;
pub mod small_matrix;
pub mod stencil_table;
pub mod stvk_quadratic;
// Private: its types have one public path, the crate root.
mod terms;

pub use assembly::{Assembler, EvalOutput, FaceForms};
pub use damping::FaceDamping;
pub use dofs::DofMap;
pub use error::EnergyError;
pub use face_stencil::{EdgeAngles, EdgeClamp, FaceStencil, edge_signs};
pub use kernel::{FaceEval, FaceRest, Want, eval_face, eval_face_energy};
pub use mass::lumped_mass;
pub use material::{
    Bilayer, ElasticLaw, EnergyConstants, FaceGeometry, LawEval, Layer, Material, MaterialModel,
    NeoHookean, Order, StVK, TensionField,
};
pub use membrane_strain::first_fundamental_form;
pub use model::ShellModel;
pub use rest::{DampingState, RestState};
pub use rest_sensitivity::face_rest_mixed;
pub use sff::{
    DIRECTOR_DOFS, DirectorVariant, EdgeDirector, MidEdgeAverage, SecondFundamentalForm, SffKind,
};
pub use small_matrix::{ProjectPsd, project_psd};
pub use stencil_table::{Stencils, fitted_free_edges};
pub use terms::{EnergyTerms, HessianMode, Terms};

// The linear-algebra crates of the public types (nalgebra vectors and forms, faer sparse
// matrices), re-exported so that a dependent crate uses the same versions and features.
pub use faer;
pub use nalgebra;

/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
