//! Newton's method, sparse Cholesky, fill-reducing orderings, path following and time
//! integrators over any model: the numerics of thinshell, with no shell type in it.
//!
//! - [`Objective`]: a scalar function of `n` unknowns with gradient and sparse Hessian (lower
//!   triangle, faer `SparseColMat`), e.g. the incremental potential of implicit Euler;
//! - [`newton_solve`]: Newton's method with backtracking Armijo line search, an adaptive
//!   Hessian ([`HessianPolicy`]: exact where positive definite, the objective's PSD Hessian
//!   elsewhere, each iteration's choice reported), diagonal regularisation, and scale-free
//!   convergence on the Newton correction (plus a gradient test where the objective's force
//!   scale is meaningful); failures are typed ([`SolverError`]) and carry the residual history
//!   and the last accepted iterate;
//! - [`linear::SparseCholesky`]: faer's supernodal LLᵀ with the symbolic analysis done once per
//!   pattern and all memory reused;
//! - [`ordering`]: AMD, METIS nested dissection (the default) or a geometric nested dissection
//!   ([`Ordering`]);
//! - [`path`]: path following past limit points and snap-backs — arc-length continuation
//!   (Riks/Crisfield) and displacement control ([`PathTracer`] on any [`LoadedObjective`];
//!   `ShellPath` in `thinshell-system` on a shell), with the stability of every point from the inertia of the
//!   tangent ([`ldlt::SparseLdlt`]);
//! - [`integrate`]: time integration over any [`Model`] (point masses with massless extra
//!   unknowns; a shell is `thinshell-system`'s `ShellSystem`): [`Static`], [`ImplicitEuler`]
//!   (incremental potential, model.md §3), [`ExplicitEuler`] (symplectic), and what happens
//!   after a failed solve (`integrate/retry.rs`: the fallback Hessian, Δt halving, the one
//!   continuation walk);
//! - [`nalgebra`] and [`faer`], re-exported: the versions of the public API's types.
//!
//! Minimise `f(x) = Σ (x_i − i)⁴/4 + x_i²/2` (a diagonal Hessian):
//!
//! ```
//! use faer::sparse::{SparseColMat, Triplet};
//! use thinshell_solver::{newton_solve, NewtonSettings, NewtonWorkspace, Objective, SolverError};
//!
//! struct Quartic(usize);
//! impl Objective for Quartic {
//!     fn n_dofs(&self) -> usize { self.0 }
//!     fn value(&mut self, x: &[f64]) -> Result<f64, SolverError> {
//!         Ok(x.iter().enumerate().map(|(i, v)| (v - i as f64).powi(4) / 4.0 + v * v / 2.0).sum())
//!     }
//!     fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
//!         for (i, (gi, v)) in g.iter_mut().zip(x).enumerate() {
//!             *gi = (v - i as f64).powi(3) + v;
//!         }
//!         self.value(x)
//!     }
//!     fn hessian(&mut self, x: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
//!         // One entry per column: the diagonal.
//!         for (i, (hi, v)) in h.val_mut().iter_mut().zip(x).enumerate() {
//!             *hi = 3.0 * (v - i as f64).powi(2) + 1.0;
//!         }
//!         Ok(())
//!     }
//!     fn hessian_template(&self) -> SparseColMat<usize, f64> {
//!         let t: Vec<_> = (0..self.0).map(|i| Triplet::new(i, i, 0.0)).collect();
//!         SparseColMat::try_new_from_triplets(self.0, self.0, &t).unwrap()
//!     }
//!     fn force_scale(&self) -> f64 { 1.0 }
//! }
//!
//! let mut f = Quartic(4);
//! let settings = NewtonSettings::default();
//! let mut ws = NewtonWorkspace::new(&f, &settings)?;
//! let mut x = vec![0.0; 4];
//! let report = newton_solve(&mut f, &mut x, &settings, &mut ws)?;
//! // Stationary: (x − i)³ + x = 0; for i = 2 the root is x = 1.
//! assert!((x[2] - 1.0).abs() < 1e-8);
//! assert!(report.residuals.last().unwrap() <= &settings.gradient_tolerance);
//! # Ok::<(), SolverError>(())
//! ```

// The linear-algebra crates of the public API (positions are nalgebra vectors, Hessians faer
// sparse matrices), re-exported so that a dependent crate uses the same versions and features.
pub use faer;
pub use nalgebra;

pub(crate) mod curvature;
pub(crate) mod descent;
pub mod error;
pub mod integrate;
pub mod iterative;
pub mod ldlt;
pub mod linear;
pub mod memory;
pub mod newton;
pub mod objective;
pub mod ordering;
pub mod path;
pub mod progress;

pub use error::{PathFailure, SolverError};
pub use linear::{FactorStats, RegularizationKind, RegularizationParams, SparseCholesky};
pub use newton::{
    Convergence, HessianPolicy, IterationHessian, IterativeFallback, KeptFactor, LinearSolver,
    NewtonReport, NewtonSettings, NewtonTimings, NewtonWorkspace, RegularizationEvent, Stability,
    WANDERING_STEPS, newton_solve,
};
pub use objective::{IterationUpdate, Objective};
pub use ordering::Ordering;
pub use path::{LoadedObjective, PathControl, PathPoint, PathSettings, PathTracer};
pub use progress::{CancelFlag, NewtonProgress, ProgressHook};
/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

pub use integrate::{
    ExplicitEuler, ImplicitEuler, Integrator, MAX_CONTINUATION_HALVINGS, Model, NewtonCache,
    ObjectiveOptions, Origin, State, Static, StepControl, StepKind, StepObjective, StepReport,
};
