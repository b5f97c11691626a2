//! Synthetic sparse objectives for the solver tests: a 3D mass-spring net.
#![allow(dead_code)]

use faer::sparse::{SparseColMat, Triplet};
use thinshell_solver::{Objective, SolverError};
use thinshell_testkit::rng::Lcg64;

/// Springs between nodes (stiffness k in N/m, rest length in m), lumped masses under gravity,
/// pinned nodes removed from the unknowns. E = Σ ½k(ℓ − L)² − Σ m g·p.
pub struct SpringNet {
    /// Initial / pinned node positions (m).
    pub reference: Vec<[f64; 3]>,
    /// (node a, node b, rest length, stiffness).
    pub springs: Vec<(usize, usize, f64, f64)>,
    /// Mass per node (kg).
    pub mass: Vec<f64>,
    /// Gravitational acceleration (m/s²).
    pub gravity: [f64; 3],
    /// First dof of each free node (3 consecutive dofs), `None` if pinned.
    pub dof: Vec<Option<usize>>,
    n_dofs: usize,
    template: SparseColMat<usize, f64>,
    /// Per spring, the value offset of each lower entry of its 6×6 local block.
    offsets: Vec<[[Option<usize>; 6]; 6]>,
    /// Force scale for the convergence test (N).
    pub force_scale: f64,
    /// Length scale (m).
    pub length_scale: f64,
}

impl SpringNet {
    pub fn new(
        reference: Vec<[f64; 3]>,
        springs: Vec<(usize, usize, f64, f64)>,
        mass: Vec<f64>,
        gravity: [f64; 3],
        pinned: &[usize],
        force_scale: f64,
        length_scale: f64,
    ) -> SpringNet {
        let n_nodes = reference.len();
        let mut dof = vec![None; n_nodes];
        let mut n_dofs = 0;
        for (v, d) in dof.iter_mut().enumerate() {
            if !pinned.contains(&v) {
                *d = Some(n_dofs);
                n_dofs += 3;
            }
        }
        let global = |dof: &[Option<usize>], node: usize, axis: usize| dof[node].map(|d| d + axis);
        let mut triplets = Vec::new();
        for i in 0..n_dofs {
            triplets.push(Triplet::new(i, i, 0.0));
        }
        for &(a, b, _, _) in &springs {
            let nodes = [a, b];
            for p in 0..6 {
                for q in 0..6 {
                    if let (Some(r), Some(c)) = (
                        global(&dof, nodes[p / 3], p % 3),
                        global(&dof, nodes[q / 3], q % 3),
                    ) {
                        if r >= c {
                            triplets.push(Triplet::new(r, c, 0.0));
                        }
                    }
                }
            }
        }
        let template = SparseColMat::try_new_from_triplets(n_dofs, n_dofs, &triplets).unwrap();
        let offset_of = |r: usize, c: usize| {
            let range = template.symbolic().col_range(c);
            let rows = &template.symbolic().row_idx()[range.clone()];
            range.start + rows.binary_search(&r).unwrap()
        };
        let offsets = springs
            .iter()
            .map(|&(a, b, _, _)| {
                let nodes = [a, b];
                let mut o = [[None; 6]; 6];
                for p in 0..6 {
                    for q in 0..6 {
                        if let (Some(r), Some(c)) = (
                            global(&dof, nodes[p / 3], p % 3),
                            global(&dof, nodes[q / 3], q % 3),
                        ) {
                            if r >= c {
                                o[p][q] = Some(offset_of(r, c));
                            }
                        }
                    }
                }
                o
            })
            .collect();
        SpringNet {
            reference,
            springs,
            mass,
            gravity,
            dof,
            n_dofs,
            template,
            offsets,
            force_scale,
            length_scale,
        }
    }

    /// Node positions for the unknowns `x`.
    pub fn positions(&self, x: &[f64]) -> Vec<[f64; 3]> {
        self.dof
            .iter()
            .enumerate()
            .map(|(v, d)| match d {
                Some(d) => [x[*d], x[d + 1], x[d + 2]],
                None => self.reference[v],
            })
            .collect()
    }

    /// The unknowns of a set of node positions.
    pub fn unknowns(&self, p: &[[f64; 3]]) -> Vec<f64> {
        let mut x = vec![0.0; self.n_dofs];
        for (v, d) in self.dof.iter().enumerate() {
            if let Some(d) = d {
                x[*d..d + 3].copy_from_slice(&p[v]);
            }
        }
        x
    }

    fn spring_geometry(p: &[[f64; 3]], a: usize, b: usize) -> ([f64; 3], f64) {
        let u = [p[b][0] - p[a][0], p[b][1] - p[a][1], p[b][2] - p[a][2]];
        let l = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        ([u[0] / l, u[1] / l, u[2] / l], l)
    }
}

impl Objective for SpringNet {
    fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    fn value(&mut self, x: &[f64]) -> Result<f64, SolverError> {
        let p = self.positions(x);
        let mut e = 0.0;
        for &(a, b, rest, k) in &self.springs {
            let (_, l) = Self::spring_geometry(&p, a, b);
            e += 0.5 * k * (l - rest) * (l - rest);
        }
        for (v, d) in self.dof.iter().enumerate() {
            if d.is_some() {
                e -= self.mass[v] * (0..3).map(|i| self.gravity[i] * p[v][i]).sum::<f64>();
            }
        }
        Ok(e)
    }

    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<f64, SolverError> {
        let p = self.positions(x);
        g.fill(0.0);
        for &(a, b, rest, k) in &self.springs {
            let (n, l) = Self::spring_geometry(&p, a, b);
            for i in 0..3 {
                let f = k * (l - rest) * n[i];
                if let Some(d) = self.dof[b] {
                    g[d + i] += f;
                }
                if let Some(d) = self.dof[a] {
                    g[d + i] -= f;
                }
            }
        }
        for (v, d) in self.dof.iter().enumerate() {
            if let Some(d) = d {
                for i in 0..3 {
                    g[d + i] -= self.mass[v] * self.gravity[i];
                }
            }
        }
        self.value(x)
    }

