//! Rest-state growth for thin shells (model.md §4–4.1): the environment (heat, moisture,
//! growth) changes a shell's rest forms (ā, b̄), and the elastic solver follows.
//!
//! - [`GrowthModel`]s compute a face's rest forms from its initial forms (a⁰, b⁰) and its
//!   [`FaceStimulus`] (m⁺ at the top surface, m⁻ at the bottom): [`NoGrowth`], [`Isotropic`]
//!   (conformal factor s, b̄ exponent p), [`Swelling`] with a [`Profile::Linear`] or
//!   [`Profile::PiecewiseConstant`] (bilayer) profile through the thickness, optionally
//!   anisotropic along a per-face material direction ([`Anisotropy`]).
//! - [`StimulusField`]s say where the stimulus comes from: [`Prescribed`] (constant, by
//!   [`Region`], or a function of time and position), the seed's [`DirectedHeat`], or
//!   [`Diffusion`] through the thickness on the prism mesh (wedge elements, backward Euler,
//!   matrix factored once).
//! - [`Growth`] couples the two for a caller that owns the time loop: rest forms from the
//!   current stimulus → the caller's elastic step → stimulus step, recomputing only what changed;
//!   [`mass_with_uptake`] when the stimulus adds mass.
//!
//! Units are SI; forms are 2×2 matrices in each face's barycentric basis
//! `(x_j − x_i, x_k − x_i)` of the initial mesh (ā in m², b̄ in m), sign convention of model.md
//! §1 (b ≈ −a/r on a sphere with outward normals).
//!
//! The seed's sphere under uniform heat (ā = 0.9 a⁰ on every face) with the solver crate:
//!
//! ```
//! use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
//! use thinshell_growth::{FaceStimulus, Growth, Isotropic, Prescribed};
//! use thinshell_mesh::generators;
//! use thinshell_solver::{ImplicitEuler, Integrator, State};
//! use thinshell_system::{Boundary, Loads, ShellSystem};
//!
//! let mesh = generators::icosphere(1.0, 2)?; // 162 vertices, 320 faces
//! let sff = SffKind::MidEdgeAverage;
//! let initial = RestState::from_mesh(&mesh, mesh.positions(), sff)?;
//! let material = Material::paper();
//! let s = 0.9f64.ln() / 2.0; // ā = e^{2s} a⁰ = 0.9 a⁰
//! let field = Prescribed::uniform(mesh.n_faces(), FaceStimulus::uniform(s))?;
//! let mut growth = Growth::new(Box::new(Isotropic::SEED), Box::new(field), initial.clone(),
//!                              material.thickness)?;
//!
//! let model = ShellModel { material, terms: Terms::ALL, sff };
//! let x0 = mesh.positions().to_vec();
//! let mut system = ShellSystem::new(mesh, model, initial, Boundary::default(), Loads::default())?;
//! let mut state = State::at_rest(x0);
//! let mut step = ImplicitEuler::new(1e-4);
//! for _ in 0..3 {
//!     let mut rest = system.rest().clone();
//!     growth.update_rest(&mut rest)?; // rest forms from the current stimulus
//!     system.set_rest(rest)?;
//!     step.step(&mut system, &mut state)?; // elastic step
//!     growth.advance(state.t, 1e-4)?; // stimulus step (constant here: nothing to do)
//! }
//! assert_eq!(growth.rest_updates(), 1); // a constant stimulus is applied once
//! assert!((system.rest().a_bar[0] - 0.9 * growth.initial().a_bar[0]).norm() < 1e-15);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! A moisture-curling strip (diffusion from the top face, linear swelling) is set up the same
//! way with [`Swelling::linear`] and a [`Diffusion`] field; see the crate README.

mod coupling;
mod diffusion;
mod error;
mod field;
mod mass;
mod model;
mod region;
mod stimulus;

pub use coupling::{Growth, GrowthState};
pub use diffusion::{Diffusion, DiffusionSettings, DiffusionSource, SourceKind, Surface};
pub use error::GrowthError;
pub use field::{DirectedHeat, Prescribed, StimulusField, StimulusFn};
pub use mass::mass_with_uptake;
pub use model::{Anisotropy, GrowthModel, Isotropic, NoGrowth, Profile, Swelling, apply_growth};
pub use region::Region;
pub use stimulus::FaceStimulus;

// The linear-algebra crates of the public types (nalgebra vectors and forms, faer sparse
// matrices), re-exported so that a dependent crate uses the same versions and features.
pub use faer;
pub use nalgebra;

/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
