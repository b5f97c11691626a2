//! Whole-mesh assembly of energy, gradient and sparse Hessian.
//!
//! [`Assembler::new`] builds, once per (mesh, dofs, terms), the stencils, the lower-triangular
//! Hessian pattern over the free dofs and the *gather maps*: for every gradient coordinate and
//! every Hessian nonzero the list of per-face buffer entries that contribute to it, in a fixed
//! order. [`Assembler::evaluate`] then
//! 1. evaluates every face in parallel (rayon) into its own slot of a per-face buffer
//!    (gradient and the 21 vertex-pair 3×3 blocks of its Hessian), and
//! 2. gathers: every gradient coordinate and every nonzero sums its contributions in the
//!    precomputed order, in parallel over coordinates / nonzeros.
//!
//! Small passes (below `PARALLEL_MIN_WORK` face work or `PARALLEL_MIN_GATHER` entries) run on
//! the calling thread instead: handing them to rayon's pool costs more than they take.
//!
//! St. Venant–Kirchhoff evaluates energy and energy + gradient with the mid-edge average (the
//! form the paper authors' library shares) and with the edge-director forms, four faces at a
//! time, one face per SIMD lane (`batch`); every other material, and every Hessian, runs the
//! per-face kernels.
//!
//! No thread ever adds into shared memory, so results are bit-identical for any number of
//! threads (and on either path), and nothing is allocated per evaluation beyond rayon's
//! bookkeeping.

mod batch;
mod pattern;
mod per_face;
mod rest_sensitivity;

pub use per_face::FaceForms;

use crate::damping::FaceDamping;
use crate::dofs::{DofMap, check_len};
use crate::error::EnergyError;
use crate::kernel::{FaceEval, FaceRest, Want, eval_face, eval_face_energy};
use crate::material::EnergyConstants;
use crate::material::MaterialModel;
use crate::model::ShellModel;
use crate::rest::{DampingState, RestState};
use crate::sff::{EdgeDirector, MidEdgeAverage, SecondFundamentalForm, SffKind};
use crate::small_matrix::ProjectPsd;
use crate::stencil_table::Stencils;
use crate::terms::{EnergyTerms, HessianMode, Terms};
use faer::sparse::SparseColMat;
use nalgebra::{SMatrix, Vector3};
use pattern::{NONE, Pattern, TRANSPOSED, pair};
use rayon::prelude::*;
use thinshell_mesh::{FaceId, Mesh, VertexId};

/// Nonzeros per parallel work item of the Hessian gather.
const GATHER_CHUNK: usize = 2048;

/// Work (in units of one face's energy) below which a face pass runs on the calling thread
/// instead of rayon's pool. Handing work to the pool from outside it wakes a worker and puts the
/// caller to sleep until the worker is done: that costs more than the energy and gradient
/// passes of the seed's 184-face square, less than its Hessian pass, which stays parallel
/// (measured in docs/performance.md, "the seed protocols").
/// Faces write their own slots and every sum has a fixed order, so both paths give
/// bit-identical results. (The units are the per-face kernels'; the batched StVK passes cost
/// about a quarter of that per face, so they go parallel at a few times less work than this
/// aims for: not re-tuned.)
const PARALLEL_MIN_WORK: usize = 2048;

/// Gathered entries (gradient coordinates or Hessian nonzeros) below which a gather runs on
/// the calling thread: a gather costs a few ns per entry, so the pool's hand-off pays only
/// for tens of thousands of entries.
const PARALLEL_MIN_GATHER: usize = 1 << 14;

/// Work units per face of an evaluation (see [`PARALLEL_MIN_WORK`]): about the measured ratios
/// of the per-face cost of energy only, energy + gradient and energy + gradient + Hessian
/// (docs/performance.md).
fn face_work(want: Want) -> usize {
    match (want.gradient, want.hessian) {
        (false, None) => 1,
        (true, None) => 3,
        (_, Some(_)) => 16,
    }
}

/// Where [`Assembler::evaluate`] writes derivatives (the energy is always returned).
#[derive(Debug, Default)]
pub struct EvalOutput<'a> {
    /// Full gradient ∂E/∂x (N), length [`DofMap::n_coordinates`]: `3·n_vertices` entries
    /// vertex-major, then ∂E/∂φ_e (J/rad) per edge when the assembler has edge unknowns;
    /// including pinned coordinates; overwritten.
    pub gradient: Option<&'a mut [f64]>,
    /// Hessian ∂²E/∂x² (N/m) over the free dofs, lower triangle, in a matrix obtained from
    /// [`Assembler::hessian_template`]; its values are overwritten.
    pub hessian: Option<(&'a mut SparseColMat<usize, f64>, HessianMode)>,
}

