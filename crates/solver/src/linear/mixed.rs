//! Mixed precision: the factorisation in single precision (f32: twice the dense kernels' rate,
//! half the factor's memory traffic) and every solve refined to double-precision accuracy by
//! iterative refinement with f64 residuals; a matrix for which that does not converge within a
//! few steps (or that is not positive definite in f32 but is in f64) is factorised in double
//! precision instead, for good (the workspace then stays in f64), and the decision is reported
//! ([`PrecisionStats`]).

use faer::Par;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};

use super::engine::Engine;
use super::symbolic::symbolic_custom;
use super::{FactorError, FactorProfile, SparseCholesky};
use crate::SolverError;

/// Most refinement steps (single-precision solves) of one mixed-precision solve before it
/// falls back to double precision.
pub const MAX_REFINEMENT_STEPS: usize = 8;

/// The normwise backward error `‖b − A x‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞)` at which refinement stops: a
/// few units of f64 round-off (a double-precision factorisation's solves reach 1e-16–1e-15).
pub const REFINEMENT_TOLERANCE: f64 = 1e-14;

/// Why a mixed-precision factorisation went back to double precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrecisionFallback {
    /// The single-precision factorisation met a non-positive pivot where the double-precision
    /// one did not (the matrix is positive definite but too ill-conditioned for f32).
    NotPositiveDefinite,
    /// Iterative refinement did not reach `REFINEMENT_TOLERANCE` (10⁻¹⁴): it stalled (the residual
    /// shrank by less than half in a step) or took `MAX_REFINEMENT_STEPS` (8).
    Refinement {
        /// Single-precision solves done.
        steps: usize,
        /// The backward error reached.
        backward_error: f64,
    },
}

/// What a [`SparseCholesky`]'s factorisations and solves did in each precision.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PrecisionStats {
    /// Whether mixed precision was asked for and is available (a supernodal factor).
    pub mixed: bool,
    /// Successful factorisations in single precision.
    pub single_factorizations: usize,
    /// Successful factorisations in double precision.
    pub double_factorizations: usize,
    /// Solves refined from a single-precision factor.
    pub refined_solves: usize,
    /// Single-precision solves those took in all.
    pub refinement_steps: usize,
    /// Largest number of single-precision solves one refined solve took.
    pub max_refinement_steps: usize,
    /// Why the factorisation went back to double precision (`None`: it did not).
    pub fallback: Option<PrecisionFallback>,
}

/// The mixed-precision state of a [`SparseCholesky`].
#[derive(Default)]
pub(super) struct Mixed {
    /// The ordering (`perm[new] = old`) and split sizes of the double-precision engine, from
    /// which the single-precision one is built.
    pub(super) perm: Option<Vec<usize>>,
    pub(super) sizes: Option<[usize; 3]>,
    pub(super) single: Option<Single>,
    /// Whether the last successful factorisation is the single-precision one.
    pub(super) last_single: bool,
    /// Skip single precision (within a regularised factorisation whose single and double
    /// attempts both failed).
    pub(super) skip_single: bool,
    pub(super) stats: PrecisionStats,
}

/// The single-precision engine and what refinement needs.
pub(super) struct Single {
    pub(super) engine: Engine<f32>,
    /// The matrix of the last single-precision factorisation (f64, the pattern's order).
    values: Vec<f64>,
    /// Its ∞-norm.
    norm: f64,
    b: Vec<f64>,
    x: Vec<f64>,
    r: Vec<f64>,
    d: Vec<f64>,
}

/// `y = A x` for the symmetric `A` whose lower triangle is stored (`col_ptr`, `row_idx`,
/// `values`).
fn sym_mul(col_ptr: &[usize], row_idx: &[usize], values: &[f64], x: &[f64], y: &mut [f64]) {
    y.fill(0.0);
    for j in 0..x.len() {
        let mut acc = 0.0;
        for p in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[p];
            let a = values[p];
            y[i] += a * x[j];
            if i != j {
                acc += a * x[i];
            }
        }
        y[j] += acc;
    }
}

