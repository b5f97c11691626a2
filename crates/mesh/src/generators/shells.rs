//! Shells of the verification benchmarks (`cargo xtask verify`): hemispheres with and without a
//! polar hole and the slit annulus. The flat [`disc`] and [`annulus`] are mapped onto the
//! sphere (azimuthal equidistant map: a point at distance r from the centre goes to polar
//! angle r / R), so the hemispheres keep their ring structure and normals point outward.

use std::f64::consts::{FRAC_PI_2, TAU};

use nalgebra::Vector3;

use super::{Diagonals, annulus, check_annulus, disc, grid_faces, lattice, positive};
use crate::error::MeshError;
use crate::mesh::Mesh;

/// Maps flat points (z = 0) at distance r from the origin onto the sphere of `radius` around
/// the origin at polar angle r / radius (measured from +z), keeping the azimuth.
fn onto_sphere(mesh: &Mesh, radius: f64) -> Result<Mesh, MeshError> {
    let positions = mesh
        .positions()
        .iter()
        .map(|p| {
            let r = (p.x * p.x + p.y * p.y).sqrt();
            let psi = r / radius;
            let th = p.y.atan2(p.x);
            Vector3::new(
                radius * psi.sin() * th.cos(),
                radius * psi.sin() * th.sin(),
                radius * psi.cos(),
            )
        })
        .collect();
    mesh.with_positions(positions)
}

/// Closed hemisphere (pole at +z, equator in z = 0 as its free edge) of `radius` (m): the
/// [`disc`] of `n_rings` rings mapped onto the sphere, ring k at polar angle (k / n_rings)·π/2
/// with 6k vertices, `1 + 3 n (n + 1)` vertices, `6 n²` faces, outward normals. The equator
/// has a vertex at azimuth 0, and at 90°, 180°, 270° when `n_rings` is even.
pub fn hemisphere(radius: f64, n_rings: usize) -> Result<Mesh, MeshError> {
    positive("radius", radius)?;
    let flat = disc(FRAC_PI_2 * radius, n_rings)?;
    onto_sphere(&flat, radius)
}

/// Hemisphere of `radius` (m) with a polar hole: the part of the sphere between polar angle
/// `hole_angle` (rad, in (0, π/2)) and the equator (z = 0), both edges free. The [`annulus`]
/// of `n_rings` rings of `n_around` vertices mapped onto the sphere: `(n_rings + 1) n_around`
/// vertices, `2 n_rings n_around` faces, outward normals. Odd rings are rotated by half a step;
/// with `n_rings` even the equator has vertices at azimuth 2πm / n_around (so at 0°, 90°,
/// 180°, 270° when `n_around` is a multiple of 4).
pub fn hemisphere_with_hole(
    radius: f64,
    hole_angle: f64,
    n_rings: usize,
    n_around: usize,
) -> Result<Mesh, MeshError> {
    positive("radius", radius)?;
    if !(hole_angle.is_finite() && hole_angle > 0.0 && hole_angle < FRAC_PI_2) {
        return Err(MeshError::InvalidParameter {
            name: "hole_angle",
            value: hole_angle,
            reason: "must lie in (0, pi/2)",
        });
    }
    let flat = annulus(hole_angle * radius, FRAC_PI_2 * radius, n_rings, n_around)?;
    onto_sphere(&flat, radius)
}