/// Assembles energy, gradient and Hessian of a mesh. Owns the sparsity pattern, the gather
/// maps and the per-face buffers; build once per (mesh connectivity, [`DofMap`], [`Terms`]).
pub struct Assembler {
    terms: Terms,
    /// The edge-director form when the bending term uses edge-angle unknowns.
    director: Option<EdgeDirector>,
    n_vertices: usize,
    n_edges: usize,
    n_slots: usize,
    stencils: Stencils,
    pattern: Pattern,
    /// Per-face gradients of the last evaluation (layout: `pattern` module).
    grad_buffer: Vec<f64>,
    /// Per-face Hessian blocks of the last evaluation (layout: `pattern` module).
    hess_buffer: Vec<f64>,
    /// Per-face energies of the last evaluation.
    energies: Vec<EnergyTerms>,
    /// Whether `hess_buffer` holds Hessian blocks of the last evaluation.
    has_hessian: bool,
    /// Whether the edge-director forms' energy + gradient runs batched across faces
    /// ([`Assembler::set_batched_director_gradient`]).
    batched_director_gradient: bool,
}

impl std::fmt::Debug for Assembler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Assembler")
            .field("terms", &self.terms)
            .field("n_vertices", &self.n_vertices)
            .field("n_faces", &self.energies.len())
            .field("n_free", &self.n_free())
            .field("nnz", &self.nnz())
            .finish_non_exhaustive()
    }
}

impl Assembler {
    /// Precomputes stencils, pattern and gather maps for `mesh` with unknowns `dofs` (positions
    /// only) and the energy `terms`, for a second fundamental form without edge unknowns. The
    /// Hessian stencil of a face is its three vertices plus, when bending or damping is on, its
    /// flap vertices. Use [`Assembler::for_model`] for the edge-director forms.
    pub fn new(mesh: &Mesh, dofs: &DofMap, terms: Terms) -> Result<Assembler, EnergyError> {
        Self::build(mesh, dofs, terms, None, false)
    }

    /// Like [`Assembler::new`] for `model`'s terms and second fundamental form: with an
    /// edge-director form and bending on, every face stencil also holds its three edge angles,
    /// and `dofs` must carry one angle coordinate per edge ([`DofMap::with_edges`]). Without
    /// bending the angles do not enter the energy and `dofs` must have none.
    pub fn for_model(
        mesh: &Mesh,
        dofs: &DofMap,
        model: &ShellModel,
    ) -> Result<Assembler, EnergyError> {
        // A director form reads a free-edge fit's outer vertex for b whenever b is used (bending
        // or damping), with or without edge unknowns.
        let fit_vertices =
            model.sff.director().is_some() && (model.terms.bend || model.terms.damping);
        Self::build(mesh, dofs, model.terms, edge_director(model), fit_vertices)
    }

    fn build(
        mesh: &Mesh,
        dofs: &DofMap,
        terms: Terms,
        director: Option<EdgeDirector>,
        fit_vertices: bool,
    ) -> Result<Assembler, EnergyError> {
        check_len("dof map vertices", mesh.n_vertices(), dofs.n_vertices())?;
        match director {
            Some(d) => {
                check_len("dof map edges", mesh.n_edges(), dofs.n_edges()).map_err(|_| {
                    EnergyError::EdgeUnknownsMismatch {
                        sff: SffKind::EdgeDirector(d.variant),
                        needs: "needs",
                        other: "dof map",
                        has: "has no (or not one per edge) edge angles",
                    }
                })?
            }
            None if dofs.n_edges() > 0 => {
                return Err(EnergyError::EdgeUnknownsMismatch {
                    sff: SffKind::MidEdgeAverage,
                    needs: "does not use",
                    other: "dof map",
                    has: "has edge angles",
                });
            }
            None => {}
        }
        let n_slots = if terms.bend || terms.damping { 6 } else { 3 };
        let stencils = Stencils::new(mesh);
        let pattern = Pattern::new(&stencils, dofs, n_slots, director.is_some(), fit_vertices)?;
        Ok(Assembler {
            terms,
            director,
            n_vertices: mesh.n_vertices(),
            n_edges: if director.is_some() {
                mesh.n_edges()
            } else {
                0
            },
            n_slots,
            grad_buffer: vec![0.0; mesh.n_faces() * pattern.grad_stride],
            hess_buffer: vec![0.0; mesh.n_faces() * pattern.hess_stride],
            energies: vec![EnergyTerms::default(); mesh.n_faces()],
            stencils,
            pattern,
            has_hessian: false,
            batched_director_gradient: true,
        })
    }

