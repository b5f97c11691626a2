//! `[material] model` end to end (docs/scenes.md, model.md §2.1–2.3): a bimetal strip curls to
//! Timoshenko's curvature; neo-Hookean and tension-field scenes against closed forms; bad
//! material tables.
#![allow(clippy::unwrap_used)]

use std::path::Path;

use nalgebra::{SMatrix, SVector};
use thinshell::scene::Scene;
use thinshell::sim::Simulation;

fn simulation(text: &str) -> Simulation {
    let scene = Scene::from_toml(text, "materials.toml", Path::new(".")).unwrap();
    Simulation::build(&scene).unwrap()
}

/// Strip of NX × NY cells, length L = 3 mm, width 1 mm.
const NX: usize = 12;
const NY: usize = 4;
const LENGTH: f64 = 3e-3;
const WIDTH: f64 = 1e-3;

/// Pins that remove the rigid motions only: the middle vertex (xyz), the middle of the right
/// edge (yz) and the middle of the top edge (z).
fn rigid_pins() -> String {
    let v = |i: usize, j: usize| j * (NX + 1) + i;
    format!(
        "[[boundary.pins]]\nregion = {{ vertices = [{}] }}\n\
         [[boundary.pins]]\nregion = {{ vertices = [{}] }}\naxes = \"yz\"\n\
         [[boundary.pins]]\nregion = {{ vertices = [{}] }}\naxes = \"z\"\n",
        v(NX / 2, NY / 2),
        v(NX, NY / 2),
        v(NX / 2, NY),
    )
}

/// Least-squares z = p0 + p1 x + p2 y + p3 x² + p4 xy + p5 y² over all vertices.
fn quadratic_fit(sim: &Simulation) -> SVector<f64, 6> {
    let mut ata = SMatrix::<f64, 6, 6>::zeros();
    let mut atz = SVector::<f64, 6>::zeros();
    for p in sim.positions() {
        let row = SVector::<f64, 6>::from([1.0, p.x, p.y, p.x * p.x, p.x * p.y, p.y * p.y]);
        ata += row * row.transpose();
        atz += row * p.z;
    }
    ata.lu().solve(&atz).unwrap()
}

/// Timoshenko's bimetal curvature, m = h₁/h₂, n = E₁/E₂ (equal ν).
fn timoshenko(delta: f64, h1: f64, h2: f64, e1: f64, e2: f64) -> f64 {
    let (m, n) = (h1 / h2, e1 / e2);
    6.0 * delta * (1.0 + m).powi(2)
        / ((h1 + h2) * (3.0 * (1.0 + m).powi(2) + (1.0 + m * n) * (m * m + 1.0 / (m * n))))
}

/// A flat bimetal strip (bottom 40 µm at 3 GPa, top 60 µm at 1 GPa, ν = 0.3 both, the top one
/// heated to a 1e-4 larger eigenstrain), static solve with only the rigid motions pinned and the
/// default bending form: the sheet curls into a shallow cap (deflection ≈ 2 µm ≪ h, the linear
/// plate regime, where a free plate with a uniform eigen-moment takes a uniform isotropic
/// curvature) with the top side convex (z = −κ r²/2 with the normals along +z). Both curvatures
/// of the fitted quadratic within 1e-3 of Timoshenko's κ (measured 6e-5 along, 2.4e-4 across on
/// this 12 × 4 grid: a uniform curvature is nearly exact for the edge-director form; plane
/// stress in each layer; equal ν makes the plate's κ the beam formula's; Δε = ε_top −
/// ε_bottom, whose difference from (s_top − s_bottom)/2 is 1e-4 relative); the twist |κ_xy|
/// below 1e-3 κ. The `[material]` table has only the model and its layers.
#[test]
fn bimetal_strip_curls_to_timoshenko() {
    let (h1, h2, e1, e2, eps) = (4e-5, 6e-5, 3e9, 1e9, 1e-4);
    let text = format!(
        "effects = [\"stretching\", \"bending\"]\n\
         [mesh]\ngenerator = \"rectangle\"\nwidth = {LENGTH}\nheight = {WIDTH}\nnx = {NX}\nny = {NY}\n\
         [material]\nmodel = \"bilayer\"\n\
         bottom = {{ thickness = {h1}, young = {e1}, poisson = 0.3, eigenstrain = 0.0 }}\n\
         top = {{ thickness = {h2}, young = {e2}, poisson = 0.3, eigenstrain = {eps} }}\n\
         [integrator]\nkind = \"static\"\nsteps = 1\n{}",
        rigid_pins()
    );
    let mut sim = simulation(&text);
    sim.step().unwrap();
    let p = quadratic_fit(&sim);
    let want = timoshenko(eps, h1, h2, e1, e2);
    let (kxx, kyy, kxy) = (-2.0 * p[3], -2.0 * p[5], -p[4]);
    for (name, k) in [("κ_xx", kxx), ("κ_yy", kyy)] {
        assert!(
            (k / want - 1.0).abs() < 1e-3,
            "{name} = {k}, Timoshenko {want}"
        );
    }
    assert!(kxy.abs() < 1e-3 * want, "twist {kxy}");
}

