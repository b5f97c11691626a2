//! Rest state (ā, b̄) and damping state (a^prev, b^prev) per face.
//!
//! All forms are symmetric 2×2 matrices in the face's barycentric basis
//! `(e1, e2) = (x_j − x_i, x_k − x_i)` of its stored vertex order (ā in m², b̄ in m).

use crate::dofs::check_len;
use crate::error::EnergyError;
use crate::membrane_strain::first_fundamental_form;
use crate::sff::SffKind;
use crate::stencil_table::Stencils;
use nalgebra::{Matrix2, Vector3};
use thinshell_mesh::{FaceId, Mesh, VertexId};

/// Relative tolerance for "the mesh lies in a plane z = const" in [`RestState::from_planar`]
/// (relative to the mesh's bounding-box diagonal).
pub const PLANAR_TOLERANCE: f64 = 1e-12;

/// Rest forms per face: first fundamental form ā (m²) and second fundamental form b̄ (m).
#[derive(Clone, Debug, PartialEq)]
pub struct RestState {
    /// ā per face (symmetric positive definite, m²).
    pub a_bar: Vec<Matrix2<f64>>,
    /// b̄ per face (symmetric, m).
    pub b_bar: Vec<Matrix2<f64>>,
    /// The second fundamental form b̄ was computed with ([`RestState::from_mesh`],
    /// [`RestState::for_model`]); `None` for forms given directly (from the plane, a growth
    /// model, a file). A shell system checks it against its model's form.
    pub sff: Option<SffKind>,
}

/// The forms (a, b) of every face of `mesh` at positions `x` (not validated); an edge-director
/// b uses the edge angles `phi` (one per edge; empty = all 0).
fn forms_of(
    mesh: &Mesh,
    x: &[Vector3<f64>],
    phi: &[f64],
    sff: SffKind,
) -> Result<RestState, EnergyError> {
    forms_with(&Stencils::new(mesh), x, phi, sff)
}

/// [`forms_of`] with given stencils (which may carry clamps, model.md §1.3).
fn forms_with(
    stencils: &Stencils,
    x: &[Vector3<f64>],
    phi: &[f64],
    sff: SffKind,
) -> Result<RestState, EnergyError> {
    check_len("positions", stencils.n_vertices(), x.len())?;
    if !phi.is_empty() {
        check_len("edge angles", stencils.n_edges(), phi.len())?;
        if let Some(e) = phi.iter().position(|p| !p.is_finite()) {
            return Err(EnergyError::InvalidParameter {
                name: "edge angle",
                value: phi[e],
                reason: "must be finite",
            });
        }
    }
    if let Some(v) = x.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(EnergyError::NonFiniteVertex {
            vertex: VertexId::new(v),
        });
    }
    let mut a = Vec::with_capacity(stencils.n_faces());
    let mut b = Vec::with_capacity(stencils.n_faces());
    for f in 0..stencils.n_faces() {
        let st = stencils.stencil(f, x);
        a.push(first_fundamental_form(&[st.x[0], st.x[1], st.x[2]]));
        let st = if phi.is_empty() {
            st
        } else {
            stencils.stencil_at(f, x, phi)
        };
        b.push(sff.b(&st));
    }
    Ok(RestState {
        a_bar: a,
        b_bar: b,
        sff: Some(sff),
    })
}

impl RestState {
    /// The forms (a⁰, b⁰) of the configuration `x` (one position per vertex, m) as rest state,
    /// with `sff` choosing the discrete second fundamental form. Errors on a length mismatch,
    /// non-finite positions, or a degenerate face (ā not positive definite).
    pub fn from_mesh(
        mesh: &Mesh,
        x: &[Vector3<f64>],
        sff: SffKind,
    ) -> Result<RestState, EnergyError> {
        let rest = forms_of(mesh, x, &[], sff)?;
        rest.validate(mesh)?;
        Ok(rest)
    }

