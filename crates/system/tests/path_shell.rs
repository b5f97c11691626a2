//! Arc length on a shell: a shallow arch strip under a central point load passes its limit
//! point, where load control jumps.

use thinshell_energy::{Material, RestState, SffKind, ShellModel, Terms};
use thinshell_mesh::VertexId;
use thinshell_solver::nalgebra::Vector3;
use thinshell_solver::{PathSettings, Static};
use thinshell_system::{Boundary, Loads, ShellPath, ShellSystem};

const RISE: f64 = 0.015;

/// The arch strip of the test kit (span 1 m, width 0.1 m, rise 15 mm, h = 10 mm, E = 10 MPa,
/// the mid-edge average), both short ends pinned, load `force` (N) down on the crown vertex;
/// returns the system (at λ = 0), the positions and the crown vertex.
fn arch(force: f64) -> (ShellSystem, Vec<Vector3<f64>>, VertexId) {
    thinshell_testkit::fixtures::shallow_arch(RISE, force, SffKind::MidEdgeAverage)
}

/// Turning points (sign changes of the increments) of a sequence.
fn turns(values: &[f64]) -> usize {
    let d: Vec<f64> = values.windows(2).map(|w| w[1] - w[0]).collect();
    d.windows(2).filter(|w| w[0] * w[1] < 0.0).count()
}

#[test]
fn arc_length_passes_the_limit_point_where_load_control_jumps() {
    let (mut system, x0, crown) = arch(1.0);
    let deflection = |x: &[Vector3<f64>]| x0[crown.idx()].z - x[crown.idx()].z;

    // Arc length: 25 steps from the unloaded arch.
    let mut path = ShellPath::new(PathSettings {
        initial_load_increment: 0.02,
        ..Default::default()
    });
    let (mut x, mut phi) = (x0.clone(), Vec::new());
    let (mut lambda, mut w, mut stable) = (vec![0.0], vec![0.0], vec![true]);
    for _ in 0..25 {
        let p = path
            .step(&mut system, &mut x, &mut phi)
            .expect("arc-length step");
        assert_eq!(p.load_factor, system.load_factor());
        assert!(
            p.residuals.last().is_some_and(|r| *r < 1e-8),
            "{:?}",
            p.residuals
        );
        lambda.push(p.load_factor);
        w.push(deflection(&x));
        stable.push(p.stable());
    }
    // A continuous path: the crown moves down monotonically in small steps while λ rises to
    // its maximum, falls (below 0: the arch pulls itself through) and rises again.
    let max_dw = w.windows(2).map(|p| p[1] - p[0]).fold(0.0f64, f64::max);
    assert_eq!(turns(&w), 0, "w {w:?}");
    assert_eq!(turns(&lambda), 2, "λ {lambda:?}");
    assert!(max_dw < 0.15 * RISE, "largest step in w {max_dw}");
    // The limit point: the first maximum of λ.
    let i_max = lambda
        .windows(2)
        .position(|p| p[1] < p[0])
        .expect("λ falls somewhere");
    let lambda_max = lambda[i_max];
    assert!(lambda.iter().any(|l| *l < 0.0));
    // Stable before the largest traced λ, unstable (at fixed load) while λ falls after it.
    assert!(
        stable[..i_max].iter().all(|s| *s) && !stable[i_max + 1],
        "λ {lambda:?}, stable {stable:?}"
    );

    // Load control: λ = 0.01, 0.02, … each solved from the previous equilibrium.
    let (mut system, _, _) = arch(1.0);
    let mut statics = Static::default();
    let mut x = x0.clone();
    let mut w_load = vec![0.0];
    let mut lambdas = vec![0.0];
    for k in 1..=25 {
        let l = 0.01 * k as f64;
        system.set_load_factor(l).expect("λ");
        statics.solve(&mut system, &mut x).expect("static solve");
        lambdas.push(l);
        w_load.push(deflection(&x));
    }
    // It jumps: one load step moves the crown many times the largest arc-length step ...
    let jump = w_load
        .windows(2)
        .position(|p| p[1] - p[0] > 5.0 * max_dw)
        .expect("load control jumps");
    // ... exactly where λ first exceeds the limit load the arc length found ...
    assert!(
        lambdas[jump] <= lambda_max && lambda_max < lambdas[jump + 1],
        "jump from λ = {} to {}, traced limit load {lambda_max}",
        lambdas[jump],
        lambdas[jump + 1]
    );
    // ... onto the far branch, past the arc length's lowest point (its second limit point).
    let i_min = (i_max..lambda.len())
        .min_by(|&a, &b| lambda[a].total_cmp(&lambda[b]))
        .expect("points");
    assert!(
        w_load[jump + 1] > w[i_min],
        "{} vs {}",
        w_load[jump + 1],
        w[i_min]
    );
    // Before the jump both methods agree on the path: λ(w) of load control between the
    // arc-length points (linear interpolation, whose error is well below 1 %).
    for (&l, &wl) in lambdas[1..=jump].iter().zip(&w_load[1..=jump]) {
        let j = w.iter().position(|&wa| wa > wl).expect("bracketing point");
        let t = (wl - w[j - 1]) / (w[j] - w[j - 1]);
        let l_arc = lambda[j - 1] + t * (lambda[j] - lambda[j - 1]);
        assert!(
            (l_arc - l).abs() < 0.01 * lambda_max,
            "λ {l} vs arc {l_arc}"
        );
    }
}

