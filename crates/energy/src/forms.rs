//! First fundamental form of a face.

use nalgebra::{Matrix2, Vector3};

/// a = RᵀR with R = [x_j − x_i | x_k − x_i] (m²), in the face's barycentric basis.
pub fn first_fundamental_form(x: &[Vector3<f64>; 3]) -> Matrix2<f64> {
    let e1 = x[1] - x[0];
    let e2 = x[2] - x[0];
    let a12 = e1.dot(&e2);
    Matrix2::new(e1.dot(&e1), a12, a12, e2.dot(&e2))
}
