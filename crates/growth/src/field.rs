//! Stimulus fields: where the per-face stimulus comes from and how it evolves in time.

use nalgebra::Vector3;
use thinshell_mesh::{FaceId, Mesh};

use crate::error::{GrowthError, check, check_len};
use crate::region::Region;
use crate::stimulus::FaceStimulus;

/// A stimulus defined on the faces of a mesh that may change with time.
pub trait StimulusField: Send {
    /// Current per-face stimulus (m⁺, m⁻).
    fn values(&self) -> &[FaceStimulus];

    /// Advances the field from time `t` to `t + dt` (s). Returns whether any value changed, so
    /// that a caller recomputes rest forms only when needed.
    fn advance(&mut self, t: f64, dt: f64) -> Result<bool, GrowthError>;

    /// Through-thickness mean of face `face` (for mass uptake); `(m⁺ + m⁻)/2` unless the field
    /// resolves the profile.
    fn mean(&self, face: usize) -> f64 {
        self.values().get(face).map_or(0.0, FaceStimulus::mean)
    }

    /// Short name for reports.
    fn name(&self) -> &'static str;

    /// Everything [`StimulusField::advance`] changes, as numbers, so that a checkpoint can
    /// save it and [`StimulusField::restore_state`] continue bit for bit (caches that are
    /// rebuilt identically, such as a diffusion factorisation, are not included).
    fn save_state(&self) -> Vec<f64>;

    /// Restores what [`StimulusField::save_state`] returned; errors on a wrong length or
    /// non-finite values.
    fn restore_state(&mut self, state: &[f64]) -> Result<(), GrowthError>;
}

/// Per-face stimulus as (top, bottom) pairs.
fn stimulus_numbers(values: &[FaceStimulus]) -> Vec<f64> {
    values.iter().flat_map(|m| [m.top, m.bottom]).collect()
}

/// Restores per-face stimulus from (top, bottom) pairs.
fn restore_stimulus(values: &mut [FaceStimulus], state: &[f64]) -> Result<(), GrowthError> {
    check_len("stimulus state", 2 * values.len(), state.len())?;
    let restored: Vec<FaceStimulus> = state
        .chunks_exact(2)
        .map(|c| FaceStimulus {
            top: c[0],
            bottom: c[1],
        })
        .collect();
    check_values(&restored)?;
    values.copy_from_slice(&restored);
    Ok(())
}

/// A prescribed stimulus type: `f(t, centroid)` (s, m) → stimulus of a face.
pub type StimulusFn = Box<dyn Fn(f64, Vector3<f64>) -> FaceStimulus + Send>;

/// A prescribed stimulus: constant per face, or a function of time and position evaluated at
/// the face centroids of a fixed configuration (the initial mesh).
pub struct Prescribed {
    values: Vec<FaceStimulus>,
    law: Option<(StimulusFn, Vec<Vector3<f64>>)>,
}

impl std::fmt::Debug for Prescribed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Prescribed")
            .field("n_faces", &self.values.len())
            .field("time_dependent", &self.law.is_some())
            .finish()
    }
}

fn check_values(values: &[FaceStimulus]) -> Result<(), GrowthError> {
    match values.iter().position(|m| !m.is_finite()) {
        None => Ok(()),
        Some(f) => Err(GrowthError::NonFiniteStimulus {
            face: FaceId::new(f),
            top: values[f].top,
            bottom: values[f].bottom,
        }),
    }
}

impl Prescribed {
    /// A constant stimulus per face.
    pub fn constant(values: Vec<FaceStimulus>) -> Result<Prescribed, GrowthError> {
        check_values(&values)?;
        Ok(Prescribed { values, law: None })
    }

    /// The same constant stimulus on all `n_faces` faces.
    pub fn uniform(n_faces: usize, m: FaceStimulus) -> Result<Prescribed, GrowthError> {
        Prescribed::constant(vec![m; n_faces])
    }

    /// A constant stimulus by region: each face takes the value of the first region containing
    /// it, `background` if none does. Regions are evaluated on positions `x` (m).
    pub fn regions(
        mesh: &Mesh,
        x: &[Vector3<f64>],
        regions: &[(Region, FaceStimulus)],
        background: FaceStimulus,
    ) -> Result<Prescribed, GrowthError> {
        let mut values = vec![None; mesh.n_faces()];
        for (region, m) in regions {
            for (slot, inside) in values.iter_mut().zip(region.faces(mesh, x)?) {
                if inside && slot.is_none() {
                    *slot = Some(*m);
                }
            }
        }
        Prescribed::constant(
            values
                .into_iter()
                .map(|m| m.unwrap_or(background))
                .collect(),
        )
    }

