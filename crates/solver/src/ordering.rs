//! Fill-reducing orderings for the sparse Cholesky factorisation.
//!
//! faer ships approximate minimum degree (AMD) but no nested dissection. The shell Hessian
//! couples two rings of vertices (the bending stencil), so its factor fills in heavily and the
//! ordering decides the cost.
//!
//! - [`metis_nested_dissection`] (the default, [`Ordering::Metis`]): nested dissection whose
//!   bisections are METIS's multilevel partitioner on the compressed graph (one node per
//!   vertex or edge angle), the separator a minimum-weight vertex cover of the cut edges.
//! - [`nested_dissection`]: a geometric nested dissection: split the dofs at the median along
//!   an axis of their bounding box, take the dofs of the smaller side that touch the other
//!   side as the vertex separator, number both halves recursively and the separator last.
//!   Without coordinates the separator is the median level of a breadth-first search from a
//!   pseudo-peripheral dof (graph-based nested dissection).
//!
//! In both, leaves (parts of at most `leaf_size` dofs) are ordered by AMD on their induced
//! subgraph, as METIS does with minimum degree.
//!
//! Predicted factorisation flops ([`factor_flops`](crate::linear::factor_flops)) on the
//! Hessian of the shrinking-sphere benchmark (`examples/ordering_flops.rs`):
//!
//! | faces | form | AMD | ND geometric | ND graph | METIS ND |
//! |---:|---|---:|---:|---:|---:|
//! | 1 280 | mid-edge average | 9.20e7 | 8.34e7 | 8.03e7 | 7.46e7 |
//! | 20 480 | mid-edge average | 9.36e9 | 8.33e9 | 7.69e9 | 7.03e9 |
//! | 81 920 | mid-edge average | 1.00e11 | 7.34e10 | 6.33e10 | 6.31e10 |
//! | 1 280 | edge director | 3.05e8 | 2.84e8 | 4.76e8 | 1.71e8 |
//! | 20 480 | edge director | 4.36e10 | 2.64e10 | 4.63e10 | 1.53e10 |
//!
//! (CHOLMOD's METIS node nested dissection: 6.4e9 at 20 480 faces and 5.65e10 at 81 920, mid-edge
//! average.)

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::amd;

use crate::SolverError;

/// Which fill-reducing ordering the Cholesky factorisation uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Ordering {
    /// faer's approximate minimum degree.
    Amd,
    /// Nested dissection ([`nested_dissection`]): geometric when the objective provides dof
    /// coordinates, graph-based otherwise.
    NestedDissection,
    /// Nested dissection with METIS's multilevel bisection on the compressed graph
    /// ([`metis_nested_dissection`]; deterministic: fixed seed). The default: on the shell
    /// sphere's Hessian it needs the fewest flops of the four on every size measured (1 280 to
    /// 81 920 faces), 16 % fewer than geometric nested dissection at 20 480 faces and 1.7×
    /// fewer with edge directors (module docs); on a flat 101 × 101 sheet geometric nested
    /// dissection is 5 % better (3.37e9 vs 3.55e9 flops, `ordering` bench; `Auto` finds it).
    #[default]
    Metis,
    /// Analyse with AMD, METIS, graph-based and (given coordinates) geometric nested
    /// dissection and keep the one with the fewest predicted flops (four symbolic analyses,
    /// once per pattern; a METIS failure just drops that candidate).
    Auto,
}

/// Dofs per leaf below which the dissection stops (leaves are then ordered by AMD).
pub const DEFAULT_LEAF_SIZE: usize = 64;

/// Dofs per leaf of [`metis_nested_dissection`] as used by [`Ordering::Metis`].
pub const METIS_LEAF_SIZE: usize = 64;

/// Symmetric adjacency (CSR, no self loops) of a pattern holding the lower triangle (entries
/// of the upper triangle, if any, are mirrored too).
#[derive(Clone, Debug)]
struct Graph {
    ptr: Vec<usize>,
    adj: Vec<usize>,
}

impl Graph {
    fn from_pattern(pattern: SymbolicSparseColMatRef<'_, usize>) -> Graph {
        let n = pattern.ncols();
        let mut degree = vec![0usize; n];
        for j in 0..n {
            for &i in pattern.row_idx_of_col_raw(j) {
                if i != j {
                    degree[i] += 1;
                    degree[j] += 1;
                }
            }
        }
        let mut ptr = Vec::with_capacity(n + 1);
        ptr.push(0);
        for d in &degree {
            let last = ptr[ptr.len() - 1];
            ptr.push(last + d);
        }
        let mut fill = ptr[..n].to_vec();
        let mut adj = vec![0usize; ptr[n]];
        for j in 0..n {
            for &i in pattern.row_idx_of_col_raw(j) {
                if i != j {
                    adj[fill[i]] = j;
                    fill[i] += 1;
                    adj[fill[j]] = i;
                    fill[j] += 1;
                }
            }
        }
        Graph { ptr, adj }
    }