    /// Whether energy + gradient evaluations of the edge-director forms run batched (four faces
    /// per SIMD lane set; about 5× fewer instructions per face than the per-face kernel, the
    /// same values to round-off; faces with fitted, clamped or mirror edges still take the
    /// per-face kernel). On by default; off routes every face through the per-face kernel,
    /// the reference the batched pass is tested against. The energy-only pass is batched
    /// either way.
    pub fn set_batched_director_gradient(&mut self, on: bool) {
        self.batched_director_gradient = on;
    }

    /// The terms this assembler was built for.
    pub fn terms(&self) -> Terms {
        self.terms
    }

    /// Whether the unknowns include one angle per edge (edge-director bending).
    pub fn has_edge_unknowns(&self) -> bool {
        self.director.is_some()
    }

    /// Length of the full gradient: `3·n_vertices`, plus one per edge with edge unknowns.
    pub fn n_coordinates(&self) -> usize {
        3 * self.n_vertices + self.n_edges
    }

    /// Number of free dofs (rows and columns of the Hessian).
    pub fn n_free(&self) -> usize {
        self.pattern.diagonal.len()
    }

    /// Number of stored Hessian entries (lower triangle).
    pub fn nnz(&self) -> usize {
        self.pattern.nz_block.len()
    }

    /// A Hessian with the assembler's pattern: `n_free × n_free`, lower triangle only, every
    /// diagonal entry present, all values 0. Allocate once and pass it to every evaluation.
    pub fn hessian_template(&self) -> SparseColMat<usize, f64> {
        SparseColMat::new(self.pattern.symbolic.clone(), vec![0.0; self.nnz()])
    }

    /// Position of the diagonal entry (d, d) in the Hessian's value array, per free dof (for
    /// adding mass or a regularisation μI in place).
    pub fn diagonal_offsets(&self) -> &[usize] {
        &self.pattern.diagonal
    }

    /// Energy terms (J) of `model.terms` at positions `x` (m, one per vertex) with the rest
    /// state `rest` and, when damping is on, the damping state; writes the gradient and/or
    /// Hessian requested in `out`. With neither requested (`EvalOutput::default()`, the
    /// line-search case) the faces run the lean energy-only kernel
    /// [`crate::eval_face_energy`] and no per-face buffer is touched. St. Venant–Kirchhoff runs
    /// batched across faces instead (the same values to round-off, 1e-13 relative): energy and
    /// energy + gradient, with the mid-edge average and the edge-director forms.
    ///
    /// Errors: `model.terms` differ from the assembler's ([`EnergyError::TermsMismatch`]);
    /// invalid material; wrong lengths; damping on without a [`DampingState`]; a Hessian not
    /// made by [`Assembler::hessian_template`]; a face producing NaN/inf
    /// ([`EnergyError::NonFinite`], the lowest such face).
    pub fn evaluate(
        &mut self,
        model: &ShellModel,
        x: &[Vector3<f64>],
        rest: &RestState,
        damping: Option<&DampingState>,
        out: EvalOutput<'_>,
    ) -> Result<EnergyTerms, EnergyError> {
        self.evaluate_with_angles(model, x, &[], rest, damping, out)
    }

