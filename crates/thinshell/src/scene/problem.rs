//! [`Problem`]: one problem found in a scene (the key it concerns and what is wrong), shared by
//! the whole-file checks (`validate`) and the sections, with the checks and the array → nalgebra
//! conversions the sections share.

use nalgebra::{Matrix2, Vector3};

/// One problem found in a scene: the key it concerns and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// Dotted key path, e.g. `material.poisson` or `boundary.pins[0].axes`.
    pub key: String,
    /// What is wrong, in one sentence.
    pub message: String,
}

pub(crate) fn problem(key: impl Into<String>, message: impl Into<String>) -> Problem {
    Problem {
        key: key.into(),
        message: message.into(),
    }
}

// Checks shared by the sections; each reports the key it was given.

/// The result of one check.
pub(crate) type Check = Result<(), Problem>;

pub(crate) fn finite(key: &str, v: f64) -> Check {
    if v.is_finite() {
        Ok(())
    } else {
        Err(problem(key, format!("must be a finite number, got {v}")))
    }
}

pub(crate) fn positive(key: &str, v: f64) -> Check {
    finite(key, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(problem(key, format!("must be > 0, got {v}")))
    }
}

pub(crate) fn finite_all(key: &str, v: &[f64]) -> Check {
    for (i, &x) in v.iter().enumerate() {
        if !x.is_finite() {
            return Err(problem(
                format!("{key}[{i}]"),
                format!("must be a finite number, got {x}"),
            ));
        }
    }
    Ok(())
}

pub(crate) fn matrix(key: &str, m: &[[f64; 2]; 2], spd: bool) -> Check {
    finite_all(key, &[m[0][0], m[0][1], m[1][0], m[1][1]])?;
    let scale = m[0][0]
        .abs()
        .max(m[1][1].abs())
        .max(m[0][1].abs())
        .max(1e-300);
    if (m[0][1] - m[1][0]).abs() > 1e-12 * scale {
        return Err(problem(key, "must be symmetric"));
    }
    if spd && !(m[0][0] > 0.0 && m[0][0] * m[1][1] - m[0][1] * m[1][0] > 0.0) {
        return Err(problem(key, "must be positive definite"));
    }
    Ok(())
}

pub(crate) fn absent<T>(key: &str, v: &Option<T>, why: &str) -> Check {
    match v {
        Some(_) => Err(problem(key, format!("does not apply {why}"))),
        None => Ok(()),
    }
}

/// A scene's `[x, y, z]` as a vector.
pub(crate) fn v3(a: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// A scene's row-major 2×2 matrix.
pub(crate) fn m2(m: &[[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(m[0][0], m[0][1], m[1][0], m[1][1])
}
