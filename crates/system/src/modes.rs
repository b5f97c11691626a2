//! Modal analysis: the system's stiffness and mass matrices and its natural frequencies and
//! mode shapes (docs/modal.md).
//!
//! Small vibrations about a state (x, φ) obey M ü + K u = 0 with K the Hessian of the static
//! potential (elastic energy and pressure) over the free dofs and M the lumped vertex masses.
//! The edge-director angles carry no mass, so their rows of M are zero: they follow the
//! positions quasi-statically, and the positions see the Schur complement
//! S = K_xx − K_xφ K_φφ⁻¹ K_φx. Modes solve S v = ω² M_x v. S is dense, so it is never formed:
//! the eigen-solve works with shift-invert, whose operator A = (S − σ M_x)⁻¹ M_x is applied as
//! one solve with the full sparse matrix K − σ M (angles included):
//!
//! ```text
//! [K_xx − σM_x  K_xφ] [y]   [M_x v]
//! [K_φx         K_φφ] [ψ] = [  0  ]   ⇒   y = (S − σ M_x)⁻¹ M_x v
//! ```
//!
//! A is self-adjoint in the M_x inner product; its largest eigenvalues θ = 1/(ω² − σ) are the
//! frequencies nearest the shift. They are found by block Lanczos (block Krylov space of A with
//! full M-orthogonalisation, Rayleigh–Ritz on the projected matrix, true residuals of the Ritz
//! pairs as the stopping test). The block (at least 6) lets repeated frequencies — the six
//! rigid motions of a free shell, the symmetric pairs of a square or a sphere — appear with
//! their multiplicity, which a single-vector Lanczos in exact arithmetic cannot do. The shift σ
//! is slightly negative, so that K − σM is positive definite also for a free shell and the
//! project's sparse Cholesky ([`SparseCholesky`]) factorises it once.

use faer::Par;
use faer::sparse::SparseColMat;
use nalgebra::{DMatrix, Vector3};
use thinshell_energy::{EvalOutput, HessianMode, ShellModel, Terms};

use super::loads::{add_pressure_hessian, unit_axis};
use super::system::ShellSystem;
use thinshell_solver::{Ordering, SolverError, SparseCholesky};

/// Settings of [`ShellSystem::natural_modes`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModalSettings {
    /// Number of modes wanted (the lowest frequencies), ≥ 1.
    pub count: usize,
    /// A Ritz pair (θ, y) is converged when ‖A y − θ y‖_M ≤ tolerance · θ (dimensionless).
    pub tolerance: f64,
    /// Largest Krylov basis (columns) before giving up with
    /// [`SolverError::ModesDidNotConverge`]; 0: `max(20·count, 200)`, at most the number of
    /// free position dofs.
    pub max_basis: usize,
    /// Block size (vectors per Krylov block); 0: `max(count, 6) + 2`. At least the largest
    /// multiplicity of a wanted frequency.
    pub block: usize,
}

impl Default for ModalSettings {
    fn default() -> Self {
        ModalSettings {
            count: 6,
            tolerance: 1e-10,
            max_basis: 0,
            block: 0,
        }
    }
}

/// Natural frequencies and mode shapes, lowest first.
#[derive(Clone, Debug, PartialEq)]
pub struct Modes {
    /// Eigenvalues ω² (rad²/s²), ascending; rigid motions give values near 0 (of either sign
    /// at round-off level), an unstable state negative ones.
    pub eigenvalues: Vec<f64>,
    /// Frequencies f = √ω² / 2π (Hz), ascending; `sign(ω²)·√|ω²|/2π` for a negative ω².
    pub frequencies: Vec<f64>,
    /// Mode shapes: displacement per vertex (m, arbitrary sign), M-normalised
    /// (Σ m_i |v_i|² = 1 kg·m²), 0 on held coordinates.
    pub shapes: Vec<Vec<Vector3<f64>>>,
    /// Relative residual ‖A y − θ y‖_M / θ of each mode at convergence (dimensionless).
    pub residuals: Vec<f64>,
    /// The shift σ (rad²/s²) the operator was factorised at.
    pub shift: f64,
    /// Krylov basis size used.
    pub basis: usize,
}

impl ShellSystem {
    /// The stiffness matrix K (lower triangle over the free dofs, in
    /// [`ShellSystem::hessian_template`]'s pattern): the exact Hessian of the static potential
    /// (elastic energy without damping, and the pressure's follower-load stiffness) at
    /// positions `x` (m) and edge angles `phi` (rad, one per edge; empty: the minimising
    /// angles, as in [`ShellSystem::energy`]). Position dofs first (N/m), then one per free
    /// edge angle (N·m/rad² in the rows and columns of angles, N/rad in the mixed ones).
    /// Contact is not included (an error when the system has it).
    pub fn stiffness_matrix(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
    ) -> Result<SparseColMat<usize, f64>, SolverError> {
        if self.contact.is_some() {
            return Err(SolverError::InvalidSetting {
                name: "contact",
                value: 1.0,
                requirement: "the stiffness matrix leaves contact out: build the system without it",
            });
        }
        let phi = if phi.is_empty() && self.has_edge_unknowns() {
            self.energy(x)?;
            self.angles.clone()
        } else {
            phi.to_vec()
        };
        let model = ShellModel {
            terms: Terms {
                damping: false,
                ..self.model.terms
            },
            ..self.model
        };
        let mut assembler = self.assembler_for(&model)?;
        let mut h = assembler.hessian_template();
        assembler.evaluate_with_angles(
            &model,
            x,
            &phi,
            &self.rest,
            None,
            EvalOutput {
                gradient: None,
                hessian: Some((&mut h, HessianMode::Exact)),
            },
        )?;
        add_pressure_hessian(
            &self.mesh,
            &assembler,
            x,
            self.pressure(),
            unit_axis(&self.loads),
            &mut h,
        )?;
        Ok(h)
    }

