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
/// mesh does not have is a problem of its key.
pub fn build(
    spec: &BoundarySpec,
    mesh: &Mesh,
    x_ref: &[Vector3<f64>],
    x: &[Vector3<f64>],
) -> Result<Boundary, Problem> {
    let mut boundary = Boundary::default();
    for (i, pin) in spec.pins.iter().enumerate() {
        let key = format!("boundary.pins[{i}].region");
        let axes: Vec<usize> = pin
            .axes
            .as_deref()
            .unwrap_or("xyz")
            .chars()
            .filter_map(|c| "xyz".find(c))
            .collect();
        for vtx in region_vertices(&key, &pin.region, x_ref)? {
            boundary
                .pinned_coordinates
                .extend(axes.iter().map(|&a| (VertexId::new(vtx), a)));
        }
    }
    for (i, clamp) in spec.clamps.iter().enumerate() {
        let key = format!("boundary.clamps[{i}].region");
        let inside = region_vertices(&key, &clamp.region, x_ref)?;
        let mut mark = vec![false; x_ref.len()];
        inside.iter().for_each(|&i| mark[i] = true);
        let topo = mesh.topology();
        let before = boundary.clamped_edges.len();
        for &e in topo.boundary_edges() {
            let [a, b] = topo.edge(e).vertices;
            if mark[a.idx()] && mark[b.idx()] {
                boundary.clamped_edges.push(e);
            }
        }
        if boundary.clamped_edges.len() == before {
            return Err(problem(key, "contains no boundary edge of the mesh"));
        }
    }
    for (i, plane) in spec.symmetry.iter().enumerate() {
        let axis = "xyz".find(plane.axis.as_str()).ok_or_else(|| {
            problem(
                format!("boundary.symmetry[{i}].axis"),
                "must be \"x\", \"y\" or \"z\"",
            )
        })?;
        let tolerance = plane
            .tolerance
            .unwrap_or(1e-9 * mesh.bounding_box().diagonal());
        let edges = Boundary::symmetry_plane(mesh, axis, plane.value, tolerance).map_err(|_| {
            problem(
                format!("boundary.symmetry[{i}]"),
                format!(
                    "the plane {} = {} holds no boundary edge of the mesh (within {tolerance:e} m)",
                    plane.axis, plane.value
                ),
            )
        })?;
        boundary.mirror_edges.extend(edges);
    }
    for (i, p) in spec.prescribed.iter().enumerate() {
        let key = format!("boundary.prescribed[{i}].region");
        let vel = v3(&p.velocity);
        for vtx in region_vertices(&key, &p.region, x_ref)? {
            let x0 = x[vtx];
            boundary.prescribed.push(Prescribed {
                vertex: VertexId::new(vtx),
                position: Box::new(move |t| x0 + vel * t),
            });
        }
    }
    Ok(boundary)
}

/// Vertices of the reference positions `x` inside a region given under `key`.
fn region_vertices(
    key: &str,
    region: &RegionSpec,
    x: &[Vector3<f64>],
) -> Result<Vec<usize>, Problem> {
    let inside: Vec<usize> = if let Some(list) = &region.vertices {
        if let Some(&bad) = list.iter().find(|&&i| i >= x.len()) {
            return Err(problem(
                format!("{key}.vertices"),
                format!("vertex {bad} out of range (the mesh has {})", x.len()),
            ));
        }
        list.clone()
    } else {
        // The same geometric predicates as the growth crate's regions (half-space, ball, box).
        let r = super::region::build(region);
        (0..x.len()).filter(|&i| r.contains(&x[i])).collect()
    };
    if inside.is_empty() {
        return Err(problem(key, "contains no vertex of the mesh"));
    }
    Ok(inside)
}
