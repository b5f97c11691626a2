//! Checkpoints: [`Simulation::save`] writes the whole state a run needs to continue bit for bit,
//! [`Simulation::restore`] reads it back into a simulation built from the same scene.
//!
//! # Format (version [`CHECKPOINT_VERSION`], little-endian throughout)
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `TSHELLCK` |
//! | 4 | format version (u32) |
//! | 8 | scene hash (u64, [`scene_hash`]) |
//! | 8 | payload length in bytes (u64) |
//! | 4 | CRC-32 of the payload (u32) |
//! | … | payload |
//!
//! The payload is a sequence of fields: `u64` counts, `f64` as their IEEE bit patterns (so every
//! value round-trips exactly), vectors as a `u64` length followed by the values. In order: the
//! caller's attachment (bytes; the CLI keeps its output bookkeeping there), steps done and
//! requested, Δt, the simulation's and the system's load factor, time, positions, velocities,
//! edge angles, the energy terms of the current state, the rest forms ā and b̄ (4 entries per
//! face each), the lumped masses, the growth state (stimulus field numbers, stale flags, rest
//! updates; a presence byte first), the regularisation memory of the integrator's Newton
//! solves and the input of the Cholesky factor its next solve may reuse (a `u64` 0, or 1
//! followed by the kind of Hessian — 0 own, 1 PSD, 2 shifted, 3 negative curvature —, the
//! shift μ, its shape — 0 identity, 1 diagonal — and the Hessian values as an f64 vector:
//! about 8 bytes per Hessian entry, e.g. 7 MB for a 20 480-face sphere; since version 2);
//! then, only for a scene with the `contact` effect, its run state (a `u64` 1, κ, the
//! adaptive stiffness's flag and last gap, the approximated-pair and pattern-rebuild counters,
//! and the couplings of the widened Hessian pattern: a presence `u64`, then the vertex pairs
//! as an f64 vector). A contact scene's checkpoint without that section (an earlier version)
//! restores with a fresh contact state. A version-1 checkpoint (no kept factor) restores with
//! none: the resumed run factorises afresh at its first step. The file is written with
//! [`crate::atomic::write_atomic`].
//!
//! Everything else a simulation holds is rebuilt from the scene identically (mesh, energy
//! terms, boundary conditions, settings, the symbolic factorisation), which is why a checkpoint
//! only restores into a simulation built from the scene with the same hash.

use std::path::Path;

use nalgebra::{Matrix2, Vector3};
use thinshell_energy::{EnergyTerms, RestState};
use thinshell_growth::GrowthState;
use thinshell_solver::{IterationHessian, KeptFactor, RegularizationKind};

use super::Simulation;
use crate::scene::Scene;

/// Version of the checkpoint format this build writes (it also reads version 1, which has no
/// kept factor).
pub const CHECKPOINT_VERSION: u32 = 2;

const MAGIC: [u8; 8] = *b"TSHELLCK";
const HEADER_LEN: usize = 8 + 4 + 8 + 8 + 4;

