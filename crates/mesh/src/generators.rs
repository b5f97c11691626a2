//! Deterministic mesh generators. All return `Result<Mesh, MeshError>`; invalid parameters
//! give [`MeshError::InvalidParameter`]. Flat meshes lie in the plane `z = 0` with normals
//! `+z`; closed and curved ones have outward normals.

use std::collections::HashMap;
use std::f64::consts::TAU;

use nalgebra::Vector3;

use crate::delaunay;
use crate::error::MeshError;
use crate::mesh::Mesh;

mod catalogue;
mod shells;

pub use catalogue::{Generator, Param, Value};
pub use shells::{hemisphere, hemisphere_with_hole, slit_annulus};

fn positive(name: &'static str, value: f64) -> Result<(), MeshError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(MeshError::InvalidParameter {
            name,
            value,
            reason: "must be finite and > 0",
        })
    }
}

fn at_least(name: &'static str, value: usize, min: usize) -> Result<(), MeshError> {
    if value >= min {
        Ok(())
    } else {
        Err(MeshError::InvalidParameter {
            name,
            value: value as f64,
            reason: match min {
                1 => "must be >= 1",
                2 => "must be >= 2",
                _ => "must be >= 3",
            },
        })
    }
}

/// `len · i / n`, exactly `len` for `i = n` (so that sides of a rectangle are exactly straight).
fn lattice(len: f64, i: usize, n: usize) -> f64 {
    if i == n {
        len
    } else {
        len * i as f64 / n as f64
    }
}

/// Triangulates the strip between two polylines `lower` and `upper` running in the same
/// direction, parametrised by increasing `s` (x on a rectangle, angle on a ring). Triangles
/// are counter-clockwise when `upper` lies to the left of the direction of travel.
/// Produces `lower.len() + upper.len() − 2` triangles.
fn merge_strip(lower: &[(usize, f64)], upper: &[(usize, f64)], faces: &mut Vec<[usize; 3]>) {
    let (mut i, mut j) = (0, 0);
    while i + 1 < lower.len() || j + 1 < upper.len() {
        // Advance along the row whose next vertex comes first; this keeps the strip's
        // diagonals as short as the two rows allow.
        let advance_lower = if i + 1 == lower.len() {
            false
        } else if j + 1 == upper.len() {
            true
        } else {
            lower[i + 1].1 <= upper[j + 1].1
        };
        if advance_lower {
            faces.push([lower[i].0, lower[i + 1].0, upper[j].0]);
            i += 1;
        } else {
            faces.push([lower[i].0, upper[j + 1].0, upper[j].0]);
            j += 1;
        }
    }
}

/// How the quads of a structured grid are split into two triangles.
///
/// The choice matters for the mid-edge average bending form, which is consistent on
/// [`Diagonals::Parallel`] grids but not on [`Diagonals::Alternating`] ones when the curvature
/// is not aligned with the grid (see `docs/accuracy.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Diagonals {
    /// Checkerboard: cell `(i, j)` is split along `(i, j)–(i+1, j+1)` when `i + j` is even and
    /// along `(i+1, j)–(i, j+1)` otherwise (no preferred direction; every interior vertex has
    /// valence 4 or 8).
    Alternating,
    /// Every cell split along the same diagonal `(i, j)–(i+1, j+1)` (all interior vertices have
    /// valence 6; the mesh has a preferred direction).
    Parallel,
}

/// Regular triangulated rectangle `[0, width] × [0, height]` (m) with `nx × ny` cells, each
/// split into two triangles with alternating (checkerboard) diagonals:
/// `(nx + 1)(ny + 1)` vertices, `2 nx ny` faces, vertex `(i, j)` at index `j (nx + 1) + i`.
/// Same as [`grid_rectangle`] with [`Diagonals::Alternating`].
pub fn rectangle(width: f64, height: f64, nx: usize, ny: usize) -> Result<Mesh, MeshError> {
    grid_rectangle(width, height, nx, ny, Diagonals::Alternating)
}

