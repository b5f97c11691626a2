//! A run's output directory as the viewer sees it: the frame list (from `frames.pvd` or the
//! `frame_NNNNNN.obj` files), the mesh connectivity, the colour fields and `steps.csv`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::frame::{self, FrameData};

/// Where a field lives on the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Location {
    /// One value per vertex (interpolated across faces).
    Vertex,
    /// One value per face (flat).
    Face,
}

/// A colour field of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Field {
    /// Key used in URLs and the frame layout (`displacement`, `bend_density`, …).
    pub key: &'static str,
    /// Label shown in the page.
    pub label: &'static str,
    /// Unit shown in the legend.
    pub unit: &'static str,
    /// Vertex or face values.
    pub location: Location,
    /// Signed quantity: coloured with a diverging map symmetric about 0.
    pub signed: bool,
}

/// The per-face arrays a VTK frame may carry (`thinshell::fields` computes them; docs/scenes.md
/// lists them), in the order the page lists them. Curvatures are signed as the frames are:
/// κ = eigenvalues of −a⁻¹b, positive where the surface bends away from its normal.
pub const FACE_FIELDS: [Field; 15] = [
    Field {
        key: "stretch_density",
        label: "stretching energy density",
        unit: "J/m²",
        location: Location::Face,
        signed: false,
    },
    Field {
        key: "bend_density",
        label: "bending energy density",
        unit: "J/m²",
        location: Location::Face,
        signed: false,
    },
    Field {
        key: "stimulus_top",
        label: "stimulus, top surface",
        unit: "stimulus units of the scene",
        location: Location::Face,
        signed: false,
    },
    Field {
        key: "stimulus_bottom",
        label: "stimulus, bottom surface",
        unit: "stimulus units of the scene",
        location: Location::Face,
        signed: false,
    },
    Field {
        key: "contact_gap",
        label: "smallest contact gap (capped at d̂)",
        unit: "m",
        location: Location::Face,
        signed: false,
    },
    Field {
        key: "principal_curvature_1",
        label: "larger principal curvature κ₁ (per face)",
        unit: "1/m",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "principal_curvature_2",
        label: "smaller principal curvature κ₂ (per face)",
        unit: "1/m",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "face_mean_curvature",
        label: "mean curvature (per face)",
        unit: "1/m",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "face_gaussian_curvature",
        label: "Gaussian curvature (per face)",
        unit: "1/m²",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "membrane_strain_1",
        label: "larger principal membrane strain (Green–Lagrange)",
        unit: "1",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "membrane_strain_2",
        label: "smaller principal membrane strain (Green–Lagrange)",
        unit: "1",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "stress_resultant_1",
        label: "larger principal membrane stress resultant",
        unit: "N/m",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "stress_resultant_2",
        label: "smaller principal membrane stress resultant",
        unit: "N/m",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "bending_moment_1",
        label: "larger principal bending moment",
        unit: "N·m/m",
        location: Location::Face,
        signed: true,
    },
    Field {
        key: "bending_moment_2",
        label: "smaller principal bending moment",
        unit: "N·m/m",
        location: Location::Face,
        signed: true,
    },
];

/// The per-vertex arrays a VTK frame may carry, in the order the page lists them.
pub const VERTEX_FIELDS: [Field; 2] = [
    Field {
        key: "mean_curvature",
        label: "mean curvature H (per vertex)",
        unit: "1/m",
        location: Location::Vertex,
        signed: true,
    },
    Field {
        key: "gaussian_curvature",
        label: "Gaussian curvature K (per vertex)",
        unit: "1/m²",
        location: Location::Vertex,
        signed: true,
    },
];

/// The displacement magnitude, a field of every run (VTK point data, or from the positions of
/// OBJ frames).
pub const DISPLACEMENT: Field = Field {
    key: "displacement",
    label: "displacement magnitude",
    unit: "m",
    location: Location::Vertex,
    signed: false,
};

/// One frame of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameEntry {
    /// Step number the frame was written at (0: the initial state).
    pub step: usize,
    /// Simulated time, s.
    pub time: f64,
    /// The frame file.
    #[serde(skip)]
    pub path: PathBuf,
}

/// `steps.csv` by column (read by header name; columns the viewer does not know are kept).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Steps {
    /// Column names in file order.
    pub columns: Vec<String>,
    /// Values per column; a cell that is not a number is `null`.
    pub values: Vec<Vec<Option<f64>>>,
    /// Why the table is missing or partial (shown in the page), if it is.
    pub error: Option<String>,
}

