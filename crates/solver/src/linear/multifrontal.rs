//! The numeric supernodal factorisation, multifrontal, on faer's dense kernels.
//!
//! faer's own supernodal driver is left-looking: each supernode gathers the update of every
//! descendant by one small product whose inner dimension is the descendant's width and whose
//! output is scattered tile by tile into the supernode (docs/performance.md, "Where the
//! factorisation time goes"). Here each supernode, once factorised, forms its whole update
//! matrix `U = −L₂₁ L₂₁ᵀ` (plus its children's updates) by one symmetric product and hands it
//! to its parent, which adds it entry by entry (extend-add): one large product per supernode
//! instead of one small one per (descendant, ancestor) pair. The factor's layout is faer's
//! ([`SymbolicSupernodalCholesky`]), so faer's supernodal solves read it unchanged.
//!
//! The supernodes are numbered children first (faer's symbolic analysis orders them so;
//! [`Plan::new`] checks it); where each pending update matrix lives is planned once.
//! Everything runs on the calling thread in a fixed order: the result does not depend on the
//! thread pool.

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt::factor::{LltError, cholesky_in_place};
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, MatMut, MatRef, Par};
use std::time::Instant;

/// A floating-point type the factorisation runs in (f64, or f32 for mixed precision).
pub trait Real:
    faer::traits::RealField + Copy + Send + Sync + std::ops::AddAssign + 'static
{
    /// `x` rounded to this type.
    fn of(x: f64) -> Self;
    /// The value as f64 (exact).
    fn wide(self) -> f64;
    /// Sets to zero the entries below `tiny` in magnitude (f32 only; f64 keeps everything).
    /// Subnormal operands slow the dense kernels down by orders of magnitude, and the factor
    /// of a well-conditioned (diagonally dominant) matrix decays geometrically away from the
    /// diagonal, into f32's subnormal range on large meshes ([`flush_threshold`]).
    fn flush(values: &mut [Self], tiny: f64);
}

impl Real for f64 {
    fn of(x: f64) -> Self {
        x
    }
    fn wide(self) -> f64 {
        self
    }
    fn flush(_: &mut [Self], _: f64) {}
}

impl Real for f32 {
    fn of(x: f64) -> Self {
        x as f32
    }
    fn wide(self) -> f64 {
        self as f64
    }
    fn flush(values: &mut [Self], tiny: f64) {
        let tiny = tiny as f32;
        for v in values {
            if v.abs() < tiny {
                *v = 0.0;
            }
        }
    }
}

/// The magnitude below which an f32 factor's entries are dropped, for a matrix whose largest
/// entry is `max_abs`: 2⁻⁵⁰ of the factor's scale `√max_abs` (far below f32's resolution of
/// the entries that matter), and at least `√f32::MIN_POSITIVE`, so that products of kept
/// entries stay normal. Dropping less than that left the f32 factorisation 2–8× slower than
/// the f64 one at 81 920 faces (subnormal intermediates in the triangular solves); a matrix
/// scaled so that the dropped entries matter fails refinement and falls back to f64.
pub(super) fn flush_threshold(max_abs: f64) -> f64 {
    (max_abs.sqrt() * 2f64.powi(-50)).max((f32::MIN_POSITIVE as f64).sqrt())
}

/// The multifrontal schedule of a supernodal symbolic factor: per supernode its columns, the
/// rows below them, its children and where their update matrices sit.
#[derive(Debug)]
pub(super) struct Plan {
    /// First column of each supernode, and `n` at the end.
    begin: Vec<usize>,
    /// Rows of each supernode's pattern below its columns (`r`).
    rows: Vec<usize>,
    /// Offset of each supernode's `(w + r) × w` block in the factor's values.
    val: Vec<usize>,
    /// Row indices (factor numbering) of each supernode's pattern, `pat[pat_ptr[s]..pat_ptr[s + 1]]`.
    pat_ptr: Vec<usize>,
    pat: Vec<usize>,
    /// Children of each supernode, ascending.
    child_ptr: Vec<usize>,
    children: Vec<usize>,
    /// Position of each pattern row of a supernode in its parent's front (`< w_parent`: one of
    /// the parent's columns), `rel[pat_ptr[s]..pat_ptr[s + 1]]`.
    rel: Vec<usize>,
    /// End (exclusive, local to the supernode's pattern) of the run of consecutive `rel` values each entry
    /// belongs to: the extend-add adds whole runs as slices (vectorised).
    run_end: Vec<usize>,
    /// How many of a supernode's pattern rows are its parent's columns.
    split: Vec<usize>,
    /// Where each supernode's update matrix (r × r, column-major) is formed and waits for its
    /// parent (regions of a supernode and its children never overlap).
    stack_at: Vec<usize>,
    /// Narrow leaves ([`DIRECT_WIDTH`]): no update matrix; the parent adds `−B Bᵀ` from the
    /// leaf's rows below (`B`, in the factor) directly.
    direct: Vec<bool>,
    /// Length of the update stack (values).
    stack_len: usize,
    /// The supernode of each column.
    col_sn: Vec<usize>,
    /// Largest width of a supernode (faer's dense Cholesky scratch).
    max_width: usize,
}