/// Two square sheets of side `side` (m) and `n × n` cells as one mesh of two components: the
/// lower one in the plane z = 0 (vertices `0..(n+1)²`, centred on the origin), the upper one
/// `gap` (m) above it, turned by `angle` (rad) about the z axis so that no edge of one is
/// parallel to an edge of the other (a generic self-contact configuration).
pub fn stacked_sheets(side: f64, n: usize, gap: f64, angle: f64) -> Result<Mesh, MeshError> {
    let sheet = rectangle(side, side, n, n)?;
    let centre = Vector3::new(0.5 * side, 0.5 * side, 0.0);
    let (c, s) = (angle.cos(), angle.sin());
    let lower: Vec<Vector3<f64>> = sheet.positions().iter().map(|p| p - centre).collect();
    let upper = lower
        .iter()
        .map(|p| Vector3::new(c * p.x - s * p.y, s * p.x + c * p.y, gap));
    let positions: Vec<Vector3<f64>> = lower.iter().copied().chain(upper).collect();
    let nv = lower.len();
    let faces = sheet.faces_usize();
    let faces = faces
        .iter()
        .copied()
        .chain(faces.iter().map(|f| f.map(|v| v + nv)))
        .collect();
    Mesh::new(positions, faces)
}

/// Regular triangulated rectangle `[0, width] × [0, height]` (m) with `nx × ny` cells, each
/// split into two triangles as `diagonals` says: `(nx + 1)(ny + 1)` vertices, `2 nx ny` faces,
/// vertex `(i, j)` at index `j (nx + 1) + i`.
pub fn grid_rectangle(
    width: f64,
    height: f64,
    nx: usize,
    ny: usize,
    diagonals: Diagonals,
) -> Result<Mesh, MeshError> {
    perturbed_rectangle(width, height, nx, ny, diagonals, 0.0, 0)
}

/// [`grid_rectangle`] with every interior vertex displaced by up to `amplitude` times the
/// cell size in x and in y (independently, uniformly, from a hash of `(seed, vertex)`);
/// boundary vertices stay on the lattice, so the rectangle is covered exactly. Same counts
/// and numbering as [`grid_rectangle`]; `amplitude = 0` gives it back.
///
/// `amplitude` must lie in `[0, 0.5)`; below `dx·dy / (2 (dx² + dy²))` (1/4 for square cells)
/// no triangle can fold, above that the generator checks every triangle and returns
/// `InvalidParameter` if one would fold or degenerate. Deterministic: the same arguments
/// always give the same mesh.
pub fn perturbed_rectangle(
    width: f64,
    height: f64,
    nx: usize,
    ny: usize,
    diagonals: Diagonals,
    amplitude: f64,
    seed: u64,
) -> Result<Mesh, MeshError> {
    positive("width", width)?;
    positive("height", height)?;
    at_least("nx", nx, 1)?;
    at_least("ny", ny, 1)?;
    if !(amplitude.is_finite() && (0.0..0.5).contains(&amplitude)) {
        return Err(MeshError::InvalidParameter {
            name: "amplitude",
            value: amplitude,
            reason: "must be finite and in [0, 0.5)",
        });
    }
    let (dx, dy) = (width / nx as f64, height / ny as f64);
    let mut positions = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            let mut p = Vector3::new(lattice(width, i, nx), lattice(height, j, ny), 0.0);
            if amplitude > 0.0 && i > 0 && i < nx && j > 0 && j < ny {
                let v = (j * (nx + 1) + i) as u64;
                p.x += amplitude * dx * hash_unit(seed, v, 0);
                p.y += amplitude * dy * hash_unit(seed, v, 1);
            }
            positions.push(p);
        }
    }
    let faces = grid_faces(nx, ny, diagonals, |i, j| j * (nx + 1) + i);
    // `Mesh::new` would silently flip a folded triangle to agree with its neighbours: refuse
    // it here. The tolerance is `Mesh::new`'s degeneracy test.
    for f in &faces {
        let [a, b, c] = f.map(|v| positions[v]);
        let (e1, e2) = (b - a, c - a);
        let twice_area = e1.x * e2.y - e1.y * e2.x;
        let l2 = e1
            .norm_squared()
            .max(e2.norm_squared())
            .max((c - b).norm_squared());
        if twice_area <= crate::DEGENERATE_TOLERANCE * l2 {
            return Err(MeshError::InvalidParameter {
                name: "amplitude",
                value: amplitude,
                reason: "too large for these cells: a perturbed triangle folds or degenerates",
            });
        }
    }
    Mesh::new(positions, faces)
}

