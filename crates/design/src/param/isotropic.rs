//! Isotropic (conformal) growth per vertex or per face.

use super::{Parametrisation, entries};
use thinshell_energy::RestState;
use thinshell_mesh::Mesh;

/// Where a parameter group sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// One group per vertex (a face takes the mean of its three vertices').
    Vertex,
    /// One group per face.
    Face,
}

/// Isotropic growth: one log-growth s per vertex or face, ā = e^{2s} ā₀ and b̄ = e^{s} b̄₀ (a
/// similarity of the reference: lengths scale by e^{s}, the shape operator by e^{−s}); with
/// vertex support the face's s is the mean of its vertices'. Bounds: the growth factor e^{s}
/// within [`Isotropic::with_bounds`] (default [0.2, 5]).
#[derive(Clone, Debug)]
pub struct Isotropic {
    support: Support,
    faces: Vec<[usize; 3]>,
    base: RestState,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Isotropic {
    /// Isotropic growth of the reference `base` on `mesh`, per `support`.
    pub fn new(mesh: &Mesh, base: &RestState, support: Support) -> Isotropic {
        let n = match support {
            Support::Vertex => mesh.n_vertices(),
            Support::Face => mesh.n_faces(),
        };
        Isotropic {
            support,
            faces: mesh.faces_usize(),
            base: base.clone(),
            lower: vec![0.2f64.ln(); n],
            upper: vec![5.0f64.ln(); n],
        }
    }

    /// The same with the growth factor e^{s} bounded to [`min`, `max`] (dimensionless,
    /// 0 < min ≤ 1 ≤ max).
    pub fn with_bounds(mut self, min: f64, max: f64) -> Isotropic {
        self.lower.iter_mut().for_each(|l| *l = min.ln());
        self.upper.iter_mut().for_each(|u| *u = max.ln());
        self
    }

    fn face_s(&self, p: &[f64], f: usize) -> f64 {
        match self.support {
            Support::Face => p[f],
            Support::Vertex => self.faces[f].iter().map(|&v| p[v]).sum::<f64>() / 3.0,
        }
    }
}

impl Parametrisation for Isotropic {
    fn name(&self) -> &'static str {
        "isotropic"
    }

    fn len(&self) -> usize {
        self.lower.len()
    }

    fn initial(&self) -> Vec<f64> {
        vec![0.0; self.len()]
    }

    fn bounds(&self) -> (&[f64], &[f64]) {
        (&self.lower, &self.upper)
    }

    fn rest(&self, p: &[f64]) -> RestState {
        let mut rest = self.base.clone();
        rest.sff = None;
        for f in 0..self.faces.len() {
            let s = self.face_s(p, f);
            rest.a_bar[f] *= (2.0 * s).exp();
            rest.b_bar[f] *= s.exp();
        }
        rest
    }

    fn pullback(&self, p: &[f64], w: &[[f64; 6]], grad: &mut [f64]) {
        for (f, wf) in w.iter().enumerate() {
            let s = self.face_s(p, f);
            let a = entries(&self.base.a_bar[f]);
            let b = entries(&self.base.b_bar[f]);
            let (ea, eb) = ((2.0 * s).exp(), s.exp());
            let mut d = 0.0;
            for k in 0..3 {
                d += wf[k] * 2.0 * ea * a[k] + wf[3 + k] * eb * b[k];
            }
            match self.support {
                Support::Face => grad[f] += d,
                Support::Vertex => self.faces[f].iter().for_each(|&v| grad[v] += d / 3.0),
            }
        }
    }

    /// s per face = ½ ln(A/A₀) (the area ratio); per vertex the mean over its faces.
    fn fit_forms(&self, forms: &RestState) -> Vec<f64> {
        let face: Vec<f64> = (0..self.faces.len())
            .map(|f| 0.25 * (forms.a_bar[f].determinant() / self.base.a_bar[f].determinant()).ln())
            .collect();
        match self.support {
            Support::Face => face,
            Support::Vertex => {
                let n = self.len();
                let (mut sum, mut count) = (vec![0.0; n], vec![0usize; n]);
                for (f, tri) in self.faces.iter().enumerate() {
                    for &v in tri {
                        sum[v] += face[f];
                        count[v] += 1;
                    }
                }
                sum.iter()
                    .zip(&count)
                    .map(|(s, &c)| if c > 0 { s / c as f64 } else { 0.0 })
                    .collect()
            }
        }
    }

    fn layout(&self) -> (Support, usize) {
        (self.support, 1)
    }
}
