//! What a `cargo xtask perf` run learned and produced: the facts of the symbolic analyses,
//! the big run, and the samples (read by the report, written by the measures).

use std::collections::BTreeMap;

use super::measure::{Samples, Sizes};

/// Sizes and symbolic-analysis figures of one level of the Newton problem (default ordering).
#[derive(Clone, Debug)]
pub(crate) struct LevelFacts {
    pub(crate) faces: usize,
    pub(crate) unknowns: usize,
    pub(crate) nnz: usize,
    pub(crate) ordering: String,
    pub(crate) flops: f64,
    pub(crate) factor_len: usize,
    pub(crate) memory_estimate: u64,
}

/// The symbolic analysis of one ordering at one level.
#[derive(Clone, Debug)]
pub(crate) struct OrderingFacts {
    pub(crate) level: usize,
    pub(crate) asked: String,
    pub(crate) used: String,
    pub(crate) flops: f64,
    pub(crate) factor_len: usize,
    pub(crate) memory_estimate: u64,
    /// A timing.
    pub(crate) symbolic_s: f64,
}

/// What the set-up learned (deterministic, except `OrderingFacts::symbolic_s`).
#[derive(Clone, Debug, Default)]
pub(crate) struct Facts {
    pub(crate) per_face_faces: usize,
    /// Unknowns of the per-face systems, by `per_face/<form>`.
    pub(crate) unknowns: BTreeMap<String, usize>,
    /// Unknowns of the implicit-step systems, by form name.
    pub(crate) step_unknowns: BTreeMap<String, usize>,
    pub(crate) levels: BTreeMap<usize, LevelFacts>,
    pub(crate) orderings: Vec<OrderingFacts>,
}

/// The `--big` Newton iteration, run in a child process.
#[derive(Clone, Debug)]
pub(crate) struct BigRun {
    pub(crate) level: usize,
    pub(crate) threads: usize,
    pub(crate) faces: usize,
    pub(crate) unknowns: usize,
    pub(crate) ordering: String,
    pub(crate) flops: f64,
    pub(crate) memory_estimate: u64,
    /// VmHWM of the child (bytes), if /proc told.
    pub(crate) peak_rss: Option<u64>,
    /// Mesh, pattern and symbolic analysis (s).
    pub(crate) setup_s: f64,
    /// Per part of [`newton::PARTS`], one value per iteration (s).
    pub(crate) samples: BTreeMap<String, Vec<f64>>,
    /// The child's whole wall time (s).
    pub(crate) wall_s: f64,
}

/// Everything a run produced.
pub(crate) struct Run {
    pub(crate) quick: bool,
    pub(crate) big: bool,
    pub(crate) rounds: usize,
    pub(crate) sizes: Sizes,
    pub(crate) samples: Samples,
    pub(crate) facts: Facts,
    pub(crate) big_runs: Vec<BigRun>,
    /// Sections of [`super::extra_sections`], in order (markdown).
    pub(crate) extra: Vec<String>,
    pub(crate) total_s: f64,
    /// The 1-minute load average when the run started.
    pub(crate) load_start: Option<f64>,
}
