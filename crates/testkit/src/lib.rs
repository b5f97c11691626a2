//! Test support for the thinshell crates: shared by their integration tests (`tests/`) and
//! benches, never part of a library's public API.
//!
//! - [`rng`] — deterministic pseudo-random numbers ([`rng::SplitMix64`], [`rng::Lcg64`]);
//! - [`exact`] — exact (rational-arithmetic) triangle intersection tests for contact checks;
//! - [`fd`] — central finite differences and the error measures the derivative checks use;
//! - [`strategies`] — proptest strategies for per-face kernel inputs and the
//!   `PROPTEST_CASES` convention ([`strategies::cases_or`]);
//! - [`fixtures`] — materials and set-ups used by more than one test file or bench (the seed's
//!   squares, the swelling strip, the shrinking sphere), data paths and temporary directories.
//!
//! What belongs here: a helper copied into two or more test files or benches, with the
//! numbers of the copies kept exactly (assertions were tuned on them). What does not: helpers
//! of a single file, assertions specific to one test, and anything a library needs at run
//! time. This crate depends on thinshell-mesh, -energy, -solver and -growth, so it is a
//! dev-dependency only; the crates' `#[cfg(test)]` unit tests inside `src/` cannot use it (they
//! compile a second copy of their crate, whose types would not unify with the ones here).

pub mod contact;
pub mod exact;
pub mod fd;
pub mod fixtures;
pub mod rng;
pub mod strategies;
