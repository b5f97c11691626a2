//! Every problem of a triangle soup at once, and the mesh of the faces without problems
//! (`thinshell info`): [`Mesh::new`] stops at the first problem, which is what a simulation
//! needs, but whoever repairs a file wants the whole list.

use std::collections::HashMap;

use nalgebra::Vector3;

use crate::error::MeshError;
use crate::geometry::out_of_scale;
use crate::mesh::{DEGENERATE_TOLERANCE, Mesh, relative_area};

/// The problems found in a triangle soup, and what is left without them.
#[derive(Debug)]
pub struct Diagnosis {
    /// Every problem, in the order of [`Mesh::new`]'s checks, each naming input (0-based) face
    /// and vertex indices. Empty when [`Mesh::new`] accepts the input and every face is within
    /// f64's scale.
    pub problems: Vec<MeshError>,
    /// The input faces (0-based, ascending) that have none of the problems.
    pub kept_faces: Vec<usize>,
    /// The mesh of [`Diagnosis::kept_faces`], when they form a valid one (for statistics).
    pub mesh: Option<Mesh>,
}

/// Checks a triangle soup for every problem [`Mesh::new`] and
/// [`check_scale`](crate::check_scale) refuse, not just the first: faces with an index out of
/// range or a repeated vertex, vertices that are not finite (and the faces using them),
/// degenerate faces and faces out of f64's scale, duplicates of earlier faces, all faces of
/// every non-manifold edge; then builds the mesh of the remaining faces (a non-orientable
/// remainder is the last problem, and leaves no mesh).
pub fn diagnose(positions: &[Vector3<f64>], faces: &[[usize; 3]]) -> Diagnosis {
    let mut problems = Vec::new();
    if faces.is_empty() {
        problems.push(MeshError::Empty);
    }
    let n = positions.len();
    let mut ok = vec![true; faces.len()];
    for (face, tri) in faces.iter().enumerate() {
        if let Some((corner, &index)) = tri.iter().enumerate().find(|&(_, &v)| v >= n) {
            problems.push(MeshError::IndexOutOfRange {
                face,
                corner,
                index,
                n_vertices: n,
            });
            ok[face] = false;
        } else if let Some(vertex) = [(0, 1), (0, 2), (1, 2)]
            .iter()
            .find(|&&(a, b)| tri[a] == tri[b])
            .map(|&(a, _)| tri[a])
        {
            problems.push(MeshError::RepeatedVertex { face, vertex });
            ok[face] = false;
        }
    }
    let mut finite = vec![true; n];
    for (vertex, p) in positions.iter().enumerate() {
        if let Some(axis) = (0..3).find(|&a| !p[a].is_finite()) {
            problems.push(MeshError::NonFiniteCoordinate {
                vertex,
                axis,
                value: p[axis],
            });
            finite[vertex] = false;
        }
    }
    for (face, tri) in faces.iter().enumerate() {
        if !ok[face] || tri.iter().any(|&v| !finite[v]) {
            ok[face] = false;
            continue;
        }
        let [a, b, c] = tri.map(|v| positions[v]);
        let relative = relative_area(&a, &b, &c);
        if relative <= DEGENERATE_TOLERANCE {
            problems.push(MeshError::DegenerateFace {
                face,
                relative_area: relative,
            });
            ok[face] = false;
        } else if let Some(twice_area) = out_of_scale(positions, *tri) {
            problems.push(MeshError::OutOfScale { face, twice_area });
            ok[face] = false;
        }
    }
    let mut seen: HashMap<[usize; 3], usize> = HashMap::new();
    for (face, tri) in faces.iter().enumerate() {
        if !ok[face] {
            continue;
        }
        let mut vertices = *tri;
        vertices.sort_unstable();
        if let Some(&first) = seen.get(&vertices) {
            problems.push(MeshError::DuplicateFace {
                face,
                first,
                vertices,
            });
            ok[face] = false;
        } else {
            seen.insert(vertices, face);
        }
    }
    let mut edge_faces: HashMap<[usize; 2], Vec<usize>> = HashMap::new();
    for (face, tri) in faces.iter().enumerate().filter(|&(f, _)| ok[f]) {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edge_faces
                .entry([a.min(b), a.max(b)])
                .or_default()
                .push(face);
        }
    }
    let mut non_manifold: Vec<([usize; 2], Vec<usize>)> = edge_faces
        .into_iter()
        .filter(|(_, fs)| fs.len() > 2)
        .collect();
    non_manifold.sort();
    for (vertices, fs) in non_manifold {
        for &f in &fs {
            ok[f] = false;
        }
        problems.push(MeshError::NonManifoldEdge {
            vertices,
            faces: fs,
        });
    }
    let kept_faces: Vec<usize> = (0..faces.len()).filter(|&f| ok[f]).collect();
    let mesh = if kept_faces.is_empty() {
        None
    } else {
        let tris = kept_faces.iter().map(|&f| faces[f]).collect();
        match Mesh::new(positions.to_vec(), tris) {
            Ok(mesh) => Some(mesh),
            Err(e) => {
                problems.push(renumber(e, &kept_faces));
                None
            }
        }
    };
    Diagnosis {
        problems,
        kept_faces,
        mesh,
    }
}

/// An error about the kept faces, renumbered to the input's faces.
fn renumber(e: MeshError, kept: &[usize]) -> MeshError {
    let k = |f: usize| kept.get(f).copied().unwrap_or(f);
    match e {
        MeshError::NonOrientable {
            face,
            neighbor,
            edge,
        } => MeshError::NonOrientable {
            face: k(face),
            neighbor: k(neighbor),
            edge,
        },
        other => other,
    }
}
