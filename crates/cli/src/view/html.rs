//! `thinshell view DIR --html FILE`: one HTML file with the page, its script and every frame
//! embedded (base64 of the same binary layout the server sends), which opens from `file://`
//! without a server or network.

use base64::Engine as _;

use super::viewer::{PAGE, SCRIPT, Viewer};

/// The self-contained page. Frames that cannot be read are embedded as their error message,
/// which the page shows in place of the frame.
pub fn page(viewer: &Viewer) -> String {
    let b64 = |bytes: &[u8]| base64::engine::general_purpose::STANDARD.encode(bytes);
    let runs: Vec<serde_json::Value> = viewer
        .runs()
        .iter()
        .enumerate()
        .map(|(r, run)| {
            let frames: Vec<serde_json::Value> = (0..run.frames.len())
                .map(|i| match viewer.frame(r, i) {
                    Ok(bytes) => serde_json::Value::String(b64(&bytes)),
                    Err(e) => serde_json::json!({ "error": e }),
                })
                .collect();
            serde_json::json!({
                "mesh": b64(&run.mesh_bytes()),
                "steps": run.steps,
                "frames": frames,
            })
        })
        .collect();
    let data = serde_json::json!({ "meta": viewer.runs_json(), "runs": runs });
    // "</" inside a <script> would end it; JSON allows the escaped form.
    let data = data.to_string().replace("</", "<\\/");
    PAGE.replacen("/*__VIEWER_JS__*/", SCRIPT, 1)
        .replacen("__DATA__", &data, 1)
}
