//! Checks a parsed scene for out-of-range and contradictory values.
//!
//! Each problem is reported with the dotted key it concerns (`integrator.dt`,
//! `boundary.pins[1].axes`); the caller turns the key into a file position.

use std::collections::BTreeSet;

use super::schema::*;

pub use super::problem::Problem;
use super::problem::problem;

use super::problem::{Check, absent, finite, finite_all, matrix, positive};

/// Checks the whole scene; returns the first problem found.
pub fn validate(s: &SceneFile) -> Result<(), Problem> {
    let effects = effects(s)?;
    let on = |e: Effect| effects.contains(&e);
    super::mesh::validate(&s.mesh)?;
    initial(&s.initial)?;
    super::material::validate(&s.material)?;
    rest(&s.rest)?;
    bending(s, &on)?;
    super::growth::validate(&s.growth, on(Effect::Growth), on(Effect::Diffusion))?;
    loads(s, &on)?;
    boundary(&s.boundary)?;
    integrator(&s.integrator, &on)?;
    static_only(s, &on)?;
    if let Some(p) = &s.path {
        let context = super::path::PathContext {
            static_integrator: s.integrator.kind == IntegratorKind::Static,
            load_ramp: s.integrator.load_ramp.is_some(),
            end_time: s.integrator.end_time.is_some(),
            growth: on(Effect::Growth),
            prescribed: !s.boundary.prescribed.is_empty(),
            loads: [Effect::Gravity, Effect::Pressure, Effect::PointLoads]
                .into_iter()
                .any(&on),
        };
        super::path::validate(p, &context)?;
    }
    contact(s, on(Effect::Contact))?;
    output(&s.output)
}

fn contact(s: &SceneFile, on: bool) -> Check {
    if on && s.integrator.kind == IntegratorKind::Explicit {
        // Explicit Euler takes no Newton step for the CCD to limit.
        return Err(problem(
            "integrator.kind",
            "effect `contact` needs the `implicit` or `static` integrator",
        ));
    }
    if on && s.path.is_some() {
        return Err(problem(
            "path",
            "effect `contact` is not available with path following yet",
        ));
    }
    let Some(c) = &s.contact else {
        return Ok(());
    };
    if !on {
        return Err(problem(
            "contact",
            "section given but effect `contact` is not in `effects`",
        ));
    }
    if let Some(d) = c.distance {
        positive("contact.distance", d)?;
    }
    if let Some(k) = c.stiffness {
        positive("contact.stiffness", k)?;
    }
    if !c.self_contact && c.obstacles.is_empty() {
        return Err(problem(
            "contact",
            "`self = false` and no obstacles: nothing to keep apart",
        ));
    }
    for (i, o) in c.obstacles.iter().enumerate() {
        let key = format!("contact.obstacles[{i}]");
        let given = [
            ("point", o.point.is_some()),
            ("normal", o.normal.is_some()),
            ("center", o.center.is_some()),
            ("radius", o.radius.is_some()),
            ("min", o.min.is_some()),
            ("max", o.max.is_some()),
            ("path", o.path.is_some()),
        ];
        let needed: &[&str] = match o.kind {
            ObstacleKind::Plane => &["point", "normal"],
            ObstacleKind::Sphere => &["center", "radius"],
            ObstacleKind::Box => &["min", "max"],
            ObstacleKind::Mesh => &["path"],
        };
        for (name, g) in given {
            if needed.contains(&name) && !g {
                return Err(problem(&key, format!("this obstacle needs `{name}`")));
            }
        }
        for (name, g) in given {
            if g && !needed.contains(&name) {
                return Err(problem(
                    format!("{key}.{name}"),
                    "not a key of this obstacle kind",
                ));
            }
        }
        for (name, v) in [
            ("point", o.point),
            ("normal", o.normal),
            ("center", o.center),
            ("min", o.min),
            ("max", o.max),
        ] {
            if let Some(v) = v {
                finite_all(&format!("{key}.{name}"), &v)?;
            }
        }
        if let Some(n) = o.normal
            && n.iter().all(|&c| c == 0.0)
        {
            return Err(problem(format!("{key}.normal"), "must not be zero"));
        }
        if let Some(r) = o.radius {
            positive(&format!("{key}.radius"), r)?;
        }
        if o.path.as_deref().is_some_and(|p| p.trim().is_empty()) {
            return Err(problem(format!("{key}.path"), "must name an OBJ file"));
        }
        if let (Some(lo), Some(hi)) = (o.min, o.max)
            && (0..3).any(|k| lo[k] >= hi[k])
        {
            return Err(problem(
                format!("{key}.max"),
                format!("must exceed `min` on every axis (min {lo:?}, max {hi:?})"),
            ));
        }
    }
    Ok(())
}

