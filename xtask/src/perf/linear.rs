//! The factorisation: numeric factorisation with 1 thread (faer's unsplit factorisation,
//! `NewtonSettings::parallel = false`, and the split one that `parallel = true`, the default,
//! runs on a one-thread pool) and with 2 threads (the split), and the predicted flops of every
//! [`Ordering`] variant.

use anyhow::{Context, Result};
use thinshell_solver::{Ordering, SparseCholesky};

use super::facts::{Facts, OrderingFacts};
use super::measure::{Measure, Sizes, pool};
use super::newton::{FactorKey, Problems, par, problem, record};

/// Id of the factorisation at `level` with `threads` faer threads (`Par::Seq` for 1).
pub(crate) fn id(level: usize, threads: usize) -> String {
    format!("factorisation/l{level}/t{threads}")
}

/// Id of the split factorisation at `level` on a one-thread pool (the default settings).
pub(crate) fn split_one_id(level: usize) -> String {
    format!("factorisation/l{level}/t1-split")
}

/// Every ordering the library has. The exhaustive `match` makes a new variant a compile error
/// here, so that it cannot be left out of the report.
pub(crate) fn orderings() -> Vec<Ordering> {
    let all = vec![
        Ordering::Amd,
        Ordering::NestedDissection,
        Ordering::Metis,
        Ordering::Auto,
    ];
    for o in &all {
        match o {
            Ordering::Amd | Ordering::NestedDissection | Ordering::Metis | Ordering::Auto => {}
        }
    }
    all
}

/// Adds the factorisation measures and records the flops of every ordering.
pub(crate) fn measures(
    sizes: &Sizes,
    problems: &mut Problems,
    out: &mut Vec<Measure>,
    facts: &mut Facts,
) -> Result<()> {
    for &level in &sizes.factor {
        let p = problem(problems, level)?;
        record(facts, level, &mut p.borrow_mut())?;
        for o in orderings() {
            // A symbolic analysis per ordering (the factor's storage is allocated and dropped).
            let c = {
                let pm = p.borrow();
                SparseCholesky::new(pm.hessian.symbolic(), o, Some(&pm.coords), par(1))
                    .with_context(|| format!("symbolic analysis with {o:?}, level {level}"))?
            };
            let s = c.stats();
            facts.orderings.push(OrderingFacts {
                level,
                asked: format!("{o:?}"),
                used: format!("{:?}", s.ordering),
                flops: s.flops,
                factor_len: s.factor_len,
                memory_estimate: s.memory_estimate,
                symbolic_s: s.symbolic_time.as_secs_f64(),
            });
        }
        let mut keys: Vec<(String, FactorKey)> = sizes
            .threads
            .iter()
            .map(|&t| (id(level, t), (t, false)))
            .collect();
        keys.push((split_one_id(level), (1, true)));
        for (measure_id, key) in keys {
            let threads = key.0;
            let pl = pool(threads)?;
            let p = p.clone();
            {
                let mut guard = p.borrow_mut();
                let pm: &mut super::newton::Problem = &mut guard;
                pl.install(|| pm.cholesky(key).map(|_| ()))?;
            }
            out.push(Measure {
                id: measure_id,
                parts: vec!["total"],
                per: 1.0,
                action: Box::new(move || {
                    let mut guard = p.borrow_mut();
                    let pm: &mut super::newton::Problem = &mut guard;
                    pl.install(|| pm.factorize(key)).map(|t| vec![t])
                }),
            });
        }
    }
    Ok(())
}
