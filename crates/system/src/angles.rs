//! Edge-director angles relaxed at fixed positions (model.md §1.1).
//!
//! The angles φ_e of an edge-director form carry no mass: at every instant they minimise the
//! energy for the current positions. Implicit and static solves find them together with the
//! positions; [`ExplicitEuler`](super::ExplicitEuler), which only moves positions, calls
//! [`ShellSystem::relax_edge_angles`](crate::ShellSystem::relax_edge_angles) once per step.
//! With the angles at their minimiser φ*(x), ∂E/∂φ = 0, so the position force −∂E/∂x(x, φ*)
//! is the exact gradient of the reduced energy E*(x) = min_φ E(x, φ): the explicit step
//! integrates a conservative system.
//!
//! The sub-problem is the shell with every vertex coordinate held: its Hessian is the sparse
//! angle block (one row per free edge, five entries per row), assembled by its own
//! [`Assembler`] and factorised by a [`SparseCholesky`] whose symbolic analysis is done once.
//! Newton iterations reuse the last factorisation while it contracts (chord steps: gradient
//! evaluations only) and refactorise when it stops doing so — in a time-stepping loop the
//! angle Hessian changes little from step to step.

use faer::Par;
use faer::sparse::SparseColMat;
use nalgebra::Vector3;
use thinshell_energy::{
    Assembler, DampingState, DofMap, EnergyError, EnergyTerms, EvalOutput, HessianMode, RestState,
    ShellModel,
};
use thinshell_mesh::{Mesh, VertexId};

use crate::Boundary;
use thinshell_solver::linear::RegularizationParams;
use thinshell_solver::{Ordering, SolverError, SparseCholesky};

/// Largest correction (rad) taken with a reused factorisation; larger ones refactorise first.
const MAX_CHORD_STEP: f64 = 0.05;

/// Settings of [`ShellSystem::relax_edge_angles`](crate::ShellSystem::relax_edge_angles).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleSettings {
    /// Converged when the Newton correction max_e |δφ_e| (rad) is at most this. Angles are
    /// dimensionless, so the test does not depend on the material or mesh scale; the
    /// remaining force error on the positions is ∂²E/∂x∂φ·δφ.
    pub tolerance: f64,
    /// Gradient evaluations allowed per call before [`SolverError::NewtonDidNotConverge`].
    pub max_iterations: usize,
    /// A reused factorisation is replaced when a chord step shrinks the correction by less
    /// than this factor (in (0, 1)).
    pub contraction: f64,
}

impl Default for AngleSettings {
    fn default() -> Self {
        AngleSettings {
            tolerance: 1e-10,
            max_iterations: 50,
            contraction: 0.25,
        }
    }
}

/// What one [`ShellSystem::relax_edge_angles`](crate::ShellSystem::relax_edge_angles) call
/// did.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AngleReport {
    /// Gradient evaluations (the last one is at the returned angles).
    pub gradient_evaluations: usize,
    /// Hessian evaluations and numeric factorisations (0 when the previous factorisation was
    /// good enough throughout).
    pub factorizations: usize,
    /// Energy-only evaluations of the line search.
    pub value_evaluations: usize,
    /// Last Newton correction max_e |δφ_e| (rad), at most the tolerance on success.
    pub last_correction: f64,
    /// Energy terms (J) at the returned angles (damping included when given).
    pub energies: EnergyTerms,
}

/// Cached angle-only problem of a [`ShellSystem`](crate::ShellSystem): assembler with every
/// vertex coordinate held, Hessian buffer, factorisation, scratch vectors.
pub(crate) struct AngleRelaxation {
    assembler: Assembler,
    hessian: SparseColMat<usize, f64>,
    cholesky: SparseCholesky,
    factorized: bool,
    mu: f64,
    /// Edge index of every free angle dof.
    edge_of_dof: Vec<usize>,
    grad_full: Vec<f64>,
    delta: Vec<f64>,
    trial: Vec<f64>,
    /// Running totals over all calls (for cost measurements).
    pub(crate) totals: AngleReport,
}