fn effects(s: &SceneFile) -> Result<BTreeSet<Effect>, Problem> {
    let mut set = BTreeSet::new();
    for (i, &e) in s.effects.iter().enumerate() {
        if !set.insert(e) {
            return Err(problem(
                format!("effects[{i}]"),
                format!("effect `{}` is listed twice", e.key()),
            ));
        }
    }
    if !set.contains(&Effect::Stretching) && !set.contains(&Effect::Bending) {
        return Err(problem(
            "effects",
            "needs at least one elastic effect: `stretching` or `bending`",
        ));
    }
    Ok(set)
}

fn initial(i: &InitialSpec) -> Check {
    if let Some(m) = &i.linear_xy {
        finite_all("initial.linear_xy", &[m[0][0], m[0][1], m[1][0], m[1][1]])?;
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        if det <= 0.0 {
            return Err(problem(
                "initial.linear_xy",
                format!("must have a positive determinant (no flips, no collapse), got {det}"),
            ));
        }
    }
    if let Some(s) = i.scale {
        positive("initial.scale", s)?;
    }
    if let Some(w) = &i.wrap_cylinder {
        positive("initial.wrap_cylinder.radius", w.radius)?;
        if let Some(c) = w.center_x {
            finite("initial.wrap_cylinder.center_x", c)?;
        }
    }
    if let Some(v) = &i.velocity {
        finite_all("initial.velocity", v)?;
    }
    Ok(())
}

fn rest(r: &RestSpec) -> Check {
    match r.from {
        RestSource::Mesh => {
            absent("rest.a_xy", &r.a_xy, "when rest.from = \"mesh\"")?;
            absent("rest.b_xy", &r.b_xy, "when rest.from = \"mesh\"")
        }
        RestSource::Planar => {
            let a = r
                .a_xy
                .as_ref()
                .ok_or_else(|| problem("rest.a_xy", "is required when rest.from = \"planar\""))?;
            matrix("rest.a_xy", a, true)?;
            if let Some(b) = &r.b_xy {
                matrix("rest.b_xy", b, false)?;
            }
            Ok(())
        }
    }
}

fn bending(s: &SceneFile, on: &dyn Fn(Effect) -> bool) -> Check {
    if s.bending.is_none() {
        return Ok(());
    }
    if !on(Effect::Bending) {
        return Err(problem(
            "bending",
            "section given but effect `bending` is not in `effects`",
        ));
    }
    Ok(())
}

fn loads(s: &SceneFile, on: &dyn Fn(Effect) -> bool) -> Check {
    match (&s.gravity, on(Effect::Gravity)) {
        (Some(_), false) => {
            return Err(problem(
                "gravity",
                "section given but effect `gravity` is not in `effects`",
            ));
        }
        (Some(g), true) => finite_all("gravity.acceleration", &g.acceleration)?,
        _ => {}
    }
    match (&s.pressure, on(Effect::Pressure)) {
        (Some(_), false) => {
            return Err(problem(
                "pressure",
                "section given but effect `pressure` is not in `effects`",
            ));
        }
        (None, true) => {
            return Err(problem(
                "pressure",
                "effect `pressure` needs a [pressure] section with `value`",
            ));
        }
        (Some(p), true) => {
            finite("pressure.value", p.value)?;
            if let Some(a) = &p.axis {
                finite_all("pressure.axis", a)?;
                if a.iter().all(|c| *c == 0.0) {
                    return Err(problem("pressure.axis", "must be a nonzero vector"));
                }
            }
        }
        (None, false) => {}
    }
    match (s.point_loads.is_empty(), on(Effect::PointLoads)) {
        (false, false) => {
            return Err(problem(
                "point_loads",
                "given but effect `point_loads` is not in `effects`",
            ));
        }
        (true, true) => {
            return Err(problem(
                "point_loads",
                "effect `point_loads` needs at least one [[point_loads]] entry",
            ));
        }
        _ => {}
    }
    for (i, p) in s.point_loads.iter().enumerate() {
        finite_all(&format!("point_loads[{i}].force"), &p.force)?;
    }
    Ok(())
}

