//! The `[boundary]` section: its spec (pins, clamps, prescribed motion, each on a region;
//! symmetry planes), its
//! validation and the solver's [`Boundary`] it builds (`docs/scenes.md`).

use std::collections::BTreeSet;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use thinshell_mesh::{Mesh, VertexId};
use thinshell_system::{Boundary, Prescribed};

use super::problem::{Check, Problem, finite, finite_all, problem, v3};
use super::region::RegionSpec;
use thinshell_growth::Region;

/// Boundary conditions.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    /// Pinned vertices (all or some coordinates).
    #[serde(default)]
    pub pins: Vec<PinSpec>,
    /// Clamped boundary edges: both rows of vertices pinned.
    #[serde(default)]
    pub clamps: Vec<ClampSpec>,
    /// Vertices moved with a prescribed velocity.
    #[serde(default)]
    pub prescribed: Vec<PrescribedSpec>,
    /// Symmetry planes: the boundary edges on each become mirror edges.
    #[serde(default)]
    pub symmetry: Vec<SymmetrySpec>,
}

/// A symmetry plane `axis = value` cutting the modelled shell: its boundary edges on the plane
/// become mirror edges (model.md §1.4; `Boundary::mirror_edges`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SymmetrySpec {
    /// The plane's normal axis: "x", "y" or "z".
    pub axis: String,
    /// The plane's coordinate along the axis, m (default 0).
    #[serde(default)]
    pub value: f64,
    /// How far a vertex may lie from the plane and count as on it, m (default 1e-9 × the
    /// mesh's bounding-box diagonal).
    #[serde(default)]
    pub tolerance: Option<f64>,
}

/// Pins the vertices of a region.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PinSpec {
    /// The vertices.
    pub region: RegionSpec,
    /// Pinned coordinates, a subset of "xyz" (default "xyz").
    #[serde(default)]
    pub axes: Option<String>,
}

/// Clamps the boundary edges whose two vertices lie in the region.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ClampSpec {
    /// The edges' region.
    pub region: RegionSpec,
}

/// Prescribed motion x(t) = x(0) + t·velocity of the region's vertices.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PrescribedSpec {
    /// The vertices.
    pub region: RegionSpec,
    /// Velocity, m/s.
    pub velocity: [f64; 3],
}

/// Checks `[boundary]`: valid regions, pinned axes a subset of "xyz", finite velocities.
pub fn validate(b: &BoundarySpec) -> Check {
    for (i, p) in b.pins.iter().enumerate() {
        super::region::validate(&format!("boundary.pins[{i}].region"), &p.region)?;
        if let Some(axes) = &p.axes {
            let key = format!("boundary.pins[{i}].axes");
            if axes.is_empty() || axes.len() > 3 {
                return Err(problem(key, "must be a non-empty subset of \"xyz\""));
            }
            let mut seen = BTreeSet::new();
            for c in axes.chars() {
                if !"xyz".contains(c) || !seen.insert(c) {
                    return Err(problem(
                        key,
                        format!("must be a subset of \"xyz\" without repeats, got \"{axes}\""),
                    ));
                }
            }
        }
    }
    for (i, c) in b.clamps.iter().enumerate() {
        super::region::validate(&format!("boundary.clamps[{i}].region"), &c.region)?;
    }
    for (i, p) in b.prescribed.iter().enumerate() {
        super::region::validate(&format!("boundary.prescribed[{i}].region"), &p.region)?;
        finite_all(&format!("boundary.prescribed[{i}].velocity"), &p.velocity)?;
    }
    for (i, p) in b.symmetry.iter().enumerate() {
        if !["x", "y", "z"].contains(&p.axis.as_str()) {
            return Err(problem(
                format!("boundary.symmetry[{i}].axis"),
                format!("must be \"x\", \"y\" or \"z\", got \"{}\"", p.axis),
            ));
        }
        finite(&format!("boundary.symmetry[{i}].value"), p.value)?;
        if let Some(t) = p.tolerance
            && !(t >= 0.0 && t.is_finite())
        {
            return Err(problem(
                format!("boundary.symmetry[{i}].tolerance"),
                format!("must be >= 0 and finite, got {t}"),
            ));
        }
    }
    Ok(())
}

