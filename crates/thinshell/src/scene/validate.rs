//! Checks a parsed scene for out-of-range and contradictory values: each section's own checks
//! (in its module), in the order of the file, and the checks across sections.
//!
//! Each problem is reported with the dotted key it concerns (`integrator.dt`,
//! `boundary.pins[1].axes`); the caller turns the key into a file position.

use super::schema::*;

pub use super::problem::Problem;
use super::problem::{Check, absent, problem};

/// Checks the whole scene; returns the first problem found.
pub fn validate(s: &SceneFile) -> Result<(), Problem> {
    let effects = super::effects::validate(&s.effects)?;
    let on = |e: Effect| effects.contains(&e);
    super::mesh::validate(&s.mesh)?;
    super::initial::validate(&s.initial)?;
    super::material::validate(&s.material)?;
    super::rest::validate(&s.rest)?;
    super::bending::validate(&s.bending, on(Effect::Bending))?;
    super::growth::validate(&s.growth, on(Effect::Growth), on(Effect::Diffusion))?;
    super::loads::validate(s.load_specs(), &on)?;
    super::boundary::validate(&s.boundary)?;
    super::integrator::validate(&s.integrator, &on)?;
    static_only(s, &on)?;
    if let Some(p) = &s.path {
        let context = super::path::PathContext {
            static_integrator: s.integrator.kind == IntegratorKind::Static,
            load_ramp: s.integrator.load_ramp.is_some(),
            end_time: s.integrator.end_time.is_some(),
            growth: on(Effect::Growth),
            prescribed: !s.boundary.prescribed.is_empty(),
            loads: has_loads(&on),
        };
        super::path::validate(p, &context)?;
    }
    let contact = super::contact::ContactContext {
        on: on(Effect::Contact),
        explicit: s.integrator.kind == IntegratorKind::Explicit,
    };
    super::contact::validate(&s.contact, contact)?;
    super::output::validate(&s.output)
}

/// Whether a load effect is on (`gravity`, `pressure`, `point_loads`).
fn has_loads(on: &dyn Fn(Effect) -> bool) -> bool {
    [Effect::Gravity, Effect::Pressure, Effect::PointLoads]
        .into_iter()
        .any(on)
}

/// Keys that only a static solve reads: `integrator.load_ramp`; and `initial.velocity`, which
/// a static solve would silently drop (it has no velocities).
fn static_only(s: &SceneFile, on: &dyn Fn(Effect) -> bool) -> Check {
    if s.integrator.kind != IntegratorKind::Static {
        return absent(
            "integrator.load_ramp",
            &s.integrator.load_ramp,
            "to a dynamic integrator (loads act at full value from t = 0; ramp them in a \
             static solve)",
        );
    }
    if s.initial.velocity.is_some() {
        return Err(problem(
            "initial.velocity",
            "has no meaning in a static solve (it finds an equilibrium, with no velocities): \
             remove it or use a dynamic integrator",
        ));
    }
    if s.integrator.load_ramp.is_some() && !has_loads(on) && s.boundary.prescribed.is_empty() {
        return Err(problem(
            "integrator.load_ramp",
            "has nothing to ramp: it needs effect `gravity`, `pressure` or `point_loads`, or \
             `boundary.prescribed`",
        ));
    }
    Ok(())
}
