//! What a perf run measures with: the mesh sizes, the timed measures and their interleaved
//! rounds, the raw samples and the statistics the report takes of them.

use std::collections::BTreeMap;
use std::time::Instant;

use anyhow::{Context, Result};

use crate::common::median;

/// The mesh sizes of a run (icosphere levels; level ℓ has 20·4^ℓ faces).
#[derive(Clone, Debug)]
pub(crate) struct Sizes {
    /// Per-face evaluation, gather and implicit steps (the issue: level 5, 20 480 faces).
    pub(crate) per_face: usize,
    /// Factorisation (the issue: 20 480 and 81 920 faces).
    pub(crate) factor: Vec<usize>,
    /// Newton iteration and growth exponent (the issue: 1 280 … 81 920 faces).
    pub(crate) newton: Vec<usize>,
    /// The `--big` Newton iteration (the issue: 327 680 faces).
    pub(crate) big: usize,
    /// Thread counts of the two-thread rows (1 and 2; only 1 on a one-core machine).
    pub(crate) threads: Vec<usize>,
}

impl Sizes {
    pub(crate) fn new(quick: bool) -> Sizes {
        let threads = if std::thread::available_parallelism().map_or(1, usize::from) > 1 {
            vec![1, 2]
        } else {
            vec![1]
        };
        if quick {
            Sizes {
                per_face: 3,
                factor: vec![3, 4],
                newton: vec![3, 4],
                big: 4,
                threads,
            }
        } else {
            Sizes {
                per_face: 5,
                factor: vec![5, 6],
                newton: vec![3, 4, 5, 6],
                big: 7,
                threads,
            }
        }
    }
}

/// Faces of the icosphere at `level`.
pub(crate) fn faces_at(level: usize) -> usize {
    20 * 4usize.pow(level as u32)
}

/// One timed action: returns its named parts in seconds (the first part is the total).
pub(crate) type Action = Box<dyn FnMut() -> Result<Vec<f64>>>;

/// A measure of the interleaved rounds.
pub(crate) struct Measure {
    /// Key in the JSON and in [`Samples`], e.g. `newton/l5/t1`.
    pub(crate) id: String,
    /// Names of the parts the action returns (`["total"]` for a single time).
    pub(crate) parts: Vec<&'static str>,
    /// Divide every time by this (e.g. faces, for per-face figures); 1 otherwise.
    pub(crate) per: f64,
    pub(crate) action: Action,
}

/// Raw samples: measure id → part name → one value per round (s, or s per `per`).
pub(crate) type Samples = BTreeMap<String, BTreeMap<String, Vec<f64>>>;

/// Runs every measure once per round, in order; one warm-up call each first (not recorded:
/// it pages in buffers and lets faer size its scratch).
pub(super) fn interleave(measures: &mut [Measure], rounds: usize) -> Result<Samples> {
    let mut samples = Samples::new();
    for m in measures.iter_mut() {
        (m.action)().with_context(|| format!("warm-up of {}", m.id))?;
    }
    for round in 0..rounds {
        let t = Instant::now();
        for m in measures.iter_mut() {
            let parts = (m.action)().with_context(|| format!("{} (round {round})", m.id))?;
            let entry = samples.entry(m.id.clone()).or_default();
            for (name, v) in m.parts.iter().zip(parts) {
                entry
                    .entry((*name).to_string())
                    .or_default()
                    .push(v / m.per);
            }
        }
        println!(
            "perf: round {}/{rounds} done in {:.1} s",
            round + 1,
            t.elapsed().as_secs_f64()
        );
    }
    Ok(samples)
}

/// Median of part `part` of measure `id` (NaN if it was not measured).
pub(crate) fn med(samples: &Samples, id: &str, part: &str) -> f64 {
    samples
        .get(id)
        .and_then(|m| m.get(part))
        .map_or(f64::NAN, |v| median(v))
}

/// Least-squares slope of ln y against ln x (NaN with fewer than two distinct x).
pub(crate) fn loglog_slope(points: &[(f64, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = pts.len() as f64;
    if pts.len() < 2 {
        return f64::NAN;
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pts.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = pts.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    if sxx > 0.0 { sxy / sxx } else { f64::NAN }
}

/// A rayon pool of `threads` threads.
pub(crate) fn pool(threads: usize) -> Result<std::sync::Arc<rayon::ThreadPool>> {
    Ok(std::sync::Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .with_context(|| format!("building a rayon pool of {threads} threads"))?,
    ))
}
