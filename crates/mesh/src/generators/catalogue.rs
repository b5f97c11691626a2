//! The named generators: one table of names, parameters and defaults, shared by scene files
//! (validation and build) and any other caller that picks a generator by name.

use std::f64::consts::PI;

use super::{
    annulus, cylinder_patch, disc, icosphere, icosphere_recursive, irregular_rectangle, rectangle,
    seed_square,
};
use crate::error::MeshError;
use crate::mesh::Mesh;

/// A parameter value: a real number (lengths in m, angles in rad) or a non-negative integer
/// (counts, levels, seeds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A real number.
    Real(f64),
    /// A non-negative integer.
    Int(u64),
}

impl Value {
    /// The value as a real number (integers converted exactly up to 2⁵³).
    pub fn as_real(self) -> f64 {
        match self {
            Value::Real(v) => v,
            Value::Int(i) => i as f64,
        }
    }
}

/// One parameter of a named generator: its key and the value used when it is not given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param {
    /// Key, as in scene files (`width`, `n_rings`, …).
    pub name: &'static str,
    /// Value used when the key is not given; its variant is the parameter's kind.
    pub default: Value,
}

const fn real(name: &'static str, default: f64) -> Param {
    Param {
        name,
        default: Value::Real(default),
    }
}

const fn int(name: &'static str, default: u64) -> Param {
    Param {
        name,
        default: Value::Int(default),
    }
}

/// A generator that can be chosen by name (scene files' `[mesh] generator = "…"`).
///
/// ```
/// use thinshell_mesh::generators::{Generator, Value};
///
/// let g = Generator::from_name("rectangle").ok_or("unknown generator")?;
/// assert_eq!(g.params().len(), 4);
/// // Keys not given take their defaults (width = height = 1 m, 10 × 10 cells).
/// let mesh = g.build(|key| (key == "nx").then_some(Value::Int(4)))?;
/// assert_eq!(mesh.n_faces(), 2 * 4 * 10);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Generator {
    /// [`seed_square`](super::seed_square).
    SeedSquare,
    /// [`rectangle`](super::rectangle).
    Rectangle,
    /// [`irregular_rectangle`](super::irregular_rectangle).
    IrregularRectangle,
    /// [`icosphere`](super::icosphere) (frequency-`2^level` geodesic sphere).
    Icosphere,
    /// [`icosphere_recursive`](super::icosphere_recursive) (standard recursive subdivision).
    IcosphereRecursive,
    /// [`cylinder_patch`](super::cylinder_patch).
    CylinderPatch,
    /// [`disc`](super::disc).
    Disc,
    /// [`annulus`](super::annulus).
    Annulus,
}

impl Generator {
    /// Every named generator, in the order error messages and documentation list them.
    pub const ALL: [Generator; 8] = [
        Generator::SeedSquare,
        Generator::Rectangle,
        Generator::IrregularRectangle,
        Generator::Icosphere,
        Generator::IcosphereRecursive,
        Generator::CylinderPatch,
        Generator::Disc,
        Generator::Annulus,
    ];

