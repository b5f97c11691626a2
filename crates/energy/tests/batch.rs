#![allow(clippy::unwrap_used)]
//! The assembler's batched passes (St. Venant–Kirchhoff with the mid-edge average, energy and
//! energy + gradient, several faces per SIMD lane) against the scalar per-face kernels
//! evaluated face by face and scattered here: per-face energies within 1e-13 of the largest
//! face energy, the gradient within 1e-13 of its largest entry (round-off of differently
//! ordered sums; measured over 40 cases: energies ≤ 4e-16, gradient ≤ 5e-15). The energy-only
//! pass's per-face energies are the kernel's bits (both evaluate the formulas written once over
//! `real::Real`), and so are the gradient pass's without damping. On random
//! meshes with free edges (faces without flaps), face counts that are no multiple of the batch
//! width, every combination of terms and random materials. Results are the same bits for 1, 2
//! and 3 threads.
//!
//! The edge-director forms' energy pass (batched since its half dihedral angles come from
//! half-angle identities instead of atan2) likewise, at random edge angles, with clamped and
//! fitted free edges (those faces go back to the per-face kernel inside the batch).

use nalgebra::Vector3;
use proptest::prelude::*;
use thinshell_energy::*;
use thinshell_mesh::{Mesh, generators};
use thinshell_testkit::rng::SplitMix64;
use thinshell_testkit::strategies::cases_or;

const TOL: f64 = 1e-13;

struct Case {
    mesh: Mesh,
    rest: RestState,
    damping: DampingState,
    x: Vec<Vector3<f64>>,
}

impl Case {
    /// Face f's rest forms.
    fn face_rest(&self, f: usize) -> FaceRest {
        FaceRest {
            a_bar: self.rest.a_bar[f],
            b_bar: self.rest.b_bar[f],
        }
    }

    /// Face f's previous forms for the damping terms.
    fn face_damping(&self, f: usize) -> FaceDamping {
        FaceDamping {
            a_prev: self.damping.a_prev[f],
            b_prev: self.damping.b_prev[f],
            dt: self.damping.dt,
        }
    }
}

/// An irregular sheet bent into a bump (rest), with random previous and current positions.
fn case(seed: u64, n: usize, amplitude: f64) -> Case {
    let flat = generators::irregular_rectangle(1.0, 0.8, n, seed).unwrap();
    let bump: Vec<_> = flat
        .positions()
        .iter()
        .map(|p| Vector3::new(p.x, p.y, 0.3 * (p.x * 2.0).sin() * (p.y * 1.5).cos()))
        .collect();
    let mesh = flat.with_positions(bump).unwrap();
    let rest = RestState::from_mesh(&mesh, mesh.positions(), SffKind::MidEdgeAverage).unwrap();
    let mut rng = SplitMix64::new(seed ^ 0xBA7C);
    let x_prev: Vec<_> = mesh
        .positions()
        .iter()
        .map(|p| p + rng.vector3(amplitude))
        .collect();
    let x: Vec<_> = x_prev
        .iter()
        .map(|p| p * 1.02 + rng.vector3(amplitude))
        .collect();
    let damping =
        DampingState::from_positions(&mesh, &x_prev, SffKind::MidEdgeAverage, 0.05).unwrap();
    Case {
        mesh,
        rest,
        damping,
        x,
    }
}

/// Per-face energies and the gradient from the scalar kernels, face by face: `eval_face_energy`
/// for the energies, `eval_face` (gradient) scattered over each face's stencil (flap slots only
/// where the flap exists).
fn scalar(c: &Case, model: &ShellModel) -> (Vec<EnergyTerms>, Vec<EnergyTerms>, Vec<f64>) {
    let stencils = Stencils::new(&c.mesh);
    let constants = EnergyConstants::new(&model.material);
    let mut energies = Vec::new();
    let mut grad_energies = Vec::new();
    let mut g = vec![0.0; 3 * c.mesh.n_vertices()];
    let want = Want {
        gradient: true,
        hessian: None,
    };
    let mut out = FaceEval::<18>::default();
    for f in 0..c.mesh.n_faces() {
        let s = stencils.stencil(f, &c.x);
        let rest = c.face_rest(f);
        let damping = c.face_damping(f);
        let d = model.terms.damping.then_some(&damping);
        energies.push(eval_face_energy(
            &MidEdgeAverage,
            &model.material,
            &constants,
            &s,
            &rest,
            d,
            model.terms,
        ));
        eval_face(
            &MidEdgeAverage,
            &model.material,
            &s,
            &rest,
            d,
            model.terms,
            want,
            &mut out,
        );
        grad_energies.push(out.energy);
        let v = stencils.vertices(f);
        for slot in 0..6 {
            if slot >= 3 && !stencils.flap(f)[slot - 3] {
                continue;
            }
            for a in 0..3 {
                g[3 * v[slot].idx() + a] += out.gradient[3 * slot + a];
            }
        }
    }
    (energies, grad_energies, g)
}

