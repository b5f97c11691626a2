//! Building a mesh (validation, orientation fixing, connectivity) from raw arrays.
//!
//! Run with `cargo bench -p thinshell-mesh --bench connectivity`.
#![allow(clippy::unwrap_used, missing_docs)]

use std::hint::black_box;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use thinshell_mesh::{Mesh, generators};

/// Raw arrays of a generated mesh, with the face order scrambled by a fixed permutation
/// (files rarely list faces in a cache-friendly order) and every third face flipped so that
/// orientation fixing has work to do.
fn raw(m: &Mesh) -> (Vec<Vector3<f64>>, Vec<[usize; 3]>) {
    let mut faces = m.faces_usize();
    let n = faces.len();
    // Multiplying by a large odd constant modulo a power of two above n permutes; skip the
    // indices >= n.
    let p = n.next_power_of_two();
    let order: Vec<usize> = (0..p)
        .map(|i| i.wrapping_mul(0x9E37_79B9) & (p - 1))
        .filter(|&i| i < n)
        .collect();
    faces = order.iter().map(|&i| faces[i]).collect();
    for (f, t) in faces.iter_mut().enumerate() {
        if f % 3 == 0 {
            t.swap(1, 2);
        }
    }
    (m.positions().to_vec(), faces)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("mesh_new");
    group.sample_size(10);
    for (name, mesh) in [
        (
            "icosphere_l5_20k_faces",
            generators::icosphere(1.0, 5).unwrap(),
        ),
        (
            "rectangle_1M_faces",
            generators::rectangle(1.0, 1.0, 708, 707).unwrap(),
        ),
    ] {
        let (x, f) = raw(&mesh);
        eprintln!("{name}: {} vertices, {} faces", x.len(), f.len());
        group.bench_function(name, |b| {
            b.iter_batched(
                || (x.clone(), f.clone()),
                |(x, f)| black_box(Mesh::new(x, f).unwrap()),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