/// Points of a staggered ("brick") lattice on `[0, width] × [0, height]`: `n_rows + 1` rows;
/// even rows have `m + 1` equally spaced points, odd rows the `m` midpoints plus both ends.
/// Returns the points and whether each is interior (not on a side).
fn staggered(width: f64, height: f64, n_rows: usize, m: usize) -> (Vec<[f64; 2]>, Vec<bool>) {
    let mut points = Vec::new();
    let mut interior = Vec::new();
    for r in 0..=n_rows {
        let y = lattice(height, r, n_rows);
        let xs: Vec<f64> = if r % 2 == 0 {
            (0..=m).map(|i| lattice(width, i, m)).collect()
        } else {
            std::iter::once(0.0)
                .chain((0..m).map(|i| width * (i as f64 + 0.5) / m as f64))
                .chain(std::iter::once(width))
                .collect()
        };
        let last = xs.len() - 1;
        for (i, &x) in xs.iter().enumerate() {
            points.push([x, y]);
            interior.push(r > 0 && r < n_rows && i > 0 && i < last);
        }
    }
    (points, interior)
}

/// SplitMix64: a tiny deterministic hash used as a pseudo-random generator.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform number in `[-1, 1)` from a seed and two integers.
fn hash_unit(seed: u64, a: u64, b: u64) -> f64 {
    let h = splitmix64(splitmix64(seed ^ splitmix64(a)) ^ b);
    (h >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

fn delaunay_faces(pts: &[[f64; 2]]) -> Result<Vec<[usize; 3]>, MeshError> {
    // Only reachable through a bug in a generator: they always include the corners.
    delaunay::triangulate(pts).ok_or(MeshError::InvalidParameter {
        name: "points",
        value: pts.len() as f64,
        reason: "planar point set must contain the corners of its bounding box",
    })
}

/// Delaunay-triangulates planar points into a flat mesh (z = 0, normals +z), after
/// `smoothing` rounds of Laplacian smoothing of the free points (each moved to the mean of
/// its Delaunay neighbours, then re-triangulated).
fn planar_delaunay(
    mut pts: Vec<[f64; 2]>,
    fixed: &[bool],
    smoothing: usize,
) -> Result<Mesh, MeshError> {
    let mut faces = delaunay_faces(&pts)?;
    for _ in 0..smoothing {
        let mut sum = vec![[0.0f64; 2]; pts.len()];
        let mut count = vec![0usize; pts.len()];
        for t in &faces {
            // Every interior edge appears in two triangles: it is counted twice for both
            // ends, which leaves the mean unchanged.
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                for (u, w) in [(a, b), (b, a)] {
                    sum[u][0] += pts[w][0];
                    sum[u][1] += pts[w][1];
                    count[u] += 1;
                }
            }
        }
        for v in 0..pts.len() {
            if !fixed[v] && count[v] > 0 {
                pts[v] = [sum[v][0] / count[v] as f64, sum[v][1] / count[v] as f64];
            }
        }
        faces = delaunay_faces(&pts)?;
    }
    let positions = pts.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let faces = faces.iter().map(|t| [t[0], t[1], t[2]]).collect();
    Mesh::new(positions, faces)
}

/// Largest vertex count of [`irregular_rectangle`] and [`scattered_rectangle`] (their Delaunay
/// step is quadratic).
pub const MAX_DELAUNAY_POINTS: usize = 20_000;

/// `InvalidParameter` on `n` when a Delaunay generator would place more than
/// [`MAX_DELAUNAY_POINTS`] points.
fn delaunay_size(points: usize, n: usize) -> Result<(), MeshError> {
    if points > MAX_DELAUNAY_POINTS {
        return Err(MeshError::InvalidParameter {
            name: "n",
            value: n as f64,
            reason: "too fine: more than 20 000 vertices (the Delaunay step is quadratic)",
        });
    }
    Ok(())
}

/// Well-shaped irregular triangulation of `[0, width] × [0, height]` (m).
///
/// Starts from a staggered lattice of near-equilateral triangles with `n` intervals across
/// the shorter side (rows run along x), displaces every interior lattice point by up to 25 % of the lattice spacing in
/// x and y (less within one spacing of the boundary) with a hash of `(seed, point)`, and Delaunay-triangulates the result (so valences
/// vary too, and angles stay as large as the points allow). Boundary vertices stay on the
/// lattice. At most [`MAX_DELAUNAY_POINTS`] vertices (else `InvalidParameter`).
/// Deterministic: the same arguments always give the same mesh.
pub fn irregular_rectangle(
    width: f64,
    height: f64,
    n: usize,
    seed: u64,
) -> Result<Mesh, MeshError> {
    positive("width", width)?;
    positive("height", height)?;
    at_least("n", n, 1)?;
    // `n` intervals across the shorter side; the other side gets as many as keep the
    // triangles closest to equilateral (row spacing = √3/2 · horizontal spacing).
    let row_ratio = 3f64.sqrt() / 2.0;
    let (rows, m) = if height <= width {
        let dy = height / n as f64;
        (n, ((width * row_ratio / dy).round() as usize).max(1))
    } else {
        let dx = width / n as f64;
        (((height / (dx * row_ratio)).round() as usize).max(1), n)
    };
    let n_points = (rows + 1) * (m + 1);
    delaunay_size(n_points, n)?;
    let dy = height / rows as f64;
    let (mut pts, interior) = staggered(width, height, rows, m);
    let dx = width / m as f64;
    let amp = 0.25 * dy.min(dx);
    for (v, p) in pts.iter_mut().enumerate() {
        if interior[v] {
            // Less jitter next to the sides, where the staggered rows end half a spacing
            // from the boundary.
            let d = p[0].min(width - p[0]).min(p[1]).min(height - p[1]);
            let a = amp * (d / dx).min(1.0);
            p[0] += a * hash_unit(seed, v as u64, 0);
            p[1] += a * hash_unit(seed, v as u64, 1);
        }
    }
    let fixed: Vec<bool> = interior.iter().map(|&i| !i).collect();
    planar_delaunay(pts, &fixed, 0)
}

/// Delaunay triangulation of scattered points in `[0, width] × [0, height]` (m), spacing
/// about `s = min(width, height) / n`.
///
/// The sides carry equally spaced points (spacing ≤ s, corners included). Interior points are
/// thrown at random (a hash of `(seed, attempt)`) inside the rectangle shrunk by `s/2` and kept
/// when no point so far lies closer than `0.6 s` ("dart throwing", a Poisson-disc sample),
/// until there are as many as an equilateral lattice of spacing `s` would have, `⌈A / (√3/2 ·
/// s²)⌉` (A = width·height), or `30×` that many throws failed. Unlike
/// [`irregular_rectangle`], the points follow no lattice at all: valences, edge directions and
/// triangle shapes vary freely. At most [`MAX_DELAUNAY_POINTS`] vertices (else
/// `InvalidParameter`). Deterministic: the same arguments always give the same mesh.
pub fn scattered_rectangle(
    width: f64,
    height: f64,
    n: usize,
    seed: u64,
) -> Result<Mesh, MeshError> {
    positive("width", width)?;
    positive("height", height)?;
    at_least("n", n, 1)?;
    let s = width.min(height) / n as f64;
    let (mx, my) = ((width / s).ceil() as usize, (height / s).ceil() as usize);
    let target = (width * height / (0.5 * 3f64.sqrt() * s * s)).ceil() as usize;
    delaunay_size(target + 2 * (mx + my), n)?;
    // Counter-clockwise around the boundary, corners once.
    let mut pts: Vec<[f64; 2]> = Vec::with_capacity(target + 2 * (mx + my));
    pts.extend((0..mx).map(|i| [lattice(width, i, mx), 0.0]));
    pts.extend((0..my).map(|j| [width, lattice(height, j, my)]));
    pts.extend((0..mx).map(|i| [width - lattice(width, i, mx), height]));
    pts.extend((0..my).map(|j| [0.0, height - lattice(height, j, my)]));
    let r_min = 0.6 * s;
    // Buckets of side r_min: a point closer than r_min to a candidate lies in one of the 3×3
    // buckets around it.
    let (bx, by) = (
        (width / r_min).ceil() as usize + 1,
        (height / r_min).ceil() as usize + 1,
    );
    let bucket = |p: [f64; 2]| {
        let i = ((p[0] / r_min) as usize).min(bx - 1);
        let j = ((p[1] / r_min) as usize).min(by - 1);
        (i, j)
    };
    let mut grid: Vec<Vec<usize>> = vec![Vec::new(); bx * by];
    for (k, &p) in pts.iter().enumerate() {
        let (i, j) = bucket(p);
        grid[j * bx + i].push(k);
    }
    let n_boundary = pts.len();
    let (x0, y0) = (0.5 * s, 0.5 * s);
    let (wx, wy) = ((width - s).max(0.0), (height - s).max(0.0));
    let mut failures = 0;
    let mut attempt = 0u64;
    while pts.len() - n_boundary < target && failures < 30 * target.max(1) {
        attempt += 1;
        let p = [
            x0 + wx * 0.5 * (1.0 + hash_unit(seed, attempt, 0)),
            y0 + wy * 0.5 * (1.0 + hash_unit(seed, attempt, 1)),
        ];
        let (i, j) = bucket(p);
        let far = (i.saturating_sub(1)..=(i + 1).min(bx - 1)).all(|u| {
            (j.saturating_sub(1)..=(j + 1).min(by - 1)).all(|w| {
                grid[w * bx + u].iter().all(|&k| {
                    (pts[k][0] - p[0]).powi(2) + (pts[k][1] - p[1]).powi(2) >= r_min * r_min
                })
            })
        });
        if far {
            grid[j * bx + i].push(pts.len());
            pts.push(p);
        } else {
            failures += 1;
        }
    }
    let fixed = vec![true; pts.len()];
    planar_delaunay(pts, &fixed, 0)
}

/// The seed's unit square `[0, 1]²` (m) with exactly 108 vertices and 184 faces.
///
/// 30 boundary vertices (8 intervals on the bottom and top sides, 7 on the left and right)
/// and 78 interior vertices, placed by a golden-ratio (Fibonacci) lattice, then relaxed by 30
/// rounds of Laplacian smoothing with Delaunay re-triangulation: an unstructured,
/// near-equilateral mesh like the mesher-generated one of the paper.
pub fn seed_square() -> Result<Mesh, MeshError> {
    let mut pts: Vec<[f64; 2]> = Vec::with_capacity(108);
    // Counter-clockwise around the boundary, corners once.
    for i in 0..8 {
        pts.push([i as f64 / 8.0, 0.0]);
    }
    for j in 0..7 {
        pts.push([1.0, j as f64 / 7.0]);
    }
    for i in 0..8 {
        pts.push([1.0 - i as f64 / 8.0, 1.0]);
    }
    for j in 0..7 {
        pts.push([0.0, 1.0 - j as f64 / 7.0]);
    }
    let n_boundary = pts.len();
    let n_interior = 78;
    let golden = (5f64.sqrt() - 1.0) / 2.0;
    let margin = 0.06;
    for i in 0..n_interior {
        let u = (i as f64 + 0.5) / n_interior as f64;
        let w = (i as f64 * golden + 0.5).fract();
        pts.push([
            margin + (1.0 - 2.0 * margin) * u,
            margin + (1.0 - 2.0 * margin) * w,
        ]);
    }
    let fixed: Vec<bool> = (0..pts.len()).map(|v| v < n_boundary).collect();
    planar_delaunay(pts, &fixed, 30)
}

/// Icosphere of `radius` (m) at subdivision `level`: [`geodesic_sphere`] with frequency
/// `2^level`, i.e. the icosahedron with every face split into `4^level` triangles.
/// `10·4^level + 2` vertices, `20·4^level` faces (level 2: 162 / 320, level 5:
/// 10 242 / 20 480); outward normals; `level ≤ 10`.
///
/// Not the textbook recursive icosphere ([`icosphere_recursive`]): the same counts and, up to
/// level 1, the same points, but from level 2 on the vertices lie elsewhere on the sphere
/// (split in one step, then projected, instead of projected after every halving), so energies
/// published for "an icosphere of level k" are reproduced with [`icosphere_recursive`].
pub fn icosphere(radius: f64, level: usize) -> Result<Mesh, MeshError> {
    max_level(level)?;
    geodesic_sphere(radius, 1 << level)
}

fn max_level(level: usize) -> Result<(), MeshError> {
    if level > 10 {
        return Err(MeshError::InvalidParameter {
            name: "level",
            value: level as f64,
            reason: "must be <= 10",
        });
    }
    Ok(())
}

/// The regular icosahedron inscribed in the unit sphere: 12 unit vectors and 20 faces with
/// outward normals.
fn icosahedron() -> ([Vector3<f64>; 12], [[usize; 3]; 20]) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let corners = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|p| Vector3::from(p).normalize());
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    (corners, faces)
}