impl Plan {
    /// The schedule of `sn`, or `None` when its structure is not what the numeric phase relies
    /// on (supernodes numbered children first, a child's rows contained in its parent's front;
    /// faer's symbolic analysis always gives that, checked anyway).
    pub(super) fn new(sn: &SymbolicSupernodalCholesky<usize>) -> Option<Plan> {
        let ns = sn.n_supernodes();
        let n = sn.nrows();
        let mut begin = sn.supernode_begin().to_vec();
        begin.push(n);
        if begin.len() != ns + 1 || sn.supernode_end()[..ns] != begin[1..] {
            return None;
        }
        let val = sn.col_ptr_for_val().to_vec();
        let mut col_sn = vec![0; n];
        let mut max_width = 0;
        for s in 0..ns {
            col_sn[begin[s]..begin[s + 1]].fill(s);
            max_width = max_width.max(begin[s + 1] - begin[s]);
        }
        let mut pat_ptr = vec![0];
        let mut pat = Vec::new();
        let mut rows = Vec::with_capacity(ns);
        for s in 0..ns {
            let p = sn.supernode(s).pattern();
            if p.windows(2).any(|w| w[0] >= w[1]) || p.first().is_some_and(|&r| r < begin[s + 1]) {
                return None;
            }
            pat.extend_from_slice(p);
            pat_ptr.push(pat.len());
            rows.push(p.len());
        }
        let parent = |s: usize| {
            pat.get(pat_ptr[s])
                .filter(|_| rows[s] > 0)
                .map(|&r| col_sn[r])
        };
        let mut child_ptr = vec![0usize; ns + 1];
        for s in 0..ns {
            if let Some(p) = parent(s) {
                child_ptr[p + 1] += 1;
            }
        }
        for s in 0..ns {
            child_ptr[s + 1] += child_ptr[s];
        }
        let mut fill = child_ptr.clone();
        let mut children = vec![0; child_ptr[ns]];
        let mut rel = vec![0; pat.len()];
        let mut split = vec![0; ns];
        for s in 0..ns {
            let Some(p) = parent(s) else { continue };
            if p <= s {
                return None;
            }
            children[fill[p]] = s;
            fill[p] += 1;
            let (pb, pe) = (begin[p], begin[p + 1]);
            let ppat = &pat[pat_ptr[p]..pat_ptr[p + 1]];
            for q in pat_ptr[s]..pat_ptr[s + 1] {
                let g = pat[q];
                rel[q] = if g < pe {
                    split[s] += 1;
                    g - pb
                } else {
                    // The child's rows beyond the parent's columns are in the parent's pattern.
                    (pe - pb) + ppat.binary_search(&g).ok()?
                };
            }
        }
        let mut run_end = vec![0; pat.len()];
        for s in 0..ns {
            let (a, b) = (pat_ptr[s], pat_ptr[s + 1]);
            let mut end = b;
            for q in (a..b).rev() {
                if q + 1 < b && rel[q + 1] != rel[q] + 1 {
                    end = q + 1;
                }
                run_end[q] = end - a;
            }
        }
        let direct: Vec<bool> = (0..ns)
            .map(|s| {
                begin[s + 1] - begin[s] <= DIRECT_WIDTH
                    && child_ptr[s] == child_ptr[s + 1]
                    && rows[s] > 0
            })
            .collect();
        // Where the update matrices live: each from its supernode's factorisation to its
        // parent's, placed first-fit (in a postorder this is a stack; faer's supernode order is
        // topological but need not be one), all planned here so that the numeric phase only
        // reads offsets.
        let mut stack_at = vec![0; ns];
        let mut free: Vec<(usize, usize)> = Vec::new();
        let mut end = 0usize;
        for s in 0..ns {
            let len = if direct[s] { 0 } else { rows[s] * rows[s] };
            if len > 0 {
                stack_at[s] = match free.iter().position(|&(_, l)| l >= len) {
                    Some(k) => {
                        let (o, l) = free[k];
                        if l == len {
                            free.remove(k);
                        } else {
                            free[k] = (o + len, l - len);
                        }
                        o
                    }
                    None => {
                        let o = match free.last() {
                            Some(&(o, l)) if o + l == end => {
                                free.pop();
                                o
                            }
                            _ => end,
                        };
                        end = o + len;
                        o
                    }
                };
            }
            for &c in children[child_ptr[s]..child_ptr[s + 1]]
                .iter()
                .filter(|&&c| !direct[c])
            {
                let (o, l) = (stack_at[c], rows[c] * rows[c]);
                let k = free.partition_point(|&(fo, _)| fo < o);
                free.insert(k, (o, l));
                // Merge with the neighbours.
                if k + 1 < free.len() && free[k].0 + free[k].1 == free[k + 1].0 {
                    free[k].1 += free[k + 1].1;
                    free.remove(k + 1);
                }
                if k > 0 && free[k - 1].0 + free[k - 1].1 == free[k].0 {
                    free[k - 1].1 += free[k].1;
                    free.remove(k);
                }
            }
        }
        Some(Plan {
            begin,
            rows,
            val,
            pat_ptr,
            pat,
            child_ptr,
            children,
            rel,
            run_end,
            split,
            stack_at,
            direct,
            stack_len: end,
            col_sn,
            max_width,
        })
    }

