//! Where the libshell figures come from (two cited measurements, both in docs/performance.md)
//! and the sizes they were measured at.

/// The sizes of the issue's figures.
pub(super) const K20: &str = "20 480 faces";
pub(super) const K80: &str = "81 920 faces";

/// Where a libshell figure comes from.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Source {
    /// The side-by-side rerun (the current figures).
    Issue31,
    /// The first cited figures (an earlier libshell build on another CPU model), for the rows
    /// the rerun did not remeasure.
    Issue17,
}

/// The rerun's libshell figures: side by side with thinshell on this machine kind (the
/// 2-core VM), interleaved, 7 rounds, medians; libshell built `-O3 -march=native -DNDEBUG`,
/// CHOLMOD supernodal with METIS capped to one OpenMP thread, OpenBLAS with its AVX-512
/// kernels; one thread. Cited, not re-measured.
pub(super) mod libshell31 {
    pub(crate) const ENERGY_NS: f64 = 106.0;
    pub(crate) const ENERGY_GRADIENT_NS: f64 = 476.0;
    pub(crate) const HESSIAN_NS: f64 = 10_600.0;
    pub(crate) const FACTOR_20K_S: f64 = 0.246;
    pub(crate) const NEWTON_20K_S: f64 = 0.594;
    pub(crate) const NEWTON_80K_S: f64 = 3.13;
    pub(crate) const GROWTH: f64 = 1.18;
    /// METIS (CHOLMOD) factorisation flops at 20 480 faces.
    pub(crate) const METIS_FLOPS_20K: f64 = 6.39e9;
}

/// The first cited libshell figures (an earlier libshell build on another CPU model; cited, not
/// re-measured): the old column, and the reference of the rows the rerun did not remeasure
/// (assembly; factorisation time and flops at 81 920 faces).
pub(super) mod libshell {
    pub(crate) const ENERGY_NS: f64 = 188.0;
    pub(crate) const ENERGY_GRADIENT_NS: f64 = 619.0;
    pub(crate) const HESSIAN_NS: f64 = 14_924.0;
    pub(crate) const ASSEMBLY_S: f64 = 0.151;
    pub(crate) const FACTOR_20K_S: f64 = 0.279;
    pub(crate) const NEWTON_20K_S: f64 = 0.757;
    pub(crate) const FACTOR_80K_S: f64 = 2.03;
    pub(crate) const NEWTON_80K_S: f64 = 4.14;
    pub(crate) const GROWTH: f64 = 1.14;
    /// METIS (CHOLMOD) factorisation flops at 20 480 and 81 920 faces.
    pub(crate) const METIS_FLOPS_20K: f64 = 6.4e9;
    pub(crate) const METIS_FLOPS_80K: f64 = 5.65e10;
}
