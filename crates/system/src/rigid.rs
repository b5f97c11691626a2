//! The rigid motions a boundary leaves free, as directions in the free unknowns (what the
//! stability analysis leaves out: [`thinshell_solver::Objective::rigid_modes`]).

use nalgebra::{Matrix6, Vector3, Vector6};
use thinshell_energy::DofMap;

/// The six rigid velocity fields at `x`: translations along x, y, z, then rotations about the
/// axes through the centroid (`ω × (x − c)`), as the velocity of vertex `v` along `axis`.
fn rigid_field(k: usize, p: &Vector3<f64>, centroid: &Vector3<f64>, axis: usize) -> f64 {
    if k < 3 {
        f64::from(u8::from(k == axis))
    } else {
        let mut w = Vector3::zeros();
        w[k - 3] = 1.0;
        w.cross(&(p - centroid))[axis]
    }
}

/// The rigid motions (combinations of the six fields) that move no held coordinate, in the free
/// unknowns (angle unknowns 0: edge-director angles are measured from the faces and do not
/// change under rigid motion). `translations`/`rotations` select which fields are candidates.
/// Returned vectors are orthonormal in the Euclidean inner product of the position unknowns.
pub(crate) fn free_rigid_modes(
    dofs: &DofMap,
    x: &[Vector3<f64>],
    translations: bool,
    rotations: bool,
) -> Vec<Vec<f64>> {
    let n_pos = 3 * x.len();
    if x.is_empty() || !(translations || rotations) {
        return Vec::new();
    }
    let centroid = x.iter().sum::<Vector3<f64>>() / x.len() as f64;
    let size = x
        .iter()
        .fold(0.0f64, |m, p| m.max((p - centroid).norm()))
        .max(f64::MIN_POSITIVE);
    let candidate = |k: usize| if k < 3 { translations } else { rotations };
    let coords = dofs.free_coordinates();
    let mut free = vec![false; n_pos];
    for &c in coords {
        if c < n_pos {
            free[c] = true;
        }
    }
    // Gram matrix of the six fields (rotations scaled by the size) on the held coordinates:
    // its null space holds the rigid motions the boundary allows.
    let field = |k: usize, c: usize| {
        let v = rigid_field(k, &x[c / 3], &centroid, c % 3);
        if k < 3 { v } else { v / size }
    };
    let mut gram = Matrix6::<f64>::zeros();
    let mut n_held = 0usize;
    for c in (0..n_pos).filter(|&c| !free[c]) {
        n_held += 1;
        let f = Vector6::from_fn(|k, _| if candidate(k) { field(k, c) } else { 0.0 });
        gram += f * f.transpose();
    }
    // Fields that are not candidates are excluded by a large penalty.
    for k in (0..6).filter(|&k| !candidate(k)) {
        gram[(k, k)] += 1e30;
    }
    let eig = gram.symmetric_eigen();
    let mut modes: Vec<Vec<f64>> = Vec::new();
    for (j, &lambda) in eig.eigenvalues.iter().enumerate() {
        // A combination that moves the held coordinates only by round-off.
        if lambda > 1e-12 * (1.0 + n_held as f64) {
            continue;
        }
        let a = eig.eigenvectors.column(j);
        let mut v: Vec<f64> = coords
            .iter()
            .map(|&c| {
                if c >= n_pos {
                    return 0.0;
                }
                (0..6).map(|k| a[k] * field(k, c)).sum()
            })
            .collect();
        // Orthonormalise against the modes found so far.
        for m in &modes {
            let d: f64 = v.iter().zip(m).map(|(p, q)| p * q).sum();
            v.iter_mut().zip(m).for_each(|(p, q)| *p -= d * q);
        }
        let norm = v.iter().map(|p| p * p).sum::<f64>().sqrt();
        if norm > 1e-8 * (coords.len() as f64).sqrt() {
            v.iter_mut().for_each(|p| *p /= norm);
            modes.push(v);
        }
    }
    modes
}
