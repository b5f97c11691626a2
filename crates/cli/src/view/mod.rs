//! `thinshell view`: a browser viewer for run output directories.
//!
//! [`Viewer`] loads one or two runs ([`run::Run`]: frame list, mesh, `steps.csv`) and answers
//! the page's requests ([`Viewer::respond`]); [`server`] serves it on 127.0.0.1 over plain
//! HTTP/1.1 (std only, one thread per connection), and [`html`] writes one self-contained page
//! with every frame embedded. The page itself (`assets/`: hand-written JavaScript and WebGL2, no
//! library) is compiled into the binary.
//!
//! Endpoints (JSON unless said otherwise; errors are `{"error": "…"}` with status 404 or 422):
//! - `GET /` the page; `GET /api/runs` every run's [`run::Run::meta`] (name, frames with step
//!   and time, fields with units);
//! - `GET /api/run/R/mesh`: triangles, little-endian u32 ×3 per face (binary);
//! - `GET /api/run/R/frame/I`: frame I, little-endian f32: positions then every field
//!   ([`run::Run::frame_bytes`]; binary);
//! - `GET /api/run/R/steps`: `steps.csv` by column ([`run::Steps`]).

pub mod frame;
pub mod html;
pub mod run;
pub mod server;

use std::collections::VecDeque;
use std::path::Path;
use std::sync::{Arc, Mutex};

use run::Run;
use thinshell::output::Failure;

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

    fn error(status: u16, message: String) -> Response {
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

/// `thinshell view DIR [DIR2] [--port P] [--html FILE]`: serves the viewer until interrupted,
/// or writes a self-contained page. A directory that is not a run output is bad input.
pub fn view(dirs: &[&Path], port: u16, html: Option<&Path>) -> Result<(), Failure> {
    let viewer = Viewer::load(dirs).map_err(Failure::BadInput)?;
    match html {
        Some(file) => {
            let page = html::page(&viewer);
            std::fs::write(file, &page)
                .map_err(|e| Failure::BadInput(format!("{}: {e}", file.display())))?;
            println!(
                "thinshell view: wrote {} ({:.1} MB, every frame embedded; open it in a browser, no server needed)",
                file.display(),
                page.len() as f64 / 1e6
            );
            Ok(())
        }
        None => {
            let listener = std::net::TcpListener::bind(("127.0.0.1", port)).map_err(|e| {
                Failure::BadInput(format!("cannot listen on 127.0.0.1:{port}: {e}"))
            })?;
            let addr = listener
                .local_addr()
                .map_err(|e| Failure::BadInput(format!("listening socket: {e}")))?;
            println!(
                "thinshell view: serving {} run(s) at http://{addr}/ (Ctrl-C to stop)",
                viewer.runs.len()
            );
            use std::io::Write as _;
            let _ = std::io::stdout().flush();
            server::serve(listener, Arc::new(viewer));
            Ok(())
        }
    }
}
