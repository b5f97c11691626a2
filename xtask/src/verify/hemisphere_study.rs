//! Studies of the hemisphere with an 18° hole under alternating forces (issue #27): whether
//! the full model leaves the doubly symmetric branch the paper's quarter model is held on, and
//! how follower forces would change the path. Not checks: they print tables (run with
//! `--ignored --nocapture`).

use anyhow::{Result, bail};
use nalgebra::{Matrix3, SVD};
use thinshell_energy::{Material, SffKind};
use thinshell_mesh::{Mesh, VertexId, generators};
use thinshell_solver::Static;
use thinshell_system::{Boundary, ShellSystem};

use super::linear::hemisphere_loads;
use super::nonlinear::hemisphere_pins;
use super::solve::{Config, V3, equilibrium, held_by_pins, ramp};

const R: f64 = 10.0;

/// The hemisphere's mesh (rings, around) and its system under P_max = `pmax` per point, held
/// by `hemisphere_pins` (`mirror`) or by `Boundary::rigid_motion_pins` (`mirror` false).
fn system(
    level: usize,
    sff: SffKind,
    pmax: f64,
    mirror: bool,
) -> Result<(ShellSystem, [VertexId; 4])> {
    let (rings, around) = (8 + 4 * level, 32 + 16 * level);
    let hole = 18f64.to_radians();
    let mesh = generators::hemisphere_with_hole(R, hole, rings, around)?;
    let (forces, v) = hemisphere_loads(&mesh, R, pmax)?;
    let pins = if mirror {
        hemisphere_pins(&mesh, R, hole)?
    } else {
        Boundary::rigid_motion_pins(&mesh, VertexId::new(0))?
    };
    let material = Material {
        thickness: 0.04,
        young: 6.825e7,
        poisson: 0.3,
        ..Material::paper()
    };
    let sys = held_by_pins(mesh, sff, material, pins, forces)?;
    Ok((sys, v))
}

/// The vertex permutation of a mirror `m` (diagonal ±1) that maps the mesh onto itself, or an
/// error if the mesh is not symmetric under it.
fn mirror_map(mesh: &Mesh, m: V3) -> Result<Vec<usize>> {
    let tol = 1e-9 * mesh.bounding_box().diagonal();
    let p = mesh.positions();
    let map: Vec<usize> = p
        .iter()
        .map(|q| mesh.nearest_vertex(&q.component_mul(&m)).idx())
        .collect();
    for (i, &j) in map.iter().enumerate() {
        if (p[j] - p[i].component_mul(&m)).norm() > tol {
            bail!("vertex {i} has no mirror image under {m:?}");
        }
    }
    // Faces too: the triangulation must map onto itself, not only the vertices.
    let mut faces: Vec<[usize; 3]> = mesh
        .faces()
        .iter()
        .map(|f| {
            let mut k = [f[0].idx(), f[1].idx(), f[2].idx()];
            k.sort_unstable();
            k
        })
        .collect();
    faces.sort_unstable();
    for f in mesh.faces() {
        let mut k = [map[f[0].idx()], map[f[1].idx()], map[f[2].idx()]];
        k.sort_unstable();
        if faces.binary_search(&k).is_err() {
            bail!("face {f:?} has no mirror image under {m:?}");
        }
    }
    Ok(map)
}

/// The proper rigid motion (R, t) that best maps `p` onto `q` in least squares (Kabsch).
fn kabsch(p: &[V3], q: &[V3]) -> (Matrix3<f64>, V3) {
    let n = p.len() as f64;
    let pc = p.iter().sum::<V3>() / n;
    let qc = q.iter().sum::<V3>() / n;
    let h: Matrix3<f64> = p
        .iter()
        .zip(q)
        .map(|(a, b)| (a - pc) * (b - qc).transpose())
        .sum();
    let svd = SVD::new(h, true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return (Matrix3::identity(), qc - pc);
    };
    let d = (vt.transpose() * u.transpose()).determinant().signum();
    let rot = vt.transpose() * Matrix3::from_diagonal(&V3::new(1.0, 1.0, d)) * u.transpose();
    (rot, qc - rot * pc)
}

