#![allow(clippy::unwrap_used)]
//! Broad phase (layer 3): the spatial hash returns exactly the pairs whose boxes overlap (brute
//! force over all pairs as the reference), hence every vertex–face and edge–edge pair closer than
//! the inflation, and never a pair that shares a vertex.

use nalgebra::Vector3;
use thinshell_contact::*;
use thinshell_mesh::generators;
use thinshell_testkit::rng::SplitMix64;

type V = Vector3<f64>;

struct Soup {
    x: Vec<V>,
    faces: Vec<[usize; 3]>,
    edges: Vec<[usize; 2]>,
}

/// A 1 m × 0.5 m sheet folded over itself at x = 0.5 (the two layers 3 cm apart) with a random
/// jitter, so that many non-adjacent primitives are close.
fn folded_sheet(n: usize, seed: u64) -> Soup {
    let mesh = generators::rectangle(1.0, 0.5, n, n / 2).unwrap();
    let mut r = SplitMix64::new(seed);
    let x = mesh
        .positions()
        .iter()
        .map(|p| {
            let u = p.x + 0.5;
            let q = if u <= 0.5 {
                V::new(u, p.y, 0.0)
            } else {
                let a = std::f64::consts::PI * (u - 0.5) / 0.03;
                if a < std::f64::consts::PI {
                    V::new(0.5 + 0.015 * a.sin() / 1.0, p.y, 0.015 * (1.0 - a.cos()))
                } else {
                    V::new(0.5 - (u - 0.5 - 0.03), p.y, 0.03)
                }
            };
            q + r.vector3(0.002)
        })
        .collect();
    let faces = mesh.faces().iter().map(|f| f.map(|v| v.idx())).collect();
    let edges = mesh
        .topology()
        .edges()
        .iter()
        .map(|e| e.vertices.map(|v| v.idx()))
        .collect();
    Soup { x, faces, edges }
}

fn brute_force(s: &Soup, dx: Option<&[V]>, inflate: f64) -> CandidatePairs {
    let swept = |ids: &[usize], grow: f64| {
        Aabb::of_points(
            ids.iter()
                .flat_map(|&v| [s.x[v], dx.map_or(s.x[v], |d| s.x[v] + d[v])]),
            grow,
        )
    };
    let mut out = CandidatePairs::default();
    for v in 0..s.x.len() {
        let b = swept(&[v], inflate);
        for (f, face) in s.faces.iter().enumerate() {
            if !face.contains(&v) && swept(face, 0.0).overlaps(&b) {
                out.point_triangle.push([v, f]);
            }
        }
    }
    for (i, a) in s.edges.iter().enumerate() {
        for (j, b) in s.edges.iter().enumerate().skip(i + 1) {
            if !b.contains(&a[0])
                && !b.contains(&a[1])
                && swept(a, 0.5 * inflate).overlaps(&swept(b, 0.5 * inflate))
            {
                out.edge_edge.push([i, j]);
            }
        }
    }
    out
}

#[test]
fn spatial_hash_equals_brute_force() {
    for (n, seed, inflate, moving) in [
        (16, 1, 0.01, false),
        (24, 2, 0.04, false),
        (20, 3, 0.005, true),
    ] {
        let s = folded_sheet(n, seed);
        let mut r = SplitMix64::new(seed + 10);
        let dx: Vec<V> = (0..s.x.len())
            .map(|i| {
                if i % 7 == 0 {
                    r.vector3(0.2)
                } else {
                    r.vector3(0.01)
                }
            })
            .collect();
        let dx = moving.then_some(dx.as_slice());
        let got = candidate_pairs(&s.x, dx, &s.faces, &s.edges, inflate);
        let want = brute_force(&s, dx, inflate);
        assert!(!want.point_triangle.is_empty() && !want.edge_edge.is_empty());
        assert_eq!(got.point_triangle, want.point_triangle, "n = {n}");
        assert_eq!(got.edge_edge, want.edge_edge, "n = {n}");
    }
}

#[test]
fn every_close_pair_is_a_candidate() {
    let s = folded_sheet(24, 7);
    let inflate = 0.035; // above the 3 cm layer spacing: the two layers see each other
    let got = candidate_pairs(&s.x, None, &s.faces, &s.edges, inflate);
    let mut close_pt = 0;
    for v in 0..s.x.len() {
        for (f, face) in s.faces.iter().enumerate() {
            if face.contains(&v) {
                continue;
            }
            let d = point_triangle_distance2(&[s.x[v], s.x[face[0]], s.x[face[1]], s.x[face[2]]]).0;
            if d.sqrt() < inflate {
                close_pt += 1;
                assert!(
                    got.point_triangle.binary_search(&[v, f]).is_ok(),
                    "vertex {v} face {f}"
                );
            }
        }
    }
    let mut close_ee = 0;
    for (i, a) in s.edges.iter().enumerate() {
        for (j, b) in s.edges.iter().enumerate().skip(i + 1) {
            if b.contains(&a[0]) || b.contains(&a[1]) {
                continue;
            }
            let d = edge_edge_distance2(&[s.x[a[0]], s.x[a[1]], s.x[b[0]], s.x[b[1]]]).0;
            if d.sqrt() < inflate {
                close_ee += 1;
                assert!(
                    got.edge_edge.binary_search(&[i, j]).is_ok(),
                    "edges {i} {j}"
                );
            }
        }
    }
    assert!(close_pt > 100 && close_ee > 100, "{close_pt} {close_ee}");
    // No pair shares a vertex.
    assert!(
        got.point_triangle
            .iter()
            .all(|&[v, f]| !s.faces[f].contains(&v))
    );
    assert!(got.edge_edge.iter().all(|&[i, j]| {
        let (a, b) = (s.edges[i], s.edges[j]);
        !b.contains(&a[0]) && !b.contains(&a[1])
    }));
}

#[test]
fn empty_and_degenerate_inputs() {
    let none = candidate_pairs(&[], None, &[], &[], 0.1);
    assert_eq!(none, CandidatePairs::default());
    // A single triangle: nothing to pair (every vertex and edge shares a vertex with the rest).
    let x = [V::zeros(), V::x(), V::y()];
    let one = candidate_pairs(&x, None, &[[0, 1, 2]], &[[0, 1], [1, 2], [2, 0]], 0.1);
    assert_eq!(one, CandidatePairs::default());
}
