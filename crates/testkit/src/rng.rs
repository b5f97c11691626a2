//! Small deterministic pseudo-random numbers for reproducible perturbations.
//!
//! Not statistically strong and not for anything but tests: the point is that a seed gives the
//! same numbers on every machine and in every run, so a failing case can be re-run. Two
//! generators exist because existing tests were tuned on their exact sequences:
//! [`SplitMix64`] (and its stateless form [`hash_unit`]) and the 64-bit LCG [`Lcg64`]. New tests
//! should use [`SplitMix64`].
//!
//! Every floating-point draw takes the top 53 bits of a `u64`: [`unit()`] in [0, 1),
//! [`SplitMix64::signed`] / [`Lcg64::signed`] in [−1, 1).

use nalgebra::Vector3;

/// The SplitMix64 increment ⌊2⁶⁴/φ⌋ (φ the golden ratio).
pub const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// The SplitMix64 output function: a bijective mix of the 64 bits of `z`.
pub fn mix64(z: u64) -> u64 {
    let z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    let z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The top 53 bits of `bits` as a number in [0, 1) (every value a multiple of 2⁻⁵³).
pub fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 / (1u64 << 53) as f64
}

/// Stateless uniform number in [0, 1) for index `i` of stream `seed`:
/// `unit(mix64(seed ^ i·γ))`. Use where draws are made out of order (e.g. one per face).
pub fn hash_unit(seed: u64, i: u64) -> f64 {
    unit(mix64(seed ^ i.wrapping_mul(GOLDEN_GAMMA)))
}

/// The SplitMix64 generator (Steele, Lea & Flood 2014): state advanced by [`GOLDEN_GAMMA`],
/// output [`mix64`] of the state.
#[derive(Clone, Debug)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator whose first output is `mix64(seed + γ)`.
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64 { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GOLDEN_GAMMA);
        mix64(self.state)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit(self.next_u64())
    }

    /// Uniform in [−1, 1).
    pub fn signed(&mut self) -> f64 {
        self.unit() * 2.0 - 1.0
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// A vector with components uniform in [−scale, scale), drawn x, y, z in that order.
    pub fn vector3(&mut self, scale: f64) -> Vector3<f64> {
        Vector3::new(self.signed(), self.signed(), self.signed()) * scale
    }
}

/// 64-bit linear congruential generator, state ← 6364136223846793005·state +
/// 1442695040888963407 (Knuth's MMIX constants); the output is the new state. Weak low bits,
/// which [`unit()`] discards.
#[derive(Clone, Debug)]
pub struct Lcg64 {
    state: u64,
}

impl Lcg64 {
    /// A generator starting from `seed` (the first output is one step after it).
    pub fn new(seed: u64) -> Lcg64 {
        Lcg64 { state: seed }
    }

    /// The next 64 bits (the new state).
    pub fn next_u64(&mut self) -> u64 {
        self.state = self
            .state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.state
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit(self.next_u64())
    }

    /// Uniform in [−1, 1).
    pub fn signed(&mut self) -> f64 {
        self.unit() * 2.0 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_matches_the_reference_sequence() {
        // Reference outputs of SplitMix64 seeded with 0 (the published test vector).
        let mut r = SplitMix64::new(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(r.next_u64(), 0x06C4_5D18_8009_454F);
    }

    #[test]
    fn draws_stay_in_their_ranges() {
        let mut s = SplitMix64::new(7);
        let mut l = Lcg64::new(7);
        for i in 0..10_000 {
            let u = s.unit();
            let v = l.signed();
            let w = s.uniform(2.0, 3.0);
            let h = hash_unit(7, i);
            assert!((0.0..1.0).contains(&u) && (-1.0..1.0).contains(&v));
            assert!((2.0..3.0).contains(&w) && (0.0..1.0).contains(&h));
        }
    }
}
