//! The viewer's web server: HTTP with tiny_http, the interactive frame stream as a
//! WebSocket with tungstenite (docs/view.md, "Frame stream").
//!
//! Both crates are synchronous and small (no async runtime): the work of a request is
//! rendering, which rayon already spreads over the cores, so a thread per request or per
//! WebSocket is all the concurrency the server needs. Several tabs each get their own
//! socket and thread; each socket renders one state at a time, and the page sends its
//! newest state only when the frame before has arrived, so frames never queue up behind a
//! moving camera.
//!
//! Every request, the WebSocket's upgrade included, first passes [`Access::check`] (token,
//! `Host`, `Origin`, content type); renders then pass the session's admission (as many at
//! once as rayon has threads, within the memory budget).

use super::access::{Access, Granted, RequestHead};
use super::api::{self, Reply, MAX_BODY_BYTES};
use super::session::ViewSession;
use super::state::{FrameOptions, ViewState, DEFAULT_JPEG_QUALITY};
use serde::{Deserialize, Serialize};
use std::io::ErrorKind;
use std::net::SocketAddr;
use std::time::{Duration, Instant};
use tungstenite::protocol::Role;
use tungstenite::{Message, WebSocket};

/// Bind the server to `addr` (port 0: a free port); returns it and the address bound.
pub fn bind(addr: SocketAddr) -> Result<(tiny_http::Server, SocketAddr), String> {
    let server = tiny_http::Server::http(addr).map_err(|e| format!("{addr}: {e}"))?;
    let bound = server
        .server_addr()
        .to_ip()
        .ok_or_else(|| format!("{addr}: not an IP address"))?;
    Ok((server, bound))
}

/// Serve `session` on `server` to the clients that `access` lets in, until the process
/// ends (the binary's interrupt handler ends it on Ctrl-C). A thread per request; requests
/// never touch the file system. When no thread can be started (memory or thread limits),
/// the request is refused as busy and the server goes on.
pub fn serve(server: &tiny_http::Server, session: &ViewSession, access: &Access) {
    std::thread::scope(|scope| {
        for request in server.incoming_requests() {
            let (tx, rx) = std::sync::mpsc::sync_channel::<tiny_http::Request>(1);
            let spawned = std::thread::Builder::new()
                .name("femto-view-request".into())
                .spawn_scoped(scope, move || {
                    if let Ok(request) = rx.recv() {
                        answer(session, access, request)
                    }
                });
            let refused = match spawned {
                Ok(_) => tx.send(request).err().map(|e| e.0),
                Err(_) => Some(request),
            };
            if let Some(request) = refused {
                let _ = request.respond(to_response(Reply::error(
                    503,
                    "busy: no thread could be started for this request; try again",
                )));
            }
        }
    });
}

fn header_value<'r>(request: &'r tiny_http::Request, name: &'static str) -> Option<&'r str> {
    request
        .headers()
        .iter()
        .find(|h| h.field.equiv(name))
        .map(|h| h.value.as_str())
}

fn header_is(request: &tiny_http::Request, name: &'static str, value: &str) -> bool {
    request.headers().iter().any(|h| {
        h.field.equiv(name)
            && h.value
                .as_str()
                .split(',')
                .any(|v| v.trim().eq_ignore_ascii_case(value))
    })
}

fn answer(session: &ViewSession, access: &Access, mut request: tiny_http::Request) {
    let method = request.method().as_str().to_ascii_uppercase();
    let websocket = header_is(&request, "Upgrade", "websocket");
    let checked = access.check(&RequestHead {
        method: &method,
        url: request.url(),
        host: header_value(&request, "Host"),
        origin: header_value(&request, "Origin"),
        authorization: header_value(&request, "Authorization"),
        cookies: request
            .headers()
            .iter()
            .filter(|h| h.field.equiv("Cookie"))
            .map(|h| h.value.as_str())
            .collect(),
        content_type: header_value(&request, "Content-Type"),
        websocket,
    });
    let Granted { url, set_cookie } = match checked {
        Ok(granted) => granted,
        Err(refusal) => {
            let _ = request.respond(to_response(refusal));
            return;
        }
    };
    let path = url.split('?').next().unwrap_or("");
    if path == "/ws" && websocket {
        return frame_stream(session, request);
    }
    let mut reply = match read_body(&mut request) {
        Ok(body) => api::handle(session, &method, &url, &body),
        Err(refusal) => refusal,
    };
    if let Some(cookie) = set_cookie.filter(|_| reply.status == 200) {
        reply.headers.push(("Set-Cookie", cookie));
    }
    let _ = request.respond(to_response(reply));
}

/// The longest a request's body may take to arrive.
const BODY_TIMEOUT: Duration = Duration::from_secs(10);

