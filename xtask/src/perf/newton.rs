//! One Newton iteration per size and thread count, the growth exponent, one implicit step per
//! bending form, and the `--big` iteration in a child process (time and peak memory).
//!
//! The iteration is the one of the `newton_iteration` bench: the unit icosphere shrinking under
//! ā = 0.9 a⁰ (mid-edge average, paper), implicit Euler Δt = 1e-3 s at x = x̃ — assembly of
//! energy, gradient and exact Hessian plus the inertia diagonal Λ/Δt², numeric Cholesky
//! factorisation, triangular solve. Ordering and regularisation are
//! [`NewtonSettings::default`]'s, i.e. whatever the library does by default; the factorisation
//! runs on the row's thread count with the default `NewtonSettings::parallel` (`true`: the
//! split factorisation, on one thread too, so that every thread count gives the same bits); the
//! symbolic analysis is done once per pattern outside the timing, as in a simulation.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::rc::Rc;
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use serde_json::json;
use thinshell_energy::{
    Assembler, DofMap, EvalOutput, HessianMode, Material, RestState, SffKind, ShellModel, Terms,
    lumped_mass,
};
use thinshell_mesh::generators;
use thinshell_solver::faer::Par;
use thinshell_solver::faer::sparse::SparseColMat;
use thinshell_solver::nalgebra::Vector3;
use thinshell_solver::{ImplicitEuler, Integrator, NewtonSettings, SparseCholesky, State};
use thinshell_system::{Boundary, Loads, ShellSystem};

use super::facts::{BigRun, Facts, LevelFacts};
use super::measure::{Measure, Sizes, pool};

/// Implicit Euler step length of the protocol (s).
const DT: f64 = 1e-3;

/// Parts of a Newton iteration sample.
pub(crate) const PARTS: [&str; 4] = ["total", "assembly", "factorisation", "solve"];

/// Id of the Newton iteration at `level` with `threads` threads.
pub(crate) fn id(level: usize, threads: usize) -> String {
    format!("newton/l{level}/t{threads}")
}

/// Id of the implicit step of form `sff`.
pub(crate) fn step_id(sff: SffKind) -> String {
    format!("implicit_step/{}", sff.name())
}

/// faer's parallelism for `threads` threads (1: sequential).
pub(crate) fn par(threads: usize) -> Par {
    if threads <= 1 {
        Par::Seq
    } else {
        Par::rayon(threads)
    }
}

/// Which factorisation a measure uses: `(threads, library default)`. `false`: [`par`]`(threads)`
/// (one thread: `Par::Seq`, faer's unsplit factorisation, i.e. `NewtonSettings::parallel =
/// false`); `true`: the parallelism `NewtonSettings::default()` asks for on a pool of `threads`.
pub(crate) type FactorKey = (usize, bool);

/// The `Par` of a [`FactorKey`].
pub(crate) fn key_par((threads, default): FactorKey) -> Par {
    if default && NewtonSettings::default().parallel {
        Par::rayon(threads)
    } else {
        par(threads)
    }
}

/// The shrinking sphere at one level: pattern, values, and one factorisation per faer thread
/// count asked for (symbolic analysis with the default ordering).
pub(crate) struct Problem {
    pub(crate) faces: usize,
    model: ShellModel,
    rest: RestState,
    x: Vec<Vector3<f64>>,
    assembler: Assembler,
    pub(crate) hessian: SparseColMat<usize, f64>,
    m_over_dt2: Vec<f64>,
    gradient: Vec<f64>,
    rhs: Vec<f64>,
    pub(crate) coords: Vec<[f64; 3]>,
    choleskys: BTreeMap<FactorKey, SparseCholesky>,
    mu: f64,
}