    /// The generator's name (`"rectangle"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Generator::SeedSquare => "seed_square",
            Generator::Rectangle => "rectangle",
            Generator::IrregularRectangle => "irregular_rectangle",
            Generator::Icosphere => "icosphere",
            Generator::IcosphereRecursive => "icosphere_recursive",
            Generator::CylinderPatch => "cylinder_patch",
            Generator::Disc => "disc",
            Generator::Annulus => "annulus",
        }
    }

    /// The generator called `name`, if any.
    pub fn from_name(name: &str) -> Option<Generator> {
        Generator::ALL.into_iter().find(|g| g.name() == name)
    }

    /// The keys the generator reads, with their defaults.
    pub fn params(self) -> &'static [Param] {
        const RECTANGLE: &[Param] = &[
            real("width", 1.0),
            real("height", 1.0),
            int("nx", 10),
            int("ny", 10),
        ];
        const IRREGULAR: &[Param] = &[
            real("width", 1.0),
            real("height", 1.0),
            int("n", 10),
            int("seed", 1),
        ];
        const SPHERE: &[Param] = &[real("radius", 1.0), int("level", 2)];
        const CYLINDER: &[Param] = &[
            real("radius", 1.0),
            real("angle", PI),
            real("length", 1.0),
            int("n_around", 16),
            int("n_along", 8),
        ];
        const DISC: &[Param] = &[real("radius", 1.0), int("n_rings", 8)];
        const ANNULUS: &[Param] = &[
            real("inner_radius", 0.5),
            real("outer_radius", 1.0),
            int("n_rings", 4),
            int("n_around", 32),
        ];
        match self {
            Generator::SeedSquare => &[],
            Generator::Rectangle => RECTANGLE,
            Generator::IrregularRectangle => IRREGULAR,
            Generator::Icosphere | Generator::IcosphereRecursive => SPHERE,
            Generator::CylinderPatch => CYLINDER,
            Generator::Disc => DISC,
            Generator::Annulus => ANNULUS,
        }
    }

    /// The default of parameter `key`, or `None` if the generator does not read it.
    pub fn default_of(self, key: &str) -> Option<Value> {
        self.params()
            .iter()
            .find(|p| p.name == key)
            .map(|p| p.default)
    }

    /// Builds the mesh. `given(key)` returns the value of each key the caller sets (`None`:
    /// use the default); it is asked only for the keys of [`params`](Self::params).
    ///
    /// Errors: [`MeshError::InvalidParameter`] for a value out of the generator's range or a
    /// real number given for an integer parameter.
    pub fn build(self, given: impl Fn(&'static str) -> Option<Value>) -> Result<Mesh, MeshError> {
        let args = Args {
            generator: self,
            given: &given,
        };
        match self {
            Generator::SeedSquare => seed_square(),
            Generator::Rectangle => rectangle(
                args.real("width")?,
                args.real("height")?,
                args.count("nx")?,
                args.count("ny")?,
            ),
            Generator::IrregularRectangle => irregular_rectangle(
                args.real("width")?,
                args.real("height")?,
                args.count("n")?,
                args.int("seed")?,
            ),
            Generator::Icosphere => icosphere(args.real("radius")?, args.count("level")?),
            Generator::IcosphereRecursive => {
                icosphere_recursive(args.real("radius")?, args.count("level")?)
            }
            Generator::CylinderPatch => cylinder_patch(
                args.real("radius")?,
                args.real("angle")?,
                args.real("length")?,
                args.count("n_around")?,
                args.count("n_along")?,
            ),
            Generator::Disc => disc(args.real("radius")?, args.count("n_rings")?),
            Generator::Annulus => annulus(
                args.real("inner_radius")?,
                args.real("outer_radius")?,
                args.count("n_rings")?,
                args.count("n_around")?,
            ),
        }
    }
}

/// The values a [`Generator::build`] call sees: given ones first, then the defaults.
struct Args<'a> {
    generator: Generator,
    given: &'a dyn Fn(&'static str) -> Option<Value>,
}

impl Args<'_> {
    fn value(&self, key: &'static str) -> Value {
        // Every key asked for here is in the generator's table (a test checks that each
        // generator builds from its defaults alone); NaN would be rejected by the generator.
        (self.given)(key)
            .or_else(|| self.generator.default_of(key))
            .unwrap_or(Value::Real(f64::NAN))
    }

    fn real(&self, key: &'static str) -> Result<f64, MeshError> {
        Ok(self.value(key).as_real())
    }

    fn int(&self, key: &'static str) -> Result<u64, MeshError> {
        match self.value(key) {
            Value::Int(i) => Ok(i),
            Value::Real(value) => Err(MeshError::InvalidParameter {
                name: key,
                value,
                reason: "must be a non-negative integer",
            }),
        }
    }

    fn count(&self, key: &'static str) -> Result<usize, MeshError> {
        let i = self.int(key)?;
        usize::try_from(i).map_err(|_| MeshError::InvalidParameter {
            name: key,
            value: i as f64,
            reason: "is too large",
        })
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_defaults_build() {
        for g in Generator::ALL {
            assert_eq!(Generator::from_name(g.name()), Some(g));
            let mesh = g.build(|_| None);
            assert!(mesh.is_ok(), "{}: {mesh:?}", g.name());
        }
        assert_eq!(Generator::from_name("sphere"), None);
    }

    #[test]
    fn given_values_override_defaults_and_kinds_are_checked() {
        let g = Generator::Disc;
        assert_eq!(g.default_of("n_rings"), Some(Value::Int(8)));
        assert_eq!(g.default_of("width"), None);
        let mesh = g
            .build(|k| (k == "n_rings").then_some(Value::Int(2)))
            .unwrap();
        assert_eq!(mesh.n_faces(), 6 * 2 * 2);
        let err = g
            .build(|k| (k == "n_rings").then_some(Value::Real(2.5)))
            .unwrap_err();
        assert!(matches!(
            err,
            MeshError::InvalidParameter {
                name: "n_rings",
                ..
            }
        ));
    }
}