/// The standard recursive icosphere of `radius` (m): the regular icosahedron, then `level`
/// times every triangle split into four by its edge midpoints, each new midpoint projected
/// radially onto the sphere before the next split. `10·4^level + 2` vertices, `20·4^level`
/// faces, outward normals, `level ≤ 10`; vertices 0–11 are the icosahedron's corners and each
/// level appends its midpoints.
///
/// This is the icosphere of most graphics and simulation codes. Compared with [`icosphere`]
/// (one-step split), its triangles vary a little more in size, and its geometry is not a
/// smooth image of a flat grid inside each icosahedron face.
///
/// ```
/// use thinshell_mesh::generators;
///
/// let sphere = generators::icosphere_recursive(2.0, 3)?;
/// assert_eq!((sphere.n_vertices(), sphere.n_faces()), (642, 1280));
/// assert!(sphere.positions().iter().all(|p| (p.norm() - 2.0).abs() < 1e-12));
/// # Ok::<(), thinshell_mesh::MeshError>(())
/// ```
pub fn icosphere_recursive(radius: f64, level: usize) -> Result<Mesh, MeshError> {
    positive("radius", radius)?;
    max_level(level)?;
    let (corners, ico) = icosahedron();
    let mut unit: Vec<Vector3<f64>> = corners.to_vec();
    let mut faces: Vec<[usize; 3]> = ico.to_vec();
    for _ in 0..level {
        // Each edge is shared by two faces: its midpoint is made once, keyed by its ends.
        let mut midpoint: HashMap<(usize, usize), usize> =
            HashMap::with_capacity(faces.len() * 3 / 2);
        let mut mid = |a: usize, b: usize, unit: &mut Vec<Vector3<f64>>| -> usize {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                unit.push((unit[a] + unit[b]).normalize());
                unit.len() - 1
            })
        };
        let mut next = Vec::with_capacity(4 * faces.len());
        for &[a, b, c] in &faces {
            let (ab, bc, ca) = (
                mid(a, b, &mut unit),
                mid(b, c, &mut unit),
                mid(c, a, &mut unit),
            );
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        faces = next;
    }
    let positions = unit.iter().map(|p| p * radius).collect();
    Mesh::new(positions, faces)
}

