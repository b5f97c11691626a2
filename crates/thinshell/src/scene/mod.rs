//! Scene files: load, apply `--set` overrides, validate.
//!
//! The format is documented in `docs/scenes.md`. Loading never panics: syntax errors, unknown
//! keys, wrong types and invalid values all come back as a [`SceneError`] whose message names the
//! file, the line and column, and the key.
//!
//! ```
//! use thinshell::scene::Scene;
//! let text = r#"
//!     effects = ["stretching", "bending"]
//!     [mesh]
//!     generator = "seed_square"
//!     [integrator]
//!     kind = "static"
//! "#;
//! let scene = Scene::from_toml(text, "example.toml", std::path::Path::new(".")).unwrap();
//! assert_eq!(scene.file.material.young(), 2e9); // paper by default
//! ```

pub mod bending;
pub mod boundary;
pub mod contact;
pub mod effects;
pub mod growth;
pub mod initial;
pub mod integrator;
pub mod loads;
pub mod material;
pub mod mesh;
pub mod output;
pub mod path;
mod problem;
pub mod region;
pub mod rest;
pub mod schema;
pub mod validate;

use std::path::{Path, PathBuf};

use toml::de::{DeTable, DeValue};

pub use schema::SceneFile;
pub use validate::Problem;

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read scene file: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// TOML syntax error, unknown key or wrong type.
    #[error("{origin}:{line}:{column}: {message}")]
    Syntax {
        /// File name (or description of the source).
        origin: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// A value out of range or contradicting another.
    #[error("{origin}:{line}:{column}: `{key}` {message}")]
    Invalid {
        /// File name (or description of the source).
        origin: String,
        /// Dotted key path.
        key: String,
        /// 1-based line of the key (or of the nearest enclosing table found).
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A `--set key=value` override that cannot be applied.
    #[error("--set {assignment}: {message}")]
    Override {
        /// The assignment as given.
        assignment: String,
        /// What is wrong.
        message: String,
    },
}

/// A parsed and validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene's content.
    pub file: SceneFile,
    /// Directory that relative paths in the scene are resolved against.
    pub base_dir: PathBuf,
    /// Where it came from (file path or a description), for messages.
    pub origin: String,
    /// The text as written and the `--set` assignments applied to it: what error messages
    /// found after loading point into (see [`Scene::key_location`]).
    source: Source,
}

/// A scene's text before overrides, and the overrides.
#[derive(Clone, Debug, Default)]
struct Source {
    text: String,
    overrides: Vec<String>,
}

impl Scene {
    /// Reads, parses and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Self::load_with_overrides(path, &[])
    }

    /// Reads a scene file, applies `key=value` overrides (TOML values, dotted keys) and validates.
    pub fn load_with_overrides(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let origin = path.display().to_string();
        Self::from_toml_with_overrides(&text, &origin, &base, overrides)
    }

    /// [`Scene::from_toml`] after applying `key=value` overrides to the text. A problem with a
    /// value that an override set (an unknown key, a wrong type, a value out of range) is
    /// reported as [`SceneError::Override`] naming the `--set` argument; any other problem
    /// points at its line in the text as written.
    pub fn from_toml_with_overrides(
        text: &str,
        origin: &str,
        base_dir: &Path,
        overrides: &[String],
    ) -> Result<Scene, SceneError> {
        if overrides.is_empty() {
            return Self::from_toml(text, origin, base_dir);
        }
        let edited = apply_overrides(text, origin, overrides)?;
        let source = Source {
            text: text.to_string(),
            overrides: overrides.to_vec(),
        };
        let (key, failure) = match parse(&edited) {
            Ok(file) => {
                return Ok(Scene {
                    file,
                    base_dir: base_dir.to_path_buf(),
                    origin: origin.to_string(),
                    source,
                });
            }
            Err(Failure::Syntax(e)) => {
                let key = e
                    .span()
                    .and_then(|s| key_at(&edited, s.start))
                    .unwrap_or_default();
                (key, Failure::Syntax(e))
            }
            Err(Failure::Invalid(p)) => (p.key.clone(), Failure::Invalid(p)),
        };
        Err(source.error(origin, &key, failure))
    }

    /// Parses and validates scene text; `origin` names it in messages, `base_dir` resolves paths.
    pub fn from_toml(text: &str, origin: &str, base_dir: &Path) -> Result<Scene, SceneError> {
        let file = parse(text).map_err(|f| match f {
            Failure::Syntax(e) => syntax(text, origin, &e),
            Failure::Invalid(p) => invalid(text, origin, p),
        })?;
        Ok(Scene {
            file,
            base_dir: base_dir.to_path_buf(),
            origin: origin.to_string(),
            source: Source {
                text: text.to_string(),
                overrides: Vec::new(),
            },
        })
    }

    /// Where the value of a dotted key came from, for messages about it found after loading
    /// (a mesh file that cannot be read, a vertex index beyond the mesh): `"--set KEY=VALUE"`
    /// when an override set it, else `"ORIGIN:LINE:COLUMN"` of the key in the text (of its
    /// nearest enclosing table when the key is not written).
    pub fn key_location(&self, key: &str) -> String {
        match self.source.override_for(key) {
            Some(a) => format!("--set {a}"),
            None => {
                let (line, column) = locate(&self.source.text, key)
                    .map_or((1, 1), |o| line_col(&self.source.text, o));
                format!("{}:{line}:{column}", self.origin)
            }
        }
    }

    /// The text of the scene as written, before any `--set` override.
    pub fn text(&self) -> &str {
        &self.source.text
    }

    /// The `--set` overrides applied to [`Scene::text`].
    pub fn overrides(&self) -> &[String] {
        &self.source.overrides
    }

    /// The scene's name: `name` if given, else the file stem of `origin`.
    pub fn name(&self) -> String {
        self.file.name.clone().unwrap_or_else(|| {
            Path::new(&self.origin)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scene".to_string())
        })
    }

    /// Turns a problem found after loading (e.g. a vertex index out of range once the mesh is
    /// known) into an error that points at the key's line, or at the `--set` that gave it.
    pub fn problem(&self, key: &str, message: impl Into<String>) -> SceneError {
        let p = Problem {
            key: key.to_string(),
            message: message.into(),
        };
        self.source.error(&self.origin, key, Failure::Invalid(p))
    }
}