/// Slit annulus `r_in ≤ r ≤ r_out` (m) in the plane z = 0, cut along the positive x axis: a
/// structured grid in (θ, r) with `n_around` cells over θ ∈ [0, 2π] and `n_rings` cells over
/// r, alternating diagonals, normals `+z`. The two slit edges (θ = 0 and θ = 2π) occupy the
/// same points but are different vertices, not connected. Vertex (i, j) (i along θ, j along r)
/// has index `j (n_around + 1) + i`: `(n_rings + 1)(n_around + 1)` vertices,
/// `2 n_rings n_around` faces.
pub fn slit_annulus(
    r_in: f64,
    r_out: f64,
    n_rings: usize,
    n_around: usize,
) -> Result<Mesh, MeshError> {
    check_annulus(r_in, r_out, n_rings, n_around)?;
    let mut positions = Vec::with_capacity((n_rings + 1) * (n_around + 1));
    for j in 0..=n_rings {
        let r = r_in + lattice(r_out - r_in, j, n_rings);
        for i in 0..=n_around {
            // The slit edges at exactly θ = 0 and θ = 2π: the same point, two vertices.
            let th = if i == n_around {
                0.0
            } else {
                TAU * i as f64 / n_around as f64
            };
            positions.push(Vector3::new(r * th.cos(), r * th.sin(), 0.0));
        }
    }
    // Counter-clockwise in (θ, r) is clockwise in the plane: reversed for normals +z.
    let faces = grid_faces(n_around, n_rings, Diagonals::Alternating, |i, j| {
        j * (n_around + 1) + i
    })
    .into_iter()
    .map(|[a, b, c]| [a, c, b])
    .collect();
    Mesh::new(positions, faces)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hemisphere_lies_on_the_sphere_with_outward_normals() -> Result<(), MeshError> {
        let m = hemisphere(10.0, 6)?;
        assert_eq!(m.n_faces(), 6 * 36);
        assert_eq!(m.n_vertices(), 1 + 3 * 6 * 7);
        for p in m.positions() {
            assert!((p.norm() - 10.0).abs() < 1e-12);
            assert!(p.z >= -1e-12);
        }
        // One boundary loop (the equator), Euler characteristic of a disc.
        assert_eq!(m.euler_characteristic(), 1);
        assert_eq!(m.topology().boundary_vertices().len(), 36);
        for f in m.faces() {
            let (a, b, c) = (
                m.positions()[f[0].idx()],
                m.positions()[f[1].idx()],
                m.positions()[f[2].idx()],
            );
            let n = (b - a).cross(&(c - a));
            assert!(n.dot(&((a + b + c) / 3.0)) > 0.0, "inward face");
        }
        // Load points of the benchmark on the equator.
        for th in [0.0f64, FRAC_PI_2, 2.0 * FRAC_PI_2, 3.0 * FRAC_PI_2] {
            let target = Vector3::new(10.0 * th.cos(), 10.0 * th.sin(), 0.0);
            let v = m.nearest_vertex(&target);
            assert!((m.positions()[v.idx()] - target).norm() < 1e-9);
        }
        Ok(())
    }

    #[test]
    fn hemisphere_with_hole_spans_the_polar_angles() -> Result<(), MeshError> {
        let hole = 18f64.to_radians();
        let m = hemisphere_with_hole(10.0, hole, 4, 16)?;
        assert_eq!(m.n_vertices(), 5 * 16);
        assert_eq!(m.n_faces(), 2 * 4 * 16);
        assert_eq!(m.euler_characteristic(), 0);
        let polar = |p: &Vector3<f64>| (p.z / p.norm()).acos();
        let min = m
            .positions()
            .iter()
            .map(polar)
            .fold(f64::INFINITY, f64::min);
        let max = m.positions().iter().map(polar).fold(0.0, f64::max);
        assert!((min - hole).abs() < 1e-12 && (max - FRAC_PI_2).abs() < 1e-12);
        for f in m.faces() {
            let (a, b, c) = (
                m.positions()[f[0].idx()],
                m.positions()[f[1].idx()],
                m.positions()[f[2].idx()],
            );
            assert!((b - a).cross(&(c - a)).dot(&a) > 0.0, "inward face");
        }
        assert!(hemisphere_with_hole(10.0, 0.0, 4, 16).is_err());
        assert!(hemisphere_with_hole(10.0, 2.0, 4, 16).is_err());
        Ok(())
    }

    #[test]
    fn slit_annulus_is_cut_along_one_radius() -> Result<(), MeshError> {
        let (n_rings, n_around) = (3, 12);
        let m = slit_annulus(6.0, 10.0, n_rings, n_around)?;
        assert_eq!(m.n_faces(), 2 * n_rings * n_around);
        // A disc topologically: one boundary loop through both slit edges.
        assert_eq!(m.euler_characteristic(), 1);
        assert_eq!(
            m.topology().boundary_vertices().len(),
            2 * (n_around + n_rings)
        );
        for j in 0..=n_rings {
            let (a, b) = (j * (n_around + 1), j * (n_around + 1) + n_around);
            assert!(m.topology().is_boundary_vertex(thinshell_vid(a)));
            assert!(m.topology().is_boundary_vertex(thinshell_vid(b)));
            assert_eq!(m.positions()[a], m.positions()[b]);
        }
        let area: f64 = m
            .faces()
            .iter()
            .map(|f| {
                let p = |k: usize| m.positions()[f[k].idx()];
                0.5 * (p(1) - p(0)).cross(&(p(2) - p(0))).z
            })
            .sum();
        assert!(area > 0.0);
        assert!(slit_annulus(10.0, 6.0, 3, 12).is_err());
        Ok(())
    }

    fn thinshell_vid(i: usize) -> crate::ids::VertexId {
        crate::ids::VertexId::new(i)
    }
}
