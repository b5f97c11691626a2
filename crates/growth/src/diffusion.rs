//! Diffusion of the stimulus through the thickness on the prism mesh (model.md §4.1).
//!
//! The triangle mesh is extruded through the thickness into `L ≥ 1` layers of 6-node wedges;
//! node `(layer l, vertex v)` has index `l·n_vertices + v`, layer 0 is the bottom surface
//! (z = −h/2) and layer L the top (z = +h/2). A wedge's shape functions are products of the
//! triangle's barycentric functions and the layer's linear functions of z, so its consistent
//! mass and stiffness are Kronecker products of the triangle's and the interval's:
//! `M = M_tri ⊗ M_z`, `K = D (K_tri ⊗ M_z + M_tri ⊗ K_z)`, built on the rest geometry a⁰.
//! Backward Euler `(M/Δt + K) mⁿ⁺¹ = M mⁿ/Δt + f` is solved with a sparse Cholesky factor
//! computed once per Δt; fixed values are eliminated, fluxes enter `f`, every other boundary
//! (including the shell's edges) is insulated.

use faer::prelude::Solve;
use faer::sparse::linalg::solvers::Llt;
use faer::sparse::{SparseColMat, Triplet};
use faer::{MatMut, Side};
use nalgebra::Matrix2;
use thinshell_energy::RestState;
use thinshell_mesh::Mesh;

use crate::error::{GrowthError, check, check_len};
use crate::field::StimulusField;
use crate::stimulus::FaceStimulus;

/// Which surface of the shell a source acts on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// z = +h/2, the side the face normals point to.
    Top,
    /// z = −h/2.
    Bottom,
}

/// What a source imposes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SourceKind {
    /// The stimulus is held at this value (from the first step on).
    Value(f64),
    /// Inflow per unit area and time (stimulus·m/s); negative drains.
    Flux(f64),
}

/// A boundary source on the faces `faces[f] == true` of one surface.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffusionSource {
    /// The surface.
    pub surface: Surface,
    /// Per face, whether the source covers it (see [`crate::Region::faces`]).
    pub faces: Vec<bool>,
    /// Fixed value or flux.
    pub kind: SourceKind,
}

/// Parameters of the through-thickness diffusion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffusionSettings {
    /// Diffusivity D, m²/s.
    pub diffusivity: f64,
    /// Shell thickness h, m.
    pub thickness: f64,
    /// Prism layers through the thickness (≥ 1).
    pub layers: usize,
    /// Initial stimulus everywhere.
    pub initial: f64,
}

/// Symmetric sparse matrix as rows of (column, value), used for products only.
type Rows = Vec<Vec<(usize, f64)>>;

/// The stimulus on the prism mesh and its backward-Euler diffusion solver.
pub struct Diffusion {
    n_vertices: usize,
    layers: usize,
    thickness: f64,
    faces: Vec<[usize; 3]>,
    m: Vec<f64>,
    mass: Rows,
    stiffness: Rows,
    node_volume: Vec<f64>,
    fixed: Vec<Option<f64>>,
    free_index: Vec<Option<usize>>,
    flux: Vec<f64>,
    factor: Option<(f64, Llt<usize, f64>)>,
    factorizations: usize,
    rhs: Vec<f64>,
    values: Vec<FaceStimulus>,
    means: Vec<f64>,
}

impl std::fmt::Debug for Diffusion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Diffusion")
            .field("n_nodes", &self.m.len())
            .field("layers", &self.layers)
            .field("factorizations", &self.factorizations)
            .finish_non_exhaustive()
    }
}

fn merge(mut t: Vec<(usize, usize, f64)>, n: usize) -> Rows {
    t.sort_unstable_by_key(|&(i, j, _)| (i, j));
    let mut rows: Rows = vec![Vec::new(); n];
    for (i, j, v) in t {
        match rows[i].last_mut() {
            Some((c, acc)) if *c == j => *acc += v,
            _ => rows[i].push((j, v)),
        }
    }
    rows
}