    /// [`RestState::from_mesh`] for a shell cut by symmetry planes: `mirror_edges` (boundary
    /// edge, plane normal) enter b̄ as they enter the energy (model.md §1.4), so that the rest
    /// shape is stress-free with the mirror edges' directors (edge-director forms) or edge
    /// normals (mid-edge average) in their planes. Errors as [`RestState::from_mesh`] and
    /// [`crate::Stencils::set_mirror_edges`].
    pub fn from_mesh_with_mirrors(
        mesh: &Mesh,
        x: &[Vector3<f64>],
        sff: SffKind,
        mirror_edges: &[(thinshell_mesh::EdgeId, Vector3<f64>)],
    ) -> Result<RestState, EnergyError> {
        let mut stencils = Stencils::new(mesh);
        stencils.set_mirror_edges(mirror_edges)?;
        let rest = forms_with(&stencils, x, &[], sff)?;
        rest.validate(mesh)?;
        Ok(rest)
    }

    /// [`RestState::from_mesh`] with `model`'s second fundamental form: the form is named once,
    /// in the model.
    pub fn for_model(
        mesh: &Mesh,
        x: &[Vector3<f64>],
        model: &crate::ShellModel,
    ) -> Result<RestState, EnergyError> {
        RestState::from_mesh(mesh, x, model.sff)
    }

    /// Rest forms given in the xy-plane (model.md §5): for a mesh lying in a plane `z = const`
    /// (its stored positions), `ā = Tᵀ ā^{xy} T` and `b̄ = Tᵀ b̄^{xy} T` with
    /// `T = [x_j − x_i | x_k − x_i]` (xy components, 2×2). `a_xy` (dimensionless metric) must
    /// be symmetric positive definite, `b_xy` (1/m) symmetric and finite.
    pub fn from_planar(
        mesh: &Mesh,
        a_xy: Matrix2<f64>,
        b_xy: Matrix2<f64>,
    ) -> Result<RestState, EnergyError> {
        check_form("a_xy", &a_xy, true)?;
        check_form("b_xy", &b_xy, false)?;
        let x = mesh.positions();
        let tol = PLANAR_TOLERANCE * mesh.bounding_box().diagonal();
        let z0 = x.first().map_or(0.0, |p| p.z);
        if let Some(v) = x.iter().position(|p| (p.z - z0).abs() > tol) {
            return Err(EnergyError::NotPlanar {
                vertex: VertexId::new(v),
                z: x[v].z,
                z0,
            });
        }
        let (a_bar, b_bar) = mesh
            .faces()
            .iter()
            .map(|f| {
                let (p, q, r) = (x[f[0].idx()], x[f[1].idx()], x[f[2].idx()]);
                let t = Matrix2::new(q.x - p.x, r.x - p.x, q.y - p.y, r.y - p.y);
                (t.transpose() * a_xy * t, t.transpose() * b_xy * t)
            })
            .unzip();
        let rest = RestState {
            a_bar,
            b_bar,
            sff: None,
        };
        rest.validate(mesh)?;
        Ok(rest)
    }

    /// Checks one (ā, b̄) per face of `mesh`, all entries finite, both symmetric (to 1e-12
    /// relative) and ā positive definite; names the first offending face.
    pub fn validate(&self, mesh: &Mesh) -> Result<(), EnergyError> {
        check_len("rest a_bar", mesh.n_faces(), self.a_bar.len())?;
        check_len("rest b_bar", mesh.n_faces(), self.b_bar.len())?;
        for (f, (a, b)) in self.a_bar.iter().zip(&self.b_bar).enumerate() {
            let face = FaceId::new(f);
            for (form, m, spd) in [("a_bar", a, true), ("b_bar", b, false)] {
                if let Err(reason) = form_problem(m, spd) {
                    return Err(EnergyError::InvalidRestForm { face, form, reason });
                }
            }
        }
        Ok(())
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.a_bar.len()
    }

    /// `out = (1 − s)·from + s·to`, face by face, for continuation between two rest states
    /// (`s ∈ [0, 1]`; a convex combination of positive definite ā stays positive definite).
    /// Errors on mismatched lengths or `s` outside [0, 1].
    pub fn blend(
        from: &RestState,
        to: &RestState,
        s: f64,
        out: &mut RestState,
    ) -> Result<(), EnergyError> {
        if !(0.0..=1.0).contains(&s) {
            return Err(EnergyError::InvalidParameter {
                name: "blend weight s",
                value: s,
                reason: "must lie in [0, 1]",
            });
        }
        let n = from.n_faces();
        check_len("rest a_bar", n, to.a_bar.len())?;
        check_len("rest b_bar", n, to.b_bar.len())?;
        check_len("rest b_bar", n, from.b_bar.len())?;
        let mix = |a: &[Matrix2<f64>], b: &[Matrix2<f64>], out: &mut Vec<Matrix2<f64>>| {
            out.clear();
            out.extend(a.iter().zip(b).map(|(a, b)| a * (1.0 - s) + b * s));
        };
        mix(&from.a_bar, &to.a_bar, &mut out.a_bar);
        mix(&from.b_bar, &to.b_bar, &mut out.b_bar);
        Ok(())
    }
}