    /// [`Assembler::evaluate`] with the edge angles `phi` (rad, one per edge) of an
    /// edge-director model; `phi` must be empty when the assembler has no edge unknowns. The
    /// model's second fundamental form must be the one the assembler was built for.
    pub fn evaluate_with_angles(
        &mut self,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
        damping: Option<&DampingState>,
        out: EvalOutput<'_>,
    ) -> Result<EnergyTerms, EnergyError> {
        let terms = model.terms;
        if terms != self.terms {
            return Err(EnergyError::TermsMismatch {
                assembler: self.terms,
                model: terms,
            });
        }
        if edge_director(model) != self.director {
            return Err(EnergyError::EdgeUnknownsMismatch {
                sff: model.sff,
                needs: if edge_director(model).is_some() {
                    "needs"
                } else {
                    "does not use"
                },
                other: "assembler",
                has: if self.director.is_some() {
                    "was built with edge angles (another form)"
                } else {
                    "was built without edge angles (`Assembler::new`): an edge-director form \
                     needs `DofMap::with_edges`, `Assembler::for_model` and \
                     `evaluate_with_angles` with the angles, or the solver's \
                     `ShellSystem::energy`, which minimises over them"
                },
            });
        }
        check_len("edge angles", self.n_edges, phi.len())?;
        model.material.validate()?;
        let n_faces = self.energies.len();
        check_len("positions", self.n_vertices, x.len())?;
        check_len("rest a_bar", n_faces, rest.a_bar.len())?;
        check_len("rest b_bar", n_faces, rest.b_bar.len())?;
        let damping = if terms.damping {
            let d = damping.ok_or(EnergyError::MissingDamping)?;
            check_len("damping a_prev", n_faces, d.a_prev.len())?;
            check_len("damping b_prev", n_faces, d.b_prev.len())?;
            if !(d.dt.is_finite() && d.dt > 0.0) {
                return Err(EnergyError::InvalidParameter {
                    name: "dt",
                    value: d.dt,
                    reason: "must be finite and > 0",
                });
            }
            Some(d)
        } else {
            None
        };
        let EvalOutput { gradient, hessian } = out;
        if let Some(g) = &gradient {
            check_len("gradient", self.n_coordinates(), g.len())?;
        }
        if let Some((h, _)) = &hessian {
            self.check_pattern(h)?;
        }
        let want = Want {
            gradient: gradient.is_some(),
            hessian: hessian.as_ref().map(|(_, mode)| *mode),
        };

        let parallel = n_faces.saturating_mul(face_work(want)) >= PARALLEL_MIN_WORK
            && rayon::current_num_threads() > 1;

        // One monomorphised per-face loop per form (adding a form adds an arm here); StVK runs
        // batched across faces where `batch` covers it.
        let batched = want.hessian.is_none() && model.material.model == MaterialModel::StVK;
        match model.sff {
            // The mid-edge batch has no mirror edges (model.md §1.4): their faces need the
            // per-face kernel, and its batched gradient pass has no fallback per face.
            SffKind::MidEdgeAverage if batched && !self.stencils.has_mirror_edges() => self
                .evaluate_faces_batched(
                    batch::Form::MidEdgeAverage,
                    model,
                    x,
                    rest,
                    damping,
                    want.gradient,
                    parallel,
                )?,
            SffKind::EdgeDirector(variant)
                if batched && (!want.gradient || self.batched_director_gradient) =>
            {
                self.evaluate_faces_batched(
                    batch::Form::EdgeDirector(variant, phi),
                    model,
                    x,
                    rest,
                    damping,
                    want.gradient,
                    parallel,
                )?
            }
            SffKind::MidEdgeAverage => self.evaluate_faces(
                &MidEdgeAverage,
                model,
                x,
                phi,
                rest,
                damping,
                want,
                parallel,
            )?,
            SffKind::EdgeDirector(variant) => self.evaluate_faces(
                &EdgeDirector { variant },
                model,
                x,
                phi,
                rest,
                damping,
                want,
                parallel,
            )?,
        }
        self.has_hessian = want.hessian.is_some();

        // Fixed-order sums: face order, independent of the thread count.
        let total = self
            .energies
            .iter()
            .fold(EnergyTerms::default(), |mut acc, e| {
                acc += *e;
                acc
            });
        if let Some(g) = gradient {
            self.gather_gradient(g, parallel && g.len() >= PARALLEL_MIN_GATHER);
        }
        if let Some((h, _)) = hessian {
            let values = h.val_mut();
            let parallel = parallel && values.len() >= PARALLEL_MIN_GATHER;
            self.gather_hessian_values(values, parallel);
        }
        Ok(total)
    }

    /// The energy or energy + gradient pass of StVK with `form`, [`batch::LANES`] faces at a
    /// time ([`batch`]), in parallel over chunks of [`batch::CHUNK`] faces or on the
    /// calling thread (the same per-face results either way), into `self.energies` and the
    /// gradient slots.
    #[allow(clippy::too_many_arguments)] // mirrors `evaluate_with_angles`
    fn evaluate_faces_batched(
        &mut self,
        form: batch::Form<'_>,
        model: &ShellModel,
        x: &[Vector3<f64>],
        rest: &RestState,
        damping: Option<&DampingState>,
        gradient: bool,
        parallel: bool,
    ) -> Result<(), EnergyError> {
        let inputs = batch::Inputs {
            constants: batch::Constants::new(&model.material, damping),
            form,
            material: &model.material,
            energy_constants: EnergyConstants::new(&model.material),
            terms: model.terms,
            stencils: &self.stencils,
            x,
            rest,
            damping,
            slots: self.n_slots,
            grad_stride: self.pattern.grad_stride,
        };
        let arch = pulp::Arch::new();
        let chunk = |(c, slots): (usize, batch::FaceSlots2<'_>)| {
            arch.dispatch(batch::ChunkOp {
                inputs: &inputs,
                first: c * batch::CHUNK,
                slots,
                gradient,
            })
        };
        let stride = batch::CHUNK * self.pattern.grad_stride;
        let bad_face = if parallel {
            self.energies
                .par_chunks_mut(batch::CHUNK)
                .zip(self.grad_buffer.par_chunks_mut(stride))
                .enumerate()
                .filter_map(chunk)
                .min()
        } else {
            self.energies
                .chunks_mut(batch::CHUNK)
                .zip(self.grad_buffer.chunks_mut(stride))
                .enumerate()
                .filter_map(chunk)
                .min()
        };
        match bad_face {
            Some(f) => Err(EnergyError::NonFinite {
                face: FaceId::new(f),
            }),
            None => Ok(()),
        }
    }