    /// Number of supernodes.
    pub(super) fn len(&self) -> usize {
        self.rows.len()
    }

    /// Values of the update stack the factorisation needs.
    pub(super) fn stack_len(&self) -> usize {
        self.stack_len
    }

    /// Widest supernode (the scratch of faer's dense Cholesky is sized for it).
    pub(super) fn max_width(&self) -> usize {
        self.max_width
    }

    /// Offset in the factor's values of entry (`row`, `col`) of L (factor numbering,
    /// `row ≥ col`), `None` when it is not in the factor's pattern.
    pub(super) fn position(&self, row: usize, col: usize) -> Option<usize> {
        let s = self.col_sn[col];
        let (b, e) = (self.begin[s], self.begin[s + 1]);
        let ld = (e - b) + self.rows[s];
        let local = if row < e {
            row.checked_sub(b)?
        } else {
            (e - b)
                + self.pat[self.pat_ptr[s]..self.pat_ptr[s + 1]]
                    .binary_search(&row)
                    .ok()?
        };
        Some(self.val[s] + (col - b) * ld + local)
    }

    /// A supernode's width and its block of the factor (`(w + r) × w`, column-major) in `l`,
    /// which must hold the factor's values up to the supernode's parent.
    fn below<'a, T>(&self, c: usize, l: &'a [T]) -> (usize, &'a [T]) {
        let w = self.begin[c + 1] - self.begin[c];
        (w, &l[self.val[c]..self.val[c] + (w + self.rows[c]) * w])
    }

    /// A supernode's positions in its parent's front and the ends of their runs (local, from
    /// 0).
    fn runs(&self, c: usize) -> (&[usize], &[usize]) {
        let (a, b) = (self.pat_ptr[c], self.pat_ptr[c + 1]);
        (&self.rel[a..b], &self.run_end[a..b])
    }
}

/// Supernodes at most this wide without children hand their update to their parent as their
/// factor block (`−B Bᵀ` added there entry by entry) instead of an update matrix: forming and
/// re-reading `r × r` values cost more than the product for them (the edge-director forms have
/// one such leaf per edge angle eliminated first).
pub(super) const DIRECT_WIDTH: usize = 4;