/// A run output directory, loaded for viewing (frames themselves are read on demand).
#[derive(Debug)]
pub struct Run {
    /// The directory.
    pub dir: PathBuf,
    /// The run's name (`summary.json`'s `name`, else the directory name).
    pub name: String,
    /// Frames in step order.
    pub frames: Vec<FrameEntry>,
    /// Triangles (vertex indices) of the first frame; every frame must have the same.
    pub faces: Vec<[u32; 3]>,
    /// Vertices per frame.
    pub n_vertices: usize,
    /// Positions of the first frame, m: the reference for displacements of OBJ frames.
    pub first_positions: Vec<[f64; 3]>,
    /// Colour fields: [`DISPLACEMENT`], then the [`VERTEX_FIELDS`] and [`FACE_FIELDS`] the
    /// first frame has.
    pub fields: Vec<Field>,
    /// `steps.csv`.
    pub steps: Steps,
}

/// Parses `frame_NNNNNN.ext` into the step number.
fn step_of(name: &str, ext: &str) -> Option<usize> {
    name.strip_prefix("frame_")?
        .strip_suffix(ext)?
        .strip_suffix('.')?
        .parse()
        .ok()
}

/// Reads `steps.csv` by header name. A missing file is not an error of the run (the page says
/// so); a malformed one is reported in [`Steps::error`].
pub fn read_steps(path: &Path) -> Steps {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => {
            return Steps {
                error: Some(format!("{}: {e}", path.display())),
                ..Steps::default()
            };
        }
    };
    let mut lines = text.lines();
    let Some(header) = lines.next() else {
        return Steps {
            error: Some(format!("{}: empty file", path.display())),
            ..Steps::default()
        };
    };
    let columns: Vec<String> = header.split(',').map(|c| c.trim().to_string()).collect();
    let mut values = vec![Vec::new(); columns.len()];
    let mut error = None;
    for (k, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != columns.len() {
            // A run killed mid-write leaves a partial last line: keep the rows before it.
            error = Some(format!(
                "{}: line {} has {} cells, the header {}; rows from there on are ignored",
                path.display(),
                k + 2,
                cells.len(),
                columns.len()
            ));
            break;
        }
        for (column, cell) in values.iter_mut().zip(cells) {
            column.push(cell.trim().parse::<f64>().ok().filter(|v| v.is_finite()));
        }
    }
    Steps {
        columns,
        values,
        error,
    }
}

impl Steps {
    /// The column named `name`, if present.
    pub fn column(&self, name: &str) -> Option<&[Option<f64>]> {
        let k = self.columns.iter().position(|c| c == name)?;
        Some(&self.values[k])
    }
}

fn vtu_frames(dir: &Path, pvd: &Path) -> Result<Vec<FrameEntry>, String> {
    let text = std::fs::read_to_string(pvd).map_err(|e| format!("{}: {e}", pvd.display()))?;
    let doc = roxmltree::Document::parse(&text)
        .map_err(|e| format!("{}: not a VTK collection: {e}", pvd.display()))?;
    let mut frames = Vec::new();
    for node in doc.descendants().filter(|n| n.has_tag_name("DataSet")) {
        let bad = |what: &str| format!("{}: a DataSet {what}", pvd.display());
        let file = node.attribute("file").ok_or_else(|| bad("has no file"))?;
        let time: f64 = node
            .attribute("timestep")
            .and_then(|t| t.parse().ok())
            .filter(|t: &f64| t.is_finite())
            .ok_or_else(|| bad("has no finite timestep"))?;
        let step = step_of(file, "vtu")
            .ok_or_else(|| bad(&format!("file {file} is not frame_NNNNNN.vtu")))?;
        frames.push(FrameEntry {
            step,
            time,
            path: dir.join(file),
        });
    }
    Ok(frames)
}

fn obj_frames(dir: &Path, steps: &Steps) -> Result<Vec<FrameEntry>, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut time_of = HashMap::new();
    if let (Some(s), Some(t)) = (steps.column("step"), steps.column("time_s")) {
        for (s, t) in s.iter().zip(t) {
            if let (Some(s), Some(t)) = (s, t) {
                time_of.insert(*s as usize, *t);
            }
        }
    }
    let mut frames = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(step) = name.to_str().and_then(|n| step_of(n, "obj")) else {
            continue;
        };
        // Frame 0 is the initial state (time 0); a step missing from steps.csv has no time.
        let time = if step == 0 {
            0.0
        } else {
            time_of.get(&step).copied().unwrap_or(f64::NAN)
        };
        frames.push(FrameEntry {
            step,
            time,
            path: entry.path(),
        });
    }
    frames.sort_by_key(|f| f.step);
    // Without a time, fall back to the step number so the timeline stays ordered.
    if frames.iter().any(|f| !f.time.is_finite()) {
        for f in &mut frames {
            f.time = f.step as f64;
        }
    }
    Ok(frames)
}

