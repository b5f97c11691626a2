//! The coupling step between a stimulus field, a growth model and an elastic solver
//! (model.md §4.1, operator splitting): rest forms from the current stimulus → elastic step →
//! stimulus step.

use thinshell_energy::{Material, RestState};
use thinshell_mesh::Mesh;

use crate::error::{GrowthError, check};
use crate::field::StimulusField;
use crate::mass::mass_with_uptake;
use crate::model::{GrowthModel, apply_growth};
use crate::stimulus::FaceStimulus;

/// What [`Growth::save_state`] saves.
#[derive(Clone, Debug, PartialEq)]
pub struct GrowthState {
    /// The stimulus field's numbers ([`StimulusField::save_state`]).
    pub field: Vec<f64>,
    /// Whether the rest forms must be recomputed before the next elastic step.
    pub rest_stale: bool,
    /// Whether the masses must be recomputed before the next elastic step.
    pub mass_stale: bool,
    /// Rest-form updates so far.
    pub rest_updates: usize,
}

/// A growth model driven by a stimulus field, for a caller that owns the time loop.
///
/// Per step: [`update_rest`](Growth::update_rest) (and [`update_mass`](Growth::update_mass)
/// when the stimulus adds mass), then the caller's elastic step, then
/// [`advance`](Growth::advance). Rest forms and masses are recomputed only when the stimulus
/// changed since they were last written.
pub struct Growth {
    model: Box<dyn GrowthModel>,
    field: Box<dyn StimulusField>,
    initial: RestState,
    thickness: f64,
    added_density: Option<f64>,
    rest_stale: bool,
    mass_stale: bool,
    rest_updates: usize,
}

impl std::fmt::Debug for Growth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Growth")
            .field("model", &self.model.name())
            .field("field", &self.field.name())
            .field("thickness", &self.thickness)
            .field("rest_updates", &self.rest_updates)
            .finish_non_exhaustive()
    }
}

impl Growth {
    /// `model` driven by `field` on a shell of thickness `thickness` (m) whose forms before any
    /// growth are `initial` (a⁰, b⁰). Errors on a field of the wrong length or a bad thickness.
    pub fn new(
        model: Box<dyn GrowthModel>,
        field: Box<dyn StimulusField>,
        initial: RestState,
        thickness: f64,
    ) -> Result<Growth, GrowthError> {
        check("thickness", thickness, thickness > 0.0, "must be positive")?;
        crate::error::check_len("stimulus field", initial.n_faces(), field.values().len())?;
        Ok(Growth {
            model,
            field,
            initial,
            thickness,
            added_density: None,
            rest_stale: true,
            mass_stale: true,
            rest_updates: 0,
        })
    }

    /// The stimulus adds `added_density` kg/m³ of mass per unit stimulus (moisture soaking in);
    /// [`update_mass`](Growth::update_mass) then reports new masses when it changes.
    pub fn with_mass_uptake(mut self, added_density: f64) -> Result<Growth, GrowthError> {
        check("added_density", added_density, true, "must be finite")?;
        self.added_density = Some(added_density);
        Ok(self)
    }

    /// Writes the rest forms for the current stimulus into `rest` if the stimulus changed since
    /// the last call (always on the first call); returns whether it wrote.
    pub fn update_rest(&mut self, rest: &mut RestState) -> Result<bool, GrowthError> {
        if !self.rest_stale {
            return Ok(false);
        }
        apply_growth(
            self.model.as_ref(),
            &self.initial,
            self.field.values(),
            self.thickness,
            rest,
        )?;
        self.rest_stale = false;
        self.rest_updates += 1;
        Ok(true)
    }

    /// New lumped masses (kg) when the stimulus adds mass and changed since the last call;
    /// `None` otherwise (the masses of the initial rest state stay valid).
    pub fn update_mass(
        &mut self,
        mesh: &Mesh,
        material: &Material,
    ) -> Result<Option<Vec<f64>>, GrowthError> {
        let Some(rho) = self.added_density.filter(|_| self.mass_stale) else {
            return Ok(None);
        };
        let means: Vec<f64> = (0..self.initial.n_faces())
            .map(|f| self.field.mean(f))
            .collect();
        let mass = mass_with_uptake(mesh, &self.initial, material, rho, &means)?;
        self.mass_stale = false;
        Ok(Some(mass))
    }

    /// Advances the stimulus from `t` to `t + dt` (s); returns whether it changed.
    pub fn advance(&mut self, t: f64, dt: f64) -> Result<bool, GrowthError> {
        let changed = self.field.advance(t, dt)?;
        self.rest_stale |= changed;
        self.mass_stale |= changed;
        Ok(changed)
    }

    /// Replaces the stimulus of every face by `values` (one per face, in the stimulus' unit),
    /// held constant from now on: the field the coupling was built with (time law, directed
    /// heat, diffusion) is dropped. Rest forms and masses are recomputed at the next
    /// [`update_rest`](Growth::update_rest) / [`update_mass`](Growth::update_mass). Errors on a
    /// wrong length or a non-finite value (nothing is changed then).
    pub fn set_stimulus(&mut self, values: Vec<FaceStimulus>) -> Result<(), GrowthError> {
        crate::error::check_len("stimulus", self.initial.n_faces(), values.len())?;
        self.field = Box::new(crate::field::Prescribed::constant(values)?);
        self.rest_stale = true;
        self.mass_stale = true;
        Ok(())
    }

    /// The coupling's evolving state for a checkpoint: the stimulus field's numbers and
    /// whether the rest forms and masses are stale.
    pub fn save_state(&self) -> GrowthState {
        GrowthState {
            field: self.field.save_state(),
            rest_stale: self.rest_stale,
            mass_stale: self.mass_stale,
            rest_updates: self.rest_updates,
        }
    }

    /// Restores what [`Growth::save_state`] returned (the caller restores the rest forms and
    /// masses it had at the same moment).
    pub fn restore_state(&mut self, state: &GrowthState) -> Result<(), GrowthError> {
        self.field.restore_state(&state.field)?;
        self.rest_stale = state.rest_stale;
        self.mass_stale = state.mass_stale;
        self.rest_updates = state.rest_updates;
        Ok(())
    }

    /// The current per-face stimulus.
    pub fn stimulus(&self) -> &[FaceStimulus] {
        self.field.values()
    }

    /// The forms before growth (a⁰, b⁰).
    pub fn initial(&self) -> &RestState {
        &self.initial
    }

    /// How many times the rest forms were recomputed.
    pub fn rest_updates(&self) -> usize {
        self.rest_updates
    }

    /// The growth model's name.
    pub fn model_name(&self) -> &'static str {
        self.model.name()
    }

    /// The stimulus field's name.
    pub fn field_name(&self) -> &'static str {
        self.field.name()
    }
}
