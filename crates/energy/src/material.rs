//! Isotropic linear-elastic material of the shell.

use crate::error::EnergyError;

/// Material parameters (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Thickness h (m).
    pub thickness: f64,
    /// Young's modulus E (Pa).
    pub young: f64,
    /// Poisson ratio ν (dimensionless, 0 ≤ ν < 0.5).
    pub poisson: f64,
    /// Mass density ρ (kg/m³).
    pub density: f64,
    /// Kelvin–Voigt viscosity η (Pa·s).
    pub viscosity: f64,
}

impl Material {
    /// Paper: h = 1e-4 m, E = 2e9 Pa, ν = 0.3, ρ = 250 kg/m³, η = 5e-13 Pa·s.
    pub fn paper() -> Self {
        Self {
            thickness: 1e-4,
            young: 2e9,
            poisson: 0.3,
            density: 250.0,
            viscosity: 5e-13,
        }
    }

    /// Checks h > 0, E > 0, 0 ≤ ν < 0.5, ρ > 0, η ≥ 0, all finite; names the first bad parameter.
    pub fn validate(&self) -> Result<(), EnergyError> {
        let checks: [(&'static str, f64, bool, &'static str); 5] = [
            (
                "thickness",
                self.thickness,
                self.thickness > 0.0,
                "must be finite and > 0",
            ),
            (
                "young",
                self.young,
                self.young > 0.0,
                "must be finite and > 0",
            ),
            (
                "poisson",
                self.poisson,
                (0.0..0.5).contains(&self.poisson),
                "must be finite and in [0, 0.5)",
            ),
            (
                "density",
                self.density,
                self.density > 0.0,
                "must be finite and > 0",
            ),
            (
                "viscosity",
                self.viscosity,
                self.viscosity >= 0.0,
                "must be finite and >= 0",
            ),
        ];
        for (name, value, ok, reason) in checks {
            if !(ok && value.is_finite()) {
                return Err(EnergyError::InvalidParameter {
                    name,
                    value,
                    reason,
                });
            }
        }
        Ok(())
    }

    /// Lamé-type coefficient α = E ν / (1 − ν²) (Pa).
    pub fn alpha(&self) -> f64 {
        self.young * self.poisson / (1.0 - self.poisson * self.poisson)
    }

    /// Shear coefficient β = E / (2 (1 + ν)) (Pa).
    pub fn beta(&self) -> f64 {
        self.young / (2.0 * (1.0 + self.poisson))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_valid_and_bad_named() {
        assert!(Material::paper().validate().is_ok());
        let m = Material {
            poisson: 0.5,
            ..Material::paper()
        };
        assert!(matches!(
            m.validate(),
            Err(EnergyError::InvalidParameter {
                name: "poisson",
                ..
            })
        ));
        let m = Material {
            thickness: f64::NAN,
            ..Material::paper()
        };
        assert!(matches!(
            m.validate(),
            Err(EnergyError::InvalidParameter {
                name: "thickness",
                ..
            })
        ));
        // α, β against hand values for E = 2e9, ν = 0.3 (tolerance 1e-12 relative).
        let p = Material::paper();
        assert!((p.alpha() - 2e9 * 0.3 / 0.91).abs() < 1e-12 * p.alpha());
        assert!((p.beta() - 2e9 / 2.6).abs() < 1e-12 * p.beta());
    }
}
