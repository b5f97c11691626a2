//! Inverse design of thin shells (issue #41): which rest forms — growth pattern — make the
//! static equilibrium take a target shape.
//!
//! - [`Forward`]: the forward map rest forms → static equilibrium x*(p) (positions and edge
//!   angles) of a `thinshell_system::ShellSystem`, warm-started, with the two adjoint pieces;
//!   the only module that talks to the solver;
//! - [`Parametrisation`] (one trait, one file per kind): [`RestForms`], [`Isotropic`],
//!   [`BilayerGrowth`], each with bounds per parameter;
//! - [`ShapeObjective`]: [`TargetPositions`] (same connectivity, optionally modulo rigid
//!   motion), [`ClosestPoint`] (a target mesh of any connectivity), [`UserObjective`]; plus the
//!   Laplacian [`Smoothness`] term;
//! - [`Design`]: the exact gradient by the adjoint, H λ = ∂J/∂x with the equilibrium's exact
//!   Hessian and dJ/dp = ∂J/∂p − λᵀ ∂²E/∂x∂p (the energy crate's rest-form mixed derivatives,
//!   `thinshell_energy::rest_sensitivity`), and the bounded quasi-Newton loop (L-BFGS-B);
//! - [`algebraic`]: the algebraic bilayer design of van Rees, Vouga & Mahadevan (PNAS 2017).
//!
//! The derivation, the parametrisations and measured results are in docs/design.md.

pub mod algebraic;
mod design;
mod error;
pub mod forward;
pub mod objective;
pub mod param;
mod pins;

pub use design::{Design, DesignResult, DesignSettings, Evaluation, HistoryRow, Outcome};
pub use error::DesignError;
pub use forward::{Equilibrium, Forward};
pub use objective::{
    ClosestPoint, ShapeObjective, Smoothness, TargetPositions, UserObjective, best_rigid_motion,
};
pub use param::{BilayerGrowth, Isotropic, Parametrisation, RestForms, Support};
pub use pins::planar_rigid_pins;