impl Run {
    /// Loads a run output directory: an error (naming what is missing) when it is not one or
    /// its first frame cannot be read.
    pub fn load(dir: &Path) -> Result<Run, String> {
        if !dir.is_dir() {
            return Err(format!("{}: not a directory", dir.display()));
        }
        let steps_path = dir.join("steps.csv");
        let pvd = dir.join("frames.pvd");
        let steps = read_steps(&steps_path);
        let frames = if pvd.is_file() {
            vtu_frames(dir, &pvd)?
        } else {
            obj_frames(dir, &steps)?
        };
        if frames.is_empty() {
            return Err(format!(
                "{}: not a thinshell run output (no frames.pvd and no frame_NNNNNN.obj{}); \
                 run a scene with `thinshell run SCENE --out DIR` and [output] formats = [\"vtk\"] or [\"obj\"]",
                dir.display(),
                if steps_path.is_file() {
                    "; steps.csv is there but the run wrote no frames"
                } else {
                    ", no steps.csv"
                }
            ));
        }
        let name = std::fs::read_to_string(dir.join("summary.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .and_then(|v| v.get("name")?.as_str().map(str::to_string))
            .unwrap_or_else(|| {
                dir.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_else(|| dir.display().to_string())
            });
        let first = frame::read(&frames[0].path)
            .map_err(|e| format!("{}: the first frame cannot be read: {e}", dir.display()))?;
        let n_vertices = first.positions.len();
        let faces = first.faces.clone();
        let mut fields = vec![DISPLACEMENT];
        fields.extend(
            VERTEX_FIELDS
                .iter()
                .filter(|f| first.vertex_fields.iter().any(|(k, _)| k == f.key))
                .cloned(),
        );
        fields.extend(
            FACE_FIELDS
                .iter()
                .filter(|f| first.face_fields.iter().any(|(k, _)| k == f.key))
                .cloned(),
        );
        Ok(Run {
            dir: dir.to_path_buf(),
            name,
            first_positions: first.positions,
            frames,
            faces,
            n_vertices,
            fields,
            steps,
        })
    }

    /// Frame `i` encoded for the page: little-endian f32, the positions (3 per vertex, m), then
    /// every field of [`Run::fields`] in order (one per vertex or per face). A frame that is
    /// missing, malformed or does not match the first frame's mesh is an error naming it.
    pub fn frame_bytes(&self, i: usize) -> Result<Vec<u8>, String> {
        let entry = self.frames.get(i).ok_or_else(|| {
            format!(
                "frame {i} does not exist (the run has {})",
                self.frames.len()
            )
        })?;
        let what = |e: String| {
            format!(
                "frame {i} (step {}, {}): {e}",
                entry.step,
                entry.path.display()
            )
        };
        let data = frame::read(&entry.path).map_err(what)?;
        self.encode(&data).map_err(what)
    }

    fn encode(&self, data: &FrameData) -> Result<Vec<u8>, String> {
        if data.positions.len() != self.n_vertices {
            return Err(format!(
                "{} vertices, the first frame has {}",
                data.positions.len(),
                self.n_vertices
            ));
        }
        if data.faces != self.faces {
            return Err("its triangles differ from the first frame's".into());
        }
        let mut out: Vec<f32> = Vec::with_capacity(3 * self.n_vertices + 4 * self.faces.len());
        out.extend(data.positions.iter().flat_map(|p| p.map(|c| c as f32)));
        for field in &self.fields {
            match field.key {
                "displacement" => {
                    match &data.displacement {
                        Some(d) => out.extend(d.iter().map(|u| norm(*u) as f32)),
                        None => out.extend(data.positions.iter().zip(&self.first_positions).map(
                            |(x, x0)| norm([x[0] - x0[0], x[1] - x0[1], x[2] - x0[2]]) as f32,
                        )),
                    }
                }
                key => {
                    let (arrays, what) = match field.location {
                        Location::Vertex => (&data.vertex_fields, "point"),
                        Location::Face => (&data.face_fields, "cell"),
                    };
                    let values = arrays
                        .iter()
                        .find(|(k, _)| k == key)
                        .map(|(_, v)| v)
                        .ok_or_else(|| {
                            format!("{what} array {key} is missing (the first frame has it)")
                        })?;
                    out.extend(values.iter().map(|&v| v as f32));
                }
            }
        }
        Ok(out.iter().flat_map(|v| v.to_le_bytes()).collect())
    }

    /// The connectivity for the page: little-endian u32, 3 per face.
    pub fn mesh_bytes(&self) -> Vec<u8> {
        self.faces
            .iter()
            .flat_map(|f| f.iter().flat_map(|v| v.to_le_bytes()))
            .collect()
    }

    /// What the page needs to know about the run before any frame (JSON).
    pub fn meta(&self) -> serde_json::Value {
        serde_json::json!({
            "name": self.name,
            "dir": self.dir.display().to_string(),
            "n_vertices": self.n_vertices,
            "n_faces": self.faces.len(),
            "frames": self.frames,
            "fields": self.fields,
        })
    }
}

fn norm(u: [f64; 3]) -> f64 {
    (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt()
}