/// RMS distance (m) between `x` and its mirror image under `m` (vertex map `map`) after the
/// best rigid fit of the image onto `x`: 0 for a state with that symmetry, wherever the pins
/// put it.
fn asymmetry(x: &[V3], m: V3, map: &[usize]) -> f64 {
    let image: Vec<V3> = map.iter().map(|&j| x[j].component_mul(&m)).collect();
    let (rot, t) = kabsch(&image, x);
    let s: f64 = image
        .iter()
        .zip(x)
        .map(|(a, b)| (rot * a + t - b).norm_squared())
        .sum();
    (s / x.len() as f64).sqrt()
}

/// Radial displacements (m, outward positive) of the load points `v` after the best rigid fit
/// of `x` onto `x0`.
fn radial(x0: &[V3], x: &[V3], v: [VertexId; 4]) -> [f64; 4] {
    let (rot, t) = kabsch(x, x0);
    v.map(|i| {
        let p0 = x0[i.idx()];
        (rot * x[i.idx()] + t - p0).dot(&p0.normalize())
    })
}

/// The four mirror images' average of the positions of `c` (each image re-fitted rigidly onto
/// `c` first), edge angles 0 (the reference director, which is symmetric by construction): the
/// doubly symmetric part of a state, as a start for Newton.
fn symmetrised(c: &Config, maps: &[(V3, Vec<usize>)]) -> Config {
    let mut x = c.x.clone();
    let mut images = 1.0;
    let mut add = |image: Vec<V3>| {
        let (rot, t) = kabsch(&image, &c.x);
        for (s, a) in x.iter_mut().zip(&image) {
            *s += rot * a + t;
        }
        images += 1.0;
    };
    for (m, map) in maps {
        add(map.iter().map(|&j| c.x[j].component_mul(m)).collect());
    }
    // The composition of the two mirrors (a half turn about z).
    if let [(m0, s0), (m1, s1)] = maps {
        add(s0
            .iter()
            .map(|&j| c.x[s1[j]].component_mul(m0).component_mul(m1))
            .collect());
    }
    x.iter_mut().for_each(|p| *p /= images);
    Config {
        x,
        phi: vec![0.0; c.phi.len()],
    }
}

/// The form named by `HEMI_SYM_SFF` (mid, sin, tan; default tan).
fn form() -> SffKind {
    match std::env::var("HEMI_SYM_SFF").as_deref() {
        Ok("mid") => SffKind::MidEdgeAverage,
        Ok("sin") => SffKind::EdgeDirector(thinshell_energy::DirectorVariant::Sin),
        _ => SffKind::default(),
    }
}

fn list(var: &str, default: &str) -> Result<Vec<f64>> {
    Ok(std::env::var(var)
        .unwrap_or_else(|_| default.into())
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()?)
}

