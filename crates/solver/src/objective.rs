//! The function Newton minimises.

use faer::sparse::SparseColMat;

use crate::SolverError;

/// What [`Objective::begin_iteration`] changed in the objective.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IterationUpdate {
    /// f (and so ∇f, the Hessian) is no longer the function of the earlier iterations, e.g. a
    /// barrier stiffness was raised.
    pub value_changed: bool,
    /// [`hessian_template`](Objective::hessian_template) now returns another pattern, e.g.
    /// contact pairs came near that couple unknowns the old pattern did not.
    pub pattern_changed: bool,
}

/// A twice differentiable scalar function of `n_dofs` unknowns with a sparse Hessian.
///
/// Implementations: the incremental potential of implicit Euler, the total potential of a
/// static solve, and synthetic objectives in tests. Conventions:
/// - `x`, gradients: flat slices of length [`n_dofs`](Objective::n_dofs) (free dofs only);
/// - the Hessian is a faer `SparseColMat<usize, f64>` holding the **lower triangle only**
///   (row ≥ column, every diagonal entry present), with the pattern of
///   [`hessian_template`](Objective::hessian_template), which must not change between calls;
///   [`hessian`](Objective::hessian) overwrites its values;
/// - [`value`](Objective::value) and [`gradient`](Objective::gradient) must return the same
///   value at the same `x`.
///
/// A trial point where the function is undefined (e.g. an inverted element) may return
/// `Ok(f64::INFINITY)` or NaN from `value`: the line search then backtracks. An `Err` aborts
/// the solve.
pub trait Objective {
    /// Number of unknowns.
    fn n_dofs(&self) -> usize;

    /// Value f(x) (J for energies).
    fn value(&mut self, x: &[f64]) -> Result<f64, SolverError>;

    /// Writes ∇f(x) into `g` (overwritten) and returns f(x).
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<f64, SolverError>;

    /// Overwrites the values of `h` (a matrix with the template's pattern) with ∇²f(x), lower
    /// triangle.
    fn hessian(&mut self, x: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError>;

    /// Whether [`psd_hessian`](Objective::psd_hessian) is a distinct positive semi-definite
    /// approximation (default `false`: the adaptive Newton of
    /// [`HessianPolicy::Adaptive`](crate::HessianPolicy::Adaptive) then behaves like
    /// [`HessianPolicy::Fixed`](crate::HessianPolicy::Fixed)).
    fn has_psd_hessian(&self) -> bool {
        false
    }

    /// Overwrites the values of `h` with a positive semi-definite approximation of ∇²f(x) (e.g.
    /// Gauss–Newton), lower triangle, same pattern. Default: [`hessian`](Objective::hessian).
    fn psd_hessian(
        &mut self,
        x: &[f64],
        h: &mut SparseColMat<usize, f64>,
    ) -> Result<(), SolverError> {
        self.hessian(x, h)
    }

    /// The Hessian's sparsity pattern (lower triangle, every diagonal present); values ignored.
    fn hessian_template(&self) -> SparseColMat<usize, f64>;

    /// Typical magnitude of a gradient entry (N for energies): reported residuals are relative to
    /// it, and so is the gradient tolerance when [`gradient_test`](Objective::gradient_test)
    /// holds. Must be positive and finite.
    fn force_scale(&self) -> f64;

    /// Whether `‖∇f‖∞ ≤ gradient_tolerance · force_scale` may end a solve (default `true`). An
    /// objective whose force scale is only a reporting unit (not a meaningful size of its
    /// forces) returns `false`: it then converges on the Newton correction or at round-off only
    /// (see [`newton_solve`](crate::newton_solve)).
    fn gradient_test(&self) -> bool {
        true
    }

    /// Typical length (m) the step tolerance is relative to (e.g. the size of the body). Default 1.
    fn length_scale(&self) -> f64 {
        1.0
    }

    /// Per-dof coordinates (m) for the geometric nested-dissection ordering, if the unknowns have
    /// positions (the three dofs of a vertex share its position). Default `None`: a graph-based
    /// nested dissection is used instead.
    fn dof_coordinates(&self) -> Option<Vec<[f64; 3]>> {
        None
    }

    /// The constant (in the Hessian's units) the last [`hessian`](Objective::hessian) or
    /// [`psd_hessian`](Objective::psd_hessian) call added to every diagonal entry with no
    /// counterpart in f (e.g. a static solve's shift against the rigid-motion null space of an
    /// unheld shell). Newton factorises the shifted matrix but uses it only as the
    /// preconditioner of CG on the unshifted one, so that the shift slows neither convergence
    /// on soft modes nor hides their curvature. Default 0.
    fn hessian_diagonal_shift(&self) -> f64 {
        0.0
    }

    /// Directions (in the free unknowns) along which f is invariant to second order at an
    /// equilibrium `x`, e.g. the rigid motions of an unheld shell: the stability analysis
    /// ([`NewtonWorkspace::stability`](crate::NewtonWorkspace::stability)) leaves them out, since
    /// their zero eigenvalues say nothing about stability. Default: none.
    fn rigid_modes(&mut self, _x: &[f64]) -> Vec<Vec<f64>> {
        Vec::new()
    }

    /// Largest fraction α ∈ (0, 1] of the step `dx` from `x` that the objective admits (e.g.
    /// contact: the step stops before any pair of primitives crosses, by continuous collision
    /// detection). Every line search and trust-region step starts from at most this fraction.
    /// Default 1 (no limit). Must return a finite α > 0; anything else fails the solve.
    fn max_step(&mut self, _x: &[f64], _dx: &[f64]) -> Result<f64, SolverError> {
        Ok(1.0)
    }

    /// Called by [`newton_solve`](crate::newton_solve) at the start of every iteration (the
    /// first included), at the current iterate `x`, before the convergence tests: the one
    /// place where the objective may change itself during a solve. Contract:
    /// - everything else (value, gradient, Hessian, step limit) must describe one fixed
    ///   function between two calls; a change made here is reported in the returned
    ///   [`IterationUpdate`], and nothing changes without being reported;
    /// - `value_changed`: Newton re-evaluates f and ∇f at `x` (replacing the iterate's
    ///   recorded residual and value, so the convergence tests judge the new function), drops
    ///   the factor kept for reuse and the watchdog's earlier point (neither compares with the
    ///   new function);
    /// - `pattern_changed`: Newton re-analyses the new [`hessian_template`](Objective::hessian_template)
    ///   (a new symbolic factorisation; the workspace keeps its regularisation memory, progress
    ///   hook and cancel flag) and proceeds as for `value_changed`. The new pattern must still
    ///   hold every diagonal entry;
    /// - the result must depend only on `x`, `iteration` and the objective's state, so that a
    ///   solve repeated from the same state repeats exactly.
    ///
    /// Default: no change. The shell objective uses it to widen its Hessian pattern when
    /// contact pairs came near mid-solve that the last Hessian could only approximate
    /// (model.md §7).
    fn begin_iteration(
        &mut self,
        _x: &[f64],
        _iteration: usize,
    ) -> Result<IterationUpdate, SolverError> {
        Ok(IterationUpdate::default())
    }
}
