//! The energy layer: energy, gradient and Hessian of a mesh at given positions against given
//! rest forms, for users who plug thinshell's energy into their own solver.

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use thinshell_energy::{
    Assembler, DofMap, EvalOutput, HessianMode, Material, MaterialModel, RestState, SffKind,
    ShellModel, Terms,
};
use thinshell_mesh::Mesh;

use crate::{convert, errors};

/// `Material` from a dict (keys thickness m, young Pa, poisson, density kg/m³, viscosity Pa·s,
/// model "stvk" | "neo_hookean"); missing keys take the paper defaults.
fn material(d: Option<&Bound<'_, PyDict>>) -> PyResult<Material> {
    let mut m = Material::paper();
    if let Some(d) = d {
        for (k, v) in d.iter() {
            let key: String = k.extract()?;
            match key.as_str() {
                "thickness" => m.thickness = v.extract()?,
                "young" => m.young = v.extract()?,
                "poisson" => m.poisson = v.extract()?,
                "density" => m.density = v.extract()?,
                "viscosity" => m.viscosity = v.extract()?,
                "model" => {
                    let name: String = v.extract()?;
                    m.model = match name.as_str() {
                        "stvk" => MaterialModel::StVK,
                        "neo_hookean" => MaterialModel::NeoHookean,
                        _ => {
                            return Err(PyValueError::new_err(format!(
                                "material.model: `{name}`: expected \"stvk\" or \"neo_hookean\" (bilayers: use a scene)"
                            )));
                        }
                    }
                }
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "material: unknown key `{key}` (expected thickness, young, poisson, density, viscosity, model)"
                    )));
                }
            }
        }
    }
    m.validate().map_err(errors::energy)?;
    Ok(m)
}

fn terms(names: Option<Vec<String>>) -> PyResult<Terms> {
    let mut t = Terms {
        stretch: false,
        bend: false,
        damping: false,
    };
    for n in names.unwrap_or_else(|| vec!["stretching".into(), "bending".into()]) {
        match n.as_str() {
            "stretching" => t.stretch = true,
            "bending" => t.bend = true,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "terms: unknown term `{n}` (expected \"stretching\", \"bending\")"
                )));
            }
        }
    }
    if !(t.stretch || t.bend) {
        return Err(PyValueError::new_err("terms: at least one term"));
    }
    Ok(t)
}

/// Energy terms, gradient and full symmetric Hessian (as COO triplets) of the mesh `(V, F)`
/// at `V` against `rest`: either rest positions (n × 3: forms of that shape) or a tuple
/// `(a_bar, b_bar)` of m × 2 × 2 arrays. Returns `(stretch, bend, gradient, rows, cols, vals,
/// n)`; the `thinshell.energy` function builds the `scipy.sparse.csc_matrix`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, rest, material=None, form="mid_edge_average", terms=None, edge_angles=None, hessian=true))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn energy_parts<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    rest: &Bound<'py, PyAny>,
    material: Option<&Bound<'py, PyDict>>,
    form: &str,
    terms: Option<Vec<String>>,
    edge_angles: Option<PyReadonlyArray1<'py, f64>>,
    hessian: bool,
) -> PyResult<(
    f64,
    f64,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    usize,
)> {
    let x = convert::points(vertices, "vertices")?;
    let f = convert::faces(faces)?;
    let n_input = x.len();
    let mesh = Mesh::new(x.clone(), f).map_err(errors::mesh)?;
    let report = mesh.build_report();
    if report.n_flipped() > 0 || report.n_dropped_vertices > 0 || mesh.n_vertices() != n_input {
        return Err(errors::mesh(format!(
            "energy(): the mesh must be used as given, but building it flipped {} face(s) (first: {:?}) and dropped {} unused vertex(es); orient the faces consistently and remove unused vertices (thinshell.Mesh(V, F) does both)",
            report.n_flipped(),
            report.flipped_faces.first().map(|f| f.idx()),
            report.n_dropped_vertices
        )));
    }
    let sff = SffKind::from_name(form).ok_or_else(|| {
        PyValueError::new_err(format!(
            "form: `{form}`: expected \"mid_edge_average\", \"edge_director_sin\" or \"edge_director_tan\""
        ))
    })?;
    let model = ShellModel {
        material: self::material(material)?,
        terms: self::terms(terms)?,
        sff,
    };
    let rest = if let Ok(t) = rest.cast::<PyTuple>() {
        if t.len() != 2 {
            return Err(PyTypeError::new_err(
                "rest: expected rest positions (n × 3) or a tuple (a_bar, b_bar)",
            ));
        }
        RestState {
            a_bar: convert::forms(&t.get_item(0)?, "a_bar")?,
            b_bar: convert::forms(&t.get_item(1)?, "b_bar")?,
        }
    } else {
        let x0 = convert::points(rest, "rest positions")?;
        RestState::from_mesh(&mesh, &x0, sff).map_err(errors::energy)?
    };
    rest.validate(&mesh).map_err(errors::energy)?;
    let n_angles = if model.has_edge_unknowns() {
        mesh.n_edges()
    } else {
        0
    };
    let phi = match edge_angles {
        Some(a) => a.as_array().to_vec(),
        None => vec![0.0; n_angles],
    };
    if phi.len() != n_angles {
        return Err(PyValueError::new_err(format!(
            "edge_angles: expected {n_angles} entries (one per edge with an edge-director form and bending on, else none), got {}",
            phi.len()
        )));
    }
    let result = py.detach(|| {
        let dofs = DofMap::all_free(mesh.n_vertices()).with_edges(n_angles, [])?;
        let mut assembler = Assembler::for_model(&mesh, &dofs, &model)?;
        let mut gradient = vec![0.0; assembler.n_coordinates()];
        let mut h = assembler.hessian_template();
        let e = assembler.evaluate_with_angles(
            &model,
            &x,
            &phi,
            &rest,
            None,
            EvalOutput {
                gradient: Some(&mut gradient),
                hessian: hessian.then_some((&mut h, HessianMode::Exact)),
            },
        )?;
        // All coordinates are free, so free dof = coordinate; the lower triangle becomes the
        // full symmetric matrix.
        let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
        if hessian {
            let col_ptr = h.col_ptr();
            let row_idx = h.row_idx();
            let values = h.val();
            for c in 0..h.ncols() {
                for k in col_ptr[c]..col_ptr[c + 1] {
                    let r = row_idx[k];
                    rows.push(r as i64);
                    cols.push(c as i64);
                    vals.push(values[k]);
                    if r != c {
                        rows.push(c as i64);
                        cols.push(r as i64);
                        vals.push(values[k]);
                    }
                }
            }
        }
        Ok::<_, thinshell_energy::EnergyError>((e, gradient, rows, cols, vals))
    });
    let (e, gradient, rows, cols, vals) = result.map_err(errors::energy)?;
    let n = gradient.len();
    Ok((
        e.stretch,
        e.bend,
        PyArray1::from_vec(py, gradient),
        PyArray1::from_vec(py, rows),
        PyArray1::from_vec(py, cols),
        PyArray1::from_vec(py, vals),
        n,
    ))
}
