//! `Mesh`: a validated triangle mesh from numpy arrays or an OBJ file.

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use thinshell_mesh::Mesh;

use crate::{convert, errors};

/// A validated, consistently oriented, edge-manifold triangle mesh.
#[pyclass(name = "Mesh", module = "thinshell", frozen)]
#[derive(Clone)]
pub struct PyMesh {
    pub inner: Mesh,
}

#[pymethods]
impl PyMesh {
    /// Builds a mesh from vertices `V` (n × 3, m) and faces `F` (m × 3, 0-based indices).
    #[new]
    fn new(vertices: &Bound<'_, PyAny>, faces: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = convert::points(vertices, "vertices")?;
        let f = convert::faces(faces)?;
        let inner = vertices
            .py()
            .detach(|| Mesh::new(v, f))
            .map_err(errors::mesh)?;
        Ok(PyMesh { inner })
    }

    /// Reads an OBJ file; polygons (quads, …) are split into triangles fanning out from their
    /// first vertex.
    #[staticmethod]
    fn from_obj(path: std::path::PathBuf) -> PyResult<Self> {
        // The message `thinshell info` prints: "<path>: <why>".
        let inner = thinshell_mesh::io::load_obj(&path)
            .map_err(|e| errors::mesh(format!("{}: {e}", path.display())))?;
        Ok(PyMesh { inner })
    }

    /// Vertex positions, n × 3 float64, m.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        convert::points_to_py(py, self.inner.positions())
    }

    /// Faces, m × 3 int64 (0-based, consistently oriented).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        faces_to_py(py, &self.inner)
    }

    /// Number of vertices.
    #[getter]
    fn n_vertices(&self) -> usize {
        self.inner.n_vertices()
    }
    /// Number of faces.
    #[getter]
    fn n_faces(&self) -> usize {
        self.inner.n_faces()
    }
    /// Number of edges.
    #[getter]
    fn n_edges(&self) -> usize {
        self.inner.n_edges()
    }

    /// Faces whose orientation was reversed when the mesh was built (ascending).
    #[getter]
    fn flipped_faces(&self) -> Vec<usize> {
        self.inner
            .build_report()
            .flipped_faces
            .iter()
            .map(|f| f.idx())
            .collect()
    }

    /// For every input vertex its index in the mesh, or -1 where it was dropped (unused).
    #[getter]
    fn vertex_map<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let m: Vec<i64> = self
            .inner
            .build_report()
            .vertex_map
            .iter()
            .map(|v| v.map_or(-1, |v| v.idx() as i64))
            .collect();
        PyArray1::from_vec(py, m)
    }

    /// Writes the mesh as OBJ, at `positions` (n × 3) if given, else at its own vertices.
    #[pyo3(signature = (path, positions=None))]
    fn save_obj(
        &self,
        path: std::path::PathBuf,
        positions: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let x = match positions {
            Some(p) => convert::points(p, "positions")?,
            None => self.inner.positions().to_vec(),
        };
        thinshell_mesh::io::save_obj(&path, &self.inner, &x)
            .map_err(|e| errors::mesh(format!("{}: {e}", path.display())))
    }

    fn __repr__(&self) -> String {
        format!(
            "Mesh({} vertices, {} faces, {} edges)",
            self.inner.n_vertices(),
            self.inner.n_faces(),
            self.inner.n_edges()
        )
    }
}

/// The faces of `mesh` as an m × 3 int64 array.
pub fn faces_to_py<'py>(py: Python<'py>, mesh: &Mesh) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let flat: Vec<i64> = mesh
        .faces()
        .iter()
        .flat_map(|f| f.iter().map(|v| v.idx() as i64))
        .collect();
    let a = Array2::from_shape_vec((mesh.n_faces(), 3), flat)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
    Ok(PyArray2::from_owned_array(py, a))
}
