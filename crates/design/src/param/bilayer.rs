//! The two layers' growth tensors of a bilayer, per face.

use super::{Parametrisation, Support, entries, matrix};
use nalgebra::Matrix2;
use thinshell_energy::{Material, MaterialModel, RestState};

/// Per face, the growth metrics G_bottom and G_top (symmetric 2×2, three entries each, in an
/// orthonormal frame of the flat reference face; G = I: no growth) of the two layers. Layer l's
/// stress-free metric at its mid-plane height z_l is ā_l = E₀ᵀ G_l E₀ (ā₀ = E₀ᵀE₀); a shell
/// whose stress-free metric varies linearly through the thickness, ā(z) = ā − 2z b̄ (the
/// [`Bilayer`](thinshell_energy::Bilayer) law's, and the bilayer ↔ curved-monolayer equivalence
/// of van Rees, Vouga & Mahadevan, PNAS 2017), then has
///
/// ā = (z_t ā_b − z_b ā_t)/(z_t − z_b), b̄ = (ā_b − ā_t)/(2 (z_t − z_b)).
///
/// z_b, z_t: the layers' mid-planes (the [`Bilayer`](thinshell_energy::Bilayer)'s layers, or
/// ∓h/4 for a single-layer material). The reference is taken flat (its b̄₀ is not kept).
/// Bounds: the diagonal entries within [1/4, 4] (growth factors 1/2 to 2), off-diagonal ±1.
#[derive(Clone, Debug)]
pub struct BilayerGrowth {
    /// E₀ per face (ā₀ = E₀ᵀE₀).
    frames: Vec<Matrix2<f64>>,
    z: (f64, f64),
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl BilayerGrowth {
    /// Layer growth on the reference `base` for `material` (its layers' heights).
    pub fn new(base: &RestState, material: &Material) -> BilayerGrowth {
        let h = material.thickness;
        let z = match material.model {
            MaterialModel::Bilayer(b) => (
                -0.5 * h + 0.5 * b.bottom.thickness,
                0.5 * h - 0.5 * b.top.thickness,
            ),
            _ => (-0.25 * h, 0.25 * h),
        };
        let frames = base
            .a_bar
            .iter()
            .map(|a| {
                // Cholesky ā₀ = L Lᵀ: E₀ = Lᵀ.
                let l11 = a[(0, 0)].sqrt();
                let l21 = a[(1, 0)] / l11;
                let l22 = (a[(1, 1)] - l21 * l21).sqrt();
                Matrix2::new(l11, l21, 0.0, l22)
            })
            .collect::<Vec<_>>();
        let n = 6 * frames.len();
        let lower = (0..n)
            .map(|i| if i % 3 == 1 { -1.0 } else { 0.25 })
            .collect();
        let upper = (0..n).map(|i| if i % 3 == 1 { 1.0 } else { 4.0 }).collect();
        BilayerGrowth {
            frames,
            z,
            lower,
            upper,
        }
    }

    /// The same with the layers' growth factors bounded to [`min`, `max`] (diagonal entries
    /// of G in [min², max²]).
    pub fn with_bounds(mut self, min: f64, max: f64) -> BilayerGrowth {
        for i in 0..self.lower.len() {
            if i % 3 != 1 {
                self.lower[i] = min * min;
                self.upper[i] = max * max;
            }
        }
        self
    }

    /// Rest forms (ā, b̄) of one face from its two layer metrics.
    fn forms(&self, ab: Matrix2<f64>, at: Matrix2<f64>) -> (Matrix2<f64>, Matrix2<f64>) {
        let (zb, zt) = self.z;
        let d = zt - zb;
        ((ab * zt - at * zb) / d, (ab - at) / (2.0 * d))
    }
}

impl Parametrisation for BilayerGrowth {
    fn name(&self) -> &'static str {
        "bilayer"
    }

    fn len(&self) -> usize {
        6 * self.frames.len()
    }

    fn initial(&self) -> Vec<f64> {
        (0..self.len())
            .map(|i| if i % 3 == 1 { 0.0 } else { 1.0 })
            .collect()
    }

    fn bounds(&self) -> (&[f64], &[f64]) {
        (&self.lower, &self.upper)
    }

    fn rest(&self, p: &[f64]) -> RestState {
        let (a_bar, b_bar) = self
            .frames
            .iter()
            .enumerate()
            .map(|(f, e)| {
                let q = &p[6 * f..6 * f + 6];
                let ab = e.transpose() * matrix(&q[..3]) * e;
                let at = e.transpose() * matrix(&q[3..]) * e;
                self.forms(ab, at)
            })
            .unzip();
        RestState {
            a_bar,
            b_bar,
            sff: None,
        }
    }

    fn pullback(&self, _p: &[f64], w: &[[f64; 6]], grad: &mut [f64]) {
        // Linear in p: the derivative in each entry is the forms of that unit entry.
        let units = [
            Matrix2::new(1.0, 0.0, 0.0, 0.0),
            Matrix2::new(0.0, 1.0, 1.0, 0.0),
            Matrix2::new(0.0, 0.0, 0.0, 1.0),
        ];
        for (f, (wf, e)) in w.iter().zip(&self.frames).enumerate() {
            for layer in 0..2 {
                for (k, u) in units.iter().enumerate() {
                    let g = e.transpose() * u * e;
                    let zero = Matrix2::zeros();
                    let (a, b) = if layer == 0 {
                        self.forms(g, zero)
                    } else {
                        self.forms(zero, g)
                    };
                    let (a, b) = (entries(&a), entries(&b));
                    grad[6 * f + 3 * layer + k] +=
                        (0..3).map(|i| wf[i] * a[i] + wf[3 + i] * b[i]).sum::<f64>();
                }
            }
        }
    }

    /// The algebraic design: ā_l = a − 2 z_l b for target forms (a, b), G_l = E₀⁻ᵀ ā_l E₀⁻¹.
    fn fit_forms(&self, forms: &RestState) -> Vec<f64> {
        let (zb, zt) = self.z;
        let mut p = Vec::with_capacity(self.len());
        for (f, e) in self.frames.iter().enumerate() {
            let inv = e.try_inverse().unwrap_or_else(Matrix2::identity);
            for z in [zb, zt] {
                let al = forms.a_bar[f] - forms.b_bar[f] * (2.0 * z);
                p.extend(entries(&(inv.transpose() * al * inv)));
            }
        }
        p
    }

    fn layout(&self) -> (Support, usize) {
        (Support::Face, 6)
    }
}
