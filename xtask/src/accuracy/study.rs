//! What the study is made of: the cases and their runs, refinement series, the forms compared
//! and the static-solve knobs every case shares.

use nalgebra::Vector3;
use thinshell_energy::SffKind;

pub(super) type V3 = Vector3<f64>;

/// Second-fundamental-form discretisations compared by the study. Extend this list (e.g. with
/// the edge-director variants) and every case runs once more per entry.
pub const FORMULATIONS: &[SffKind] = &SffKind::ALL;

/// Names of the cases every study run must contain (checked by the test).
pub const CASE_NAMES: &[&str] = &[
    "enlarged square",
    "rhombus",
    "cylindrical patch",
    "cylinder under refinement",
    "spherical cap under refinement",
    "strip, linear swelling",
    "strip, bilayer swelling",
    "falling cantilever (dynamic)",
];

/// The study's gradient tolerance knob for static solves (relative to the solver's force scale
/// `ShellSystem::force_scale`, E·h·L), on top of the solver's scale-free test.
pub(super) const STATIC_TOLERANCE: f64 = 1e-11;
/// Static solves may take many iterations from a far start: the study's own cap, 5× the
/// solver's default `NewtonSettings::max_iterations` (100) that scenes use.
pub(super) const STATIC_MAX_ITERATIONS: usize = 500;

/// One run: a point of the error–time plane.
#[derive(Clone, Debug)]
pub(super) struct Run {
    /// The knob being varied (one plotted series).
    pub(super) family: String,
    /// The knob values of this run.
    pub(super) label: String,
    pub(super) faces: usize,
    pub(super) dt: Option<f64>,
    pub(super) tolerance: Option<f64>,
    /// Error against the known answer (unit: the case's `error_unit`).
    pub(super) error: f64,
    /// Wall time of the solve / time stepping, s (set-up of the system excluded, Newton
    /// workspace with its symbolic analysis included).
    pub(super) wall_s: f64,
    pub(super) newton_iterations: usize,
    pub(super) steps: usize,
    /// False when Newton or the time stepping failed; the error is then that of the last
    /// accepted state.
    pub(super) converged: bool,
    /// Elastic energy of the final state, J (static solves only: tells apart equilibria).
    pub(super) energy: Option<f64>,
    /// Distance to the discrete equilibrium (the tightest static solve on the same mesh), same
    /// unit as `error`: the solver's share of the error (seed-mesh squares only).
    pub(super) to_discrete: Option<f64>,
}

/// A convergence series under mesh refinement (also used by `cargo xtask verify`).
#[derive(Clone, Debug)]
pub(crate) struct Refinement {
    pub(crate) name: String,
    /// (faces, error).
    pub(crate) points: Vec<(usize, f64)>,
}

impl Refinement {
    /// Observed order p of error ∝ h^p with h ∝ faces^(−1/2): least-squares slope over all
    /// levels, and per consecutive pair.
    pub(crate) fn orders(&self) -> (Option<f64>, Vec<f64>) {
        let pts: Vec<(f64, f64)> = self
            .points
            .iter()
            .filter(|(f, e)| *f > 0 && e.is_finite() && *e > 0.0)
            .map(|&(f, e)| (-0.5 * (f as f64).ln(), e.ln()))
            .collect();
        let pairs = pts
            .windows(2)
            .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
            .collect();
        if pts.len() < 2 {
            return (None, pairs);
        }
        let n = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        (Some(sxy / sxx), pairs)
    }
}

/// All runs of one case and one formulation.
pub(super) struct Case {
    pub(super) name: &'static str,
    pub(super) sff: SffKind,
    /// The known answer and how the error is measured.
    pub(super) answer: String,
    pub(super) error_unit: &'static str,
    pub(super) runs: Vec<Run>,
    pub(super) refinement: Vec<Refinement>,
    /// Measured facts worth a sentence (reference quality, stability limit, …).
    pub(super) notes: Vec<String>,
    /// Recommendation lines derived from this case's runs.
    pub(super) verdict: Vec<String>,
}

impl Case {
    pub(super) fn new(
        name: &'static str,
        sff: SffKind,
        answer: String,
        error_unit: &'static str,
    ) -> Case {
        Case {
            name,
            sff,
            answer,
            error_unit,
            runs: Vec::new(),
            refinement: Vec::new(),
            notes: Vec::new(),
            verdict: Vec::new(),
        }
    }

    /// Indices of the runs on the Pareto front of (wall time, error): no other run is both
    /// faster and more accurate. Failed runs are left out: they produced no answer.
    pub(super) fn pareto(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.runs.len())
            .filter(|&i| {
                let r = &self.runs[i];
                r.converged && r.error.is_finite() && r.wall_s.is_finite()
            })
            .collect();
        idx.sort_by(|&a, &b| {
            let (ra, rb) = (&self.runs[a], &self.runs[b]);
            ra.wall_s
                .total_cmp(&rb.wall_s)
                .then(ra.error.total_cmp(&rb.error))
        });
        let mut front = Vec::new();
        let mut best = f64::INFINITY;
        for i in idx {
            if self.runs[i].error < best {
                best = self.runs[i].error;
                front.push(i);
            }
        }
        front
    }

    /// The cheapest run whose error is within `factor` of the best error of the case.
    pub(super) fn cheapest_within(&self, factor: f64) -> Option<&Run> {
        let best = self
            .runs
            .iter()
            .map(|r| r.error)
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        self.runs
            .iter()
            .filter(|r| r.converged && r.error <= factor * best.max(1e-300))
            .min_by(|a, b| a.wall_s.total_cmp(&b.wall_s))
    }
}

/// The name a bending form goes by in the study's tables, plots and JSON.
pub(super) fn sff_name(sff: SffKind) -> String {
    sff.name().to_string()
}