/// Energy-only and energy + gradient evaluations of the assembler on `threads` threads:
/// (per-face energies of each, gradient).
fn batched(
    c: &Case,
    model: &ShellModel,
    threads: usize,
) -> (Vec<EnergyTerms>, Vec<EnergyTerms>, Vec<f64>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let dofs = DofMap::all_free(c.mesh.n_vertices());
        let mut asm = Assembler::for_model(&c.mesh, &dofs, model).unwrap();
        let damping = model.terms.damping.then_some(&c.damping);
        asm.evaluate(model, &c.x, &c.rest, damping, EvalOutput::default())
            .unwrap();
        let e = asm.face_energies().to_vec();
        let mut g = vec![0.0; asm.n_coordinates()];
        let out = EvalOutput {
            gradient: Some(&mut g),
            hessian: None,
        };
        asm.evaluate(model, &c.x, &c.rest, damping, out).unwrap();
        (e, asm.face_energies().to_vec(), g)
    })
}

fn terms_of(bits: u8) -> Terms {
    Terms {
        stretch: bits & 1 != 0,
        bend: bits & 2 != 0,
        damping: bits & 4 != 0,
    }
}

fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Largest difference of the per-term face energies, over the largest face energy.
fn energy_error(a: &[EnergyTerms], b: &[EnergyTerms]) -> f64 {
    let parts = |e: &EnergyTerms| [e.stretch, e.bend, e.damping];
    let scale = max_abs(b.iter().flat_map(parts));
    let err = max_abs(
        a.iter()
            .zip(b)
            .flat_map(|(x, y)| parts(x).into_iter().zip(parts(y)).map(|(p, q)| p - q)),
    );
    err / scale
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(12)))]

    /// Batched and scalar passes agree on random sheets, terms and materials.
    #[test]
    fn batched_matches_scalar_kernels(
        seed in 0u64..10_000,
        n in 3usize..9,
        terms in 1u8..8,
        thickness in 0.01f64..0.2,
        poisson in 0.0f64..0.45,
        amplitude in 0.0f64..0.05,
    ) {
        let c = case(seed, n, amplitude);
        let model = ShellModel {
            material: Material {
                thickness,
                young: 1.0e3,
                poisson,
                density: 1.0,
                viscosity: 10.0,
                model: MaterialModel::StVK,
            },
            terms: terms_of(terms),
            sff: SffKind::MidEdgeAverage,
        };
        let (e_ref, eg_ref, g_ref) = scalar(&c, &model);
        let (e, eg, g) = batched(&c, &model, 1);
        let err = energy_error(&e, &e_ref);
        prop_assert!(err <= TOL, "energy-only pass: {err:e}");
        // The energy-only pass evaluates the energy-only kernel's formulas (written once over
        // `real::Real`) in the same order: the same bits.
        let bits = |v: &[EnergyTerms]| -> Vec<[u64; 3]> {
            v.iter().map(|t| [t.stretch, t.bend, t.damping].map(f64::to_bits)).collect()
        };
        prop_assert_eq!(bits(&e), bits(&e_ref), "energy-only pass: not the kernel's bits");
        let err = energy_error(&eg, &eg_ref);
        prop_assert!(err <= TOL, "gradient pass energies: {err:e}");
        if !model.terms.damping {
            // Likewise the law's 2Kd (damping's gradient is K·d there, the matrix K in the
            // kernel, which also needs K for its Hessian).
            prop_assert_eq!(bits(&eg), bits(&eg_ref), "gradient pass: not the kernel's bits");
        }
        let scale = max_abs(g_ref.iter().copied());
        let gerr = max_abs(g.iter().zip(&g_ref).map(|(a, b)| a - b));
        prop_assert!(gerr <= TOL * scale, "gradient: {gerr:e} of {scale:e}");
    }
}

