//! The `[output]` section: its spec (frame interval and formats) and its validation
//! (`docs/scenes.md`); the run output it configures is written by [`crate::output`].

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

use super::problem::{Check, problem};

/// Output format.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// One OBJ per frame.
    Obj,
    /// VTK `.vtu` per frame plus a `.pvd` index.
    Vtk,
}

/// Output settings.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write a frame every n steps (default 10; the first and last are always written).
    #[serde(default = "default_every")]
    pub every: usize,
    /// Frame formats (default ["obj"]). The per-step CSV and `summary.json` are always written.
    #[serde(default = "default_formats")]
    pub formats: Vec<Format>,
}

fn default_every() -> usize {
    10
}
fn default_formats() -> Vec<Format> {
    vec![Format::Obj]
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            every: default_every(),
            formats: default_formats(),
        }
    }
}

/// Checks `[output]`: a frame interval ≥ 1, each format once.
pub fn validate(o: &OutputSpec) -> Check {
    if o.every == 0 {
        return Err(problem("output.every", "must be ≥ 1"));
    }
    let mut seen = BTreeSet::new();
    for (i, f) in o.formats.iter().enumerate() {
        if !seen.insert(*f) {
            return Err(problem(format!("output.formats[{i}]"), "is listed twice"));
        }
    }
    Ok(())
}