/// Symmetry and stability along the path (issue #27, hypothesis 1): at each load level the
/// largest pin force, the four load points' radial displacements (after the best rigid fit
/// onto the initial shape; pushed inward positive), the RMS asymmetry under the mirrors
/// y → −y and x → −x relative to the RMS displacement, the smallest eigenvalue of the exact
/// Hessian and the stretching share of the energy; at the last level the state symmetrised
/// and solved again. `HEMI_SYM_LEVELS`: mesh levels (default 2: 16×64); `HEMI_SYM_LAMBDA`:
/// load levels; `HEMI_SYM_SFF`: form; `HEMI_SYM_PINS=rigid`: the 3-2-1 pins instead of
/// `hemisphere_pins`; `HEMI_SYM_ENERGY` (set): also the energy of each mirror image and where
/// it differs (faces touching the boundary or not). Run:
/// `cargo test -p xtask --release hemisphere_symmetry_study -- --ignored --nocapture`.
#[test]
#[ignore = "a study of minutes; prints a table"]
fn hemisphere_symmetry_study() -> Result<()> {
    let levels = list("HEMI_SYM_LEVELS", "2")?;
    let lambdas = list(
        "HEMI_SYM_LAMBDA",
        "0.05,0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1",
    )?;
    let mirror = std::env::var("HEMI_SYM_PINS").as_deref() != Ok("rigid");
    println!(
        "pins {} | mesh | λ | +x (pulled) | −x (pulled) | +y (pushed) | −y (pushed) | asym y | asym x | rms u | min eig | stretch share | s",
        if mirror { "mirror" } else { "rigid" }
    );
    for &level in &levels {
        let (mut sys, v) = system(level as usize, form(), 400.0, mirror)?;
        let mesh = sys.mesh().clone();
        let maps = [
            (
                V3::new(1.0, -1.0, 1.0),
                mirror_map(&mesh, V3::new(1.0, -1.0, 1.0))?,
            ),
            (
                V3::new(-1.0, 1.0, 1.0),
                mirror_map(&mesh, V3::new(-1.0, 1.0, 1.0))?,
            ),
        ];
        let x0 = mesh.positions().to_vec();
        for &(i, k) in &sys.boundary().pinned_coordinates {
            println!("pin: vertex {} at {:.4?}, axis {k}", i.idx(), x0[i.idx()]);
        }
        let mut c = Config::of(&sys, x0.clone());
        let start = std::time::Instant::now();
        let faces = mesh.n_faces();
        let stopped = ramp(&mut sys, &mut c, &lambdas, 0.1, |sys, l, c| {
            let u = radial(&x0, &c.x, v);
            let (rot, t) = kabsch(&c.x, &x0);
            let rms =
                (c.x.iter()
                    .zip(&x0)
                    .map(|(p, q)| (rot * p + t - q).norm_squared())
                    .sum::<f64>()
                    / x0.len() as f64)
                    .sqrt();
            let reactions = sys.reactions_at(&c.x, &c.phi)?;
            let largest = reactions.iter().fold(0.0f64, |m, r| m.max(r.abs()));
            println!("  largest pin reaction / P: {:.3e}", largest / (400.0 * l));
            let eig = Static::default()
                .stability(sys, &c.x, &c.phi)?
                .min_eigenvalue;
            // A mirror-invariant energy has the same value at a state and its mirror image
            // (edge angles relaxed at each).
            let check = std::env::var("HEMI_SYM_ENERGY").is_ok();
            let e0 = sys.energy_at(&c.x, &[])?;
            for (m, map) in maps.iter().filter(|_| check) {
                let image: Vec<V3> = map.iter().map(|&j| c.x[j].component_mul(m)).collect();
                let _ = sys.energy_at(&image, &[])?;
                // Twice: the second relaxation starts from the image's own relaxed angles.
                let e1 = sys.energy_at(&image, &[])?;
                println!(
                    "  energy (stretch, bend) {:.10e} {:.10e}, mirror image {:.10e} {:.10e}",
                    e0.stretch, e0.bend, e1.stretch, e1.bend
                );
                {
                    // Where the image's energy differs: per face, by whether the face has a
                    // boundary vertex.
                    let f0 = sys.face_energies(&c.x, &[])?;
                    let f1 = sys.face_energies(&image, &[])?;
                    let faces = mesh.faces();
                    let mut index = std::collections::HashMap::new();
                    for (g, f) in faces.iter().enumerate() {
                        let mut k = [f[0].idx(), f[1].idx(), f[2].idx()];
                        k.sort_unstable();
                        index.insert(k, g);
                    }
                    let (mut edge, mut inner) = (0.0, 0.0);
                    for (fi, f) in faces.iter().enumerate() {
                        let mut k = [map[f[0].idx()], map[f[1].idx()], map[f[2].idx()]];
                        k.sort_unstable();
                        let g = index[&k];
                        let d = (f0[fi].bend - f1[g].bend).abs();
                        if f.iter().any(|&v| mesh.topology().is_boundary_vertex(v)) {
                            edge += d;
                        } else {
                            inner += d;
                        }
                    }
                    println!(
                        "  |Δ bend| summed over faces touching the boundary {edge:.3e}, other faces {inner:.3e}"
                    );
                }
            }
            println!(
                "{faces} | {l} | {:.4} | {:.4} | {:.4} | {:.4} | {:.2e} | {:.2e} | {:.4} | {:.3e} | {:.3} | {:.1}",
                u[0],
                u[1],
                -u[2],
                -u[3],
                asymmetry(&c.x, maps[0].0, &maps[0].1) / rms,
                asymmetry(&c.x, maps[1].0, &maps[1].1) / rms,
                rms,
                eig,
                e0.stretch / (e0.stretch + e0.bend),
                start.elapsed().as_secs_f64()
            );
            Ok(())
        })?;
        if let Some(l) = stopped {
            println!("stopped at {l}");
        }
        // The doubly symmetric branch from the last state: symmetrise, re-solve, repeat
        // until the state stops moving (a symmetric state solves to a symmetric one).
        for _ in 0..4 {
            let s = symmetrised(&c, &maps);
            let mut t = s.clone();
            if !equilibrium(&mut sys, &mut t) {
                println!("symmetrised state: no equilibrium");
                break;
            }
            let d =
                t.x.iter()
                    .zip(&c.x)
                    .map(|(a, b)| (a - b).norm())
                    .fold(0.0, f64::max);
            let u = radial(&x0, &t.x, v);
            println!(
                "symmetrised, re-solved at λ = {}: pushed {:.4} {:.4}, pulled {:.4} {:.4}, moved {d:.2e}",
                sys.load_factor(),
                -u[2],
                -u[3],
                u[0],
                u[1]
            );
            c = t;
            if d < 1e-8 {
                break;
            }
        }
    }
    Ok(())
}

