//! Set-ups shared by several test files and benches: materials, the seed's squares, the
//! swelling strip, the shrinking sphere; paths of shipped data and per-process temporary
//! directories.
//!
//! Each fixture keeps the numbers of the copies it replaced exactly, because the tests'
//! tolerances and expected iteration counts were measured with them. A fixture used by one
//! file only belongs in that file.

use std::path::PathBuf;

use nalgebra::{Matrix2, Vector2, Vector3};
use thinshell_energy::{Material, MaterialModel, RestState, SffKind, ShellModel, Terms};
use thinshell_growth::{FaceStimulus, Growth, Prescribed, Swelling};
use thinshell_mesh::{Mesh, generators};
use thinshell_solver::{State, Static};
use thinshell_system::{Boundary, Loads, ShellSystem};

/// Unit-scale material for single-face kernel checks: h = 0.3, E = 1, ν = 0.3, ρ = 1, with the
/// given viscosity η. Stretching, bending and damping are then of comparable size on O(1)
/// stencils.
pub fn unit_material(viscosity: f64) -> Material {
    Material {
        thickness: 0.3,
        young: 1.0,
        poisson: 0.3,
        density: 1.0,
        viscosity,
        model: MaterialModel::StVK,
    }
}

/// A soft, thick material for whole-mesh checks on unit sheets: h = 0.05, E = 1e3, ν = 0.3,
/// ρ = 1, η = 20 (stretching and bending of similar size, damping visible at Δt ~ 0.1).
pub fn soft_material() -> Material {
    Material {
        thickness: 0.05,
        young: 1.0e3,
        poisson: 0.3,
        density: 1.0,
        viscosity: 20.0,
        model: MaterialModel::StVK,
    }
}

/// The beam-theory strip material: h = 0.01 m, E = 1e7 Pa, ν = 0 (so the plate stiffness of a
/// strip equals the beam's E I), ρ = 1000 kg/m³, no damping.
pub const BEAM_MATERIAL: Material = Material {
    thickness: 0.01,
    young: 1e7,
    poisson: 0.0,
    density: 1000.0,
    viscosity: 0.0,
    model: MaterialModel::StVK,
};

/// [`Material::paper`] (E = 2 GPa, ν = 0.3) with thickness `h` (m).
pub fn paper(h: f64) -> Material {
    Material {
        thickness: h,
        ..Material::paper()
    }
}

/// [`Material::paper`] with a Kelvin–Voigt relaxation time η/E of `relaxation_time` (s).
pub fn damped_paper(relaxation_time: f64) -> Material {
    let paper = Material::paper();
    Material {
        viscosity: paper.young * relaxation_time,
        ..paper
    }
}

/// The seed's unit square mesh ([`generators::seed_square`]) with planar rest forms
/// (ā, b̄) = (`a_xy`, `b_xy`) in the xy basis.
pub fn seed_square(a_xy: Matrix2<f64>, b_xy: Matrix2<f64>) -> (Mesh, RestState) {
    let mesh = generators::seed_square().expect("the seed square builds");
    let rest = RestState::from_planar(&mesh, a_xy, b_xy).expect("planar rest forms");
    (mesh, rest)
}

/// The mesh's (x, y) mapped by `map` into the plane z = 0: the seed's planar starts.
pub fn planar_start(mesh: &Mesh, map: Matrix2<f64>) -> Vec<Vector3<f64>> {
    mesh.positions()
        .iter()
        .map(|p| {
            let q = map * Vector2::new(p.x, p.y);
            Vector3::new(q.x, q.y, 0.0)
        })
        .collect()
}

/// The moisture strip: a 100 × 2 mm paper strip, h = 1 mm, 50 cells along and `ny` across,
/// mid-edge-average bending without damping, whose top surface swells by Δm ramped linearly
/// from 0 to 1 over the first four unit time steps ([`swelling_strip`]).
pub struct SwellingStrip {
    /// The strip, flat and stress-free as built.
    pub system: ShellSystem,
    /// The swelling model driven by the ramp, growth thickness h.
    pub growth: Growth,
    /// `Static::default()` with the force scale of the bending moment resultant
    /// D·κ₀·w ≈ 4e-3 N and gradient tolerance 1e-6 (the gradient's round-off floor is
    /// ~1e-16·E·h·ℓ ≈ 4e-10 N).
    pub solver: Static,
    /// The flat start at rest.
    pub state: State,
}