    /// `law(t, c_f)` at every face centroid c_f of positions `x` (m), starting at time 0.
    pub fn function(
        mesh: &Mesh,
        x: &[Vector3<f64>],
        law: StimulusFn,
    ) -> Result<Prescribed, GrowthError> {
        check_len("positions", mesh.n_vertices(), x.len())?;
        let centroids: Vec<Vector3<f64>> = mesh
            .faces()
            .iter()
            .map(|f| (x[f[0].idx()] + x[f[1].idx()] + x[f[2].idx()]) / 3.0)
            .collect();
        let values = centroids.iter().map(|c| law(0.0, *c)).collect::<Vec<_>>();
        check_values(&values)?;
        Ok(Prescribed {
            values,
            law: Some((law, centroids)),
        })
    }
}

impl StimulusField for Prescribed {
    fn values(&self) -> &[FaceStimulus] {
        &self.values
    }
    fn advance(&mut self, t: f64, dt: f64) -> Result<bool, GrowthError> {
        let Some((law, centroids)) = &self.law else {
            return Ok(false);
        };
        let t1 = t + dt;
        let mut changed = false;
        for (f, (m, c)) in self.values.iter_mut().zip(centroids).enumerate() {
            let new = law(t1, *c);
            if !new.is_finite() {
                return Err(GrowthError::NonFiniteStimulus {
                    face: FaceId::new(f),
                    top: new.top,
                    bottom: new.bottom,
                });
            }
            changed |= new != *m;
            *m = new;
        }
        Ok(changed)
    }
    fn name(&self) -> &'static str {
        "prescribed"
    }
    fn save_state(&self) -> Vec<f64> {
        stimulus_numbers(&self.values)
    }
    fn restore_state(&mut self, state: &[f64]) -> Result<(), GrowthError> {
        restore_stimulus(&mut self.values, state)
    }
}

/// The seed's directed heat source (model.md §5): faces of the `hot` region are held at
/// `value`, faces of the `held` region at 0, and at every step each other face's value is
/// replaced by the mean of itself and its edge neighbours (a stand-in for diffusion that ignores
/// Δt). Both surfaces carry the same value. A face in both regions counts as hot.
#[derive(Clone, Debug)]
pub struct DirectedHeat {
    values: Vec<FaceStimulus>,
    scratch: Vec<f64>,
    // Per face: None (hot or held, fixed) or its neighbour list.
    free: Vec<Option<Vec<usize>>>,
}

impl DirectedHeat {
    /// Sets up the rule on `mesh` with regions evaluated on positions `x` (m). Errors when the
    /// hot region holds no face or `value` is not finite.
    pub fn new(
        mesh: &Mesh,
        x: &[Vector3<f64>],
        hot: &Region,
        held: &Region,
        value: f64,
    ) -> Result<DirectedHeat, GrowthError> {
        check("value", value, true, "must be finite")?;
        let hot = hot.faces(mesh, x)?;
        let held = held.faces(mesh, x)?;
        if !hot.iter().any(|&h| h) {
            return Err(GrowthError::EmptyRegion { name: "hot".into() });
        }
        let topo = mesh.topology();
        let mut values = Vec::with_capacity(mesh.n_faces());
        let mut free = Vec::with_capacity(mesh.n_faces());
        for f in 0..mesh.n_faces() {
            if hot[f] {
                values.push(FaceStimulus::uniform(value));
                free.push(None);
            } else {
                values.push(FaceStimulus::uniform(0.0));
                free.push((!held[f]).then(|| {
                    topo.face_neighbors(FaceId::new(f))
                        .iter()
                        .flatten()
                        .map(|g| g.idx())
                        .collect()
                }));
            }
        }
        Ok(DirectedHeat {
            scratch: vec![0.0; values.len()],
            values,
            free,
        })
    }
}

impl StimulusField for DirectedHeat {
    fn values(&self) -> &[FaceStimulus] {
        &self.values
    }
    fn advance(&mut self, _t: f64, _dt: f64) -> Result<bool, GrowthError> {
        // Jacobi sweep: every face averages the values of the previous step.
        for (f, nb) in self.free.iter().enumerate() {
            self.scratch[f] = match nb {
                None => self.values[f].top,
                Some(nb) => {
                    let sum: f64 = nb.iter().map(|&g| self.values[g].top).sum();
                    (self.values[f].top + sum) / (1 + nb.len()) as f64
                }
            };
        }
        let mut changed = false;
        for (m, &s) in self.values.iter_mut().zip(&self.scratch) {
            changed |= m.top != s;
            *m = FaceStimulus::uniform(s);
        }
        Ok(changed)
    }
    fn name(&self) -> &'static str {
        "directed heat"
    }
    fn save_state(&self) -> Vec<f64> {
        stimulus_numbers(&self.values)
    }
    fn restore_state(&mut self, state: &[f64]) -> Result<(), GrowthError> {
        restore_stimulus(&mut self.values, state)
    }
}
