//! OBJ input and output (positions and triangles only).
//!
//! Reading keeps `v` lines (`x y z`, an optional weight `w` that divides them, or trailing
//! `r g b` vertex colours, ignored) and `f` lines (corners `v`, `v/vt`, `v//vn` or `v/vt/vn`;
//! 1-based indices, negative ones counting back from the last `v` line above; polygons are
//! fan-triangulated). Texture coordinates, normals, points, lines, groups, objects and materials
//! are ignored; all objects and groups of a file are merged into one mesh. Vertices keep the
//! file's numbering (`v` lines in order), so
//! [`BuildReport::vertex_map`](crate::BuildReport::vertex_map) maps file vertices (0-based) to
//! mesh vertices. The result then goes through [`Mesh::new`] (validation, dropping of
//! unreferenced vertices, orientation fixing).
//!
//! Every error names its 1-based line: a malformed line is [`MeshError::ObjSyntax`], and a mesh
//! problem [`Mesh::new`] finds (a degenerate face, a non-manifold edge, …) comes back as
//! [`MeshError::InObj`], naming the `f` (or `v`) lines of the faces (vertices) involved.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::Path;

use nalgebra::Vector3;

use crate::error::MeshError;
use crate::mesh::Mesh;

/// Positions (m) and 0-based triangles as read from a file, before validation.
pub type RawMesh = (Vec<Vector3<f64>>, Vec<[usize; 3]>);

/// An OBJ file's positions and triangles with the lines they came from.
#[derive(Clone, Debug, Default)]
pub struct ObjData {
    /// Every `v` line's position (m), in file order (including unreferenced ones).
    pub positions: Vec<Vector3<f64>>,
    /// 0-based triangles (polygons fan-triangulated), in file order.
    pub faces: Vec<[usize; 3]>,
    /// The 1-based line of each position's `v` line.
    pub vertex_lines: Vec<usize>,
    /// The 1-based line of each triangle's `f` line (several triangles share a polygon's line).
    pub face_lines: Vec<usize>,
}

impl ObjData {
    /// Builds the mesh ([`Mesh::new`]); a problem it finds names the OBJ lines involved
    /// ([`MeshError::InObj`]).
    pub fn into_mesh(self) -> Result<Mesh, MeshError> {
        let (face_lines, vertex_lines) = (self.face_lines, self.vertex_lines);
        Mesh::new(self.positions, self.faces)
            .map_err(|e| locate_in_obj(e, &face_lines, &vertex_lines))
    }
}

/// Wraps a [`Mesh::new`] error about input faces or vertices into [`MeshError::InObj`] with
/// the 1-based OBJ lines they came from (other errors are returned as they are).
pub fn locate_in_obj(e: MeshError, face_lines: &[usize], vertex_lines: &[usize]) -> MeshError {
    let mut lines: Vec<usize> = e
        .faces()
        .iter()
        .filter_map(|&f| face_lines.get(f).copied())
        .chain(
            e.vertices()
                .iter()
                .filter_map(|&v| vertex_lines.get(v).copied()),
        )
        .collect();
    lines.sort_unstable();
    lines.dedup();
    if lines.is_empty() {
        e
    } else {
        MeshError::InObj {
            lines,
            source: Box::new(e),
        }
    }
}

fn syntax(line: usize, message: impl Into<String>) -> MeshError {
    MeshError::ObjSyntax {
        line,
        message: message.into(),
    }
}

