//! The stimulus seen by one face.

/// Stimulus (temperature change, moisture content, or directly the growth factor s) at the top
/// (`z = +h/2`, the side the face normal points to) and bottom (`z = −h/2`) surfaces of a face,
/// in the stimulus' own unit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FaceStimulus {
    /// m⁺, at the top surface.
    pub top: f64,
    /// m⁻, at the bottom surface.
    pub bottom: f64,
}

impl FaceStimulus {
    /// The same value on both surfaces.
    pub const fn uniform(value: f64) -> FaceStimulus {
        FaceStimulus {
            top: value,
            bottom: value,
        }
    }

    /// `(m⁺ + m⁻) / 2`, the through-thickness mean of a linear profile.
    pub fn mean(&self) -> f64 {
        0.5 * (self.top + self.bottom)
    }

    /// Both values finite.
    pub fn is_finite(&self) -> bool {
        self.top.is_finite() && self.bottom.is_finite()
    }
}
