//! The `[rest]` section: its spec (rest forms from the mesh or planar forms), its validation
//! and the rest state it builds (`docs/scenes.md`).

use nalgebra::{Matrix2, Vector3};
use serde::{Deserialize, Serialize};
use thinshell_energy::{EnergyError, RestState, SffKind};
use thinshell_mesh::Mesh;

use super::problem::{Check, absent, m2, matrix, problem};

/// Where the rest forms (ā, b̄) come from before any growth.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum RestSource {
    /// The forms (a⁰, b⁰) of the mesh as loaded or generated (before `[initial]`).
    #[default]
    Mesh,
    /// Planar forms `a_xy`, `b_xy` mapped to each face: ā = Tᵀ ā^{xy} T (model.md §5).
    Planar,
    /// Forms per face read from a CSV file (`file`, relative to the scene), e.g. a designed
    /// growth pattern written by `thinshell design`.
    File,
}

/// Rest forms.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct RestSpec {
    /// `mesh` (default) or `planar`.
    #[serde(default)]
    pub from: RestSource,
    /// ā^{xy} (row-major 2×2, symmetric positive definite), for `from = "planar"`.
    #[serde(default)]
    pub a_xy: Option<[[f64; 2]; 2]>,
    /// b̄^{xy} (row-major 2×2, symmetric), for `from = "planar"`; default 0.
    #[serde(default)]
    pub b_xy: Option<[[f64; 2]; 2]>,
    /// CSV of the forms per face, for `from = "file"`: a header line, then one line per face
    /// `a11,a12,a22,b11,b12,b22` (m², m; each face's barycentric basis).
    #[serde(default)]
    pub file: Option<String>,
}

/// Checks `[rest]`: planar forms only with `from = "planar"`, ā^{xy} given and SPD, b̄^{xy}
/// symmetric.
pub fn validate(r: &RestSpec) -> Check {
    if r.from != RestSource::File {
        absent("rest.file", &r.file, "unless rest.from = \"file\"")?;
    }
    match r.from {
        RestSource::Mesh => {
            absent("rest.a_xy", &r.a_xy, "when rest.from = \"mesh\"")?;
            absent("rest.b_xy", &r.b_xy, "when rest.from = \"mesh\"")
        }
        RestSource::File => {
            absent("rest.a_xy", &r.a_xy, "when rest.from = \"file\"")?;
            absent("rest.b_xy", &r.b_xy, "when rest.from = \"file\"")?;
            r.file
                .as_ref()
                .map(|_| ())
                .ok_or_else(|| problem("rest.file", "is required when rest.from = \"file\""))
        }
        RestSource::Planar => {
            let a = r
                .a_xy
                .as_ref()
                .ok_or_else(|| problem("rest.a_xy", "is required when rest.from = \"planar\""))?;
            matrix("rest.a_xy", a, true)?;
            if let Some(b) = &r.b_xy {
                matrix("rest.b_xy", b, false)?;
            }
            Ok(())
        }
    }
}

/// The rest state (before growth) of a validated `[rest]` section: the forms of the mesh's
/// positions `x_ref` with the bending form `sff`, or the planar forms.
pub fn build(
    spec: &RestSpec,
    mesh: &Mesh,
    x_ref: &[Vector3<f64>],
    sff: SffKind,
    mirror_edges: &[(thinshell_mesh::EdgeId, Vector3<f64>)],
) -> Result<RestState, EnergyError> {
    match spec.from {
        RestSource::Mesh => RestState::from_mesh_with_mirrors(mesh, x_ref, sff, mirror_edges),
        RestSource::Planar => {
            let a = spec.a_xy.as_ref().map_or(Matrix2::identity(), m2);
            let b = spec.b_xy.as_ref().map_or(Matrix2::zeros(), m2);
            RestState::from_planar(mesh, a, b)
        }
        // Read by `read_file` (it needs the scene's directory and reports file problems).
        RestSource::File => RestState::from_mesh_with_mirrors(mesh, x_ref, sff, mirror_edges),
    }
}

/// The forms of `[rest] from = "file"`: the CSV `spec.file` (relative to `base_dir`), one line
/// per face of `mesh` after a header, `a11,a12,a22,b11,b12,b22`; checked (count, numbers, ā
/// positive definite) with the line named.
pub fn read_file(
    spec: &RestSpec,
    base_dir: &std::path::Path,
    mesh: &Mesh,
) -> Result<RestState, super::problem::Problem> {
    let name = spec.file.as_deref().unwrap_or_default();
    let path = base_dir.join(name);
    let text = std::fs::read_to_string(&path)
        .map_err(|e| problem("rest.file", format!("cannot read {}: {e}", path.display())))?;
    let mut rows = Vec::with_capacity(mesh.n_faces());
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let v: Vec<f64> = line
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| problem("rest.file", format!("{name}:{}: {e}", i + 1)))?;
        if v.len() != 6 || v.iter().any(|x| !x.is_finite()) {
            return Err(problem(
                "rest.file",
                format!(
                    "{name}:{}: needs 6 finite numbers a11,a12,a22,b11,b12,b22",
                    i + 1
                ),
            ));
        }
        if !(v[0] > 0.0 && v[0] * v[2] - v[1] * v[1] > 0.0) {
            return Err(problem(
                "rest.file",
                format!("{name}:{}: the rest metric is not positive definite", i + 1),
            ));
        }
        rows.push(v);
    }
    if rows.len() != mesh.n_faces() {
        return Err(problem(
            "rest.file",
            format!(
                "{name} has {} faces, the mesh {}",
                rows.len(),
                mesh.n_faces()
            ),
        ));
    }
    Ok(RestState {
        a_bar: rows
            .iter()
            .map(|v| Matrix2::new(v[0], v[1], v[1], v[2]))
            .collect(),
        b_bar: rows
            .iter()
            .map(|v| Matrix2::new(v[3], v[4], v[4], v[5]))
            .collect(),
        sff: None,
    })
}
