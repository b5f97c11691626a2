//! Second-order forward-mode numbers in the six form entries (a11, a12, a22, b11, b12, b22):
//! value, gradient and Hessian carried through +, −, ×, 1/x and ln, so that a nonlinear law is
//! written once as plain arithmetic and its exact derivatives follow.

use nalgebra::{SMatrix, SVector};
use std::ops::{Add, Mul, Sub};

/// A scalar function of the six form entries with its gradient and Hessian.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dual {
    pub v: f64,
    pub g: SVector<f64, 6>,
    pub h: SMatrix<f64, 6, 6>,
}

impl Dual {
    /// The constant c.
    pub fn constant(c: f64) -> Dual {
        Dual {
            v: c,
            g: SVector::zeros(),
            h: SMatrix::zeros(),
        }
    }

    /// The i-th independent variable at value v.
    pub fn variable(v: f64, i: usize) -> Dual {
        let mut d = Dual::constant(v);
        d.g[i] = 1.0;
        d
    }

    /// f(self) for f with value f0, first derivative f1, second derivative f2 at self.v.
    fn chain(self, f0: f64, f1: f64, f2: f64) -> Dual {
        Dual {
            v: f0,
            g: self.g * f1,
            h: self.h * f1 + self.g * self.g.transpose() * f2,
        }
    }

    /// 1/x.
    pub fn recip(self) -> Dual {
        let r = 1.0 / self.v;
        self.chain(r, -r * r, 2.0 * r * r * r)
    }

    /// ln x (NaN for x ≤ 0, never a panic).
    pub fn ln(self) -> Dual {
        let r = 1.0 / self.v;
        self.chain(self.v.ln(), r, -r * r)
    }

    /// c·x.
    pub fn scale(self, c: f64) -> Dual {
        Dual {
            v: self.v * c,
            g: self.g * c,
            h: self.h * c,
        }
    }
}

impl Add for Dual {
    type Output = Dual;
    fn add(self, o: Dual) -> Dual {
        Dual {
            v: self.v + o.v,
            g: self.g + o.g,
            h: self.h + o.h,
        }
    }
}

impl Sub for Dual {
    type Output = Dual;
    fn sub(self, o: Dual) -> Dual {
        Dual {
            v: self.v - o.v,
            g: self.g - o.g,
            h: self.h - o.h,
        }
    }
}

impl Mul for Dual {
    type Output = Dual;
    fn mul(self, o: Dual) -> Dual {
        let cross = self.g * o.g.transpose();
        Dual {
            v: self.v * o.v,
            g: o.g * self.v + self.g * o.v,
            h: o.h * self.v + self.h * o.v + cross + cross.transpose(),
        }
    }
}

/// A 2×2 matrix of [`Dual`]s (row-major `[[m11, m12], [m21, m22]]`).
pub(crate) type DualMat = [[Dual; 2]; 2];

/// Product of two 2×2 matrices.
pub(crate) fn mat_mul(p: &DualMat, q: &DualMat) -> DualMat {
    std::array::from_fn(|i| std::array::from_fn(|j| p[i][0] * q[0][j] + p[i][1] * q[1][j]))
}

/// ‖M‖²_SV = α/2 tr(M)² + β tr(M²) of a general 2×2 matrix.
pub(crate) fn sv_norm_sq(m: &DualMat, alpha: f64, beta: f64) -> Dual {
    let tr = m[0][0] + m[1][1];
    let tr_sq = m[0][0] * m[0][0] + m[0][1] * m[1][0] + m[1][0] * m[0][1] + m[1][1] * m[1][1];
    (tr * tr).scale(0.5 * alpha) + tr_sq.scale(beta)
}
