//! Unknowns: which vertex coordinates (and edge angles) are free.
//!
//! Coordinates are numbered vertex-major, `c = 3·v + axis` (axis 0, 1, 2 = x, y, z), matching the
//! flat gradient layout; with an edge-director second fundamental form every edge `e` adds one
//! angle coordinate `c = 3·n_vertices + e` (rad) after all positions. Free coordinates get
//! consecutive dof indices in increasing coordinate order, so the dof numbering is monotone in
//! `(vertex, axis)` and every edge dof comes after every position dof. The assembler relies on
//! this to place whole vertex (and edge) blocks in the lower triangle.

use crate::error::EnergyError;
use thinshell_mesh::{EdgeId, VertexId};

/// Marker for a pinned coordinate in [`DofMap`]'s coordinate → dof table.
const PINNED: u32 = u32::MAX;

/// Map from coordinates (`3·v + axis`, then one angle per edge when present) to free degrees
/// of freedom; pinned coordinates (single coordinates, whole vertices, fixed edge angles) have
/// no dof.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DofMap {
    n_vertices: usize,
    n_edges: usize,
    /// Coordinate index → dof index or [`PINNED`].
    coord_to_dof: Vec<u32>,
    /// Dof index → coordinate index.
    dof_to_coord: Vec<usize>,
}

impl DofMap {
    /// All `3·n_vertices` coordinates free.
    pub fn all_free(n_vertices: usize) -> DofMap {
        let n = 3 * n_vertices;
        DofMap {
            n_vertices,
            n_edges: 0,
            coord_to_dof: (0..n as u32).collect(),
            dof_to_coord: (0..n).collect(),
        }
    }

    /// Pins the given `(vertex, axis)` coordinates (axis 0, 1, 2 = x, y, z); repeated entries
    /// are allowed. Errors with [`EnergyError::InvalidPin`] on a vertex `≥ n_vertices` or an
    /// axis `≥ 3`, and with [`EnergyError::TooLarge`] when `3·n_vertices` does not fit a `u32`.
    pub fn with_pinned(
        n_vertices: usize,
        pinned: impl IntoIterator<Item = (VertexId, usize)>,
    ) -> Result<DofMap, EnergyError> {
        let n = 3 * n_vertices;
        if n >= PINNED as usize {
            return Err(EnergyError::TooLarge {
                what: "coordinates",
                count: n,
            });
        }
        let mut is_pinned = vec![false; n];
        for (v, axis) in pinned {
            if v.idx() >= n_vertices || axis >= 3 {
                return Err(EnergyError::InvalidPin { vertex: v, axis });
            }
            is_pinned[3 * v.idx() + axis] = true;
        }
        let mut coord_to_dof = vec![PINNED; n];
        let mut dof_to_coord = Vec::with_capacity(n);
        for (c, _) in is_pinned.iter().enumerate().filter(|(_, p)| !**p) {
            coord_to_dof[c] = dof_to_coord.len() as u32;
            dof_to_coord.push(c);
        }
        Ok(DofMap {
            n_vertices,
            n_edges: 0,
            coord_to_dof,
            dof_to_coord,
        })
    }

    /// Adds one angle unknown per edge (`n_edges` edges, coordinates `3·n_vertices + e`), free
    /// except for the edges in `fixed` (e.g. clamped edges, whose angle stays 0; a solver also
    /// fixes [`crate::fitted_free_edges`], whose angles do not enter the energy). Replaces any
    /// edge unknowns the map had. Errors with [`EnergyError::InvalidEdge`] on an edge
    /// `≥ n_edges`.
    pub fn with_edges(
        mut self,
        n_edges: usize,
        fixed: impl IntoIterator<Item = EdgeId>,
    ) -> Result<DofMap, EnergyError> {
        let n_pos = 3 * self.n_vertices;
        let n = n_pos + n_edges;
        if n >= PINNED as usize {
            return Err(EnergyError::TooLarge {
                what: "coordinates",
                count: n,
            });
        }
        let mut is_fixed = vec![false; n_edges];
        for e in fixed {
            if e.idx() >= n_edges {
                return Err(EnergyError::InvalidEdge { edge: e, n_edges });
            }
            is_fixed[e.idx()] = true;
        }
        self.coord_to_dof.truncate(n_pos);
        self.dof_to_coord.retain(|&c| c < n_pos);
        self.coord_to_dof.resize(n, PINNED);
        for (e, _) in is_fixed.iter().enumerate().filter(|(_, f)| !**f) {
            self.coord_to_dof[n_pos + e] = self.dof_to_coord.len() as u32;
            self.dof_to_coord.push(n_pos + e);
        }
        self.n_edges = n_edges;
        Ok(self)
    }

    /// Pins all three coordinates of each given vertex (see [`DofMap::with_pinned`]).
    pub fn with_pinned_vertices(
        n_vertices: usize,
        vertices: impl IntoIterator<Item = VertexId>,
    ) -> Result<DofMap, EnergyError> {
        Self::with_pinned(
            n_vertices,
            vertices
                .into_iter()
                .flat_map(|v| (0..3).map(move |a| (v, a))),
        )
    }

    /// Number of free dofs.
    pub fn n_free(&self) -> usize {
        self.dof_to_coord.len()
    }

    /// Number of vertices the map was built for.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// Number of edge angle coordinates (0 without edge unknowns).
    pub fn n_edges(&self) -> usize {
        self.n_edges
    }

