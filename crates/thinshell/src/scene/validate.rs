//! Checks a parsed scene for out-of-range and contradictory values.
//!
//! Each problem is reported with the dotted key it concerns (`integrator.dt`,
//! `boundary.pins[1].axes`); the caller turns the key into a file position.

use std::collections::BTreeSet;

use thinshell_mesh::generators::Generator;

use super::schema::*;

/// One problem found in a scene: the key it concerns and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// Dotted key path, e.g. `material.poisson` or `boundary.pins[0].axes`.
    pub key: String,
    /// What is wrong, in one sentence.
    pub message: String,
}

fn problem(key: impl Into<String>, message: impl Into<String>) -> Problem {
    Problem {
        key: key.into(),
        message: message.into(),
    }
}

type Check = Result<(), Problem>;

fn finite(key: &str, v: f64) -> Check {
    if v.is_finite() {
        Ok(())
    } else {
        Err(problem(key, format!("must be a finite number, got {v}")))
    }
}

fn positive(key: &str, v: f64) -> Check {
    finite(key, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(problem(key, format!("must be > 0, got {v}")))
    }
}

fn finite_all(key: &str, v: &[f64]) -> Check {
    for (i, &x) in v.iter().enumerate() {
        if !x.is_finite() {
            return Err(problem(
                format!("{key}[{i}]"),
                format!("must be a finite number, got {x}"),
            ));
        }
    }
    Ok(())
}

fn matrix(key: &str, m: &[[f64; 2]; 2], spd: bool) -> Check {
    finite_all(key, &[m[0][0], m[0][1], m[1][0], m[1][1]])?;
    let scale = m[0][0]
        .abs()
        .max(m[1][1].abs())
        .max(m[0][1].abs())
        .max(1e-300);
    if (m[0][1] - m[1][0]).abs() > 1e-12 * scale {
        return Err(problem(key, "must be symmetric"));
    }
    if spd && !(m[0][0] > 0.0 && m[0][0] * m[1][1] - m[0][1] * m[1][0] > 0.0) {
        return Err(problem(key, "must be positive definite"));
    }
    Ok(())
}

fn absent<T>(key: &str, v: &Option<T>, why: &str) -> Check {
    match v {
        Some(_) => Err(problem(key, format!("does not apply {why}"))),
        None => Ok(()),
    }
}

