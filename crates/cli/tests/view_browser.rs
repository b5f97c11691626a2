//! End-to-end tests of `thinshell view` in headless Chromium (Debian's `chromium`, SwiftShader
//! WebGL2), driven through the DevTools protocol (`browser/mod.rs`).
//!
//! `#[ignore]`d: they need a browser, so plain `cargo test` skips them; the browser stage of
//! `cargo xtask test` installs chromium when missing and runs them with `--ignored`, and there a
//! missing browser is a failure, never a pass. `bench_playback_20k_faces` is the playback
//! benchmark (`cargo test --release -p thinshell-cli --test view_browser -- --ignored bench_ --nocapture`),
//! skipped by the stage.
//!
//! Every screenshot is taken with `lighting=0` (unlit colours), so a pixel's colour is exactly
//! the colour map's (or the plain front/back colour) and the tests can compare colours.

mod browser;

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, OnceLock};

use browser::{Browser, Image};
use thinshell_cli::view::Viewer;

const WIDTH: u32 = 1000;
const HEIGHT: u32 = 700;

/// A strip clamped at x = 0 drooping under gravity: flat and at rest in frame 0 (zero bending
/// energy), bent in the last frame.
const DROOP: &str = r#"
name = "drooping strip"
effects = ["stretching", "bending", "inertia", "damping", "gravity"]

[mesh]
generator = "rectangle"
width = 0.1
height = 0.04
nx = 10
ny = 4

[material]
thickness = 1e-3
young = 1e6

[[boundary.clamps]]
region = { box = { min = [-1.0, -1.0, -1.0], max = [1e-6, 1.0, 1.0] } }

[integrator]
kind = "implicit"
dt = 0.01
steps = 20

[output]
every = 2
formats = ["vtk", "obj"]
"#;

struct Runs {
    root: PathBuf,
    /// The drooping strip (default bending form).
    droop: PathBuf,
    /// The same with the sin edge-director form (same clamp and free-edge treatment as the
    /// default tan form: the two droop alike; the mid-edge average keeps the two-row clamp, a
    /// cell shorter, and droops visibly less: docs/model.md §1.3).
    droop_sin: PathBuf,
    /// A copy of `droop` whose frame 2 (step 4) is garbage.
    broken: PathBuf,
}

fn runs() -> &'static Runs {
    static RUNS: OnceLock<Runs> = OnceLock::new();
    RUNS.get_or_init(|| {
        let root = std::env::temp_dir().join(format!("thinshell-view-e2e-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).expect("temp dir");
        let scene = root.join("droop.toml");
        std::fs::write(&scene, DROOP).expect("scene");
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        let run = |name: &str, set: &[&str]| {
            let out = root.join(name);
            let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
            thinshell_cli::run(&scene, Some(&out), &set, true, &stop)
                .unwrap_or_else(|e| panic!("run {name}: {e:?}"));
            out
        };
        let droop = run("droop", &[]);
        let droop_sin = run("droop_sin", &["bending.form=\"edge_director_sin\""]);
        let broken = run("broken", &[]);
        std::fs::write(broken.join("frame_000004.vtu"), "this is not a frame").expect("corrupt");
        Runs {
            root,
            droop,
            droop_sin,
            broken,
        }
    })
}

/// Serves `dirs` on a free port of 127.0.0.1; returns the base URL.
fn serve(dirs: &[&Path]) -> String {
    let viewer = Viewer::load(dirs).expect("runs load");
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr");
    std::thread::spawn(move || thinshell_cli::view::server::serve(listener, Arc::new(viewer)));
    format!("http://{addr}/")
}

/// Positions of an OBJ frame.
fn obj(path: &Path) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let text = std::fs::read(path).expect("obj");
    let (p, f) = thinshell_mesh::io::read_obj_raw(&text[..]).expect("obj parse");
    (p.iter().map(|x| [x.x, x.y, x.z]).collect(), f)
}