    /// Length of a full coordinate vector: `3·n_vertices + n_edges`.
    pub fn n_coordinates(&self) -> usize {
        3 * self.n_vertices + self.n_edges
    }

    /// Number of free position dofs (they come first in the dof numbering).
    pub fn n_free_positions(&self) -> usize {
        self.dof_to_coord
            .partition_point(|&c| c < 3 * self.n_vertices)
    }

    /// Dof of the angle of edge `e`, `None` if fixed, out of range or without edge unknowns.
    pub fn edge_dof(&self, e: EdgeId) -> Option<usize> {
        if e.idx() >= self.n_edges {
            return None;
        }
        self.coordinate_dof(3 * self.n_vertices + e.idx())
    }

    /// Dof of coordinate `axis` of assembly node `node`: nodes `0..n_vertices` are vertices,
    /// node `n_vertices + e` is edge `e`, whose only coordinate is axis 0.
    pub(crate) fn node_dof(&self, node: usize, axis: usize) -> Option<usize> {
        if node < self.n_vertices {
            self.dof(VertexId::new(node), axis)
        } else if axis == 0 {
            self.edge_dof(EdgeId::new(node - self.n_vertices))
        } else {
            None
        }
    }

    /// Dof of coordinate `axis` of vertex `v`, `None` if pinned or out of range.
    pub fn dof(&self, v: VertexId, axis: usize) -> Option<usize> {
        if axis >= 3 || v.idx() >= self.n_vertices {
            return None;
        }
        self.coordinate_dof(3 * v.idx() + axis)
    }

    /// Dof of flat coordinate index `c = 3·v + axis`, `None` if pinned or out of range.
    pub fn coordinate_dof(&self, c: usize) -> Option<usize> {
        match self.coord_to_dof.get(c) {
            Some(&d) if d != PINNED => Some(d as usize),
            _ => None,
        }
    }

    /// Whether coordinate `axis` of vertex `v` is pinned (`false` when out of range).
    pub fn is_pinned(&self, v: VertexId, axis: usize) -> bool {
        axis < 3 && v.idx() < self.n_vertices && self.dof(v, axis).is_none()
    }

    /// Dof index → flat coordinate index (`3·v + axis`, or `3·n_vertices + e` for an edge
    /// angle), increasing.
    pub fn free_coordinates(&self) -> &[usize] {
        &self.dof_to_coord
    }

    /// Gathers the free entries of a full coordinate vector (length [`DofMap::n_coordinates`]) into
    /// `out` (length [`DofMap::n_free`]).
    pub fn restrict(&self, full: &[f64], out: &mut [f64]) -> Result<(), EnergyError> {
        check_len("full coordinate vector", self.n_coordinates(), full.len())?;
        check_len("free dof vector", self.n_free(), out.len())?;
        for (o, &c) in out.iter_mut().zip(&self.dof_to_coord) {
            *o = full[c];
        }
        Ok(())
    }
}

/// `Err(LengthMismatch)` unless `got == expected`.
pub(crate) fn check_len(
    what: &'static str,
    expected: usize,
    got: usize,
) -> Result<(), EnergyError> {
    if got == expected {
        Ok(())
    } else {
        Err(EnergyError::LengthMismatch {
            what,
            expected,
            got,
        })
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn pinned_coordinates_are_skipped_and_numbering_is_monotone() {
        let d =
            DofMap::with_pinned(3, [(VertexId(1), 2), (VertexId(0), 0), (VertexId(1), 2)]).unwrap();
        assert_eq!(d.n_free(), 7);
        assert_eq!(d.free_coordinates(), &[1, 2, 3, 4, 6, 7, 8]);
        assert_eq!(d.dof(VertexId(0), 0), None);
        assert_eq!(d.dof(VertexId(0), 1), Some(0));
        assert_eq!(d.dof(VertexId(1), 2), None);
        assert_eq!(d.dof(VertexId(2), 0), Some(4));
        assert!(d.is_pinned(VertexId(1), 2));
        assert!(!d.is_pinned(VertexId(2), 2));
        assert_eq!(d.dof(VertexId(3), 0), None);
        assert_eq!(d.dof(VertexId(0), 3), None);
        for (dof, &c) in d.free_coordinates().iter().enumerate() {
            assert_eq!(d.coordinate_dof(c), Some(dof));
        }
        let full: Vec<f64> = (0..9).map(f64::from).collect();
        let mut free = vec![0.0; 7];
        d.restrict(&full, &mut free).unwrap();
        assert_eq!(free, vec![1.0, 2.0, 3.0, 4.0, 6.0, 7.0, 8.0]);
        assert!(d.restrict(&full[..8], &mut free).is_err());
    }

    #[test]
    fn all_free_and_invalid_pins() {
        let d = DofMap::all_free(2);
        assert_eq!(d.n_free(), 6);
        assert_eq!(d, DofMap::with_pinned(2, []).unwrap());
        assert!(matches!(
            DofMap::with_pinned(2, [(VertexId(2), 0)]),
            Err(EnergyError::InvalidPin {
                vertex: VertexId(2),
                axis: 0
            })
        ));
        assert!(matches!(
            DofMap::with_pinned(2, [(VertexId(0), 3)]),
            Err(EnergyError::InvalidPin { axis: 3, .. })
        ));
        let v = DofMap::with_pinned_vertices(2, [VertexId(1)]).unwrap();
        assert_eq!(v.free_coordinates(), &[0, 1, 2]);
    }
}
