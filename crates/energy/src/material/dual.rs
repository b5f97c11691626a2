//! Second-order forward-mode numbers: value, gradient and Hessian in N variables carried through
//! +, −, ×, 1/x, √x and ln, so that a nonlinear function is written once as plain arithmetic and
//! its exact derivatives follow. The material laws use N = 6 (the form entries a11, a12, a22,
//! b11, b12, b22, `Dual`); the contact distances use N = 12 (four points).

use crate::real::Real;
use nalgebra::{SMatrix, SVector};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A scalar function of N variables with its gradient and Hessian (also used by the contact
/// crate's distances, N = 12).
#[derive(Clone, Copy, Debug)]
pub struct DualN<const N: usize> {
    /// Value.
    pub v: f64,
    /// Gradient in the N variables.
    pub g: SVector<f64, N>,
    /// Hessian in the N variables (symmetric).
    pub h: SMatrix<f64, N, N>,
}

/// A scalar function of the six form entries with its gradient and Hessian.
pub(crate) type Dual = DualN<6>;

impl<const N: usize> DualN<N> {
    /// The constant c.
    pub fn constant(c: f64) -> Self {
        DualN {
            v: c,
            g: SVector::zeros(),
            h: SMatrix::zeros(),
        }
    }

    /// The i-th independent variable at value v.
    pub fn variable(v: f64, i: usize) -> Self {
        let mut d = Self::constant(v);
        d.g[i] = 1.0;
        d
    }

    /// f(self) for f with value f0, first derivative f1, second derivative f2 at self.v.
    pub fn chain(self, f0: f64, f1: f64, f2: f64) -> Self {
        // h·f1 + (g gᵀ)·f2 in one pass: the matrix expression builds two N×N temporaries, and
        // for N = 19 (the free-edge fit) copying them cost as much as the arithmetic.
        let mut h = self.h;
        for j in 0..N {
            for i in 0..N {
                h[(i, j)] = self.h[(i, j)] * f1 + self.g[i] * self.g[j] * f2;
            }
        }
        DualN {
            v: f0,
            g: self.g * f1,
            h,
        }
    }

    /// 1/x.
    pub fn recip(self) -> Self {
        let r = 1.0 / self.v;
        self.chain(r, -r * r, 2.0 * r * r * r)
    }

    /// ln x (NaN for x ≤ 0, never a panic).
    pub fn ln(self) -> Self {
        let r = 1.0 / self.v;
        self.chain(self.v.ln(), r, -r * r)
    }

    /// √x (NaN for x < 0; infinite derivatives at 0).
    pub fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.chain(s, 0.5 / s, -0.25 / (s * self.v))
    }

    /// c·x.
    pub fn scale(self, c: f64) -> Self {
        DualN {
            v: self.v * c,
            g: self.g * c,
            h: self.h * c,
        }
    }
}

impl<const N: usize> Add for DualN<N> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        DualN {
            v: self.v + o.v,
            g: self.g + o.g,
            h: self.h + o.h,
        }
    }
}

impl<const N: usize> Sub for DualN<N> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        DualN {
            v: self.v - o.v,
            g: self.g - o.g,
            h: self.h - o.h,
        }
    }
}

impl<const N: usize> Mul for DualN<N> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        // o.h·v + h·o.v + g o.gᵀ + o.g gᵀ in one pass, summed in that order (see `chain`).
        let mut h = self.h;
        for j in 0..N {
            for i in 0..N {
                h[(i, j)] = o.h[(i, j)] * self.v
                    + self.h[(i, j)] * o.v
                    + self.g[i] * o.g[j]
                    + self.g[j] * o.g[i];
            }
        }
        DualN {
            v: self.v * o.v,
            g: o.g * self.v + self.g * o.v,
            h,
        }
    }
}

/// A 2×2 matrix of [`Dual`]s (row-major `[[m11, m12], [m21, m22]]`).
pub(crate) type DualMat = [[Dual; 2]; 2];

/// Product of two 2×2 matrices.
pub(crate) fn mat_mul(p: &DualMat, q: &DualMat) -> DualMat {
    std::array::from_fn(|i| std::array::from_fn(|j| p[i][0] * q[0][j] + p[i][1] * q[1][j]))
}

/// What formulas written once for values and derivatives need beyond [`Real`]'s arithmetic:
/// f64 for values, [`Dual1`] for exact gradients, [`DualN`] for exact gradients and Hessians
/// (the free-edge fit, the SV norm of a general matrix).
pub(crate) trait Scalar: Real {
    /// c·x.
    fn scale(self, c: f64) -> Self;
    /// g(x) for g with value f0, first derivative f1, second derivative f2 at x.
    fn apply(self, f0: f64, f1: f64, f2: f64) -> Self;
    /// The value.
    fn value(self) -> f64;
}

