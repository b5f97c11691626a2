//! A small software renderer for the benchmark images: orthographic z-buffer rasterisation of a
//! triangle mesh with two-sided Lambert shading (front faces warm, back faces blue, so a viewer
//! sees orientation and inverted faces) and thin dark edges.

use std::path::Path;

use anyhow::{Context, Result, anyhow};
use nalgebra::Vector3;
use plotters::prelude::*;

/// An orthographic camera.
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// Direction the camera looks along (need not be unit).
    pub forward: Vector3<f64>,
    /// Up direction (need not be unit or orthogonal to `forward`).
    pub up: Vector3<f64>,
    /// World point at the image centre, m.
    pub center: Vector3<f64>,
    /// Half the side of the visible square, m.
    pub half_extent: f64,
}

/// An RGB image, row-major from the top-left corner.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Pixels.
    pub pixels: Vec<[u8; 3]>,
}

/// Background colour.
pub const BACKGROUND: [u8; 3] = [255, 255, 255];
const FRONT: [f64; 3] = [235.0, 150.0, 70.0];
const BACK: [f64; 3] = [80.0, 130.0, 220.0];

/// Renders `faces` at `positions` (m) into a `size × size` image.
pub fn render(faces: &[[usize; 3]], positions: &[Vector3<f64>], view: &View, size: usize) -> Image {
    let f = view.forward.normalize();
    let r = f.cross(&view.up).normalize();
    let u = r.cross(&f);
    let scale = size as f64 / (2.0 * view.half_extent);
    let half = size as f64 / 2.0;
    // Screen coordinates: x to the right, y down, depth along `forward`.
    let screen: Vec<Vector3<f64>> = positions
        .iter()
        .map(|p| {
            let d = p - view.center;
            Vector3::new(
                half + scale * d.dot(&r),
                half - scale * d.dot(&u),
                d.dot(&f),
            )
        })
        .collect();
    let light = (-f + 0.6 * u + 0.3 * r).normalize();
    let mut image = Image {
        width: size,
        height: size,
        pixels: vec![BACKGROUND; size * size],
    };
    let mut depth = vec![f64::INFINITY; size * size];
    for face in faces {
        let (a, b, c) = (screen[face[0]], screen[face[1]], screen[face[2]]);
        let n = (positions[face[1]] - positions[face[0]])
            .cross(&(positions[face[2]] - positions[face[0]]));
        let Some(n) = n.try_normalize(0.0) else {
            continue;
        };
        let front = n.dot(&f) < 0.0;
        let base = if front { FRONT } else { BACK };
        let shade = 0.3 + 0.7 * n.dot(&light).abs();
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if area.abs() < 1e-12 {
            continue;
        }
        let lens = [
            (c - b).xy().norm(),
            (a - c).xy().norm(),
            (b - a).xy().norm(),
        ];
        let x0 = a.x.min(b.x).min(c.x).floor().max(0.0) as usize;
        let x1 = (a.x.max(b.x).max(c.x).ceil().max(0.0) as usize).min(size);
        let y0 = a.y.min(b.y).min(c.y).floor().max(0.0) as usize;
        let y1 = (a.y.max(b.y).max(c.y).ceil().max(0.0) as usize).min(size);
        for py in y0..y1 {
            for px in x0..x1 {
                let (x, y) = (px as f64 + 0.5, py as f64 + 0.5);
                let edge = |p: &Vector3<f64>, q: &Vector3<f64>| {
                    (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x)
                };
                let w = [
                    edge(&b, &c) / area,
                    edge(&c, &a) / area,
                    edge(&a, &b) / area,
                ];
                if w.iter().any(|&w| w < 0.0) {
                    continue;
                }
                let z = w[0] * a.z + w[1] * b.z + w[2] * c.z;
                let k = py * size + px;
                if z >= depth[k] {
                    continue;
                }
                depth[k] = z;
                // Distance to the nearest edge in pixels: barycentric × twice-area / edge length.
                let dist = (0..3)
                    .map(|i| w[i] * area.abs() / lens[i].max(1e-12))
                    .fold(f64::INFINITY, f64::min);
                let line = if dist < 0.6 { 0.55 } else { 1.0 };
                let px_colour = base.map(|ch| (ch * shade * line).clamp(0.0, 255.0) as u8);
                image.pixels[k] = px_colour;
            }
        }
    }
    image
}

/// Writes panels side by side as one PNG with a caption under each.
pub fn save_panels(panels: &[(Image, String)], title: &str, path: &Path) -> Result<()> {
    crate::plot::register_font();
    let size = panels.first().map_or(0, |p| p.0.width.max(p.0.height));
    let (w, h) = ((size * panels.len()) as u32, size as u32 + 70);
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| anyhow!("{}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    root.draw_text(
        title,
        &("sans-serif", 18).into_font().color(&BLACK),
        (10, 6),
    )
    .map_err(|e| err(&e))?;
    for (i, (img, caption)) in panels.iter().enumerate() {
        let ox = (i * size) as i32;
        for (k, p) in img.pixels.iter().enumerate() {
            if *p != BACKGROUND {
                let (x, y) = ((k % img.width) as i32, (k / img.width) as i32);
                root.draw_pixel((ox + x, 30 + y), &RGBColor(p[0], p[1], p[2]))
                    .map_err(|e| err(&e))?;
            }
        }
        root.draw_text(
            caption,
            &("sans-serif", 15).into_font().color(&BLACK),
            (ox + 10, 36 + img.height as i32),
        )
        .map_err(|e| err(&e))?;
    }
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn view(forward: Vector3<f64>) -> View {
        View {
            forward,
            up: Vector3::z(),
            center: Vector3::zeros(),
            half_extent: 1.25,
        }
    }

    #[test]
    fn sphere_covers_its_disc() {
        let mesh = thinshell_mesh::generators::icosphere(1.0, 3).unwrap();
        let img = render(
            &mesh.faces_usize(),
            mesh.positions(),
            &view(Vector3::new(1.0, -1.5, 0.8)),
            240,
        );
        let covered = img.pixels.iter().filter(|p| **p != BACKGROUND).count() as f64;
        let want = std::f64::consts::PI / (2.5 * 2.5) * (240.0 * 240.0);
        assert!((covered / want - 1.0).abs() < 0.02, "{covered} vs {want}");
    }

    #[test]
    fn back_faces_get_the_back_colour() {
        let x = [
            Vector3::new(-1.0, 0.0, -1.0),
            Vector3::new(1.0, 0.0, -1.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let centre = |img: &Image| img.pixels[img.width * img.height / 2 + img.width / 2];
        // Normal (x1 − x0) × (x2 − x0) points to −y: seen from −y it is the front.
        let front = centre(&render(&[[0, 1, 2]], &x, &view(Vector3::y()), 64));
        let back = centre(&render(&[[0, 1, 2]], &x, &view(-Vector3::y()), 64));
        assert!(
            front[0] > front[2] && back[2] > back[0],
            "{front:?} {back:?}"
        );
    }
}
