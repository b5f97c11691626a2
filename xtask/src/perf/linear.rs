//! The factorisation: numeric factorisation with 1 and 2 faer threads (forced, whatever the
//! library's default), and the predicted flops of every [`Ordering`] variant.

use anyhow::{Context, Result};
use thinshell_solver::{Ordering, SparseCholesky};

use super::newton::{Problems, par, problem, record};
use super::report::{Facts, OrderingFacts};
use super::{Measure, Sizes, pool};

/// Id of the factorisation at `level` with `threads` faer threads.
pub(crate) fn id(level: usize, threads: usize) -> String {
    format!("factorisation/l{level}/t{threads}")
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
        for &threads in &sizes.threads {
            let pl = pool(threads)?;
            let p = p.clone();
            {
                let mut guard = p.borrow_mut();
                let pm: &mut super::newton::Problem = &mut guard;
                pl.install(|| pm.cholesky(threads).map(|_| ()))?;
            }
            out.push(Measure {
                id: id(level, threads),
                parts: vec!["total"],
                per: 1.0,
                action: Box::new(move || {
                    let mut guard = p.borrow_mut();
                    let pm: &mut super::newton::Problem = &mut guard;
                    pl.install(|| pm.factorize(threads)).map(|t| vec![t])
                }),
            });
        }
    }
    Ok(())
}