    fn neighbors(&self, v: usize) -> &[usize] {
        &self.adj[self.ptr[v]..self.ptr[v + 1]]
    }
}

/// Nested-dissection ordering of a symmetric pattern.
///
/// `pattern`: square, lower triangle (as handed to the Cholesky factorisation). `coordinates`:
/// optional per-dof positions (length `n`), used for geometric bisection; without them the
/// bisection uses breadth-first distances. `leaf_size`: parts with at most this many dofs are
/// not split further but ordered by AMD (values below 2 are treated as 2).
///
/// Returns the permutation as faer's *forward* array: `perm[new] = old` (the separator of the
/// whole graph comes last).
pub fn nested_dissection(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    coordinates: Option<&[[f64; 3]]>,
    leaf_size: usize,
) -> Result<Vec<usize>, SolverError> {
    let n = pattern.ncols();
    if pattern.nrows() != n {
        return Err(SolverError::DimensionMismatch {
            what: "Hessian pattern rows",
            expected: n,
            found: pattern.nrows(),
        });
    }
    if let Some(c) = coordinates {
        if c.len() != n {
            return Err(SolverError::DimensionMismatch {
                what: "dof coordinates",
                expected: n,
                found: c.len(),
            });
        }
        if let Some(dof) = c.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(SolverError::NonFiniteCoordinate { dof });
        }
    }
    let leaf_size = leaf_size.max(2);
    let graph = Graph::from_pattern(pattern);
    let mut dissector = Dissector {
        graph: &graph,
        coordinates,
        side: vec![0; n],
        local: vec![0; n],
        dist: vec![usize::MAX; n],
        queue: Vec::new(),
        order: Vec::with_capacity(n),
    };

    // Explicit stack instead of recursion: children are pushed after their separator so that
    // the first half, then the second half, then the separator get numbered.
    enum Task {
        Dissect(Vec<usize>),
        Emit(Vec<usize>),
    }
    let mut stack = vec![Task::Dissect((0..n).collect())];
    while let Some(task) = stack.pop() {
        match task {
            Task::Emit(set) => dissector.order.extend_from_slice(&set),
            Task::Dissect(set) => {
                if set.len() <= leaf_size {
                    dissector.emit_leaf(&set);
                    continue;
                }
                match dissector.bisect(set) {
                    Split::Leaf(set) => dissector.emit_leaf(&set),
                    Split::Parts { a, b, separator } => {
                        stack.push(Task::Emit(separator));
                        stack.push(Task::Dissect(b));
                        stack.push(Task::Dissect(a));
                    }
                }
            }
        }
    }
    Ok(dissector.order)
}

/// Seed of METIS's randomised coarsening: fixed, so the same pattern always gets the same
/// permutation. (Any seed gives orderings of the same quality; with seed 17 the Newton solve of
/// test `effects::a_prescribed_stimulus_builds_no_diffusion_solver` failed to converge, a
/// round-off sensitivity of that solve which seeds 1–5 and the other orderings do not hit.)
const METIS_SEED: metis::Idx = 1;

/// Serialises METIS calls: METIS seeds and draws from one process-wide random state (GKlib's
/// static generator), so two threads bisecting at once (concurrent tests, several
/// simulations on threads) interleave their draws and get different, run-dependent
/// permutations, hence different round-off. One call at a time keeps every permutation a
/// function of the pattern alone.
static METIS_LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Nested-dissection ordering of a symmetric pattern with METIS's multilevel bisection.
///
/// The graph is first compressed: dofs with identical closed adjacency (the three coordinates
/// of a vertex) become one node weighted by their count, which makes the partitioning about
/// three times smaller and keeps a vertex's dofs together. Each part is bisected by METIS
/// (`METIS_PartGraphRecursive` into two parts, fixed seed), the cut edges are turned into the
/// vertex separator of least dof weight (a minimum weighted vertex cover of the bipartite cut
/// graph, by max flow), and both halves are ordered recursively before the separator. Parts
/// of at most `leaf_size` dofs are ordered by AMD on their induced subgraph.
///
/// `pattern`: square, lower triangle. Returns `perm[new] = old` like [`nested_dissection`].
/// Errors: a non-square pattern, a graph too large for METIS's 32-bit indices, or a METIS
/// failure ([`SolverError::Linear`]).
pub fn metis_nested_dissection(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    leaf_size: usize,
) -> Result<Vec<usize>, SolverError> {
    metis_dissection_with_split(pattern, leaf_size).map(|(perm, _)| perm)
}

