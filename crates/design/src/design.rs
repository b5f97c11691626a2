//! The design problem (forward map, parametrisation, objective, regulariser), its exact
//! gradient by the adjoint, and the bounded quasi-Newton loop.

use nalgebra::Vector3;
use rcompat_lbfgsb::{Bounds, OptimControl, optim_lbfgsb_with_gradient};
use std::cell::RefCell;
use thinshell_energy::RestState;

use crate::DesignError;
use crate::forward::{Equilibrium, Forward};
use crate::objective::{ShapeObjective, Smoothness};
use crate::param::{Parametrisation, clamp_to_bounds};

/// Parameter vectors whose equilibria are kept as starts.
const VISITED: usize = 16;

/// One evaluation of the design objective: J(x*(p)) + R(p), its gradient in p and the
/// equilibrium it was measured at.
#[derive(Clone, Debug)]
pub struct Evaluation {
    /// Shape objective J at the equilibrium (m² for the distances).
    pub shape: f64,
    /// Regulariser R(p).
    pub regulariser: f64,
    /// dJ/dp + ∂R/∂p (exact: the adjoint).
    pub gradient: Vec<f64>,
    /// The equilibrium.
    pub equilibrium: Equilibrium,
}

impl Evaluation {
    /// J + R.
    pub fn total(&self) -> f64 {
        self.shape + self.regulariser
    }
}

/// One row of a design loop's history (one forward solve and adjoint per row).
#[derive(Clone, Debug, PartialEq)]
pub struct HistoryRow {
    /// Evaluation number (0 = the start).
    pub evaluation: usize,
    /// J + R.
    pub objective: f64,
    /// Root-mean-square distance to the target (m).
    pub rms_distance: f64,
    /// Infinity norm of the projected gradient (zero on components pressed against a bound).
    pub projected_gradient: f64,
    /// Newton iterations of the forward solve.
    pub forward_iterations: usize,
    /// Whether the equilibrium was a strict minimum (its adjoint exists).
    pub stable: bool,
}

/// Stopping rules of [`Design::optimise`].
#[derive(Clone, Debug, PartialEq)]
pub struct DesignSettings {
    /// Target reached when the root-mean-square distance ≤ `tolerance` × the target's size.
    /// Default 1e-3.
    pub tolerance: f64,
    /// L-BFGS-B iterations at most. Default 200.
    pub max_iterations: usize,
    /// L-BFGS-B's relative-reduction tolerance factr (× machine ε). Default 1e5.
    pub factr: f64,
    /// L-BFGS-B's projected-gradient tolerance. Default 0 (off: the relative reduction decides).
    pub pgtol: f64,
    /// Weight μ of the Laplacian smoothness term (0: none). Default 0.
    pub smoothness: f64,
}

impl Default for DesignSettings {
    fn default() -> Self {
        DesignSettings {
            tolerance: 1e-3,
            max_iterations: 200,
            factr: 1e5,
            pgtol: 0.0,
            smoothness: 0.0,
        }
    }
}

/// How a design loop ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// The target was reached within the tolerance.
    Reached,
    /// The optimiser stopped (converged to a point that does not reach the target, or its
    /// iteration limit) with the residual above the tolerance.
    NotReached,
    /// A forward solve failed, or an equilibrium was not a minimum.
    Failed,
}

/// The result of [`Design::optimise`].
#[derive(Clone, Debug)]
pub struct DesignResult {
    /// The best parameters found.
    pub parameters: Vec<f64>,
    /// Their rest forms.
    pub rest: RestState,
    /// The equilibrium at them.
    pub equilibrium: Equilibrium,
    /// J + R there.
    pub objective: f64,
    /// Root-mean-square distance to the target there (m).
    pub rms_distance: f64,
    /// The target's size (m).
    pub target_size: f64,
    /// Parameters on a bound.
    pub at_bounds: usize,
    /// How it ended.
    pub outcome: Outcome,
    /// A sentence saying so, with the residual.
    pub message: String,
    /// One row per forward solve.
    pub history: Vec<HistoryRow>,
}

/// A design problem: which parameters p of the rest forms make the static equilibrium x*(p)
/// minimise a shape objective J(x*).
pub struct Design {
    forward: Forward,
    /// Recent (parameters, equilibrium) pairs: each solve starts from the equilibrium of the
    /// nearest parameters, so that a line search stepping back returns to the same branch
    /// (a shell can have several equilibria at the same rest forms).
    visited: Vec<(Vec<f64>, Equilibrium)>,
    param: Box<dyn Parametrisation>,
    objective: Box<dyn ShapeObjective>,
    smoothness: Option<Smoothness>,
}

impl std::fmt::Debug for Design {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Design")
            .field("forward", &self.forward)
            .field("parametrisation", &self.param.name())
            .finish_non_exhaustive()
    }
}

impl Design {
    /// The problem of `forward` with parameters `param` and objective `objective`.
    pub fn new(
        forward: Forward,
        param: Box<dyn Parametrisation>,
        objective: Box<dyn ShapeObjective>,
    ) -> Design {
        Design {
            forward,
            visited: Vec::new(),
            param,
            objective,
            smoothness: None,
        }
    }