/// Why scene text was refused: by the parser (syntax, unknown key, wrong type) or by validation.
enum Failure {
    Syntax(toml::de::Error),
    Invalid(Problem),
}

fn parse(text: &str) -> Result<SceneFile, Failure> {
    let file: SceneFile = toml::from_str(text).map_err(Failure::Syntax)?;
    validate::validate(&file).map_err(Failure::Invalid)?;
    Ok(file)
}

impl Source {
    /// The last override that set `key`, a value inside it, or a table containing it that the
    /// text as written does not have.
    fn override_for(&self, key: &str) -> Option<&str> {
        self.overrides.iter().rev().find_map(|a| {
            let set = a.split_once('=')?.0.split('.').map(str::trim);
            let set: Vec<&str> = set.collect();
            let set = set.join(".");
            let inside = key == set
                || key
                    .strip_prefix(set.as_str())
                    .is_some_and(|r| r.starts_with(['.', '[']));
            // An error at a table the override created (e.g. a missing field of it).
            let creates = set.strip_prefix(key).is_some_and(|r| r.starts_with('.'))
                && !exists(&self.text, key);
            (inside || creates).then_some(a.as_str())
        })
    }

    /// A problem at `key`: blamed on the override that set it, else at the key's line in the
    /// text as written.
    fn error(&self, origin: &str, key: &str, failure: Failure) -> SceneError {
        let message = match &failure {
            Failure::Syntax(e) => e.message().trim().to_string(),
            Failure::Invalid(p) => format!("`{}` {}", p.key, p.message),
        };
        if let Some(a) = self.override_for(key) {
            return SceneError::Override {
                assignment: a.to_string(),
                message,
            };
        }
        match failure {
            Failure::Invalid(p) => invalid(&self.text, origin, p),
            Failure::Syntax(e) => {
                let (line, column) =
                    locate(&self.text, key).map_or((1, 1), |o| line_col(&self.text, o));
                SceneError::Syntax {
                    origin: origin.to_string(),
                    line,
                    column,
                    message: e.message().trim().to_string(),
                }
            }
        }
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

fn syntax(text: &str, origin: &str, e: &toml::de::Error) -> SceneError {
    let (line, column) = e.span().map_or((0, 0), |s| line_col(text, s.start));
    SceneError::Syntax {
        origin: origin.to_string(),
        line,
        column,
        message: e.message().trim().to_string(),
    }
}

fn invalid(text: &str, origin: &str, p: Problem) -> SceneError {
    // A key missing from the text altogether (e.g. a section an effect needs) points at the
    // start of the file, as the parser's own "missing field" errors do, rather than at 0:0.
    let (line, column) = locate(text, &p.key).map_or((1, 1), |o| line_col(text, o));
    SceneError::Invalid {
        origin: origin.to_string(),
        key: p.key,
        line,
        column,
        message: p.message,
    }
}

/// Splits `a.b[2].c` into segments `a`, `b`, `[2]`, `c`.
fn key_segments(key: &str) -> Vec<Segment<'_>> {
    let mut out = Vec::new();
    for part in key.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if !name.is_empty() {
            out.push(Segment::Key(name));
        }
        while let Some(end) = rest.find(']') {
            if let Ok(i) = rest[1..end].parse() {
                out.push(Segment::Index(i));
            }
            rest = &rest[end + 1..];
        }
    }
    out
}

enum Segment<'a> {
    Key(&'a str),
    Index(usize),
}