impl SwellingStrip {
    /// Cells along the strip.
    pub const NX: usize = 50;
    /// Thickness h (m), of the shell and of the growth model.
    pub const THICKNESS: f64 = 1e-3;
}

/// Builds the [`SwellingStrip`] with `ny` cells across and the growth `model`.
pub fn swelling_strip(model: Swelling, ny: usize) -> SwellingStrip {
    let h = SwellingStrip::THICKNESS;
    let mesh = generators::rectangle(0.1, 0.002, SwellingStrip::NX, ny).expect("strip mesh");
    let x0 = mesh.positions().to_vec();
    let sff = SffKind::MidEdgeAverage;
    let initial = RestState::from_mesh(&mesh, &x0, sff).expect("rest forms of the strip");
    let ramp = Prescribed::function(
        &mesh,
        &x0,
        Box::new(|t, _| FaceStimulus {
            top: (t / 4.0).min(1.0),
            bottom: 0.0,
        }),
    )
    .expect("swelling ramp");
    let growth =
        Growth::new(Box::new(model), Box::new(ramp), initial.clone(), h).expect("growth set-up");
    let shell = ShellModel {
        material: paper(h),
        terms: Terms::ELASTIC,
        sff,
    };
    let system = ShellSystem::new(mesh, shell, initial, Boundary::default(), Loads::default())
        .expect("strip system");
    let mut solver = Static {
        force_scale: Some(4e-3),
        ..Static::default()
    };
    solver.newton.gradient_tolerance = 1e-6;
    SwellingStrip {
        system,
        growth,
        solver,
        state: State::at_rest(x0),
    }
}

/// The benches' shrinking sphere: the unit icosphere at `level` ([`generators::icosphere`]),
/// rest forms of the sphere with ā scaled by 0.9 (so it wants to shrink), paper, stretching and
/// bending with form `sff`, no loads, at rest in the sphere.
pub fn shrinking_sphere(level: usize, sff: SffKind) -> (ShellSystem, State) {
    let mesh = generators::icosphere(1.0, level).expect("icosphere");
    let x = mesh.positions().to_vec();
    let mut rest = RestState::from_mesh(&mesh, &x, sff).expect("rest forms of the sphere");
    rest.a_bar.iter_mut().for_each(|a| *a *= 0.9);
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let sys = ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default())
        .expect("sphere system");
    (sys, State::at_rest(x))
}

/// [`generators::stacked_sheets`] (a generic self-contact configuration), panicking on bad
/// arguments.
pub fn stacked_sheets(side: f64, n: usize, gap: f64, angle: f64) -> Mesh {
    generators::stacked_sheets(side, n, gap, angle).expect("two sheets")
}

/// The path of `rel` inside the repository's `data/` folder (shipped meshes and scenes).
pub fn data_path(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(rel)
}

/// `<temp>/thinshell-<name>-<process id>`, created if missing and otherwise left as it is, so
/// the tests of one process that run in parallel can share it (each writing its own files).
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("thinshell-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("create the temporary directory");
    d
}

/// Like [`temp_dir`] but emptied first: for a test that lists what it wrote.
pub fn fresh_temp_dir(name: &str) -> PathBuf {
    let d = temp_dir(name);
    std::fs::remove_dir_all(&d).expect("empty the temporary directory");
    std::fs::create_dir_all(&d).expect("create the temporary directory");
    d
}

/// The conformal cone (docs/robustness.md, "Indefinite Hessians near critical points"): a flat
/// annulus (radii 0.1 and 1 m, `rings × around` cells of [`generators::annulus`]) whose rest metric
/// is grown isotropically by e^{2s}, s = c·ln r per face (r at the face centroid, m), b̄ = 0: its
/// stretch-free shape is a round cone with sin(half-angle) = 1 + c (slant distance r^{1+c}/(1+c),
/// radius r^{1+c}). E = 1 MPa, ν = 0.3, ρ = 1000 kg/m³, StVK, stretching and bending with form
/// `sff`, free boundary, no loads.
pub struct ConformalCone {
    /// The system, rest forms grown.
    pub system: ShellSystem,
    /// Growth exponent c (the cone's sin(half-angle) is 1 + c).
    pub c: f64,
    /// The flat annulus (m).
    pub flat: Vec<Vector3<f64>>,
    /// The far start of the issue: the annulus lifted by 10⁻³·r² + 10⁻⁴·r·sin 3x (m).
    pub start: Vec<Vector3<f64>>,
    rings: usize,
    around: usize,
}

