//! Reading one frame file (`.vtu` as written by `thinshell::vtk`, or `.obj`). The viewer colours
//! by the arrays a frame carries — curvatures, strains, resultants, energy densities, computed
//! by the simulation (`thinshell::fields`) — and computes nothing itself but the displacement
//! of OBJ frames.

use std::path::Path;

/// One frame's arrays.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameData {
    /// Positions, m.
    pub positions: Vec<[f64; 3]>,
    /// Triangles.
    pub faces: Vec<[u32; 3]>,
    /// Displacement from the reference mesh (VTK point data), m.
    pub displacement: Option<Vec<[f64; 3]>>,
    /// Cell arrays of scalars (name, one value per face).
    pub face_fields: Vec<(String, Vec<f64>)>,
    /// Point arrays of scalars (name, one value per vertex).
    pub vertex_fields: Vec<(String, Vec<f64>)>,
}

/// Reads a `.vtu` or `.obj` frame; the error says what is wrong.
pub fn read(path: &Path) -> Result<FrameData, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    match path.extension().and_then(|e| e.to_str()) {
        Some("vtu") => parse_vtu(&text),
        Some("obj") => parse_obj(&text),
        _ => Err("not a .vtu or .obj file".into()),
    }
}

fn numbers(text: &str, what: &str) -> Result<Vec<f64>, String> {
    text.split_ascii_whitespace()
        .map(|t| match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("{what}: {t:?} is not a finite number")),
        })
        .collect()
}

fn triples(v: Vec<f64>, what: &str) -> Result<Vec<[f64; 3]>, String> {
    if v.len() % 3 != 0 {
        return Err(format!("{what}: {} numbers, not a multiple of 3", v.len()));
    }
    Ok(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// Parses the VTK XML frames this project writes (ASCII UnstructuredGrid of triangles).
pub fn parse_vtu(text: &str) -> Result<FrameData, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not valid XML: {e}"))?;
    let piece = doc
        .descendants()
        .find(|n| n.has_tag_name("Piece"))
        .ok_or("no <Piece>: not a VTK UnstructuredGrid")?;
    let count = |name: &str| -> Result<usize, String> {
        piece
            .attribute(name)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("<Piece> has no {name}"))
    };
    let (nv, nf) = (count("NumberOfPoints")?, count("NumberOfCells")?);
    let section = |tag: &str| piece.children().find(|n| n.has_tag_name(tag));
    fn array_text<'a>(
        parent: Option<roxmltree::Node<'a, 'a>>,
        name: Option<&str>,
    ) -> Option<&'a str> {
        parent.and_then(|p| {
            p.children()
                .filter(|n| n.has_tag_name("DataArray"))
                .find(|n| name.is_none() || n.attribute("Name") == name)
                .map(|n| n.text().unwrap_or(""))
        })
    }
    let points = array_text(section("Points"), None).ok_or("no <Points> array")?;
    let positions = triples(numbers(points, "points")?, "points")?;
    if positions.len() != nv {
        return Err(format!(
            "{} points, NumberOfPoints says {nv}",
            positions.len()
        ));
    }
    let conn = array_text(section("Cells"), Some("connectivity")).ok_or("no connectivity array")?;
    let conn = numbers(conn, "connectivity")?;
    if conn.len() != 3 * nf {
        return Err(format!(
            "connectivity has {} indices, {nf} triangles need {}",
            conn.len(),
            3 * nf
        ));
    }
    let faces = index_faces(&conn, nv)?;
    let displacement = match array_text(section("PointData"), Some("displacement")) {
        Some(t) => {
            let d = triples(numbers(t, "displacement")?, "displacement")?;
            if d.len() != nv {
                return Err(format!("displacement has {} vectors, {nv} points", d.len()));
            }
            Some(d)
        }
        None => None,
    };
    // Scalar arrays (one component); vector arrays other than the displacement are not colours.
    let scalar_arrays =
        |tag: &str, n: usize, what: &str| -> Result<Vec<(String, Vec<f64>)>, String> {
            let mut out = Vec::new();
            let Some(data) = section(tag) else {
                return Ok(out);
            };
            for node in data.children().filter(|n| n.has_tag_name("DataArray")) {
                if node
                    .attribute("NumberOfComponents")
                    .is_some_and(|c| c != "1")
                {
                    continue;
                }
                let name = node.attribute("Name").unwrap_or("").to_string();
                let v = numbers(node.text().unwrap_or(""), &name)?;
                if v.len() != n {
                    return Err(format!(
                        "{what} array {name} has {} values, {n} {what}s",
                        v.len()
                    ));
                }
                out.push((name, v));
            }
            Ok(out)
        };
    Ok(FrameData {
        positions,
        faces,
        displacement,
        face_fields: scalar_arrays("CellData", nf, "cell")?,
        vertex_fields: scalar_arrays("PointData", nv, "point")?,
    })
}

fn index_faces(conn: &[f64], nv: usize) -> Result<Vec<[u32; 3]>, String> {
    let index = |v: f64| -> Result<u32, String> {
        if v >= 0.0 && v.fract() == 0.0 && (v as usize) < nv {
            Ok(v as u32)
        } else {
            Err(format!("vertex index {v} out of range (0..{nv})"))
        }
    };
    conn.chunks_exact(3)
        .map(|c| Ok([index(c[0])?, index(c[1])?, index(c[2])?]))
        .collect()
}

/// Parses an OBJ frame (triangles only) with the mesh crate's raw reader (no re-orientation,
/// so face order and orientation are those of the file).
pub fn parse_obj(text: &str) -> Result<FrameData, String> {
    let (positions, faces) =
        thinshell_mesh::io::read_obj_raw(text.as_bytes()).map_err(|e| e.to_string())?;
    if let Some(k) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(format!("vertex {k} is not finite"));
    }
    let nv = positions.len();
    let faces = faces
        .iter()
        .map(|f| {
            if f.iter().all(|&v| v < nv) {
                Ok([f[0] as u32, f[1] as u32, f[2] as u32])
            } else {
                Err(format!("face {f:?} has a vertex out of range (0..{nv})"))
            }
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok(FrameData {
        positions: positions.iter().map(|p| [p.x, p.y, p.z]).collect(),
        faces,
        displacement: None,
        face_fields: Vec::new(),
        vertex_fields: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn malformed_vtu_is_named() {
        assert!(
            parse_vtu("<VTKFile>")
                .expect_err("must fail")
                .contains("not valid XML")
        );
        let e = parse_vtu("<VTKFile><UnstructuredGrid><Piece NumberOfPoints=\"1\" NumberOfCells=\"0\"><Points><DataArray>0 0 nan</DataArray></Points></Piece></UnstructuredGrid></VTKFile>").expect_err("must fail");
        assert!(e.contains("not a finite number"), "{e}");
    }
}
