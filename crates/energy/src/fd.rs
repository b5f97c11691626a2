//! Central finite differences, for tests (here and in other crates).

/// Central-difference gradient of `f` at `x` with step `h` (error O(h²)).
pub fn fd_gradient(f: impl Fn(&[f64]) -> f64, x: &[f64], h: f64) -> Vec<f64> {
    let mut y = x.to_vec();
    (0..x.len())
        .map(|i| {
            y[i] = x[i] + h;
            let fp = f(&y);
            y[i] = x[i] - h;
            let fm = f(&y);
            y[i] = x[i];
            (fp - fm) / (2.0 * h)
        })
        .collect()
}

/// Central-difference Jacobian of `f: R^n → R^m`; result row-major, `m` rows of length `n`.
pub fn fd_jacobian(f: impl Fn(&[f64]) -> Vec<f64>, x: &[f64], h: f64) -> Vec<Vec<f64>> {
    let mut y = x.to_vec();
    let cols: Vec<Vec<f64>> = (0..x.len())
        .map(|i| {
            y[i] = x[i] + h;
            let fp = f(&y);
            y[i] = x[i] - h;
            let fm = f(&y);
            y[i] = x[i];
            fp.iter()
                .zip(&fm)
                .map(|(p, m)| (p - m) / (2.0 * h))
                .collect()
        })
        .collect();
    let m = cols.first().map_or(0, Vec::len);
    (0..m)
        .map(|r| cols.iter().map(|c| c[r]).collect())
        .collect()
}
