//! The separator's dense Cholesky factorisation, cut into fixed tasks that two threads share
//! with results that do not depend on the thread count.

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt::factor::{LltError, cholesky_in_place};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, MatMut, Par};
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
pub(super) fn cholesky_blocked(
    mut a: MatMut<'_, f64>,
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
                -1.0,
                Par::Seq,
            );
            matmul(
                below,
                Accum::Add,
                panel.get(c0 + w.., ..),
                p_top.transpose(),
                -1.0,
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
