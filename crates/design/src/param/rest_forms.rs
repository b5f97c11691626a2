//! Free rest forms per face.

use super::{Parametrisation, Support, entries, matrix};
use thinshell_energy::RestState;

/// Six free parameters per face: the rest-form entries scaled to be dimensionless,
/// p = (ā11, ā12, ā22)/A₀ and (b̄11, b̄12, b̄22)/√A₀ with A₀ = √det ā₀ of the reference face.
/// Bounds: ā's diagonal entries within [1/25, 25] of the reference's, off-diagonal and b̄
/// entries within ±25 (in the scaled units). Box bounds do not keep ā positive definite: a
/// design that leaves it fails its forward solve with a message naming the face.
#[derive(Clone, Debug)]
pub struct RestForms {
    scale: Vec<f64>,
    base: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl RestForms {
    /// Free rest forms starting from (and scaled by) the reference `base`.
    pub fn new(base: &RestState) -> RestForms {
        let scale: Vec<f64> = base.a_bar.iter().map(|a| a.determinant().sqrt()).collect();
        let mut p = Vec::with_capacity(6 * scale.len());
        let (mut lower, mut upper) = (Vec::new(), Vec::new());
        for (f, &s) in scale.iter().enumerate() {
            let a = entries(&base.a_bar[f]);
            let b = entries(&base.b_bar[f]);
            for (k, v) in a.iter().enumerate() {
                p.push(v / s);
                if k == 1 {
                    lower.push(-25.0);
                    upper.push(25.0);
                } else {
                    lower.push(v / s / 25.0);
                    upper.push(v / s * 25.0);
                }
            }
            for v in b {
                p.push(v / s.sqrt());
                lower.push(-25.0);
                upper.push(25.0);
            }
        }
        RestForms {
            scale,
            base: p,
            lower,
            upper,
        }
    }
}

impl Parametrisation for RestForms {
    fn name(&self) -> &'static str {
        "rest_forms"
    }

    fn len(&self) -> usize {
        self.base.len()
    }

    fn initial(&self) -> Vec<f64> {
        self.base.clone()
    }

    fn bounds(&self) -> (&[f64], &[f64]) {
        (&self.lower, &self.upper)
    }

    fn rest(&self, p: &[f64]) -> RestState {
        let (a_bar, b_bar) = self
            .scale
            .iter()
            .enumerate()
            .map(|(f, &s)| {
                let q = &p[6 * f..6 * f + 6];
                let a: Vec<f64> = q[..3].iter().map(|v| v * s).collect();
                let b: Vec<f64> = q[3..].iter().map(|v| v * s.sqrt()).collect();
                (matrix(&a), matrix(&b))
            })
            .unzip();
        RestState {
            a_bar,
            b_bar,
            sff: None,
        }
    }

    fn pullback(&self, _p: &[f64], w: &[[f64; 6]], grad: &mut [f64]) {
        for (f, (wf, &s)) in w.iter().zip(&self.scale).enumerate() {
            for k in 0..6 {
                grad[6 * f + k] += wf[k] * if k < 3 { s } else { s.sqrt() };
            }
        }
    }

    fn fit_forms(&self, forms: &RestState) -> Vec<f64> {
        let mut p = Vec::with_capacity(self.base.len());
        for (f, &s) in self.scale.iter().enumerate() {
            p.extend(entries(&forms.a_bar[f]).iter().map(|v| v / s));
            p.extend(entries(&forms.b_bar[f]).iter().map(|v| v / s.sqrt()));
        }
        p
    }

    fn layout(&self) -> (Support, usize) {
        (Support::Face, 6)
    }
}