    /// The parametrisation.
    pub fn parametrisation(&self) -> &dyn Parametrisation {
        self.param.as_ref()
    }

    /// The forward map.
    pub fn forward(&self) -> &Forward {
        &self.forward
    }

    /// Adds the Laplacian smoothness term of weight `weight` (0: none).
    pub fn set_smoothness(&mut self, weight: f64) {
        self.smoothness = (weight > 0.0)
            .then(|| Smoothness::new(self.forward.mesh(), self.param.layout(), weight));
    }

    /// The equilibrium at `p`, solved from that of the nearest parameters seen.
    fn equilibrium(&mut self, p: &[f64]) -> Result<Equilibrium, DesignError> {
        let distance = |q: &[f64]| q.iter().zip(p).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        if let Some((_, eq)) = self
            .visited
            .iter()
            .min_by(|a, b| distance(&a.0).total_cmp(&distance(&b.0)))
        {
            self.forward.start_from(eq);
        }
        let eq = self.forward.solve(&self.param.rest(p))?;
        if self.visited.len() >= VISITED {
            self.visited.remove(0);
        }
        self.visited.push((p.to_vec(), eq.clone()));
        Ok(eq)
    }

    /// J(x*(p)) + R(p) without the gradient (one forward solve).
    pub fn value(&mut self, p: &[f64]) -> Result<(f64, Equilibrium), DesignError> {
        let eq = self.equilibrium(p)?;
        let mut g = vec![Vector3::zeros(); eq.x.len()];
        let mut gp = vec![0.0; p.len()];
        let r = self
            .smoothness
            .as_ref()
            .map_or(0.0, |s| s.evaluate(p, &mut gp));
        Ok((self.objective.evaluate(&eq.x, &mut g) + r, eq))
    }

    /// J(x*(p)) + R(p) and its exact gradient: one forward solve (from the last equilibrium),
    /// one adjoint solve H λ = ∂J/∂x with the equilibrium's exact Hessian, and
    /// dJ/dp = ∂J/∂p − λᵀ ∂²E/∂x∂p through the parametrisation. Errors with
    /// [`DesignError::NotAMinimum`] at an equilibrium that is not a strict minimum.
    pub fn evaluate(&mut self, p: &[f64]) -> Result<Evaluation, DesignError> {
        if p.len() != self.param.len() {
            return Err(DesignError::Invalid(format!(
                "{} parameters given, the {} parametrisation has {}",
                p.len(),
                self.param.name(),
                self.param.len()
            )));
        }
        if let Some(bad) = p.iter().position(|v| !v.is_finite()) {
            return Err(DesignError::Invalid(format!(
                "parameter {bad} is not finite"
            )));
        }
        let eq = self.equilibrium(p)?;
        let mut gx = vec![Vector3::zeros(); eq.x.len()];
        let shape = self.objective.evaluate(&eq.x, &mut gx);
        let mut rhs = vec![0.0; self.forward.n_coordinates()];
        for (v, g) in gx.iter().enumerate() {
            rhs[3 * v..3 * v + 3].copy_from_slice(g.as_slice());
        }
        let w = self.forward.adjoint(&eq, &rhs)?;
        let minus: Vec<[f64; 6]> = w.iter().map(|wf| wf.map(|v| -v)).collect();
        let mut gradient = vec![0.0; p.len()];
        self.param.pullback(p, &minus, &mut gradient);
        let regulariser = self
            .smoothness
            .as_ref()
            .map_or(0.0, |s| s.evaluate(p, &mut gradient));
        Ok(Evaluation {
            shape,
            regulariser,
            gradient,
            equilibrium: eq,
        })
    }