/// Forms of the previous configuration for Kelvin–Voigt damping (model.md §2), with the time
/// step Δt (s).
#[derive(Clone, Debug, PartialEq)]
pub struct DampingState {
    /// a^prev per face (m²).
    pub a_prev: Vec<Matrix2<f64>>,
    /// b^prev per face (m).
    pub b_prev: Vec<Matrix2<f64>>,
    /// Time step Δt (s, > 0).
    pub dt: f64,
}

impl DampingState {
    /// Forms of the positions `x_prev` (m) at the start of a step of length `dt` (s). Errors on
    /// a length mismatch, non-finite positions, a degenerate face or `dt` not finite and > 0.
    /// An edge-director form is evaluated with all edge angles 0: use
    /// [`DampingState::from_configuration`] to pass the angles.
    pub fn from_positions(
        mesh: &Mesh,
        x_prev: &[Vector3<f64>],
        sff: SffKind,
        dt: f64,
    ) -> Result<DampingState, EnergyError> {
        Self::from_configuration(mesh, x_prev, &[], sff, dt)
    }

    /// Like [`DampingState::from_positions`], with the edge angles `phi_prev` (rad, one per
    /// edge, or empty for all 0) of an edge-director form at the start of the step.
    pub fn from_configuration(
        mesh: &Mesh,
        x_prev: &[Vector3<f64>],
        phi_prev: &[f64],
        sff: SffKind,
        dt: f64,
    ) -> Result<DampingState, EnergyError> {
        Self::with_stencils(&Stencils::new(mesh), x_prev, phi_prev, sff, dt)
    }

    /// [`DampingState::from_configuration`] with given stencils: those of an assembler, whose
    /// clamps (model.md §1.3) then enter b^prev as they enter b.
    pub(crate) fn with_stencils(
        stencils: &Stencils,
        x_prev: &[Vector3<f64>],
        phi_prev: &[f64],
        sff: SffKind,
        dt: f64,
    ) -> Result<DampingState, EnergyError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(EnergyError::InvalidParameter {
                name: "dt",
                value: dt,
                reason: "must be finite and > 0",
            });
        }
        let RestState {
            a_bar: a_prev,
            b_bar: b_prev,
            ..
        } = forms_with(stencils, x_prev, phi_prev, sff)?;
        for (f, a) in a_prev.iter().enumerate() {
            if let Err(reason) = form_problem(a, true) {
                return Err(EnergyError::InvalidRestForm {
                    face: FaceId::new(f),
                    form: "a_prev",
                    reason,
                });
            }
        }
        Ok(DampingState { a_prev, b_prev, dt })
    }
}

/// Why a 2×2 form is unusable, if it is: non-finite, not symmetric, or (when `spd`) not
/// positive definite.
fn form_problem(m: &Matrix2<f64>, spd: bool) -> Result<(), &'static str> {
    if !m.iter().all(|v| v.is_finite()) {
        return Err("non-finite entry");
    }
    let scale = m.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    if (m[(0, 1)] - m[(1, 0)]).abs() > 1e-12 * scale {
        return Err("not symmetric");
    }
    if spd && !(m[(0, 0)] > 0.0 && m.determinant() > 0.0) {
        return Err("not positive definite");
    }
    Ok(())
}

/// [`form_problem`] of a user-given parameter as [`EnergyError::InvalidParameter`].
fn check_form(name: &'static str, m: &Matrix2<f64>, spd: bool) -> Result<(), EnergyError> {
    form_problem(m, spd).map_err(|reason| EnergyError::InvalidParameter {
        name,
        value: m.determinant(),
        reason,
    })
}
