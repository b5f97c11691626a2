//! The error type of the crate.

/// Everything that can go wrong when building, reading or writing a mesh.
///
/// Face indices refer to the face list as given to [`Mesh::new`](crate::Mesh::new) (0-based);
/// vertex indices refer to the position list as given (before unreferenced vertices are dropped).
#[derive(thiserror::Error, Debug)]
#[non_exhaustive]
pub enum MeshError {
    /// The mesh has no faces.
    #[error("mesh is empty: no faces")]
    Empty,
    /// A face refers to a vertex that does not exist.
    #[error(
        "face {face}, corner {corner}: vertex index {index} out of range (mesh has {n_vertices} vertices)"
    )]
    IndexOutOfRange {
        /// Offending face.
        face: usize,
        /// Corner (0, 1, 2) of the face.
        corner: usize,
        /// The out-of-range vertex index.
        index: usize,
        /// Number of vertices given.
        n_vertices: usize,
    },
    /// A face uses the same vertex twice.
    #[error("face {face} uses vertex {vertex} more than once")]
    RepeatedVertex {
        /// Offending face.
        face: usize,
        /// The repeated vertex.
        vertex: usize,
    },
    /// Two faces have the same three vertices (in any order or orientation).
    #[error("face {face} duplicates face {first} (same vertices {vertices:?})")]
    DuplicateFace {
        /// The later of the two faces.
        face: usize,
        /// The earlier face it duplicates.
        first: usize,
        /// The shared vertices (sorted).
        vertices: [usize; 3],
    },
    /// A face has (numerically) zero area; see [`DEGENERATE_TOLERANCE`](crate::DEGENERATE_TOLERANCE).
    #[error("face {face} is degenerate: |e1 x e2| / l_max^2 = {relative_area:e}")]
    DegenerateFace {
        /// Offending face.
        face: usize,
        /// `|e1 × e2| / ℓ_max²` of the face (twice its area over its longest edge squared).
        relative_area: f64,
    },
    /// A face is so small or so large that its first fundamental form (squared edge lengths,
    /// squared area) under- or overflows `f64`: the energies could not be computed.
    #[error(
        "face {face} is out of the representable scale: twice its area is {twice_area:e} (edge lengths must lie between about 1e-76 and 1e76)"
    )]
    OutOfScale {
        /// Offending face.
        face: usize,
        /// `|e1 × e2|` of the face as computed (0 on underflow, `inf` on overflow).
        twice_area: f64,
    },
    /// An edge is shared by three or more faces.
    #[error("edge ({}, {}) is non-manifold: shared by {} faces {faces:?}", .vertices[0], .vertices[1], .faces.len())]
    NonManifoldEdge {
        /// The edge's two vertices (sorted).
        vertices: [usize; 2],
        /// All faces that use the edge.
        faces: Vec<usize>,
    },
    /// The faces of a connected component cannot be oriented consistently (e.g. a Möbius strip).
    #[error("mesh is not orientable: face {face} and face {neighbor} cannot agree on the direction of edge ({}, {})", .edge[0], .edge[1])]
    NonOrientable {
        /// The face where the contradiction was found.
        face: usize,
        /// Its neighbour across `edge`.
        neighbor: usize,
        /// The shared edge.
        edge: [usize; 2],
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex}: coordinate {axis} is not finite ({value})")]
    NonFiniteCoordinate {
        /// Offending vertex.
        vertex: usize,
        /// Axis 0, 1, 2 (x, y, z).
        axis: usize,
        /// The value found.
        value: f64,
    },
    /// A position array has the wrong length for this mesh.
    #[error("expected {expected} positions, got {found}")]
    WrongPositionCount {
        /// Number of vertices of the mesh.
        expected: usize,
        /// Length of the given array.
        found: usize,
    },
    /// More vertices or faces than `u32` indices can address.
    #[error("mesh too large: {count} {what} (limit {limit})")]
    TooLarge {
        /// "vertices" or "faces".
        what: &'static str,
        /// Number given.
        count: usize,
        /// The largest supported number.
        limit: usize,
    },
    /// A generator parameter is out of its valid range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Given value (integers are converted to f64).
        value: f64,
        /// What is required.
        reason: &'static str,
    },
    /// A line of the OBJ text is malformed.
    #[error("OBJ line {line}: {message}")]
    ObjSyntax {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A mesh problem of faces or vertices read from an OBJ file, with their 1-based lines.
    #[error("OBJ line{} {}: {source}", if .lines.len() > 1 { "s" } else { "" }, join_lines(.lines))]
    InObj {
        /// The `f` lines of the faces and the `v` lines of the vertices involved (ascending).
        lines: Vec<usize>,
        /// The problem, with the mesh's 0-based face and vertex indices.
        source: Box<MeshError>,
    },
    /// Reading or writing failed.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

fn join_lines(lines: &[usize]) -> String {
    let shown: Vec<String> = lines.iter().take(8).map(usize::to_string).collect();
    let more = lines.len().saturating_sub(8);
    if more > 0 {
        format!("{} and {more} more", shown.join(", "))
    } else {
        shown.join(", ")
    }
}

impl MeshError {
    /// The input faces (0-based) the problem is about, for locating it in a file.
    pub fn faces(&self) -> Vec<usize> {
        match self {
            MeshError::IndexOutOfRange { face, .. }
            | MeshError::RepeatedVertex { face, .. }
            | MeshError::DegenerateFace { face, .. }
            | MeshError::OutOfScale { face, .. } => vec![*face],
            MeshError::DuplicateFace { face, first, .. } => vec![*first, *face],
            MeshError::NonManifoldEdge { faces, .. } => faces.clone(),
            MeshError::NonOrientable { face, neighbor, .. } => vec![*face, *neighbor],
            MeshError::InObj { source, .. } => source.faces(),
            _ => Vec::new(),
        }
    }

    /// The input vertices (0-based) the problem is about when no face is (a coordinate that is
    /// not finite).
    pub fn vertices(&self) -> Vec<usize> {
        match self {
            MeshError::NonFiniteCoordinate { vertex, .. } => vec![*vertex],
            MeshError::InObj { source, .. } => source.vertices(),
            _ => Vec::new(),
        }
    }
}
