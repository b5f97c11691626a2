//! Shell materials: the parameters every model shares ([`Material`]: thickness, E, ν for
//! damping and mass, density, viscosity), the elastic model ([`MaterialModel`]) and the trait
//! each model implements ([`ElasticLaw`]): the face's elastic energy as a function of the six
//! form entries (a11, a12, a22, b11, b12, b22), with gradient and Hessian.
//!
//! One file per model: [`StVK`] (the paper's, model.md §2), [`NeoHookean`], [`Bilayer`] and
//! [`TensionField`] (model.md §2.1–2.3). Adding a model is one new file implementing [`ElasticLaw`] plus a
//! [`MaterialModel`] variant.

mod bilayer;
pub mod dual;
mod neo_hookean;
mod rest_mixed;
mod stvk;
mod tension_field;

pub use bilayer::{Bilayer, Layer};
pub use neo_hookean::NeoHookean;
pub use stvk::StVK;
pub(crate) use stvk::sv_energy_of;
pub use tension_field::TensionField;

use crate::error::EnergyError;
use crate::terms::Terms;
use nalgebra::{Matrix2, Matrix3, Matrix6, Vector3};

/// What a law computes besides the energies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// Energies only.
    Energy,
    /// Energies and the 6-gradient.
    Gradient,
    /// Energies, gradient and the 6×6 Hessian.
    Hessian,
}

/// Rest data of one face as a law reads it (barycentric basis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceGeometry {
    /// Entries (ā11, ā12, ā22) of the rest first fundamental form (m²).
    pub a_bar: Vector3<f64>,
    /// Entries (b̄11, b̄12, b̄22) of the rest second fundamental form (m).
    pub b_bar: Vector3<f64>,
    /// ā⁻¹ (1/m²).
    pub a_bar_inv: Matrix2<f64>,
    /// A = √det ā (m², twice the rest area: the energies are per unit A).
    pub area: f64,
}

/// Output of [`ElasticLaw::eval`]: energies (J) and derivatives in the form entries
/// a = (a11, a12, a22), b = (b11, b12, b22). Entries not asked for by the [`Order`] are
/// unspecified.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LawEval {
    /// Stretching energy (J).
    pub stretch: f64,
    /// Bending energy (J), including any a–b coupling.
    pub bend: f64,
    /// ∂E/∂a (J/m²).
    pub ga: Vector3<f64>,
    /// ∂E/∂b (J/m).
    pub gb: Vector3<f64>,
    /// ∂²E/∂a².
    pub haa: Matrix3<f64>,
    /// ∂²E/∂a∂b (row: a entry, column: b entry); zero when the law is not
    /// [`coupled`](ElasticLaw::coupled).
    pub hab: Matrix3<f64>,
    /// ∂²E/∂b².
    pub hbb: Matrix3<f64>,
}

impl LawEval {
    /// Zeroes the energies and the derivatives `order` asks for.
    pub fn clear(&mut self, order: Order) {
        self.stretch = 0.0;
        self.bend = 0.0;
        if order != Order::Energy {
            self.ga = Vector3::zeros();
            self.gb = Vector3::zeros();
        }
        if order == Order::Hessian {
            self.haa = Matrix3::zeros();
            self.hab = Matrix3::zeros();
            self.hbb = Matrix3::zeros();
        }
    }
}

/// An elastic energy of a shell face as a function of its forms a, b given the rest forms.
///
/// [`crate::eval_face`] does the chain rule through a and b for every law; a law only gives
/// the energy, its 6-gradient and 6×6 Hessian in the form entries. Terms switched off in
/// `terms` must contribute nothing (and with bending off, `b` is not evaluated: it is passed as
/// b̄). Kelvin–Voigt damping is not part of the law: it stays the StVK-shaped quadratic of the
/// [`Material`]'s h, E, ν for every model ([`crate::damping`]).
pub trait ElasticLaw: std::fmt::Debug + Send + Sync {
    /// Name used in scene files (`[material] model = "…"`).
    fn name(&self) -> &'static str;

    /// Checks the model's own parameters against the shared ones (called by
    /// [`Material::validate`] after the shared checks). Default: nothing beyond the shared
    /// h, E, ν, ρ, η checks.
    fn validate(&self, _material: &Material) -> Result<(), EnergyError> {
        Ok(())
    }

