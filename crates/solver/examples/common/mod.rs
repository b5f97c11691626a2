//! Helpers shared by the examples.
use faer::sparse::SparseColMat;

/// Writes on `h`'s pattern the graph Laplacian plus the identity (off-diagonal entries −1,
/// diagonal = degree + 1): SPD and diagonally dominant; the factorisation's work depends only
/// on the pattern.
pub fn spd(h: &mut SparseColMat<usize, f64>) {
    let n = h.ncols();
    let (cp, rows) = (
        h.symbolic().col_ptr().to_vec(),
        h.symbolic().row_idx().to_vec(),
    );
    let mut off = vec![0.0; n];
    for j in 0..n {
        for &i in &rows[cp[j]..cp[j + 1]] {
            if i != j {
                off[i] += 1.0;
                off[j] += 1.0;
            }
        }
    }
    let val = h.val_mut();
    for j in 0..n {
        for (k, &i) in rows[cp[j]..cp[j + 1]].iter().enumerate() {
            val[cp[j] + k] = if i == j { off[j] + 1.0 } else { -1.0 };
        }
    }
}