/// The page's top view (`camera=top`), as documented in viewer.js: orthographic along −z, the
/// centre of the bounding box of the first and last frames at the canvas centre, its half
/// diagonal r filling 90 % of half the shorter canvas side: s = 0.9·min(w, h)/(2r) pixels per
/// metre.
struct TopView {
    centre: [f64; 3],
    scale: f64,
    width: f64,
    height: f64,
}

impl TopView {
    fn new(first_and_last: &[&[[f64; 3]]], canvas: [f64; 4]) -> TopView {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in first_and_last.iter().flat_map(|f| f.iter()) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let radius = 0.5
            * ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
        TopView {
            centre: [
                0.5 * (lo[0] + hi[0]),
                0.5 * (lo[1] + hi[1]),
                0.5 * (lo[2] + hi[2]),
            ],
            scale: 0.9 * canvas[2].min(canvas[3]) / (2.0 * radius),
            width: canvas[2],
            height: canvas[3],
        }
    }

    fn project(&self, p: [f64; 3]) -> [f64; 2] {
        [
            0.5 * self.width + (p[0] - self.centre[0]) * self.scale,
            0.5 * self.height - (p[1] - self.centre[1]) * self.scale,
        ]
    }

    /// The silhouette of a triangle mesh as a mask of the canvas (pixel centres inside a face).
    fn silhouette(&self, positions: &[[f64; 3]], faces: &[[usize; 3]]) -> Vec<bool> {
        let (w, h) = (self.width.round() as usize, self.height.round() as usize);
        let mut mask = vec![false; w * h];
        for f in faces {
            let [a, b, c] = f.map(|v| self.project(positions[v]));
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            if area.abs() < 1e-12 {
                continue;
            }
            let x0 = a[0].min(b[0]).min(c[0]).floor().max(0.0) as usize;
            let x1 = (a[0].max(b[0]).max(c[0]).ceil().max(0.0) as usize).min(w);
            let y0 = a[1].min(b[1]).min(c[1]).floor().max(0.0) as usize;
            let y1 = (a[1].max(b[1]).max(c[1]).ceil().max(0.0) as usize).min(h);
            let edge = |p: [f64; 2], q: [f64; 2], x: f64, y: f64| {
                ((q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])) / area
            };
            for py in y0..y1 {
                for px in x0..x1 {
                    let (x, y) = (px as f64 + 0.5, py as f64 + 0.5);
                    if edge(b, c, x, y) >= 0.0 && edge(c, a, x, y) >= 0.0 && edge(a, b, x, y) >= 0.0
                    {
                        mask[py * w + px] = true;
                    }
                }
            }
        }
        mask
    }
}

/// Not the white background (anti-aliased edges count from a quarter of the way in).
fn is_shell(c: [u8; 3]) -> bool {
    c.iter().any(|&v| v < 240)
}

fn distance(a: [u8; 3], b: [u8; 3]) -> f64 {
    let d: i32 = (0..3).map(|k| (a[k] as i32 - b[k] as i32).pow(2)).sum();
    (d as f64).sqrt()
}

/// The canvas of view `k`, with the title and legend boxes (drawn over it) painted as
/// background so that they do not count as shell.
fn canvas_mask(
    b: &mut Browser,
    img: &Image,
    k: usize,
    keep: impl Fn([u8; 3]) -> bool,
) -> (Vec<bool>, [f64; 4]) {
    let canvas = b.rect(&format!(".view:nth-child({}) canvas.gl", k + 1));
    let mut overlays = vec![b.rect(&format!(".view:nth-child({}) .title", k + 1))];
    let legend = b.rect(&format!(".view:nth-child({}) .legend", k + 1));
    if legend[2] > 0.0 {
        overlays.push(legend);
    }
    let mut mask = img.mask(canvas, keep);
    let w = canvas[2].round() as usize;
    for (i, m) in mask.iter_mut().enumerate() {
        let (x, y) = (
            canvas[0] + (i % w) as f64 + 0.5,
            canvas[1] + (i / w) as f64 + 0.5,
        );
        if overlays.iter().any(|r| {
            x >= r[0] - 1.0 && x <= r[0] + r[2] + 1.0 && y >= r[1] - 1.0 && y <= r[1] + r[3] + 1.0
        }) {
            *m = false;
        }
    }
    (mask, canvas)
}

