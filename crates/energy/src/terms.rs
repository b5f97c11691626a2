//! Which energy terms a model evaluates, the energies per term and how a Hessian is formed:
//! plain data shared by the material laws, the kernel, the assembler and the errors.

/// Which energy terms are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Terms {
    /// Stretching (membrane) energy.
    pub stretch: bool,
    /// Bending energy.
    pub bend: bool,
    /// Kelvin–Voigt damping (needs a [`FaceDamping`](crate::FaceDamping)).
    pub damping: bool,
}

impl Terms {
    /// All three terms.
    pub const ALL: Terms = Terms {
        stretch: true,
        bend: true,
        damping: true,
    };

    /// Stretching and bending, no damping (static solves reject damping).
    pub const ELASTIC: Terms = Terms {
        stretch: true,
        bend: true,
        damping: false,
    };
}

/// How the Hessian is formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HessianMode {
    /// Exact second derivatives.
    Exact,
    /// Only first-derivative products Jᵀ (∂²E/∂form²) J (PSD for the quadratic laws StVK and
    /// bilayer; for neo-Hookean only where ∂²E/∂form² is).
    GaussNewton,
    /// Exact face Hessian projected to PSD (symmetric eigen-decomposition, negatives clamped to 0).
    ProjectedPsd,
}

/// Energies per term (J). With the crate's `serde` feature it serialises as
/// `{"stretch", "bend", "damping"}` (the run output's `energy` records).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct EnergyTerms {
    /// Stretching energy (J).
    pub stretch: f64,
    /// Bending energy (J).
    pub bend: f64,
    /// Damping pseudo-energy (J).
    pub damping: f64,
}

impl EnergyTerms {
    /// Sum of the terms (J).
    pub fn total(&self) -> f64 {
        self.stretch + self.bend + self.damping
    }

    /// Elastic energy, stretching + bending (J).
    pub fn elastic(&self) -> f64 {
        self.stretch + self.bend
    }
}

impl std::ops::AddAssign for EnergyTerms {
    fn add_assign(&mut self, o: Self) {
        self.stretch += o.stretch;
        self.bend += o.bend;
        self.damping += o.damping;
    }
}