/// Checks the whole scene; returns the first problem found.
pub fn validate(s: &SceneFile) -> Result<(), Problem> {
    let effects = effects(s)?;
    let on = |e: Effect| effects.contains(&e);
    mesh(&s.mesh)?;
    initial(&s.initial)?;
    material(&s.material)?;
    rest(&s.rest)?;
    bending(s, &on)?;
    growth(s, on(Effect::Growth), on(Effect::Diffusion))?;
    loads(s, &on)?;
    boundary(&s.boundary)?;
    integrator(&s.integrator, &on)?;
    static_only(s, &on)?;
    super::path::validate(s, &on)?;
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

fn mesh(m: &MeshSpec) -> Check {
    let allowed: Vec<&str> = match (&m.obj, &m.generator) {
        (Some(_), Some(_)) => {
            return Err(problem(
                "mesh",
                "give either `obj` or `generator`, not both",
            ));
        }
        (None, None) => return Err(problem("mesh", "needs `obj` or `generator`")),
        (Some(path), None) => {
            if path.trim().is_empty() {
                return Err(problem("mesh.obj", "is an empty path"));
            }
            Vec::new()
        }
        (None, Some(g)) => match Generator::from_name(g) {
            Some(generator) => generator.params().iter().map(|p| p.name).collect(),
            None => {
                let names: Vec<&str> = Generator::ALL.iter().map(|g| g.name()).collect();
                return Err(problem(
                    "mesh.generator",
                    format!("unknown generator `{g}`; known: {}", names.join(", ")),
                ));
            }
        },
    };
    let what = match &m.generator {
        Some(g) => format!("to generator `{g}`"),
        None => "to an OBJ mesh".to_string(),
    };
    for (key, _) in m.given() {
        if !allowed.contains(&key) {
            return Err(problem(
                format!("mesh.{key}"),
                format!("does not apply {what}"),
            ));
        }
    }
    for (key, v) in [
        ("width", m.width),
        ("height", m.height),
        ("radius", m.radius),
        ("angle", m.angle),
        ("length", m.length),
        ("inner_radius", m.inner_radius),
        ("outer_radius", m.outer_radius),
    ] {
        if let Some(v) = v {
            positive(&format!("mesh.{key}"), v)?;
        }
    }
    for (key, v, min) in [
        ("nx", m.nx, 1),
        ("ny", m.ny, 1),
        ("n", m.n, 2),
        ("n_around", m.n_around, 1),
        ("n_along", m.n_along, 1),
        ("n_rings", m.n_rings, 1),
    ] {
        if let Some(v) = v {
            if v < min {
                return Err(problem(
                    format!("mesh.{key}"),
                    format!("must be ≥ {min}, got {v}"),
                ));
            }
            if v > 4096 {
                return Err(problem(
                    format!("mesh.{key}"),
                    format!("must be ≤ 4096, got {v}"),
                ));
            }
        }
    }
    if let Some(level) = m.level {
        if level > 8 {
            return Err(problem(
                "mesh.level",
                format!("must be ≤ 8 (level 8 has 1.3 million faces), got {level}"),
            ));
        }
    }
    // The generator's defaults take part too: `inner_radius = 2` alone is as wrong as with an
    // explicit `outer_radius = 1`.
    if m.inner_radius.is_some() || m.outer_radius.is_some() {
        let default = |key| {
            Generator::Annulus
                .default_of(key)
                .map_or(f64::NAN, |v| v.as_real())
        };
        let a = m.inner_radius.unwrap_or_else(|| default("inner_radius"));
        let b = m.outer_radius.unwrap_or_else(|| default("outer_radius"));
        if a >= b {
            return Err(problem(
                "mesh.inner_radius",
                format!("must be smaller than outer_radius = {b}, got {a}"),
            ));
        }
    }
    if let Some(angle) = m.angle {
        if angle >= 2.0 * std::f64::consts::PI {
            return Err(problem("mesh.angle", format!("must be < 2π, got {angle}")));
        }
    }
    Ok(())
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

fn material(m: &MaterialSpec) -> Check {
    let model = m.model.name();
    let single = |key: &str, v: &Option<f64>| match v {
        Some(_) if m.model == MaterialModelName::Bilayer => Err(problem(
            key,
            "does not apply to model = \"bilayer\" (set it per layer in `bottom` and `top`)",
        )),
        _ => Ok(()),
    };
    single("material.thickness", &m.thickness)?;
    single("material.young", &m.young)?;
    single("material.poisson", &m.poisson)?;
    if m.model == MaterialModelName::Bilayer {
        for (key, layer) in [("material.bottom", &m.bottom), ("material.top", &m.top)] {
            let Some(l) = layer else {
                return Err(problem(key, "is required with model = \"bilayer\""));
            };
            positive(&format!("{key}.thickness"), l.thickness)?;
            positive(&format!("{key}.young"), l.young)?;
            poisson(&format!("{key}.poisson"), l.poisson)?;
            finite(&format!("{key}.eigenstrain"), l.eigenstrain)?;
            if l.eigenstrain <= -1.0 {
                return Err(problem(
                    format!("{key}.eigenstrain"),
                    format!("must be > -1, got {}", l.eigenstrain),
                ));
            }
        }
    } else {
        let why = format!("to model = \"{model}\" (only to \"bilayer\")");
        absent("material.bottom", &m.bottom, &why)?;
        absent("material.top", &m.top, &why)?;
        positive("material.thickness", m.thickness())?;
        positive("material.young", m.young())?;
        poisson("material.poisson", m.poisson())?;
    }
    positive("material.density", m.density)?;
    finite("material.viscosity", m.viscosity)?;
    if m.viscosity < 0.0 {
        return Err(problem(
            "material.viscosity",
            format!("must be ≥ 0, got {}", m.viscosity),
        ));
    }
    Ok(())
}

fn poisson(key: &str, v: f64) -> Check {
    finite(key, v)?;
    if !(0.0..0.5).contains(&v) {
        return Err(problem(key, format!("must be in [0, 0.5), got {v}")));
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

fn region(key: &str, r: &RegionSpec) -> Check {
    let n = [
        r.half_space.is_some(),
        r.sphere.is_some(),
        r.aabb.is_some(),
        r.vertices.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if n != 1 {
        return Err(problem(
            key,
            "needs exactly one of `half_space`, `sphere`, `box`, `vertices`",
        ));
    }
    if let Some(h) = &r.half_space {
        finite_all(&format!("{key}.half_space.point"), &h.point)?;
        finite_all(&format!("{key}.half_space.normal"), &h.normal)?;
        if h.normal.iter().all(|&c| c == 0.0) {
            return Err(problem(
                format!("{key}.half_space.normal"),
                "must not be zero",
            ));
        }
    }
    if let Some(s) = &r.sphere {
        finite_all(&format!("{key}.sphere.center"), &s.center)?;
        positive(&format!("{key}.sphere.radius"), s.radius)?;
    }
    if let Some(b) = &r.aabb {
        finite_all(&format!("{key}.box.min"), &b.min)?;
        finite_all(&format!("{key}.box.max"), &b.max)?;
        if (0..3).any(|i| b.min[i] > b.max[i]) {
            return Err(problem(
                format!("{key}.box"),
                "needs min ≤ max in every coordinate",
            ));
        }
    }
    if let Some(v) = &r.vertices {
        if v.is_empty() {
            return Err(problem(format!("{key}.vertices"), "is empty"));
        }
    }
    Ok(())
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

fn growth(s: &SceneFile, growth_on: bool, diffusion_on: bool) -> Check {
    let g = match (&s.growth, growth_on) {
        (None, false) => {
            if diffusion_on {
                return Err(problem(
                    "effects",
                    "effect `diffusion` needs effect `growth` and a [growth] section",
                ));
            }
            return Ok(());
        }
        (Some(_), false) => {
            return Err(problem(
                "growth",
                "section given but effect `growth` is not in `effects`",
            ));
        }
        (None, true) => {
            return Err(problem(
                "growth",
                "effect `growth` needs a [growth] section",
            ));
        }
        (Some(g), true) => g,
    };
    match g.model {
        GrowthModelKind::Isotropic => {
            absent(
                "growth.coefficient",
                &g.coefficient,
                "to isotropic growth (use p)",
            )?;
            if let Some(p) = g.p {
                finite("growth.p", p)?;
            }
        }
        GrowthModelKind::Linear | GrowthModelKind::Bilayer => {
            absent("growth.p", &g.p, "to swelling models")?;
            let c = g.coefficient.ok_or_else(|| {
                problem("growth.coefficient", "is required by the swelling models")
            })?;
            finite("growth.coefficient", c)?;
            match (&g.direction, g.cross_coefficient) {
                (None, None) => {}
                (Some(d), Some(cc)) => {
                    finite("growth.cross_coefficient", cc)?;
                    for (i, v) in d.iter().enumerate() {
                        finite(&format!("growth.direction[{i}]"), *v)?;
                    }
                    if d.iter().all(|v| *v == 0.0) {
                        return Err(problem("growth.direction", "must not be zero"));
                    }
                }
                (Some(_), None) => {
                    return Err(problem(
                        "growth.cross_coefficient",
                        "is required with `direction` (anisotropic swelling)",
                    ));
                }
                (None, Some(_)) => {
                    return Err(problem(
                        "growth.direction",
                        "is required with `cross_coefficient` (anisotropic swelling)",
                    ));
                }
            }
        }
    }
    if g.model == GrowthModelKind::Isotropic {
        absent("growth.direction", &g.direction, "to isotropic growth")?;
        absent(
            "growth.cross_coefficient",
            &g.cross_coefficient,
            "to isotropic growth",
        )?;
    }
    if let Some(rho) = g.mass_uptake {
        finite("growth.mass_uptake", rho)?;
    }
    let st = &g.stimulus;
    let k = "growth.stimulus";
    let is_diffusion = st.kind == StimulusKind::Diffusion;
    if is_diffusion != diffusion_on {
        return Err(problem(
            format!("{k}.kind"),
            if is_diffusion {
                "is `diffusion` but effect `diffusion` is not in `effects`"
            } else {
                "effect `diffusion` is on, so the stimulus kind must be `diffusion`"
            },
        ));
    }
    if !is_diffusion {
        absent(
            &format!("{k}.diffusivity"),
            &st.diffusivity,
            "without diffusion",
        )?;
        absent(&format!("{k}.layers"), &st.layers, "without diffusion")?;
        if !st.sources.is_empty() {
            return Err(problem(
                format!("{k}.sources"),
                "do not apply without diffusion",
            ));
        }
    }
    match st.kind {
        StimulusKind::Uniform => {
            absent(&format!("{k}.hot"), &st.hot, "to a uniform stimulus")?;
            absent(&format!("{k}.held"), &st.held, "to a uniform stimulus")?;
            match (st.value, st.top, st.bottom) {
                (Some(v), None, None) => finite(&format!("{k}.value"), v),
                (None, Some(t), Some(b)) => {
                    if g.model == GrowthModelKind::Isotropic && t != b {
                        return Err(problem(
                            format!("{k}.top"),
                            "isotropic growth takes one value (use `value`)",
                        ));
                    }
                    finite(&format!("{k}.top"), t)?;
                    finite(&format!("{k}.bottom"), b)
                }
                _ => Err(problem(
                    k,
                    "a uniform stimulus needs either `value` or both `top` and `bottom`",
                )),
            }
        }
        StimulusKind::DirectedHeat => {
            if g.model != GrowthModelKind::Isotropic {
                return Err(problem(
                    format!("{k}.kind"),
                    "`directed_heat` drives isotropic growth only",
                ));
            }
            absent(
                &format!("{k}.top"),
                &st.top,
                "to directed heat (use `value`)",
            )?;
            absent(
                &format!("{k}.bottom"),
                &st.bottom,
                "to directed heat (use `value`)",
            )?;
            let v = st
                .value
                .ok_or_else(|| problem(format!("{k}.value"), "is required (the hot value)"))?;
            finite(&format!("{k}.value"), v)?;
            let hot = st
                .hot
                .as_ref()
                .ok_or_else(|| problem(format!("{k}.hot"), "is required by directed heat"))?;
            region(&format!("{k}.hot"), hot)?;
            if let Some(held) = &st.held {
                region(&format!("{k}.held"), held)?;
            }
            Ok(())
        }
        StimulusKind::Diffusion => {
            for (key, v) in [
                ("value", &st.value),
                ("top", &st.top),
                ("bottom", &st.bottom),
            ] {
                absent(&format!("{k}.{key}"), v, "to diffusion (use `sources`)")?;
            }
            absent(&format!("{k}.hot"), &st.hot, "to diffusion")?;
            absent(&format!("{k}.held"), &st.held, "to diffusion")?;
            let d = st
                .diffusivity
                .ok_or_else(|| problem(format!("{k}.diffusivity"), "is required by diffusion"))?;
            positive(&format!("{k}.diffusivity"), d)?;
            if let Some(l) = st.layers {
                if !(1..=64).contains(&l) {
                    return Err(problem(
                        format!("{k}.layers"),
                        format!("must be in 1..=64, got {l}"),
                    ));
                }
            }
            if st.sources.is_empty() {
                return Err(problem(
                    format!("{k}.sources"),
                    "diffusion needs at least one source",
                ));
            }
            for (i, src) in st.sources.iter().enumerate() {
                let sk = format!("{k}.sources[{i}]");
                match (src.value, src.flux) {
                    (Some(v), None) => finite(&format!("{sk}.value"), v)?,
                    (None, Some(f)) => finite(&format!("{sk}.flux"), f)?,
                    _ => {
                        return Err(problem(sk, "needs exactly one of `value` and `flux`"));
                    }
                }
                if let Some(r) = &src.region {
                    region(&format!("{sk}.region"), r)?;
                }
            }
            Ok(())
        }
    }
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
        (Some(p), true) => finite("pressure.value", p.value)?,
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
        region(&format!("boundary.pins[{i}].region"), &p.region)?;
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
        region(&format!("boundary.clamps[{i}].region"), &c.region)?;
    }
    for (i, p) in b.prescribed.iter().enumerate() {
        region(&format!("boundary.prescribed[{i}].region"), &p.region)?;
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
