//! `Objective::begin_iteration` (the hook contact uses to widen its Hessian pattern mid-solve):
//! an objective that changes its function and its Hessian pattern after the first iteration is
//! minimised to the new function's minimiser, with the new pattern re-analysed.

use faer::sparse::{SparseColMat, Triplet};
use thinshell_solver::{
    IterationUpdate, NewtonSettings, NewtonWorkspace, Objective, SolverError, newton_solve,
};

const N: usize = 6;
/// Coupling stiffness of neighbouring unknowns once switched on.
const C: f64 = 3.0;

/// f = Σ ¼(xᵢ − aᵢ)⁴ + ½(xᵢ − aᵢ)² (+ ½ C Σ (xᵢ − xᵢ₊₁)² once `coupled`): the pattern is
/// diagonal until `coupled`, then tridiagonal. At iteration 1 `begin_iteration` switches the
/// coupling on and moves the targets a.
struct Switching {
    a: [f64; N],
    coupled: bool,
    calls: usize,
    changes: usize,
}

fn gradient_of(a: &[f64; N], coupled: bool, x: &[f64], g: &mut [f64]) -> f64 {
    let mut f = 0.0;
    for i in 0..N {
        let d = x[i] - a[i];
        f += 0.25 * d.powi(4) + 0.5 * d * d;
        g[i] = d.powi(3) + d;
    }
    if coupled {
        for i in 0..N - 1 {
            let d = x[i] - x[i + 1];
            f += 0.5 * C * d * d;
            g[i] += C * d;
            g[i + 1] -= C * d;
        }
    }
    f
}

impl Objective for Switching {
    fn n_dofs(&self) -> usize {
        N
    }
    fn value(&mut self, x: &[f64]) -> Result<f64, SolverError> {
        let mut g = [0.0; N];
        Ok(gradient_of(&self.a, self.coupled, x, &mut g))
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        Ok(gradient_of(&self.a, self.coupled, x, g))
    }
    fn hessian(&mut self, x: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
        // Column-major lower triangle: per column j the diagonal, then (j+1, j) when coupled.
        let val = h.val_mut();
        let mut k = 0;
        for (j, (xj, aj)) in x.iter().zip(&self.a).enumerate() {
            let d = xj - aj;
            let coupling = if self.coupled {
                C * (if j == 0 || j == N - 1 { 1.0 } else { 2.0 })
            } else {
                0.0
            };
            val[k] = 3.0 * d * d + 1.0 + coupling;
            k += 1;
            if self.coupled && j + 1 < N {
                val[k] = -C;
                k += 1;
            }
        }
        assert_eq!(k, val.len(), "pattern and coupling disagree");
        Ok(())
    }
    fn hessian_template(&self) -> SparseColMat<usize, f64> {
        let mut t = Vec::new();
        for j in 0..N {
            t.push(Triplet::new(j, j, 0.0));
            if self.coupled && j + 1 < N {
                t.push(Triplet::new(j + 1, j, 0.0));
            }
        }
        SparseColMat::try_new_from_triplets(N, N, &t).expect("valid pattern")
    }
    fn force_scale(&self) -> f64 {
        1.0
    }
    fn begin_iteration(
        &mut self,
        _x: &[f64],
        iteration: usize,
    ) -> Result<IterationUpdate, SolverError> {
        self.calls += 1;
        if iteration == 1 && !self.coupled {
            self.coupled = true;
            self.a = std::array::from_fn(|i| -0.5 + 0.3 * i as f64);
            self.changes += 1;
            return Ok(IterationUpdate {
                value_changed: true,
                pattern_changed: true,
            });
        }
        Ok(IterationUpdate::default())
    }
}

/// The solve ends at the minimiser of the switched function (its gradient, evaluated here
/// independently, below 10⁻¹⁰; measured 10⁻¹²), the switch happened once, and Newton converged
/// quadratically after it.
#[test]
fn begin_iteration_changes_value_and_pattern_mid_solve() {
    let mut obj = Switching {
        a: [1.0; N],
        coupled: false,
        calls: 0,
        changes: 0,
    };
    let settings = NewtonSettings::default();
    let mut ws = NewtonWorkspace::new(&obj, &settings).expect("workspace");
    let mut x = vec![3.0; N];
    let report = newton_solve(&mut obj, &mut x, &settings, &mut ws).expect("solve");
    let mut g = [0.0; N];
    gradient_of(&obj.a, true, &x, &mut g);
    let residual = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    eprintln!(
        "{} iterations, {} hook calls, corrections {:?}, residual {residual:e}",
        report.iterations, obj.calls, report.corrections
    );
    assert_eq!(obj.changes, 1);
    assert!(obj.calls >= 2 && report.iterations >= 2);
    assert!(
        residual < 1e-10,
        "gradient of the switched function {residual}"
    );
    // Quadratic at the end: the last correction below the square of the one before.
    let c = &report.corrections;
    assert!(
        c.len() >= 2 && c[c.len() - 1] <= c[c.len() - 2].powi(2),
        "{c:?}"
    );
}
