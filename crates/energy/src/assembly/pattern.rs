//! Construction of the Hessian sparsity pattern and of the gather maps (done once).
//!
//! Per-face buffers: the gradient buffer holds `3·n_slots` f64 per face (slot-major, x y z);
//! the Hessian buffer one block per unordered slot pair `s1 ≥ s2`, in pair order
//! `p = s1(s1+1)/2 + s2`, each at its real size `d(s1) × d(s2)`, where a slot's dimension
//! `d` is 3 for a vertex and 1 for an edge angle (whose node has only axis 0). Block `p`
//! starts at [`Pattern::pair_offset`]`[p]` within the face's `hess_stride` f64: 9 per
//! vertex–vertex pair (the mid-edge average's 21 pairs give 189), 3 per vertex–edge pair
//! and 1 per edge–edge pair (the director forms' 45 pairs give 249 instead of 405 with
//! padded 3×3 blocks; the padding was only written and skipped, but it cost memory traffic).
//! Blocks are column-major like nalgebra (so that vertex blocks are copied in runs of
//! three): `B[d(s1)·c + a] = H_local[(s1, a), (s2, c)]`. Global block entries are numbered
//! row-major, `e = 3a + c`; [`Pattern::nz_src_offset`] and [`Pattern::block_dims`] say
//! where such an entry sits in a face block read untransposed or transposed.
//!
//! A face's slot pair `(s1, s2)` over vertices `(v1, v2)` contributes to the global vertex
//! block `(max, min)` of the lower triangle — transposed when `v1 < v2`. With vertex-major,
//! monotone dof numbering ([`DofMap`]) a block with row vertex > column vertex lies entirely
//! below the diagonal; a diagonal block keeps its lower entries only.
//!
//! Edge-director unknowns ride on the same machinery: with `edge_slots`, every face has three
//! more slots, one per edge, and edge `e` is *node* `n_vertices + e`, a node whose only
//! coordinate is axis 0 (axes 1 and 2 have no dof, like pinned coordinates, so their entries
//! are never gathered and are not stored per face). Edge nodes come after all vertices and
//! their dofs after all position dofs, so the lower-triangle argument above holds unchanged;
//! it also means a mixed global block always has the edge as row node and the vertex as
//! column node, so the shape of every face block feeding a global block (3×3, 1×3 — a
//! vertex–edge pair always has the edge slot as `s1`, edge slots coming last — or 1×1)
//! follows from the global block's two nodes alone.

use crate::dofs::DofMap;
use crate::error::EnergyError;
use crate::stencil_table::Stencils;
use faer::sparse::SymbolicSparseColMat;

/// Flag bit in a contribution: read the face block transposed.
pub(super) const TRANSPOSED: u32 = 1 << 31;
/// Marker for "no value" (pinned coordinate or upper triangle) in [`Pattern::block_offsets`].
pub(super) const NONE: u32 = u32::MAX;

/// Number of unordered slot pairs for `n` slots.
pub(super) const fn n_pairs(n: usize) -> usize {
    n * (n + 1) / 2
}

/// Pair index of slots `s1 ≥ s2`.
pub(super) const fn pair(s1: usize, s2: usize) -> usize {
    s1 * (s1 + 1) / 2 + s2
}

/// Offset of entry (row axis `a`, column axis `c`) in a column-major face block with `rows`
/// rows (the row slot's dimension).
const fn block_index(rows: usize, a: usize, c: usize) -> usize {
    rows * c + a
}

/// Everything the assembler precomputes from (mesh topology, dofs, stencil size).
pub(super) struct Pattern {
    /// Slots per face: vertex slots, then 3 edge slots when edge unknowns are present.
    pub slots: usize,
    /// Number of vertex nodes (edge node e is `n_vertices + e`).
    pub n_vertices: usize,
    /// Lower-triangular CSC structure over the free dofs.
    pub symbolic: SymbolicSparseColMat<usize>,
    /// Position of (d, d) in the value array, per free dof.
    pub diagonal: Vec<usize>,
    /// f64 per face in the gradient buffer.
    pub grad_stride: usize,
    /// f64 per face in the Hessian buffer: the sum of the pair block sizes.
    pub hess_stride: usize,
    /// Per slot pair index ([`pair`]): start of its block within a face's Hessian buffer.
    /// Blocks have their real size (9, 3 or 1 f64), so this is the one place that knows the
    /// layout; the face copy and [`Pattern::block_src`] both take their offsets from here.
    pub pair_offset: Vec<usize>,
    /// Per node (CSR): gradient-buffer offsets of the face slots that touch it.
    pub grad_ptr: Vec<usize>,
    /// See `grad_ptr`.
    pub grad_src: Vec<u32>,
    /// Per global vertex block (CSR): Hessian-buffer offsets of face blocks, with [`TRANSPOSED`].
    pub block_ptr: Vec<usize>,
    /// See `block_ptr`.
    pub block_src: Vec<u32>,
    /// Value-array position of each of the 9 entries `3a + c` of a global block, or [`NONE`].
    pub block_offsets: Vec<[u32; 9]>,
    /// Per global block: the dimensions `[rows, columns]` of its row and column nodes (3 for a
    /// vertex, 1 for an edge), i.e. the shape of its face blocks read untransposed.
    pub block_dims: Vec<[u8; 2]>,
    /// Per nonzero: its global block.
    pub nz_block: Vec<u32>,
    /// Per nonzero: where its entry sits in a face block of its global block, `[read
    /// untransposed, read transposed]` (so the per-nonzero gather needs no shape logic).
    pub nz_src_offset: Vec<[u8; 2]>,
    /// Per face: global block (with [`TRANSPOSED`]) of the slot pairs among its three vertices,
    /// in pair order (0,0), (1,0), (1,1), (2,0), (2,1), (2,2).
    pub face_blocks: Vec<[u32; 6]>,
}