    /// The mass matrix's diagonal over the free dofs (kg), in the order of
    /// [`ShellSystem::stiffness_matrix`]: the lumped mass of the vertex on each free position
    /// coordinate, 0 on the (massless) edge angles.
    pub fn mass_diagonal(&self) -> Vec<f64> {
        let n3 = 3 * self.dofs.n_vertices();
        self.dofs
            .free_coordinates()
            .iter()
            .map(|&c| if c < n3 { self.mass[c / 3] } else { 0.0 })
            .collect()
    }

    /// The `settings.count` lowest natural frequencies and mode shapes of small vibrations
    /// about positions `x` (m) and edge angles `phi` (rad; empty: the minimising angles), the
    /// massless angles condensed (module docs). Errors: a state where K is not positive
    /// semi-definite (an unstable equilibrium: the factorisation fails), no free position,
    /// contact on, or no convergence within the basis limit.
    pub fn natural_modes(
        &mut self,
        x: &[Vector3<f64>],
        phi: &[f64],
        settings: &ModalSettings,
    ) -> Result<Modes, SolverError> {
        let k = self.stiffness_matrix(x, phi)?;
        let mass = self.mass_diagonal();
        let n_pos = self.dofs.n_free_positions();
        let modes = modes_of(k, &mass, n_pos, settings)?;
        let coords = self.dofs.free_coordinates();
        let n = self.mesh.n_vertices();
        let shapes = modes
            .vectors
            .iter()
            .map(|v| {
                let mut s = vec![Vector3::zeros(); n];
                for (&c, val) in coords.iter().zip(v) {
                    s[c / 3][c % 3] = *val;
                }
                s
            })
            .collect();
        let frequencies = modes
            .eigenvalues
            .iter()
            .map(|&l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI))
            .collect();
        Ok(Modes {
            eigenvalues: modes.eigenvalues,
            frequencies,
            shapes,
            residuals: modes.residuals,
            shift: modes.shift,
            basis: modes.basis,
        })
    }
}

/// Eigenpairs over the free position dofs.
struct RawModes {
    eigenvalues: Vec<f64>,
    /// Position parts (first `n_pos` free dofs), M-normalised.
    vectors: Vec<Vec<f64>>,
    residuals: Vec<f64>,
    shift: f64,
    basis: usize,
}

/// The M-inner product over the position dofs.
fn m_dot(m: &[f64], a: &[f64], b: &[f64]) -> f64 {
    m.iter().zip(a).zip(b).map(|((m, a), b)| m * a * b).sum()
}

