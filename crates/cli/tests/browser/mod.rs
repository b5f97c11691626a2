//! Driving Debian's headless Chromium for the viewer's browser tests: a minimal DevTools-protocol
//! client over `--remote-debugging-pipe` (JSON messages separated by NUL on file descriptors 3
//! and 4; no WebSocket, no crate, no browser download), and screenshot pixel helpers.
//!
//! Why this and not Playwright or a CDP crate: the pipe protocol needs only serde_json (already a
//! dependency), works with the system chromium as it is, and the tests need five commands
//! (navigate, evaluate, screenshot, mouse and key events).

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use base64::Engine as _;
use serde_json::{Value, json};

/// The browser binary: `$CHROMIUM`, else the first of chromium / chromium-browser on PATH.
pub fn chromium_path() -> Option<String> {
    if let Ok(p) = std::env::var("CHROMIUM") {
        return Some(p);
    }
    ["chromium", "chromium-browser"]
        .into_iter()
        .find_map(|name| {
            std::env::var_os("PATH").and_then(|paths| {
                std::env::split_paths(&paths)
                    .map(|d| d.join(name))
                    .find(|p| p.is_file())
                    .map(|p| p.display().to_string())
            })
        })
}

/// A headless Chromium with one page attached.
pub struct Browser {
    child: Child,
    to: ChildStdin,
    from: Receiver<Value>,
    next: u64,
    session: String,
    _profile: tempdir::Dir,
}