/// Why a checkpoint could not be written or restored; the simulation is unchanged.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// Reading or writing the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The checkpoint file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file does not start with the checkpoint magic bytes.
    #[error("{path}: not a thinshell checkpoint")]
    NotACheckpoint {
        /// The file.
        path: String,
    },
    /// Written by another format version.
    #[error("{path}: checkpoint format version {found}; this build reads version {expected}")]
    Version {
        /// The file.
        path: String,
        /// Version in the file.
        found: u32,
        /// Version this build reads.
        expected: u32,
    },
    /// A path-following run (`[path]`): the arc-length tracer's state (step length, ψ, the
    /// previous increment that sets the direction) is not part of the format, so a resume
    /// would not continue the same path.
    #[error(
        "path-following runs ([path]) cannot be checkpointed: the arc-length tracer's state is not saved"
    )]
    PathFollowing,
    /// Shorter (or longer) than its header says: an interrupted copy or a damaged file.
    #[error("{path}: truncated checkpoint ({found} payload bytes, the header says {expected})")]
    Truncated {
        /// The file.
        path: String,
        /// Payload bytes present.
        found: u64,
        /// Payload bytes announced by the header.
        expected: u64,
    },
    /// The payload's checksum does not match: the file is corrupted.
    #[error(
        "{path}: corrupted checkpoint (payload CRC-32 {found:08x}, the header says {expected:08x})"
    )]
    Corrupted {
        /// The file.
        path: String,
        /// Checksum of the payload read.
        found: u32,
        /// Checksum stored in the header.
        expected: u32,
    },
    /// The checkpoint belongs to another scene (or the same file with other `--set` values).
    #[error(
        "{path}: the checkpoint belongs to another scene (scene hash {found:016x}; this scene, after --set overrides, has {expected:016x})"
    )]
    SceneMismatch {
        /// The file.
        path: String,
        /// Hash stored in the checkpoint.
        found: u64,
        /// Hash of the scene being restored into.
        expected: u64,
    },
    /// The payload does not fit this simulation (a wrong length, a bad value).
    #[error("{path}: checkpoint does not fit this simulation: {what}")]
    Mismatch {
        /// The file.
        path: String,
        /// What does not fit.
        what: String,
    },
}

/// A 64-bit fingerprint of a scene after its `--set` overrides: two CRC-32s (different initial
/// values) of the validated scene serialised as JSON, so comments and formatting do not count
/// but every value does. Not a cryptographic hash: it guards against resuming the wrong run.
pub fn scene_hash(scene: &Scene) -> u64 {
    let text = serde_json::to_string(&scene.file).unwrap_or_default();
    let crc = |init: u32| {
        let mut h = crc32fast::Hasher::new_with_initial(init);
        h.update(text.as_bytes());
        h.finalize()
    };
    (u64::from(crc(0)) << 32) | u64::from(crc(0x9e37_79b9))
}

/// Header of a checkpoint file and its attachment, read without a simulation (the CLI reads
/// which scene a checkpoint belongs to before it can build one).
#[derive(Clone, Debug)]
pub struct CheckpointInfo {
    /// Scene hash stored in the file.
    pub scene_hash: u64,
    /// The caller's attachment.
    pub attachment: Vec<u8>,
}

/// Reads and verifies a checkpoint file (magic, version, length, checksum) and returns its
/// scene hash and attachment.
pub fn read_checkpoint_info(path: &Path) -> Result<CheckpointInfo, CheckpointError> {
    let bytes = read(path)?;
    let (_, hash, payload) = verify(&bytes, path)?;
    let mut r = Reader::new(payload, path);
    Ok(CheckpointInfo {
        scene_hash: hash,
        attachment: r.bytes()?,
    })
}

fn read(path: &Path) -> Result<Vec<u8>, CheckpointError> {
    std::fs::read(path).map_err(|source| CheckpointError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Checks the header and checksum; returns the format version, the scene hash and the payload.
fn verify<'a>(bytes: &'a [u8], path: &Path) -> Result<(u32, u64, &'a [u8]), CheckpointError> {
    let p = || path.display().to_string();
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(CheckpointError::NotACheckpoint { path: p() });
    }
    if bytes.len() < HEADER_LEN {
        return Err(CheckpointError::Truncated {
            path: p(),
            found: 0,
            expected: HEADER_LEN as u64,
        });
    }
    let u32_at = |i: usize| {
        let mut b = [0u8; 4];
        b.copy_from_slice(&bytes[i..i + 4]);
        u32::from_le_bytes(b)
    };
    let u64_at = |i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[i..i + 8]);
        u64::from_le_bytes(b)
    };
    let version = u32_at(8);
    if !(1..=CHECKPOINT_VERSION).contains(&version) {
        return Err(CheckpointError::Version {
            path: p(),
            found: version,
            expected: CHECKPOINT_VERSION,
        });
    }
    let hash = u64_at(12);
    let len = u64_at(20);
    let crc = u32_at(28);
    let payload = &bytes[HEADER_LEN..];
    if payload.len() as u64 != len {
        return Err(CheckpointError::Truncated {
            path: p(),
            found: payload.len() as u64,
            expected: len,
        });
    }
    let found = crc32fast::hash(payload);
    if found != crc {
        return Err(CheckpointError::Corrupted {
            path: p(),
            found,
            expected: crc,
        });
    }
    Ok((version, hash, payload))
}