/// Generalised eigenpairs K v = λ M v (M = diag(`mass`), zero on the dofs from `n_pos` on)
/// with the lowest λ, by shift-invert block Lanczos (module docs). `k` is the lower triangle.
fn modes_of(
    mut k: SparseColMat<usize, f64>,
    mass: &[f64],
    n_pos: usize,
    settings: &ModalSettings,
) -> Result<RawModes, SolverError> {
    let count = settings.count;
    if count == 0 || n_pos == 0 || !(settings.tolerance > 0.0 && settings.tolerance < 1.0) {
        return Err(SolverError::InvalidSetting {
            name: "modal settings",
            value: count as f64,
            requirement: "count >= 1, a free position dof, tolerance in (0, 1)",
        });
    }
    let m = &mass[..n_pos];
    if let Some(&bad) = m.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(SolverError::InvalidSetting {
            name: "mass",
            value: bad,
            requirement: "every free position needs a positive mass",
        });
    }
    let max_basis = match settings.max_basis {
        0 => (20 * count).max(200),
        b => b,
    }
    .min(n_pos);
    let block = match settings.block {
        0 => count.max(6) + 2,
        b => b,
    }
    .min(n_pos);
    if count > max_basis {
        return Err(SolverError::InvalidSetting {
            name: "count",
            value: count as f64,
            requirement: "at most the number of free position dofs (and max_basis)",
        });
    }
    // Shift σ = −τ: τ = 1e-9 of the largest diagonal ratio K_ii/m_i, far below the lowest
    // elastic ω² of any shell worth a modal analysis, and far above round-off in K, so that
    // K + τM is positive definite for a free shell (its rigid motions, λ = 0, become θ = 1/τ).
    let diag = thinshell_solver::linear::diagonal_offsets(k.symbolic())?;
    let lambda_max = (0..n_pos)
        .map(|d| k.val()[diag[d]] / m[d])
        .fold(0.0f64, f64::max);
    if !(lambda_max.is_finite() && lambda_max > 0.0) {
        return Err(SolverError::InvalidSetting {
            name: "stiffness diagonal",
            value: lambda_max,
            requirement: "a positive, finite stiffness on the free positions",
        });
    }
    let tau = 1e-9 * lambda_max;
    {
        let val = k.val_mut();
        for d in 0..n_pos {
            val[diag[d]] += tau * m[d];
        }
    }
    let mut chol = SparseCholesky::new(k.symbolic(), Ordering::Amd, None, Par::Seq)?;
    chol.factorize(k.as_ref())
        .map_err(|_| SolverError::InvalidSetting {
            name: "stiffness",
            value: -tau,
            requirement: "K − σM must be positive definite: the state is not a stable \
                      equilibrium (a negative eigenvalue), or the angles are unconstrained",
        })?;
    let n_all = k.nrows();
    // A v = positions of (K − σM)⁻¹ [M v; 0].
    let mut rhs = vec![0.0; n_all];
    let mut apply = |v: &[f64]| -> Result<Vec<f64>, SolverError> {
        rhs.iter_mut().for_each(|r| *r = 0.0);
        for d in 0..n_pos {
            rhs[d] = m[d] * v[d];
        }
        chol.solve_in_place(&mut rhs)?;
        Ok(rhs[..n_pos].to_vec())
    };

    let mut basis: Vec<Vec<f64>> = Vec::new();
    let mut images: Vec<Vec<f64>> = Vec::new();
    // Deterministic start block: smooth-ish pseudo-random vectors (no mode is missing).
    let mut next: Vec<Vec<f64>> = (0..block)
        .map(|j| {
            (0..n_pos)
                .map(|d| {
                    let s = ((d * 7919 + j * 104_729 + 1) as f64 * 0.618_033_988_749_895).fract();
                    s - 0.5
                })
                .collect()
        })
        .collect();
    loop {
        // M-orthonormalise the new block against the basis and itself (twice: full
        // reorthogonalisation keeps the Krylov basis orthogonal in floating point).
        for mut v in next.drain(..) {
            let norm0 = m_dot(m, &v, &v).sqrt();
            for _ in 0..2 {
                for q in &basis {
                    let c = m_dot(m, q, &v);
                    v.iter_mut().zip(q).for_each(|(a, b)| *a -= c * b);
                }
            }
            let norm = m_dot(m, &v, &v).sqrt();
            // A vector already in the span (deflation) is dropped.
            if norm > 1e-10 * norm0 && norm > 0.0 {
                v.iter_mut().for_each(|a| *a /= norm);
                images.push(apply(&v)?);
                basis.push(v);
            }
            if basis.len() >= max_basis {
                break;
            }
        }
        let nb = basis.len();
        // Rayleigh–Ritz: T = Qᵀ M (A Q), symmetric in exact arithmetic.
        let mut t = DMatrix::<f64>::zeros(nb, nb);
        for i in 0..nb {
            for j in 0..=i {
                let v = 0.5 * (m_dot(m, &basis[i], &images[j]) + m_dot(m, &basis[j], &images[i]));
                t[(i, j)] = v;
                t[(j, i)] = v;
            }
        }
        let eig = t.symmetric_eigen();
        let mut order: Vec<usize> = (0..nb).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let wanted = count.min(nb);
        let mut vectors = Vec::with_capacity(wanted);
        let mut residuals = Vec::with_capacity(wanted);
        let mut thetas = Vec::with_capacity(wanted);
        for &i in order.iter().take(wanted) {
            let theta = eig.eigenvalues[i];
            let s = eig.eigenvectors.column(i);
            let mut y = vec![0.0; n_pos];
            let mut ay = vec![0.0; n_pos];
            for (c, (q, aq)) in basis.iter().zip(&images).enumerate() {
                let w = s[c];
                y.iter_mut().zip(q).for_each(|(a, b)| *a += w * b);
                ay.iter_mut().zip(aq).for_each(|(a, b)| *a += w * b);
            }
            let r: Vec<f64> = ay.iter().zip(&y).map(|(a, b)| a - theta * b).collect();
            residuals.push(m_dot(m, &r, &r).sqrt() / theta.abs());
            thetas.push(theta);
            vectors.push(y);
        }
        let converged = wanted == count && residuals.iter().all(|r| *r <= settings.tolerance);
        if converged {
            let eigenvalues = thetas.iter().map(|th| 1.0 / th - tau).collect();
            return Ok(RawModes {
                eigenvalues,
                vectors,
                residuals,
                shift: -tau,
                basis: nb,
            });
        }
        if nb >= max_basis {
            return Err(SolverError::ModesDidNotConverge {
                basis: nb,
                worst: residuals
                    .iter()
                    .fold(f64::INFINITY.min(0.0), |a, &b| a.max(b)),
            });
        }
        // Next block: A applied to the newest block.
        let start = nb.saturating_sub(block);
        next = images[start..].to_vec();
    }
}
