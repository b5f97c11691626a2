//! Second fundamental form discretisations.

pub(crate) mod edge_director;
pub(crate) mod mid_edge_average;
pub(crate) mod normals;

pub use edge_director::{DIRECTOR_DOFS, DirectorVariant, EdgeDirector};
pub(crate) use edge_director::{fit_quality, fitted_edge_angle};
pub use mid_edge_average::MidEdgeAverage;

use crate::face_stencil::FaceStencil;
use nalgebra::{Matrix2, SMatrix, SVector, Vector3};

/// Output of [`SecondFundamentalForm::b_derivatives`].
#[derive(Clone, Debug)]
pub struct SffDerivatives<const N: usize> {
    /// b (m), symmetric.
    pub b: Matrix2<f64>,
    /// Jacobian: rows b11, b12, b22 w.r.t. the form's N face dofs (18 positions in stencil
    /// order — dimensionless —, then any edge angles, m/rad).
    pub jacobian: SMatrix<f64, 3, N>,
}

/// A discrete second fundamental form b of a face over its N dofs: the 18 stencil positions
/// (x0, x1, x2, flap0, flap1, flap2, three coordinates each), then the form's extra per-face
/// unknowns (the three edge angles for N = 21). Sign of model.md §1: b ≈ −a/r on a sphere of
/// radius r with outward normals.
///
/// A new discretisation is one type implementing this trait (plus an [`SffKind`] variant and
/// its dispatch in the assembler); [`crate::eval_face`] does the chain rule for every energy.
pub trait SecondFundamentalForm<const N: usize>: Sync {
    /// b of the face (no derivatives). `stencil.x[3+e]` is ignored when `!stencil.flap[e]`
    /// (boundary edge: the face normal is used).
    fn b(&self, stencil: &FaceStencil) -> Matrix2<f64>;

    /// b and its Jacobian (rows b11, b12, b22 w.r.t. the N dofs). When `hessian` is
    /// `Some((w, h))`, ADDS the contracted Hessian Σ_k w_k ∇²b_k (N×N, w = (w11, w12, w22))
    /// to `h`; the third-order tensor is never formed.
    fn b_derivatives(
        &self,
        stencil: &FaceStencil,
        hessian: Option<(&Vector3<f64>, &mut SMatrix<f64, N, N>)>,
    ) -> SffDerivatives<N>;

    /// b, the weights w = (w11, w12, w22) computed from b by `weights`, and the gradient of
    /// w·b = Σ_k w_k b_k (N entries). Implementations may avoid forming the Jacobian (reverse
    /// mode); the default goes through [`b_derivatives`](Self::b_derivatives).
    fn b_and_weighted_gradient(
        &self,
        stencil: &FaceStencil,
        weights: &dyn Fn(&Matrix2<f64>) -> Vector3<f64>,
    ) -> (Matrix2<f64>, Vector3<f64>, SVector<f64, N>) {
        let d = self.b_derivatives(stencil, None);
        let w = weights(&d.b);
        (d.b, w, d.jacobian.transpose() * w)
    }
}

/// Choice of second fundamental form discretisation.
///
/// The default is [`SffKind::EdgeDirector`]`(`[`DirectorVariant::Tan`]`)`, the form that is
/// consistent on every mesh. The mid-edge average is kept for reproducing the paper and for
/// cost comparisons; its bending energy does **not** converge under refinement on irregular
/// meshes, at free edges, and on the alternating-diagonal grids of
/// `thinshell_mesh::generators::rectangle` / `cylinder_patch` as soon as the curvature is not
/// aligned with the grid (`crates/solver/tests/default_form.rs`).
///
/// Why `tan` rather than `sin`: the accuracy and the cost are of the same class (same unknowns
/// and pattern), but `tan`'s energy barrier as a hinge approaches 180° (II ∝ tan α → ∞) resists
/// folding a sheet flat onto itself, which `sin` allows — the variant the paper authors'
/// library recommends. The measurements behind both choices are in docs/scenes.md ("Why the
/// default is `edge_director_tan`").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SffKind {
    /// Normalised average of the two unit face normals per edge (model.md §1, the paper's
    /// form): positions only, cheapest per iteration, but inconsistent — its error does not
    /// shrink under refinement on irregular meshes, at free edges and on alternating-diagonal
    /// grids bent across the grid.
    MidEdgeAverage,
    /// Edge directors (model.md §1.1): one extra unknown per edge, the angle (rad) of the
    /// edge's normal director about the edge; consistent under refinement on any mesh. On free
    /// edges the director is extrapolated from the interior and on clamped edges held (model.md
    /// §1.2–1.3; no unknown there) and on mirror edges in their symmetry plane (§1.4), which keeps the bending energy second order up to the
    /// boundary.
    /// Default: `EdgeDirector(DirectorVariant::Tan)`.
    EdgeDirector(DirectorVariant),
}

impl Default for SffKind {
    /// The tan edge-director form (see [`SffKind`] for why).
    fn default() -> Self {
        SffKind::EdgeDirector(DirectorVariant::Tan)
    }
}

impl Default for DirectorVariant {
    /// `Tan`: the folding barrier, same accuracy and cost as `Sin` (see [`SffKind`]).
    fn default() -> Self {
        DirectorVariant::Tan
    }
}

impl SffKind {
    /// The three discretisations, cheapest first.
    pub const ALL: [SffKind; 3] = [
        SffKind::MidEdgeAverage,
        SffKind::EdgeDirector(DirectorVariant::Sin),
        SffKind::EdgeDirector(DirectorVariant::Tan),
    ];

    /// b of a face with this form, at the stencil's edge angles (all 0 for a stencil from
    /// [`FaceStencil::new`]: used for rest forms of a given shape).
    pub fn b(self, stencil: &FaceStencil) -> Matrix2<f64> {
        match self {
            SffKind::MidEdgeAverage => MidEdgeAverage.b(stencil),
            SffKind::EdgeDirector(variant) => EdgeDirector { variant }.b(stencil),
        }
    }

    /// The edge-director form, if this is one (it needs one angle unknown per edge).
    pub fn director(self) -> Option<EdgeDirector> {
        match self {
            SffKind::MidEdgeAverage => None,
            SffKind::EdgeDirector(variant) => Some(EdgeDirector { variant }),
        }
    }

    /// Short name used in scene files and reports: `mid_edge_average`, `edge_director_sin`,
    /// `edge_director_tan`.
    pub fn name(self) -> &'static str {
        match self {
            SffKind::MidEdgeAverage => "mid_edge_average",
            SffKind::EdgeDirector(DirectorVariant::Sin) => "edge_director_sin",
            SffKind::EdgeDirector(DirectorVariant::Tan) => "edge_director_tan",
        }
    }

    /// Inverse of [`SffKind::name`].
    pub fn from_name(name: &str) -> Option<SffKind> {
        SffKind::ALL.into_iter().find(|k| k.name() == name)
    }
}
