//! Sparse symmetric **indefinite** factorisation `A = L D Lᵀ` with its inertia, for the
//! tangent of path following past limit points (where the Hessian of the total potential is
//! no longer positive definite and [`SparseCholesky`](crate::SparseCholesky) fails).
//!
//! faer's supernodal LDLᵀ without pivoting, on the same fill-reducing symbolic analysis as the
//! Cholesky factorisation. By Sylvester's law of inertia the number of negative pivots `D_ii`
//! is the number of negative eigenvalues of `A` (exact in exact arithmetic; without pivoting a
//! tiny pivot can lose accuracy, which the path tracer's Newton corrector absorbs). A zero
//! pivot (a singular matrix in the permuted order) is reported as an error.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{LdltRef, SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::SolverError;
use crate::ordering::Ordering;

/// A sparse LDLᵀ factorisation (lower triangle input, symbolic analysis reused for every
/// matrix with the pattern given to [`SparseLdlt::new`]).
pub struct SparseLdlt {
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    par: Par,
    negative: usize,
    factorized: bool,
}

impl std::fmt::Debug for SparseLdlt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLdlt")
            .field("n", &self.col_ptr.len().saturating_sub(1))
            .field("negative_pivots", &self.negative)
            .field("factorized", &self.factorized)
            .finish_non_exhaustive()
    }
}

impl SparseLdlt {
    /// Symbolic analysis of a square lower-triangle pattern (every diagonal entry present), with
    /// the Cholesky factorisation's ordering choice (no coordinates: graph nested dissection)
    /// and its memory refusal ([`SolverError::InsufficientMemory`]).
    pub fn new(
        pattern: SymbolicSparseColMatRef<'_, usize>,
        ordering: Ordering,
        par: Par,
    ) -> Result<SparseLdlt, SolverError> {
        crate::linear::diagonal_offsets(pattern)?;
        let (symbolic, _, _) = crate::linear::analyse(pattern, ordering, None)?;
        let (factor_mem, solve_mem, _) = crate::linear::scratch(
            &symbolic,
            symbolic.factorize_numeric_ldlt_scratch::<f64>(par, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, par),
        )?;
        Ok(SparseLdlt {
            l_values: vec![0.0; symbolic.len_val()],
            symbolic,
            factor_mem,
            solve_mem,
            col_ptr: pattern.col_ptr().to_vec(),
            row_idx: pattern.row_idx().to_vec(),
            par,
            negative: 0,
            factorized: false,
        })
    }

    /// Matrix dimension.
    pub fn n(&self) -> usize {
        self.col_ptr.len().saturating_sub(1)
    }

    /// Factorises `a` (the analysed pattern, lower triangle). Errors: a different pattern
    /// ([`SolverError::InvalidPattern`]), a zero pivot ([`SolverError::Linear`]: the matrix is
    /// singular or nearly so in the pivot order) or a non-finite pivot.
    pub fn factorize(&mut self, a: SparseColMatRef<'_, usize, f64>) -> Result<(), SolverError> {
        self.factorized = false;
        crate::linear::same_pattern(a, &self.col_ptr, &self.row_idx)?;
        let stack = MemStack::new(&mut self.factor_mem);
        self.symbolic
            .factorize_numeric_ldlt(
                &mut self.l_values,
                a,
                Side::Lower,
                Default::default(),
                self.par,
                stack,
                Default::default(),
            )
            .map_err(|e| SolverError::Linear(format!("LDLT factorisation: {e:?}")))?;
        let d = self.pivots();
        if d.iter().any(|v| !v.is_finite() || *v == 0.0) {
            return Err(SolverError::Linear(
                "LDLT factorisation: zero or non-finite pivot (singular tangent)".into(),
            ));
        }
        self.negative = d.iter().filter(|v| **v < 0.0).count();
        self.factorized = true;
        Ok(())
    }

    /// The pivots `D_ii` of the last factorisation, in the permuted order.
    fn pivots(&self) -> Vec<f64> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                // Each column of L starts with its diagonal entry, which holds D_jj.
                let col_ptr = s.col_ptr();
                (0..s.ncols()).map(|j| self.l_values[col_ptr[j]]).collect()
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                // Supernode k stores a column-major (width + below) × width block whose
                // square top holds D on its diagonal.
                let begin = s.supernode_begin();
                let end = s.supernode_end();
                let ptr = s.col_ptr_for_val();
                let mut d = Vec::with_capacity(s.nrows());
                for k in 0..s.n_supernodes() {
                    let width = end[k] - begin[k];
                    let rows = width + s.supernode(k).pattern().len();
                    for c in 0..width {
                        d.push(self.l_values[ptr[k] + c * rows + c]);
                    }
                }
                d
            }
        }
    }

    /// Number of negative pivots of the last successful factorisation: the number of negative
    /// eigenvalues of the matrix (0: positive definite).
    pub fn negative_pivots(&self) -> usize {
        self.negative
    }

    /// Solves `A x = rhs` in place with the last successful factorisation.
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolverError> {
        let n = self.n();
        crate::linear::ready_to_solve(self.factorized, n, rhs)?;
        let ldlt = LdltRef::new(&self.symbolic, &self.l_values);
        let stack = MemStack::new(&mut self.solve_mem);
        ldlt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            self.par,
            stack,
        );
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};
    use nalgebra::DMatrix;

    /// Random symmetric banded matrices with diagonal shifts, small (simplicial factor) and
    /// wide-banded (supernodal factor): the inertia from the LDLᵀ pivots equals the count of
    /// negative eigenvalues of a dense eigen-decomposition, and the solve matches.
    #[test]
    fn inertia_and_solve_match_dense() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for (n, band, supernodal) in [(60usize, 5usize, false), (200, 200, true)] {
            let mut dense = DMatrix::<f64>::zeros(n, n);
            for j in 0..n {
                for i in j..(j + band).min(n) {
                    let v = rnd();
                    dense[(i, j)] = v;
                    dense[(j, i)] = v;
                }
            }
            let spread = 0.3 * (band as f64).sqrt();
            for shift in [-2.0 * spread, -spread, 0.0, spread, 10.0 * spread] {
                let mut m = dense.clone();
                for i in 0..n {
                    m[(i, i)] += shift;
                }
                let triplets: Vec<_> = (0..n)
                    .flat_map(|j| (j..n).map(move |i| (i, j)))
                    .filter(|&(i, j)| i - j < band)
                    .map(|(i, j)| Triplet::new(i, j, m[(i, j)]))
                    .collect();
                let a = SparseColMat::try_new_from_triplets(n, n, &triplets).unwrap();
                let eig = m.clone().symmetric_eigen();
                let negative = eig.eigenvalues.iter().filter(|v| **v < 0.0).count();
                for ordering in [Ordering::Amd, Ordering::NestedDissection, Ordering::Metis] {
                    let mut f = SparseLdlt::new(a.symbolic(), ordering, Par::Seq).unwrap();
                    assert_eq!(
                        matches!(f.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)),
                        supernodal,
                        "n = {n}: factor kind"
                    );
                    f.factorize(a.as_ref()).unwrap();
                    assert_eq!(f.negative_pivots(), negative, "n = {n}, shift {shift}");
                    let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
                    let mut x = b.clone();
                    f.solve_in_place(&mut x).unwrap();
                    let r = &m * nalgebra::DVector::from_vec(x) - nalgebra::DVector::from_vec(b);
                    assert!(
                        r.amax() < 1e-8,
                        "n = {n}, shift {shift}: residual {}",
                        r.amax()
                    );
                }
            }
        }
    }
}