    /// Whether the energy mixes a and b (a nonzero ∂²E/∂a∂b or bending that depends on a). When
    /// `false` the kernel skips the a–b blocks.
    fn coupled(&self) -> bool;

    /// Energies and (per `order`) derivatives of the face at forms a, b (entries); `out` is
    /// overwritten.
    #[allow(clippy::too_many_arguments)] // independent plain inputs of one kernel
    fn eval(
        &self,
        material: &Material,
        face: &FaceGeometry,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        terms: Terms,
        order: Order,
        out: &mut LawEval,
    );

    /// The energies (stretch, bend) (J) alone, for the energy-only kernel
    /// ([`crate::eval_face_energy`]), with `constants` = [`EnergyConstants::new`]`(material)`
    /// computed once per mesh evaluation. Default: [`eval`](Self::eval) at [`Order::Energy`];
    /// a law with a cheaper closed form overrides it (and has `eval` at [`Order::Energy`]
    /// agree with it).
    fn energy(
        &self,
        material: &Material,
        _constants: &EnergyConstants,
        face: &FaceGeometry,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        terms: Terms,
    ) -> (f64, f64) {
        let mut le = LawEval::default();
        self.eval(material, face, a, b, terms, Order::Energy, &mut le);
        (le.stretch, le.bend)
    }

    /// The mixed second derivative ∂²W/∂m∂m̄ (6×6; rows m = (a11, a12, a22, b11, b12, b22),
    /// columns m̄ = (ā11, ā12, ā22, b̄11, b̄12, b̄22), symmetric-entry convention of
    /// [`crate::small_matrix::sym_entries`]) of the energies switched on in `terms`, at forms a, b and
    /// rest forms ā, b̄ (entries): what differentiating an equilibrium in its rest forms needs
    /// ([`crate::rest_sensitivity`]). `None` (the default): the law does not provide it.
    fn rest_mixed(
        &self,
        _material: &Material,
        _a: &Vector3<f64>,
        _b: &Vector3<f64>,
        _a_bar: &Vector3<f64>,
        _b_bar: &Vector3<f64>,
        _terms: Terms,
    ) -> Option<Matrix6<f64>> {
        None
    }
}

/// Constants of a [`Material`] that the energy-only kernel needs at every face, computed once
/// per mesh evaluation instead of once per face: h/8 and h³/24 (m, m³), α/2 and β (Pa), η/E (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnergyConstants {
    pub(crate) h_8: f64,
    pub(crate) h3_24: f64,
    pub(crate) half_alpha: f64,
    pub(crate) beta: f64,
    pub(crate) eta_over_e: f64,
}

impl EnergyConstants {
    /// The constants of `material` (not validated: [`crate::Assembler::evaluate`] validates).
    pub fn new(material: &Material) -> Self {
        let h = material.thickness;
        Self {
            h_8: h / 8.0,
            h3_24: h * h * h / 24.0,
            half_alpha: 0.5 * material.alpha(),
            beta: material.beta(),
            eta_over_e: material.viscosity / material.young,
        }
    }
}

/// The elastic model of a [`Material`] (scene key `[material] model`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum MaterialModel {
    /// St. Venant–Kirchhoff ([`StVK`], `"stvk"`): the paper's quadratic energies. Default.
    #[default]
    StVK,
    /// Compressible neo-Hookean stretching with a metric-aware bending term
    /// ([`NeoHookean`], `"neo_hookean"`).
    NeoHookean,
    /// Two bonded layers with their own moduli and eigenstrains ([`Bilayer`], `"bilayer"`).
    Bilayer(Bilayer),
    /// StVK stretching with the compressive stress relaxed (wrinkling), no bending
    /// ([`TensionField`], `"tension_field"`).
    TensionField,
}

impl MaterialModel {
    /// Scene names of the models, in declaration order.
    pub const NAMES: [&'static str; 4] = ["stvk", "neo_hookean", "bilayer", "tension_field"];

    /// The model's law.
    pub fn law(&self) -> &dyn ElasticLaw {
        match self {
            MaterialModel::StVK => &StVK,
            MaterialModel::NeoHookean => &NeoHookean,
            MaterialModel::Bilayer(b) => b,
            MaterialModel::TensionField => &TensionField,
        }
    }

    /// Scene name (`stvk`, `neo_hookean`, `bilayer`, `tension_field`).
    pub fn name(&self) -> &'static str {
        self.law().name()
    }