/// [`ConformalCone`] with growth exponent `c` ∈ (−1, 0), thickness `h` (m) and form `sff`.
pub fn conformal_cone(c: f64, h: f64, rings: usize, around: usize, sff: SffKind) -> ConformalCone {
    let mesh = generators::annulus(0.1, 1.0, rings, around).expect("annulus");
    let flat = mesh.positions().to_vec();
    let mut rest = RestState::from_mesh(&mesh, &flat, sff).expect("rest forms of the annulus");
    for (f, a) in rest.a_bar.iter_mut().enumerate() {
        let [i, j, k] = mesh.faces()[f];
        let centroid = (flat[i.idx()] + flat[j.idx()] + flat[k.idx()]) / 3.0;
        *a *= (2.0 * c * centroid.xy().norm().ln()).exp();
    }
    rest.b_bar.iter_mut().for_each(|b| *b = Matrix2::zeros());
    let material = Material {
        thickness: h,
        young: 1e6,
        poisson: 0.3,
        density: 1000.0,
        viscosity: 0.0,
        model: MaterialModel::StVK,
    };
    let model = ShellModel {
        material,
        terms: Terms::ELASTIC,
        sff,
    };
    let system = ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default())
        .expect("cone system");
    let start = flat
        .iter()
        .map(|p| {
            let r = p.xy().norm();
            p + Vector3::new(0.0, 0.0, 1e-3 * r * r + 1e-4 * (3.0 * p.x).sin() * r)
        })
        .collect();
    ConformalCone {
        system,
        c,
        flat,
        start,
        rings,
        around,
    }
}

impl ConformalCone {
    /// The stretch-free round cone (m): each flat point at radius r moved to slant distance
    /// r^{1+c}/(1+c) on the cone of sin(half-angle) 1 + c.
    pub fn round_cone(&self) -> Vec<Vector3<f64>> {
        let sin_a = 1.0 + self.c;
        let cos_a = (1.0 - sin_a * sin_a).max(0.0).sqrt();
        self.flat
            .iter()
            .map(|p| {
                let radius = p.xy().norm().powf(1.0 + self.c);
                let theta = p.y.atan2(p.x);
                Vector3::new(
                    radius * theta.cos(),
                    radius * theta.sin(),
                    radius / sin_a * cos_a,
                )
            })
            .collect()
    }

    /// Per ring (vertex circles of the annulus, inner to outer): centroid, mean distance from it
    /// (m) and largest relative deviation from that mean (out of round).
    fn rings_of(&self, x: &[Vector3<f64>]) -> Vec<(Vector3<f64>, f64, f64)> {
        (0..=self.rings)
            .map(|k| {
                let ring = &x[k * self.around..(k + 1) * self.around];
                let centroid = ring.iter().sum::<Vector3<f64>>() / self.around as f64;
                let radii: Vec<f64> = ring.iter().map(|p| (p - centroid).norm()).collect();
                let mean = radii.iter().sum::<f64>() / self.around as f64;
                let oor = radii.iter().fold(0.0f64, |m, r| m.max((r - mean).abs())) / mean;
                (centroid, mean, oor)
            })
            .collect()
    }

    /// Largest relative error of sin(half-angle) against 1 + c between neighbouring rings,
    /// away from the rims (flat radii in [0.3, 0.8] m: the bending boundary layers are about
    /// √(h·r) wide), from the rings' mean radii and centroids.
    pub fn sin_error(&self, x: &[Vector3<f64>]) -> f64 {
        let rings = self.rings_of(x);
        let r_flat = |k: usize| self.flat[k * self.around].xy().norm();
        (1..=self.rings)
            .filter(|&k| r_flat(k - 1) >= 0.3 - 1e-12 && r_flat(k) <= 0.8 + 1e-12)
            .map(|k| {
                let (c0, r0, _) = rings[k - 1];
                let (c1, r1, _) = rings[k];
                let dr = r1 - r0;
                let dc = (c1 - c0).norm();
                let sin_a = dr / (dr * dr + dc * dc).sqrt();
                ((sin_a - (1.0 + self.c)) / (1.0 + self.c)).abs()
            })
            .fold(0.0, f64::max)
    }