/// Geodesic sphere of `radius` (m): every face of an icosahedron is split into a regular
/// grid of `frequency²` triangles in one step and the grid points are projected radially onto
/// the sphere. `10 f² + 2` vertices, `20 f²` faces, outward normals, `1 ≤ frequency ≤ 1024`.
///
/// One-step splitting (rather than repeated halving with projection after every step) makes
/// the vertex distribution a smooth image of the flat grid inside each icosahedron face, so
/// geometric quantities such as mid-edge normals converge at second order in the mesh size.
pub fn geodesic_sphere(radius: f64, frequency: usize) -> Result<Mesh, MeshError> {
    positive("radius", radius)?;
    at_least("frequency", frequency, 1)?;
    if frequency > 1024 {
        return Err(MeshError::InvalidParameter {
            name: "frequency",
            value: frequency as f64,
            reason: "must be <= 1024",
        });
    }
    let (corners, ico) = icosahedron();
    let n = frequency;
    let mut positions: Vec<Vector3<f64>> = corners.iter().map(|c| c * radius).collect();
    // Points on icosahedron edges are shared by two faces: key (low corner, high corner,
    // steps from the low corner).
    let mut on_edge: HashMap<(usize, usize, usize), usize> = HashMap::new();
    let mut faces = Vec::with_capacity(20 * n * n);
    let mut grid = vec![0usize; (n + 1) * (n + 1)];
    for tri in &ico {
        for i in 0..=n {
            for j in 0..=(n - i) {
                // Barycentric weights (n − i − j, i, j) on corners (A, B, C).
                let w = [n - i - j, i, j];
                let nonzero: Vec<usize> = (0..3).filter(|&k| w[k] > 0).collect();
                let id = match nonzero.as_slice() {
                    [k] => tri[*k],
                    [k, l] => {
                        let (lo, hi, steps) = if tri[*k] < tri[*l] {
                            (tri[*k], tri[*l], w[*l])
                        } else {
                            (tri[*l], tri[*k], w[*k])
                        };
                        let p = (corners[lo] * (n - steps) as f64 + corners[hi] * steps as f64)
                            .normalize()
                            * radius;
                        *on_edge.entry((lo, hi, steps)).or_insert_with(|| {
                            positions.push(p);
                            positions.len() - 1
                        })
                    }
                    _ => {
                        let p = (0..3)
                            .map(|k| corners[tri[k]] * w[k] as f64)
                            .sum::<Vector3<f64>>();
                        positions.push(p.normalize() * radius);
                        positions.len() - 1
                    }
                };
                grid[i * (n + 1) + j] = id;
            }
        }
        let g = |i: usize, j: usize| grid[i * (n + 1) + j];
        for i in 0..n {
            for j in 0..(n - i) {
                faces.push([g(i, j), g(i + 1, j), g(i, j + 1)]);
                if i + j + 2 <= n {
                    faces.push([g(i + 1, j), g(i + 1, j + 1), g(i, j + 1)]);
                }
            }
        }
    }
    Mesh::new(positions, faces)
}

