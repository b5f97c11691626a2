//! `Scene`: a validated scene from a TOML file, a TOML string or a dict (same schema, same
//! messages as the CLI).

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use pyo3::types::PyDict;
use thinshell::scene::Scene;

use crate::{convert, errors};

/// A parsed and validated scene (docs/scenes.md), with the text it came from so that it can be
/// sent to other processes (pickled) and rebuilt there.
#[pyclass(name = "Scene", module = "thinshell", frozen)]
#[derive(Clone)]
pub struct PyScene {
    pub inner: Scene,
    text: String,
    overrides: Vec<String>,
    origin: String,
}

impl PyScene {
    /// Where the scene came from (file path, `<string>`, `<dict>`).
    pub fn origin_text(&self) -> String {
        self.origin.clone()
    }

    fn parse(
        text: String,
        origin: String,
        base_dir: &Path,
        overrides: Vec<String>,
    ) -> PyResult<Self> {
        let inner = Scene::from_toml_with_overrides(&text, &origin, base_dir, &overrides)
            .map_err(errors::scene)?;
        Ok(PyScene {
            inner,
            text,
            overrides,
            origin,
        })
    }
}

/// `{"vertices": ..., "faces": ...}` (a mesh given as arrays in a scene dict).
fn is_array_mesh(mesh: &Bound<'_, PyAny>) -> PyResult<bool> {
    match mesh.cast::<PyDict>() {
        Ok(d) => Ok(d.contains("vertices")? || d.contains("faces")?),
        Err(_) => Ok(false),
    }
}

#[pymethods]
impl PyScene {
    /// Reads a scene file; `overrides` are `key=value` strings as the CLI's `--set`.
    #[staticmethod]
    #[pyo3(signature = (path, overrides=None))]
    fn from_file(path: PathBuf, overrides: Option<Vec<String>>) -> PyResult<Self> {
        let text = std::fs::read_to_string(&path).map_err(|source| {
            errors::scene(thinshell::scene::SceneError::Io {
                path: path.clone(),
                source,
            })
        })?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        Self::parse(
            text,
            path.display().to_string(),
            &base,
            overrides.unwrap_or_default(),
        )
    }

    /// Parses scene text; `origin` names it in messages, `base_dir` resolves relative paths.
    #[staticmethod]
    #[pyo3(signature = (text, overrides=None, base_dir=None, origin="<string>"))]
    fn from_toml(
        text: String,
        overrides: Option<Vec<String>>,
        base_dir: Option<PathBuf>,
        origin: &str,
    ) -> PyResult<Self> {
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        Self::parse(
            text,
            origin.to_string(),
            &base,
            overrides.unwrap_or_default(),
        )
    }

    /// A scene from a dict with the schema of a scene file (nested dicts for tables, lists
    /// for arrays; `None` values are left out). Messages name the dotted key path and the line
    /// of the equivalent TOML text (`Scene.toml`).
    #[staticmethod]
    #[pyo3(signature = (scene, overrides=None, base_dir=None, origin="<dict>"))]
    fn from_dict(
        scene: &Bound<'_, PyDict>,
        overrides: Option<Vec<String>>,
        base_dir: Option<PathBuf>,
        origin: &str,
    ) -> PyResult<Self> {
        // A mesh given as a `Mesh` or as `{"vertices": V, "faces": F}` becomes an OBJ file
        // named by its content (`thinshell._scenes.mesh_file`), which the scene then names.
        let py = scene.py();
        let scene = match scene.get_item("mesh")? {
            Some(mesh) if mesh.cast::<crate::mesh::PyMesh>().is_ok() || is_array_mesh(&mesh)? => {
                let spec = py
                    .import("thinshell._scenes")?
                    .getattr("mesh_spec")?
                    .call1((mesh,))?;
                let copy = scene.copy()?;
                copy.set_item("mesh", spec)?;
                copy
            }
            _ => scene.clone(),
        };
        let value = convert::toml_value(scene.as_any(), "")?;
        let text = toml::to_string(&value).map_err(errors::scene)?;
        Self::from_toml(text, overrides, base_dir, origin)
    }

    /// The scene's name (`name`, else the file stem).
    #[getter]
    fn name(&self) -> String {
        self.inner.name()
    }
    /// Where the scene came from (file path, `<string>`, `<dict>`).
    #[getter]
    fn origin(&self) -> &str {
        &self.origin
    }
    /// The TOML text the scene was parsed from (before overrides).
    #[getter]
    fn toml(&self) -> &str {
        &self.text
    }
    /// The `key=value` overrides applied to it.
    #[getter]
    fn overrides(&self) -> Vec<String> {
        self.overrides.clone()
    }
    /// Directory relative paths in the scene are resolved against.
    #[getter]
    fn base_dir(&self) -> PathBuf {
        self.inner.base_dir.clone()
    }

    /// The scene after its overrides, validated, as canonical TOML (every value, no comments;
    /// the text `scene_hash` fingerprints): what a run of it does.
    #[getter]
    fn resolved_toml(&self) -> PyResult<String> {
        toml::to_string(&self.inner.file).map_err(errors::scene)
    }

    /// The 64-bit fingerprint of the scene after its overrides, as checkpoints store it.
    #[getter]
    fn scene_hash(&self) -> u64 {
        thinshell::output::scene_hash(&self.inner)
    }

    /// The files a simulation of this scene reads (absolute or relative to the working
    /// directory): the mesh's OBJ file, if any.
    #[getter]
    fn files(&self) -> Vec<PathBuf> {
        self.inner
            .file
            .mesh
            .obj
            .iter()
            .map(|p| self.inner.base_dir.join(p))
            .collect()
    }

    /// This scene with further `key=value` overrides (applied after the existing ones).
    fn with_overrides(&self, overrides: Vec<String>) -> PyResult<Self> {
        let mut all = self.overrides.clone();
        all.extend(overrides);
        Self::parse(
            self.text.clone(),
            self.origin.clone(),
            &self.inner.base_dir,
            all,
        )
    }

    fn __reduce__(&self, py: Python<'_>) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let ctor = py.get_type::<PyScene>().getattr("from_toml")?.unbind();
        let args = (
            self.text.clone(),
            self.overrides.clone(),
            self.inner.base_dir.clone(),
            self.origin.clone(),
        )
            .into_pyobject(py)?
            .into_any()
            .unbind();
        Ok((ctor, args))
    }

    fn __repr__(&self) -> String {
        format!("Scene({:?} from {})", self.inner.name(), self.origin)
    }
}