impl Scalar for f64 {
    #[inline]
    fn scale(self, c: f64) -> Self {
        self * c
    }
    #[inline]
    fn apply(self, f0: f64, _: f64, _: f64) -> Self {
        f0
    }
    #[inline]
    fn value(self) -> f64 {
        self
    }
}

impl<const N: usize> Real for DualN<N> {
    #[inline]
    fn cst(c: f64) -> Self {
        DualN::constant(c)
    }
    #[inline]
    fn recip(self) -> Self {
        DualN::recip(self)
    }
    #[inline]
    fn sqrt(self) -> Self {
        DualN::sqrt(self)
    }
}

impl<const N: usize> Div for DualN<N> {
    type Output = Self;
    #[allow(clippy::suspicious_arithmetic_impl)] // x/y = x·(1/y): the chain rule through 1/y
    fn div(self, o: Self) -> Self {
        self * o.recip()
    }
}

impl<const N: usize> Neg for DualN<N> {
    type Output = Self;
    fn neg(self) -> Self {
        DualN {
            v: -self.v,
            g: -self.g,
            h: -self.h,
        }
    }
}

impl<const N: usize> Scalar for DualN<N> {
    #[inline]
    fn scale(self, c: f64) -> Self {
        DualN::scale(self, c)
    }
    #[inline]
    fn apply(self, f0: f64, f1: f64, f2: f64) -> Self {
        self.chain(f0, f1, f2)
    }
    #[inline]
    fn value(self) -> f64 {
        self.v
    }
}

/// A scalar function of N variables with its gradient only: the first-order companion of
/// [`DualN`] for gradient-only evaluations, about N flops per operation instead of N².
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dual1<const N: usize> {
    pub v: f64,
    pub g: SVector<f64, N>,
}

impl<const N: usize> Dual1<N> {
    /// The i-th independent variable at value v.
    pub fn variable(v: f64, i: usize) -> Self {
        let mut g = SVector::zeros();
        g[i] = 1.0;
        Dual1 { v, g }
    }
}

impl<const N: usize> Add for Dual1<N> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Dual1 {
            v: self.v + o.v,
            g: self.g + o.g,
        }
    }
}

impl<const N: usize> Sub for Dual1<N> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Dual1 {
            v: self.v - o.v,
            g: self.g - o.g,
        }
    }
}

impl<const N: usize> Mul for Dual1<N> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Dual1 {
            v: self.v * o.v,
            g: o.g * self.v + self.g * o.v,
        }
    }
}

impl<const N: usize> Real for Dual1<N> {
    #[inline]
    fn cst(c: f64) -> Self {
        Dual1 {
            v: c,
            g: SVector::zeros(),
        }
    }
    #[inline]
    fn recip(self) -> Self {
        let r = 1.0 / self.v;
        self.apply(r, -r * r, 0.0)
    }
    #[inline]
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.apply(s, 0.5 / s, 0.0)
    }
}

impl<const N: usize> Div for Dual1<N> {
    type Output = Self;
    #[allow(clippy::suspicious_arithmetic_impl)] // x/y = x·(1/y): the chain rule through 1/y
    fn div(self, o: Self) -> Self {
        self * o.recip()
    }
}

impl<const N: usize> Neg for Dual1<N> {
    type Output = Self;
    fn neg(self) -> Self {
        Dual1 {
            v: -self.v,
            g: -self.g,
        }
    }
}

impl<const N: usize> Scalar for Dual1<N> {
    #[inline]
    fn scale(self, c: f64) -> Self {
        Dual1 {
            v: self.v * c,
            g: self.g * c,
        }
    }
    #[inline]
    fn apply(self, f0: f64, f1: f64, _: f64) -> Self {
        Dual1 {
            v: f0,
            g: self.g * f1,
        }
    }
    #[inline]
    fn value(self) -> f64 {
        self.v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-pass products equal the matrix expressions they replace, bit for bit.
    #[test]
    fn one_pass_products_equal_the_matrix_expressions() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut dual = || DualN::<19> {
            v: next(),
            g: SVector::from_fn(|_, _| next()),
            h: SMatrix::from_fn(|_, _| next()),
        };
        for _ in 0..20 {
            let (a, b) = (dual(), dual());
            let p = a * b;
            let cross = a.g * b.g.transpose();
            assert_eq!(p.h, b.h * a.v + a.h * b.v + cross + cross.transpose());
            assert_eq!(p.g, b.g * a.v + a.g * b.v);
            let (f1, f2) = (1.7, -0.3);
            let c = a.chain(0.0, f1, f2);
            assert_eq!(c.h, a.h * f1 + a.g * a.g.transpose() * f2);
        }
    }
}
