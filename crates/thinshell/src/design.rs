//! Inverse design from a scene (`thinshell-design`, docs/design.md): the one entry point of
//! `thinshell design` and Python's `thinshell.design`. [`design_command`] finds the rest forms
//! (growth pattern) whose static equilibrium takes a target's shape and writes DIR/scene.toml
//! (the input scene with `[rest] from = "file"` and the designed forms in DIR/rest_forms.csv:
//! `thinshell run DIR/scene.toml` reproduces the shape), DIR/design.json, DIR/achieved.obj and
//! DIR/history.csv. [`Simulation::adjoint_gradient`] differentiates any objective of a static
//! equilibrium in its rest forms.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::scene::integrator::IntegratorKind;
use crate::scene::schema::Effect;
use crate::{Failure, Scene, Simulation};
use nalgebra::Vector3;
use thinshell_design::{
    BilayerGrowth, ClosestPoint, Design, DesignResult, DesignSettings, Forward, Isotropic, Outcome,
    Parametrisation, RestForms, ShapeObjective, Support, TargetPositions, algebraic,
};
use thinshell_mesh::Mesh;
use thinshell_solver::Static;

/// Options of `thinshell design`.
#[derive(Clone, Debug)]
pub struct DesignOptions {
    /// `isotropic` (per vertex), `isotropic_face`, `rest_forms` or `bilayer`.
    pub parametrisation: String,
    /// Stop when the rms distance is at most this fraction of the target's size.
    pub tolerance: f64,
    /// Weight of the Laplacian smoothness term.
    pub smoothness: f64,
    /// Growth factor bounds (min, max) for `isotropic` and `bilayer`.
    pub growth_bounds: Option<(f64, f64)>,
}

/// The parametrisation names `--parametrisation` accepts.
pub const PARAMETRISATIONS: [&str; 4] = ["isotropic", "isotropic_face", "rest_forms", "bilayer"];

fn bad(e: impl std::fmt::Display) -> Failure {
    Failure::BadInput(e.to_string())
}

/// Runs the design of the scene at `scene_path` for the target OBJ `target_path` and writes its
/// outputs into `out`; returns the result (its `outcome` says whether the target was reached;
/// the outputs are written either way). Bad input (scene, target, parametrisation, a scene
/// that is not static or has growth) is [`Failure::BadInput`].
pub fn design_command(
    scene_path: &Path,
    target_path: &Path,
    out: &Path,
    overrides: &[String],
    options: &DesignOptions,
) -> Result<DesignResult, Failure> {
    let scene = Scene::load_with_overrides(scene_path, overrides).map_err(bad)?;
    let sim = Simulation::build(&scene).map_err(bad)?;
    if sim.integrator() != IntegratorKind::Static {
        return Err(bad(
            "design needs a static scene (integrator.kind = \"static\"): it designs equilibria",
        ));
    }
    if sim.effects().contains(&Effect::Growth) {
        return Err(bad(
            "design sets the rest forms itself: remove the `growth` effect from the scene",
        ));
    }
    let target = thinshell_mesh::io::load_obj(target_path)
        .map_err(|e| bad(format!("{}: {e}", target_path.display())))?;
    let (system, start) = sim.into_system();
    let mesh = system.mesh().clone();
    let base = system.rest().clone();
    let model = *system.model();
    let same = same_connectivity(&mesh, &target);
    let param: Box<dyn Parametrisation> = match options.parametrisation.as_str() {
        "isotropic" | "isotropic_face" => {
            let support = if options.parametrisation == "isotropic" {
                Support::Vertex
            } else {
                Support::Face
            };
            let p = Isotropic::new(&mesh, &base, support);
            Box::new(match options.growth_bounds {
                Some((lo, hi)) => p.with_bounds(lo, hi),
                None => p,
            })
        }
        "rest_forms" => Box::new(RestForms::new(&base)),
        "bilayer" => {
            let p = BilayerGrowth::new(&base, &model.material);
            Box::new(match options.growth_bounds {
                Some((lo, hi)) => p.with_bounds(lo, hi),
                None => p,
            })
        }
        other => {
            return Err(bad(format!(
                "unknown parametrisation `{other}`; one of {}",
                PARAMETRISATIONS.join(", ")
            )));
        }
    };
    // Same connectivity: distance per vertex modulo rigid motion, from the algebraic start;
    // otherwise the closest point of the target, from no growth.
    let (objective, start_p): (Box<dyn ShapeObjective>, Vec<f64>) = if same {
        let forms = algebraic::target_forms(&mesh, target.positions(), model.sff).map_err(bad)?;
        let p = param.fit_forms(&forms);
        let objective = TargetPositions {
            target: target.positions().to_vec(),
            rigid: true,
        };
        (Box::new(objective), p)
    } else {
        (Box::new(ClosestPoint::new(&target)), param.initial())
    };
    let forward = Forward::new(system, start).map_err(bad)?;
    let mut design = Design::new(forward, param, objective);
    let settings = DesignSettings {
        tolerance: options.tolerance,
        smoothness: options.smoothness,
        ..DesignSettings::default()
    };
    let result = design.optimise(&start_p, &settings);
    std::fs::create_dir_all(out).map_err(|e| bad(format!("{}: {e}", out.display())))?;
    write_outputs(&scene, scene_path, out, &mesh, &design, &result, same)?;
    Ok(result)
}

