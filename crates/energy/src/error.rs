//! Typed errors of the energy crate.

/// Errors raised by material validation and energy evaluation.
#[derive(thiserror::Error, Debug)]
#[non_exhaustive]
pub enum EnergyError {
    /// A material or model parameter is out of its admissible range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name (e.g. `"thickness"`).
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// A face produced a NaN or infinite energy, gradient or Hessian entry (the lowest such
    /// face): typically non-finite positions or a degenerate configuration.
    #[error("non-finite energy or derivative at face {face}")]
    NonFinite {
        /// Offending face.
        face: thinshell_mesh::FaceId,
    },
    /// A vertex position is NaN or infinite.
    #[error("non-finite position of vertex {vertex}")]
    NonFiniteVertex {
        /// Offending vertex.
        vertex: thinshell_mesh::VertexId,
    },
    /// A slice or per-face array has the wrong length.
    #[error("{what}: expected length {expected}, got {got}")]
    LengthMismatch {
        /// What was checked (e.g. `"positions"`).
        what: &'static str,
        /// Required length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// A pinned coordinate names a vertex out of range or an axis ≥ 3.
    #[error("invalid pin: vertex {vertex}, axis {axis}")]
    InvalidPin {
        /// Vertex of the pin.
        vertex: thinshell_mesh::VertexId,
        /// Axis of the pin (must be 0, 1 or 2).
        axis: usize,
    },
    /// An edge id (e.g. of a fixed edge angle) is out of range.
    #[error("invalid edge {edge}: the mesh has {n_edges} edges")]
    InvalidEdge {
        /// Offending edge.
        edge: thinshell_mesh::EdgeId,
        /// Number of edges.
        n_edges: usize,
    },
    /// The model's second-fundamental-form discretisation needs edge unknowns and the assembler
    /// or dof map has none, or the other way round.
    #[error(
        "edge unknowns mismatch: the model's second fundamental form {sff:?} {needs} edge \
         angles, but the {other} {has}"
    )]
    EdgeUnknownsMismatch {
        /// The model's discretisation.
        sff: crate::sff::SffKind,
        /// "needs" or "does not use".
        needs: &'static str,
        /// What disagrees ("assembler", "dof map").
        other: &'static str,
        /// What it has.
        has: &'static str,
    },
    /// A rest (or previous-step) form of a face is unusable.
    #[error("face {face}: {form} is {reason}")]
    InvalidRestForm {
        /// Offending face.
        face: thinshell_mesh::FaceId,
        /// Which form (`"a_bar"`, `"b_bar"`, `"a_prev"`).
        form: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// Planar rest forms were requested for a mesh that does not lie in a plane z = const.
    #[error("mesh is not planar: vertex {vertex} has z = {z}, vertex 0 has z = {z0}")]
    NotPlanar {
        /// First vertex off the plane.
        vertex: thinshell_mesh::VertexId,
        /// Its z (m).
        z: f64,
        /// z of vertex 0 (m).
        z0: f64,
    },
    /// The model's terms differ from those the assembler was built for.
    #[error("terms mismatch: assembler built for {assembler:?}, model asks for {model:?}")]
    TermsMismatch {
        /// Terms of the assembler.
        assembler: crate::terms::Terms,
        /// Terms of the model.
        model: crate::terms::Terms,
    },
    /// Damping is switched on but no damping state was given.
    #[error("damping is on but no DampingState was given")]
    MissingDamping,
    /// The Hessian passed in was not made by this assembler's `hessian_template`.
    #[error("Hessian sparsity pattern differs from the assembler's template")]
    HessianPatternMismatch,
    /// `gather_hessian` was called before any evaluation computed a Hessian.
    #[error("no Hessian has been evaluated yet")]
    NoHessianEvaluated,
    /// A face index is out of range.
    #[error("face {face} out of range ({n_faces} faces)")]
    FaceOutOfRange {
        /// Offending face.
        face: thinshell_mesh::FaceId,
        /// Number of faces.
        n_faces: usize,
    },
    /// A mesh is too large for the assembler's 32-bit internal indices.
    #[error("too many {what}: {count}")]
    TooLarge {
        /// What overflowed.
        what: &'static str,
        /// How many were needed.
        count: usize,
    },
    /// An operation the material law (or form) does not provide.
    #[error("{what} not provided by `{of}`")]
    Unsupported {
        /// The operation.
        what: &'static str,
        /// The law or form lacking it.
        of: &'static str,
    },
}