/// The hinged cylindrical roof (R = 2540, length 508, opening 0.2 rad, E = 3102.75, ν = 0.3,
/// straight edges hinged, curved edges free, central point load P_max; Sze, Liu & Lo 2004)
/// on a coarse 8 × 8 mesh with the mid-edge average; returns the system at λ = 0, the start
/// positions, the loaded vertex and the inward radial direction there.
fn roof(h: f64, p_max: f64) -> (ShellSystem, Vec<Vector3<f64>>, VertexId, Vector3<f64>) {
    let n = 8;
    let mesh = thinshell_mesh::generators::cylinder_patch(2540.0, 0.2, 508.0, n, n).expect("mesh");
    let x0 = mesh.positions().to_vec();
    let sff = SffKind::MidEdgeAverage;
    let rest = RestState::from_mesh(&mesh, mesh.positions(), sff).expect("rest");
    let model = ShellModel {
        material: Material {
            thickness: h,
            young: 3102.75,
            poisson: 0.3,
            ..Material::paper()
        },
        terms: Terms::ELASTIC,
        sff,
    };
    // Vertex j·(n + 1) + i sits at angle 0.2·i/n, height 508·j/n.
    let hinged = (0..mesh.n_vertices())
        .filter(|v| v % (n + 1) == 0 || v % (n + 1) == n)
        .map(VertexId::new)
        .collect();
    let centre = VertexId::new((n / 2) * (n + 1) + n / 2);
    let inward = -Vector3::new(0.1f64.cos(), 0.1f64.sin(), 0.0);
    let loads = Loads {
        point_forces: vec![(centre, inward * p_max)],
        ..Default::default()
    };
    let boundary = Boundary {
        pinned_vertices: hinged,
        ..Default::default()
    };
    let mut system = ShellSystem::new(mesh, model, rest, boundary, loads).expect("system");
    system.set_load_factor(0.0).expect("λ = 0");
    (system, x0, centre, inward)
}

/// The thinner roof (h = 6.35, P_max = 600) snaps through and then back: after its load limit
/// point the centre deflection W itself turns back (a snap-back, which displacement control of
/// W cannot pass) while λ keeps falling. The sign rule (continue the previous increment)
/// carries the arc length through both turning points without a cut-back.
#[test]
fn arc_length_follows_the_snap_back_of_the_thin_hinged_roof() {
    let (mut system, x0, centre, inward) = roof(6.35, 600.0);
    let mut path = ShellPath::new(PathSettings {
        initial_load_increment: 0.05,
        ..Default::default()
    });
    let (mut x, mut phi) = (x0.clone(), Vec::new());
    let (mut lambda, mut w) = (vec![0.0], vec![0.0]);
    for _ in 0..32 {
        let p = path
            .step(&mut system, &mut x, &mut phi)
            .expect("arc-length step");
        assert_eq!(p.cutbacks, 0);
        lambda.push(p.load_factor);
        w.push((x[centre.idx()] - x0[centre.idx()]).dot(&inward));
    }
    let i_lambda = lambda
        .windows(2)
        .position(|p| p[1] < p[0])
        .expect("limit point");
    let i_w = w.windows(2).position(|p| p[1] < p[0]).expect("snap-back");
    // Load limit first (λ ≈ 0.91 on this mesh), then W turns back, with λ still falling.
    assert!(i_lambda < i_w, "λ turns at {i_lambda}, W at {i_w}");
    assert!((0.85..0.95).contains(&lambda[i_lambda]), "{lambda:?}");
    assert_eq!(turns(&lambda), 1, "λ {lambda:?}");
    assert_eq!(turns(&w), 1, "W {w:?}");
    assert!(
        lambda[i_w + 1] < lambda[i_w] && w[i_w] > 15.0,
        "{lambda:?} {w:?}"
    );
}