    /// Largest relative out-of-roundness of any ring.
    pub fn out_of_round(&self, x: &[Vector3<f64>]) -> f64 {
        self.rings_of(x).iter().map(|r| r.2).fold(0.0, f64::max)
    }
}

/// A flat rectangle `length × width` (m) along x, `nx × ny` cells, thickness `h` (m), Young's
/// modulus `young` (Pa), Poisson ratio `poisson`, StVK, default bending form, under an axial
/// end load `p` (N, compressive, spread over the x = `length` edge with half shares at its
/// corners): both ends held in z (free to rotate about them), the x = 0 end also in x, one
/// corner in y; `sides`: the long edges held in z too (a plate simply supported on all four
/// edges). `f` (N, +z) is a lateral force at the vertex nearest the centre (an imperfection;
/// 0: none). Returns the system and the flat start. Euler's strut (`sides = false`, ν = 0):
/// P_cr = π²EI/L²; the square plate (`sides = true`): N_cr = 4π²D/a².
#[allow(clippy::too_many_arguments)]
pub fn compressed_plate(
    length: f64,
    width: f64,
    nx: usize,
    ny: usize,
    h: f64,
    young: f64,
    poisson: f64,
    sides: bool,
    p: f64,
    f: f64,
) -> (ShellSystem, Vec<Vector3<f64>>) {
    use thinshell_mesh::VertexId;
    let mesh = generators::rectangle(length, width, nx, ny).expect("rectangle");
    let x0 = mesh.positions().to_vec();
    let sff = SffKind::default();
    let rest = RestState::from_mesh(&mesh, &x0, sff).expect("rest forms of the plate");
    let vertex = |i: usize, j: usize| VertexId::new(j * (nx + 1) + i);
    let mut pinned = vec![(vertex(0, 0), 1)];
    let mut forces = Vec::new();
    for j in 0..=ny {
        pinned.push((vertex(0, j), 0));
        pinned.push((vertex(0, j), 2));
        pinned.push((vertex(nx, j), 2));
        let share = if j == 0 || j == ny { 0.5 } else { 1.0 } / ny as f64;
        forces.push((vertex(nx, j), Vector3::new(-p * share, 0.0, 0.0)));
    }
    if f != 0.0 {
        forces.push((vertex(nx / 2, ny / 2), Vector3::new(0.0, 0.0, f)));
    }
    if sides {
        for i in 1..nx {
            pinned.push((vertex(i, 0), 2));
            pinned.push((vertex(i, ny), 2));
        }
    }
    let boundary = Boundary {
        pinned_coordinates: pinned,
        ..Boundary::default()
    };
    let loads = Loads {
        point_forces: forces,
        ..Loads::default()
    };
    let system = elastic_system(mesh, rest, (h, young, poisson), boundary, loads);
    (system, x0)
}

/// The elastic (no inertia, no damping) StVK system of the critical-load fixtures, default
/// form: `(h, E, ν)` in m, Pa, –; density 1000 kg/m³ (unused by static solves).
fn elastic_system(
    mesh: Mesh,
    rest: RestState,
    (h, young, poisson): (f64, f64, f64),
    boundary: Boundary,
    loads: Loads,
) -> ShellSystem {
    let model = ShellModel {
        material: Material {
            thickness: h,
            young,
            poisson,
            density: 1000.0,
            viscosity: 0.0,
            model: MaterialModel::StVK,
        },
        terms: Terms::ELASTIC,
        sff: SffKind::default(),
    };
    ShellSystem::new(mesh, model, rest, boundary, loads).expect("elastic system of a fixture")
}