fn iou(a: &[bool], b: &[bool]) -> f64 {
    let inter = a.iter().zip(b).filter(|(x, y)| **x && **y).count();
    let union = a.iter().zip(b).filter(|(x, y)| **x || **y).count();
    inter as f64 / union.max(1) as f64
}

/// Interior pixels of a mask (all 8 neighbours in it): free of anti-aliasing.
fn interior(mask: &[bool], w: usize) -> Vec<usize> {
    let h = mask.len() / w;
    (0..mask.len())
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            x > 0 && y > 0 && x + 1 < w && y + 1 < h && {
                (-1i64..=1).all(|dy| {
                    (-1i64..=1)
                        .all(|dx| mask[((y as i64 + dy) as usize) * w + (x as i64 + dx) as usize])
                })
            }
        })
        .collect()
}

const COLOUR_OF_ZERO: [u8; 3] = [0x44, 0x01, 0x54];

#[test]
#[ignore = "needs chromium: run by `cargo xtask test` (browser stage)"]
fn browser_shell_covers_the_canvas_and_the_last_frame_matches_the_final_obj() {
    let r = runs();
    let url = serve(&[&r.droop]);
    let mut b = Browser::start(WIDTH, HEIGHT);
    assert_eq!(
        b.open(&format!("{url}?camera=top&lighting=0&field=none&frame=0")),
        "1"
    );
    let img = b.screenshot();
    let (mask, canvas) = canvas_mask(&mut b, &img, 0, is_shell);
    let (first, faces) = obj(&r.droop.join("frame_000000.obj"));
    let (last, _) = obj(&r.droop.join("frame_000020.obj"));
    let top = TopView::new(&[&first, &last], canvas);
    // The flat 0.1 m × 0.04 m strip covers 0.004 m² · s² pixels.
    let expected = 0.1 * 0.04 * top.scale * top.scale;
    let covered = mask.iter().filter(|m| **m).count() as f64;
    assert!(
        (covered / expected - 1.0).abs() < 0.03,
        "covered {covered} px, expected {expected:.0}"
    );
    let iou0 = iou(&mask, &top.silhouette(&first, &faces));
    eprintln!("frame 0: covered {covered} px of {expected:.0} expected; silhouette IoU {iou0:.4}");
    assert!(iou0 > 0.95, "frame 0 silhouette IoU {iou0}");

    // UI: the End key scrubs to the last frame; its silhouette is the final OBJ's projection.
    b.key("End");
    b.wait_for("document.body.dataset.frame", |f| f == "10");
    b.wait_ready();
    let img = b.screenshot();
    let (mask, _) = canvas_mask(&mut b, &img, 0, is_shell);
    let silhouette = top.silhouette(&last, &faces);
    let iou_last = iou(&mask, &silhouette);
    let iou_wrong = iou(&mask, &top.silhouette(&first, &faces));
    eprintln!("last frame: silhouette IoU {iou_last:.4} (against frame 0's shape: {iou_wrong:.4})");
    assert!(iou_last > 0.95, "last-frame silhouette IoU {iou_last}");
    // The strip did move: the first frame's silhouette does not match the last.
    assert!(iou_wrong < 0.8);
    let info = b.eval("document.getElementById('frameinfo').textContent");
    assert!(
        info.as_str()
            .is_some_and(|s| s.contains("step 20") && s.contains("0.200 s")),
        "{info}"
    );

    // UI: clicking the wireframe checkbox draws dark edges over the shell.
    let dark = |c: [u8; 3]| c.iter().all(|&v| v < 60);
    let before = canvas_mask(&mut b, &img, 0, dark)
        .0
        .iter()
        .filter(|m| **m)
        .count();
    let wire = b.rect("#wire");
    b.click(wire[0] + wire[2] / 2.0, wire[1] + wire[3] / 2.0);
    // `data-wire` is set when a frame with the wireframe has been drawn.
    b.wait_for("document.body.dataset.wire", |w| w == "true");
    let img = b.screenshot();
    let after = canvas_mask(&mut b, &img, 0, dark)
        .0
        .iter()
        .filter(|m| **m)
        .count();
    let shell = silhouette.iter().filter(|m| **m).count();
    eprintln!("wireframe click: dark pixels {before} → {after} (shell {shell})");
    assert!(
        before == 0 && after as f64 > 0.03 * shell as f64,
        "dark pixels {before} → {after} of {shell}"
    );
}

