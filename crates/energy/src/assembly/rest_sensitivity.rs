//! The whole-mesh rest-form sensitivity of the elastic forces ([`crate::rest_sensitivity`]):
//! the product λᵀ ∂²E/∂x∂m̄ per face that an adjoint needs, and the sparse matrix ∂²E/∂x∂m̄.

use super::{Assembler, face_data};
use crate::dofs::check_len;
use crate::error::EnergyError;
use crate::model::ShellModel;
use crate::rest::RestState;
use crate::rest_sensitivity::face_rest_mixed;
use crate::sff::{EdgeDirector, MidEdgeAverage, SecondFundamentalForm, SffKind};
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{SMatrix, Vector3};
use rayon::prelude::*;
use thinshell_mesh::FaceId;

impl Assembler {
    /// Per face f, the six numbers w_f = (∂²E/∂x∂m̄_f)ᵀ λ (J per unit of the rest-form entries
    /// m̄_f = (ā11, ā12, ā22, b̄11, b̄12, b̄22) of face f, symmetric-entry convention; see
    /// [`crate::rest_sensitivity`]), i.e. the derivative of λ·∇E(x) in face f's rest forms,
    /// for the elastic terms of `model` at positions `x` (m) and edge angles `phi` (rad; empty
    /// without edge unknowns) with the rest state `rest`.
    ///
    /// `lambda` has the layout of the full gradient ([`Assembler::n_coordinates`]: three per
    /// vertex, then one per edge with edge unknowns, in N and J/rad duals: a displacement in m,
    /// an angle in rad); entries of coordinates that are not unknowns (pins, clamped or fitted
    /// edges) should be 0 for an adjoint. Clamped and mirror edges act as in
    /// [`Assembler::evaluate`]. Errors: wrong lengths, a law without
    /// [`ElasticLaw::rest_mixed`](crate::ElasticLaw::rest_mixed), a non-finite result.
    pub fn rest_adjoint_product(
        &self,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
        lambda: &[f64],
    ) -> Result<Vec<[f64; 6]>, EnergyError> {
        check_len("adjoint", self.n_coordinates(), lambda.len())?;
        self.per_face(model, x, phi, rest, |_, k, local| {
            let mut w = [0.0; 6];
            for (i, &g) in local.iter().enumerate() {
                if let Some(g) = g {
                    let l = lambda[g];
                    if l != 0.0 {
                        for (j, wj) in w.iter_mut().enumerate() {
                            *wj += k[(i, j)] * l;
                        }
                    }
                }
            }
            w
        })
    }

    /// The sparse matrix ∂²E/∂x∂m̄ (rows: the full coordinates as in
    /// [`Assembler::rest_adjoint_product`], columns 6f + k: rest-form entry k of face f) of the
    /// elastic terms of `model` at `x`, `phi`, `rest`. The adjoint needs only its product with a
    /// vector ([`Assembler::rest_adjoint_product`], which does not form it).
    pub fn rest_mixed_matrix(
        &self,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
    ) -> Result<SparseColMat<usize, f64>, EnergyError> {
        let blocks = self.per_face(model, x, phi, rest, |f, k, local| {
            let mut t = Vec::new();
            for (i, &g) in local.iter().enumerate() {
                if let Some(g) = g {
                    for j in 0..6 {
                        t.push(Triplet::new(g, 6 * f + j, k[(i, j)]));
                    }
                }
            }
            t
        })?;
        let triplets: Vec<_> = blocks.into_iter().flatten().collect();
        SparseColMat::try_new_from_triplets(self.n_coordinates(), 6 * rest.a_bar.len(), &triplets)
            .map_err(|_| EnergyError::TooLarge {
                what: "rest-form mixed matrix entries",
                count: triplets.len(),
            })
    }

    /// Runs `op(f, K_f, local)` on every face in parallel, with K_f = ∂²E_f/∂x∂m̄_f (N × 6, as
    /// a dynamic view of its first `n` rows) and `local[i]` the full coordinate of local dof i
    /// (`None` for a stencil slot the form does not read).
    fn per_face<T: Send>(
        &self,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
        op: impl Fn(usize, &nalgebra::DMatrix<f64>, &[Option<usize>]) -> T + Sync,
    ) -> Result<Vec<T>, EnergyError> {
        model.material.validate()?;
        check_len("positions", self.n_vertices, x.len())?;
        check_len("edge angles", self.n_edges, phi.len())?;
        let n_faces = self.energies.len();
        check_len("rest a_bar", n_faces, rest.a_bar.len())?;
        check_len("rest b_bar", n_faces, rest.b_bar.len())?;
        match model.sff {
            SffKind::MidEdgeAverage => self.faces(&MidEdgeAverage, model, x, phi, rest, op),
            SffKind::EdgeDirector(variant) => {
                self.faces(&EdgeDirector { variant }, model, x, phi, rest, op)
            }
        }
    }

    fn faces<const N: usize, F, T: Send>(
        &self,
        form: &F,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
        op: impl Fn(usize, &nalgebra::DMatrix<f64>, &[Option<usize>]) -> T + Sync,
    ) -> Result<Vec<T>, EnergyError>
    where
        F: SecondFundamentalForm<N> + ?Sized,
    {
        let stencils = &self.stencils;
        let director = model.sff.director().is_some();
        let with_angles = self.director.is_some();
        let n3 = 3 * self.n_vertices;
        let slots = self.n_slots;
        (0..rest.a_bar.len())
            .into_par_iter()
            .map(|f| {
                let stencil = if with_angles {
                    stencils.stencil_at(f, x, phi)
                } else {
                    stencils.stencil(f, x)
                };
                let (face_rest, _) = face_data(rest, None, f);
                let k: SMatrix<f64, N, 6> =
                    face_rest_mixed(form, &model.material, &stencil, &face_rest, model.terms)?;
                if !k.iter().all(|v| v.is_finite()) {
                    return Err(EnergyError::NonFinite {
                        face: FaceId::new(f),
                    });
                }
                let vertices = stencils.vertices(f);
                let mut local = vec![None; N];
                for s in 0..slots.min(6) {
                    let present = if director {
                        stencils.slot_present_director(f, s)
                    } else {
                        stencils.slot_present(f, s)
                    };
                    if present {
                        for c in 0..3 {
                            local[3 * s + c] = Some(3 * vertices[s].idx() + c);
                        }
                    }
                }
                if with_angles && N > 18 {
                    for (i, e) in stencils.edges(f).iter().enumerate() {
                        local[18 + i] = Some(n3 + e.idx());
                    }
                }
                let dense = nalgebra::DMatrix::from_column_slice(N, 6, k.as_slice());
                Ok(op(f, &dense, &local))
            })
            .collect()
    }
}
