//! Consistent orientation of every connected component by breadth-first propagation.
//!
//! Two faces sharing an edge are consistently oriented when they run the edge in opposite
//! directions. Starting from the lowest-index face of each component, the required flip state
//! propagates across edges; a contradiction means the component is not orientable (a Möbius
//! strip, say). Of the two consistent orientations of a component the one that flips **fewer**
//! faces is kept (the majority orientation); on a tie the lowest-index face keeps its
//! orientation.

use crate::topology::{Adjacency, NONE};

/// Result of orienting: which faces to flip, and the component of every face.
#[derive(Clone, Debug)]
pub(crate) struct Orientation {
    pub flip: Vec<bool>,
    pub face_component: Vec<u32>,
    pub n_components: usize,
}

/// The contradiction found on a non-orientable component (face, neighbour, edge vertices).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Contradiction {
    pub face: u32,
    pub neighbor: u32,
    pub edge: [u32; 2],
}

/// Decides which faces to flip so that every component is consistently oriented.
pub(crate) fn orient(faces: &[[u32; 3]], adj: &Adjacency) -> Result<Orientation, Contradiction> {
    let n = faces.len();
    let mut comp = vec![NONE; n];
    let mut flip = vec![false; n];
    let mut queue: Vec<u32> = Vec::new();
    let mut members: Vec<u32> = Vec::new();
    let mut n_components = 0u32;
    for root in 0..n {
        if comp[root] != NONE {
            continue;
        }
        comp[root] = n_components;
        queue.clear();
        members.clear();
        queue.push(root as u32);
        let mut head = 0;
        while head < queue.len() {
            let f = queue[head] as usize;
            head += 1;
            members.push(f as u32);
            for e in 0..3 {
                let t = adj.twin[3 * f + e];
                if t == NONE {
                    continue;
                }
                let g = (t / 3) as usize;
                let eg = (t % 3) as usize;
                // Start vertex of each half-edge in the stored orientation: equal starts mean
                // both faces run the edge the same way, so exactly one of them must flip.
                let same = faces[f][(e + 1) % 3] == faces[g][(eg + 1) % 3];
                let want = flip[f] ^ same;
                if comp[g] == NONE {
                    comp[g] = n_components;
                    flip[g] = want;
                    queue.push(g as u32);
                } else if flip[g] != want {
                    return Err(Contradiction {
                        face: f as u32,
                        neighbor: g as u32,
                        edge: [faces[f][(e + 1) % 3], faces[f][(e + 2) % 3]],
                    });
                }
            }
        }
        let flipped = members.iter().filter(|&&f| flip[f as usize]).count();
        if 2 * flipped > members.len() {
            for &f in &members {
                flip[f as usize] = !flip[f as usize];
            }
        }
        n_components += 1;
    }
    Ok(Orientation {
        flip,
        face_component: comp,
        n_components: n_components as usize,
    })
}

/// Flips the marked faces (`[i, j, k] -> [i, k, j]`) and renumbers the half-edge pairing to
/// match: a flip swaps local edges 1 and 2 of the face.
pub(crate) fn apply_flips(faces: &mut [[u32; 3]], adj: &mut Adjacency, flip: &[bool]) {
    let perm = |h: u32| -> u32 {
        let f = (h / 3) as usize;
        match (flip[f], h % 3) {
            (true, 1) => h + 1,
            (true, 2) => h - 1,
            _ => h,
        }
    };
    for (f, tri) in faces.iter_mut().enumerate() {
        if flip[f] {
            tri.swap(1, 2);
            adj.twin.swap(3 * f + 1, 3 * f + 2);
            adj.he_edge.swap(3 * f + 1, 3 * f + 2);
        }
    }
    for t in adj.twin.iter_mut() {
        if *t != NONE {
            *t = perm(*t);
        }
    }
    for h in adj.edge_he.iter_mut() {
        *h = perm(*h);
    }
}