/// 1, 2 and 3 threads give the same bits on both batched passes, with damping, on a mesh whose
/// face count is no multiple of the chunk size (the last chunk and last batch are partial) and
/// large enough for the passes to run in parallel.
#[test]
fn batched_passes_independent_of_thread_count() {
    let c = case(5, 43, 0.01);
    let n = c.mesh.n_faces();
    assert!(n % 64 != 0 && n % 4 != 0 && n > 2048, "{n} faces");
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ALL,
        sff: SffKind::MidEdgeAverage,
    };
    let bits = |(e, eg, g): (Vec<EnergyTerms>, Vec<EnergyTerms>, Vec<f64>)| {
        let flat = |v: &[EnergyTerms]| -> Vec<u64> {
            v.iter()
                .flat_map(|t| [t.stretch, t.bend, t.damping])
                .map(f64::to_bits)
                .collect()
        };
        (
            flat(&e),
            flat(&eg),
            g.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        )
    };
    let one = bits(batched(&c, &model, 1));
    assert!(one.2.iter().any(|&b| f64::from_bits(b) != 0.0));
    assert_eq!(one, bits(batched(&c, &model, 2)));
    assert_eq!(one, bits(batched(&c, &model, 3)));
}

/// The edge-director passes of one configuration: per-face energies of the energy pass and of
/// the energy + gradient pass, and the gradient.
struct DirectorPasses {
    e: Vec<EnergyTerms>,
    eg: Vec<EnergyTerms>,
    g: Vec<f64>,
    /// The largest |f(α_i)| = |II_i| / 2d_i over the faces' edges (the scalar kernel's b).
    f_max: f64,
}

/// The edge-director form `variant` at edge angles `phi`, with the boundary edges in `clamped`
/// clamped at the rest positions: the assembler's energy and energy + gradient passes on
/// `threads` threads, and the scalar kernels face by face on stencils clamped the same way
/// (`eval_face_energy`; `eval_face` over the 21 dofs scattered like the assembler: the stencil
/// slots its pattern keeps, ∂E/∂φ onto the face's edges).
fn director_passes(
    c: &Case,
    model: &ShellModel,
    phi: &[f64],
    clamped: &[thinshell_mesh::EdgeId],
    threads: usize,
) -> (DirectorPasses, DirectorPasses) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let damping = model.terms.damping.then_some(&c.damping);
    let batched = pool.install(|| {
        let mut dofs = DofMap::all_free(c.mesh.n_vertices());
        if model.has_edge_unknowns() {
            dofs = dofs
                .with_edges(c.mesh.n_edges(), fitted_free_edges(&c.mesh))
                .unwrap();
        }
        let mut asm = Assembler::for_model(&c.mesh, &dofs, model).unwrap();
        asm.set_batched_director_gradient(true);
        asm.clamp_edges(clamped, c.mesh.positions()).unwrap();
        asm.evaluate_with_angles(model, &c.x, phi, &c.rest, damping, EvalOutput::default())
            .unwrap();
        let e = asm.face_energies().to_vec();
        let mut g = vec![0.0; asm.n_coordinates()];
        let out = EvalOutput {
            gradient: Some(&mut g),
            hessian: None,
        };
        asm.evaluate_with_angles(model, &c.x, phi, &c.rest, damping, out)
            .unwrap();
        DirectorPasses {
            e,
            eg: asm.face_energies().to_vec(),
            g,
            f_max: 0.0,
        }
    });
    let mut stencils = Stencils::new(&c.mesh);
    stencils
        .set_clamped_edges(clamped, c.mesh.positions())
        .unwrap();
    let form = model.sff.director().unwrap();
    let constants = EnergyConstants::new(&model.material);
    let want = Want {
        gradient: true,
        hessian: None,
    };
    let n_pos = 3 * c.mesh.n_vertices();
    let mut scalar = DirectorPasses {
        e: Vec::new(),
        eg: Vec::new(),
        g: vec![0.0; n_pos + if phi.is_empty() { 0 } else { c.mesh.n_edges() }],
        f_max: 0.0,
    };
    let mut out = FaceEval::<DIRECTOR_DOFS>::default();
    for f in 0..c.mesh.n_faces() {
        let rest = c.face_rest(f);
        let face_damping = c.face_damping(f);
        let d = model.terms.damping.then_some(&face_damping);
        let s = if phi.is_empty() {
            stencils.stencil(f, &c.x)
        } else {
            stencils.stencil_at(f, &c.x, phi)
        };
        let (m, t) = (&model.material, model.terms);
        scalar
            .e
            .push(eval_face_energy(&form, m, &constants, &s, &rest, d, t));
        eval_face(&form, m, &s, &rest, d, t, want, &mut out);
        scalar.eg.push(out.energy);
        // b = −[[II_0 + II_1, II_0], [II_0, II_0 + II_2]], d_i = |c_f| / |edge i|.
        let b = form.b_with_angles(&s, &s.angles);
        let ii = [-b[(0, 1)], b[(0, 1)] - b[(0, 0)], b[(0, 1)] - b[(1, 1)]];
        let area2 = (s.x[1] - s.x[0]).cross(&(s.x[2] - s.x[0])).norm();
        for (i, ii) in ii.iter().enumerate() {
            let edge = (s.x[(i + 2) % 3] - s.x[(i + 1) % 3]).norm();
            scalar.f_max = scalar.f_max.max(ii.abs() * edge / (2.0 * area2));
        }
        for (slot, v) in stencils.vertices(f).iter().enumerate() {
            // With or without edge unknowns, a free-edge fit's outer vertex is read (its b
            // enters the damping even with bending off).
            if stencils.slot_present_director(f, slot) {
                for a in 0..3 {
                    scalar.g[3 * v.idx() + a] += out.gradient[3 * slot + a];
                }
            }
        }
        if !phi.is_empty() {
            for (e, edge) in stencils.edges(f).iter().enumerate() {
                scalar.g[n_pos + edge.idx()] += out.gradient[18 + e];
            }
        }
    }
    (batched, scalar)
}

