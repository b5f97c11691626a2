//! Why a target is missed: what was measured about the cause (shown only for rows that
//! miss).

/// The per-face reason of an evaluation kind of the first table.
pub(super) fn per_face(what: &str) -> &'static str {
    match what {
        "energy" => ENERGY,
        "energy_gradient" => ENERGY_GRADIENT,
        _ => "",
    }
}
pub(super) const ENERGY: &str = "*Energy only*: StVK with the mid-edge average or an edge-director \
    form is evaluated four faces per SIMD lane (`assembly/batch.rs`, structure of arrays, run-time \
    AVX2 dispatch; docs/performance.md \"item 6\"): what is left is the law's and b's arithmetic \
    itself and the gather of the stencil positions.";
pub(super) const ENERGY_GRADIENT: &str = "*Energy + gradient*: batched four faces a lane for the \
    mid-edge average (`assembly/batch.rs`); about 115 of its instructions per face are the \
    gradient's scatter of 18 entries per face, which stays scalar. The edge-director forms are \
    batched too (faces with fitted, clamped or mirror edges take the per-face kernel).";
pub(super) const FACTOR: &str = "*Factorisation*: the same METIS ordering as libshell's \
    CHOLMOD since issue #31 (the ordering row); what is left is the supernodal kernels' rate.";
pub(super) const THREADS: &str = "*Two threads*: the split factorises the two halves of the \
    top separator concurrently, each stopping at the separator, then the separator densely in \
    fixed blocks; it does the unsplit factorisation's flops, and its predicted critical path is \
    about 0.53 of them at 20 480 faces, so small factors gain little.";
pub(super) const ORDERING: &str = "*Ordering flops*: the default is METIS's own nested \
    dissection (`METIS_NodeND` through the solver's checked `unsafe` wrapper since issue #31), \
    the ordering CHOLMOD uses; a residual difference is METIS's random stream and CHOLMOD's \
    postordering.";
pub(super) const NEWTON: &str = "*Newton iteration ≥ 4× libshell on 2 threads*: 4× needs \
    ≤ 149 ms (issue #31's libshell: 594 ms) for assembly, factorisation and solve, and the \
    two-thread factorisation is about three quarters of that (Factorisation table); closing it needs \
    fewer flops (the ordering row), faster supernodal kernels, or skipped factorisations \
    (factor reuse, below: the default of implicit steps since issue #31, which this row, \
    one factorisation per iteration, does not count).";
pub(super) const GROWTH: &str = "*Growth exponent*: nested dissection factorises a 2-D mesh \
    of n unknowns in O(n^1.5) flops, and the factorisation is most of an iteration from \
    20 480 faces up, so the slope rises with size; two threads pull it down (the split \
    pays more on larger factors: the speed-up column of the Factorisation table).";
pub(super) const DIRECTOR_FACE: &str = "*Director forms per face*: 21 dofs per face (the \
    three edge angles) against 18, and 45 vertex/edge block pairs gathered against 21 (edge \
    slots' blocks at their real size since issue #31: 249 f64 per face against the average's \
    189); the dihedral angle's Hessian is in closed form; what remains is the altitude's \
    Hessian and the fitted/clamped edges' dual numbers (callgrind `face_cost FORM egh`: 39 347 \
    instructions per face for tan against 29 126 for the average on 2026-12-03).";
pub(super) const DIRECTOR_STEP: &str = "*Director forms per implicit step*: twice the \
    unknowns (one angle per edge) and about 2.2× the predicted factorisation flops with \
    METIS (1.44e10 against 6.38e9 at 20 480 faces), on top of the per-face cost.";