/// Patch of a cylinder of `radius` (m) around the z axis: angle `θ ∈ [0, angle]` (rad),
/// `z ∈ [0, length]` (m), `n_around × n_along` quads split with alternating diagonals, outward
/// normals. With `angle = 2π` (to 1e-12) the patch closes into a tube (`n_around ≥ 3`).
pub fn cylinder_patch(
    radius: f64,
    angle: f64,
    length: f64,
    n_around: usize,
    n_along: usize,
) -> Result<Mesh, MeshError> {
    positive("radius", radius)?;
    positive("angle", angle)?;
    positive("length", length)?;
    at_least("n_along", n_along, 1)?;
    if angle > TAU + 1e-12 {
        return Err(MeshError::InvalidParameter {
            name: "angle",
            value: angle,
            reason: "must be <= 2 pi",
        });
    }
    let closed = (angle - TAU).abs() <= 1e-12;
    at_least("n_around", n_around, if closed { 3 } else { 1 })?;
    let n_theta = if closed { n_around } else { n_around + 1 };
    let mut positions = Vec::with_capacity(n_theta * (n_along + 1));
    for j in 0..=n_along {
        let z = lattice(length, j, n_along);
        for i in 0..n_theta {
            let th = angle * i as f64 / n_around as f64;
            positions.push(Vector3::new(radius * th.cos(), radius * th.sin(), z));
        }
    }
    let faces = grid_faces(n_around, n_along, Diagonals::Alternating, |i, j| {
        j * n_theta + i % n_theta
    });
    Mesh::new(positions, faces)
}

