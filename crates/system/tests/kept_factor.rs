//! Implicit steps reuse the Cholesky factor by default, and the factor they
//! keep from step to step can be carried over (a checkpoint) or survive a cancelled step, so
//! that the steps after it are bit-identical to an uninterrupted run's; reuse stays
//! independent of the thread count.
#![allow(clippy::unwrap_used)]

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering as AtomicOrdering};

use thinshell_energy::SffKind;
use thinshell_solver::linear::SPLIT_MIN_FLOPS;
use thinshell_solver::{
    ImplicitEuler, Integrator, NewtonSettings, ProgressHook, SolverError, State, StepControl,
};
use thinshell_system::ShellSystem;
use thinshell_testkit::fixtures::shrinking_sphere;

const DT: f64 = 1e-3;

/// Positions, velocities and time as bits.
fn bits(state: &State) -> Vec<u64> {
    state
        .x
        .iter()
        .chain(&state.v)
        .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .chain([state.t.to_bits()])
        .collect()
}

/// `steps` implicit steps; returns (factorisations, reused iterations) over them.
fn run(
    ie: &mut ImplicitEuler,
    sys: &mut ShellSystem,
    state: &mut State,
    steps: usize,
) -> [usize; 2] {
    let mut counts = [0, 0];
    for _ in 0..steps {
        let n = ie.step(sys, state).unwrap().newton.unwrap();
        counts[0] += n.factorizations;
        counts[1] += n.reused_steps;
    }
    counts
}

#[test]
fn implicit_steps_reuse_the_factor_by_default() {
    let ie = ImplicitEuler::new(DT);
    assert!(ie.newton.reuse_factor);
    // Static solves keep refactorising (reuse did not pay on the static cylinder).
    assert!(!NewtonSettings::default().reuse_factor);

    let (mut sys, mut state) = shrinking_sphere(3, SffKind::MidEdgeAverage);
    let mut reuse = ImplicitEuler::new(DT);
    let [factorizations, reused] = run(&mut reuse, &mut sys, &mut state, 6);
    let (mut sys_b, mut fresh) = shrinking_sphere(3, SffKind::MidEdgeAverage);
    let mut direct = ImplicitEuler::new(DT);
    direct.newton.reuse_factor = false;
    let direct_counts = run(&mut direct, &mut sys_b, &mut fresh, 6);
    assert!(reused > 0, "nothing reused");
    assert!(
        factorizations < direct_counts[0],
        "{factorizations} factorisations with reuse, {} without",
        direct_counts[0]
    );
    // Each step converges once its Newton correction is below 1e-3 of its move
    // (`relative_step_tolerance`), so two solves of it may differ by about that much; reuse
    // changes the positions far less (2.5e-7 m for a motion of 5e-2 m).
    let x0 = sys.mesh().positions();
    let moved = state
        .x
        .iter()
        .zip(x0)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    let d = state
        .x
        .iter()
        .zip(&fresh.x)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    println!(
        "moved {moved:.3e} m, reuse differs by {d:.3e} m; factorisations {factorizations} with \
         reuse ({reused} reused iterations), {} without",
        direct_counts[0]
    );
    assert!(moved > 1e-2, "nothing moved: {moved}");
    assert!(
        d <= 1e-4 * moved,
        "reuse moved the result by {d} m (motion {moved} m)"
    );
}