impl Pattern {
    /// Builds the pattern for stencils with `n_slots` vertex slots (3: face only, 6: with
    /// flaps) and, with `edge_slots`, the three edge-angle slots of every face. With
    /// `fit_vertices` (or `edge_slots`) the outer vertex of a free-edge fit counts as present,
    /// as the edge-director forms read it.
    pub fn new(
        stencils: &Stencils,
        dofs: &DofMap,
        n_slots: usize,
        edge_slots: bool,
        fit_vertices: bool,
    ) -> Result<Pattern, EnergyError> {
        let n_faces = stencils.n_faces();
        let n_vertices = dofs.n_vertices();
        let n_nodes = n_vertices + if edge_slots { dofs.n_edges() } else { 0 };
        let slots = n_slots + if edge_slots { 3 } else { 0 };
        // Coordinates per slot: an edge slot's node has axis 0 only.
        let dim = |s: usize| if s < n_slots { 3 } else { 1 };
        let mut pair_offset = vec![0; n_pairs(slots)];
        let mut hess_stride = 0;
        for s1 in 0..slots {
            for s2 in 0..=s1 {
                pair_offset[pair(s1, s2)] = hess_stride;
                hess_stride += dim(s1) * dim(s2);
            }
        }
        let grad_stride = 3 * slots;
        let node_dim = |v: u32| if (v as usize) < n_vertices { 3 } else { 1 };
        let node = |f: usize, s: usize| -> u32 {
            if s < n_slots {
                stencils.vertices(f)[s].0
            } else {
                (n_vertices + stencils.edges(f)[s - n_slots].idx()) as u32
            }
        };
        let present = |f: usize, s: usize| {
            s >= n_slots
                || if edge_slots || fit_vertices {
                    stencils.slot_present_director(f, s)
                } else {
                    stencils.slot_present(f, s)
                }
        };
        let too_large = |what, count| EnergyError::TooLarge { what, count };
        if n_faces.saturating_mul(hess_stride) >= TRANSPOSED as usize {
            return Err(too_large(
                "per-face buffer entries",
                n_faces.saturating_mul(hess_stride),
            ));
        }

        // Face-block contributions keyed by global block (column vertex, row vertex); the
        // stable sort keeps face order inside a block, which fixes the summation order.
        let mut contrib: Vec<(u32, u32, u32)> =
            Vec::with_capacity(n_faces * n_pairs(slots) + n_nodes);
        let mut grad: Vec<(u32, u32)> = Vec::with_capacity(n_faces * slots);
        for f in 0..n_faces {
            for s1 in 0..slots {
                if !present(f, s1) {
                    continue;
                }
                let v1 = node(f, s1);
                grad.push((v1, (f * grad_stride + 3 * s1) as u32));
                for s2 in 0..=s1 {
                    if !present(f, s2) {
                        continue;
                    }
                    let v2 = node(f, s2);
                    let src = (f * hess_stride + pair_offset[pair(s1, s2)]) as u32;
                    let (r, c) = (v1.max(v2), v1.min(v2));
                    if v1 == v2 && s1 != s2 {
                        // The same vertex in two slots (e.g. a tetrahedron's flaps): B + Bᵀ.
                        contrib.push((c, r, src));
                        contrib.push((c, r, src | TRANSPOSED));
                    } else {
                        contrib.push((c, r, if v1 < v2 { src | TRANSPOSED } else { src }));
                    }
                }
            }
        }
        // Every node gets its diagonal block (every diagonal entry present), sorted first
        // within its column and contributing nothing.
        contrib.extend((0..n_nodes as u32).map(|v| (v, v, NONE)));
        contrib.sort_by_key(|&(c, r, src)| (c, r, src != NONE));
        grad.sort_by_key(|&(v, _)| v);

        let mut block_ptr = vec![0];
        let mut block_src = Vec::with_capacity(contrib.len());
        let mut block_vertices: Vec<(u32, u32)> = Vec::new();
        for &(c, r, src) in &contrib {
            if block_vertices.last() != Some(&(c, r)) {
                if !block_vertices.is_empty() {
                    block_ptr.push(block_src.len());
                }
                block_vertices.push((c, r));
            }
            if src != NONE {
                block_src.push(src);
            }
        }
        block_ptr.push(block_src.len());

        // CSC over free dofs, column by column: the blocks of column vertex c are sorted by
        // row vertex, and dofs are monotone in (vertex, axis), so rows come out sorted.
        let n_free = dofs.n_free();
        let mut col_ptr = Vec::with_capacity(n_free + 1);
        let mut row_idx: Vec<usize> = Vec::new();
        let mut block_offsets = vec![[NONE; 9]; block_vertices.len()];
        let mut diagonal = vec![0; n_free];
        let mut first = 0;
        while first < block_vertices.len() {
            let c = block_vertices[first].0;
            let last = first + block_vertices[first..].partition_point(|&(cc, _)| cc == c);
            for axis_c in 0..3 {
                let Some(col) = dofs.node_dof(c as usize, axis_c) else {
                    continue;
                };
                debug_assert_eq!(col, col_ptr.len());
                col_ptr.push(row_idx.len());
                for (k, &(_, r)) in block_vertices[first..last].iter().enumerate() {
                    for axis_r in 0..3 {
                        if r == c && axis_r < axis_c {
                            continue;
                        }
                        let Some(row) = dofs.node_dof(r as usize, axis_r) else {
                            continue;
                        };
                        if row == col {
                            diagonal[col] = row_idx.len();
                        }
                        let pos = u32::try_from(row_idx.len())
                            .ok()
                            .filter(|&p| p != NONE)
                            .ok_or(too_large("Hessian nonzeros", row_idx.len()))?;
                        block_offsets[first + k][3 * axis_r + axis_c] = pos;
                        row_idx.push(row);
                    }
                }
            }
            first = last;
        }
        col_ptr.push(row_idx.len());
        let nnz = row_idx.len();
        let symbolic = SymbolicSparseColMat::new_checked(n_free, n_free, col_ptr, None, row_idx);

        // Untransposed, a face block of global block (row r, column c) is d(r) × d(c) and
        // holds entry (a, c) at d(r)·c + a; transposed it is d(c) × d(r) with the entry at
        // d(c)·a + c. Entries outside the node dimensions have no dof (NONE) and never occur.
        let block_dims: Vec<[u8; 2]> = block_vertices
            .iter()
            .map(|&(c, r)| [node_dim(r), node_dim(c)])
            .collect();
        let mut nz_block = vec![0u32; nnz];
        let mut nz_src_offset = vec![[0u8; 2]; nnz];
        for (b, offs) in block_offsets.iter().enumerate() {
            let [rows, cols] = block_dims[b].map(usize::from);
            for (e, &o) in offs.iter().enumerate() {
                if o != NONE {
                    let (a, c) = (e / 3, e % 3);
                    debug_assert!(a < rows && c < cols);
                    nz_block[o as usize] = b as u32;
                    nz_src_offset[o as usize] =
                        [block_index(rows, a, c) as u8, block_index(cols, c, a) as u8];
                }
            }
        }

        let mut grad_ptr = vec![0; n_nodes + 1];
        for &(v, _) in &grad {
            grad_ptr[v as usize + 1] += 1;
        }
        for v in 0..n_nodes {
            grad_ptr[v + 1] += grad_ptr[v];
        }
        let grad_src = grad.into_iter().map(|(_, s)| s).collect();

        let block_of = |c: u32, r: u32| {
            // Blocks are sorted by (column, row); every face pair's block exists.
            block_vertices.partition_point(|&k| k < (c, r)) as u32
        };
        let face_blocks = (0..n_faces)
            .map(|f| {
                let v = stencils.vertices(f);
                let mut out = [0u32; 6];
                for s1 in 0..3 {
                    for s2 in 0..=s1 {
                        let (v1, v2) = (v[s1].0, v[s2].0);
                        let b = block_of(v1.min(v2), v1.max(v2));
                        out[pair(s1, s2)] = if v1 < v2 { b | TRANSPOSED } else { b };
                    }
                }
                out
            })
            .collect();

        Ok(Pattern {
            slots,
            n_vertices,
            symbolic,
            diagonal,
            grad_stride,
            hess_stride,
            pair_offset,
            grad_ptr,
            grad_src,
            block_ptr,
            block_src,
            block_offsets,
            block_dims,
            nz_block,
            nz_src_offset,
            face_blocks,
        })
    }
}
