//! The arithmetic that a formula written once needs, so that the per-face kernels (f64) and
//! the assembler's batched pass (one SIMD lane per face, `assembly::batch`) evaluate the same
//! definition: the metric, the SV norm and K·d, the metric's pull-back, normals and b
//! ([`crate::membrane_strain`], [`crate::stvk_quadratic`], [`crate::sff`]). The dual numbers
//! of the material laws implement it too, and their `Scalar` (derivatives through any
//! function) extends it ([`crate::material::dual`]).
//!
//! Formulas over [`Real`] use only IEEE-exact operations in a fixed order (no fused
//! multiply-add), so a face's result is the same bits in every implementation.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A real number or a vector of them operated on elementwise.
pub(crate) trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The constant c.
    fn cst(c: f64) -> Self;
    /// √x.
    fn sqrt(self) -> Self;
    /// 1/x.
    #[inline(always)]
    fn recip(self) -> Self {
        Self::cst(1.0) / self
    }
}

impl Real for f64 {
    #[inline(always)]
    fn cst(c: f64) -> Self {
        c
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
}

/// A 3-vector of [`Real`]s.
pub(crate) type Vec3<T> = [T; 3];

/// u · v, summed in index order.
#[inline(always)]
pub(crate) fn dot<T: Real>(u: &Vec3<T>, v: &Vec3<T>) -> T {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

/// u × v.
#[inline(always)]
pub(crate) fn cross<T: Real>(u: &Vec3<T>, v: &Vec3<T>) -> Vec3<T> {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// u − v.
#[inline(always)]
pub(crate) fn sub<T: Real>(u: &Vec3<T>, v: &Vec3<T>) -> Vec3<T> {
    [u[0] - v[0], u[1] - v[1], u[2] - v[2]]
}

/// u + v.
#[inline(always)]
pub(crate) fn add<T: Real>(u: &Vec3<T>, v: &Vec3<T>) -> Vec3<T> {
    [u[0] + v[0], u[1] + v[1], u[2] + v[2]]
}

/// s·u (each entry times s).
#[inline(always)]
pub(crate) fn scale<T: Real>(u: &Vec3<T>, s: T) -> Vec3<T> {
    [u[0] * s, u[1] * s, u[2] * s]
}
