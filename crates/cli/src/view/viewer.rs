//! The viewer's state and answers: the loaded runs, a cache of encoded frames, and the
//! response to each request of the page (served by `server`, embedded by `html`).

use std::collections::VecDeque;
use std::path::Path;
use std::sync::{Arc, Mutex};

use super::run::Run;

/// The page template; `/*__VIEWER_JS__*/` is replaced by the script and `__DATA__` by the
/// embedded data (empty when served).
pub const PAGE: &str = include_str!("assets/index.html");
/// The viewer script.
pub const SCRIPT: &str = include_str!("assets/viewer.js");

/// An HTTP answer.
#[derive(Clone, Debug, PartialEq)]
pub struct Response {
    /// Status code (200, 404, 422, 405).
    pub status: u16,
    /// MIME type.
    pub content_type: &'static str,
    /// Body.
    pub body: Arc<Vec<u8>>,
}

impl Response {
    fn json(status: u16, value: &serde_json::Value) -> Response {
        Response {
            status,
            content_type: "application/json",
            body: Arc::new(value.to_string().into_bytes()),
        }
    }

    pub(super) fn error(status: u16, message: String) -> Response {
        Response::json(status, &serde_json::json!({ "error": message }))
    }

    fn binary(body: Arc<Vec<u8>>) -> Response {
        Response {
            status: 200,
            content_type: "application/octet-stream",
            body,
        }
    }
}

/// Encoded frames kept in memory, so that replaying a window of frames does not parse them
/// again (oldest dropped first).
const CACHE_FRAMES: usize = 64;

/// An encoded frame keyed by (run, frame).
type CachedFrame = ((usize, usize), Arc<Vec<u8>>);

/// The runs being viewed.
pub struct Viewer {
    runs: Vec<Run>,
    cache: Mutex<VecDeque<CachedFrame>>,
}

impl Viewer {
    /// Loads the run directories; the error names the directory and what is wrong.
    pub fn load(dirs: &[&Path]) -> Result<Viewer, String> {
        if dirs.is_empty() || dirs.len() > 2 {
            return Err(format!("view shows one or two runs, got {}", dirs.len()));
        }
        let runs = dirs
            .iter()
            .map(|d| Run::load(d))
            .collect::<Result<_, _>>()?;
        Ok(Viewer {
            runs,
            cache: Mutex::new(VecDeque::new()),
        })
    }

    /// The loaded runs.
    pub fn runs(&self) -> &[Run] {
        &self.runs
    }

    /// The page as served: the script inlined, no embedded data.
    pub fn page() -> String {
        PAGE.replacen("/*__VIEWER_JS__*/", SCRIPT, 1)
            .replacen("__DATA__", "null", 1)
    }

    /// The JSON list of runs (`/api/runs`).
    pub fn runs_json(&self) -> serde_json::Value {
        serde_json::Value::Array(self.runs.iter().map(Run::meta).collect())
    }

    /// Frame `i` of run `r`, encoded (cached).
    pub fn frame(&self, r: usize, i: usize) -> Result<Arc<Vec<u8>>, String> {
        let run = self
            .runs
            .get(r)
            .ok_or_else(|| format!("run {r} does not exist"))?;
        if let Ok(cache) = self.cache.lock() {
            if let Some((_, bytes)) = cache.iter().find(|(k, _)| *k == (r, i)) {
                return Ok(Arc::clone(bytes));
            }
        }
        let bytes = Arc::new(run.frame_bytes(i)?);
        if let Ok(mut cache) = self.cache.lock() {
            if cache.len() >= CACHE_FRAMES {
                cache.pop_front();
            }
            cache.push_back(((r, i), Arc::clone(&bytes)));
        }
        Ok(bytes)
    }

    /// Answers a GET of `path` (the query string is ignored).
    pub fn respond(&self, path: &str) -> Response {
        let path = path.split('?').next().unwrap_or("");
        let parts: Vec<&str> = path.trim_matches('/').split('/').collect();
        let run = |s: &str| -> Result<usize, Response> {
            s.parse::<usize>()
                .ok()
                .filter(|&r| r < self.runs.len())
                .ok_or_else(|| {
                    Response::error(
                        404,
                        format!("run {s:?} does not exist ({} loaded)", self.runs.len()),
                    )
                })
        };
        let answer = || -> Result<Response, Response> {
            Ok(match parts.as_slice() {
                [""] | ["index.html"] => Response {
                    status: 200,
                    content_type: "text/html; charset=utf-8",
                    body: Arc::new(Viewer::page().into_bytes()),
                },
                ["api", "runs"] => Response::json(200, &self.runs_json()),
                ["api", "run", r, "mesh"] => {
                    Response::binary(Arc::new(self.runs[run(r)?].mesh_bytes()))
                }
                ["api", "run", r, "steps"] => {
                    Response::json(200, &serde_json::json!(self.runs[run(r)?].steps))
                }
                ["api", "run", r, "frame", i] => {
                    let r = run(r)?;
                    let i: usize = i.parse().map_err(|_| {
                        Response::error(404, format!("frame {i:?} is not a number"))
                    })?;
                    if i >= self.runs[r].frames.len() {
                        return Err(Response::error(
                            404,
                            format!(
                                "frame {i} does not exist (the run has {})",
                                self.runs[r].frames.len()
                            ),
                        ));
                    }
                    Response::binary(self.frame(r, i).map_err(|e| Response::error(422, e))?)
                }
                _ => Response::error(404, format!("no such page: {path}")),
            })
        };
        answer().unwrap_or_else(|e| e)
    }
}