/// [`metis_nested_dissection`] and, when the whole graph was bisected, the dof counts
/// `[a, b, s]` of its two halves and top separator: the permutation numbers the first half's
/// `a` dofs, then the second half's `b`, then the `s` separator dofs, and no entry of the
/// pattern couples the two halves.
pub(crate) fn metis_dissection_with_split(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    leaf_size: usize,
) -> Result<(Vec<usize>, Option<[usize; 3]>), SolverError> {
    let n = pattern.ncols();
    if pattern.nrows() != n {
        return Err(SolverError::DimensionMismatch {
            what: "Hessian pattern rows",
            expected: n,
            found: pattern.nrows(),
        });
    }
    let leaf_size = leaf_size.max(2);
    let graph = Graph::from_pattern(pattern);
    if metis::Idx::try_from(graph.adj.len().max(n)).is_err() {
        return Err(SolverError::Linear(format!(
            "METIS ordering: {n} dofs with {} adjacencies exceed its 32-bit indices",
            graph.adj.len()
        )));
    }
    let compressed = Compressed::new(&graph);
    let m = compressed.weight.len();
    let mut dissector = Dissector {
        graph: &graph,
        coordinates: None,
        side: vec![0; n],
        local: vec![0; n],
        dist: vec![usize::MAX; n],
        queue: Vec::new(),
        order: Vec::with_capacity(n),
    };
    let mut bisector = MetisBisector {
        c: &compressed,
        local: vec![usize::MAX; m],
        part: vec![0; m],
    };
    let expand = |nodes: &[usize]| -> Vec<usize> {
        let mut dofs: Vec<usize> = nodes
            .iter()
            .flat_map(|&v| compressed.members_of(v).iter().copied())
            .collect();
        dofs.sort_unstable();
        dofs
    };
    enum Task {
        Dissect(Vec<usize>),
        Emit(Vec<usize>),
    }
    let mut stack = vec![Task::Dissect((0..m).collect())];
    let weight_of =
        |nodes: &[usize]| -> usize { nodes.iter().map(|&v| compressed.weight[v] as usize).sum() };
    let mut top_split = None;
    while let Some(task) = stack.pop() {
        match task {
            Task::Emit(nodes) => dissector.order.extend(expand(&nodes)),
            Task::Dissect(nodes) => {
                let dofs = weight_of(&nodes);
                let split = if dofs <= leaf_size {
                    None
                } else {
                    bisector.bisect(&nodes)?
                };
                match split {
                    None => dissector.emit_leaf(&expand(&nodes)),
                    Some((a, b, separator)) => {
                        if top_split.is_none() && dofs == n {
                            top_split = Some([weight_of(&a), weight_of(&b), weight_of(&separator)]);
                        }
                        stack.push(Task::Emit(separator));
                        stack.push(Task::Dissect(b));
                        stack.push(Task::Dissect(a));
                    }
                }
            }
        }
    }
    Ok((dissector.order, top_split))
}

/// The dof graph with indistinguishable dofs (identical closed adjacency) merged into one
/// weighted node.
struct Compressed {
    graph: Graph,
    /// Dofs per node.
    weight: Vec<metis::Idx>,
    /// Dofs of node `v`: `members[members_ptr[v]..members_ptr[v + 1]]`, increasing.
    members_ptr: Vec<usize>,
    members: Vec<usize>,
}

