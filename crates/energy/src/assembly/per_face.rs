//! Per-face quantities of one configuration, for output and diagnostics rather than solves:
//! the elastic energy of every face ([`Assembler::elastic_face_energies`], the one per-face
//! energy function) and every face's forms with the law's first derivatives
//! ([`Assembler::face_forms`], what curvatures, stress resultants and bending moments are
//! computed from). Both read edge angles the same way (documented once, on
//! [`Assembler::elastic_face_energies`]).

use nalgebra::{Matrix2, Vector3};

use super::{Assembler, EvalOutput, face_data};
use crate::EnergyTerms;
use crate::dofs::check_len;
use crate::error::EnergyError;
use crate::material::{FaceGeometry, LawEval, Order};
use crate::membrane_strain::first_fundamental_form;
use crate::model::ShellModel;
use crate::rest::RestState;
use crate::small_matrix::{inv2, sym_entries};
use thinshell_mesh::FaceId;

/// A face's forms at one configuration and the first derivatives of its elastic energy E (J;
/// the model's law, damping excluded) in them — the conjugate forces of the forms, from which
/// stress resultants and bending moments follow. Forms are in the face's barycentric basis
/// (e1, e2) = (x_j − x_i, x_k − x_i); derivatives are with respect to the entries
/// (m11, m12, m22) of a symmetric form, m12 = m21 being one entry.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FaceForms {
    /// First fundamental form a = [e1 e2]ᵀ[e1 e2] (m²).
    pub a: Matrix2<f64>,
    /// Second fundamental form b of the model's discretisation at the configuration's edge
    /// angles (m; model.md §1 sign: b ≈ −a/r on a sphere of radius r with outward normals).
    /// Computed whether or not bending is on.
    pub b: Matrix2<f64>,
    /// ∂E/∂(a11, a12, a22) (J/m²).
    pub de_da: Vector3<f64>,
    /// ∂E/∂(b11, b12, b22) (J/m); 0 with bending off.
    pub de_db: Vector3<f64>,
}

impl Assembler {
    /// Elastic energy terms (J; stretch and bend, damping 0) of every face at positions `x` (m)
    /// and edge angles `phi` against `rest`, in face order, with their sum: the one per-face
    /// energy function (energy maps, `Simulation::face_energies`, `ShellSystem::face_energies`).
    /// The assembler must be built for `model`'s terms without damping
    /// ([`ShellModel::elastic`]); errors as [`Assembler::evaluate_with_angles`].
    ///
    /// **Edge angles.** With edge unknowns `phi` holds one angle per edge (rad), and an
    /// **empty `phi` means every φ_e = 0**: the value the angles start at, which a state keeps
    /// until its first solve (model.md §1.1). A caller that means "the angles that minimise the
    /// energy at `x`" solves for them and passes them (`ShellSystem::face_energies` does that
    /// for an empty `phi`). Without edge unknowns `phi` must be empty.
    pub fn elastic_face_energies(
        &mut self,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
    ) -> Result<(EnergyTerms, &[EnergyTerms]), EnergyError> {
        let model = model.elastic();
        let zeros;
        let phi = if phi.is_empty() && self.has_edge_unknowns() {
            zeros = vec![0.0; self.n_edges];
            &zeros[..]
        } else {
            phi
        };
        let total = self.evaluate_with_angles(&model, x, phi, rest, None, EvalOutput::default())?;
        Ok((total, &self.energies))
    }

    /// Every face's [`FaceForms`] at positions `x` (m) and edge angles `phi` (rad; read as in
    /// [`Assembler::elastic_face_energies`]: empty means all 0) against `rest`, in face order.
    /// The law's derivatives are those of `model`'s elastic terms (no damping), by its own
    /// gradient ([`crate::ElasticLaw::eval`]). Errors on wrong lengths, an invalid material or a
    /// face whose values are not finite (the lowest such face).
    pub fn face_forms(
        &self,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
    ) -> Result<Vec<FaceForms>, EnergyError> {
        let n_faces = self.energies.len();
        check_len("positions", self.n_vertices, x.len())?;
        check_len("rest a_bar", n_faces, rest.a_bar.len())?;
        check_len("rest b_bar", n_faces, rest.b_bar.len())?;
        if !phi.is_empty() {
            check_len("edge angles", self.n_edges, phi.len())?;
        }
        model.material.validate()?;
        let terms = model.elastic().terms;
        let law = model.material.model.law();
        let with_angles = self.has_edge_unknowns() && !phi.is_empty();
        let mut out = Vec::with_capacity(n_faces);
        let mut le = LawEval::default();
        for f in 0..n_faces {
            let stencil = if with_angles {
                self.stencils.stencil_at(f, x, phi)
            } else {
                self.stencils.stencil(f, x)
            };
            let a = first_fundamental_form(&[stencil.x[0], stencil.x[1], stencil.x[2]]);
            let b = model.sff.b(&stencil);
            let (face_rest, _) = face_data(rest, None, f);
            let geometry = FaceGeometry {
                a_bar: sym_entries(&face_rest.a_bar),
                b_bar: sym_entries(&face_rest.b_bar),
                a_bar_inv: inv2(&face_rest.a_bar),
                area: face_rest.a_bar.determinant().sqrt(),
            };
            // The law reads b̄ for b when bending is off (its contract).
            let b_law = if terms.bend {
                sym_entries(&b)
            } else {
                geometry.b_bar
            };
            law.eval(
                &model.material,
                &geometry,
                &sym_entries(&a),
                &b_law,
                terms,
                Order::Gradient,
                &mut le,
            );
            let forms = FaceForms {
                a,
                b,
                de_da: le.ga,
                de_db: if terms.bend { le.gb } else { Vector3::zeros() },
            };
            let finite = forms.a.iter().chain(forms.b.iter()).all(|v| v.is_finite())
                && forms
                    .de_da
                    .iter()
                    .chain(forms.de_db.iter())
                    .all(|v| v.is_finite());
            if !finite {
                return Err(EnergyError::NonFinite {
                    face: FaceId::new(f),
                });
            }
            out.push(forms);
        }
        Ok(out)
    }
}