/// Byte offset of the deepest existing part of a dotted key path in the TOML text.
fn locate(text: &str, key: &str) -> Option<usize> {
    walk(text, key).map(|(offset, _)| offset)
}

/// Whether the whole dotted key path is written in the TOML text.
fn exists(text: &str, key: &str) -> bool {
    walk(text, key).is_some_and(|(_, complete)| complete)
}

/// The offset of the deepest existing part of `key`, and whether that is all of it.
fn walk(text: &str, key: &str) -> Option<(usize, bool)> {
    let doc = DeTable::parse(text).ok()?;
    let mut best: Option<usize> = None;
    let mut table: Option<&DeTable<'_>> = Some(doc.get_ref());
    let mut array: Option<&[toml::Spanned<DeValue<'_>>]> = None;
    let segments = key_segments(key);
    let mut matched = 0;
    for seg in &segments {
        let found = match *seg {
            Segment::Key(k) => table
                .and_then(|t| t.iter().find(|(name, _)| name.get_ref() == k))
                .map(|(kspan, v)| (kspan.span().start, v)),
            Segment::Index(i) => array.and_then(|a| a.get(i)).map(|v| (v.span().start, v)),
        };
        let Some((offset, value)) = found else { break };
        best = Some(offset);
        matched += 1;
        table = None;
        array = None;
        match value.get_ref() {
            DeValue::Table(t) => table = Some(t),
            DeValue::Array(a) => array = Some(&a[..]),
            _ => {}
        }
    }
    best.map(|b| (b, matched == segments.len()))
}

/// The dotted key path (`a.b[2].c`) of the key or value at byte `offset` of the TOML text: the
/// deepest key whose name or (non-table) value spans the offset.
fn key_at(text: &str, offset: usize) -> Option<String> {
    fn value_path(v: &toml::Spanned<DeValue<'_>>, offset: usize, path: &str) -> Option<String> {
        match v.get_ref() {
            DeValue::Table(t) => table_path(t, offset, path),
            DeValue::Array(a) => a.iter().enumerate().find_map(|(i, e)| {
                let p = format!("{path}[{i}]");
                value_path(e, offset, &p).or_else(|| e.span().contains(&offset).then_some(p))
            }),
            _ => None,
        }
    }
    fn table_path(t: &DeTable<'_>, offset: usize, path: &str) -> Option<String> {
        t.iter().find_map(|(k, v)| {
            let p = if path.is_empty() {
                k.get_ref().to_string()
            } else {
                format!("{path}.{}", k.get_ref())
            };
            value_path(v, offset, &p).or_else(|| {
                let here = k.span().contains(&offset)
                    || (!matches!(v.get_ref(), DeValue::Table(_)) && v.span().contains(&offset));
                here.then_some(p)
            })
        })
    }
    let doc = DeTable::parse(text).ok()?;
    table_path(doc.get_ref(), offset, "")
}

/// Applies `key=value` assignments (TOML syntax for the value; a bare word is taken as a string).
fn apply_overrides(text: &str, origin: &str, overrides: &[String]) -> Result<String, SceneError> {
    let mut doc: toml::Table = toml::from_str(text).map_err(|e| syntax(text, origin, &e))?;
    for a in overrides {
        let err = |message: &str| SceneError::Override {
            assignment: a.clone(),
            message: message.to_string(),
        };
        let (key, raw) = a.split_once('=').ok_or_else(|| err("expected key=value"))?;
        let key = key.trim();
        if key.is_empty() || key.split('.').any(|k| k.trim().is_empty()) {
            return Err(err("empty key"));
        }
        let value: toml::Value = match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
            Ok(mut t) => t.remove("v").ok_or_else(|| err("no value"))?,
            Err(_) => toml::Value::String(raw.trim().to_string()),
        };
        let parts: Vec<&str> = key.split('.').map(str::trim).collect();
        let (last, parents) = parts.split_last().ok_or_else(|| err("empty key"))?;
        let mut table = &mut doc;
        for p in parents {
            let entry = table
                .entry(p.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            table = entry
                .as_table_mut()
                .ok_or_else(|| err(&format!("`{p}` is not a table")))?;
        }
        table.insert(last.to_string(), value);
    }
    toml::to_string(&doc).map_err(|e| SceneError::Override {
        assignment: overrides.join(" "),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_paths_resolve_to_line_and_column() {
        let text = "effects = [\"bending\"]\n[integrator]\nkind = \"static\"\n\n[[boundary.pins]]\nregion = { vertices = [1] }\naxes = \"xq\"\n";
        let off = locate(text, "boundary.pins[0].axes").map(|o| line_col(text, o));
        assert_eq!(off, Some((7, 1)));
        let off = locate(text, "integrator.kind").map(|o| line_col(text, o));
        assert_eq!(off, Some((3, 1)));
        // Missing leaf: the deepest existing parent.
        let off = locate(text, "integrator.dt").map(|o| line_col(text, o));
        assert_eq!(off, Some((2, 2)));
    }
}