/// Factorises in place the supernodes `0..stop` of the factor whose values `l` hold the
/// matrix's lower triangle at [`Plan::position`] (zeros elsewhere); supernodes from `stop` on
/// only receive their children's updates (the split's tail, which must have no rows below its
/// columns). Per supernode, in order: the children's updates are added to its columns, its
/// diagonal block is factorised (faer's dense Cholesky), its rows below solved (triangular
/// solve), and its update matrix formed (`−L₂₁ L₂₁ᵀ`, lower triangle) with the children's
/// remaining entries added (a narrow leaf, [`DIRECT_WIDTH`], forms none: its parent adds its
/// `−B Bᵀ` directly). `stack`: [`Plan::stack_len`] values; `mem`: faer's dense Cholesky
/// scratch for [`Plan::max_width`] columns. Errors with the first non-positive pivot (factor
/// numbering).
/// `tiny`: an f32 factor's entries below it are dropped ([`flush_threshold`]; ignored in
/// f64). `profile`: when given, the time of each stage is added to the supernode's width class.
pub(super) fn factorize<T: Real>(
    plan: &Plan,
    l: &mut [T],
    stack: &mut [T],
    stop: usize,
    mem: &mut MemStack,
    tiny: f64,
    mut profile: Option<&mut FactorProfile>,
) -> Result<(), usize> {
    let mut clock = Instant::now();
    let mut lap = |profile: &mut Option<&mut FactorProfile>, w: usize, r: usize, stage: usize| {
        if let Some(p) = profile {
            let now = Instant::now();
            p.add(w, r, stage, (now - clock).as_secs_f64());
            clock = now;
        }
    };
    for s in 0..plan.len() {
        let (b, e) = (plan.begin[s], plan.begin[s + 1]);
        let (w, r) = (e - b, plan.rows[s]);
        let ld = w + r;
        lap(&mut profile, w, r, 4);
        let kids = &plan.children[plan.child_ptr[s]..plan.child_ptr[s + 1]];
        let (head, tail) = l.split_at_mut(plan.val[s]);
        let head = &*head;
        let front = &mut tail[..ld * w];
        for &c in kids {
            let rc = plan.rows[c];
            let (rel, runs) = plan.runs(c);
            if plan.direct[c] {
                let (wc, bc) = plan.below(c, head);
                for jj in 0..plan.split[c] {
                    sub_outer(&mut front[rel[jj] * ld..], bc, wc, rc, jj, rel, runs, 0);
                }
                continue;
            }
            let u = &stack[plan.stack_at[c]..plan.stack_at[c] + rc * rc];
            for jj in 0..plan.split[c] {
                add_column(
                    &mut front[rel[jj] * ld..],
                    &u[jj * rc..(jj + 1) * rc],
                    jj,
                    rel,
                    runs,
                    0,
                );
            }
        }
        lap(&mut profile, w, r, 0);
        if s >= stop {
            // Only a root (no rows below) may stay unfactorised: its update matrix is empty.
            if r > 0 {
                return Err(b);
            }
            continue;
        }
        T::flush(front, tiny);
        {
            let f = MatMut::from_column_major_slice_mut(&mut *front, ld, w);
            let (mut top, mut bot) = f.split_at_row_mut(w);
            cholesky_in_place(
                top.rb_mut(),
                Default::default(),
                Par::Seq,
                mem,
                Default::default(),
            )
            .map_err(|LltError::NonPositivePivot { index }| b + index)?;
            lap(&mut profile, w, r, 1);
            if r == 0 {
                continue;
            }
            solve_lower_triangular_in_place(top.rb(), bot.rb_mut().transpose_mut(), Par::Seq);
        }
        T::flush(front, tiny);
        let (_, bot) = MatRef::from_column_major_slice(&*front, ld, w).split_at_row(w);
        lap(&mut profile, w, r, 2);
        if plan.direct[s] {
            // The parent adds −B Bᵀ itself.
            continue;
        }
        let at = plan.stack_at[s];
        let (before, rest) = stack.split_at_mut(at);
        let (u, after) = rest.split_at_mut(r * r);
        let after = &*after;
        // A child's update matrix lies wholly before or wholly after the supernode's.
        let region = |o: usize, len: usize| -> &[T] {
            if o < at {
                &before[o..o + len]
            } else {
                &after[o - at - r * r..][..len]
            }
        };
        triangular::matmul(
            MatMut::from_column_major_slice_mut(u, r, r),
            BlockStructure::TriangularLower,
            Accum::Replace,
            bot.rb(),
            BlockStructure::Rectangular,
            bot.rb().transpose(),
            BlockStructure::Rectangular,
            T::of(-1.0),
            Par::Seq,
        );
        lap(&mut profile, w, r, 3);
        for &c in kids {
            let rc = plan.rows[c];
            let (rel, runs) = plan.runs(c);
            if plan.direct[c] {
                let (wc, bc) = plan.below(c, head);
                for jj in plan.split[c]..rc {
                    sub_outer(&mut u[(rel[jj] - w) * r..], bc, wc, rc, jj, rel, runs, w);
                }
                continue;
            }
            let src = region(plan.stack_at[c], rc * rc);
            for jj in plan.split[c]..rc {
                add_column(
                    &mut u[(rel[jj] - w) * r..],
                    &src[jj * rc..(jj + 1) * rc],
                    jj,
                    rel,
                    runs,
                    w,
                );
            }
        }
        lap(&mut profile, w, r, 0);
    }
    Ok(())
}