    /// Minimises J(x*(p)) + R(p) over the box bounds of the parametrisation by L-BFGS-B from
    /// `start` (clamped into the bounds), every forward solve warm-started from the previous
    /// equilibrium. Ends [`Outcome::Reached`] only when the root-mean-square distance is at
    /// most `settings.tolerance` × the target's size; otherwise [`Outcome::NotReached`] with the
    /// residual and the parameters on their bounds, or [`Outcome::Failed`] with the error of
    /// the forward solve or adjoint.
    pub fn optimise(&mut self, start: &[f64], settings: &DesignSettings) -> DesignResult {
        self.set_smoothness(settings.smoothness);
        let mut p0 = start.to_vec();
        clamp_to_bounds(self.param.as_ref(), &mut p0);
        let (lo, hi) = self.param.bounds();
        let (lo, hi) = (lo.to_vec(), hi.to_vec());
        let size = self.objective.size();
        struct Best {
            p: Vec<f64>,
            eval: Evaluation,
        }
        let state = RefCell::new((
            Vec::<HistoryRow>::new(),
            None::<Best>,
            None::<(Vec<f64>, Vec<f64>)>,
            None::<DesignError>,
        ));
        let this = RefCell::new(&mut *self);
        let run = |p: &[f64]| -> Option<(f64, Vec<f64>)> {
            let mut st = state.borrow_mut();
            if st.3.is_some() {
                return None;
            }
            let evaluated = this.borrow_mut().evaluate(p);
            match evaluated {
                Ok(eval) => {
                    let pg = projected_gradient(p, &eval.gradient, &lo, &hi);
                    let row = HistoryRow {
                        evaluation: st.0.len(),
                        objective: eval.total(),
                        rms_distance: this.borrow().objective.rms(eval.shape),
                        projected_gradient: pg,
                        forward_iterations: eval.equilibrium.iterations,
                        stable: true,
                    };
                    st.0.push(row);
                    let value = eval.total();
                    let gradient = eval.gradient.clone();
                    if st.1.as_ref().is_none_or(|b| value < b.eval.total()) {
                        st.1 = Some(Best {
                            p: p.to_vec(),
                            eval,
                        });
                    }
                    st.2 = Some((p.to_vec(), gradient.clone()));
                    Some((value, gradient))
                }
                Err(e) => {
                    if matches!(e, DesignError::NotAMinimum) {
                        let n = st.0.len();
                        st.0.push(HistoryRow {
                            evaluation: n,
                            objective: f64::NAN,
                            rms_distance: f64::NAN,
                            projected_gradient: f64::NAN,
                            forward_iterations: 0,
                            stable: false,
                        });
                    }
                    st.3 = Some(e);
                    None
                }
            }
        };
        let f = |p: &[f64]| run(p).map_or(f64::NAN, |(v, _)| v);
        let g = |p: &[f64]| {
            let cached = state
                .borrow()
                .2
                .as_ref()
                .filter(|(q, _)| q.as_slice() == p)
                .map(|(_, g)| g.clone());
            cached.unwrap_or_else(|| run(p).map_or(vec![f64::NAN; p.len()], |(_, g)| g))
        };
        let control = OptimControl {
            maxit: settings.max_iterations,
            factr: settings.factr,
            pgtol: settings.pgtol,
            lmm: 10,
            ..OptimControl::default_for_dimension(p0.len())
        };
        let result = Bounds::new(lo.clone(), hi.clone())
            .map_err(|e| DesignError::Optimiser(e.to_string()))
            .and_then(|b| {
                optim_lbfgsb_with_gradient(p0.clone(), b, f, g, control)
                    .map_err(|e| DesignError::Optimiser(e.to_string()))
            });
        let (history, best, _, error) = state.into_inner();
        let Some(best) = best else {
            let e = error.map_or_else(|| "no evaluation".to_string(), |e| e.to_string());
            let rest = self.param.rest(&p0);
            let x = self.forward.positions().to_vec();
            return DesignResult {
                parameters: p0,
                rest,
                equilibrium: Equilibrium {
                    x,
                    phi: Vec::new(),
                    iterations: 0,
                },
                objective: f64::NAN,
                rms_distance: f64::NAN,
                target_size: size,
                at_bounds: 0,
                outcome: Outcome::Failed,
                message: format!("design failed at its start: {e}"),
                history,
            };
        };
        let rms = self.objective.rms(best.eval.shape);
        let at_bounds = best
            .p
            .iter()
            .zip(lo.iter().zip(&hi))
            .filter(|(v, (l, h))| *v <= l || *v >= h)
            .count();
        let reached = rms <= settings.tolerance * size;
        let optimiser = match &result {
            Ok(r) => format!("L-BFGS-B: {} (code {})", r.message, r.convergence),
            Err(e) => e.to_string(),
        };
        let (outcome, message) = match (&error, reached) {
            (None, true) | (Some(_), true) => (
                Outcome::Reached,
                format!(
                    "target reached: rms distance {rms:.3e} m = {:.2e} of the target's size \
                     (tolerance {:.1e}) after {} forward solves",
                    rms / size,
                    settings.tolerance,
                    history.len()
                ),
            ),
            (Some(e), false) => (
                Outcome::Failed,
                format!(
                    "design stopped by an error: {e}; best rms distance {rms:.3e} m = {:.2e} of \
                     the target's size (tolerance {:.1e})",
                    rms / size,
                    settings.tolerance
                ),
            ),
            (None, false) => (
                Outcome::NotReached,
                format!(
                    "target NOT reached: rms distance {rms:.3e} m = {:.2e} of the target's size \
                     (tolerance {:.1e}); {at_bounds} of {} parameters at their bounds; {optimiser}",
                    rms / size,
                    settings.tolerance,
                    best.p.len()
                ),
            ),
        };
        DesignResult {
            rest: self.param.rest(&best.p),
            parameters: best.p,
            equilibrium: best.eval.equilibrium.clone(),
            objective: best.eval.total(),
            rms_distance: rms,
            target_size: size,
            at_bounds,
            outcome,
            message,
            history,
        }
    }
}

/// ‖P(p − g) − p‖∞ with P the projection onto the box: the gradient's size that the bounds do
/// not hold back.
fn projected_gradient(p: &[f64], g: &[f64], lo: &[f64], hi: &[f64]) -> f64 {
    p.iter()
        .zip(g)
        .zip(lo.iter().zip(hi))
        .map(|((v, d), (l, h))| ((v - d).clamp(*l, *h) - v).abs())
        .fold(0.0, f64::max)
}