/// The strip, flat, with `model` and the planar rest metric a_xy = diag(sx, sy), one static
/// step.
fn planar_rest_scene(sx: f64, sy: f64, model: &str) -> String {
    format!(
        "effects = [\"stretching\", \"bending\"]\n\
         [mesh]\ngenerator = \"rectangle\"\nwidth = {LENGTH}\nheight = {WIDTH}\nnx = {NX}\nny = {NY}\n\
         [material]\nmodel = \"{model}\"\n\
         [rest]\nfrom = \"planar\"\na_xy = [[{sx}, 0.0], [0.0, {sy}]]\n\
         [integrator]\nkind = \"static\"\nsteps = 1\n"
    )
}

/// Neo-Hookean through a scene: (1) a sheet whose rest metric is shrunk (planar ā = s·I, s =
/// 0.64) held flat along its whole boundary stays in uniform equibiaxial stretch μ = 1/√s = 1.25
/// with the closed-form energy h/4·[β(2μ² − 2 − 4 ln μ) + 4α ln²μ]·2·(rest area), relative
/// 1e-9 (StVK's differs by 13 %); (2) with the rest metric enlarged (s = 2.25) and only rigid
/// motions pinned, a static solve reaches the stress-free state: energy < 1e-12 of the start's
/// and the area grown by s within 1e-6.
#[test]
fn neo_hookean_scenes() {
    let (h, e, nu) = (1e-4, 2e9, 0.3);
    let (alpha, beta) = (e * nu / (1.0 - nu * nu), e / (2.0 * (1.0 + nu)));
    let base = |s: f64, model: &str| planar_rest_scene(s, s, model);
    // (1) Boundary held.
    let s = 0.64f64;
    let mu = 1.0 / s.sqrt();
    let psi = beta * (2.0 * mu * mu - 2.0 - 4.0 * mu.ln()) + 4.0 * alpha * mu.ln().powi(2);
    let want = h / 4.0 * psi * 2.0 * s * LENGTH * WIDTH;
    let mut held = String::new();
    for (min, max) in [
        ([-1.0, -1.0], [1e-9, 1.0]),
        ([LENGTH - 1e-9, -1.0], [1.0, 1.0]),
        ([-1.0, -1.0], [1.0, 1e-9]),
        ([-1.0, WIDTH - 1e-9], [1.0, 1.0]),
    ] {
        held += &format!(
            "[[boundary.pins]]\nregion = {{ box = {{ min = [{}, {}, -1.0], max = [{}, {}, 1.0] }} }}\n",
            min[0], min[1], max[0], max[1]
        );
    }
    let mut sim = simulation(&(base(s, "neo_hookean") + &held));
    sim.step().unwrap();
    let got = sim.energy();
    assert!(
        (got.stretch / want - 1.0).abs() < 1e-9,
        "{} vs {want}",
        got.stretch
    );
    let stvk = simulation(&(base(s, "stvk") + &held)).energy().stretch;
    assert!((stvk / want - 1.0).abs() > 0.1, "StVK {stvk} vs NH {want}");

    // (2) Free expansion to the rest size.
    let s = 2.25;
    let mut sim = simulation(&(base(s, "neo_hookean") + &rigid_pins()));
    let start = sim.energy().total();
    sim.step().unwrap();
    assert!(sim.energy().total() < 1e-12 * start, "{:?}", sim.energy());
    let area: f64 = sim
        .mesh()
        .faces()
        .iter()
        .map(|f| {
            let x = sim.positions();
            let (a, b, c) = (x[f[0].idx()], x[f[1].idx()], x[f[2].idx()]);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum();
    assert!(
        (area / (s * LENGTH * WIDTH) - 1.0).abs() < 1e-6,
        "area {area}"
    );
}

/// `model = "tension_field"` through a scene (model.md §2.3): the flat start of a sheet whose
/// planar rest metric is a_xy = diag(0.81, 1.21) is stretched along x (strain λ₁ = 1/0.81 − 1) and
/// compressed along y (λ₂ = 1/1.21 − 1 < −ν λ₁): wrinkled everywhere, so its energy is the
/// uniaxial h/8 · E/2 · λ₁² · 2·(rest area), rest area √(0.81·1.21)·L·W, relative 1e-12, with
/// no bending energy; StVK's differs by more than 10 %.
#[test]
fn tension_field_scene_relaxes_compression() {
    let (h, e) = (1e-4, 2e9);
    let (sx, sy) = (0.81f64, 1.21f64);
    let text = |model: &str| planar_rest_scene(sx, sy, model);
    let l1 = 1.0 / sx - 1.0;
    let want = h / 8.0 * 0.5 * e * l1 * l1 * 2.0 * (sx * sy).sqrt() * LENGTH * WIDTH;
    let got = simulation(&text("tension_field")).energy();
    assert!(
        (got.stretch / want - 1.0).abs() < 1e-12,
        "{} vs {want}",
        got.stretch
    );
    assert_eq!(got.bend, 0.0);
    let stvk = simulation(&text("stvk")).energy().stretch;
    assert!((stvk / want - 1.0).abs() > 0.1, "StVK {stvk} vs {want}");
}

/// Bad `[material]` tables are scene errors with file:line:col: an unknown model lists the
/// valid ones; a single-layer key with `bilayer`, a layer with `stvk`, a missing layer, a bad
/// layer value.
#[test]
fn bad_material_tables() {
    let load = |material: &str| {
        let text = format!(
            "effects = [\"stretching\", \"bending\"]\n[mesh]\ngenerator = \"seed_square\"\n\
             [integrator]\nkind = \"static\"\n[material]\n{material}\n"
        );
        Scene::from_toml(&text, "scene.toml", Path::new("."))
            .unwrap_err()
            .to_string()
    };
    let layer = "{ thickness = 5e-5, young = 2e9, poisson = 0.3, eigenstrain = 0.0 }";
    let cases = [
        (
            "model = \"rubber\"".to_string(),
            vec![
                "scene.toml:7:",
                "unknown variant `rubber`, expected one of `stvk`, `neo_hookean`, `bilayer`, `tension_field`",
            ],
        ),
        (
            format!("model = \"bilayer\"\nyoung = 1e9\nbottom = {layer}\ntop = {layer}"),
            vec![
                "scene.toml:8:",
                "`material.young` does not apply to model = \"bilayer\"",
            ],
        ),
        (
            format!("model = \"neo_hookean\"\ntop = {layer}"),
            vec![
                "scene.toml:8:",
                "`material.top` does not apply to model = \"neo_hookean\"",
            ],
        ),
        (
            format!("top = {layer}"),
            vec![
                "scene.toml:7:",
                "`material.top` does not apply to model = \"stvk\"",
            ],
        ),
        (
            format!("model = \"bilayer\"\nbottom = {layer}"),
            vec!["`material.top` is required with model = \"bilayer\""],
        ),
        (
            format!(
                "model = \"bilayer\"\nbottom = {layer}\n\
                 top = {{ thickness = 5e-5, young = 2e9, poisson = 0.5, eigenstrain = 0.0 }}"
            ),
            vec![
                "scene.toml:9:",
                "`material.top.poisson` must be in [0, 0.5), got 0.5",
            ],
        ),
        (
            "model = \"bilayer\"\nbottom = { thickness = 5e-5, young = 2e9, poisson = 0.3 }"
                .to_string(),
            vec!["scene.toml:8:", "missing field `eigenstrain`"],
        ),
    ];
    for (material, wants) in cases {
        let msg = load(&material);
        for w in wants {
            assert!(msg.contains(w), "{material}:\n{msg}\nlacks: {w}");
        }
    }
}