/// Subtracts entries `jj..` of column `jj` of `B Bᵀ` from the parent's front column `dst`
/// (entry `i` at `rel[i] − shift`), `B` (the leaf's `(wc + rc) × wc` factor block from
/// [`Plan::below`], whose rows `wc..` are `B`) a narrow leaf's rows below its columns: the leaf's update added without
/// forming it.
#[allow(clippy::too_many_arguments)]
fn sub_outer<T: Real>(
    dst: &mut [T],
    b: &[T],
    wc: usize,
    rc: usize,
    jj: usize,
    rel: &[usize],
    run_end: &[usize],
    shift: usize,
) {
    let ld = wc + rc;
    let mut i = jj;
    while i < rc {
        let end = run_end[i];
        let d = rel[i] - shift;
        let out = &mut dst[d..d + (end - i)];
        for k in 0..wc {
            let col = &b[k * ld + wc..k * ld + ld];
            let bjk = col[jj];
            for (a, &x) in out.iter_mut().zip(&col[i..end]) {
                *a -= x * bjk;
            }
        }
        i = end;
    }
}

/// Adds entries `jj..` of a child's update column `src` to the parent's front column `dst`,
/// entry `i` at `rel[i] − shift`, a run of consecutive positions at a time.
fn add_column<T: Real>(
    dst: &mut [T],
    src: &[T],
    jj: usize,
    rel: &[usize],
    run_end: &[usize],
    shift: usize,
) {
    let mut i = jj;
    while i < src.len() {
        let end = run_end[i];
        let d = rel[i] - shift;
        for (a, &b) in dst[d..d + (end - i)].iter_mut().zip(&src[i..end]) {
            *a += b;
        }
        i = end;
    }
}

/// Where a multifrontal factorisation's time goes, by supernode width class (a measurement
/// aid: `SparseCholesky::factorize_profiled`).
#[derive(Clone, Debug, Default)]
pub struct FactorProfile {
    /// Classes of widths `[1, 4)`, `[4, 16)`, `[16, 64)`, `[64, 256)`, `[256, 1024)`, `≥ 1024`.
    pub classes: [ClassProfile; 6],
}

/// One width class of a [`FactorProfile`]; times in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct ClassProfile {
    /// Supernodes of the class.
    pub supernodes: usize,
    /// Their predicted flops (Σ over columns of (column count)², as `factor_flops`).
    pub flops: f64,
    /// Adding the children's update matrices (extend-add).
    pub extend_add: f64,
    /// Dense Cholesky of the diagonal blocks.
    pub cholesky: f64,
    /// Triangular solves of the rows below.
    pub solve: f64,
    /// The symmetric products forming the update matrices.
    pub update: f64,
    /// Loop overhead between supernodes.
    pub other: f64,
}

impl FactorProfile {
    /// The class of a supernode `w` columns wide.
    pub fn class(w: usize) -> usize {
        match w {
            0..4 => 0,
            4..16 => 1,
            16..64 => 2,
            64..256 => 3,
            256..1024 => 4,
            _ => 5,
        }
    }

    /// Adds `t` seconds of `stage` (0 extend-add, 1 Cholesky, 2 solve, 3 update, 4 other) of a
    /// `w`-wide supernode with `r` rows below; its flops are counted with its Cholesky.
    fn add(&mut self, w: usize, r: usize, stage: usize, t: f64) {
        let c = &mut self.classes[Self::class(w)];
        match stage {
            0 => c.extend_add += t,
            1 => {
                c.cholesky += t;
                c.supernodes += 1;
                c.flops += (1..=w).map(|k| ((k + r) as f64).powi(2)).sum::<f64>();
            }
            2 => c.solve += t,
            3 => c.update += t,
            _ => c.other += t,
        }
    }
}