impl Problem {
    pub(crate) fn new(level: usize) -> Result<Problem> {
        let mesh = generators::icosphere(1.0, level)?;
        let x = mesh.positions().to_vec();
        let sff = SffKind::MidEdgeAverage;
        let mut rest = RestState::from_mesh(&mesh, &x, sff)?;
        rest.a_bar.iter_mut().for_each(|a| *a *= 0.9);
        let model = ShellModel {
            material: Material::paper(),
            terms: Terms::ELASTIC,
            sff,
        };
        let n = mesh.n_vertices();
        let assembler = Assembler::new(&mesh, &DofMap::all_free(n), model.terms)?;
        let mass = lumped_mass(&mesh, &rest, &model.material)?;
        let mut p = Problem {
            faces: mesh.n_faces(),
            hessian: assembler.hessian_template(),
            m_over_dt2: (0..3 * n).map(|c| mass[c / 3] / (DT * DT)).collect(),
            gradient: vec![0.0; 3 * n],
            rhs: vec![0.0; 3 * n],
            coords: (0..3 * n).map(|c| x[c / 3].into()).collect(),
            choleskys: BTreeMap::new(),
            mu: 0.0,
            model,
            rest,
            x,
            assembler,
        };
        // Real values in the matrix, for factorisation-only measures.
        p.assemble()?;
        Ok(p)
    }

    pub(crate) fn unknowns(&self) -> usize {
        self.assembler.n_free()
    }

    pub(crate) fn nnz(&self) -> usize {
        self.assembler.nnz()
    }

    fn assemble(&mut self) -> Result<()> {
        self.assembler.evaluate(
            &self.model,
            &self.x,
            &self.rest,
            None,
            EvalOutput {
                gradient: Some(&mut self.gradient),
                hessian: Some((&mut self.hessian, HessianMode::Exact)),
            },
        )?;
        let vals = self.hessian.val_mut();
        for (&d, m) in self
            .assembler
            .diagonal_offsets()
            .iter()
            .zip(&self.m_over_dt2)
        {
            vals[d] += m;
        }
        Ok(())
    }

    /// The factorisation of `key` (built on first use).
    pub(crate) fn cholesky(&mut self, key: FactorKey) -> Result<&mut SparseCholesky> {
        if !self.choleskys.contains_key(&key) {
            let c = SparseCholesky::new(
                self.hessian.symbolic(),
                NewtonSettings::default().ordering,
                Some(&self.coords),
                key_par(key),
            )?;
            self.choleskys.insert(key, c);
        }
        self.choleskys
            .get_mut(&key)
            .ok_or_else(|| anyhow!("factorisation {key:?} missing"))
    }

    /// Numeric factorisation alone (s).
    pub(crate) fn factorize(&mut self, key: FactorKey) -> Result<f64> {
        self.cholesky(key)?;
        let c = self
            .choleskys
            .get_mut(&key)
            .ok_or_else(|| anyhow!("factorisation {key:?} missing"))?;
        let t = Instant::now();
        c.factorize(self.hessian.as_ref())
            .map_err(|e| anyhow!("factorisation failed: {e:?}"))?;
        Ok(t.elapsed().as_secs_f64())
    }

    /// One Newton iteration with the default settings on `threads` threads; returns [`PARTS`]
    /// (s).
    pub(crate) fn iteration(&mut self, threads: usize) -> Result<Vec<f64>> {
        let key = (threads, true);
        self.cholesky(key)?;
        let settings = NewtonSettings::default();
        let t0 = Instant::now();
        self.assemble()?;
        let t1 = Instant::now();
        let c = self
            .choleskys
            .get_mut(&key)
            .ok_or_else(|| anyhow!("factorisation {key:?} missing"))?;
        match &settings.regularization {
            Some(params) => {
                c.factorize_regularized(&mut self.hessian, params, &mut self.mu)
                    .map_err(|e| anyhow!("factorisation failed: {e:?}"))?;
            }
            None => c
                .factorize(self.hessian.as_ref())
                .map_err(|e| anyhow!("factorisation failed: {e:?}"))?,
        }
        let t2 = Instant::now();
        for (r, g) in self.rhs.iter_mut().zip(&self.gradient) {
            *r = -g;
        }
        c.solve_in_place(&mut self.rhs)?;
        std::hint::black_box(&self.rhs);
        let t3 = Instant::now();
        let (a, f, s) = (
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            (t3 - t2).as_secs_f64(),
        );
        Ok(vec![a + f + s, a, f, s])
    }
}

