//! The separator's dense Cholesky factorisation, cut into fixed tasks that two threads share
//! with results that do not depend on the thread count.

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt::factor::{LltError, cholesky_in_place};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, MatMut, Par};

use super::multifrontal::Real;
use rayon::iter::{IntoParallelIterator, ParallelIterator};

/// Columns per block of [`cholesky_blocked`]: large enough for faer's matrix kernels to run at
/// full rate, small enough that a separator of ~1 000 dofs gives each step several tasks.
pub(super) const BLOCK: usize = 128;

/// Factorises the lower triangle of the square `a` in place (`a = L Lᵀ`, `L` lower; the upper
/// triangle is neither read nor written). Right-looking by blocks of [`BLOCK`] columns: per
/// block, its diagonal block (faer's dense Cholesky), then its panel by row blocks (triangular
/// solves), then the trailing matrix by column blocks (products). Every task is one fixed
/// sequence of faer calls on one thread (`Par::Seq`) on data no other task of its stage
/// touches, so the result does not depend on `concurrent`, which only says whether a stage's
/// tasks run on the rayon pool. Errors with the first non-positive pivot. `stack`: scratch of
/// faer's dense Cholesky for [`BLOCK`] columns.
pub(super) fn cholesky_blocked<T: Real>(
    mut a: MatMut<'_, T>,
    concurrent: bool,
    stack: &mut MemStack,
) -> Result<(), usize> {
    let n = a.nrows();
    let mut k0 = 0;
    while k0 < n {
        let bs = BLOCK.min(n - k0);
        let (block_col, trailing) = a.rb_mut().get_mut(k0.., k0..).split_at_col_mut(bs);
        let (mut diag, mut panel) = block_col.split_at_row_mut(bs);
        cholesky_in_place(
            diag.rb_mut(),
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        )
        .map_err(|LltError::NonPositivePivot { index }| k0 + index)?;
        let diag = diag.rb();
        // P = A_panel L_diag⁻ᵀ, row block by row block.
        let mut rows = Vec::new();
        let mut rest = panel.rb_mut();
        while rest.nrows() > 0 {
            let h = BLOCK.min(rest.nrows());
            let (head, tail) = rest.split_at_row_mut(h);
            rows.push(head);
            rest = tail;
        }
        run(rows, concurrent, |p| {
            solve_lower_triangular_in_place(diag, p.transpose_mut(), Par::Seq);
        });
        // A_trailing −= P Pᵀ (lower), column block by column block: each block's diagonal
        // part (lower triangle) and the part below it.
        let panel = panel.rb();
        let mut cols = Vec::new();
        let mut rest = trailing.split_at_row_mut(bs).1;
        let mut c0 = 0;
        while rest.ncols() > 0 {
            let w = BLOCK.min(rest.ncols());
            let (head, tail) = rest.split_at_col_mut(w);
            cols.push((c0, head.split_at_row_mut(c0).1));
            rest = tail;
            c0 += w;
        }
        run(cols, concurrent, |(c0, dst)| {
            let w = dst.ncols();
            let (top, below) = dst.split_at_row_mut(w);
            let p_top = panel.get(c0..c0 + w, ..);
            triangular::matmul(
                top,
                BlockStructure::TriangularLower,
                Accum::Add,
                p_top,
                BlockStructure::Rectangular,
                p_top.transpose(),
                BlockStructure::Rectangular,
                T::of(-1.0),
                Par::Seq,
            );
            matmul(
                below,
                Accum::Add,
                panel.get(c0 + w.., ..),
                p_top.transpose(),
                T::of(-1.0),
                Par::Seq,
            );
        });
        k0 += bs;
    }
    Ok(())
}

/// Runs `f` on every task, concurrently on the rayon pool or one after the other in order.
fn run<T: Send>(tasks: Vec<T>, concurrent: bool, f: impl Fn(T) + Sync + Send) {
    if concurrent {
        tasks.into_par_iter().for_each(f);
    } else {
        tasks.into_iter().for_each(f);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use faer::dyn_stack::MemBuffer;
    use faer::{Mat, Side};

    use super::*;

    /// A well-conditioned SPD matrix of order `n` with uneven entries (so that round-off
    /// differs between operation orders).
    fn spd(n: usize) -> Mat<f64> {
        let b = Mat::from_fn(n, n, |i, j| (((i * 31 + j * 17) % 23) as f64 - 11.0) / 7.0);
        let mut a = &b * b.transpose();
        for i in 0..n {
            a[(i, i)] += n as f64;
        }
        a
    }

    fn factor(a: &Mat<f64>, concurrent: bool) -> Result<Mat<f64>, usize> {
        let mut l = a.clone();
        let mut mem = MemBuffer::new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                BLOCK,
                Par::Seq,
                Default::default(),
            ),
        );
        cholesky_blocked(l.as_mut(), concurrent, MemStack::new(&mut mem))?;
        Ok(Mat::from_fn(a.nrows(), a.ncols(), |i, j| {
            if i >= j { l[(i, j)] } else { 0.0 }
        }))
    }

    /// Several blocks and a last partial one: the factor reproduces the matrix, agrees with
    /// faer's dense Cholesky to round-off, and is bit-identical whether the tasks run on a
    /// two-thread pool or one after the other.
    #[test]
    fn blocked_cholesky_is_a_cholesky_factor_independent_of_the_threads() {
        let n = 2 * BLOCK + 45;
        let a = spd(n);
        let sequential = factor(&a, false).unwrap();
        let reference = a.llt(Side::Lower).unwrap();
        let diff = &sequential - reference.L();
        assert!(
            diff.norm_max() < 1e-12 * reference.L().norm_max(),
            "{}",
            diff.norm_max()
        );
        let residual = &sequential * sequential.transpose() - &a;
        assert!(residual.norm_max() < 1e-12 * a.norm_max());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let concurrent = pool.install(|| factor(&a, true)).unwrap();
        for j in 0..n {
            for i in j..n {
                assert_eq!(
                    concurrent[(i, j)].to_bits(),
                    sequential[(i, j)].to_bits(),
                    "({i}, {j})"
                );
            }
        }
    }

    /// The first non-positive pivot is reported in the whole matrix's numbering, also when it
    /// lies in a later block.
    #[test]
    fn blocked_cholesky_reports_the_failing_pivot() {
        let n = 2 * BLOCK + 45;
        let mut a = Mat::<f64>::identity(n, n);
        let bad = BLOCK + 7;
        a[(bad, bad)] = -1.0;
        assert_eq!(factor(&a, false), Err(bad));
        assert_eq!(factor(&a, true), Err(bad));
    }
}
