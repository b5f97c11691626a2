//! The iterative fallback: one implicit step of the seed's sphere (uniform heat) on
//! icospheres of growing size, solved by sparse Cholesky and by preconditioned CG (IC(0), and
//! Jacobi on the small meshes), forced with `NewtonSettings::force_iterative` so that both run
//! on the same machine. Reports the time per Newton iteration, the memory of each (the
//! symbolic analysis's estimate of the factor and scratch; IC(0) values, indices and CG
//! vectors) and the largest distance between the direct and the iterative result relative to
//! the model size.

use std::time::Instant;

use anyhow::{Context, Result};
use thinshell::scene::Scene;
use thinshell::sim::Simulation;
use thinshell_solver::faer::Par;
use thinshell_solver::iterative::Ic0;
use thinshell_solver::memory::human_bytes;
use thinshell_solver::{IterativeFallback, Ordering, SparseCholesky};

/// One solve: wall time, Newton iterations, CG iterations, factor or preconditioner bytes,
/// final positions.
struct Solve {
    wall: f64,
    newton: usize,
    cg: usize,
    memory: u64,
    x: Vec<thinshell_solver::nalgebra::Vector3<f64>>,
}

fn solve(level: usize, dt: f64, iterative: Option<IterativeFallback>) -> Result<Solve> {
    let path = crate::common::workspace_root()
        .join("data")
        .join("scenes")
        .join("sphere_uniform_heat.toml");
    let mut set = vec![
        format!("mesh.level={level}"),
        format!("integrator.dt={dt:e}"),
        "integrator.steps=1".to_string(),
        "integrator.newton.line_search=true".to_string(),
    ];
    if let Some(kind) = iterative {
        set.push("integrator.newton.force_iterative=true".into());
        let name = match kind {
            IterativeFallback::Jacobi => "jacobi",
            _ => "ic0",
        };
        set.push(format!("integrator.newton.fallback=\"{name}\""));
    }
    let scene = Scene::load_with_overrides(&path, &set)
        .with_context(|| format!("loading {}", path.display()))?;
    let mut sim = Simulation::build(&scene).context("setting up the sphere")?;
    // Memory: the symbolic analysis of the Hessian pattern (AMD or the coordinate-free nested
    // dissection, whichever needs fewer flops), or IC(0) and the CG vectors.
    let template = sim.system().hessian_template();
    let memory = match iterative {
        None => SparseCholesky::new(template.symbolic(), Ordering::Auto, None, Par::Seq)
            .map(|c| c.stats().memory_estimate)?,
        Some(IterativeFallback::Jacobi) => (7 * template.ncols() * 8) as u64,
        Some(_) => Ic0::memory_estimate(template.ncols(), template.val().len()),
    };
    let t0 = Instant::now();
    let r = sim.step().map_err(|e| anyhow::anyhow!("{e}"))?;
    let wall = t0.elapsed().as_secs_f64();
    Ok(Solve {
        wall,
        newton: r.newton_iterations,
        cg: r.cg_iterations,
        memory,
        x: sim.positions().to_vec(),
    })
}

fn rel_diff(
    a: &[thinshell_solver::nalgebra::Vector3<f64>],
    b: &[thinshell_solver::nalgebra::Vector3<f64>],
) -> f64 {
    // The unit sphere: size 2 (diameter).
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
        / 2.0
}

/// The markdown section: direct against iterative per mesh size.
pub(crate) fn section(quick: bool) -> Result<String> {
    let levels: &[usize] = if quick { &[1, 2] } else { &[2, 3, 4, 5, 6] };
    let dts: &[f64] = if quick { &[1e-3] } else { &[5e-6, 1e-3] };
    let mut md = String::from(
        "### Iterative fallback\n\n`cargo xtask perf` (section `fallback`). One implicit \
         step of the seed's sphere (uniform heat, line search) from rest, by sparse Cholesky \
         and by CG (`integrator.newton.force_iterative=true`); memory: the symbolic analysis's \
         estimate of the factor and its scratch, or IC(0)'s values and indices plus the CG \
         vectors. Δx: largest distance to the direct result over the diameter.\n\n\
         | faces | dt [s] | solver | Newton it. | CG it. | s / Newton it. | memory | Δx / size |\n\
         |---:|---:|---|---:|---:|---:|---:|---:|\n",
    );
    for &dt in dts {
        for &level in levels {
            let faces = 20 * 4usize.pow(level as u32);
            let direct = solve(level, dt, None)?;
            let mut rows = vec![("Cholesky", &direct, 0.0)];
            let ic0 = solve(level, dt, Some(IterativeFallback::Ic0));
            let jac = if level <= 4 {
                Some(solve(level, dt, Some(IterativeFallback::Jacobi)))
            } else {
                None
            };
            let owned: Vec<(&str, Result<Solve>)> = std::iter::once(("CG + IC(0)", ic0))
                .chain(jac.map(|j| ("CG + Jacobi", j)))
                .collect();
            let mut texts = Vec::new();
            for (name, r) in &owned {
                match r {
                    Ok(s) => rows.push((name, s, rel_diff(&direct.x, &s.x))),
                    Err(e) => texts.push(format!(
                        "| {faces} | {dt:e} | {name} | failed: {e:#} | | | | |\n"
                    )),
                }
            }
            for (name, s, d) in rows {
                md += &format!(
                    "| {faces} | {dt:e} | {name} | {} | {} | {:.4} | {} | {:.1e} |\n",
                    s.newton,
                    s.cg,
                    s.wall / s.newton.max(1) as f64,
                    human_bytes(s.memory),
                    d
                );
            }
            for t in texts {
                md += &t;
            }
        }
    }
    Ok(md)
}