/// Little-endian payload writer.
#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    fn f64s(&mut self, v: impl ExactSizeIterator<Item = f64>) {
        self.u64(v.len() as u64);
        for x in v {
            self.f64(x);
        }
    }
    fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.extend_from_slice(b);
    }
}

/// Little-endian payload reader; running out of bytes is a mismatch, never a panic.
struct Reader<'a> {
    rest: &'a [u8],
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn new(rest: &'a [u8], path: &'a Path) -> Self {
        Reader { rest, path }
    }
    fn mismatch(&self, what: impl Into<String>) -> CheckpointError {
        CheckpointError::Mismatch {
            path: self.path.display().to_string(),
            what: what.into(),
        }
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], CheckpointError> {
        if self.rest.len() < n {
            return Err(self.mismatch("payload ends early"));
        }
        let (a, b) = self.rest.split_at(n);
        self.rest = b;
        Ok(a)
    }
    fn u64(&mut self) -> Result<u64, CheckpointError> {
        let mut b = [0u8; 8];
        b.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(b))
    }
    fn usize(&mut self) -> Result<usize, CheckpointError> {
        let v = self.u64()?;
        usize::try_from(v).map_err(|_| self.mismatch(format!("count {v} too large")))
    }
    fn f64(&mut self) -> Result<f64, CheckpointError> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn len(&mut self, max_item_bytes: usize) -> Result<usize, CheckpointError> {
        let n = self.usize()?;
        if n.saturating_mul(max_item_bytes) > self.rest.len() {
            return Err(self.mismatch("payload ends early"));
        }
        Ok(n)
    }
    fn f64s(&mut self) -> Result<Vec<f64>, CheckpointError> {
        let n = self.len(8)?;
        (0..n).map(|_| self.f64()).collect()
    }
    fn bytes(&mut self) -> Result<Vec<u8>, CheckpointError> {
        let n = self.len(1)?;
        Ok(self.take(n)?.to_vec())
    }
}

/// Everything a checkpoint restores, parsed and checked before the simulation is touched.
struct Saved {
    attachment: Vec<u8>,
    steps_done: usize,
    load_factor: f64,
    system_load_factor: f64,
    t: f64,
    x: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
    phi: Vec<f64>,
    energy: EnergyTerms,
    a_bar: Vec<Matrix2<f64>>,
    b_bar: Vec<Matrix2<f64>>,
    mass: Vec<f64>,
    growth: Option<GrowthState>,
    regularization_memory: f64,
    kept_factor: Option<KeptFactor>,
    contact: Option<thinshell_system::ContactRunState>,
}

fn vectors(v: &[Vector3<f64>]) -> impl ExactSizeIterator<Item = f64> + '_ {
    // Flattened x0, y0, z0, x1, …; the length is 3n.
    let n = v.len();
    (0..3 * n).map(move |i| v[i / 3][i % 3])
}

fn matrices(m: &[Matrix2<f64>]) -> impl ExactSizeIterator<Item = f64> + '_ {
    let n = m.len();
    (0..4 * n).map(move |i| m[i / 4][i % 4])
}

