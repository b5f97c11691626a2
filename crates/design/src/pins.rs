//! Holding the rigid motions of a flat sheet without holding its shape.

use thinshell_mesh::{Mesh, VertexId};

use crate::DesignError;

/// Six pinned coordinates `(vertex, axis)` that remove the rigid motions of a sheet whose
/// reference lies in a plane z = const, and that any deformed shape can satisfy exactly (a
/// statically determinate support, also at large deformation): a vertex a held in x, y, z;
/// the vertex b farthest from a on the line through a along x (same y and z) held in y and z
/// (free to slide along ab); the vertex c farthest from that line held in z (free in the
/// plane z = const through a and b). A designed shape is then compared modulo rigid motion.
/// `anchor`: a; errors when the reference is not planar in z or no vertex shares a's y.
pub fn planar_rigid_pins(
    mesh: &Mesh,
    anchor: VertexId,
) -> Result<Vec<(VertexId, usize)>, DesignError> {
    let p = mesh.positions();
    let a = *p.get(anchor.idx()).ok_or_else(|| {
        DesignError::Invalid(format!("anchor vertex {} out of range", anchor.idx()))
    })?;
    let size = mesh.bounding_box().diagonal().max(f64::MIN_POSITIVE);
    let tol = 1e-9 * size;
    if p.iter().any(|q| (q.z - a.z).abs() > tol) {
        return Err(DesignError::Invalid(
            "planar rigid pins need a reference in a plane z = const".into(),
        ));
    }
    let b = (0..p.len())
        .filter(|&i| (p[i].y - a.y).abs() <= tol && i != anchor.idx())
        .max_by(|&i, &j| (p[i].x - a.x).abs().total_cmp(&(p[j].x - a.x).abs()))
        .ok_or_else(|| {
            DesignError::Invalid(
                "planar rigid pins: no other vertex on the anchor's line along x".into(),
            )
        })?;
    let c = (0..p.len())
        .max_by(|&i, &j| (p[i].y - a.y).abs().total_cmp(&(p[j].y - a.y).abs()))
        .filter(|&i| (p[i].y - a.y).abs() > tol)
        .ok_or_else(|| {
            DesignError::Invalid("planar rigid pins: all vertices on one line".into())
        })?;
    let (b, c) = (VertexId::new(b), VertexId::new(c));
    Ok(vec![
        (anchor, 0),
        (anchor, 1),
        (anchor, 2),
        (b, 1),
        (b, 2),
        (c, 2),
    ])
}
