//! VTK output: one XML UnstructuredGrid (`.vtu`) per frame and a `.pvd` collection indexing them
//! by time (opens in ParaView; Blender reads the `.vtu` files with an importer).
//!
//! Frames are ASCII, positions in m, triangles as VTK cell type 5, with named per-vertex and
//! per-face arrays of scalars and 3-vectors (a run's frames: [`crate::fields`] says which). The
//! `.pvd` index is rewritten after every
//! frame through a temporary file and a rename, so an interrupted or failed run always leaves a
//! valid index of exactly the frames written.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use thinshell_mesh::Mesh;

/// Why a VTK file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum VtkError {
    /// Writing or renaming a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// An array holds NaN or infinity (never written silently).
    #[error("{array}: entry {index} is not finite")]
    NonFinite {
        /// The array (`points`, `displacement`, …).
        array: String,
        /// Index of the first non-finite entry.
        index: usize,
    },
    /// An array has the wrong length for the mesh.
    #[error("{array}: expected {expected} entries, got {got}")]
    Length {
        /// The array.
        array: String,
        /// Entries expected.
        expected: usize,
        /// Entries given.
        got: usize,
    },
}

/// One frame: the mesh at positions `points` with optional named point and cell arrays.
pub struct Frame<'a> {
    /// The mesh (connectivity).
    pub mesh: &'a Mesh,
    /// Vertex positions, m.
    pub points: &'a [Vector3<f64>],
    /// Per-vertex 3-vectors (name, values).
    pub point_vectors: Vec<(&'a str, &'a [Vector3<f64>])>,
    /// Per-face scalars (name, values).
    pub cell_scalars: Vec<(&'a str, Vec<f64>)>,
    /// Per-vertex scalars (name, values), written after the point vectors.
    pub point_scalars: Vec<(&'a str, &'a [f64])>,
    /// Per-face 3-vectors (name, values), written after the cell scalars.
    pub cell_vectors: Vec<(&'a str, &'a [Vector3<f64>])>,
}

impl<'a> Frame<'a> {
    /// A frame of `mesh` at `points` without arrays.
    pub fn new(mesh: &'a Mesh, points: &'a [Vector3<f64>]) -> Frame<'a> {
        Frame {
            mesh,
            points,
            point_vectors: Vec::new(),
            cell_scalars: Vec::new(),
            point_scalars: Vec::new(),
            cell_vectors: Vec::new(),
        }
    }
}

fn check_scalars(name: &str, v: &[f64], n: usize) -> Result<(), VtkError> {
    if v.len() != n {
        return Err(VtkError::Length {
            array: name.into(),
            expected: n,
            got: v.len(),
        });
    }
    match v.iter().position(|c| !c.is_finite()) {
        Some(index) => Err(VtkError::NonFinite {
            array: name.into(),
            index,
        }),
        None => Ok(()),
    }
}

fn check_vectors(name: &str, v: &[Vector3<f64>], n: usize) -> Result<(), VtkError> {
    if v.len() != n {
        return Err(VtkError::Length {
            array: name.into(),
            expected: n,
            got: v.len(),
        });
    }
    match v.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(index) => Err(VtkError::NonFinite {
            array: name.into(),
            index,
        }),
        None => Ok(()),
    }
}