#[test]
#[ignore = "needs chromium: run by `cargo xtask test` (browser stage)"]
fn browser_bending_density_is_zero_on_the_flat_sheet_and_not_when_bent() {
    let r = runs();
    let url = serve(&[&r.droop]);
    let mut b = Browser::start(WIDTH, HEIGHT);
    for (frame, flat) in [(0, true), (10, false)] {
        let state = b.open(&format!(
            "{url}?camera=top&lighting=0&field=bend_density&frame={frame}"
        ));
        assert_eq!(state, "1");
        let img = b.screenshot();
        let (mask, canvas) = canvas_mask(&mut b, &img, 0, is_shell);
        let w = canvas[2].round() as usize;
        let inside = interior(&mask, w);
        assert!(
            inside.len() > 1000,
            "frame {frame}: {} interior shell pixels",
            inside.len()
        );
        let pixel = |i: usize| img.at(canvas[0] as usize + i % w, canvas[1] as usize + i / w);
        let far = inside
            .iter()
            .filter(|&&i| distance(pixel(i), COLOUR_OF_ZERO) > 40.0)
            .count();
        let fraction = far as f64 / inside.len() as f64;
        let legend = b.eval("document.querySelector('.legend').textContent");
        eprintln!(
            "frame {frame}: {far} of {} interior pixels away from the colour of 0; legend {legend}",
            inside.len()
        );
        if flat {
            // Zero everywhere: the colour of 0 on every interior pixel, and a legend from 0 to 0.
            assert_eq!(
                far,
                0,
                "frame 0: {far} of {} pixels are not the colour of 0",
                inside.len()
            );
            assert!(
                legend
                    .as_str()
                    .is_some_and(|s| s.contains("J/m²") && s.contains("0 J/m²")),
                "{legend}"
            );
        } else {
            assert!(
                fraction > 0.05,
                "frame 10: only {fraction} of the shell is away from the colour of 0"
            );
        }
    }
}

/// The viewer's sequential colour map (viewer.js `SEQUENTIAL`, `ramp`) at t ∈ [0, 1].
fn sequential(t: f64) -> [u8; 3] {
    const STOPS: [[u8; 3]; 5] = [
        [0x44, 0x01, 0x54],
        [0x3b, 0x52, 0x8b],
        [0x21, 0x91, 0x8c],
        [0x5e, 0xc9, 0x62],
        [0xfd, 0xe7, 0x25],
    ];
    let x = t.clamp(0.0, 1.0) * 4.0;
    let k = (x.floor() as usize).min(3);
    let f = x - k as f64;
    std::array::from_fn(|j| {
        let (a, b) = (f64::from(STOPS[k][j]), f64::from(STOPS[k + 1][j]));
        (a + f * (b - a)).round() as u8
    })
}