impl Compressed {
    fn new(g: &Graph) -> Compressed {
        let n = g.ptr.len() - 1;
        // Sorted closed neighbourhoods and a hash of each, to compare candidates cheaply.
        let mut closed = Vec::with_capacity(g.adj.len() + n);
        let mut closed_ptr = Vec::with_capacity(n + 1);
        closed_ptr.push(0);
        let mut hash = Vec::with_capacity(n);
        for v in 0..n {
            let start = closed.len();
            closed.extend_from_slice(g.neighbors(v));
            closed.push(v);
            closed[start..].sort_unstable();
            dedup_tail(&mut closed, start);
            let h = closed[start..]
                .iter()
                .fold(0xcbf2_9ce4_8422_2325u64, |h, &u| {
                    (h ^ u as u64).wrapping_mul(0x0000_0100_0000_01b3)
                });
            hash.push(h);
            closed_ptr.push(closed.len());
        }
        let closed_of = |v: usize| &closed[closed_ptr[v]..closed_ptr[v + 1]];
        // Dofs with equal closed neighbourhoods are adjacent, so each dof only needs to be
        // compared with the groups of its earlier neighbours (by their first member).
        let mut group = vec![usize::MAX; n];
        let mut reps: Vec<usize> = Vec::new();
        for v in 0..n {
            for &u in g.neighbors(v) {
                if u < v {
                    let r = reps[group[u]];
                    if hash[r] == hash[v] && closed_of(r) == closed_of(v) {
                        group[v] = group[u];
                        break;
                    }
                }
            }
            if group[v] == usize::MAX {
                group[v] = reps.len();
                reps.push(v);
            }
        }
        let m = reps.len();
        let mut weight = vec![0 as metis::Idx; m];
        for &gid in &group {
            weight[gid] += 1;
        }
        let mut members_ptr = Vec::with_capacity(m + 1);
        members_ptr.push(0);
        for &w in &weight {
            let last = members_ptr[members_ptr.len() - 1];
            members_ptr.push(last + w as usize);
        }
        let mut fill = members_ptr[..m].to_vec();
        let mut members = vec![0; n];
        for (v, &gid) in group.iter().enumerate() {
            members[fill[gid]] = v;
            fill[gid] += 1;
        }
        // Node adjacency from each representative's neighbours (all members share them).
        let mut ptr = Vec::with_capacity(m + 1);
        ptr.push(0);
        let mut adj = Vec::new();
        for (gid, &r) in reps.iter().enumerate() {
            let start = adj.len();
            adj.extend(
                g.neighbors(r)
                    .iter()
                    .map(|&u| group[u])
                    .filter(|&h| h != gid),
            );
            adj[start..].sort_unstable();
            dedup_tail(&mut adj, start);
            ptr.push(adj.len());
        }
        Compressed {
            graph: Graph { ptr, adj },
            weight,
            members_ptr,
            members,
        }
    }

    fn members_of(&self, v: usize) -> &[usize] {
        &self.members[self.members_ptr[v]..self.members_ptr[v + 1]]
    }
}

/// Removes repeated values from the sorted `v[start..]`.
fn dedup_tail(v: &mut Vec<usize>, start: usize) {
    let mut kept = start;
    for k in start..v.len() {
        if k == start || v[k] != v[kept - 1] {
            v[kept] = v[k];
            kept += 1;
        }
    }
    v.truncate(kept);
}

/// One METIS bisection of a set of compressed nodes and its vertex separator.
struct MetisBisector<'a> {
    c: &'a Compressed,
    /// Index of a node in the set being bisected (`usize::MAX` outside it).
    local: Vec<usize>,
    /// Side of each node of the set (0, 1), by local index.
    part: Vec<metis::Idx>,
}

impl MetisBisector<'_> {
    /// Splits `nodes` into two halves and a separator, or `None` if the set cannot be split
    /// (no edges, or METIS put everything on one side).
    #[allow(clippy::type_complexity)]
    fn bisect(
        &mut self,
        nodes: &[usize],
    ) -> Result<Option<(Vec<usize>, Vec<usize>, Vec<usize>)>, SolverError> {
        let k = nodes.len();
        if k < 2 {
            return Ok(None);
        }
        for (l, &v) in nodes.iter().enumerate() {
            self.local[v] = l;
        }
        let g = &self.c.graph;
        let mut xadj: Vec<metis::Idx> = Vec::with_capacity(k + 1);
        xadj.push(0);
        let mut adjncy: Vec<metis::Idx> = Vec::new();
        let mut vwgt: Vec<metis::Idx> = Vec::with_capacity(k);
        for &v in nodes {
            adjncy.extend(
                g.neighbors(v)
                    .iter()
                    .filter(|&&u| self.local[u] != usize::MAX)
                    .map(|&u| self.local[u] as metis::Idx),
            );
            xadj.push(adjncy.len() as metis::Idx);
            vwgt.push(self.c.weight[v]);
        }
        let result = if adjncy.is_empty() {
            Ok(None)
        } else {
            self.part.clear();
            self.part.resize(k, 0);
            metis::Graph::new(1, 2, &xadj, &adjncy)
                .map_err(|e| SolverError::Linear(format!("METIS ordering: {e}")))
                .and_then(|graph| {
                    // A poisoned lock only means another caller panicked; METIS reseeds anyway.
                    let _serial = METIS_LOCK
                        .lock()
                        .unwrap_or_else(std::sync::PoisonError::into_inner);
                    graph
                        .set_vwgt(&vwgt)
                        .set_option(metis::option::Seed(METIS_SEED))
                        .part_recursive(&mut self.part)
                        .map_err(|e| SolverError::Linear(format!("METIS ordering: {e}")))
                })
                .map(|_| Some(self.separate(nodes, &xadj, &adjncy, &vwgt)))
        };
        for &v in nodes {
            self.local[v] = usize::MAX;
        }
        let Some((a, b, separator)) = result? else {
            return Ok(None);
        };
        if separator.is_empty() && (a.is_empty() || b.is_empty()) {
            return Ok(None);
        }
        Ok(Some((a, b, separator)))
    }

    /// The halves and separator of a bisection `self.part` of the local graph: the separator
    /// is a minimum-weight vertex cover of the cut edges.
    fn separate(
        &self,
        nodes: &[usize],
        xadj: &[metis::Idx],
        adjncy: &[metis::Idx],
        vwgt: &[metis::Idx],
    ) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
        let k = nodes.len();
        let part = &self.part;
        // Flow network: source → boundary node of side 0 (capacity: its weight) → cut edge
        // (unbounded) → boundary node of side 1 → sink (its weight). A minimum cut is a
        // minimum-weight vertex cover of the cut edges (König–Egerváry, weighted).
        let mut flow = Flow::new(k + 2);
        let (source, sink) = (k, k + 1);
        let mut boundary = vec![false; k];
        for l in 0..k {
            for &u in &adjncy[xadj[l] as usize..xadj[l + 1] as usize] {
                let u = u as usize;
                if part[l] == 0 && part[u] == 1 {
                    flow.add_edge(l, u, i64::MAX / 4);
                    boundary[l] = true;
                    boundary[u] = true;
                }
            }
        }
        for l in (0..k).filter(|&l| boundary[l]) {
            if part[l] == 0 {
                flow.add_edge(source, l, i64::from(vwgt[l]));
            } else {
                flow.add_edge(l, sink, i64::from(vwgt[l]));
            }
        }
        flow.max_flow(source, sink);
        let reach = flow.reachable(source);
        let mut a = Vec::new();
        let mut b = Vec::new();
        let mut separator = Vec::new();
        for (l, &v) in nodes.iter().enumerate() {
            let in_cover = boundary[l] && ((part[l] == 0) != reach[l]);
            if in_cover {
                separator.push(v);
            } else if part[l] == 0 {
                a.push(v);
            } else {
                b.push(v);
            }
        }
        (a, b, separator)
    }
}