impl Simulation {
    /// The checkpoint bytes of the current state (see the [module](self) documentation), with
    /// `scene_hash` ([`scene_hash`]) and the caller's `attachment`.
    pub fn checkpoint_bytes(&self, scene_hash: u64, attachment: &[u8]) -> Vec<u8> {
        let mut w = Writer::default();
        w.bytes(attachment);
        w.u64(self.steps_done as u64);
        w.u64(self.steps_total as u64);
        w.f64(self.dt);
        w.f64(self.load_factor);
        w.f64(self.system.load_factor());
        w.f64(self.state.t);
        w.f64s(vectors(&self.state.x));
        w.f64s(vectors(&self.state.v));
        w.f64s(self.state.phi.iter().copied());
        w.f64(self.energy.stretch);
        w.f64(self.energy.bend);
        w.f64(self.energy.damping);
        w.f64s(matrices(&self.system.rest().a_bar));
        w.f64s(matrices(&self.system.rest().b_bar));
        w.f64s(self.system.mass().iter().copied());
        match &self.growth {
            None => w.u64(0),
            Some(g) => {
                let s = g.save_state();
                w.u64(1);
                w.f64s(s.field.iter().copied());
                w.u64(u64::from(s.rest_stale));
                w.u64(u64::from(s.mass_stale));
                w.u64(s.rest_updates as u64);
            }
        }
        w.f64(self.integrator.carried_state());
        match self.integrator.kept_factor() {
            None => w.u64(0),
            Some(k) => {
                w.u64(1);
                w.u64(match k.kind {
                    IterationHessian::Own => 0,
                    IterationHessian::Psd => 1,
                    IterationHessian::Shifted => 2,
                    IterationHessian::NegativeCurvature => 3,
                });
                w.f64(k.shift);
                w.u64(match k.shift_kind {
                    RegularizationKind::Identity => 0,
                    RegularizationKind::Diagonal => 1,
                });
                w.f64s(k.values.iter().copied());
            }
        }
        // Only with contact: the payload of a scene without it is as before.
        if let Some(c) = self.system.contact_run_state() {
            w.u64(1);
            w.f64(c.stiffness);
            w.u64(u64::from(c.adaptive_initialised));
            w.f64(c.adaptive_last_gap);
            w.u64(c.approximated_pairs as u64);
            w.u64(c.pattern_rebuilds as u64);
            match &c.pattern_couplings {
                None => w.u64(0),
                Some(p) => {
                    w.u64(1);
                    w.f64s((0..2 * p.len()).map(|i| p[i / 2][i % 2] as f64));
                }
            }
        }
        let payload = w.0;
        let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
        out.extend_from_slice(&scene_hash.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
        out.extend_from_slice(&payload);
        out
    }

    /// Writes a checkpoint of the current state to `path` atomically.
    pub fn save(&self, path: &Path, scene_hash: u64) -> Result<(), CheckpointError> {
        self.save_with(path, scene_hash, &[])
    }

    /// [`Simulation::save`] with the caller's `attachment` bytes stored alongside (returned by
    /// [`Simulation::restore`]).
    pub fn save_with(
        &self,
        path: &Path,
        scene_hash: u64,
        attachment: &[u8],
    ) -> Result<(), CheckpointError> {
        if self.is_path_following() {
            return Err(CheckpointError::PathFollowing);
        }
        crate::atomic::write_atomic(path, &self.checkpoint_bytes(scene_hash, attachment)).map_err(
            |source| CheckpointError::Io {
                path: path.display().to_string(),
                source,
            },
        )
    }

    /// Restores the checkpoint at `path` into this simulation, which must have been built from
    /// the scene whose [`scene_hash`] is `scene_hash`; returns the attachment. On any error
    /// (unreadable, corrupted, truncated, another scene, another version, a shape that does
    /// not fit) the simulation is unchanged.
    pub fn restore(&mut self, path: &Path, scene_hash: u64) -> Result<Vec<u8>, CheckpointError> {
        let bytes = read(path)?;
        self.restore_bytes(&bytes, scene_hash, path)
    }

    /// [`Simulation::restore`] from bytes in memory; `path` names them in errors.
    pub fn restore_bytes(
        &mut self,
        bytes: &[u8],
        scene_hash: u64,
        path: &Path,
    ) -> Result<Vec<u8>, CheckpointError> {
        if self.is_path_following() {
            return Err(CheckpointError::PathFollowing);
        }
        let (version, found, payload) = verify(bytes, path)?;
        if found != scene_hash {
            return Err(CheckpointError::SceneMismatch {
                path: path.display().to_string(),
                found,
                expected: scene_hash,
            });
        }
        let saved = self.parse(payload, version, path)?;
        let mismatch = |what: String| CheckpointError::Mismatch {
            path: path.display().to_string(),
            what,
        };
        // Fallible updates first, each undone if a later one fails.
        let sff = self.system.rest().sff;
        let old_rest = self
            .system
            .set_rest(RestState {
                a_bar: saved.a_bar,
                b_bar: saved.b_bar,
                sff,
            })
            .map_err(|e| mismatch(format!("rest forms: {e}")))?;
        let old_mass = self.system.mass().to_vec();
        let old_lf = self.system.load_factor();
        if let Err(e) = self.system.set_mass(saved.mass) {
            let _ = self.system.set_rest(old_rest);
            return Err(mismatch(format!("masses: {e}")));
        }
        if let Err(e) = self.system.set_load_factor(saved.system_load_factor) {
            let _ = self.system.set_mass(old_mass);
            let _ = self.system.set_rest(old_rest);
            return Err(mismatch(format!("load factor: {e}")));
        }
        if let Some(c) = &saved.contact
            && let Err(e) = self.system.restore_contact_run_state(c)
        {
            let _ = self.system.set_load_factor(old_lf);
            let _ = self.system.set_mass(old_mass);
            let _ = self.system.set_rest(old_rest);
            return Err(mismatch(format!("contact: {e}")));
        }
        if let (Some(g), Some(s)) = (&mut self.growth, &saved.growth) {
            let before = g.save_state();
            if let Err(e) = g.restore_state(s) {
                let _ = g.restore_state(&before);
                let _ = self.system.set_load_factor(old_lf);
                let _ = self.system.set_mass(old_mass);
                let _ = self.system.set_rest(old_rest);
                return Err(mismatch(format!("growth: {e}")));
            }
        }
        self.steps_done = saved.steps_done;
        self.load_factor = saved.load_factor;
        self.state.t = saved.t;
        self.state.x = saved.x;
        self.state.v = saved.v;
        self.state.phi = saved.phi;
        self.energy = saved.energy;
        self.integrator
            .restore_carried_state(saved.regularization_memory);
        self.integrator.restore_kept_factor(saved.kept_factor);
        Ok(saved.attachment)
    }

    /// Parses a verified payload and checks every length against this simulation.
    fn parse(&self, payload: &[u8], version: u32, path: &Path) -> Result<Saved, CheckpointError> {
        let mut r = Reader::new(payload, path);
        let attachment = r.bytes()?;
        let steps_done = r.usize()?;
        let steps_total = r.usize()?;
        let dt = r.f64()?;
        if steps_total != self.steps_total || dt.to_bits() != self.dt.to_bits() {
            return Err(r.mismatch(format!(
                "{steps_total} steps of {dt:e} s, the scene has {} of {:e} s",
                self.steps_total, self.dt
            )));
        }
        if steps_done > steps_total {
            return Err(r.mismatch(format!("{steps_done} steps done of {steps_total}")));
        }
        let load_factor = r.f64()?;
        let system_load_factor = r.f64()?;
        let t = r.f64()?;
        let n = self.system.mesh().n_vertices();
        let n_faces = self.system.mesh().n_faces();
        let vecs = |r: &mut Reader, what: &str| -> Result<Vec<Vector3<f64>>, CheckpointError> {
            let flat = r.f64s()?;
            if flat.len() != 3 * n {
                return Err(r.mismatch(format!(
                    "{what}: {} numbers, the mesh has {n} vertices",
                    flat.len()
                )));
            }
            Ok(flat
                .chunks_exact(3)
                .map(|c| Vector3::new(c[0], c[1], c[2]))
                .collect())
        };
        let x = vecs(&mut r, "positions")?;
        let v = vecs(&mut r, "velocities")?;
        let phi = r.f64s()?;
        let n_edges = self.system.n_edge_angles();
        if !(phi.is_empty() || phi.len() == n_edges) {
            return Err(r.mismatch(format!(
                "{} edge angles, the system has {n_edges}",
                phi.len()
            )));
        }
        let energy = EnergyTerms {
            stretch: r.f64()?,
            bend: r.f64()?,
            damping: r.f64()?,
        };
        let mats = |r: &mut Reader, what: &str| -> Result<Vec<Matrix2<f64>>, CheckpointError> {
            let flat = r.f64s()?;
            if flat.len() != 4 * n_faces {
                return Err(r.mismatch(format!(
                    "{what}: {} numbers, the mesh has {n_faces} faces",
                    flat.len()
                )));
            }
            Ok(flat
                .chunks_exact(4)
                .map(Matrix2::from_column_slice)
                .collect())
        };
        let a_bar = mats(&mut r, "rest forms a")?;
        let b_bar = mats(&mut r, "rest forms b")?;
        let mass = r.f64s()?;
        let growth = match (r.u64()?, &self.growth) {
            (0, None) => None,
            (1, Some(_)) => Some(GrowthState {
                field: r.f64s()?,
                rest_stale: r.u64()? != 0,
                mass_stale: r.u64()? != 0,
                rest_updates: r.usize()?,
            }),
            (flag, _) => {
                return Err(r.mismatch(format!(
                    "growth state flag {flag}, the scene {} growth",
                    if self.growth.is_some() {
                        "has"
                    } else {
                        "has no"
                    }
                )));
            }
        };
        let regularization_memory = r.f64()?;
        // Version 1 has no kept factor.
        let kept_flag = if version >= 2 { r.u64()? } else { 0 };
        let kept_factor = match kept_flag {
            0 => None,
            1 => {
                let kind = match r.u64()? {
                    0 => IterationHessian::Own,
                    1 => IterationHessian::Psd,
                    2 => IterationHessian::Shifted,
                    3 => IterationHessian::NegativeCurvature,
                    k => return Err(r.mismatch(format!("kept factor of Hessian kind {k}"))),
                };
                let shift = r.f64()?;
                let shift_kind = match r.u64()? {
                    0 => RegularizationKind::Identity,
                    1 => RegularizationKind::Diagonal,
                    k => return Err(r.mismatch(format!("kept factor of shift shape {k}"))),
                };
                let values = r.f64s()?;
                if !(shift.is_finite() && values.iter().all(|v| v.is_finite())) {
                    return Err(r.mismatch("non-finite kept factor values"));
                }
                Some(KeptFactor {
                    kind,
                    values,
                    shift,
                    shift_kind,
                })
            }
            flag => return Err(r.mismatch(format!("kept factor flag {flag}"))),
        };
        // Absent from checkpoints of scenes without contact and of earlier versions (a
        // contact scene then restarts its contact state).
        let contact = if r.rest.is_empty() {
            None
        } else {
            if r.u64()? != 1 || self.system.contact().is_none() {
                return Err(r.mismatch("a contact state, the scene has no contact"));
            }
            let stiffness = r.f64()?;
            let adaptive_initialised = r.u64()? != 0;
            let adaptive_last_gap = r.f64()?;
            let approximated_pairs = r.usize()?;
            let pattern_rebuilds = r.usize()?;
            let pattern_couplings = match r.u64()? {
                0 => None,
                _ => {
                    let flat = r.f64s()?;
                    // Written from vertex indices, so exact integers in f64.
                    let idx = |v: f64| v as usize;
                    Some(
                        flat.chunks_exact(2)
                            .map(|p| [idx(p[0]), idx(p[1])])
                            .collect(),
                    )
                }
            };
            Some(thinshell_system::ContactRunState {
                stiffness,
                adaptive_initialised,
                adaptive_last_gap,
                approximated_pairs,
                pattern_rebuilds,
                pattern_couplings,
            })
        };
        if !r.rest.is_empty() {
            return Err(r.mismatch(format!("{} unread payload bytes", r.rest.len())));
        }
        let finite = x.iter().chain(&v).all(|p| p.iter().all(|c| c.is_finite()))
            && phi.iter().all(|p| p.is_finite())
            && t.is_finite();
        if !finite {
            return Err(r.mismatch("non-finite positions, velocities, angles or time"));
        }
        Ok(Saved {
            attachment,
            steps_done,
            load_factor,
            system_load_factor,
            t,
            x,
            v,
            phi,
            energy,
            a_bar,
            b_bar,
            mass,
            growth,
            regularization_memory,
            kept_factor,
            contact,
        })
    }
}