/// Largest difference of the position and of the edge-angle entries of two gradients (the
/// first `n_pos` entries, the rest), each over the largest such entry of `b`.
fn gradient_errors(a: &[f64], b: &[f64], n_pos: usize) -> (f64, f64) {
    let err = |x: &[f64], y: &[f64]| {
        let scale = max_abs(y.iter().copied());
        if scale == 0.0 {
            return max_abs(x.iter().copied());
        }
        max_abs(x.iter().zip(y).map(|(p, q)| p - q)) / scale
    };
    (err(&a[..n_pos], &b[..n_pos]), err(&a[n_pos..], &b[n_pos..]))
}

/// The director passes (batched, then the scalar reference) on the random sheet `case(seed, n,
/// amplitude)` with the terms `terms_of(terms)`, the tan or sin variant, edge angles uniform in
/// ±`angle` (stream `salt`) and every third boundary edge clamped.
fn random_director_passes(
    seed: u64,
    n: usize,
    terms: u8,
    tan: bool,
    angle: f64,
    amplitude: f64,
    salt: u64,
) -> (Case, DirectorVariant, DirectorPasses, DirectorPasses) {
    let c = case(seed, n, amplitude);
    let variant = if tan {
        DirectorVariant::Tan
    } else {
        DirectorVariant::Sin
    };
    let model = ShellModel {
        material: Material::paper(),
        terms: terms_of(terms),
        sff: SffKind::EdgeDirector(variant),
    };
    let mut rng = SplitMix64::new(seed ^ salt);
    let phi: Vec<f64> = if model.has_edge_unknowns() {
        (0..c.mesh.n_edges())
            .map(|_| angle * rng.signed())
            .collect()
    } else {
        Vec::new()
    };
    let clamped: Vec<_> = c
        .mesh
        .topology()
        .boundary_edges()
        .iter()
        .copied()
        .step_by(3)
        .collect();
    let (b, r) = director_passes(&c, &model, &phi, &clamped, 1);
    (c, variant, b, r)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases_or(12)))]

    /// The batched edge-director energy pass agrees with the scalar kernel, both variants,
    /// random edge angles up to 0.3 rad, some free edges clamped.
    #[test]
    fn batched_director_energy_matches_scalar_kernel(
        seed in 0u64..10_000,
        n in 3usize..9,
        terms in 1u8..8,
        tan in any::<bool>(),
        angle in 0.0f64..0.3,
        amplitude in 0.0f64..0.05,
    ) {
        let (_, variant, b, r) = random_director_passes(seed, n, terms, tan, angle, amplitude, 0xD1);
        let err = energy_error(&b.e, &r.e);
        prop_assert!(err <= TOL, "{variant:?}: {err:e}");
    }

    /// The batched edge-director energy + gradient pass agrees with the scalar kernel face by
    /// face: energies, the position gradient and ∂E/∂φ, each within 1e-13 of its largest
    /// entry times max(1, max |f(α)|), both variants, random edge angles up to 0.3 rad, some
    /// free edges clamped. The factor is tan's conditioning near its pole (a hinge of these
    /// random configurations can fold over): an error δα of an ulp or so, from atan2 in one and
    /// the half-angle identities in the other, moves f by f′δα = (1 + f²)δα, relative f δα,
    /// and the energy (∝ f²) and gradient (∝ f f′) by a few times that.
    #[test]
    fn batched_director_gradient_matches_scalar_kernel(
        seed in 0u64..10_000,
        n in 3usize..9,
        terms in 1u8..8,
        tan in any::<bool>(),
        angle in 0.0f64..0.3,
        amplitude in 0.0f64..0.05,
    ) {
        let (c, variant, b, r) = random_director_passes(seed, n, terms, tan, angle, amplitude, 0xD2);
        let tol = TOL * r.f_max.max(1.0);
        let err = energy_error(&b.eg, &r.eg);
        prop_assert!(err <= tol, "{variant:?} energies: {err:e}, f_max {}", r.f_max);
        prop_assert_eq!(b.g.len(), r.g.len());
        let (pos, ang) = gradient_errors(&b.g, &r.g, 3 * c.mesh.n_vertices());
        prop_assert!(pos <= tol, "{variant:?} position gradient: {pos:e}, f_max {}", r.f_max);
        prop_assert!(ang <= tol, "{variant:?} angle gradient: {ang:e}, f_max {}", r.f_max);
    }
}