/// ∞-norm of the symmetric matrix whose lower triangle is stored.
fn sym_norm(col_ptr: &[usize], row_idx: &[usize], values: &[f64]) -> f64 {
    let n = col_ptr.len() - 1;
    let mut rows = vec![0.0f64; n];
    for j in 0..n {
        for p in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[p];
            rows[i] += values[p].abs();
            if i != j {
                rows[j] += values[p].abs();
            }
        }
    }
    rows.into_iter().fold(0.0, f64::max)
}

fn norm_inf(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, a| m.max(a.abs()))
}

impl SparseCholesky {
    /// Asks for mixed precision (`true`) or double precision only (`false`, the default of a
    /// new factorisation). With mixed precision every factorisation is done in f32 and every
    /// [`solve_in_place`](Self::solve_in_place) refined to a backward error of
    /// `REFINEMENT_TOLERANCE` (10⁻¹⁴) with f64 residuals; where that fails (see
    /// [`PrecisionFallback`]) the matrix is factorised in f64 and this factorisation stays in
    /// f64. Only supernodal factors take it (a simplicial one is small). Builds the
    /// single-precision engine (a symbolic analysis with the same ordering; the memory budget
    /// is checked) the first time. Returns whether mixed precision is now on.
    pub fn set_mixed_precision(&mut self, on: bool) -> Result<bool, SolverError> {
        if !on {
            self.mixed.single = None;
            self.mixed.last_single = false;
            self.mixed.stats.mixed = false;
            return Ok(false);
        }
        if self.mixed.single.is_some() {
            return Ok(true);
        }
        let supernodal = self.engine.is_multifrontal() || self.is_split();
        if !supernodal || self.mixed.stats.fallback.is_some() {
            return Ok(false);
        }
        let n = self.stats.n;
        let pattern =
            SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let identity: Vec<usize>;
        let perm = match &self.mixed.perm {
            Some(p) => p,
            None => {
                identity = (0..n).collect();
                &identity
            }
        };
        let symbolic = symbolic_custom(pattern, perm)?;
        let split = self.mixed.sizes.map(|s| (perm.clone(), s));
        let par = if self.is_split() { self.par } else { Par::Seq };
        let (engine, _) = Engine::<f32>::new(pattern, symbolic, split, par)?;
        self.mixed.single = Some(Single {
            engine,
            values: vec![0.0; self.row_idx.len()],
            norm: 0.0,
            b: vec![0.0; n],
            x: vec![0.0; n],
            r: vec![0.0; n],
            d: vec![0.0; n],
        });
        self.mixed.stats.mixed = true;
        self.factorized = false;
        Ok(true)
    }

    /// What the factorisations and solves did in each precision.
    pub fn precision(&self) -> PrecisionStats {
        self.mixed.stats
    }

    /// Whether the last successful factorisation is in single precision.
    pub fn single_active(&self) -> bool {
        self.mixed.last_single && self.mixed.single.is_some()
    }

    /// The single-precision factorisation of `h`, or the double one when f32 meets a
    /// non-positive pivot (a fallback for good when f64 then succeeds).
    pub(super) fn factorize_mixed(
        &mut self,
        h: SparseColMatRef<'_, usize, f64>,
        profile: Option<&mut FactorProfile>,
    ) -> Result<(), FactorError> {
        let Some(single) = &mut self.mixed.single else {
            return Err(FactorError::Other(SolverError::Linear(
                "mixed precision without its engine".into(),
            )));
        };
        match single.engine.factorize(h, profile) {
            Ok(()) => {
                single.values.copy_from_slice(h.val());
                single.norm = sym_norm(&self.col_ptr, &self.row_idx, &single.values);
                self.mixed.last_single = true;
                self.mixed.stats.single_factorizations += 1;
                self.factorized = true;
                Ok(())
            }
            Err(FactorError::NotPositiveDefinite { .. }) => {
                let r = self.engine.factorize(h, None);
                match r {
                    Ok(()) => {
                        self.fall_back(PrecisionFallback::NotPositiveDefinite);
                        self.mixed.stats.double_factorizations += 1;
                        self.factorized = true;
                    }
                    // Not positive definite in f64 either: the regularisation's next
                    // attempts skip f32 (`factorize_regularized`).
                    Err(FactorError::NotPositiveDefinite { .. }) => self.mixed.skip_single = true,
                    Err(_) => {}
                }
                r
            }
            Err(e) => Err(e),
        }
    }