/// Outward unit normal (area-weighted over the incident faces) of vertex `v` at positions `x`.
fn vertex_normal(mesh: &Mesh, x: &[V3], v: VertexId) -> V3 {
    let faces = mesh.faces();
    let n: V3 = mesh
        .topology()
        .vertex_faces(v)
        .iter()
        .map(|&f| {
            let [a, b, c] = faces[f.idx()].map(|k| x[k.idx()]);
            (b - a).cross(&(c - a))
        })
        .sum();
    n.normalize()
}

/// Follower against dead loads (issue #27, hypothesis 2; Abaqus' concentrated loads are dead
/// unless FOLLOWER is asked for): the pulled and pushed forces along the current vertex normal
/// instead of the fixed radial axes, at load steps of 0.05, each solved to a fixed point of
/// the load directions (directions from the last equilibrium, re-solved until they move less
/// than 1e-9 rad; half steps). Mesh level `HEMI_SYM_LEVELS` (default 2), form `HEMI_SYM_SFF`. Run:
/// `cargo test -p xtask --release hemisphere_follower_study -- --ignored --nocapture`.
#[test]
#[ignore = "a study of minutes; prints a table"]
fn hemisphere_follower_study() -> Result<()> {
    let levels = list("HEMI_SYM_LEVELS", "2")?;
    println!(
        "mesh | λ | pulled dead | pulled follower | pushed dead | pushed follower | fixed-point solves"
    );
    for &level in &levels {
        let (mut dead, v) = system(level as usize, form(), 400.0, true)?;
        let (mut follow, _) = system(level as usize, form(), 400.0, true)?;
        let mesh = dead.mesh().clone();
        let x0 = mesh.positions().to_vec();
        let sign = [1.0, 1.0, -1.0, -1.0];
        let (mut cd, mut cf) = (
            Config::of(&dead, x0.clone()),
            Config::of(&follow, x0.clone()),
        );
        for step in 1..=20 {
            let l = 0.05 * step as f64;
            dead.set_load_factor(l)?;
            if !equilibrium(&mut dead, &mut cd) {
                bail!("dead loads: no equilibrium at {l}");
            }
            let mut solves = 0;
            loop {
                let dirs = v.map(|i| vertex_normal(&mesh, &cf.x, i));
                let turned = follow
                    .loads()
                    .point_forces
                    .iter()
                    .zip(&dirs)
                    .zip(&sign)
                    .map(|((f, d), s)| (f.1 / (400.0 * s)).angle(d))
                    .fold(0.0, f64::max);
                if solves > 0 && turned < 1e-9 {
                    break;
                }
                // Half steps towards the new directions: the plain fixed-point iteration
                // stops contracting past P/Pmax ≈ 0.45 (24 solves at 0.4, none at 0.5).
                let mut loads = follow.loads().clone();
                for ((f, d), s) in loads.point_forces.iter_mut().zip(&dirs).zip(&sign) {
                    let old = f.1 / (400.0 * s);
                    let new = if solves == 0 {
                        *d
                    } else {
                        (old + d).normalize()
                    };
                    f.1 = new * (400.0 * s);
                }
                follow.set_loads(loads)?;
                follow.set_load_factor(l)?;
                if !equilibrium(&mut follow, &mut cf) || solves > 200 {
                    println!("follower loads: no fixed point at P/Pmax = {l:.2}");
                    return Ok(());
                }
                solves += 1;
            }
            if step % 2 == 0 || step == 1 {
                let (a, b) = (radial(&x0, &cd.x, v), radial(&x0, &cf.x, v));
                println!(
                    "{} | {l:.2} | {:.4} | {:.4} | {:.4} | {:.4} | {solves}",
                    mesh.n_faces(),
                    0.5 * (a[0] + a[1]),
                    0.5 * (b[0] + b[1]),
                    -0.5 * (a[2] + a[3]),
                    -0.5 * (b[2] + b[3]),
                );
            }
        }
    }
    Ok(())
}