/// Reads an OBJ file's positions and triangles with their lines, without building a [`Mesh`]
/// (see the module docs for what is kept). A malformed `v` or `f` line — a number that does not
/// parse, a wrong count of coordinates, a face with fewer than three corners or an index of no
/// `v` line — is [`MeshError::ObjSyntax`] naming its 1-based line, never skipped, so that a
/// truncated file is not silently accepted.
pub fn read_obj_data(mut reader: impl BufRead) -> Result<ObjData, MeshError> {
    let mut text = String::new();
    reader.read_to_string(&mut text)?;
    // A positive index may name a `v` line further down the file.
    let n_v_lines = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some("v"))
        .count();
    let mut data = ObjData::default();
    let mut corners: Vec<usize> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        // A comment may follow the data on the same line.
        let line = line.split('#').next().unwrap_or("");
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut vals = Vec::with_capacity(4);
                for t in tokens {
                    vals.push(t.parse::<f64>().map_err(|_| {
                        syntax(line_no, format!("vertex coordinate `{t}` is not a number"))
                    })?);
                }
                let mut p = match vals.len() {
                    3 | 6 => [vals[0], vals[1], vals[2]],
                    4 => [vals[0], vals[1], vals[2]],
                    n => {
                        return Err(syntax(
                            line_no,
                            format!(
                                "vertex with {n} numbers (expected x y z, x y z w or x y z r g b)"
                            ),
                        ));
                    }
                };
                if vals.len() == 4 {
                    if vals[3] == 0.0 {
                        return Err(syntax(line_no, "vertex weight w is 0 (x/w undefined)"));
                    }
                    p = p.map(|c| c / vals[3]);
                }
                data.positions.push(Vector3::from(p));
                data.vertex_lines.push(line_no);
            }
            Some("f") => {
                corners.clear();
                for t in tokens {
                    let index = t.split('/').next().unwrap_or("");
                    let k: i64 = index.parse().map_err(|_| {
                        syntax(
                            line_no,
                            format!("face vertex index `{t}` is not an integer"),
                        )
                    })?;
                    let so_far = data.positions.len();
                    let v = match k {
                        k if k > 0 && k.unsigned_abs() as usize <= n_v_lines => k as usize - 1,
                        k if k < 0 && k.unsigned_abs() as usize <= so_far => {
                            so_far - k.unsigned_abs() as usize
                        }
                        _ => {
                            return Err(syntax(
                                line_no,
                                format!(
                                    "face vertex index out of range: {k} (0, or beyond the `v` \
                                     lines: the file has {n_v_lines}, {so_far} above this line)"
                                ),
                            ));
                        }
                    };
                    corners.push(v);
                }
                if corners.len() < 3 {
                    return Err(syntax(line_no, "face with fewer than 3 vertices"));
                }
                for k in 1..corners.len() - 1 {
                    data.faces.push([corners[0], corners[k], corners[k + 1]]);
                    data.face_lines.push(line_no);
                }
            }
            _ => {}
        }
    }
    Ok(data)
}

/// Reads raw positions and triangles from OBJ text without building a [`Mesh`] (see
/// [`read_obj_data`], which also gives each one's line).
pub fn read_obj_raw(reader: impl BufRead) -> Result<RawMesh, MeshError> {
    let data = read_obj_data(reader)?;
    Ok((data.positions, data.faces))
}

/// Reads a mesh from OBJ text (see the module docs for what is kept).
pub fn read_obj(reader: impl BufRead) -> Result<Mesh, MeshError> {
    read_obj_data(reader)?.into_mesh()
}

/// Loads a mesh from an OBJ file.
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh, MeshError> {
    let file = File::open(path)?;
    read_obj(BufReader::new(file))
}

/// Writes `mesh` with positions `x` (m) as OBJ: one `v x y z` line per vertex, with the
/// shortest decimal text that reads back to the identical `f64`, then one 1-based
/// `f i j k` line per face in the stored orientation.
pub fn write_obj(
    mesh: &Mesh,
    x: &[nalgebra::Vector3<f64>],
    mut writer: impl Write,
) -> Result<(), MeshError> {
    if x.len() != mesh.n_vertices() {
        return Err(MeshError::WrongPositionCount {
            expected: mesh.n_vertices(),
            found: x.len(),
        });
    }
    crate::mesh::check_finite(x)?;
    // `Display` for f64 prints the shortest representation that round-trips exactly.
    for p in x {
        writeln!(writer, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for f in mesh.faces() {
        writeln!(writer, "f {} {} {}", f[0].0 + 1, f[1].0 + 1, f[2].0 + 1)?;
    }
    writer.flush()?;
    Ok(())
}

/// Saves `mesh` with positions `x` (m) to an OBJ file (see [`write_obj`]).
pub fn save_obj(path: impl AsRef<Path>, mesh: &Mesh, x: &[Vector3<f64>]) -> Result<(), MeshError> {
    let file = File::create(path)?;
    write_obj(mesh, x, BufWriter::new(file))
}