    /// Per-face kernels ([`eval_face`] over the form's N dofs), in parallel, into the per-face
    /// buffers and `self.energies`. Slot s < 6 (a stencil vertex) takes face dofs 3s..3s+3;
    /// an edge slot (s ≥ 6, edge unknowns only) takes dof 18 + s − 6 on axis 0, zeros
    /// elsewhere. Without edge unknowns a form's extra dofs (angles held at 0) are dropped.
    #[allow(clippy::too_many_arguments)] // mirrors `evaluate_with_angles`
    fn evaluate_faces<const N: usize, F>(
        &mut self,
        form: &F,
        model: &ShellModel,
        x: &[Vector3<f64>],
        phi: &[f64],
        rest: &RestState,
        damping: Option<&DampingState>,
        want: Want,
        parallel: bool,
    ) -> Result<(), EnergyError>
    where
        F: SecondFundamentalForm<N> + ?Sized,
        SMatrix<f64, N, N>: ProjectPsd,
    {
        let with_angles = self.director.is_some();
        let stencils = &self.stencils;
        if !want.gradient && want.hessian.is_none() {
            // Energy only (every line-search trial): the lean kernel, no per-face buffers.
            let constants = EnergyConstants::new(&model.material);
            let face = |(f, energy): (usize, &mut EnergyTerms)| {
                let stencil = if with_angles {
                    stencils.stencil_at(f, x, phi)
                } else {
                    stencils.stencil(f, x)
                };
                let (face_rest, face_damping) = face_data(rest, damping, f);
                *energy = eval_face_energy(
                    form,
                    &model.material,
                    &constants,
                    &stencil,
                    &face_rest,
                    face_damping.as_ref(),
                    model.terms,
                );
                (!energy.total().is_finite()).then_some(f)
            };
            let bad_face = if parallel {
                self.energies
                    .par_iter_mut()
                    .enumerate()
                    .map(face)
                    .flatten()
                    .min()
            } else {
                self.energies.iter_mut().enumerate().filter_map(face).min()
            };
            return match bad_face {
                Some(f) => Err(EnergyError::NonFinite {
                    face: FaceId::new(f),
                }),
                None => Ok(()),
            };
        }
        let slots = self.pattern.slots;
        let vertex_slots = slots.min(6);
        let (grad_stride, hess_stride) = (self.pattern.grad_stride, self.pattern.hess_stride);
        let copy_gradient = want.gradient || want.hessian.is_some();
        let pair_offset = &self.pattern.pair_offset[..];
        let face = |fe: &mut FaceEval<N>, (f, ((grad, hess), energy)): FaceSlots<'_>| {
            let stencil = if with_angles {
                stencils.stencil_at(f, x, phi)
            } else {
                stencils.stencil(f, x)
            };
            let (face_rest, face_damping) = face_data(rest, damping, f);
            eval_face(
                form,
                &model.material,
                &stencil,
                &face_rest,
                face_damping.as_ref(),
                model.terms,
                want,
                fe,
            );
            *energy = fe.energy;
            let mut finite = fe.energy.total().is_finite();
            if copy_gradient {
                let g = fe.gradient.as_slice();
                grad[..3 * vertex_slots].copy_from_slice(&g[..3 * vertex_slots]);
                for s in 6..slots {
                    grad[3 * s] = g[18 + s - 6];
                    grad[3 * s + 1] = 0.0;
                    grad[3 * s + 2] = 0.0;
                }
                finite &= all_finite(grad);
            }
            if want.hessian.is_some() {
                // Each slot pair's block at its real size (see `pattern`): nalgebra is
                // column-major, so column 3 s2 + c of a vertex pair holds rows 3 s1 .. 3 s1 + 3;
                // an edge slot s ≥ 6 is the single local dof 18 + s − 6. Every value is read
                // from the same local entry (not its symmetric twin) as with padded blocks.
                let h = fe.hessian.as_slice();
                for s1 in 0..vertex_slots {
                    for s2 in 0..=s1 {
                        let o = pair_offset[pair(s1, s2)];
                        let b = &mut hess[o..o + 9];
                        for c in 0..3 {
                            let col = N * (3 * s2 + c) + 3 * s1;
                            b[3 * c..3 * c + 3].copy_from_slice(&h[col..col + 3]);
                        }
                    }
                }
                for s1 in vertex_slots..slots {
                    let i = 18 + s1 - 6;
                    // Vertex–edge: a 1×3 block, entry c at c.
                    for s2 in 0..vertex_slots {
                        let o = pair_offset[pair(s1, s2)];
                        let b = &mut hess[o..o + 3];
                        for c in 0..3 {
                            b[c] = h[N * (3 * s2 + c) + i];
                        }
                    }
                    // Edge–edge: 1×1.
                    for s2 in vertex_slots..=s1 {
                        hess[pair_offset[pair(s1, s2)]] = h[N * (18 + s2 - 6) + i];
                    }
                }
                finite &= all_finite(hess);
            }
            (!finite).then_some(f)
        };
        let bad_face = if parallel {
            self.grad_buffer
                .par_chunks_mut(grad_stride)
                .zip(self.hess_buffer.par_chunks_mut(hess_stride))
                .zip(self.energies.par_iter_mut())
                .enumerate()
                .map_init(FaceEval::<N>::default, face)
                .flatten()
                .min()
        } else {
            let mut fe = FaceEval::<N>::default();
            self.grad_buffer
                .chunks_mut(grad_stride)
                .zip(self.hess_buffer.chunks_mut(hess_stride))
                .zip(self.energies.iter_mut())
                .enumerate()
                .filter_map(|item| face(&mut fe, item))
                .min()
        };
        match bad_face {
            Some(f) => Err(EnergyError::NonFinite {
                face: FaceId::new(f),
            }),
            None => Ok(()),
        }
    }

    /// Gradient gather: each vertex (and edge) sums its face slots in the precomputed order;
    /// in parallel or on the calling thread (the same sums either way).
    fn gather_gradient(&self, gradient: &mut [f64], parallel: bool) {
        let p = &self.pattern;
        let buf = &self.grad_buffer;
        let (positions, angles) = gradient.split_at_mut(3 * self.n_vertices);
        let edge = |(e, g): (usize, &mut f64)| {
            let node = p.n_vertices + e;
            *g = p.grad_src[p.grad_ptr[node]..p.grad_ptr[node + 1]]
                .iter()
                .fold(0.0, |s, &src| s + buf[src as usize]);
        };
        let vertex = |(v, g): (usize, &mut [f64])| {
            let mut s = [0.0; 3];
            for &src in &p.grad_src[p.grad_ptr[v]..p.grad_ptr[v + 1]] {
                let src = src as usize;
                s[0] += buf[src];
                s[1] += buf[src + 1];
                s[2] += buf[src + 2];
            }
            g.copy_from_slice(&s);
        };
        if parallel {
            angles.par_iter_mut().enumerate().for_each(edge);
            positions.par_chunks_mut(3).enumerate().for_each(vertex);
        } else {
            angles.iter_mut().enumerate().for_each(edge);
            positions.chunks_mut(3).enumerate().for_each(vertex);
        }
    }

    /// Hessian gather: each nonzero sums its face-block entries in the precomputed order; in
    /// parallel or on the calling thread (the same sums either way).
    fn gather_hessian_values(&self, values: &mut [f64], parallel: bool) {
        let p = &self.pattern;
        let buf = &self.hess_buffer;
        let chunk = |(chunk, vals): (usize, &mut [f64])| {
            let start = chunk * GATHER_CHUNK;
            for (i, val) in vals.iter_mut().enumerate() {
                let k = start + i;
                let blk = p.nz_block[k] as usize;
                // Where this entry sits in a face block read untransposed / transposed.
                let [off, off_t] = p.nz_src_offset[k].map(usize::from);
                let mut s = 0.0;
                for &src in &p.block_src[p.block_ptr[blk]..p.block_ptr[blk + 1]] {
                    let base = (src & !TRANSPOSED) as usize;
                    s += buf[base + if src & TRANSPOSED != 0 { off_t } else { off }];
                }
                *val = s;
            }
        };
        if parallel {
            values
                .par_chunks_mut(GATHER_CHUNK)
                .enumerate()
                .for_each(chunk);
            return;
        }
        // On the calling thread, block by block: each face block's nine entries are read once
        // and contiguously (the per-nonzero loop re-reads a block's source list for each of its
        // entries; blocks write scattered positions, hence not the parallel path). Every entry
        // sums its sources in the same order from 0, so the bits are those of the loop above.
        for (blk, offsets) in p.block_offsets.iter().enumerate() {
            // Row-major entries e = 3a + c; face blocks are stored column-major, at the real
            // size `rows × cols` of the block's nodes (entries beyond it have no dof).
            let mut acc = [0.0f64; 9];
            let sources = &p.block_src[p.block_ptr[blk]..p.block_ptr[blk + 1]];
            match p.block_dims[blk] {
                [3, 3] => {
                    for &src in sources {
                        let base = (src & !TRANSPOSED) as usize;
                        let b = &buf[base..base + 9];
                        if src & TRANSPOSED != 0 {
                            for (a, v) in acc.iter_mut().zip(b) {
                                *a += v;
                            }
                        } else {
                            for r in 0..3 {
                                for c in 0..3 {
                                    acc[3 * r + c] += b[3 * c + r];
                                }
                            }
                        }
                    }
                }
                // Blocks with an edge node are its row (edge nodes come after all vertices),
                // stored as a single row: vertex–edge 1×3, edge–edge 1×1. A one-row block
                // reads the same transposed or not (entry (0, c) at c), so the flag is moot.
                [1, 3] => {
                    for &src in sources {
                        let base = (src & !TRANSPOSED) as usize;
                        for (a, v) in acc[..3].iter_mut().zip(&buf[base..base + 3]) {
                            *a += v;
                        }
                    }
                }
                _ => {
                    debug_assert_eq!(p.block_dims[blk], [1, 1]);
                    for &src in sources {
                        acc[0] += buf[(src & !TRANSPOSED) as usize];
                    }
                }
            }
            for (&o, &a) in offsets.iter().zip(&acc) {
                if o != NONE {
                    values[o as usize] = a;
                }
            }
        }
    }

    /// Refills `hessian`'s values from the per-face blocks of the last [`Assembler::evaluate`]
    /// that computed a Hessian (the gather step alone: for benchmarks, or to fill a second
    /// matrix). Errors if there is none or the pattern differs.
    pub fn gather_hessian(
        &self,
        hessian: &mut SparseColMat<usize, f64>,
    ) -> Result<(), EnergyError> {
        self.check_pattern(hessian)?;
        if !self.has_hessian {
            return Err(EnergyError::NoHessianEvaluated);
        }
        let parallel =
            hessian.val().len() >= PARALLEL_MIN_GATHER && rayon::current_num_threads() > 1;
        self.gather_hessian_values(hessian.val_mut(), parallel);
        Ok(())
    }

    /// Clamps the boundary edges `edges` for the edge-director forms (model.md §1.3): their
    /// directors stay where they are at the reference positions `x_ref` (m); see
    /// [`Stencils::set_clamped_edges`]. Without an edge-director form the clamp acts through
    /// held vertices only and this is a no-op apart from the checks. Errors on an edge out of
    /// range or a wrong length of `x_ref`.
    pub fn clamp_edges(
        &mut self,
        edges: &[thinshell_mesh::EdgeId],
        x_ref: &[Vector3<f64>],
    ) -> Result<(), EnergyError> {
        self.stencils.set_clamped_edges(edges, x_ref)
    }

    /// Makes `edges` mirror edges on symmetry planes with the given normals (model.md §1.4);
    /// see [`Stencils::set_mirror_edges`]. Read by the edge-director forms only. Same errors.
    pub fn set_mirror_edges(
        &mut self,
        edges: &[(thinshell_mesh::EdgeId, Vector3<f64>)],
    ) -> Result<(), EnergyError> {
        self.stencils.set_mirror_edges(edges)
    }

    /// Kelvin–Voigt damping forms of the configuration (`x_prev` m, `phi_prev` rad or empty)
    /// at the start of a step of `dt` s, as [`DampingState::from_configuration`] but through
    /// this assembler's stencils, so that clamped edges (model.md §1.3) enter b^prev as they
    /// enter b. Same errors.
    pub fn damping_state(
        &self,
        x_prev: &[Vector3<f64>],
        phi_prev: &[f64],
        sff: SffKind,
        dt: f64,
    ) -> Result<DampingState, EnergyError> {
        DampingState::with_stencils(&self.stencils, x_prev, phi_prev, sff, dt)
    }

    /// Per-face energies (J) of the last evaluation, in face order.
    pub fn face_energies(&self) -> &[EnergyTerms] {
        &self.energies
    }

    /// Adds the symmetric part `(B + Bᵀ)/2` of a 9×9 block `B` over face `f`'s three vertices
    /// (dofs `x_i, x_j, x_k`, 3 coordinates each, N/m) to `hessian`'s lower triangle; pinned
    /// coordinates are skipped. For per-face loads such as pressure.
    pub fn add_face_block(
        &self,
        f: FaceId,
        block: &SMatrix<f64, 9, 9>,
        hessian: &mut SparseColMat<usize, f64>,
    ) -> Result<(), EnergyError> {
        self.check_pattern(hessian)?;
        self.add_face_block_unchecked(f, block, hessian.val_mut())
    }

    /// [`add_face_block`](Self::add_face_block) for every face: `block_of(f)` gives face `f`'s
    /// 9×9 block. The pattern is checked once, not once per face (the check compares the whole
    /// pattern, so per-face checks made a pressure Hessian cost faces × nonzeros).
    pub fn add_face_blocks(
        &self,
        mut block_of: impl FnMut(FaceId) -> SMatrix<f64, 9, 9>,
        hessian: &mut SparseColMat<usize, f64>,
    ) -> Result<(), EnergyError> {
        self.check_pattern(hessian)?;
        let values = hessian.val_mut();
        for f in 0..self.pattern.face_blocks.len() {
            let f = FaceId::new(f);
            self.add_face_block_unchecked(f, &block_of(f), values)?;
        }
        Ok(())
    }

    /// Adds face `f`'s block into the values of a Hessian with this assembler's pattern.
    fn add_face_block_unchecked(
        &self,
        f: FaceId,
        block: &SMatrix<f64, 9, 9>,
        values: &mut [f64],
    ) -> Result<(), EnergyError> {
        let blocks = self
            .pattern
            .face_blocks
            .get(f.idx())
            .ok_or(EnergyError::FaceOutOfRange {
                face: f,
                n_faces: self.energies.len(),
            })?;
        for s1 in 0..3 {
            for s2 in 0..=s1 {
                let gb = blocks[pair(s1, s2)];
                let offsets = &self.pattern.block_offsets[(gb & !TRANSPOSED) as usize];
                let transposed = gb & TRANSPOSED != 0;
                for a in 0..3 {
                    for c in 0..3 {
                        let (i, j) = (3 * s1 + a, 3 * s2 + c);
                        let e = if transposed { 3 * c + a } else { 3 * a + c };
                        let o = offsets[e];
                        if o != NONE {
                            values[o as usize] += 0.5 * (block[(i, j)] + block[(j, i)]);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Whether `h` has exactly this assembler's Hessian pattern (size, column pointers, row
    /// indices): a matrix made by [`Assembler::hessian_template`] of this or an identical
    /// assembler. Costs one comparison of the pattern arrays, no allocation.
    pub fn has_pattern(&self, h: &SparseColMat<usize, f64>) -> bool {
        self.check_pattern(h).is_ok()
    }

    /// `Err` unless `h` has exactly this assembler's pattern.
    fn check_pattern(&self, h: &SparseColMat<usize, f64>) -> Result<(), EnergyError> {
        let (mine, theirs) = (self.pattern.symbolic.as_ref(), h.symbolic());
        let same = theirs.nrows() == mine.nrows()
            && theirs.ncols() == mine.ncols()
            && theirs.col_ptr() == mine.col_ptr()
            && theirs.col_nnz().is_none()
            && theirs.row_idx() == mine.row_idx();
        if same {
            Ok(())
        } else {
            Err(EnergyError::HessianPatternMismatch)
        }
    }

    /// Vertex slots per face stencil: 3 (stretching only) or 6 (with flap vertices).
    pub fn stencil_size(&self) -> usize {
        self.n_slots
    }

    /// The stencil vertices of face `f` (see [`Stencils::vertices`]); `None` out of range.
    pub fn stencil_vertices(&self, f: FaceId) -> Option<&[VertexId; 6]> {
        (f.idx() < self.stencils.n_faces()).then(|| self.stencils.vertices(f.idx()))
    }
}

/// One face's index and its slots of the per-face buffers: gradient, Hessian blocks, energies.
type FaceSlots<'a> = (usize, ((&'a mut [f64], &'a mut [f64]), &'a mut EnergyTerms));

/// Rest forms and (when damping) previous-step forms of face `f`.
fn face_data(
    rest: &RestState,
    damping: Option<&DampingState>,
    f: usize,
) -> (FaceRest, Option<FaceDamping>) {
    let face_rest = FaceRest {
        a_bar: rest.a_bar[f],
        b_bar: rest.b_bar[f],
    };
    let face_damping = damping.map(|d| FaceDamping {
        a_prev: d.a_prev[f],
        b_prev: d.b_prev[f],
        dt: d.dt,
    });
    (face_rest, face_damping)
}

/// The edge-director form whose angles are unknowns of `model`: a director form with bending on
/// (without bending the angles would not enter the energy).
fn edge_director(model: &ShellModel) -> Option<EdgeDirector> {
    model.sff.director().filter(|_| model.has_edge_unknowns())
}

/// Whether every entry is finite. `x · 0` is 0 for finite x and NaN for NaN or ±inf (and, unlike
/// a plain sum, cannot overflow); four independent lanes keep the adds pipelined.
fn all_finite(v: &[f64]) -> bool {
    let mut acc = [0.0f64; 4];
    let chunks = v.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for (a, x) in acc.iter_mut().zip(c) {
            *a += x * 0.0;
        }
    }
    for (a, x) in acc.iter_mut().zip(rest) {
        *a += x * 0.0;
    }
    acc.iter().all(|a| *a == 0.0)
}