/// The shared problems, one per level (built on first use).
pub(crate) type Problems = BTreeMap<usize, Rc<RefCell<Problem>>>;

/// The problem at `level`, built once.
pub(crate) fn problem(problems: &mut Problems, level: usize) -> Result<Rc<RefCell<Problem>>> {
    if let Some(p) = problems.get(&level) {
        return Ok(Rc::clone(p));
    }
    let p = Rc::new(RefCell::new(
        Problem::new(level).with_context(|| format!("shrinking sphere, level {level}"))?,
    ));
    problems.insert(level, Rc::clone(&p));
    Ok(p)
}

/// Records the level's sizes and the stats of its factorisations in `facts`.
pub(crate) fn record(facts: &mut Facts, level: usize, p: &mut Problem) -> Result<()> {
    // The 1-thread factorisation: its stats do not depend on the thread count.
    let stats = *p.cholesky((1, false))?.stats();
    facts.levels.insert(
        level,
        LevelFacts {
            faces: p.faces,
            unknowns: p.unknowns(),
            nnz: p.nnz(),
            ordering: format!("{:?}", stats.ordering),
            flops: stats.flops,
            factor_len: stats.factor_len,
            memory_estimate: stats.memory_estimate,
        },
    );
    Ok(())
}

/// Adds the Newton iteration and implicit step measures.
pub(crate) fn measures(
    sizes: &Sizes,
    problems: &mut Problems,
    out: &mut Vec<Measure>,
    facts: &mut Facts,
) -> Result<()> {
    for &threads in &sizes.threads {
        let pl = pool(threads)?;
        for &level in &sizes.newton {
            let p = problem(problems, level)?;
            // The factorisation is the library default's (`NewtonSettings::parallel`).
            let faer = threads;
            {
                let mut guard = p.borrow_mut();
                let pm: &mut Problem = &mut guard;
                pl.install(|| pm.cholesky((faer, true)).map(|_| ()))?;
                record(facts, level, pm)?;
            }
            let pl = pl.clone();
            out.push(Measure {
                id: id(level, threads),
                parts: PARTS.to_vec(),
                per: 1.0,
                action: Box::new(move || {
                    let mut guard = p.borrow_mut();
                    let pm: &mut Problem = &mut guard;
                    pl.install(|| pm.iteration(faer))
                }),
            });
        }
    }
    // One implicit step per form, one thread, library defaults (line search, adaptive Hessian,
    // the workspace reused between samples as in a running simulation).
    let one = pool(1)?;
    for sff in SffKind::ALL {
        let (sys, state0) = shrinking_system(sizes.per_face, sff)?;
        facts.step_unknowns.insert(sff.name().to_string(), {
            let a = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model())?;
            a.n_free()
        });
        let sys = Rc::new(RefCell::new((sys, ImplicitEuler::new(DT))));
        let pl = one.clone();
        out.push(Measure {
            id: step_id(sff),
            parts: vec!["total", "newton_iterations"],
            per: 1.0,
            action: Box::new(move || {
                let mut guard = sys.borrow_mut();
                let (sys, ie) = &mut *guard;
                let mut s = state0.clone();
                let t = Instant::now();
                let r = pl.install(|| ie.step(sys, &mut s))?;
                let wall = t.elapsed().as_secs_f64();
                let iterations = r.newton.map_or(0, |n| n.iterations);
                Ok(vec![wall, iterations as f64])
            }),
        });
    }
    Ok(())
}

/// The benches' shrinking sphere as a system: unit icosphere, ā = 0.9 a⁰, paper, form `sff`.
fn shrinking_system(level: usize, sff: SffKind) -> Result<(ShellSystem, State)> {
    let mesh = generators::icosphere(1.0, level)?;
    let x = mesh.positions().to_vec();
    let mut rest = RestState::from_mesh(&mesh, &x, sff)?;
    rest.a_bar.iter_mut().for_each(|a| *a *= 0.9);
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ELASTIC,
        sff,
    };
    let sys = ShellSystem::new(mesh, model, rest, Boundary::default(), Loads::default())?;
    Ok((sys, State::at_rest(x)))
}