/// A request's body, read in chunks of 8 kB up to [`MAX_BODY_BYTES`] and within
/// [`BODY_TIMEOUT`]; a declared `Content-Length` over the limit is refused (413) before
/// anything is read or allocated. A client that lies about the length and disconnects, or
/// stops sending, gets a refusal, and the server goes on (the patched tiny_http discards the
/// rest of a refused body through a fixed buffer, vendor/tiny_http/PATCH.md).
fn read_body(request: &mut tiny_http::Request) -> Result<Vec<u8>, Reply> {
    if let Some(declared) = request.body_length().filter(|&n| n > MAX_BODY_BYTES) {
        return Err(Reply::error(
            413,
            format!("the body is {declared} bytes; at most {MAX_BODY_BYTES}"),
        ));
    }
    let started = Instant::now();
    let reader = request.as_reader();
    let mut body = Vec::new();
    let mut chunk = [0u8; 8192];
    loop {
        if started.elapsed() > BODY_TIMEOUT {
            return Err(Reply::error(
                408,
                format!("the body took more than {} s", BODY_TIMEOUT.as_secs()),
            ));
        }
        let n = match reader.read(&mut chunk) {
            Ok(0) => return Ok(body),
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) => {
                return Err(Reply::error(408, "the body stopped arriving"))
            }
            Err(e) => return Err(Reply::error(400, format!("reading the request body: {e}"))),
        };
        if body.len() + n > MAX_BODY_BYTES {
            return Err(Reply::error(
                413,
                format!("the body is over {MAX_BODY_BYTES} bytes"),
            ));
        }
        body.extend_from_slice(&chunk[..n]);
    }
}

fn header(name: &str, value: &str) -> tiny_http::Header {
    tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes())
        .expect("header names and values are ASCII")
}

fn to_response(reply: Reply) -> tiny_http::Response<std::io::Cursor<Vec<u8>>> {
    let mut response = tiny_http::Response::from_data(reply.body)
        .with_status_code(reply.status)
        .with_header(header("Content-Type", reply.content_type))
        .with_header(header("Cache-Control", "no-store"))
        .with_header(header("X-Content-Type-Options", "nosniff"));
    for (name, value) in reply.headers {
        response.add_header(header(name, &value));
    }
    response
}

/// A frame request on the WebSocket: a state, its sequence number and the frame's scale
/// and JPEG quality (checked as `/api/frame`'s, [`FrameOptions::check`]).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameRequest {
    pub seq: u64,
    #[serde(default = "full_scale")]
    pub scale: f64,
    #[serde(default = "default_quality")]
    pub quality: i64,
    pub state: ViewState,
}

fn full_scale() -> f64 {
    1.0
}

fn default_quality() -> i64 {
    DEFAULT_JPEG_QUALITY
}

/// The header of a frame sent on the WebSocket.
#[derive(Debug, Serialize, Deserialize)]
pub struct FrameHeader {
    pub seq: u64,
    pub hud: super::session::Hud,
}

/// A refusal sent on the WebSocket (as text) instead of a frame.
#[derive(Debug, Serialize, Deserialize)]
pub struct FrameRefusal {
    pub seq: Option<u64>,
    pub error: String,
}

/// Answer frame requests on one WebSocket until the page closes it: each binary reply is a
/// 4-byte little-endian header length, the header as JSON ([`FrameHeader`]) and the JPEG.
fn frame_stream(session: &ViewSession, request: tiny_http::Request) {
    let Some(key) = request
        .headers()
        .iter()
        .find(|h| h.field.equiv("Sec-WebSocket-Key"))
        .map(|h| h.value.as_str().to_string())
    else {
        let _ = request.respond(to_response(Reply::error(
            400,
            "/ws: a WebSocket upgrade needs Sec-WebSocket-Key",
        )));
        return;
    };
    let accept = tungstenite::handshake::derive_accept_key(key.as_bytes());
    let response = tiny_http::Response::empty(101)
        .with_header(header("Upgrade", "websocket"))
        .with_header(header("Connection", "Upgrade"))
        .with_header(header("Sec-WebSocket-Accept", &accept));
    let stream = request.upgrade("websocket", response);
    let mut socket = WebSocket::from_raw_socket(stream, Role::Server, None);
    loop {
        let reply = match socket.read() {
            Ok(Message::Text(text)) => frame_reply(session, text.as_bytes()),
            Ok(Message::Binary(bytes)) => frame_reply(session, &bytes),
            // A read that timed out (tiny_http's socket read timeout) on an idle tab.
            Err(tungstenite::Error::Io(e))
                if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) =>
            {
                continue
            }
            Ok(Message::Close(_)) | Err(_) => break,
            Ok(_) => continue,
        };
        if socket.send(reply).is_err() {
            break;
        }
    }
}

/// The reply to one frame request: the frame, or a refusal naming why.
pub fn frame_reply(session: &ViewSession, request: &[u8]) -> Message {
    let refuse = |seq, error: String| {
        Message::text(
            serde_json::to_string(&FrameRefusal { seq, error }).expect("refusals serialise"),
        )
    };
    if request.len() > MAX_BODY_BYTES {
        return refuse(
            None,
            format!(
                "the request is {} bytes; at most {MAX_BODY_BYTES}",
                request.len()
            ),
        );
    }
    let req: FrameRequest = match serde_json::from_slice(request) {
        Ok(r) => r,
        Err(e) => return refuse(None, format!("frame request: {e}")),
    };
    let options = FrameOptions {
        scale: req.scale,
        quality: req.quality,
    };
    if let Err(e) = options.check().and_then(|_| req.state.check()) {
        return refuse(Some(req.seq), e.to_string());
    }
    match session.frame_jpeg(&req.state, options) {
        Ok((jpeg, hud)) => {
            let header =
                serde_json::to_vec(&FrameHeader { seq: req.seq, hud }).expect("headers serialise");
            let mut out = Vec::with_capacity(4 + header.len() + jpeg.len());
            out.extend_from_slice(&(header.len() as u32).to_le_bytes());
            out.extend_from_slice(&header);
            out.extend_from_slice(&jpeg);
            Message::binary(out)
        }
        Err(e) => refuse(Some(req.seq), e.to_string()),
    }
}