    /// Drops the single-precision engine for good and records why.
    fn fall_back(&mut self, why: PrecisionFallback) {
        self.mixed.single = None;
        self.mixed.last_single = false;
        self.mixed.stats.fallback = Some(why);
    }

    /// Solves with the single-precision factor and iterative refinement; falls back to a
    /// double-precision factorisation of the same matrix when refinement does not converge.
    pub(super) fn solve_refined(&mut self, rhs: &mut [f64]) -> Result<(), SolverError> {
        let Some(s) = &mut self.mixed.single else {
            return Err(SolverError::Linear(
                "mixed precision without its engine".into(),
            ));
        };
        let b_norm = norm_inf(rhs);
        if b_norm == 0.0 {
            rhs.fill(0.0);
            return Ok(());
        }
        s.b.copy_from_slice(rhs);
        s.x.fill(0.0);
        s.r.copy_from_slice(rhs);
        let mut previous = f64::INFINITY;
        let mut eta = f64::NAN;
        for step in 1..=MAX_REFINEMENT_STEPS {
            s.d.copy_from_slice(&s.r);
            s.engine.solve_in_place(&mut s.d);
            for (x, d) in s.x.iter_mut().zip(&s.d) {
                *x += d;
            }
            sym_mul(&self.col_ptr, &self.row_idx, &s.values, &s.x, &mut s.r);
            for (r, b) in s.r.iter_mut().zip(&s.b) {
                *r = b - *r;
            }
            let r_norm = norm_inf(&s.r);
            eta = r_norm / (s.norm * norm_inf(&s.x) + b_norm);
            if eta <= REFINEMENT_TOLERANCE {
                rhs.copy_from_slice(&s.x);
                let st = &mut self.mixed.stats;
                st.refined_solves += 1;
                st.refinement_steps += step;
                st.max_refinement_steps = st.max_refinement_steps.max(step);
                return Ok(());
            }
            if !eta.is_finite() || r_norm > 0.5 * previous {
                let why = PrecisionFallback::Refinement {
                    steps: step,
                    backward_error: eta,
                };
                return self.refactorize_double(rhs, why);
            }
            previous = r_norm;
        }
        let why = PrecisionFallback::Refinement {
            steps: MAX_REFINEMENT_STEPS,
            backward_error: eta,
        };
        self.refactorize_double(rhs, why)
    }

    /// Factorises the single-precision factor's matrix in double precision, drops mixed
    /// precision for good and solves `rhs` (the original right-hand side is in the scratch).
    fn refactorize_double(
        &mut self,
        rhs: &mut [f64],
        why: PrecisionFallback,
    ) -> Result<(), SolverError> {
        let Some(s) = self.mixed.single.take() else {
            return Err(SolverError::Linear(
                "mixed precision without its engine".into(),
            ));
        };
        let n = self.stats.n;
        let pattern =
            SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let h = SparseColMatRef::new(pattern, &s.values);
        self.factorized = false;
        self.engine.factorize(h, None).map_err(|e| match e {
            FactorError::NotPositiveDefinite { pivot } => SolverError::Linear(format!(
                "mixed precision fell back to f64, whose factorisation failed at pivot {pivot}"
            )),
            FactorError::Other(e) => e,
        })?;
        self.fall_back(why);
        self.mixed.stats.double_factorizations += 1;
        self.factorized = true;
        rhs.copy_from_slice(&s.b);
        self.engine.solve_in_place(rhs);
        Ok(())
    }
}