/// A long tube of radius `radius` (m) around z under uniform external pressure `p` (Pa,
/// inward), `n_around × n_along` cells of about square shape (length `n_along` cells), thickness
/// `h` (m), Young's modulus `young` (Pa), Poisson ratio `poisson`, StVK, default bending form.
/// Every vertex is held along the axis (plane strain: the tube's cross-section is that of an
/// infinitely long one), the vertices at θ = 0 and π in y and those at θ = ±π/2 in x (no rigid
/// motion left — one line of each would leave a rotation about an axis off the tube's; all four
/// are nodal lines of the tangential displacement of the two-lobed buckling mode cos 2θ). The pressure's volume is the tube's own ([`Loads::pressure_axis`] = z).
/// Ring buckling under pressure that stays normal to the surface: p_cr = 3D/R³ with
/// D = E h³/(12(1 − ν²)) (Timoshenko & Gere §7.3). `f` (N) pushes the vertex at θ = 0 of the
/// middle ring inwards (an imperfection; 0: none). `n_around` must be a multiple of 4.
/// Returns the system and the round start.
#[allow(clippy::too_many_arguments)]
pub fn pressurised_tube(
    radius: f64,
    n_around: usize,
    n_along: usize,
    h: f64,
    young: f64,
    poisson: f64,
    p: f64,
    f: f64,
) -> (ShellSystem, Vec<Vector3<f64>>) {
    use thinshell_mesh::VertexId;
    assert!(n_around % 4 == 0, "n_around must be a multiple of 4");
    let cell = std::f64::consts::TAU * radius / n_around as f64;
    let length = cell * n_along as f64;
    let mesh = generators::cylinder_patch(radius, std::f64::consts::TAU, length, n_around, n_along)
        .expect("tube");
    let x0 = mesh.positions().to_vec();
    let sff = SffKind::default();
    let rest = RestState::from_mesh(&mesh, &x0, sff).expect("rest forms of the tube");
    // cylinder_patch numbers ring j's vertices j·n_around + i at angle 2π i / n_around.
    let mut pinned = Vec::new();
    for j in 0..=n_along {
        for i in 0..n_around {
            pinned.push((VertexId::new(j * n_around + i), 2));
        }
        for q in [0, n_around / 2] {
            pinned.push((VertexId::new(j * n_around + q), 1));
            pinned.push((VertexId::new(j * n_around + q + n_around / 4), 0));
        }
    }
    let boundary = Boundary {
        pinned_coordinates: pinned,
        ..Boundary::default()
    };
    let mut point_forces = Vec::new();
    if f != 0.0 {
        point_forces.push((
            VertexId::new(n_along / 2 * n_around),
            Vector3::new(-f, 0.0, 0.0),
        ));
    }
    let loads = Loads {
        pressure: -p,
        pressure_axis: Some(Vector3::z()),
        point_forces,
        ..Loads::default()
    };
    let system = elastic_system(mesh, rest, (h, young, poisson), boundary, loads);
    (system, x0)
}

/// The shallow arch strip of the path-following tests: span 1 m, width 0.1 m, 20 × 2 cells,
/// curved into z = rise·(1 − (2x − 1)²), h = 10 mm, E = 10 MPa, ν = 0.3 (paper's density), both
/// short ends pinned and `force` (N) down on the crown vertex at load factor 1; the system is at
/// load factor 0. Returns the system, the arch's positions and the crown vertex.
pub fn shallow_arch(
    rise: f64,
    force: f64,
    sff: SffKind,
) -> (ShellSystem, Vec<Vector3<f64>>, thinshell_mesh::VertexId) {
    use thinshell_mesh::VertexId;
    let flat = generators::rectangle(1.0, 0.1, 20, 2).expect("rectangle");
    let x: Vec<Vector3<f64>> = flat
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x, p.y, rise * (1.0 - (2.0 * p.x - 1.0).powi(2))))
        .collect();
    let mesh = Mesh::new(x.clone(), flat.faces_usize()).expect("arch mesh");
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).expect("rest state");
    let model = ShellModel {
        material: Material {
            thickness: 0.01,
            young: 1e7,
            poisson: 0.3,
            ..Material::paper()
        },
        terms: Terms::ELASTIC,
        sff,
    };
    let ends = (0..mesh.n_vertices())
        .map(VertexId::new)
        .filter(|v| x[v.idx()].x < 1e-9 || x[v.idx()].x > 1.0 - 1e-9)
        .collect();
    let crown = mesh.nearest_vertex(&Vector3::new(0.5, 0.05, rise));
    let boundary = Boundary {
        pinned_vertices: ends,
        ..Default::default()
    };
    let loads = Loads {
        point_forces: vec![(crown, Vector3::new(0.0, 0.0, -force))],
        ..Default::default()
    };
    let mut system = ShellSystem::new(mesh, model, rest, boundary, loads).expect("arch system");
    system.set_load_factor(0.0).expect("load factor 0");
    (system, x, crown)
}