impl AngleRelaxation {
    /// The angle-only problem of `model` on `mesh` with the angles of `boundary`'s clamped and
    /// mirror edges fixed, the clamped directors held as at `clamp_reference` (model.md §1.3)
    /// and the mirror edges' in their planes (§1.4).
    pub(crate) fn new(
        mesh: &Mesh,
        model: &ShellModel,
        boundary: &Boundary,
        clamp_reference: &[Vector3<f64>],
    ) -> Result<AngleRelaxation, SolverError> {
        let n = mesh.n_vertices();
        let all_vertices = (0..n).map(VertexId::new);
        let dofs = DofMap::with_pinned_vertices(n, all_vertices)
            .and_then(|d| d.with_edges(mesh.n_edges(), boundary.fixed_angle_edges(mesh)))?;
        let mut assembler = Assembler::for_model(mesh, &dofs, model)?;
        assembler.clamp_edges(&boundary.clamped_edges, clamp_reference)?;
        assembler.set_mirror_edges(&boundary.mirror_normals())?;
        let hessian = assembler.hessian_template();
        let cholesky = SparseCholesky::new(hessian.symbolic(), Ordering::Amd, None, Par::Seq)?;
        let n3 = 3 * n;
        let edge_of_dof: Vec<usize> = dofs.free_coordinates().iter().map(|&c| c - n3).collect();
        let m = edge_of_dof.len();
        Ok(AngleRelaxation {
            assembler,
            hessian,
            cholesky,
            factorized: false,
            mu: 0.0,
            edge_of_dof,
            grad_full: vec![0.0; dofs.n_coordinates()],
            delta: vec![0.0; m],
            trial: Vec::new(),
            totals: AngleReport::default(),
        })
    }

    /// Whether this cache still fits a system with unknowns `dofs` (same counts of
    /// coordinates and free angles).
    pub(crate) fn fits(&self, dofs: &DofMap) -> bool {
        self.grad_full.len() == dofs.n_coordinates()
            && self.edge_of_dof.len() == dofs.n_free() - dofs.n_free_positions()
    }

    /// The full gradient (N, then J/rad per edge) of the last evaluation.
    pub(crate) fn gradient_full(&self) -> &[f64] {
        &self.grad_full
    }

    fn energy(
        &mut self,
        model: &ShellModel,
        rest: &RestState,
        x: &[Vector3<f64>],
        phi: &[f64],
        damping: Option<&DampingState>,
    ) -> Result<f64, SolverError> {
        match self.assembler.evaluate_with_angles(
            model,
            x,
            phi,
            rest,
            damping,
            EvalOutput::default(),
        ) {
            Ok(t) => Ok(t.total()),
            // A trial angle where tan α blows up: reject it in the line search.
            Err(EnergyError::NonFinite { .. }) => Ok(f64::INFINITY),
            Err(e) => Err(e.into()),
        }
    }

    fn gradient(
        &mut self,
        model: &ShellModel,
        rest: &RestState,
        x: &[Vector3<f64>],
        phi: &[f64],
        damping: Option<&DampingState>,
    ) -> Result<EnergyTerms, SolverError> {
        self.assembler
            .evaluate_with_angles(
                model,
                x,
                phi,
                rest,
                damping,
                EvalOutput {
                    gradient: Some(&mut self.grad_full),
                    hessian: None,
                },
            )
            .map_err(SolverError::from)
    }

    fn factorize(
        &mut self,
        model: &ShellModel,
        rest: &RestState,
        x: &[Vector3<f64>],
        phi: &[f64],
        damping: Option<&DampingState>,
    ) -> Result<(), SolverError> {
        self.factorized = false;
        self.assembler.evaluate_with_angles(
            model,
            x,
            phi,
            rest,
            damping,
            EvalOutput {
                gradient: None,
                hessian: Some((&mut self.hessian, HessianMode::Exact)),
            },
        )?;
        self.cholesky
            .factorize_regularized(
                &mut self.hessian,
                &RegularizationParams::default(),
                &mut self.mu,
            )
            .map_err(|e| SolverError::Linear(format!("edge-angle Hessian: {e:?}")))?;
        self.factorized = true;
        Ok(())
    }

