//! Orientation fixing: randomly flipped faces of generated meshes are restored.
#![allow(clippy::unwrap_used)]

use std::collections::HashSet;

use nalgebra::Vector3;
use proptest::prelude::*;
use thinshell_mesh::{Mesh, generators};
use thinshell_testkit::rng::hash_unit as uniform;

fn base_mesh(kind: usize) -> Mesh {
    match kind {
        0 => generators::rectangle(1.0, 2.0, 5, 4),
        1 => generators::irregular_rectangle(1.0, 1.0, 6, 11),
        2 => generators::icosphere(1.0, 2),
        3 => generators::disc(1.0, 4),
        4 => generators::annulus(0.5, 1.0, 2, 12),
        5 => generators::cylinder_patch(1.0, std::f64::consts::TAU, 1.0, 8, 3),
        _ => generators::seed_square(),
    }
    .unwrap()
}

fn as_usize(m: &Mesh) -> Vec<[usize; 3]> {
    m.faces_usize()
}

/// Same cyclic order (0), reversed (1), or a different vertex set (panic).
fn relation(a: [usize; 3], b: [usize; 3]) -> bool {
    let rot = |t: [usize; 3], k: usize| [t[k], t[(k + 1) % 3], t[(k + 2) % 3]];
    if (0..3).any(|k| rot(a, k) == b) {
        false
    } else if (0..3).any(|k| rot([a[0], a[2], a[1]], k) == b) {
        true
    } else {
        panic!("faces {a:?} and {b:?} differ")
    }
}

fn assert_consistent(faces: &[[usize; 3]]) {
    let mut directed = HashSet::new();
    for f in faces {
        for e in 0..3 {
            assert!(
                directed.insert((f[e], f[(e + 1) % 3])),
                "directed edge used twice"
            );
        }
    }
}

proptest! {
    // Case count from PROPTEST_CASES (default 256); failures are kept next to the tests.
    #![proptest_config(proptest::prelude::ProptestConfig {
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::Direct(
            "proptest-regressions/orientation.txt",
        ))),
        ..proptest::prelude::ProptestConfig::default()
    })]

    #[test]
    fn random_flips_are_undone(kind in 0usize..7, seed in any::<u64>(), p in 0.0f64..1.0) {
        let base = base_mesh(kind);
        let orig = as_usize(&base);
        let flipped: Vec<bool> = (0..orig.len()).map(|f| uniform(seed, f as u64) < p).collect();
        let input: Vec<[usize; 3]> = orig
            .iter()
            .zip(&flipped)
            .map(|(&[i, j, k], &fl)| if fl { [i, k, j] } else { [i, j, k] })
            .collect();
        let m = Mesh::new(base.positions().to_vec(), input.clone()).unwrap();
        let out = as_usize(&m);
        assert_consistent(&out);
        // Equal to the original up to one global flip (every generator is one component).
        let rel: Vec<bool> = orig.iter().zip(&out).map(|(&a, &b)| relation(a, b)).collect();
        prop_assert!(rel.iter().all(|&r| r == rel[0]));
        // The majority orientation of the input is kept: fewer than half flipped back means
        // the original is restored exactly.
        let n_in_flipped = flipped.iter().filter(|&&f| f).count();
        let changed = input.iter().zip(&out).filter(|&(&a, &b)| relation(a, b)).count();
        prop_assert_eq!(changed, m.build_report().n_flipped());
        prop_assert_eq!(changed, n_in_flipped.min(orig.len() - n_in_flipped));
        if 2 * n_in_flipped < orig.len() {
            prop_assert!(!rel[0]);
        } else if 2 * n_in_flipped > orig.len() {
            prop_assert!(rel[0]);
        }
    }

    #[test]
    fn components_are_oriented_independently(seed in any::<u64>(), p in 0.0f64..1.0, q in 0.0f64..1.0) {
        // A disc and a sphere side by side, each flipped with its own probability.
        let a = generators::disc(1.0, 3).unwrap();
        let b = generators::icosphere(1.0, 1).unwrap();
        let shift = Vector3::new(5.0, 0.0, 0.0);
        let mut x: Vec<Vector3<f64>> = a.positions().to_vec();
        x.extend(b.positions().iter().map(|v| v + shift));
        let nv = a.n_vertices();
        let mut orig = as_usize(&a);
        orig.extend(as_usize(&b).iter().map(|t| t.map(|v| v + nv)));
        let na = a.n_faces();
        let input: Vec<[usize; 3]> = orig
            .iter()
            .enumerate()
            .map(|(f, &[i, j, k])| {
                let prob = if f < na { p } else { q };
                if uniform(seed, f as u64) < prob { [i, k, j] } else { [i, j, k] }
            })
            .collect();
        let m = Mesh::new(x, input).unwrap();
        prop_assert_eq!(m.topology().n_components(), 2);
        prop_assert_eq!(m.euler_characteristic(), 3);
        let out = as_usize(&m);
        assert_consistent(&out);
        let rel: Vec<bool> = orig.iter().zip(&out).map(|(&a, &b)| relation(a, b)).collect();
        prop_assert!(rel[..na].iter().all(|&r| r == rel[0]));
        prop_assert!(rel[na..].iter().all(|&r| r == rel[na]));
        for f in 0..orig.len() {
            let c = m.topology().face_component(thinshell_mesh::FaceId::new(f));
            prop_assert_eq!(c, usize::from(f >= na));
        }
    }
}

#[test]
fn tie_keeps_the_first_face() {
    // Two triangles, the second reversed: one flip either way; face 0 keeps its orientation.
    let x = vec![
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(1.0, 1.0, 0.0),
        Vector3::new(0.0, 1.0, 0.0),
    ];
    let m = Mesh::new(x, vec![[0, 1, 2], [0, 3, 2]]).unwrap();
    assert_eq!(m.faces_usize(), vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(
        m.build_report().flipped_faces,
        vec![thinshell_mesh::FaceId(1)]
    );
}

#[test]
fn unreferenced_vertices_are_dropped_and_mapped() {
    use thinshell_mesh::VertexId;
    let x = vec![
        Vector3::new(7.0, 7.0, 7.0),
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(8.0, 8.0, 8.0),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.0, 1.0, 0.0),
    ];
    let m = Mesh::new(x.clone(), vec![[1, 3, 4]]).unwrap();
    let r = m.build_report();
    assert_eq!(r.n_dropped_vertices, 2);
    assert_eq!(
        r.vertex_map,
        vec![
            None,
            Some(VertexId(0)),
            None,
            Some(VertexId(1)),
            Some(VertexId(2))
        ]
    );
    assert_eq!(m.positions(), &[x[1], x[3], x[4]]);
    assert_eq!(m.faces_usize(), vec![[0, 1, 2]]);
}