/// Colour by contact gap: the shipped sheet dropped on a pyramid (`sheet_on_pyramid.toml`, 40
/// steps) writes the cell field `contact_gap` (capped at d̂); the page lists it, and in the top
/// view the centroid pixel of every face whose 5 × 5 neighbourhood is inside the shell has the
/// colour of its gap on the [0, max] sequential map, computed here from the frame file (within
/// 12 of 255 per channel, for ≥ 95 % of them): the faces at the apex dark, those far from it at
/// the top colour.
#[test]
#[ignore = "needs chromium: run by `cargo xtask test` (browser stage)"]
fn browser_colours_faces_by_contact_gap() {
    let r = runs();
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/sheet_on_pyramid.toml");
    let out = r.root.join("pyramid");
    let set: Vec<String> = [
        "integrator.steps=40",
        "output.every=20",
        "output.formats=[\"vtk\", \"obj\"]",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    thinshell_cli::run(
        &scene,
        Some(&out),
        &set,
        true,
        &AtomicBool::new(false).into(),
    )
    .unwrap_or_else(|e| panic!("pyramid run: {e:?}"));
    let frame = thinshell_cli::view::frame::read(&out.join("frame_000040.vtu")).expect("vtu");
    let gaps = &frame
        .face_fields
        .iter()
        .find(|(n, _)| n == "contact_gap")
        .expect("contact_gap in the frame")
        .1;
    let (lo, hi) = gaps
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &g| (a.min(g), b.max(g)));
    eprintln!("contact_gap over the faces: {lo:e} .. {hi:e} m");
    assert!(lo > 0.0 && lo < 0.1 * hi, "gaps {lo} .. {hi}");

    let url = serve(&[&out]);
    let mut b = Browser::start(WIDTH, HEIGHT);
    assert_eq!(
        b.open(&format!(
            "{url}?camera=top&lighting=0&field=contact_gap&frame=2"
        )),
        "1"
    );
    let options =
        b.eval("[...document.querySelectorAll('#field option')].map(o => o.value).join(' ')");
    assert!(
        options.as_str().is_some_and(|s| s.contains("contact_gap")),
        "{options}"
    );
    let legend = b.eval("document.querySelector('.legend').textContent");
    assert!(
        legend
            .as_str()
            .is_some_and(|s| s.contains("contact gap") && s.contains(" m")),
        "{legend}"
    );
    let img = b.screenshot();
    let (mask, canvas) = canvas_mask(&mut b, &img, 0, is_shell);
    let (first, faces) = obj(&out.join("frame_000000.obj"));
    let (last, _) = obj(&out.join("frame_000040.obj"));
    let top = TopView::new(&[&first, &last], canvas);
    let w = canvas[2].round() as usize;
    let h = mask.len() / w;
    let (mut checked, mut matched, mut dark) = (0, 0, 0);
    for (k, f) in faces.iter().enumerate() {
        let c = f.iter().fold([0.0; 3], |s, &v| {
            std::array::from_fn(|j| s[j] + last[v][j] / 3.0)
        });
        let [px, py] = top.project(c).map(|q| q.floor() as i64);
        let inside = (-2..=2).all(|dy| {
            (-2..=2).all(|dx| {
                let (x, y) = (px + dx, py + dy);
                x >= 0
                    && y >= 0
                    && (x as usize) < w
                    && (y as usize) < h
                    && mask[y as usize * w + x as usize]
            })
        });
        if !inside {
            continue;
        }
        checked += 1;
        let pixel = img.at(
            canvas[0] as usize + px as usize,
            canvas[1] as usize + py as usize,
        );
        let expected = sequential(gaps[k] / hi);
        if distance(pixel, expected) < 12.0 {
            matched += 1;
        }
        dark += usize::from(gaps[k] < 0.2 * hi && distance(pixel, COLOUR_OF_ZERO) < 60.0);
    }
    eprintln!("contact gap colours: {matched} of {checked} face centroids match, {dark} dark");
    assert!(
        checked > 100 && matched as f64 >= 0.95 * checked as f64,
        "{matched} of {checked}"
    );
    assert!(dark > 0);
}