    /// δ = −H⁻¹ g_φ from the current factorisation and gradient; returns max |δ| (rad).
    fn correction(&mut self, n3: usize) -> Result<f64, SolverError> {
        for (d, &e) in self.delta.iter_mut().zip(&self.edge_of_dof) {
            *d = -self.grad_full[n3 + e];
        }
        self.cholesky.solve_in_place(&mut self.delta)?;
        let m = self.delta.iter().fold(0.0f64, |m, d| m.max(d.abs()));
        if m.is_finite() {
            Ok(m)
        } else {
            Err(SolverError::NonFinite {
                what: "Newton direction",
                iteration: 0,
                dof: None,
            })
        }
    }

    /// Newton on the free angles at fixed `x`; `phi` holds the start and receives the result.
    pub(crate) fn relax(
        &mut self,
        model: &ShellModel,
        rest: &RestState,
        x: &[Vector3<f64>],
        phi: &mut [f64],
        damping: Option<&DampingState>,
        settings: &AngleSettings,
    ) -> Result<AngleReport, SolverError> {
        let n3 = 3 * x.len();
        let mut report = AngleReport::default();
        let mut residuals = Vec::new();
        // Correction predicted before the last chord step (None after a fresh Newton step).
        let mut chord_from: Option<f64> = None;
        let result = loop {
            report.energies = self.gradient(model, rest, x, phi, damping)?;
            report.gradient_evaluations += 1;
            if self.edge_of_dof.is_empty() {
                break Ok(());
            }
            let mut fresh = false;
            if !self.factorized {
                self.factorize(model, rest, x, phi, damping)?;
                report.factorizations += 1;
                fresh = true;
            }
            let mut norm = self.correction(n3)?;
            // A reused factorisation whose last chord step did not contract well, or that
            // proposes a large step (it may be from a very different configuration; chord
            // steps have no line search): refresh it.
            if !fresh
                && norm > settings.tolerance
                && (norm > MAX_CHORD_STEP
                    || chord_from.is_some_and(|prev| norm > settings.contraction * prev))
            {
                self.factorize(model, rest, x, phi, damping)?;
                report.factorizations += 1;
                fresh = true;
                norm = self.correction(n3)?;
            }
            report.last_correction = norm;
            residuals.push(norm);
            if norm <= settings.tolerance {
                break Ok(());
            }
            if report.gradient_evaluations >= settings.max_iterations {
                break Err(());
            }
            let mut t = 1.0;
            if fresh {
                // Armijo backtracking on the energy: the exact Hessian may be far from the
                // curvature when the angles start far from their minimiser (tan near ±π/2).
                let e0 = report.energies.total();
                let slope: f64 = self
                    .delta
                    .iter()
                    .zip(&self.edge_of_dof)
                    .map(|(d, &e)| d * self.grad_full[n3 + e])
                    .sum();
                let mut trial = std::mem::take(&mut self.trial);
                trial.clear();
                trial.extend_from_slice(phi);
                loop {
                    for (d, &e) in self.delta.iter().zip(&self.edge_of_dof) {
                        trial[e] = phi[e] + t * d;
                    }
                    let e1 = self.energy(model, rest, x, &trial, damping)?;
                    report.value_evaluations += 1;
                    if e1 <= e0 + 1e-4 * t * slope || t < 1e-10 {
                        break;
                    }
                    t *= 0.5;
                }
                self.trial = trial;
                chord_from = None;
            } else {
                chord_from = Some(norm);
            }
            for (d, &e) in self.delta.iter().zip(&self.edge_of_dof) {
                phi[e] += t * d;
            }
        };
        let t = &mut self.totals;
        t.gradient_evaluations += report.gradient_evaluations;
        t.factorizations += report.factorizations;
        t.value_evaluations += report.value_evaluations;
        match result {
            Ok(()) => Ok(report),
            Err(()) => Err(SolverError::NewtonDidNotConverge {
                iterations: report.gradient_evaluations,
                residuals,
                tolerance: settings.tolerance,
                last_correction: None,
                step_tolerance: 0.0,
                last_good: phi.to_vec(),
            }),
        }
    }
}