impl Simulation {
    /// The gradient of an objective J of the current state in the rest forms, by the adjoint:
    /// `dj_dx` is ∂J/∂x (one per vertex, m⁻¹ × J's unit); returns per face dJ/dm̄ with
    /// m̄ = (ā11, ā12, ā22, b̄11, b̄12, b̄22) (face barycentric basis, the 12 entry moving both
    /// off-diagonal entries). The state must be a static equilibrium of the current rest forms
    /// (e.g. after a static step); errors when it is not a strict minimum, when rigid motions
    /// are free, or on a length mismatch.
    pub fn adjoint_gradient(&mut self, dj_dx: &[Vector3<f64>]) -> Result<Vec<[f64; 6]>, Failure> {
        let n = self.system.mesh().n_vertices();
        if dj_dx.len() != n {
            return Err(bad(format!(
                "dj_dx has {} rows, the mesh {n} vertices",
                dj_dx.len()
            )));
        }
        let mut rhs = vec![0.0; 3 * n + self.system.n_edge_angles()];
        for (v, g) in dj_dx.iter().enumerate() {
            rhs[3 * v..3 * v + 3].copy_from_slice(g.as_slice());
        }
        let (x, phi) = (self.state.x.clone(), self.state.phi.clone());
        let lambda = self
            .system
            .solve_adjoint(&mut Static::default(), &x, &phi, &rhs)
            .map_err(|e| Failure::Simulation(e.to_string()))?
            .ok_or_else(|| {
                Failure::Simulation(
                    "the state is not a strict minimum (its exact Hessian is not positive \
                     definite): no adjoint gradient"
                        .into(),
                )
            })?;
        let w = self
            .system
            .rest_adjoint_product(&x, &phi, &lambda)
            .map_err(|e| Failure::Simulation(e.to_string()))?;
        Ok(w.into_iter().map(|wf| wf.map(|v| -v)).collect())
    }
}

fn same_connectivity(mesh: &Mesh, target: &Mesh) -> bool {
    mesh.n_vertices() == target.n_vertices() && mesh.faces() == target.faces()
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> Failure + '_ {
    move |e| Failure::Simulation(format!("{}: {e}", path.display()))
}

