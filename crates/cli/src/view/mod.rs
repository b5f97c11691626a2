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
mod viewer;

use std::path::Path;
use std::sync::Arc;

use thinshell::output::Failure;

pub use viewer::{PAGE, Response, SCRIPT, Viewer};

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
                viewer.runs().len()
            );
            use std::io::Write as _;
            let _ = std::io::stdout().flush();
            server::serve(listener, Arc::new(viewer));
            Ok(())
        }
    }
}