/// The edge-director energy pass gives the same bits on 1, 2 and 3 threads.
#[test]
fn batched_director_energy_independent_of_thread_count() {
    let c = case(8, 43, 0.01);
    let model = ShellModel {
        material: Material::paper(),
        terms: Terms::ALL,
        sff: SffKind::default(),
    };
    let phi: Vec<f64> = (0..c.mesh.n_edges())
        .map(|e| 0.05 * (e as f64 * 0.7).sin())
        .collect();
    let bits = |e: Vec<EnergyTerms>| -> Vec<u64> {
        e.iter()
            .flat_map(|t| [t.stretch, t.bend, t.damping])
            .map(f64::to_bits)
            .collect()
    };
    let one = bits(director_passes(&c, &model, &phi, &[], 1).0.e);
    assert!(one.iter().any(|&b| f64::from_bits(b) != 0.0));
    assert_eq!(one, bits(director_passes(&c, &model, &phi, &[], 2).0.e));
    assert_eq!(one, bits(director_passes(&c, &model, &phi, &[], 3).0.e));
}

/// The edge-director energy + gradient pass gives the same bits on 1, 2 and 3 threads (both
/// variants, damping on, a 4 085-face sheet: partial last chunk and batch, parallel passes).
#[test]
fn batched_director_gradient_independent_of_thread_count() {
    let c = case(8, 43, 0.01);
    let n = c.mesh.n_faces();
    assert!(n % 64 != 0 && n % 4 != 0 && n > 2048, "{n} faces");
    let phi: Vec<f64> = (0..c.mesh.n_edges())
        .map(|e| 0.05 * (e as f64 * 0.7).sin())
        .collect();
    for variant in [DirectorVariant::Tan, DirectorVariant::Sin] {
        let model = ShellModel {
            material: Material::paper(),
            terms: Terms::ALL,
            sff: SffKind::EdgeDirector(variant),
        };
        let bits = |p: DirectorPasses| -> (Vec<u64>, Vec<u64>) {
            let e = p.eg.iter().flat_map(|t| [t.stretch, t.bend, t.damping]);
            (
                e.map(f64::to_bits).collect(),
                p.g.iter().map(|x| x.to_bits()).collect(),
            )
        };
        let one = bits(director_passes(&c, &model, &phi, &[], 1).0);
        let n_pos = 3 * c.mesh.n_vertices();
        assert!(one.1[..n_pos].iter().any(|&b| f64::from_bits(b) != 0.0));
        assert!(one.1[n_pos..].iter().any(|&b| f64::from_bits(b) != 0.0));
        assert_eq!(one, bits(director_passes(&c, &model, &phi, &[], 2).0));
        assert_eq!(one, bits(director_passes(&c, &model, &phi, &[], 3).0));
    }
}