#[test]
fn a_restored_kept_factor_continues_bit_for_bit() {
    let (mut sys, mut state) = shrinking_sphere(3, SffKind::MidEdgeAverage);
    let mut a = ImplicitEuler::new(DT);
    run(&mut a, &mut sys, &mut state, 3);
    let kept = a.kept_factor();
    assert!(kept.is_some(), "no factor kept after three steps");
    let mu = a.carried_state();
    let saved = state.clone();
    run(&mut a, &mut sys, &mut state, 4);

    // A new integrator with the carried state continues exactly like `a`.
    let (mut sys_b, _) = shrinking_sphere(3, SffKind::MidEdgeAverage);
    let mut b = ImplicitEuler::new(DT);
    b.restore_carried_state(mu);
    b.restore_kept_factor(kept.clone());
    let mut state_b = saved.clone();
    let counts_b = run(&mut b, &mut sys_b, &mut state_b, 4);
    assert!(bits(&state_b) == bits(&state), "the restored run differs");
    assert!(counts_b[1] > 0, "the restored run reused nothing");

    // Without it the first step factorises afresh and the run differs in the last bits: the
    // kept factor is what makes the restore exact.
    let (mut sys_c, _) = shrinking_sphere(3, SffKind::MidEdgeAverage);
    let mut c = ImplicitEuler::new(DT);
    c.restore_carried_state(mu);
    let mut state_c = saved;
    run(&mut c, &mut sys_c, &mut state_c, 4);
    assert!(
        bits(&state_c) != bits(&state),
        "a fresh factor gave the same bits"
    );

    // A kept factor of another pattern is refused by the next step, not used.
    let (mut sys_d, mut state_d) = shrinking_sphere(2, SffKind::MidEdgeAverage);
    let mut d = ImplicitEuler::new(DT);
    d.restore_kept_factor(kept);
    let e = d.step(&mut sys_d, &mut state_d).unwrap_err();
    assert!(matches!(e, SolverError::DimensionMismatch { .. }), "{e}");
}

/// Five implicit steps; the step `cancelled` (0-based) is first
/// cancelled after its first iteration and then taken again. Returns the final state.
fn five_steps(cancelled: Option<usize>) -> Vec<u64> {
    let (mut sys, mut state) = shrinking_sphere(3, SffKind::MidEdgeAverage);
    // A small step: the factor of one step serves the next ones (as in the seed's protocol).
    let mut ie = ImplicitEuler::new(1e-5);
    // The absolute step tolerance only, so that every step takes a second pass through the
    // Newton loop, where the cancel set after the first iteration is seen (with the relative
    // tolerance these steps end after one iteration, by the correction estimate).
    ie.newton.relative_step_tolerance = 0.0;
    for step in 0..5 {
        if cancelled == Some(step) {
            let cancel = Arc::new(AtomicBool::new(false));
            let flag = cancel.clone();
            let hook: ProgressHook = Arc::new(move |_| flag.store(true, AtomicOrdering::SeqCst));
            ie.set_cancel(Some(cancel));
            ie.set_progress(Some(hook));
            let before = bits(&state);
            let e = ie.step(&mut sys, &mut state).unwrap_err();
            match e {
                SolverError::Cancelled { .. } => {}
                e => panic!("{e}"),
            }
            assert!(bits(&state) == before, "a cancelled step changed the state");
            ie.set_cancel(None);
            ie.set_progress(None);
        }
        ie.step(&mut sys, &mut state).unwrap();
    }
    bits(&state)
}

#[test]
fn a_cancelled_step_leaves_the_kept_factor_as_it_found_it() {
    // Step 0 factorises before it is cancelled (that factor is dropped with the attempt);
    // step 2 reuses the factor kept from step 0, which the cancel must keep (and the retried
    // step rebuild) or the retried step factorises afresh and differs in the last bits. (That
    // a factor recorded by the cancelled attempt is replaced by the one kept at its start is
    // tested in `newton/kept.rs`.)
    let reference = five_steps(None);
    for cancelled in [0, 2] {
        let b = five_steps(Some(cancelled));
        assert!(
            b == reference,
            "step {cancelled} cancelled: the run differs"
        );
    }
}

#[test]
fn reuse_with_the_split_factorisation_is_bit_identical_for_1_2_and_3_threads() {
    let run_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let (mut sys, mut state) = shrinking_sphere(4, SffKind::MidEdgeAverage);
            // A small step (the seed's kind): one factorisation, then reuse.
            let mut ie = ImplicitEuler::new(1e-5);
            let counts = run(&mut ie, &mut sys, &mut state, 2);
            let flops = ie.workspace().unwrap().factor_stats().flops;
            (bits(&state), counts, flops)
        })
    };
    let (reference, counts, flops) = run_with(1);
    assert!(flops >= SPLIT_MIN_FLOPS, "not split: {flops:.2e} flops");
    assert!(counts[1] > 0, "nothing reused");
    for threads in [2, 3] {
        let (b, c, _) = run_with(threads);
        assert_eq!(c, counts, "{threads} threads: factorisation counts");
        assert!(b == reference, "{threads} threads differ from 1 thread");
    }
}
