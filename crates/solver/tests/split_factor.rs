//! The split factorisation ([`SparseCholesky::new`] with `Par::Rayon`) does the work of the
//! unsplit one: each half eliminates only its own dofs and the separator is factorised once,
//! densely, so the predicted flops of its parts add up to the unsplit factorisation's and two
//! threads halve the critical path (docs/performance.md, "Factorisation").
#![allow(clippy::unwrap_used)]

use faer::Par;
use thinshell_energy::{Assembler, SffKind};
use thinshell_solver::{Ordering, SparseCholesky};

#[test]
fn split_parts_add_up_to_the_unsplit_flops() {
    for level in [4, 5] {
        let (sys, _) =
            thinshell_testkit::fixtures::shrinking_sphere(level, SffKind::MidEdgeAverage);
        let h = Assembler::for_model(sys.mesh(), sys.dofs(), sys.model())
            .unwrap()
            .hessian_template();
        let whole = SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::Seq).unwrap();
        let split =
            SparseCholesky::new(h.symbolic(), Ordering::Metis, None, Par::rayon(2)).unwrap();
        assert!(split.is_split(), "level {level}");
        let total = whole.stats().flops;
        let [a, b, s] = split.split_flops().unwrap();
        eprintln!(
            "level {level}: unsplit {total:.3e}, halves {a:.3e} + {b:.3e}, separator {s:.3e}"
        );
        assert!(
            ((a + b + s) / total - 1.0).abs() < 0.02,
            "level {level}: parts {:.4e} vs unsplit {total:.4e}",
            a + b + s
        );
        assert!(
            a.max(b) + s < 0.6 * total,
            "level {level}: critical path {:.3e} of {total:.3e}",
            a.max(b) + s
        );
    }
}
