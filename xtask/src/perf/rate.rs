//! The factorisation's rate (issue #43): per size and form, the one-thread time and GFlop/s of
//! the library's drivers against faer's dense matrix product on one core (the limit), where the
//! time goes by supernode width, and mixed precision (f32 factorisation + refinement) against
//! double precision, on factorisations and on implicit steps.

use std::fmt::Write as _;
use std::time::Instant;

use anyhow::{Result, anyhow};
use thinshell_energy::{Assembler, SffKind};
use thinshell_solver::faer::sparse::SparseColMat;
use thinshell_solver::faer::{Accum, Mat, Par};
use thinshell_solver::linear::FactorProfile;
use thinshell_solver::{ImplicitEuler, Integrator, Ordering, SparseCholesky};
use thinshell_testkit::fixtures::shrinking_sphere;

use super::measure::pool;

/// Icosphere levels (faces 20·4ˡ) and interleaved rounds.
fn plan(quick: bool) -> (Vec<usize>, Vec<usize>, usize) {
    if quick {
        (vec![3], vec![2], 1)
    } else {
        (vec![5, 6], vec![5], 5)
    }
}

/// The forms compared: the mid-edge average and the default (edge directors, tan).
fn forms() -> [SffKind; 2] {
    [SffKind::MidEdgeAverage, SffKind::default()]
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// faer's one-thread dense product `C += A Bᵀ` of n × n matrices, best of 5 (GFlop/s).
pub(crate) fn dense_rate(n: usize) -> f64 {
    let a = Mat::<f64>::from_fn(n, n, |i, j| ((i + 3 * j) % 7) as f64);
    let mut c = Mat::<f64>::zeros(n, n);
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        thinshell_solver::faer::linalg::matmul::matmul(
            c.as_mut(),
            Accum::Add,
            a.as_ref(),
            a.as_ref().transpose(),
            1.0,
            Par::Seq,
        );
        best = best.min(t.elapsed().as_secs_f64());
    }
    2.0 * (n as f64).powi(3) / best / 1e9
}

/// The Hessian pattern of the shrinking sphere's form `sff` with diagonally dominant values
/// (SPD, condition number ≈ 10: what the factorisation's time depends on is the pattern).
fn matrix(level: usize, sff: SffKind) -> Result<SparseColMat<usize, f64>> {
    let (sys, _) = shrinking_sphere(level, sff);
    let mut h = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model())?.hessian_template();
    let n = h.ncols();
    let (cp, rows) = (
        h.symbolic().col_ptr().to_vec(),
        h.symbolic().row_idx().to_vec(),
    );
    let mut off = vec![0.0; n];
    for j in 0..n {
        for &i in &rows[cp[j]..cp[j + 1]] {
            if i != j {
                off[i] += 1.0;
                off[j] += 1.0;
            }
        }
    }
    let val = h.val_mut();
    for j in 0..n {
        for (k, &i) in rows[cp[j]..cp[j + 1]].iter().enumerate() {
            val[cp[j] + k] = if i == j { 1.1 * off[j] + 1.0 } else { -1.0 };
        }
    }
    Ok(h)
}

fn ms(t: f64) -> String {
    format!("{:.1}", t * 1e3)
}

fn rate(flops: f64, t: f64) -> String {
    format!("{:.1}", flops / t / 1e9)
}

