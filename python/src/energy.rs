//! The energy layer: energy, gradient and Hessian of a mesh at given positions against given
//! rest forms, for users who plug thinshell's energy into their own solver.

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use thinshell_energy::nalgebra::{SMatrix, Vector3};
use thinshell_energy::{
    Assembler, DofMap, EdgeDirector, EnergyError, EvalOutput, FaceEval, FaceRest, HessianMode,
    Material, MaterialModel, MidEdgeAverage, ProjectPsd, RestState, SecondFundamentalForm, SffKind,
    ShellModel, Stencils, Terms, Want, eval_face,
};
use thinshell_mesh::{FaceId, Mesh};

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

/// The checked inputs shared by [`energy_parts`] and [`reference_hessian`].
struct Inputs {
    mesh: Mesh,
    x: Vec<Vector3<f64>>,
    model: ShellModel,
    rest: RestState,
    /// Edge angles (rad): one per edge with edge unknowns, else empty.
    phi: Vec<f64>,
    n_angles: usize,
}

/// Builds and checks the mesh, model, rest state and edge angles from the Python arguments.
fn inputs<'py>(
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    rest: &Bound<'py, PyAny>,
    material: Option<&Bound<'py, PyDict>>,
    form: &str,
    terms: Option<Vec<String>>,
    edge_angles: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<Inputs> {
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
            sff: None,
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
        None if n_angles > 0 => relaxed_angles(&mesh, &model, &rest, &x)?,
        None => Vec::new(),
    };
    if phi.len() != n_angles {
        return Err(PyValueError::new_err(format!(
            "edge_angles: expected {n_angles} entries (one per edge with an edge-director form and bending on, else none), got {}",
            phi.len()
        )));
    }
    Ok(Inputs {
        mesh,
        x,
        model,
        rest,
        phi,
        n_angles,
    })
}

/// The edge angles (rad, one per edge) that minimise the energy of `model` at positions `x`:
/// the massless angles' own equilibrium (model.md §1.1), what `edge_angles=None` means with an
/// edge-director form (never silently 0). Fitted free edges keep 0 (no unknown, model.md §1.2).
fn relaxed_angles(
    mesh: &Mesh,
    model: &ShellModel,
    rest: &RestState,
    x: &[Vector3<f64>],
) -> PyResult<Vec<f64>> {
    use thinshell_system::{AngleSettings, Boundary, Loads, ShellSystem};
    let fail = |e: thinshell_solver::SolverError| {
        errors::energy(format!("relaxing the edge angles (edge_angles=None): {e}"))
    };
    let mut system = ShellSystem::new(
        mesh.clone(),
        *model,
        rest.clone(),
        Boundary::default(),
        Loads::default(),
    )
    .map_err(fail)?;
    let mut phi = vec![0.0; mesh.n_edges()];
    system
        .relax_edge_angles(x, &mut phi, None, &AngleSettings::default(), None)
        .map_err(fail)?;
    Ok(phi)
}

/// Energy terms, gradient and full symmetric Hessian (as COO triplets) of the mesh `(V, F)`
/// at `V` against `rest`: either rest positions (n × 3: forms of that shape) or a tuple
/// `(a_bar, b_bar)` of m × 2 × 2 arrays. Returns `(stretch, bend, gradient, rows, cols, vals,
/// n)`; the `thinshell.energy` function builds the `scipy.sparse.csc_matrix`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, rest, material=None, form="edge_director_tan", terms=None, edge_angles=None, hessian=true))]
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
    Bound<'py, PyArray1<f64>>,
)> {
    let Inputs {
        mesh,
        x,
        model,
        rest,
        phi,
        n_angles,
    } = inputs(vertices, faces, rest, material, form, terms, edge_angles)?;
    let angles = phi.clone();
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
        PyArray1::from_vec(py, angles),
    ))
}