/// A hinge folded completely flat (the neighbour triangle lies on the face, θ = π exactly): the
/// batched half-angle formulas give 0/0 there, and the face goes back to the per-face kernel,
/// so both variants give the scalar kernel's energies bit for bit (finite and nonzero), on
/// the energy pass and on the energy + gradient pass, and the latter the scalar kernel's
/// gradient (summed in face order, as the assembler's gather) bit for bit.
#[test]
fn folded_flat_hinge_goes_back_to_the_per_face_kernel() {
    let p = |x: f64, y: f64| Vector3::new(x, y, 0.0);
    let mesh = Mesh::new(
        vec![p(0.0, 0.0), p(1.0, 0.0), p(0.0, 1.0), p(1.0, 1.0)],
        vec![[0, 1, 2], [2, 1, 3]],
    )
    .unwrap();
    // Vertex 3 reflected across the shared edge lands on vertex 0.
    let x = vec![p(0.0, 0.0), p(1.0, 0.0), p(0.0, 1.0), p(0.0, 0.0)];
    for variant in [DirectorVariant::Sin, DirectorVariant::Tan] {
        let model = ShellModel {
            material: Material::paper(),
            terms: Terms::ELASTIC,
            sff: SffKind::EdgeDirector(variant),
        };
        let rest = RestState::from_mesh(&mesh, mesh.positions(), model.sff).unwrap();
        let dofs = DofMap::all_free(4)
            .with_edges(mesh.n_edges(), fitted_free_edges(&mesh))
            .unwrap();
        let phi = vec![0.0; mesh.n_edges()];
        let mut asm = Assembler::for_model(&mesh, &dofs, &model).unwrap();
        asm.set_batched_director_gradient(true);
        asm.evaluate_with_angles(&model, &x, &phi, &rest, None, EvalOutput::default())
            .unwrap();
        let stencils = Stencils::new(&mesh);
        let constants = EnergyConstants::new(&model.material);
        let form = model.sff.director().unwrap();
        for f in 0..2 {
            let face_rest = FaceRest {
                a_bar: rest.a_bar[f],
                b_bar: rest.b_bar[f],
            };
            let e = eval_face_energy(
                &form,
                &model.material,
                &constants,
                &stencils.stencil_at(f, &x, &phi),
                &face_rest,
                None,
                model.terms,
            );
            assert!(e.bend.is_finite() && e.bend > 0.0, "{variant:?}: {e:?}");
            assert_eq!(asm.face_energies()[f], e, "{variant:?}, face {f}");
        }
        let mut g = vec![0.0; asm.n_coordinates()];
        let out = EvalOutput {
            gradient: Some(&mut g),
            hessian: None,
        };
        asm.evaluate_with_angles(&model, &x, &phi, &rest, None, out)
            .unwrap();
        let want = Want {
            gradient: true,
            hessian: None,
        };
        let mut g_ref = vec![0.0; g.len()];
        let mut fe = FaceEval::<DIRECTOR_DOFS>::default();
        for f in 0..2 {
            let face_rest = FaceRest {
                a_bar: rest.a_bar[f],
                b_bar: rest.b_bar[f],
            };
            let s = stencils.stencil_at(f, &x, &phi);
            eval_face(
                &form,
                &model.material,
                &s,
                &face_rest,
                None,
                model.terms,
                want,
                &mut fe,
            );
            assert!(fe.energy.bend.is_finite() && fe.energy.bend > 0.0);
            assert_eq!(asm.face_energies()[f], fe.energy, "{variant:?}, face {f}");
            let v = stencils.vertices(f);
            for slot in (0..6).filter(|&s| stencils.slot_present_director(f, s)) {
                for a in 0..3 {
                    g_ref[3 * v[slot].idx() + a] += fe.gradient[3 * slot + a];
                }
            }
            for (e, edge) in stencils.edges(f).iter().enumerate() {
                g_ref[12 + edge.idx()] += fe.gradient[18 + e];
            }
        }
        assert!(g_ref.iter().all(|v| v.is_finite()) && g_ref.iter().any(|&v| v != 0.0));
        assert_eq!(g, g_ref, "{variant:?}");
    }
}

