//! Loads an OBJ, fixes the orientation, prints statistics and the boundary, writes it back.
//!
//! `cargo run --release -p thinshell-mesh --example load_fix_write -- input.obj [output.obj]`
//!
//! Without an output path the fixed mesh is written to `<input>.fixed.obj`.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use thinshell_mesh::{geometry, io};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let Some(input) = args.next().map(PathBuf::from) else {
        eprintln!("usage: load_fix_write <input.obj> [output.obj]");
        std::process::exit(2);
    };
    let output = args
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| input.with_extension("fixed.obj"));

    let mesh = io::load_obj(&input)?;
    let report = mesh.build_report();
    let topo = mesh.topology();
    let x = mesh.positions();
    println!("{}", input.display());
    println!(
        "  {} vertices, {} faces, {} edges, Euler characteristic {}",
        mesh.n_vertices(),
        mesh.n_faces(),
        mesh.n_edges(),
        mesh.euler_characteristic()
    );
    println!("  {} component(s)", topo.n_components());
    println!(
        "  {} face(s) flipped to a consistent orientation",
        report.n_flipped()
    );
    println!(
        "  {} unreferenced vertex(es) dropped",
        report.n_dropped_vertices
    );
    let areas = geometry::face_areas(&mesh, x);
    let total: f64 = areas.iter().sum();
    let min = areas.iter().copied().fold(f64::INFINITY, f64::min);
    println!("  area {total:.6e}, smallest face {min:.3e}");
    let boundary_length: f64 = topo
        .boundary_edges()
        .iter()
        .map(|&e| {
            let [a, b] = topo.edge(e).vertices;
            (x[b.idx()] - x[a.idx()]).norm()
        })
        .fold(0.0, |acc, l| acc + l);
    println!(
        "  boundary: {} edges, {} vertices, length {boundary_length:.6e}",
        topo.boundary_edges().len(),
        topo.boundary_vertices().len()
    );
    let shown: Vec<String> = topo
        .boundary_vertices()
        .iter()
        .take(20)
        .map(|v| v.to_string())
        .collect();
    if !shown.is_empty() {
        let more = topo.boundary_vertices().len().saturating_sub(shown.len());
        let tail = if more > 0 {
            format!(" … (+{more})")
        } else {
            String::new()
        };
        println!("  boundary vertices: {}{tail}", shown.join(" "));
    }

    io::save_obj(&output, &mesh, x)?;
    println!("wrote {}", output.display());
    Ok(())
}