#[test]
#[ignore = "needs chromium: run by `cargo xtask test` (browser stage)"]
fn browser_two_runs_side_by_side_share_camera_and_timeline() {
    let r = runs();
    let url = serve(&[&r.droop, &r.droop_sin]);
    let mut b = Browser::start(WIDTH, HEIGHT);
    // Frame 2 (step 4, t = 0.04 s): early in the droop, where the two forms still coincide
    // (by frame 10 the soft strip swings with large rotations, where sin and tan differ).
    assert_eq!(
        b.open(&format!("{url}?camera=top&lighting=0&field=none&frame=2")),
        "1"
    );
    assert_eq!(b.eval("document.querySelectorAll('.view').length"), 2);
    let img = b.screenshot();
    let (a, _) = canvas_mask(&mut b, &img, 0, is_shell);
    let (c, _) = canvas_mask(&mut b, &img, 1, is_shell);
    let (na, nc) = (
        a.iter().filter(|m| **m).count(),
        c.iter().filter(|m| **m).count(),
    );
    assert!(na > 1000 && nc > 1000, "shell pixels {na}, {nc}");
    // Same scene, same camera: the two silhouettes nearly coincide.
    eprintln!("two runs: shell pixels {na}, {nc}; IoU {:.4}", iou(&a, &c));
    assert!(iou(&a, &c) > 0.8, "IoU of the two runs {}", iou(&a, &c));
    // Linked cameras: dragging in view A turns both views the same way.
    let ca = b.rect(".view:nth-child(1) canvas.gl");
    let centre = [ca[0] + ca[2] / 2.0, ca[1] + ca[3] / 2.0];
    b.drag(centre, [centre[0] + 80.0, centre[1] + 60.0]);
    // `data-yaw` is the yaw of the last frame drawn.
    b.wait_for(
        "document.body.dataset.yaw === window.thinshell.state.camera.yaw.toFixed(4) && document.body.dataset.yaw",
        |y| y != "0.0000" && y != "false",
    );
    let img = b.screenshot();
    let (a2, _) = canvas_mask(&mut b, &img, 0, is_shell);
    let (c2, _) = canvas_mask(&mut b, &img, 1, is_shell);
    eprintln!(
        "after a drag in A: IoU with before A {:.3}, B {:.3}; A vs B {:.3}",
        iou(&a, &a2),
        iou(&c, &c2),
        iou(&a2, &c2)
    );
    assert!(
        iou(&a, &a2) < 0.7 && iou(&c, &c2) < 0.7,
        "both views turned"
    );
    assert!(iou(&a2, &c2) > 0.8, "and still show the same view");
    let titles =
        b.eval("[...document.querySelectorAll('.title')].map(t => t.textContent).join('|')");
    assert!(
        titles
            .as_str()
            .is_some_and(|t| t.contains("A: drooping strip") && t.contains("B: drooping strip"))
    );
}

#[test]
#[ignore = "needs chromium: run by `cargo xtask test` (browser stage)"]
fn browser_malformed_frame_shows_a_message() {
    let r = runs();
    let url = serve(&[&r.broken]);
    let mut b = Browser::start(WIDTH, HEIGHT);
    assert_eq!(b.open(&format!("{url}?frame=2")), "1");
    let msg = b.eval("(() => { const m = document.querySelector('.view .msg'); return getComputedStyle(m).display + '|' + m.textContent; })()");
    let msg = msg.as_str().unwrap_or("").to_string();
    assert!(msg.starts_with("block|"), "{msg}");
    assert!(
        msg.contains("frame 2 (step 4)") && msg.contains("not valid XML"),
        "{msg}"
    );
    // Not a blank canvas: a neighbouring frame is drawn, and the message says which.
    assert!(msg.contains("(showing frame "), "{msg}");
    let img = b.screenshot();
    let (mask, _) = canvas_mask(&mut b, &img, 0, is_shell);
    let shell = mask.iter().filter(|m| **m).count();
    assert!(
        shell > 1000,
        "blank canvas under the message ({shell} shell pixels)"
    );
    // The neighbouring frames still play.
    b.key("ArrowRight");
    b.wait_for("document.body.dataset.frame", |f| f == "3");
    b.wait_ready();
    let msg = b.eval("getComputedStyle(document.querySelector('.view .msg')).display");
    assert_eq!(msg, "none");
}

