//! OBJ input and output (positions and triangles only), via `tobj`.
//!
//! Reading uses `tobj` with `triangulate: true` (polygons are fan-triangulated),
//! `single_index: false` (texture / normal seams do not split vertices), and ignores points,
//! lines, normals, texture coordinates and materials. All objects and groups of a file are
//! merged into one mesh. Vertices keep the file's numbering (`v` lines in order), so
//! [`BuildReport::vertex_map`](crate::BuildReport::vertex_map) maps file vertices (0-based) to
//! mesh vertices. Because `tobj` renumbers vertices per object, the file numbering is
//! recovered from the coordinates: distinct `v` lines with bit-identical coordinates are
//! merged into the first of them. The result then goes through [`Mesh::new`] (validation,
//! dropping of unreferenced vertices, orientation fixing).

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::Path;

use nalgebra::Vector3;

use crate::error::MeshError;
use crate::mesh::Mesh;

fn load_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    }
}

/// Positions (m) and 0-based triangles as read from a file, before validation.
pub type RawMesh = (Vec<Vector3<f64>>, Vec<[usize; 3]>);

/// Reads raw positions and triangles from OBJ text without building a [`Mesh`].
///
/// Positions are all `v` lines in file order (including unreferenced ones).
/// Besides `tobj`'s own checks, a face line (`f`) with fewer than three corners is an error
/// ([`MeshError::ObjSyntax`]) rather than being read as a point or line and skipped, so that
/// a truncated file is not silently accepted.
pub fn read_obj_raw(mut reader: impl BufRead) -> Result<RawMesh, MeshError> {
    let mut text = String::new();
    reader.read_to_string(&mut text)?;
    // `tobj` renumbers vertices per object in order of first use; the file's own numbering is
    // restored through the (bit-exact) coordinates of the `v` lines, parsed here the same way
    // `tobj` parses them.
    let mut file_positions: Vec<Vector3<f64>> = Vec::new();
    let mut file_index: HashMap<[u64; 3], usize> = HashMap::new();
    let n_v_lines = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some("v"))
        .count();
    let mut v_lines_so_far = 0;
    for (i, line) in text.lines().enumerate() {
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("f") if tokens.clone().count() < 3 => {
                return Err(MeshError::ObjSyntax {
                    line: i + 1,
                    message: "face with fewer than 3 vertices",
                });
            }
            Some("f") => {
                // `tobj` reports a bad vertex index without its line; find it here. Positive
                // indices may refer to any `v` line of the file, negative ones count back from
                // the last `v` line before the face.
                for t in tokens {
                    let index = t.split('/').next().and_then(|v| v.parse::<i64>().ok());
                    let in_range = match index {
                        Some(k) if k > 0 => k.unsigned_abs() as usize <= n_v_lines,
                        Some(k) if k < 0 => k.unsigned_abs() as usize <= v_lines_so_far,
                        Some(_) => false,
                        // Not a number: left for `tobj` to report.
                        None => true,
                    };
                    if !in_range {
                        return Err(MeshError::ObjSyntax {
                            line: i + 1,
                            message: "face vertex index out of range (0, or beyond the `v` lines)",
                        });
                    }
                }
            }
            Some("v") => {
                v_lines_so_far += 1;
                let vals: Vec<f64> = tokens.map_while(|t| t.parse::<f64>().ok()).collect();
                // Malformed lines are left for `tobj` to report.
                if vals.len() >= 3 {
                    let mut p = [vals[0], vals[1], vals[2]];
                    if vals.len() == 4 && vals[3] != 0.0 {
                        p = p.map(|c| c / vals[3]);
                    }
                    let v = Vector3::from(p);
                    file_index
                        .entry(p.map(f64::to_bits))
                        .or_insert(file_positions.len());
                    file_positions.push(v);
                }
            }
            _ => {}
        }
    }
    // Materials are ignored: the loader reports "no materials" without touching the disk.
    let (models, _materials) = tobj::load_obj_buf(&mut text.as_bytes(), &load_options(), |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })?;
    let mut faces: Vec<[usize; 3]> = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let local: Vec<usize> = m
            .positions
            .chunks_exact(3)
            .map(|p| {
                let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
                *file_index.entry(key).or_insert_with(|| {
                    file_positions.push(Vector3::new(p[0], p[1], p[2]));
                    file_positions.len() - 1
                })
            })
            .collect();
        for t in m.indices.chunks_exact(3) {
            let mut tri = [0usize; 3];
            for (c, &i) in t.iter().enumerate() {
                tri[c] = *local
                    .get(i as usize)
                    .ok_or(MeshError::Obj(tobj::LoadError::FaceVertexOutOfBounds))?;
            }
            faces.push(tri);
        }
    }
    Ok((file_positions, faces))
}

/// Reads a mesh from OBJ text (see the module docs for what is kept).
pub fn read_obj(reader: impl BufRead) -> Result<Mesh, MeshError> {
    let (positions, faces) = read_obj_raw(reader)?;
    Mesh::new(positions, faces)
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