/// Max flow by Dinic's algorithm (integer capacities), for the separator cover.
struct Flow {
    head: Vec<usize>,
    next: Vec<usize>,
    to: Vec<usize>,
    cap: Vec<i64>,
}

impl Flow {
    const NONE: usize = usize::MAX;

    fn new(nodes: usize) -> Flow {
        Flow {
            head: vec![Self::NONE; nodes],
            next: Vec::new(),
            to: Vec::new(),
            cap: Vec::new(),
        }
    }

    /// Adds `from → to` with capacity `cap` and its residual twin (edge index ^ 1).
    fn add_edge(&mut self, from: usize, to: usize, cap: i64) {
        for (a, b, c) in [(from, to, cap), (to, from, 0)] {
            self.next.push(self.head[a]);
            self.head[a] = self.to.len();
            self.to.push(b);
            self.cap.push(c);
        }
    }

    fn levels(&self, source: usize) -> Vec<usize> {
        let mut level = vec![usize::MAX; self.head.len()];
        level[source] = 0;
        let mut queue = vec![source];
        let mut h = 0;
        while h < queue.len() {
            let v = queue[h];
            h += 1;
            let mut e = self.head[v];
            while e != Self::NONE {
                let u = self.to[e];
                if self.cap[e] > 0 && level[u] == usize::MAX {
                    level[u] = level[v] + 1;
                    queue.push(u);
                }
                e = self.next[e];
            }
        }
        level
    }

    fn max_flow(&mut self, source: usize, sink: usize) {
        loop {
            let level = self.levels(source);
            if level[sink] == usize::MAX {
                return;
            }
            let mut it = self.head.clone();
            // Blocking flow: repeated depth-first searches along the level graph with an
            // explicit stack of edges (the paths can be long).
            loop {
                let mut path: Vec<usize> = Vec::new();
                let mut v = source;
                let found = loop {
                    if v == sink {
                        break true;
                    }
                    let mut advanced = false;
                    while it[v] != Self::NONE {
                        let e = it[v];
                        let u = self.to[e];
                        if self.cap[e] > 0 && level[u] == level[v] + 1 {
                            path.push(e);
                            v = u;
                            advanced = true;
                            break;
                        }
                        it[v] = self.next[e];
                    }
                    if !advanced {
                        // Dead end: retreat and skip the edge that led here.
                        match path.pop() {
                            Some(e) => {
                                v = self.to[e ^ 1];
                                it[v] = self.next[it[v]];
                            }
                            None => break false,
                        }
                    }
                };
                if !found {
                    break;
                }
                let push = path.iter().map(|&e| self.cap[e]).min().unwrap_or(0);
                for &e in &path {
                    self.cap[e] -= push;
                    self.cap[e ^ 1] += push;
                }
            }
        }
    }