/// Peak resident memory of this process (VmHWM of /proc/self/status), bytes.
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// The hidden `perf-child` subcommand: builds the problem at `level`, runs `rounds` Newton
/// iterations on a pool of `threads` threads and prints one JSON line (times, peak memory).
pub(crate) fn child_main(level: usize, threads: usize, rounds: usize) -> Result<()> {
    if rounds == 0 {
        bail!("--rounds must be at least 1");
    }
    let pl = pool(threads)?;
    let faer = threads;
    let t = Instant::now();
    let mut p = pl.install(|| -> Result<Problem> {
        let mut p = Problem::new(level)?;
        p.cholesky((faer, true))?;
        Ok(p)
    })?;
    let setup_s = t.elapsed().as_secs_f64();
    // One untimed warm-up iteration, as in the interleaved rounds (first touch of the factor).
    pl.install(|| p.iteration(faer))?;
    let mut samples: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for _ in 0..rounds {
        let parts = pl.install(|| p.iteration(faer))?;
        for (name, v) in PARTS.iter().zip(parts) {
            samples.entry(name).or_default().push(v);
        }
    }
    let stats = *p.cholesky((faer, true))?.stats();
    let line = json!({
        "level": level,
        "threads": threads,
        "faces": p.faces,
        "unknowns": p.unknowns(),
        "ordering": format!("{:?}", stats.ordering),
        "flops": stats.flops,
        "memory_estimate": stats.memory_estimate,
        "setup_s": setup_s,
        "samples": samples,
        "peak_rss": peak_rss(),
    });
    println!("{line}");
    Ok(())
}

/// Runs [`child_main`] in a child process (this binary, hidden subcommand) and reads its line.
pub(crate) fn run_big(level: usize, threads: usize, rounds: usize) -> Result<BigRun> {
    let exe = std::env::current_exe().context("locating the xtask binary")?;
    let t = Instant::now();
    let out = std::process::Command::new(&exe)
        .args([
            "perf-child",
            "--level",
            &level.to_string(),
            "--threads",
            &threads.to_string(),
            "--rounds",
            &rounds.to_string(),
        ])
        .stderr(std::process::Stdio::inherit())
        .output()
        .with_context(|| format!("running {} perf-child", exe.display()))?;
    if !out.status.success() {
        bail!(
            "the level-{level} child process failed ({}); its output:\n{}",
            out.status,
            String::from_utf8_lossy(&out.stdout)
        );
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .ok_or_else(|| anyhow!("the level-{level} child printed no result line"))?;
    let v: serde_json::Value = serde_json::from_str(line).context("parsing the child's line")?;
    let samples = |part: &str| -> Vec<f64> {
        v["samples"][part]
            .as_array()
            .map(|a| a.iter().filter_map(serde_json::Value::as_f64).collect())
            .unwrap_or_default()
    };
    let run = BigRun {
        level,
        threads,
        faces: v["faces"].as_u64().unwrap_or(0) as usize,
        unknowns: v["unknowns"].as_u64().unwrap_or(0) as usize,
        ordering: v["ordering"].as_str().unwrap_or("?").to_string(),
        flops: v["flops"].as_f64().unwrap_or(f64::NAN),
        memory_estimate: v["memory_estimate"].as_u64().unwrap_or(0),
        peak_rss: v["peak_rss"].as_u64(),
        setup_s: v["setup_s"].as_f64().unwrap_or(f64::NAN),
        samples: PARTS
            .iter()
            .map(|p| ((*p).to_string(), samples(p)))
            .collect(),
        wall_s: t.elapsed().as_secs_f64(),
    };
    println!(
        "perf: level {level}, {threads} thread(s): iteration {:.2} s, peak memory {}",
        crate::common::median(&run.samples["total"]),
        run.peak_rss
            .map_or("unknown".to_string(), thinshell_solver::memory::human_bytes)
    );
    Ok(run)
}