/// Triangulates between two closed rings given by `(vertex, unwrapped angle)`, both starting
/// near angle 0 and increasing; the first vertex is repeated at the end with angle + 2π.
fn merge_rings(inner: &[(usize, f64)], outer: &[(usize, f64)], faces: &mut Vec<[usize; 3]>) {
    let close = |ring: &[(usize, f64)]| -> Vec<(usize, f64)> {
        let mut r = ring.to_vec();
        r.push((ring[0].0, ring[0].1 + TAU));
        r
    };
    // Travelling counter-clockwise, the inner ring lies to the left.
    merge_strip(&close(outer), &close(inner), faces);
}

/// Disc of `radius` (m) centred at the origin in the plane z = 0: a centre vertex and
/// `n_rings` equally spaced rings, ring `k` with `6k` vertices. `1 + 3 n (n + 1)` vertices,
/// `6 n²` faces, normals `+z`.
pub fn disc(radius: f64, n_rings: usize) -> Result<Mesh, MeshError> {
    positive("radius", radius)?;
    at_least("n_rings", n_rings, 1)?;
    let mut positions = vec![Vector3::zeros()];
    let mut faces = Vec::with_capacity(6 * n_rings * n_rings);
    let mut prev: Vec<(usize, f64)> = Vec::new();
    for k in 1..=n_rings {
        let r = radius * k as f64 / n_rings as f64;
        let n = 6 * k;
        let ring: Vec<(usize, f64)> = (0..n)
            .map(|m| {
                let th = TAU * m as f64 / n as f64;
                positions.push(Vector3::new(r * th.cos(), r * th.sin(), 0.0));
                (positions.len() - 1, th)
            })
            .collect();
        if k == 1 {
            for m in 0..n {
                faces.push([0, ring[m].0, ring[(m + 1) % n].0]);
            }
        } else {
            merge_rings(&prev, &ring, &mut faces);
        }
        prev = ring;
    }
    Mesh::new(positions, faces)
}