fn write_outputs(
    scene: &Scene,
    scene_path: &Path,
    out: &Path,
    mesh: &Mesh,
    design: &Design,
    result: &DesignResult,
    same: bool,
) -> Result<(), Failure> {
    // Rest forms per face.
    let mut csv = String::from("a11,a12,a22,b11,b12,b22\n");
    for (a, b) in result.rest.a_bar.iter().zip(&result.rest.b_bar) {
        let _ = writeln!(
            csv,
            "{:e},{:e},{:e},{:e},{:e},{:e}",
            a[(0, 0)],
            a[(0, 1)],
            a[(1, 1)],
            b[(0, 0)],
            b[(0, 1)],
            b[(1, 1)]
        );
    }
    let path = out.join("rest_forms.csv");
    std::fs::write(&path, csv).map_err(io(&path))?;
    // The input scene with the designed rest forms; relative paths made absolute.
    let text = std::fs::read_to_string(scene_path).map_err(io(scene_path))?;
    let mut doc: toml::Table = toml::from_str(&text).map_err(bad)?;
    let mut rest = toml::Table::new();
    rest.insert("from".into(), "file".into());
    rest.insert("file".into(), "rest_forms.csv".into());
    doc.insert("rest".into(), toml::Value::Table(rest));
    if let Some(obj) = doc
        .get_mut("mesh")
        .and_then(|m| m.as_table_mut())
        .and_then(|m| m.get_mut("obj"))
    {
        if let Some(rel) = obj.as_str() {
            let abs: PathBuf = std::fs::canonicalize(scene.base_dir.join(rel))
                .unwrap_or_else(|_| scene.base_dir.join(rel));
            *obj = abs.display().to_string().into();
        }
    }
    let path = out.join("scene.toml");
    let header = format!(
        "# Designed by `thinshell design` from {} ({}): rest forms in rest_forms.csv.\n",
        scene_path.display(),
        design.parametrisation().name()
    );
    std::fs::write(&path, header + &toml::to_string(&doc).map_err(bad)?).map_err(io(&path))?;
    // Achieved shape.
    let path = out.join("achieved.obj");
    thinshell_mesh::io::save_obj(&path, mesh, &result.equilibrium.x)
        .map_err(|e| Failure::Simulation(format!("{}: {e}", path.display())))?;
    // History.
    let mut h = String::from(
        "evaluation,objective,rms_distance,projected_gradient,forward_iterations,stable\n",
    );
    for r in &result.history {
        let _ = writeln!(
            h,
            "{},{:e},{:e},{:e},{},{}",
            r.evaluation,
            r.objective,
            r.rms_distance,
            r.projected_gradient,
            r.forward_iterations,
            r.stable
        );
    }
    let path = out.join("history.csv");
    std::fs::write(&path, h).map_err(io(&path))?;
    // design.json: parameters with where they sit.
    let (support, per) = design.parametrisation().layout();
    let x = mesh.positions();
    let sites: Vec<Vector3<f64>> = match support {
        Support::Vertex => x.to_vec(),
        Support::Face => mesh
            .faces()
            .iter()
            .map(|f| (x[f[0].idx()] + x[f[1].idx()] + x[f[2].idx()]) / 3.0)
            .collect(),
    };
    let items: Vec<serde_json::Value> = sites
        .iter()
        .enumerate()
        .map(|(i, p)| {
            serde_json::json!({
                "position": [p.x, p.y, p.z],
                "parameters": &result.parameters[per * i..per * (i + 1)],
            })
        })
        .collect();
    let json = serde_json::json!({
        "parametrisation": design.parametrisation().name(),
        "support": match support { Support::Vertex => "vertex", Support::Face => "face" },
        "objective": if same { "target positions modulo rigid motion" } else { "closest point on the target" },
        "final_objective": result.objective,
        "rms_distance": result.rms_distance,
        "target_size": result.target_size,
        "parameters_at_bounds": result.at_bounds,
        "converged": result.outcome == Outcome::Reached,
        "outcome": format!("{:?}", result.outcome),
        "message": result.message,
        "forward_solves": result.history.len(),
        "items": items,
    });
    let path = out.join("design.json");
    let text = serde_json::to_string_pretty(&json).map_err(bad)?;
    std::fs::write(&path, text).map_err(io(&path))?;
    Ok(())
}

/// Parses `MIN,MAX` growth factor bounds (0 < MIN ≤ 1 ≤ MAX).
pub fn parse_bounds(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(',')
        .ok_or_else(|| format!("`{s}`: expected MIN,MAX"))?;
    let parse = |t: &str| t.trim().parse::<f64>().map_err(|e| format!("`{t}`: {e}"));
    let (lo, hi) = (parse(a)?, parse(b)?);
    if !(lo > 0.0 && lo <= 1.0 && hi >= 1.0 && hi.is_finite()) {
        return Err(format!("growth bounds {lo},{hi}: need 0 < MIN <= 1 <= MAX"));
    }
    Ok((lo, hi))
}