/// The markdown section.
pub(crate) fn section(quick: bool) -> Result<String> {
    let (levels, step_levels, rounds) = plan(quick);
    let one = pool(1)?;
    let two = pool(2)?;
    let limit = dense_rate(1024);
    let mut md = String::new();
    writeln!(
        md,
        "### Factorisation rate (issue #43)\n\n\
         `cargo xtask perf` (section `factorisation rate`; `--only rate` alone). One-thread \
         numeric factorisations of the shrinking sphere's Hessian pattern (diagonally dominant \
         values: the time depends on the pattern), METIS ordering, {rounds} interleaved round(s) \
         after a warm-up, medians; GFlop/s = predicted flops (Σ column counts²) / time. \
         *multifrontal*: the library's unsplit driver (`parallel = false`); *faer*: faer's \
         left-looking supernodal driver on the same analysis; *split*: the default \
         (`parallel = true`) on a one-thread pool and on two threads; *mixed*: the \
         multifrontal driver in f32, then one solve refined to a backward error of 1e-14 \
         against the f64 solve. Limit: faer's dense product (1024³, one thread) in this run: \
         **{limit:.1} GFlop/s**.\n"
    )?;
    writeln!(
        md,
        "| faces | form | unknowns | predicted flops | multifrontal ms (GFlop/s) | faer ms (GFlop/s) | split 1 thread ms (GFlop/s) | split 2 threads ms | mixed: f32 factorisation ms (GFlop/s) | f64 solve ms | refined solve ms (f32 solves) | limit GFlop/s |\n\
         |---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    let mut profiles = Vec::new();
    for &level in &levels {
        for sff in forms() {
            let h = matrix(level, sff)?;
            let n = h.ncols();
            let new = |par: Par| SparseCholesky::new(h.symbolic(), Ordering::Metis, None, par);
            let mut mf = new(Par::Seq)?;
            let mut faer_driver = new(Par::Seq)?;
            faer_driver.use_faer_driver();
            let mut split1 = one.install(|| new(Par::rayon(1)))?;
            let mut split2 = two.install(|| new(Par::rayon(2)))?;
            let mut mixed = new(Par::Seq)?;
            mixed.set_mixed_precision(true)?;
            let flops = mf.stats().flops;
            let b: Vec<f64> = (0..n).map(|i| (i % 11) as f64 - 5.0).collect();
            let mut x = b.clone();
            let mut t = vec![Vec::new(); 7];
            let fail = |e| anyhow!("factorisation failed: {e:?}");
            for round in 0..=rounds {
                let mut lap = Vec::new();
                let mut time = |f: &mut dyn FnMut() -> Result<()>| -> Result<()> {
                    let s = Instant::now();
                    f()?;
                    lap.push(s.elapsed().as_secs_f64());
                    Ok(())
                };
                time(&mut || mf.factorize(h.as_ref()).map_err(fail))?;
                time(&mut || faer_driver.factorize(h.as_ref()).map_err(fail))?;
                time(&mut || one.install(|| split1.factorize(h.as_ref())).map_err(fail))?;
                time(&mut || two.install(|| split2.factorize(h.as_ref())).map_err(fail))?;
                time(&mut || mixed.factorize(h.as_ref()).map_err(fail))?;
                time(&mut || {
                    x.copy_from_slice(&b);
                    Ok(mf.solve_in_place(&mut x)?)
                })?;
                time(&mut || {
                    x.copy_from_slice(&b);
                    Ok(mixed.solve_in_place(&mut x)?)
                })?;
                if round > 0 {
                    for (v, l) in t.iter_mut().zip(lap) {
                        v.push(l);
                    }
                }
            }
            let m: Vec<f64> = t.into_iter().map(median).collect();
            let p = mixed.precision();
            let steps = if p.fallback.is_some() {
                format!("fallback {:?}", p.fallback)
            } else {
                format!("{}", p.max_refinement_steps)
            };
            writeln!(
                md,
                "| {} | {} | {n} | {flops:.2e} | {} ({}) | {} ({}) | {} ({}) | {} | {} ({}) | {:.2} | {:.2} ({steps}) | {limit:.1} |",
                20 * 4usize.pow(level as u32),
                sff.name(),
                ms(m[0]),
                rate(flops, m[0]),
                ms(m[1]),
                rate(flops, m[1]),
                ms(m[2]),
                rate(flops, m[2]),
                ms(m[3]),
                ms(m[4]),
                rate(flops, m[4]),
                m[5] * 1e3,
                m[6] * 1e3,
            )?;
            if level == levels[0] {
                let runs: Vec<FactorProfile> = (0..rounds.max(1))
                    .map(|_| mf.factorize_profiled(h.as_ref()))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(fail)?
                    .into_iter()
                    .flatten()
                    .collect();
                profiles.push((level, sff, runs));
            }
        }
    }
    writeln!(md)?;
    for (level, sff, runs) in profiles {
        let Some(first) = runs.first() else { continue };
        let total: f64 = first.classes.iter().map(|c| c.flops).sum();
        writeln!(
            md,
            "Where the multifrontal factorisation's time goes, {} faces, {} (one thread, medians \
             of {} profiled factorisations; the timers add about 1 %):\n\n\
             | supernode width | supernodes | share of flops | extend-add ms | dense Cholesky ms | triangular solve ms | update product ms | GFlop/s |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|",
            20 * 4usize.pow(level as u32),
            sff.name(),
            runs.len()
        )?;
        let names = ["1–3", "4–15", "16–63", "64–255", "256–1023", "≥ 1024"];
        for (k, name) in names.iter().enumerate() {
            let med = |f: fn(&thinshell_solver::linear::ClassProfile) -> f64| {
                median(runs.iter().map(|r| f(&r.classes[k])).collect())
            };
            let c = first.classes[k];
            let parts = [
                med(|c| c.extend_add),
                med(|c| c.cholesky),
                med(|c| c.solve),
                med(|c| c.update),
            ];
            let sum: f64 = parts.iter().sum::<f64>() + med(|c| c.other);
            writeln!(
                md,
                "| {name} | {} | {:.1} % | {} | {} | {} | {} | {} |",
                c.supernodes,
                100.0 * c.flops / total,
                ms(parts[0]),
                ms(parts[1]),
                ms(parts[2]),
                ms(parts[3]),
                rate(c.flops, sum),
            )?;
        }
        writeln!(md)?;
    }
    steps(&mut md, &step_levels, rounds)?;
    Ok(md)
}

/// One implicit step (Δt = 1e-3 s, from rest, the library's defaults on one thread) per form,
/// with mixed precision (the default of implicit steps) and without, with factor reuse (the
/// default) and without, interleaved; each integrator does a warm-up step first (the symbolic
/// analysis), then every round steps from the same state.
fn steps(md: &mut String, levels: &[usize], rounds: usize) -> Result<()> {
    writeln!(
        md,
        "One implicit step of the shrinking sphere (Δt = 1e-3 s, from rest; `ImplicitEuler::new` \
         on one thread, whose defaults are factor reuse and, now, mixed precision), each \
         variant's integrator warmed up by one step (symbolic analysis, kept factor), then \
         {rounds} interleaved round(s) stepping from the same state, medians; Δx: largest \
         distance between the final positions of the f64 and mixed steps over the diameter.\n\n\
         | faces | form | reuse | step f64 ms | step mixed ms | f64 / mixed | Newton it. f64 / mixed | factorisations f32 / f64 (mixed run) | max f32 solves per solve | fallback | Δx / size |\n\
         |---:|---|---|---:|---:|---:|---:|---:|---:|---|---:|"
    )?;
    let one = pool(1)?;
    for &level in levels {
        for sff in forms() {
            for reuse in [false, true] {
                let state0 = shrinking_sphere(level, sff).1;
                let mut runs: Vec<_> = [false, true]
                    .into_iter()
                    .map(|mixed| {
                        let mut ie = ImplicitEuler::new(1e-3);
                        ie.newton.mixed_precision = mixed;
                        ie.newton.reuse_factor = reuse;
                        (shrinking_sphere(level, sff).0, ie)
                    })
                    .collect();
                let mut t = [Vec::new(), Vec::new()];
                let mut its = [0, 0];
                let mut finals: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
                for round in 0..=rounds {
                    for (k, (sys, ie)) in runs.iter_mut().enumerate() {
                        let mut s = state0.clone();
                        let start = Instant::now();
                        let r = one.install(|| ie.step(sys, &mut s))?;
                        if round > 0 {
                            t[k].push(start.elapsed().as_secs_f64());
                        }
                        its[k] = r.newton.map_or(0, |n| n.iterations);
                        finals[k] = s.x.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
                    }
                }
                let p = runs[1]
                    .1
                    .workspace()
                    .and_then(|w| w.precision())
                    .unwrap_or_default();
                let dx = finals[0]
                    .iter()
                    .zip(&finals[1])
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
                    / 2.0;
                let [t64, tmixed] = t.map(median);
                writeln!(
                    md,
                    "| {} | {} | {} | {} | {} | {:.2} | {} / {} | {} / {} | {} | {} | {dx:.1e} |",
                    20 * 4usize.pow(level as u32),
                    sff.name(),
                    if reuse { "on" } else { "off" },
                    ms(t64),
                    ms(tmixed),
                    t64 / tmixed,
                    its[0],
                    its[1],
                    p.single_factorizations,
                    p.double_factorizations,
                    p.max_refinement_steps,
                    p.fallback.map_or("—".to_string(), |f| format!("{f:?}")),
                )?;
            }
        }
    }
    writeln!(md)?;
    Ok(())
}