/// A reference for tests: the DENSE Hessian (numpy n × n, n = 3·n_vertices plus one per edge
/// with edge unknowns, same ordering as the gradient) of the same energy as [`energy_parts`],
/// built independently of the [`Assembler`]: every face's N×N kernel Hessian
/// ([`eval_face`]) is added entry by entry at its global dof indices. It shares only the
/// per-face stencils with the assembler ([`Stencils`], a pure topology lookup) — not its
/// sparsity pattern, gather maps or lower-triangle storage, nor `energy_parts`' lower → full
/// conversion, which is what it checks. O(n²) memory: small meshes only. Exposed to Python as
/// `thinshell._thinshell._reference_hessian`.
#[pyfunction]
#[pyo3(name = "_reference_hessian", signature = (vertices, faces, rest, material=None, form="edge_director_tan", terms=None, edge_angles=None))]
#[allow(clippy::too_many_arguments)]
pub fn reference_hessian<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    rest: &Bound<'py, PyAny>,
    material: Option<&Bound<'py, PyDict>>,
    form: &str,
    terms: Option<Vec<String>>,
    edge_angles: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let inputs = inputs(vertices, faces, rest, material, form, terms, edge_angles)?;
    let n = 3 * inputs.mesh.n_vertices() + inputs.n_angles;
    // Refuse sizes whose dense matrix would not fit comfortably (1 GiB of f64).
    const MAX_ENTRIES: usize = 1 << 27;
    if n.saturating_mul(n) > MAX_ENTRIES {
        return Err(PyValueError::new_err(format!(
            "_reference_hessian: {n} × {n} dense matrix is too large (a reference for tests on small meshes)"
        )));
    }
    let h = py
        .detach(|| match inputs.model.sff {
            SffKind::MidEdgeAverage => dense_hessian::<18, _>(&MidEdgeAverage, &inputs, n),
            SffKind::EdgeDirector(variant) => {
                dense_hessian::<21, _>(&EdgeDirector { variant }, &inputs, n)
            }
        })
        .map_err(errors::energy)?;
    Ok(PyArray2::from_owned_array(py, h))
}

/// Sum of every face's exact kernel Hessian, scattered into a dense n × n matrix. Local dof
/// `3s + a` (s < 6) is coordinate a of stencil vertex s (x_i, x_j, x_k, flap_0..2; a missing
/// flap contributes nothing); local dof `18 + e` (N = 21) is the angle of the face's local edge
/// e, global dof `3·n_vertices + edge`, when the angles are unknowns (else dropped: held at 0).
fn dense_hessian<const N: usize, F>(
    form: &F,
    inputs: &Inputs,
    n: usize,
) -> Result<Array2<f64>, EnergyError>
where
    F: SecondFundamentalForm<N>,
    SMatrix<f64, N, N>: ProjectPsd,
{
    let Inputs {
        mesh,
        x,
        model,
        rest,
        phi,
        n_angles,
    } = inputs;
    let with_angles = *n_angles > 0;
    let n_positions = 3 * mesh.n_vertices();
    let stencils = Stencils::new(mesh);
    let director = N == thinshell_energy::DIRECTOR_DOFS;
    let want = Want {
        gradient: false,
        hessian: Some(HessianMode::Exact),
    };
    let mut h = Array2::<f64>::zeros((n, n));
    let mut out = FaceEval::<N>::default();
    for f in 0..mesh.n_faces() {
        let stencil = if with_angles {
            stencils.stencil_at(f, x, phi)
        } else {
            stencils.stencil(f, x)
        };
        let face_rest = FaceRest {
            a_bar: rest.a_bar[f],
            b_bar: rest.b_bar[f],
        };
        eval_face(
            form,
            &model.material,
            &stencil,
            &face_rest,
            None,
            model.terms,
            want,
            &mut out,
        );
        let global = |l: usize| -> Option<usize> {
            if l < 18 {
                let s = l / 3;
                // The edge-director forms also read the outer vertices of free-edge fits.
                let present = if director {
                    stencils.slot_present_director(f, s)
                } else {
                    stencils.slot_present(f, s)
                };
                present.then(|| 3 * stencils.vertices(f)[s].idx() + l % 3)
            } else {
                with_angles.then(|| n_positions + stencils.edges(f)[l - 18].idx())
            }
        };
        for j in 0..N {
            let Some(gj) = global(j) else { continue };
            for i in 0..N {
                let Some(gi) = global(i) else { continue };
                let v = out.hessian[(i, j)];
                if !v.is_finite() {
                    return Err(EnergyError::NonFinite {
                        face: FaceId::new(f),
                    });
                }
                h[(gi, gj)] += v;
            }
        }
    }
    Ok(h)
}