/// The parameter checks of every ring-shaped generator (annulus, slit annulus): radii positive
/// and increasing, at least one ring of at least three vertices.
fn check_annulus(r_in: f64, r_out: f64, n_rings: usize, n_around: usize) -> Result<(), MeshError> {
    positive("r_in", r_in)?;
    positive("r_out", r_out)?;
    if r_out <= r_in {
        return Err(MeshError::InvalidParameter {
            name: "r_out",
            value: r_out,
            reason: "must be > r_in",
        });
    }
    at_least("n_rings", n_rings, 1)?;
    at_least("n_around", n_around, 3)
}

/// Annulus `r_in ≤ r ≤ r_out` (m) in the plane z = 0: `n_rings + 1` rings of `n_around`
/// vertices, every other ring rotated by half a step (staggered), `(n_rings + 1) n_around`
/// vertices, `2 n_rings n_around` faces, normals `+z`.
pub fn annulus(r_in: f64, r_out: f64, n_rings: usize, n_around: usize) -> Result<Mesh, MeshError> {
    check_annulus(r_in, r_out, n_rings, n_around)?;
    let mut positions = Vec::with_capacity((n_rings + 1) * n_around);
    let mut faces = Vec::with_capacity(2 * n_rings * n_around);
    let mut prev: Vec<(usize, f64)> = Vec::new();
    for k in 0..=n_rings {
        let r = r_in + (r_out - r_in) * k as f64 / n_rings as f64;
        let shift = if k % 2 == 1 { 0.5 } else { 0.0 };
        let ring: Vec<(usize, f64)> = (0..n_around)
            .map(|m| {
                let th = TAU * (m as f64 + shift) / n_around as f64;
                positions.push(Vector3::new(r * th.cos(), r * th.sin(), 0.0));
                (positions.len() - 1, th)
            })
            .collect();
        if k > 0 {
            merge_rings(&prev, &ring, &mut faces);
        }
        prev = ring;
    }
    Mesh::new(positions, faces)
}

/// Triangles of an `nx × ny` grid of quads whose corner (i, j) is vertex `id(i, j)`, split as
/// `diagonals` says, counter-clockwise in (i, j).
fn grid_faces(
    nx: usize,
    ny: usize,
    diagonals: Diagonals,
    id: impl Fn(usize, usize) -> usize,
) -> Vec<[usize; 3]> {
    let mut faces = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if diagonals == Diagonals::Parallel || (i + j) % 2 == 0 {
                faces.push([a, b, c]);
                faces.push([a, c, d]);
            } else {
                faces.push([a, b, d]);
                faces.push([b, c, d]);
            }
        }
    }
    faces
}
