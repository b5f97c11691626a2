//! A minimal HTTP/1.1 server for the viewer (GET only, `Connection: close`, one thread per
//! connection), bound by the caller to 127.0.0.1. std only: the viewer needs four GET routes,
//! which do not justify an HTTP crate.

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Arc;
use std::time::Duration;

use super::viewer::{Response, Viewer};

/// Serves `viewer` on `listener` until the process ends.
pub fn serve(listener: TcpListener, viewer: Arc<Viewer>) {
    for stream in listener.incoming().flatten() {
        let viewer = Arc::clone(&viewer);
        std::thread::spawn(move || {
            // A client that vanishes mid-request only ends its own connection.
            let _ = handle(stream, &viewer);
        });
    }
}

fn status_text(status: u16) -> &'static str {
    match status {
        200 => "OK",
        404 => "Not Found",
        405 => "Method Not Allowed",
        422 => "Unprocessable Entity",
        _ => "Bad Request",
    }
}

fn handle(stream: TcpStream, viewer: &Viewer) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(10)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut request_line = String::new();
    reader.read_line(&mut request_line)?;
    // Skip the headers (bounded, so a client cannot make the server read forever).
    let mut line = String::new();
    for _ in 0..100 {
        line.clear();
        if reader.read_line(&mut line)? == 0 || line.trim().is_empty() {
            break;
        }
    }
    let mut words = request_line.split_whitespace();
    let response = match (words.next(), words.next()) {
        (Some("GET"), Some(path)) => viewer.respond(path),
        _ => Response::error(405, "only GET is served".into()),
    };
    let mut stream = stream;
    write!(
        stream,
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        response.status,
        status_text(response.status),
        response.content_type,
        response.body.len()
    )?;
    stream.write_all(&response.body)?;
    stream.flush()
}