mod tempdir {
    /// A directory removed on drop.
    pub struct Dir(pub std::path::PathBuf);
    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

impl Browser {
    /// Starts chromium (panics with a clear message when it is missing: these tests never pass
    /// without a browser) with a `width × height` CSS-pixel page at device scale 1.
    pub fn start(width: u32, height: u32) -> Browser {
        let exe = chromium_path().unwrap_or_else(|| {
            panic!("chromium not found (install it: apt-get install -y chromium, or set CHROMIUM)")
        });
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let profile =
            std::env::temp_dir().join(format!("thinshell-chromium-{}-{nanos}", std::process::id()));
        // fd 3: commands in, fd 4: replies out (the shell wires our pipes there).
        let mut child = Command::new("sh")
            .arg("-c")
            .arg("exec \"$0\" \"$@\" 3<&0 4>&1 0</dev/null 1>/dev/null")
            .arg(&exe)
            .args([
                "--headless",
                "--no-sandbox",
                "--remote-debugging-pipe",
                "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader",
                "--ignore-gpu-blocklist",
                "--no-first-run",
                "--no-default-browser-check",
                "--disable-extensions",
                "--hide-scrollbars",
                "--allow-file-access-from-files",
                &format!("--user-data-dir={}", profile.display()),
                &format!("--window-size={width},{height}"),
                "about:blank",
            ])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {exe}: {e}"));
        let to = child.stdin.take().expect("stdin piped");
        let mut out = BufReader::new(child.stdout.take().expect("stdout piped"));
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            while matches!(out.read_until(0, &mut buf), Ok(n) if n > 0) {
                if buf.last() == Some(&0) {
                    buf.pop();
                }
                if let Ok(v) = serde_json::from_slice::<Value>(&buf) {
                    if tx.send(v).is_err() {
                        break;
                    }
                }
                buf.clear();
            }
            let _ = out.read_to_end(&mut buf);
        });
        let mut b = Browser {
            child,
            to,
            from: rx,
            next: 0,
            session: String::new(),
            _profile: tempdir::Dir(profile),
        };
        let target = b.call_browser("Target.createTarget", json!({ "url": "about:blank" }));
        let id = target["targetId"].as_str().expect("targetId").to_string();
        let attached = b.call_browser(
            "Target.attachToTarget",
            json!({ "targetId": id, "flatten": true }),
        );
        b.session = attached["sessionId"]
            .as_str()
            .expect("sessionId")
            .to_string();
        b.call(
            "Emulation.setDeviceMetricsOverride",
            json!({ "width": width, "height": height, "deviceScaleFactor": 1, "mobile": false }),
        );
        b.call("Page.enable", json!({}));
        b
    }

    fn send(&mut self, session: Option<String>, method: &str, params: Value) -> Value {
        self.next += 1;
        let id = self.next;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = session {
            msg["sessionId"] = json!(s);
        }
        let mut bytes = msg.to_string().into_bytes();
        bytes.push(0);
        self.to.write_all(&bytes).expect("write to chromium");
        self.to.flush().expect("flush to chromium");
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let v = self
                .from
                .recv_timeout(left)
                .unwrap_or_else(|_| panic!("chromium did not answer {method}"));
            if v["id"].as_u64() == Some(id) {
                if let Some(e) = v.get("error") {
                    panic!("{method}: {e}");
                }
                return v["result"].clone();
            }
        }
    }

    fn call_browser(&mut self, method: &str, params: Value) -> Value {
        self.send(None, method, params)
    }

    /// A DevTools command to the page.
    pub fn call(&mut self, method: &str, params: Value) -> Value {
        let s = self.session.clone();
        self.send(Some(s), method, params)
    }

    /// Opens `url` and waits until the viewer says its current frame is drawn
    /// (`body[data-ready]` is 1) or it failed (`error`); returns that state.
    pub fn open(&mut self, url: &str) -> String {
        self.call("Page.navigate", json!({ "url": url }));
        self.wait_ready()
    }

    /// Waits (≤ 30 s) until `body[data-ready]` is `1` or `error`.
    pub fn wait_ready(&mut self) -> String {
        self.wait_for("document.body && document.body.dataset.ready", |v| {
            v == "1" || v == "error"
        })
    }

    /// Evaluates `expr` in the page until `ok` accepts its string value (≤ 30 s).
    pub fn wait_for(&mut self, expr: &str, ok: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let v = self.eval(expr);
            let s = v
                .as_str()
                .map(str::to_string)
                .unwrap_or_else(|| v.to_string());
            if ok(&s) {
                return s;
            }
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {expr} (last: {s})"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Evaluates a JavaScript expression (promises awaited) and returns its JSON value.
    pub fn eval(&mut self, expr: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            json!({ "expression": expr, "returnByValue": true, "awaitPromise": true }),
        );
        if let Some(e) = r.get("exceptionDetails") {
            panic!("{expr}: {e}");
        }
        r["result"]["value"].clone()
    }

    /// A screenshot of the page.
    pub fn screenshot(&mut self) -> Image {
        let r = self.call("Page.captureScreenshot", json!({ "format": "png" }));
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(r["data"].as_str().expect("screenshot data"))
            .expect("screenshot base64");
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().expect("png header");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("png frame");
        let channels = info.color_type.samples();
        let pixels = buf[..info.buffer_size()]
            .chunks_exact(channels)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        Image {
            width: info.width as usize,
            height: info.height as usize,
            pixels,
        }
    }

    /// A left click at CSS pixel (x, y).
    pub fn click(&mut self, x: f64, y: f64) {
        for kind in ["mousePressed", "mouseReleased"] {
            self.call(
                "Input.dispatchMouseEvent",
                json!({ "type": kind, "x": x, "y": y, "button": "left", "clickCount": 1 }),
            );
        }
    }

    /// A left-button drag from (x0, y0) to (x1, y1), CSS pixels, in ten moves.
    pub fn drag(&mut self, from: [f64; 2], to: [f64; 2]) {
        let event = |kind: &str, p: [f64; 2], buttons: u32| json!({ "type": kind, "x": p[0], "y": p[1], "button": "left", "buttons": buttons, "clickCount": 1 });
        self.call("Input.dispatchMouseEvent", event("mousePressed", from, 1));
        for k in 1..=10 {
            let t = k as f64 / 10.0;
            let p = [
                from[0] + t * (to[0] - from[0]),
                from[1] + t * (to[1] - from[1]),
            ];
            self.call("Input.dispatchMouseEvent", event("mouseMoved", p, 1));
        }
        self.call("Input.dispatchMouseEvent", event("mouseReleased", to, 0));
    }

    /// Presses and releases a key such as `End` (DOM key name and code).
    pub fn key(&mut self, key: &str) {
        for kind in ["rawKeyDown", "keyUp"] {
            self.call(
                "Input.dispatchKeyEvent",
                json!({ "type": kind, "key": key, "code": key, "windowsVirtualKeyCode": match key {
                    "End" => 35, "Home" => 36, "ArrowLeft" => 37, "ArrowRight" => 39, _ => 0 } }),
            );
        }
    }

    /// The page rectangle (x, y, width, height; CSS pixels) of the first element matching `css`.
    pub fn rect(&mut self, css: &str) -> [f64; 4] {
        let v = self.eval(&format!(
            "(() => {{ const r = document.querySelector({css:?}).getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; }})()"
        ));
        let a: Vec<f64> = v
            .as_array()
            .expect("rect")
            .iter()
            .map(|x| x.as_f64().unwrap_or(f64::NAN))
            .collect();
        [a[0], a[1], a[2], a[3]]
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// An RGB screenshot.
pub struct Image {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Row-major RGB.
    pub pixels: Vec<[u8; 3]>,
}

impl Image {
    /// The pixel at (x, y).
    pub fn at(&self, x: usize, y: usize) -> [u8; 3] {
        self.pixels[y * self.width + x]
    }

    /// The pixels inside a rectangle [x, y, w, h] (CSS pixels = image pixels at scale 1) that
    /// `keep` accepts, as a mask of the rectangle.
    pub fn mask(&self, rect: [f64; 4], keep: impl Fn([u8; 3]) -> bool) -> Vec<bool> {
        let (x0, y0) = (rect[0].round() as usize, rect[1].round() as usize);
        let (w, h) = (rect[2].round() as usize, rect[3].round() as usize);
        let mut m = Vec::with_capacity(w * h);
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                m.push(keep(self.at(x, y)));
            }
        }
        m
    }
}