    fn hessian(&mut self, x: &[f64], h: &mut SparseColMat<usize, f64>) -> Result<(), SolverError> {
        let p = self.positions(x);
        let val = h.val_mut();
        val.fill(0.0);
        for (s, &(a, b, rest, k)) in self.springs.iter().enumerate() {
            let (n, l) = Self::spring_geometry(&p, a, b);
            // K = k[(1 − L/ℓ) I + (L/ℓ) n nᵀ]; blocks (a,a), (b,b) = K, (a,b), (b,a) = −K.
            let mut kb = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    kb[i][j] = k * (rest / l) * n[i] * n[j];
                }
                kb[i][i] += k * (1.0 - rest / l);
            }
            for pp in 0..6 {
                for qq in 0..6 {
                    if let Some(o) = self.offsets[s][pp][qq] {
                        let sign = if (pp / 3) == (qq / 3) { 1.0 } else { -1.0 };
                        val[o] += sign * kb[pp % 3][qq % 3];
                    }
                }
            }
        }
        Ok(())
    }

    fn hessian_template(&self) -> SparseColMat<usize, f64> {
        self.template.clone()
    }

    fn force_scale(&self) -> f64 {
        self.force_scale
    }

    fn length_scale(&self) -> f64 {
        self.length_scale
    }

    fn dof_coordinates(&self) -> Option<Vec<[f64; 3]>> {
        let mut c = vec![[0.0; 3]; self.n_dofs];
        for (v, d) in self.dof.iter().enumerate() {
            if let Some(d) = d {
                for i in 0..3 {
                    c[d + i] = self.reference[v];
                }
            }
        }
        Some(c)
    }
}

/// Hanging chain: node 0 pinned at the origin, `n` free nodes of mass `m` below it, springs of
/// rest length `rest` and stiffness `k`, gravity g along −z.
pub fn chain(n: usize, m: f64, k: f64, rest: f64, g: f64, start: Vec<[f64; 3]>) -> SpringNet {
    let springs = (1..=n).map(|i| (i - 1, i, rest, k)).collect();
    let mass = vec![m; n + 1];
    SpringNet::new(
        start,
        springs,
        mass,
        [0.0, 0.0, -g],
        &[0],
        m * g * n as f64,
        rest,
    )
}

/// Analytic equilibrium heights of the chain: spring i (above node i) carries the weight of
/// nodes i..=n, so ℓ_i = L + m g (n − i + 1)/k and z_i = −Σ_{s ≤ i} ℓ_s.
pub fn chain_equilibrium_z(n: usize, m: f64, k: f64, rest: f64, g: f64) -> Vec<f64> {
    let mut z = vec![0.0];
    for i in 1..=n {
        let l = rest + m * g * (n - i + 1) as f64 / k;
        z.push(z[i - 1] - l);
    }
    z
}

/// A chain start crumpled into a ball of radius `r` below the pin: every spring is compressed,
/// so the Hessian is indefinite.
pub fn crumpled_start(n: usize, r: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Lcg64::new(seed);
    let mut p = vec![[0.0; 3]];
    for _ in 0..n {
        p.push([r * rng.signed(), r * rng.signed(), -r + r * rng.signed()]);
    }
    p
}

/// A rigid 3D lattice (`m`³ nodes, spacing 1, springs between all pairs closer than 1.8) rotated
/// by a fixed rotation; rest lengths from the rotated lattice, no gravity. Returns the net with
/// four non-coplanar corner nodes pinned and the reference (zero-energy) positions.
pub fn rigid_lattice(m: usize, k: f64) -> (SpringNet, Vec<[f64; 3]>) {
    let (c, s) = (0.6f64, 0.8f64); // rotation by atan(4/3) about z, then about x
    let rot = |p: [f64; 3]| {
        let q = [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]];
        [q[0], c * q[1] - s * q[2], s * q[1] + c * q[2]]
    };
    let mut reference = Vec::new();
    for i in 0..m {
        for j in 0..m {
            for l in 0..m {
                reference.push(rot([i as f64, j as f64, l as f64]));
            }
        }
    }
    let mut springs = Vec::new();
    for a in 0..reference.len() {
        for b in a + 1..reference.len() {
            let d: f64 = (0..3)
                .map(|i| (reference[a][i] - reference[b][i]).powi(2))
                .sum::<f64>()
                .sqrt();
            if d < 1.8 {
                springs.push((a, b, d, k));
            }
        }
    }
    let idx = |i: usize, j: usize, l: usize| (i * m + j) * m + l;
    let pinned = [
        idx(0, 0, 0),
        idx(m - 1, 0, 0),
        idx(0, m - 1, 0),
        idx(0, 0, m - 1),
    ];
    let n = reference.len();
    let net = SpringNet::new(
        reference.clone(),
        springs,
        vec![0.0; n],
        [0.0; 3],
        &pinned,
        k,
        1.0,
    );
    (net, reference)
}