impl Diffusion {
    /// Builds the prism mesh of `mesh` with rest geometry `rest.a_bar` (the initial forms a⁰),
    /// and applies `sources`. Errors on invalid settings, mismatched lengths, or a degenerate
    /// rest metric.
    pub fn new(
        mesh: &Mesh,
        rest: &RestState,
        settings: DiffusionSettings,
        sources: &[DiffusionSource],
    ) -> Result<Diffusion, GrowthError> {
        let DiffusionSettings {
            diffusivity: d,
            thickness: h,
            layers,
            initial,
        } = settings;
        check("diffusivity", d, d > 0.0, "must be positive")?;
        check("thickness", h, h > 0.0, "must be positive")?;
        check("layers", layers as f64, layers >= 1, "must be at least 1")?;
        check("initial", initial, true, "must be finite")?;
        check_len("rest a_bar", mesh.n_faces(), rest.a_bar.len())?;
        rest.validate(mesh)?;
        let nv = mesh.n_vertices();
        let n = nv * (layers + 1);
        let faces: Vec<[usize; 3]> = mesh.faces_usize();
        let dz = h / layers as f64;
        let mz = [[dz / 3.0, dz / 6.0], [dz / 6.0, dz / 3.0]];
        let kz = [[1.0 / dz, -1.0 / dz], [-1.0 / dz, 1.0 / dz]];
        // Barycentric gradients in (u, v): λ0 = 1 − u − v, λ1 = u, λ2 = v.
        let g = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
        let mut tm = Vec::with_capacity(faces.len() * layers * 36);
        let mut tk = Vec::with_capacity(faces.len() * layers * 36);
        let mut area = Vec::with_capacity(faces.len());
        for (face, a) in faces.iter().zip(&rest.a_bar) {
            let ar = 0.5 * a.determinant().sqrt();
            let ai: Matrix2<f64> = a.try_inverse().unwrap_or_else(Matrix2::zeros);
            area.push(ar);
            let mut mt = [[0.0; 3]; 3];
            let mut kt = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    mt[i][j] = ar / 12.0 * if i == j { 2.0 } else { 1.0 };
                    let gi = nalgebra::Vector2::new(g[i][0], g[i][1]);
                    let gj = nalgebra::Vector2::new(g[j][0], g[j][1]);
                    kt[i][j] = ar * gi.dot(&(ai * gj));
                }
            }
            for l in 0..layers {
                for (i, s) in (0..3).flat_map(|i| [(i, 0), (i, 1)]) {
                    let p = (l + s) * nv + face[i];
                    for (j, t) in (0..3).flat_map(|j| [(j, 0), (j, 1)]) {
                        let q = (l + t) * nv + face[j];
                        tm.push((p, q, mt[i][j] * mz[s][t]));
                        tk.push((p, q, d * (kt[i][j] * mz[s][t] + mt[i][j] * kz[s][t])));
                    }
                }
            }
        }
        let mass = merge(tm, n);
        let stiffness = merge(tk, n);
        let node_volume = mass.iter().map(|r| r.iter().map(|e| e.1).sum()).collect();

        let mut fixed = vec![None; n];
        let mut flux = vec![0.0; n];
        for src in sources {
            check_len("source faces", faces.len(), src.faces.len())?;
            let layer = match src.surface {
                Surface::Top => layers,
                Surface::Bottom => 0,
            };
            for (f, face) in faces.iter().enumerate().filter(|(f, _)| src.faces[*f]) {
                for &v in face {
                    let node = layer * nv + v;
                    match src.kind {
                        SourceKind::Value(val) => {
                            check("source value", val, true, "must be finite")?;
                            fixed[node] = Some(val);
                        }
                        SourceKind::Flux(q) => {
                            check("source flux", q, true, "must be finite")?;
                            // ∫ q λ_i dA = q·A/3 for a constant flux.
                            flux[node] += q * area[f] / 3.0;
                        }
                    }
                }
            }
        }
        let mut free_index = vec![None; n];
        let mut k = 0;
        for (slot, fx) in free_index.iter_mut().zip(&fixed) {
            if fx.is_none() {
                *slot = Some(k);
                k += 1;
            }
        }
        let mut out = Diffusion {
            n_vertices: nv,
            layers,
            thickness: h,
            faces,
            m: vec![initial; n],
            mass,
            stiffness,
            node_volume,
            fixed,
            free_index,
            flux,
            factor: None,
            factorizations: 0,
            rhs: vec![0.0; k],
            values: Vec::new(),
            means: Vec::new(),
        };
        out.update_faces();
        Ok(out)
    }

    /// Node values (index `layer·n_vertices + vertex`, layer 0 = bottom).
    pub fn node_values(&self) -> &[f64] {
        &self.m
    }

    /// Replaces the node values (e.g. a non-uniform initial field). Fixed nodes keep theirs
    /// from the next step on.
    pub fn set_node_values(&mut self, values: &[f64]) -> Result<(), GrowthError> {
        check_len("node values", self.m.len(), values.len())?;
        if let Some(&v) = values.iter().find(|v| !v.is_finite()) {
            return Err(GrowthError::InvalidParameter {
                name: "node value",
                value: v,
                reason: "must be finite",
            });
        }
        self.m.copy_from_slice(values);
        self.update_faces();
        Ok(())
    }

    /// Layers L through the thickness.
    pub fn layers(&self) -> usize {
        self.layers
    }

    /// Total amount ∫ m dV = Σᵢⱼ Mᵢⱼ mⱼ (stimulus·m³); conserved without sources.
    pub fn total(&self) -> f64 {
        self.node_volume
            .iter()
            .zip(&self.m)
            .map(|(w, m)| w * m)
            .sum()
    }

    /// Number of matrix factorisations so far (one per distinct Δt).
    pub fn factorizations(&self) -> usize {
        self.factorizations
    }

    fn factorize(&mut self, dt: f64) -> Result<(), GrowthError> {
        let n_free = self.rhs.len();
        let mut triplets = Vec::new();
        for (i, (mr, kr)) in self.mass.iter().zip(&self.stiffness).enumerate() {
            let Some(fi) = self.free_index[i] else {
                continue;
            };
            // M and K share the wedge pattern, so their rows hold the same columns.
            for (&(j, mv), &(_, kv)) in mr.iter().zip(kr) {
                if let Some(fj) = self.free_index[j].filter(|&fj| fj >= fi) {
                    triplets.push(Triplet::new(fj, fi, mv / dt + kv));
                }
            }
        }
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n_free, n_free, &triplets)
            .map_err(|e| GrowthError::Factorization(format!("{e:?}")))?;
        let llt = a
            .sp_cholesky(Side::Lower)
            .map_err(|e| GrowthError::Factorization(format!("{e:?}")))?;
        self.factor = Some((dt, llt));
        self.factorizations += 1;
        Ok(())
    }

    /// One backward-Euler step of length `dt` (s).
    pub fn step(&mut self, dt: f64) -> Result<(), GrowthError> {
        check("dt", dt, dt > 0.0, "must be positive")?;
        if self.rhs.is_empty() {
            self.apply_fixed();
            self.update_faces();
            return Ok(());
        }
        if self.factor.as_ref().is_none_or(|(d, _)| *d != dt) {
            self.factorize(dt)?;
        }
        for (i, (row, kr)) in self.mass.iter().zip(&self.stiffness).enumerate() {
            let Some(fi) = self.free_index[i] else {
                continue;
            };
            let mut r = self.flux[i];
            for (&(j, mv), &(_, kv)) in row.iter().zip(kr) {
                r += mv * self.m[j] / dt;
                if let Some(val) = self.fixed[j] {
                    r -= (mv / dt + kv) * val;
                }
            }
            self.rhs[fi] = r;
        }
        let n_free = self.rhs.len();
        if let Some((_, llt)) = &self.factor {
            llt.solve_in_place(MatMut::from_column_major_slice_mut(
                &mut self.rhs,
                n_free,
                1,
            ));
        }
        for (i, slot) in self.free_index.iter().enumerate() {
            if let Some(fi) = slot {
                self.m[i] = self.rhs[*fi];
            }
        }
        self.apply_fixed();
        self.update_faces();
        Ok(())
    }

    fn apply_fixed(&mut self) {
        for (m, fx) in self.m.iter_mut().zip(&self.fixed) {
            if let Some(v) = fx {
                *m = *v;
            }
        }
    }

    fn update_faces(&mut self) {
        let nv = self.n_vertices;
        let (l, m) = (self.layers, &self.m);
        // Through-thickness mean per vertex: exact integral of the piecewise-linear profile.
        let vertex_mean = |v: usize| {
            let ends = 0.5 * (m[v] + m[l * nv + v]);
            let inner: f64 = (1..l).map(|k| m[k * nv + v]).sum();
            (ends + inner) / l as f64
        };
        self.values.clear();
        self.means.clear();
        for f in &self.faces {
            let top = f.iter().map(|&v| m[l * nv + v]).sum::<f64>() / 3.0;
            let bottom = f.iter().map(|&v| m[v]).sum::<f64>() / 3.0;
            self.values.push(FaceStimulus { top, bottom });
            self.means
                .push(f.iter().map(|&v| vertex_mean(v)).sum::<f64>() / 3.0);
        }
    }

    /// Shell thickness h (m) of the prism mesh.
    pub fn thickness(&self) -> f64 {
        self.thickness
    }
}

impl StimulusField for Diffusion {
    fn values(&self) -> &[FaceStimulus] {
        &self.values
    }
    fn advance(&mut self, _t: f64, dt: f64) -> Result<bool, GrowthError> {
        let before = self.values.clone();
        self.step(dt)?;
        Ok(before != self.values)
    }
    fn mean(&self, face: usize) -> f64 {
        self.means.get(face).copied().unwrap_or(0.0)
    }
    fn name(&self) -> &'static str {
        "diffusion"
    }
    fn save_state(&self) -> Vec<f64> {
        self.m.clone()
    }
    fn restore_state(&mut self, state: &[f64]) -> Result<(), GrowthError> {
        self.set_node_values(state)
    }
}