/// The solver's boundary of a validated `[boundary]` section: regions select vertices of the
/// reference positions `x_ref`; prescribed motion starts from the start positions `x`. A
/// region that selects nothing (no vertex; a clamp's, no boundary edge) or names a vertex the
/// mesh does not have is a problem of its key. The selection is [`crate::Supports`]'s, the
/// Rust API's (one home for both).
pub fn build(
    spec: &BoundarySpec,
    mesh: &Mesh,
    x_ref: &[Vector3<f64>],
    x: &[Vector3<f64>],
) -> Result<Boundary, Problem> {
    let mut boundary = Boundary::default();
    for (i, pin) in spec.pins.iter().enumerate() {
        let key = format!("boundary.pins[{i}].region");
        let inside = region_vertices(&super::region::build(&pin.region), x_ref)
            .map_err(|(sub, m)| problem(format!("{key}{sub}"), m))?;
        pin_vertices(&mut boundary, &inside, pin.axes.as_deref().unwrap_or("xyz"));
    }
    for (i, clamp) in spec.clamps.iter().enumerate() {
        let key = format!("boundary.clamps[{i}].region");
        let inside = region_vertices(&super::region::build(&clamp.region), x_ref)
            .map_err(|(sub, m)| problem(format!("{key}{sub}"), m))?;
        clamp_edges(&mut boundary, mesh, &inside).map_err(|m| problem(key, m))?;
    }
    for (i, plane) in spec.symmetry.iter().enumerate() {
        let axis = "xyz".find(plane.axis.as_str()).ok_or_else(|| {
            problem(
                format!("boundary.symmetry[{i}].axis"),
                "must be \"x\", \"y\" or \"z\"",
            )
        })?;
        mirror_plane(&mut boundary, mesh, axis, plane.value, plane.tolerance)
            .map_err(|m| problem(format!("boundary.symmetry[{i}]"), m))?;
    }
    for (i, p) in spec.prescribed.iter().enumerate() {
        let key = format!("boundary.prescribed[{i}].region");
        let vel = v3(&p.velocity);
        let inside = region_vertices(&super::region::build(&p.region), x_ref)
            .map_err(|(sub, m)| problem(format!("{key}{sub}"), m))?;
        for vtx in inside {
            let x0 = x[vtx];
            boundary.prescribed.push(Prescribed {
                vertex: VertexId::new(vtx),
                position: Box::new(move |t| x0 + vel * t),
            });
        }
    }
    Ok(boundary)
}

/// Vertices of the positions `x` inside `region` (listed vertices: checked against the mesh).
/// An error is a sub-key (`""` or `".vertices"`) and what is wrong.
pub(crate) fn region_vertices(
    region: &Region,
    x: &[Vector3<f64>],
) -> Result<Vec<usize>, (&'static str, String)> {
    let inside: Vec<usize> = if let Region::Vertices(list) = region {
        if let Some(&bad) = list.iter().find(|&&i| i >= x.len()) {
            return Err((
                ".vertices",
                format!("vertex {bad} out of range (the mesh has {})", x.len()),
            ));
        }
        list.clone()
    } else {
        // The same geometric predicates as the growth crate's regions (half-space, ball, box).
        (0..x.len()).filter(|&i| region.contains(&x[i])).collect()
    };
    if inside.is_empty() {
        return Err(("", "contains no vertex of the mesh".to_string()));
    }
    Ok(inside)
}

/// Pins the coordinates `axes` (letters of "xyz") of `vertices`.
pub(crate) fn pin_vertices(boundary: &mut Boundary, vertices: &[usize], axes: &str) {
    let axes: Vec<usize> = axes.chars().filter_map(|c| "xyz".find(c)).collect();
    for &vtx in vertices {
        boundary
            .pinned_coordinates
            .extend(axes.iter().map(|&a| (VertexId::new(vtx), a)));
    }
}

/// Clamps the boundary edges with both ends among `vertices`.
pub(crate) fn clamp_edges(
    boundary: &mut Boundary,
    mesh: &Mesh,
    vertices: &[usize],
) -> Result<(), String> {
    let mut mark = vec![false; mesh.n_vertices()];
    vertices.iter().for_each(|&i| mark[i] = true);
    let topo = mesh.topology();
    let before = boundary.clamped_edges.len();
    for &e in topo.boundary_edges() {
        let [a, b] = topo.edge(e).vertices;
        if mark[a.idx()] && mark[b.idx()] {
            boundary.clamped_edges.push(e);
        }
    }
    if boundary.clamped_edges.len() == before {
        return Err("contains no boundary edge of the mesh".into());
    }
    Ok(())
}

/// Makes the boundary edges on the plane `x[axis] = value` mirror edges; the tolerance
/// defaults to 1e-9 of the mesh's bounding-box diagonal.
pub(crate) fn mirror_plane(
    boundary: &mut Boundary,
    mesh: &Mesh,
    axis: usize,
    value: f64,
    tolerance: Option<f64>,
) -> Result<(), String> {
    let tolerance = tolerance.unwrap_or(1e-9 * mesh.bounding_box().diagonal());
    let edges = Boundary::symmetry_plane(mesh, axis, value, tolerance).map_err(|_| {
        format!(
            "the plane {} = {value} holds no boundary edge of the mesh (within {tolerance:e} m)",
            ["x", "y", "z"].get(axis).copied().unwrap_or("?")
        )
    })?;
    boundary.mirror_edges.extend(edges);
    Ok(())
}