/// The `.vtu` text of a frame. Errors on non-finite values or wrong array lengths.
pub fn vtu_string(frame: &Frame) -> Result<String, VtkError> {
    let (nv, nf) = (frame.mesh.n_vertices(), frame.mesh.n_faces());
    check_vectors("points", frame.points, nv)?;
    for (name, v) in &frame.point_vectors {
        check_vectors(name, v, nv)?;
    }
    for (name, v) in &frame.point_scalars {
        check_scalars(name, v, nv)?;
    }
    for (name, v) in &frame.cell_scalars {
        check_scalars(name, v, nf)?;
    }
    for (name, v) in &frame.cell_vectors {
        check_vectors(name, v, nf)?;
    }
    // `write!` into a String cannot fail; the results are ignored on purpose.
    let mut s = String::with_capacity(64 * (nv + nf));
    s.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n");
    let _ = writeln!(s, "<Piece NumberOfPoints=\"{nv}\" NumberOfCells=\"{nf}\">");
    s.push_str(
        "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
    );
    for p in frame.points {
        // `{:e}` prints the shortest representation that reads back to the same f64.
        let _ = writeln!(s, "{:e} {:e} {:e}", p.x, p.y, p.z);
    }
    s.push_str("</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    for f in frame.mesh.faces() {
        let _ = writeln!(s, "{} {} {}", f[0].idx(), f[1].idx(), f[2].idx());
    }
    s.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    for k in 1..=nf {
        let _ = write!(s, "{} ", 3 * k);
    }
    s.push_str("\n</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    for _ in 0..nf {
        s.push_str("5 ");
    }
    s.push_str("\n</DataArray>\n</Cells>\n<PointData>\n");
    for (name, v) in &frame.point_vectors {
        write_vectors(&mut s, name, v);
    }
    for (name, v) in &frame.point_scalars {
        write_scalars(&mut s, name, v);
    }
    s.push_str("</PointData>\n<CellData>\n");
    for (name, v) in &frame.cell_scalars {
        write_scalars(&mut s, name, v);
    }
    for (name, v) in &frame.cell_vectors {
        write_vectors(&mut s, name, v);
    }
    s.push_str("</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    Ok(s)
}

fn write_vectors(s: &mut String, name: &str, v: &[Vector3<f64>]) {
    let _ = writeln!(
        s,
        "<DataArray type=\"Float64\" Name=\"{name}\" NumberOfComponents=\"3\" format=\"ascii\">"
    );
    for p in v {
        let _ = writeln!(s, "{:e} {:e} {:e}", p.x, p.y, p.z);
    }
    s.push_str("</DataArray>\n");
}

fn write_scalars(s: &mut String, name: &str, v: &[f64]) {
    let _ = writeln!(
        s,
        "<DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">"
    );
    for c in v {
        let _ = writeln!(s, "{c:e}");
    }
    s.push_str("</DataArray>\n");
}

fn write_atomic(path: &Path, text: &str) -> Result<(), VtkError> {
    let io = |source| VtkError::Io {
        path: path.to_path_buf(),
        source,
    };
    crate::atomic::write_atomic(path, text.as_bytes()).map_err(io)
}

/// A time series of `.vtu` frames in one directory with its `.pvd` index.
#[derive(Debug)]
pub struct Series {
    dir: PathBuf,
    index: PathBuf,
    entries: Vec<(f64, String)>,
}

impl Series {
    /// A series writing into `dir` with the index `dir/<name>.pvd`.
    pub fn new(dir: &Path, name: &str) -> Series {
        Series {
            dir: dir.to_path_buf(),
            index: dir.join(format!("{name}.pvd")),
            entries: Vec::new(),
        }
    }

    /// Writes `frame` as `file` (relative to the directory) at time `t` (s) and rewrites the
    /// index atomically. Writing the most recent file name again replaces its entry.
    pub fn write(&mut self, file: &str, t: f64, frame: &Frame) -> Result<(), VtkError> {
        if !t.is_finite() {
            return Err(VtkError::NonFinite {
                array: "time".into(),
                index: self.entries.len(),
            });
        }
        let text = vtu_string(frame)?;
        write_atomic(&self.dir.join(file), &text)?;
        // Writing the same file again (the last good state after a failure) replaces its entry.
        if self.entries.last().is_some_and(|(_, f)| f == file) {
            self.entries.pop();
        }
        self.entries.push((t, file.to_string()));
        let mut pvd = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n<Collection>\n",
        );
        for (t, f) in &self.entries {
            let _ = writeln!(pvd, "<DataSet timestep=\"{t:e}\" part=\"0\" file=\"{f}\"/>");
        }
        pvd.push_str("</Collection>\n</VTKFile>\n");
        write_atomic(&self.index, &pvd)
    }

    /// Replaces the list of frames (a resumed run continues the index of the interrupted one).
    pub fn set_entries(&mut self, entries: Vec<(f64, String)>) {
        self.entries = entries;
    }

    /// Frames written so far (time, file).
    pub fn entries(&self) -> &[(f64, String)] {
        &self.entries
    }

    /// Path of the `.pvd` index.
    pub fn index_path(&self) -> &Path {
        &self.index
    }
}