fn boundary(b: &BoundarySpec) -> Check {
    for (i, p) in b.pins.iter().enumerate() {
        super::region::validate(&format!("boundary.pins[{i}].region"), &p.region)?;
        if let Some(axes) = &p.axes {
            let key = format!("boundary.pins[{i}].axes");
            if axes.is_empty() || axes.len() > 3 {
                return Err(problem(key, "must be a non-empty subset of \"xyz\""));
            }
            let mut seen = BTreeSet::new();
            for c in axes.chars() {
                if !"xyz".contains(c) || !seen.insert(c) {
                    return Err(problem(
                        key,
                        format!("must be a subset of \"xyz\" without repeats, got \"{axes}\""),
                    ));
                }
            }
        }
    }
    for (i, c) in b.clamps.iter().enumerate() {
        super::region::validate(&format!("boundary.clamps[{i}].region"), &c.region)?;
    }
    for (i, p) in b.prescribed.iter().enumerate() {
        super::region::validate(&format!("boundary.prescribed[{i}].region"), &p.region)?;
        finite_all(&format!("boundary.prescribed[{i}].velocity"), &p.velocity)?;
    }
    Ok(())
}

/// Most steps a scene may ask for (directly or through `end_time`).
const MAX_STEPS: usize = 1_000_000_000;

fn integrator(i: &IntegratorSpec, on: &dyn Fn(Effect) -> bool) -> Check {
    let dynamic = matches!(i.kind, IntegratorKind::Implicit | IntegratorKind::Explicit);
    if dynamic {
        if !on(Effect::Inertia) {
            return Err(problem(
                "effects",
                "a dynamic integrator (implicit/explicit) needs effect `inertia`",
            ));
        }
        let dt =
            i.dt.ok_or_else(|| problem("integrator.dt", "is required by dynamic integrators"))?;
        positive("integrator.dt", dt)?;
        // The inertia term divides by Δt²: a Δt whose square underflows makes every step inf.
        if !(1.0 / (dt * dt)).is_finite() {
            return Err(problem(
                "integrator.dt",
                format!("is too small to compute with (1/dt² overflows), got {dt:e}"),
            ));
        }
        match (i.steps, i.end_time) {
            (Some(_), Some(_)) | (None, None) => {
                return Err(problem(
                    "integrator",
                    "give exactly one of `steps` and `end_time`",
                ));
            }
            (Some(0), None) => return Err(problem("integrator.steps", "must be ≥ 1")),
            (None, Some(t)) => {
                positive("integrator.end_time", t)?;
                if t / dt > MAX_STEPS as f64 {
                    return Err(problem(
                        "integrator.end_time",
                        format!("needs {:.3e} steps of dt = {dt}: more than 1e9", t / dt),
                    ));
                }
            }
            _ => {}
        }
    } else {
        for e in [Effect::Inertia, Effect::Damping] {
            if on(e) {
                return Err(problem(
                    "effects",
                    format!("effect `{}` has no meaning in a static solve", e.key()),
                ));
            }
        }
        if let Some(dt) = i.dt {
            positive("integrator.dt", dt)?;
        }
        if i.steps == Some(0) {
            return Err(problem("integrator.steps", "must be ≥ 1"));
        }
        absent(
            "integrator.end_time",
            &i.end_time,
            "to a static solve (use steps)",
        )?;
    }
    // The same bound as for `end_time`: a run of more steps would never finish.
    if let Some(k) = i.steps.filter(|&k| k > MAX_STEPS) {
        return Err(problem(
            "integrator.steps",
            format!("must be ≤ 1e9, got {k}"),
        ));
    }
    let n = &i.newton;
    if i.kind == IntegratorKind::Explicit && *n != NewtonSpec::default() {
        return Err(problem(
            "integrator.newton",
            "does not apply to the explicit integrator",
        ));
    }
    if let Some(t) = n.tolerance {
        positive("integrator.newton.tolerance", t)?;
    }
    if let Some(t) = n.step_tolerance {
        positive("integrator.newton.step_tolerance", t)?;
    }
    if n.max_iterations == Some(0) {
        return Err(problem("integrator.newton.max_iterations", "must be ≥ 1"));
    }
    Ok(())
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
    let has_loads = [Effect::Gravity, Effect::Pressure, Effect::PointLoads]
        .into_iter()
        .any(on)
        || !s.boundary.prescribed.is_empty();
    if s.integrator.load_ramp.is_some() && !has_loads {
        return Err(problem(
            "integrator.load_ramp",
            "has nothing to ramp: it needs effect `gravity`, `pressure` or `point_loads`, or \
             `boundary.prescribed`",
        ));
    }
    Ok(())
}

fn output(o: &OutputSpec) -> Check {
    if o.every == 0 {
        return Err(problem("output.every", "must be ≥ 1"));
    }
    let mut seen = BTreeSet::new();
    for (i, f) in o.formats.iter().enumerate() {
        if !seen.insert(*f) {
            return Err(problem(format!("output.formats[{i}]"), "is listed twice"));
        }
    }
    Ok(())
}