    /// Nodes reachable from `source` in the residual network.
    fn reachable(&self, source: usize) -> Vec<bool> {
        self.levels(source)
            .into_iter()
            .map(|l| l != usize::MAX)
            .collect()
    }
}

/// The inverse of a permutation given as `perm[new] = old`: `inv[old] = new`.
pub fn inverse_permutation(perm: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; perm.len()];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    inv
}

enum Split {
    Leaf(Vec<usize>),
    Parts {
        a: Vec<usize>,
        b: Vec<usize>,
        separator: Vec<usize>,
    },
}

struct Dissector<'a> {
    graph: &'a Graph,
    coordinates: Option<&'a [[f64; 3]]>,
    /// 0 outside the current set, 1 / 2 for its two halves, 3 for members during BFS.
    side: Vec<u8>,
    /// Local index of a dof inside the leaf being ordered.
    local: Vec<usize>,
    dist: Vec<usize>,
    queue: Vec<usize>,
    order: Vec<usize>,
}

impl Dissector<'_> {
    /// Appends `set` ordered by AMD on its induced subgraph (natural order if AMD fails).
    fn emit_leaf(&mut self, set: &[usize]) {
        let k = set.len();
        if k <= 2 {
            self.order.extend_from_slice(set);
            return;
        }
        for (l, &v) in set.iter().enumerate() {
            self.local[v] = l;
            self.side[v] = 5;
        }
        let mut col_ptr = Vec::with_capacity(k + 1);
        col_ptr.push(0);
        let mut rows = Vec::new();
        for (l, &v) in set.iter().enumerate() {
            let start = rows.len();
            rows.push(l);
            for &u in self.graph.neighbors(v) {
                if self.side[u] == 5 && self.local[u] > l {
                    rows.push(self.local[u]);
                }
            }
            rows[start..].sort_unstable();
            col_ptr.push(rows.len());
        }
        for &v in set {
            self.side[v] = 0;
        }
        let mut perm = vec![0usize; k];
        let mut perm_inv = vec![0usize; k];
        let ok = match (
            SymbolicSparseColMatRef::new_unsorted_checked(k, k, &col_ptr, None, &rows),
            MemBuffer::try_new(amd::order_maybe_unsorted_scratch::<usize>(k, rows.len())),
        ) {
            (a, Ok(mut mem)) => amd::order_maybe_unsorted(
                &mut perm,
                &mut perm_inv,
                a,
                amd::Control::default(),
                MemStack::new(&mut mem),
            )
            .is_ok(),
            _ => false,
        };
        if ok {
            self.order.extend(perm.iter().map(|&l| set[l]));
        } else {
            self.order.extend_from_slice(set);
        }
    }

    fn bisect(&mut self, mut set: Vec<usize>) -> Split {
        let Some(coords) = self.coordinates else {
            // Level-set bisection: the BFS level holding the median dof separates the levels
            // before it from those after it (edges only join adjacent levels).
            let mid = set.len() / 2;
            self.bfs_distances(&set);
            let dist = &self.dist;
            set.select_nth_unstable_by(mid, |&p, &q| dist[p].cmp(&dist[q]).then(p.cmp(&q)));
            let level = dist[set[mid]];
            let a = set.iter().copied().filter(|&v| dist[v] < level).collect();
            let b = set.iter().copied().filter(|&v| dist[v] > level).collect();
            let separator = set.iter().copied().filter(|&v| dist[v] == level).collect();
            for &v in &set {
                self.dist[v] = usize::MAX;
            }
            return Split::Parts { a, b, separator };
        };
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &v in &set {
            for k in 0..3 {
                lo[k] = lo[k].min(coords[v][k]);
                hi[k] = hi[k].max(coords[v][k]);
            }
        }
        // Cut across each axis with a non-zero extent and keep the smallest separator (ties:
        // the longest axis, the classic choice).
        let mut axes: Vec<usize> = (0..3).filter(|&k| hi[k] > lo[k]).collect();
        axes.sort_by(|&p, &q| (hi[q] - lo[q]).total_cmp(&(hi[p] - lo[p])));
        let mut best: Option<(Vec<usize>, Vec<usize>, Vec<usize>)> = None;
        for axis in axes {
            set.sort_unstable_by(|&p, &q| coords[p][axis].total_cmp(&coords[q][axis]));
            // Split at the median *value* so that dofs with equal coordinates (the three dofs
            // of a vertex, a grid line) stay on one side: cleaner separators.
            let median = coords[set[set.len() / 2]][axis];
            let mid = if median > lo[axis] {
                set.partition_point(|&v| coords[v][axis] < median)
            } else {
                set.partition_point(|&v| coords[v][axis] <= median)
            };
            let parts = self.separate(&set[..mid], &set[mid..]);
            if best.as_ref().is_none_or(|b| parts.2.len() < b.2.len()) {
                best = Some(parts);
            }
        }
        match best {
            Some((a, b, separator)) => Split::Parts { a, b, separator },
            // All dofs at one point: nothing geometric to split.
            None => Split::Leaf(set),
        }
    }

    /// Vertex separator between two halves: the smaller one-sided boundary. Returns the halves
    /// without it and the separator.
    fn separate(
        &mut self,
        a_half: &[usize],
        b_half: &[usize],
    ) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
        for &v in a_half {
            self.side[v] = 1;
        }
        for &v in b_half {
            self.side[v] = 2;
        }
        let graph = self.graph;
        let side = &self.side;
        let touches = |v: usize, other: u8| graph.neighbors(v).iter().any(|&u| side[u] == other);
        let boundary_a: Vec<usize> = a_half.iter().copied().filter(|&v| touches(v, 2)).collect();
        let boundary_b: Vec<usize> = b_half.iter().copied().filter(|&v| touches(v, 1)).collect();
        let (separator, sep_side) = if boundary_a.len() <= boundary_b.len() {
            (boundary_a, 1)
        } else {
            (boundary_b, 2)
        };
        for &v in &separator {
            self.side[v] = 4;
        }
        let a: Vec<usize> = a_half
            .iter()
            .copied()
            .filter(|&v| self.side[v] == 1)
            .collect();
        let b: Vec<usize> = b_half
            .iter()
            .copied()
            .filter(|&v| self.side[v] == 2)
            .collect();
        debug_assert!(sep_side == 1 || b.len() + separator.len() == b_half.len());
        for &v in a_half.iter().chain(b_half) {
            self.side[v] = 0;
        }
        (a, b, separator)
    }

    /// Breadth-first distances inside `set` from a pseudo-peripheral dof (two sweeps); dofs of
    /// other components of `set` get distances continuing after the first component's.
    fn bfs_distances(&mut self, set: &[usize]) {
        for &v in set {
            self.side[v] = 3;
        }
        let far = self.sweep(set[0], 0);
        for &v in set {
            self.dist[v] = usize::MAX;
        }
        let mut offset = 0;
        let mut start = far;
        loop {
            let last = self.sweep(start, offset);
            offset = self.dist[last] + 1;
            match set.iter().find(|&&v| self.dist[v] == usize::MAX) {
                Some(&v) => start = v,
                None => break,
            }
        }
        for &v in set {
            self.side[v] = 0;
        }
    }

    /// One BFS from `start` over unvisited members (side 3); returns the last dof reached.
    fn sweep(&mut self, start: usize, offset: usize) -> usize {
        self.queue.clear();
        self.queue.push(start);
        self.dist[start] = offset;
        let mut head = 0;
        while head < self.queue.len() {
            let v = self.queue[head];
            head += 1;
            for &u in self.graph.neighbors(v) {
                if self.side[u] == 3 && self.dist[u] == usize::MAX {
                    self.dist[u] = self.dist[v] + 1;
                    self.queue.push(u);
                }
            }
        }
        self.queue[self.queue.len() - 1]
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use faer::sparse::SymbolicSparseColMat;

    /// Lower pattern of a path graph 0 - 1 - … - (n-1).
    fn path(n: usize) -> SymbolicSparseColMat<usize> {
        let mut col_ptr = vec![0];
        let mut rows = Vec::new();
        for j in 0..n {
            rows.push(j);
            if j + 1 < n {
                rows.push(j + 1);
            }
            col_ptr.push(rows.len());
        }
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows)
    }

    #[test]
    fn path_separator_is_numbered_last_and_splits_the_path() {
        let n = 9;
        let p = path(n);
        let coords: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, 0.0, 0.0]).collect();
        for c in [Some(coords.as_slice()), None] {
            let perm = nested_dissection(p.as_ref(), c, 2).unwrap();
            let mut sorted = perm.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>());
            // The last dof separates the path into two parts numbered before it.
            let last = perm[n - 1];
            assert!(
                last > 0 && last < n - 1,
                "separator {last} is an end of the path"
            );
        }
    }

    /// Lower pattern of a `k × k` grid of vertices with 3 dofs each, every vertex coupled
    /// (dense 3×3 blocks) to its 8 neighbours: the shape of a shell Hessian.
    fn block_grid(k: usize) -> SymbolicSparseColMat<usize> {
        let n = 3 * k * k;
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
        for v in 0..k * k {
            let (x, y) = (v % k, v / k);
            for u in 0..k * k {
                let (ux, uy) = (u % k, u / k);
                if u >= v && ux.abs_diff(x) <= 1 && uy.abs_diff(y) <= 1 {
                    for a in 0..3 {
                        for b in 0..3 {
                            let (i, j) = (3 * u + a, 3 * v + b);
                            if i >= j {
                                cols[j].push(i);
                            }
                        }
                    }
                }
            }
        }
        let mut col_ptr = vec![0];
        let mut rows = Vec::new();
        for mut c in cols {
            c.sort_unstable();
            rows.extend(c);
            col_ptr.push(rows.len());
        }
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows)
    }

    #[test]
    fn compression_merges_the_dofs_of_a_vertex() {
        let p = block_grid(6);
        let c = Compressed::new(&Graph::from_pattern(p.as_ref()));
        assert_eq!(c.weight.len(), 36);
        for v in 0..36 {
            assert_eq!(c.members_of(v), &[3 * v, 3 * v + 1, 3 * v + 2]);
        }
        // A corner vertex has 3 neighbouring vertices, an interior one 8.
        assert_eq!(c.graph.neighbors(0).len(), 3);
        assert_eq!(c.graph.neighbors(7).len(), 8);
    }

    /// METIS draws from one process-wide random state: orderings computed on several threads
    /// at once must still equal the one computed alone (the lock around each call).
    #[test]
    fn concurrent_metis_dissections_equal_the_sequential_one() {
        let p = block_grid(16);
        let alone = metis_nested_dissection(p.as_ref(), 16).unwrap();
        std::thread::scope(|scope| {
            let runs: Vec<_> = (0..4)
                .map(|_| {
                    scope.spawn(|| {
                        (0..5)
                            .map(|_| metis_nested_dissection(p.as_ref(), 16).unwrap())
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            for r in runs {
                for perm in r.join().unwrap() {
                    assert_eq!(perm, alone);
                }
            }
        });
    }

    #[test]
    fn metis_dissection_is_a_deterministic_permutation_with_a_separator_last() {
        let k = 12;
        let p = block_grid(k);
        let n = 3 * k * k;
        let perm = metis_nested_dissection(p.as_ref(), 16).unwrap();
        assert_eq!(perm, metis_nested_dissection(p.as_ref(), 16).unwrap());
        let mut sorted = perm.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n).collect::<Vec<_>>());
        // The three dofs of a vertex stay together.
        for w in perm.chunks(3) {
            assert_eq!(w[0] / 3, w[2] / 3);
        }
        // The top separator (the last vertices numbered) splits the grid: removing it leaves
        // no edge between the dofs numbered in the first half and those in the second. Find
        // the split as the first position after which no earlier dof touches a later one
        // other than through the tail.
        let g = Graph::from_pattern(p.as_ref());
        let inv = inverse_permutation(&perm);
        // The separator of a 12 × 12 king's-move grid needs two vertex rows: at most 2k + 2
        // vertices. Find the smallest tail that disconnects the rest.
        let tail = (1..=2 * k + 2).map(|t| 3 * t).find(|&t| {
            let cut = n - t;
            // Component of the first numbered dof within the dofs before the tail.
            let mut seen = vec![false; n];
            let mut queue = vec![perm[0]];
            seen[perm[0]] = true;
            while let Some(v) = queue.pop() {
                for &u in g.neighbors(v) {
                    if inv[u] < cut && !seen[u] {
                        seen[u] = true;
                        queue.push(u);
                    }
                }
            }
            seen.iter().filter(|s| **s).count() < cut
        });
        assert!(tail.is_some(), "no small separator numbered last");
    }

    #[test]
    fn separator_is_a_minimum_weight_cover() {
        // Star: centre 0 (weight 1) joined to leaves 1..=4 (weight 3 each); centre on side 0,
        // leaves on side 1. The cheapest cover of the four cut edges is the centre.
        let mut f = Flow::new(7);
        for leaf in 1..=4 {
            f.add_edge(0, leaf, i64::MAX / 4);
            f.add_edge(leaf, 6, 3);
        }
        f.add_edge(5, 0, 1);
        f.max_flow(5, 6);
        let reach = f.reachable(5);
        assert!(
            !reach[0],
            "the centre is in the cover (cut from the source)"
        );
        assert!((1..=4).all(|l| !reach[l]), "no leaf is in the cover");
    }

    #[test]
    fn inverse_permutation_round_trips() {
        let perm = vec![2, 0, 3, 1];
        let inv = inverse_permutation(&perm);
        for (new, &old) in perm.iter().enumerate() {
            assert_eq!(inv[old], new);
        }
    }
}
