//! Small patterns for the ordering module's unit tests.

use faer::sparse::SymbolicSparseColMat;

/// Lower pattern of a path graph 0 - 1 - … - (n-1).
pub(super) fn path(n: usize) -> SymbolicSparseColMat<usize> {
    let mut col_ptr = vec![0];
    let mut rows = Vec::new();
    for j in 0..n {
        rows.push(j);
        if j + 1 < n {
            rows.push(j + 1);
        }
        col_ptr.push(rows.len());
    }
    SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows)
}

/// Lower pattern of a `k × k` grid of vertices with 3 dofs each, every vertex coupled
/// (dense 3×3 blocks) to its 8 neighbours: the shape of a shell Hessian.
pub(super) fn block_grid(k: usize) -> SymbolicSparseColMat<usize> {
    let n = 3 * k * k;
    let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
    for v in 0..k * k {
        let (x, y) = (v % k, v / k);
        for u in 0..k * k {
            let (ux, uy) = (u % k, u / k);
            if u >= v && ux.abs_diff(x) <= 1 && uy.abs_diff(y) <= 1 {
                for a in 0..3 {
                    for b in 0..3 {
                        let (i, j) = (3 * u + a, 3 * v + b);
                        if i >= j {
                            cols[j].push(i);
                        }
                    }
                }
            }
        }
    }
    let mut col_ptr = vec![0];
    let mut rows = Vec::new();
    for mut c in cols {
        c.sort_unstable();
        rows.extend(c);
        col_ptr.push(rows.len());
    }
    SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows)
}
