//! Proptest strategies for per-face kernel inputs, and the case-count convention.
//!
//! Property tests run a modest number of cases by default (each test names its own default
//! through [`cases_or`]) so that `cargo test` stays fast; `PROPTEST_CASES=N` raises it for a
//! thorough run.

use nalgebra::{Matrix2, Vector3};
use proptest::prelude::*;
use thinshell_energy::{FaceRest, FaceStencil};

/// The case count from the `PROPTEST_CASES` environment variable, or `default` when it is
/// unset or not a number.
pub fn cases_or(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// A well-shaped triangle (edges ≈ 1 m, vertices jittered by up to 0.2 m in plane) plus a flap
/// vertex beyond each edge, 0.3–0.8 m out from the edge's midpoint and up to ±0.6 m off the
/// face's plane (dihedral angles up to about ±1.1 rad), with any boundary mask.
pub fn stencil_strategy() -> impl Strategy<Value = FaceStencil> {
    (
        prop::array::uniform6(-0.2f64..0.2),
        prop::array::uniform3(-0.6f64..0.6),
        prop::array::uniform3(0.3f64..0.8),
        prop::array::uniform3(any::<bool>()),
    )
        .prop_map(|(jit, heights, out, flap)| {
            let base = [
                Vector3::new(0.0, 0.0, 0.1),
                Vector3::new(1.0, 0.0, -0.1),
                Vector3::new(0.5, 0.9, 0.05),
            ];
            let mut x = [Vector3::zeros(); 6];
            for (i, xi) in x.iter_mut().take(3).enumerate() {
                *xi = base[i] + Vector3::new(jit[2 * i], jit[2 * i + 1], 0.0);
            }
            let n = (x[1] - x[0]).cross(&(x[2] - x[0])).normalize();
            for e in 0..3 {
                let (p, q) = (x[(e + 1) % 3], x[(e + 2) % 3]);
                let mid = (p + q) * 0.5;
                let away = (mid - x[e]).normalize();
                x[3 + e] = mid + away * out[e] + n * heights[e];
            }
            FaceStencil::new(x, flap)
        })
}

/// Rest forms of one face: ā = L Lᵀ with L lower triangular, diagonal in [0.7, 1.3] and
/// [0.5, 1.1] (so ā is symmetric positive definite), and a symmetric b̄ with entries in [−1, 1).
pub fn rest_strategy() -> impl Strategy<Value = FaceRest> {
    (
        prop::array::uniform3(-0.3f64..0.3),
        prop::array::uniform3(-1.0f64..1.0),
    )
        .prop_map(|(p, q)| {
            let l = Matrix2::new(1.0 + p[0], 0.0, p[1], 0.8 + p[2]);
            FaceRest {
                a_bar: l * l.transpose(),
                b_bar: Matrix2::new(q[0], q[1], q[1], q[2]),
            }
        })
}