#[test]
#[ignore = "needs chromium: run by `cargo xtask test` (browser stage)"]
fn browser_self_contained_html_works_offline_from_file_url() {
    let r = runs();
    let viewer = Viewer::load(&[&r.droop]).expect("load");
    let file = r.root.join("droop.html");
    std::fs::write(&file, thinshell_cli::view::html::page(&viewer)).expect("write html");
    let mut b = Browser::start(WIDTH, HEIGHT);
    b.call("Network.enable", serde_json::json!({}));
    b.call(
        "Network.emulateNetworkConditions",
        serde_json::json!({ "offline": true, "latency": 0, "downloadThroughput": -1, "uploadThroughput": -1 }),
    );
    let url = format!(
        "file://{}?camera=top&lighting=0&field=none&frame=10",
        file.display()
    );
    assert_eq!(b.open(&url), "1");
    // Nothing was fetched: every byte came from the file.
    assert_eq!(b.eval("performance.getEntriesByType('resource').length"), 0);
    let img = b.screenshot();
    let (mask, canvas) = canvas_mask(&mut b, &img, 0, is_shell);
    let (first, faces) = obj(&r.droop.join("frame_000000.obj"));
    let (last, _) = obj(&r.droop.join("frame_000020.obj"));
    let top = TopView::new(&[&first, &last], canvas);
    let score = iou(&mask, &top.silhouette(&last, &faces));
    eprintln!("offline file:// page: last-frame silhouette IoU {score:.4}");
    assert!(
        score > 0.95,
        "offline page: last-frame silhouette IoU {score}"
    );
}

/// Playback benchmark (not a test; skipped by the browser stage): a synthetic 20 000-face,
/// 500-frame VTK run served lazily, played for 10 s at a requested 30 frames/s; prints the
/// frames per second shown and the stalls (ticks that waited for a frame).
#[test]
#[ignore = "benchmark: cargo test --release -p thinshell-cli --test view_browser -- --ignored bench_ --nocapture"]
fn bench_playback_20k_faces() {
    let dir = std::env::temp_dir().join(format!("thinshell-view-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let mesh = thinshell_mesh::generators::rectangle(1.0, 1.0, 100, 100).expect("mesh");
    assert_eq!(mesh.n_faces(), 20_000);
    let mut series = thinshell::vtk::Series::new(&dir, "frames");
    let n_frames = 500;
    let t0 = std::time::Instant::now();
    for k in 0..n_frames {
        let phase = k as f64 * 0.05;
        let x: Vec<nalgebra::Vector3<f64>> = mesh
            .positions()
            .iter()
            .map(|p| nalgebra::Vector3::new(p.x, p.y, 0.1 * (6.0 * p.x + phase).sin() * p.y))
            .collect();
        let u: Vec<_> = x.iter().zip(mesh.positions()).map(|(a, b)| a - b).collect();
        let density: Vec<f64> = (0..mesh.n_faces()).map(|f| ((f + k) % 97) as f64).collect();
        let frame = thinshell::vtk::Frame {
            mesh: &mesh,
            points: &x,
            point_vectors: vec![("displacement", &u)],
            cell_scalars: vec![
                ("stretch_density", density.clone()),
                ("bend_density", density),
            ],
            point_scalars: vec![],
            cell_vectors: vec![],
        };
        series
            .write(&format!("frame_{k:06}.vtu"), k as f64 * 1e-3, &frame)
            .expect("frame");
    }
    std::fs::write(
        dir.join("steps.csv"),
        "step,time_s,stretch_J,bend_J,kinetic_J\n",
    )
    .expect("csv");
    println!(
        "wrote {n_frames} frames in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    let url = serve(&[&dir]);
    let mut b = Browser::start(WIDTH, HEIGHT);
    let query = std::env::var("VIEW_BENCH_QUERY").unwrap_or_default();
    assert_eq!(
        b.open(&format!("{url}?field=bend_density&fps=30{query}")),
        "1"
    );
    b.eval("window.thinshell.setPlaying(true)");
    std::thread::sleep(std::time::Duration::from_secs(10));
    let stats = b.eval("window.thinshell.stats()");
    println!("playback of 20 000 faces, 500 frames, requested 30 frames/s: {stats}");
    assert!(stats["played"].as_f64().unwrap_or(0.0) > 0.0);
    let _ = std::fs::remove_dir_all(&dir);
}