    /// [`ElasticLaw::energy`] of the model's law, dispatched statically (the energy-only
    /// kernel's per-face call, where a closed form such as [`StVK`]'s is inlined).
    #[inline]
    pub fn energy(
        &self,
        material: &Material,
        constants: &EnergyConstants,
        face: &FaceGeometry,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        terms: Terms,
    ) -> (f64, f64) {
        match self {
            MaterialModel::StVK => StVK.energy(material, constants, face, a, b, terms),
            MaterialModel::NeoHookean => NeoHookean.energy(material, constants, face, a, b, terms),
            MaterialModel::Bilayer(l) => l.energy(material, constants, face, a, b, terms),
            MaterialModel::TensionField => {
                TensionField.energy(material, constants, face, a, b, terms)
            }
        }
    }
}

/// Material parameters (SI units) and the elastic model.
///
/// `thickness`, `young` and `poisson` are the elastic constants of [`StVK`], [`NeoHookean`] and
/// [`TensionField`];
/// for every model they also set the Kelvin–Voigt damping (η/E, α, β) and, with `density`, the
/// mass. A [`Bilayer`] carries its layers' own constants; [`Material::bilayer`] sets the
/// shared ones from them.
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
    /// Elastic model (default [`MaterialModel::StVK`]).
    pub model: MaterialModel,
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
            model: MaterialModel::StVK,
        }
    }

    /// St. Venant–Kirchhoff material with every physical constant stated: thickness h (m),
    /// Young's modulus E (Pa), Poisson ratio ν, mass density ρ (kg/m³) and Kelvin–Voigt
    /// viscosity η (Pa·s; 0 for an undamped material). Checked by [`Material::validate`]
    /// (every evaluation calls it). Named presets: [`Material::paper`].
    pub fn stvk(thickness: f64, young: f64, poisson: f64, density: f64, viscosity: f64) -> Self {
        Self {
            thickness,
            young,
            poisson,
            density,
            viscosity,
            model: MaterialModel::StVK,
        }
    }

    /// St. Venant–Kirchhoff material of thickness h (m), Young's modulus E (Pa) and Poisson
    /// ratio ν, with **paper's** density (250 kg/m³) and viscosity ([`Material::paper`]).
    #[deprecated(
        note = "takes paper's density and viscosity silently (a steel plate's frequencies come \
                out 5.7x too high): use `Material::stvk(h, E, nu, density, viscosity)`, or \
                `Material { thickness, young, poisson, ..Material::paper() }` to mean paper's"
    )]
    pub fn new(thickness: f64, young: f64, poisson: f64) -> Self {
        Self {
            thickness,
            young,
            poisson,
            ..Self::paper()
        }
    }

    /// This material with the elastic model `model`.
    pub fn with_model(self, model: MaterialModel) -> Self {
        Self { model, ..self }
    }

    /// A [`Bilayer`] of `bottom` and `top`, with density ρ (kg/m³) and viscosity η (Pa·s). The
    /// shared constants are the thickness-weighted averages: h = h₁ + h₂, E = (E₁h₁ + E₂h₂)/h,
    /// ν = (ν₁h₁ + ν₂h₂)/h (used by damping only).
    pub fn bilayer(bottom: Layer, top: Layer, density: f64, viscosity: f64) -> Self {
        let h = bottom.thickness + top.thickness;
        Self {
            thickness: h,
            young: (bottom.young * bottom.thickness + top.young * top.thickness) / h,
            poisson: (bottom.poisson * bottom.thickness + top.poisson * top.thickness) / h,
            density,
            viscosity,
            model: MaterialModel::Bilayer(Bilayer { bottom, top }),
        }
    }

    /// Checks h > 0, E > 0, 0 ≤ ν < 0.5, ρ > 0, η ≥ 0, all finite, then the model's own
    /// parameters ([`ElasticLaw::validate`]); names the first bad parameter.
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
        self.model.law().validate(self)
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
