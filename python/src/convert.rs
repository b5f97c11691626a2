//! numpy ↔ Rust conversions, and Python values → TOML for scenes given as dicts.

use nalgebra::{Matrix2, Vector3};
use numpy::ndarray::{Array2, Array3};
use numpy::{PyArray2, PyArray3, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// `np.asarray(obj, dtype)` (a copy only when needed).
fn asarray<'py>(obj: &Bound<'py, PyAny>, dtype: &str) -> PyResult<Bound<'py, PyAny>> {
    let np = obj.py().import("numpy")?;
    np.call_method1("asarray", (obj, dtype))
}

/// An `n × 3` float array (anything numpy converts to float64) as points, m.
pub fn points(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Vector3<f64>>> {
    let arr = asarray(obj, "float64")?;
    let arr: PyReadonlyArray2<'_, f64> = arr.extract().map_err(|_| {
        PyValueError::new_err(format!("{what}: expected a 2-D array of shape (n, 3)"))
    })?;
    let shape = arr.shape();
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected shape (n, 3), got ({}, {})",
            shape[0], shape[1]
        )));
    }
    let a = arr.as_array();
    Ok(a.outer_iter()
        .map(|r| Vector3::new(r[0], r[1], r[2]))
        .collect())
}

/// An `m × 3` integer array of vertex indices (0-based).
pub fn faces(obj: &Bound<'_, PyAny>) -> PyResult<Vec<[usize; 3]>> {
    let np = obj.py().import("numpy")?;
    let raw = np.call_method1("asarray", (obj,))?;
    let kind: String = raw.getattr("dtype")?.getattr("kind")?.extract()?;
    // Empty lists come out as float64; anything else that is not integer is a mistake.
    let size: usize = raw.getattr("size")?.extract()?;
    if !(kind == "i" || kind == "u" || size == 0) {
        return Err(PyTypeError::new_err(format!(
            "faces: expected an integer array of shape (m, 3), got dtype kind '{kind}'"
        )));
    }
    let arr = np.call_method1("asarray", (raw, "int64"))?;
    let arr: PyReadonlyArray2<'_, i64> = arr.extract().map_err(|_| {
        PyValueError::new_err("faces: expected a 2-D integer array of shape (m, 3)")
    })?;
    let shape = arr.shape();
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "faces: expected shape (m, 3), got ({}, {})",
            shape[0], shape[1]
        )));
    }
    let mut out = Vec::with_capacity(shape[0]);
    for (f, r) in arr.as_array().outer_iter().enumerate() {
        let mut face = [0usize; 3];
        for (k, &i) in r.iter().enumerate() {
            // A MeshError, like an index past the last vertex (both are bad connectivity).
            face[k] = usize::try_from(i).map_err(|_| {
                crate::errors::mesh(format!("faces: face {f} has a negative index {i}"))
            })?;
        }
        out.push(face);
    }
    Ok(out)
}

/// Points as an `n × 3` float64 array.
pub fn points_to_py<'py>(py: Python<'py>, x: &[Vector3<f64>]) -> Bound<'py, PyArray2<f64>> {
    let mut a = Array2::<f64>::zeros((x.len(), 3));
    for (mut row, p) in a.outer_iter_mut().zip(x) {
        row[0] = p.x;
        row[1] = p.y;
        row[2] = p.z;
    }
    PyArray2::from_owned_array(py, a)
}

/// 2×2 forms as an `m × 2 × 2` float64 array.
pub fn forms_to_py<'py>(py: Python<'py>, m: &[Matrix2<f64>]) -> Bound<'py, PyArray3<f64>> {
    let mut a = Array3::<f64>::zeros((m.len(), 2, 2));
    for (f, form) in m.iter().enumerate() {
        for i in 0..2 {
            for j in 0..2 {
                a[[f, i, j]] = form[(i, j)];
            }
        }
    }
    PyArray3::from_owned_array(py, a)
}

/// An `m × 2 × 2` float array as forms.
pub fn forms(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Matrix2<f64>>> {
    let arr = asarray(obj, "float64")?;
    let arr: numpy::PyReadonlyArray3<'_, f64> = arr.extract().map_err(|_| {
        PyValueError::new_err(format!("{what}: expected an array of shape (m, 2, 2)"))
    })?;
    let shape = arr.shape();
    if shape[1] != 2 || shape[2] != 2 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected shape (m, 2, 2), got ({}, {}, {})",
            shape[0], shape[1], shape[2]
        )));
    }
    let a = arr.as_array();
    Ok((0..shape[0])
        .map(|f| Matrix2::new(a[[f, 0, 0]], a[[f, 0, 1]], a[[f, 1, 0]], a[[f, 1, 1]]))
        .collect())
}

/// A serialisable Rust value as Python objects (via JSON: floats round-trip exactly).
pub fn to_py<'py>(py: Python<'py>, value: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| PyValueError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A Python value (dict, list, tuple, str, bool, int, float, numpy scalar or array) as TOML;
/// `path` is the dotted key path, for messages.
pub fn toml_value(obj: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
    let at = |what: &str| {
        PyTypeError::new_err(format!(
            "scene dict: `{}` {what}",
            if path.is_empty() { "<root>" } else { path }
        ))
    };
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        let i: i64 = obj
            .extract()
            .map_err(|_| at("is an integer out of TOML's 64-bit range"))?;
        return Ok(toml::Value::Integer(i));
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(obj.extract()?));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| at("has a key that is not a string"))?;
            let sub = if path.is_empty() {
                key.clone()
            } else {
                format!("{path}.{key}")
            };
            if v.is_none() {
                // None means "not given", as an absent key in a TOML file.
                continue;
            }
            table.insert(key, toml_value(&v, &sub)?);
        }
        return Ok(toml::Value::Table(table));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, v) in obj.try_iter()?.enumerate() {
            items.push(toml_value(&v?, &format!("{path}[{i}]"))?);
        }
        return Ok(toml::Value::Array(items));
    }
    // numpy scalars and arrays, pathlib paths.
    if obj.hasattr("tolist")? {
        return toml_value(&obj.call_method0("tolist")?, path);
    }
    if obj.hasattr("__fspath__")? {
        return toml_value(&obj.call_method0("__fspath__")?, path);
    }
    Err(at(&format!(
        "has a value of type {} that TOML cannot hold",
        obj.get_type().name()?
    )))
}