/// Mirror edges (model.md §1.4) take the per-face route inside the batched passes: on a bent
/// irregular sheet with mirror edges on its side x = 0, for every form, the assembler's bending
/// energy
/// alone (batched), with the gradient (batched for the mid-edge average without mirrors) and
/// with the Hessian (per face) give the same energy to 1e-13 and the same gradient to 1e-13 of
/// its largest entry, equal to the scalar kernels summed face by face on stencils with the same
/// mirrors; without the mirrors the energy differs (so a pass that dropped them would fail).
#[test]
fn mirror_edges_take_the_per_face_route() {
    let c = case(7, 9, 0.02);
    let topo = c.mesh.topology();
    let p = c.mesh.positions();
    let mirror: Vec<(thinshell_mesh::EdgeId, Vector3<f64>)> = topo
        .boundary_edges()
        .iter()
        .filter(|&&e| {
            topo.edge(e)
                .vertices
                .iter()
                .all(|v| p[v.idx()].x.abs() < 1e-12)
        })
        .map(|&e| (e, Vector3::x()))
        .collect();
    assert!(mirror.len() >= 3, "{} mirror edges", mirror.len());
    for sff in SffKind::ALL {
        let model = ShellModel {
            material: Material::paper(),
            // Bending alone: stretching would hide the few boundary faces' share.
            terms: Terms {
                stretch: false,
                bend: true,
                damping: false,
            },
            sff,
        };
        let mut dofs = DofMap::all_free(c.mesh.n_vertices());
        let phi = if model.has_edge_unknowns() {
            let fixed = fitted_free_edges(&c.mesh)
                .into_iter()
                .chain(mirror.iter().map(|m| m.0));
            dofs = dofs.with_edges(c.mesh.n_edges(), fixed).unwrap();
            vec![0.0; c.mesh.n_edges()]
        } else {
            Vec::new()
        };
        let n = dofs.n_coordinates();
        let mut asm = Assembler::for_model(&c.mesh, &dofs, &model).unwrap();
        asm.set_batched_director_gradient(true);
        let plain = asm
            .evaluate_with_angles(&model, &c.x, &phi, &c.rest, None, EvalOutput::default())
            .unwrap()
            .total();
        asm.set_mirror_edges(&mirror).unwrap();
        let mut run = |gradient: bool, hessian: bool| {
            let mut g = vec![0.0; n];
            let mut h = asm.hessian_template();
            let out = EvalOutput {
                gradient: gradient.then_some(&mut g[..]),
                hessian: hessian.then_some((&mut h, HessianMode::Exact)),
            };
            let e = asm
                .evaluate_with_angles(&model, &c.x, &phi, &c.rest, None, out)
                .unwrap();
            (e.total(), g)
        };
        let (e0, _) = run(false, false);
        let (e1, g1) = run(true, false);
        let (e2, g2) = run(true, true);
        let mut stencils = Stencils::new(&c.mesh);
        stencils.set_mirror_edges(&mirror).unwrap();
        let constants = EnergyConstants::new(&model.material);
        let scalar: f64 = (0..c.mesh.n_faces())
            .map(|f| {
                let rest = c.face_rest(f);
                let s = stencils.stencil(f, &c.x);
                match sff.director() {
                    Some(form) => eval_face_energy(
                        &form,
                        &model.material,
                        &constants,
                        &s,
                        &rest,
                        None,
                        model.terms,
                    ),
                    None => eval_face_energy(
                        &MidEdgeAverage,
                        &model.material,
                        &constants,
                        &s,
                        &rest,
                        None,
                        model.terms,
                    ),
                }
                .total()
            })
            .sum();
        for e in [e0, e1, e2] {
            assert!(
                (e - scalar).abs() <= TOL * scalar,
                "{sff:?}: {e} vs {scalar}"
            );
        }
        let gmax = g2.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let gdiff = g1
            .iter()
            .zip(&g2)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            gdiff <= TOL * gmax,
            "{sff:?}: gradient {gdiff:e} of {gmax:e}"
        );
        assert!(
            (plain - e0).abs() > 1e-6 * e0,
            "{sff:?}: mirrors changed nothing"
        );
    }
}
