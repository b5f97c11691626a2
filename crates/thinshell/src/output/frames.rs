//! The frame files of a run: `frame_NNNNNN.obj` and/or `frame_NNNNNN.vtu` with the index
//! `frames.pvd` ([`crate::vtk`]), one per written frame. What a VTK frame holds besides the
//! positions comes from [`crate::fields`]; this module only writes it and counts frames.

use std::path::{Path, PathBuf};

use crate::fields::{FieldEvaluator, FrameFields};
use crate::scene::schema::{Format, OutputSpec};
use crate::sim::Simulation;

/// The frame files of one output directory.
pub(super) struct Frames {
    dir: PathBuf,
    obj: bool,
    vtk: Option<crate::vtk::Series>,
    fields: FieldEvaluator,
    /// Frames counted so far (across resumes).
    count: usize,
    /// The step of the last frame counted, so that rewriting it (the failure path writes the
    /// last good state, which may already be a frame) does not count it twice.
    last: Option<usize>,
}

impl Frames {
    /// The frames `output` asks for in `dir`, continuing `count` frames (the last at step
    /// `last`) and the `.pvd` list `pvd` (time as f64 bits, file) of a resumed run.
    pub(super) fn new(
        dir: &Path,
        output: &OutputSpec,
        count: usize,
        last: Option<usize>,
        pvd: &[(u64, String)],
    ) -> Frames {
        let vtk = output.formats.contains(&Format::Vtk).then(|| {
            let mut s = crate::vtk::Series::new(dir, "frames");
            s.set_entries(
                pvd.iter()
                    .map(|(t, f)| (f64::from_bits(*t), f.clone()))
                    .collect(),
            );
            s
        });
        Frames {
            dir: dir.to_path_buf(),
            obj: output.formats.contains(&Format::Obj),
            vtk,
            fields: FieldEvaluator::new(),
            count,
            last,
        }
    }

    /// Also writes OBJ frames from now on (the last good state of a failed run is always
    /// written as one, for inspection).
    pub(super) fn add_obj(&mut self) {
        self.obj = true;
    }

    /// Frames written so far.
    pub(super) fn count(&self) -> usize {
        self.count
    }

    /// The step of the last frame.
    pub(super) fn last(&self) -> Option<usize> {
        self.last
    }

    /// The `.pvd` list: time (f64 bits, so that it round-trips exactly) and file.
    pub(super) fn pvd(&self) -> Vec<(u64, String)> {
        self.vtk
            .as_ref()
            .map(|s| {
                s.entries()
                    .iter()
                    .map(|(t, f)| (t.to_bits(), f.clone()))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Writes the frame of `sim`'s current state. Returns why some of its fields are missing
    /// (written without them), if so; errors when a file cannot be written.
    pub(super) fn write(&mut self, sim: &Simulation) -> Result<Option<String>, String> {
        let step = sim.steps_done();
        if self.obj {
            let path = self.dir.join(format!("frame_{step:06}.obj"));
            let mut text = Vec::new();
            thinshell_mesh::io::write_obj(sim.mesh(), sim.positions(), &mut text)
                .map_err(|e| e.to_string())
                .and_then(|_| crate::atomic::write_atomic(&path, &text).map_err(|e| e.to_string()))
                .map_err(|e| format!("{}: {e}", path.display()))?;
        }
        let mut missing = None;
        if let Some(series) = &mut self.vtk {
            let FrameFields {
                point_vectors,
                point_scalars,
                cell_scalars,
                cell_vectors,
                missing: m,
            } = self.fields.evaluate(sim);
            missing = m;
            let frame = crate::vtk::Frame {
                mesh: sim.mesh(),
                points: sim.positions(),
                point_vectors: point_vectors
                    .iter()
                    .map(|(name, v)| (*name, v.as_slice()))
                    .collect(),
                cell_scalars,
                point_scalars: point_scalars
                    .iter()
                    .map(|(name, v)| (*name, v.as_slice()))
                    .collect(),
                cell_vectors: cell_vectors
                    .iter()
                    .map(|(name, v)| (*name, v.as_slice()))
                    .collect(),
            };
            series
                .write(&format!("frame_{step:06}.vtu"), sim.time(), &frame)
                .map_err(|e| e.to_string())?;
        }
        if (self.obj || self.vtk.is_some()) && self.last != Some(step) {
            self.count += 1;
            self.last = Some(step);
        }
        Ok(missing)
    }
}
