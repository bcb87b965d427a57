//! The viewer's HTTP API (docs/view.md), as a function from a request to a reply, apart
//! from the sockets ([`super::server`]) so that tests can drive it directly.
//!
//! Only the embedded assets and the routes below answer; no part of a request's path or
//! body ever names a file. Every refusal is one line of text with status 400 (a bad state,
//! query or body), 404 (no such route), 405 (a route without that method), 413 (a body
//! over [`MAX_BODY_BYTES`], or a frame larger than the memory budget) or 503 (every render
//! slot busy, or no memory free for the frame now; [`super::admission`]). Who may ask is
//! decided before, by [`super::access`].

use super::admission::Refusal;
use super::assets;
use super::session::{ViewError, ViewSession};
use super::state::{BadState, FrameOptions, ViewState};

/// Largest request body accepted, bytes (a state is about 600 bytes; a path file of the
/// most keyframes a session keeps about 400 kB).
pub const MAX_BODY_BYTES: usize = 4 << 20;

/// A reply: status, content type, body and extra headers.
#[derive(Clone, Debug, PartialEq)]
pub struct Reply {
    pub status: u16,
    pub content_type: &'static str,
    pub body: Vec<u8>,
    pub headers: Vec<(&'static str, String)>,
}

impl Reply {
    fn ok(content_type: &'static str, body: Vec<u8>) -> Reply {
        Reply {
            status: 200,
            content_type,
            body,
            headers: Vec::new(),
        }
    }

    fn json(value: &impl serde::Serialize) -> Reply {
        Reply::ok(
            "application/json",
            serde_json::to_vec(value).expect("replies serialise"),
        )
    }

    /// A one-line refusal.
    pub fn error(status: u16, message: impl std::fmt::Display) -> Reply {
        let line = message.to_string().replace(['\n', '\r'], " ");
        Reply::ok(
            "text/plain; charset=utf-8",
            format!("{line}\n").into_bytes(),
        )
        .status(status)
    }

    pub fn status(mut self, status: u16) -> Reply {
        self.status = status;
        self
    }
}

impl From<ViewError> for Reply {
    fn from(e: ViewError) -> Reply {
        match e {
            ViewError::Encode(_) => Reply::error(500, e),
            ViewError::State(_) | ViewError::Render(_) => Reply::error(400, e),
            ViewError::Admission(Refusal::TooLarge { .. }) => Reply::error(413, e),
            ViewError::Admission(Refusal::Busy(_)) => {
                let mut r = Reply::error(503, e);
                r.headers.push(("Retry-After", "1".into()));
                r
            }
        }
    }
}

impl From<BadState> for Reply {
    fn from(e: BadState) -> Reply {
        Reply::error(400, e)
    }
}

/// Parse `scale=0.5&quality=80`; unknown keys and bad values are refused, the ranges by
/// [`FrameOptions::check`] as on the WebSocket.
pub fn parse_frame_query(query: &str) -> Result<FrameOptions, String> {
    let mut q = FrameOptions::default();
    for pair in query.split('&').filter(|p| !p.is_empty()) {
        let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
        match key {
            "scale" => {
                q.scale = value
                    .parse::<f64>()
                    .map_err(|_| format!("scale={value}: must be a number in (0, 1]"))?
            }
            "quality" => {
                q.quality = value
                    .parse::<i64>()
                    .map_err(|_| format!("quality={value}: must be an integer from 1 to 100"))?
            }
            _ => return Err(format!("unknown query parameter '{key}' (scale, quality)")),
        }
    }
    q.check().map_err(|e| e.to_string())?;
    Ok(q)
}

/// The query of `/api/probe`: `x=I&y=J&t0=PS&t1=PS` (the pixel and the received
/// profile's range); each is needed, and unknown keys are refused.
pub fn parse_probe_query(query: &str) -> Result<(usize, usize, [f64; 2]), String> {
    let (mut x, mut y, mut t0, mut t1) = (None, None, None, None);
    for pair in query.split('&').filter(|p| !p.is_empty()) {
        let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
        let pixel = || {
            value
                .parse::<usize>()
                .map_err(|_| format!("{key}={value}: must be a pixel index (0, 1, ...)"))
        };
        let time = || {
            value
                .parse::<f64>()
                .ok()
                .filter(|t| t.is_finite())
                .ok_or_else(|| format!("{key}={value}: must be a finite time in ps"))
        };
        match key {
            "x" => x = Some(pixel()?),
            "y" => y = Some(pixel()?),
            "t0" => t0 = Some(time()?),
            "t1" => t1 = Some(time()?),
            _ => return Err(format!("unknown query parameter '{key}' (x, y, t0, t1)")),
        }
    }
    match (x, y, t0, t1) {
        (Some(x), Some(y), Some(t0), Some(t1)) => Ok((x, y, [t0, t1])),
        _ => Err("the probe needs x, y, t0 and t1 (docs/view.md, \"Pixel probe\")".into()),
    }
}

/// The query of `POST /api/video`: `format=mp4` (default) or `format=gif`.
fn parse_video_query(query: &str) -> Result<crate::video::VideoFormat, String> {
    let mut format = crate::video::VideoFormat::Mp4;
    for pair in query.split('&').filter(|p| !p.is_empty()) {
        let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
        match key {
            "format" => format = super::video_export::parse_video_format(value)?,
            _ => return Err(format!("unknown query parameter '{key}' (format)")),
        }
    }
    Ok(format)
}

/// A JSON array of states (a page's own keyframes), each checked as a state is, at most
/// [`super::keyframes::MAX_KEYFRAMES`].
fn keyframes_of_json(body: &[u8]) -> Result<Vec<ViewState>, BadState> {
    let values: Vec<serde_json::Value> = serde_json::from_slice(body).map_err(|e| BadState {
        field: "keyframes".into(),
        message: format!("{e}: expected a JSON array of states"),
    })?;
    if values.len() > super::keyframes::MAX_KEYFRAMES {
        return Err(BadState {
            field: "keyframes".into(),
            message: format!(
                "{} keyframes: at most {}",
                values.len(),
                super::keyframes::MAX_KEYFRAMES
            ),
        });
    }
    values
        .iter()
        .enumerate()
        .map(|(i, v)| {
            ViewState::from_json(v.to_string().as_bytes()).map_err(|e| BadState {
                field: format!("keyframes[{i}].{}", e.field),
                message: e.message,
            })
        })
        .collect()
}

/// Answer one request. `url` is the request target (path and query), `body` its body.
pub fn handle(session: &ViewSession, method: &str, url: &str, body: &[u8]) -> Reply {
    if body.len() > MAX_BODY_BYTES {
        return Reply::error(
            413,
            format!("the body is {} bytes; at most {MAX_BODY_BYTES}", body.len()),
        );
    }
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    if let Some(asset) = assets::find(path) {
        return match method {
            "GET" | "HEAD" => Reply::ok(asset.content_type, asset.body.to_vec()),
            _ => Reply::error(405, format!("{method} {path}: only GET")),
        };
    }
    let route = (method, path);
    match route {
        ("GET", "/api/info") => Reply::json(session.info()),
        ("GET", "/api/state") => Reply::json(&session.latest_state()),
        ("POST", "/api/still") => match ViewState::from_json(body) {
            Ok(state) => match session.still_png(&state) {
                Ok(png) => Reply::ok("image/png", png),
                Err(e) => e.into(),
            },
            Err(e) => e.into(),
        },
        ("POST", "/api/frame") => {
            let q = match parse_frame_query(query) {
                Ok(q) => q,
                Err(e) => return Reply::error(400, e),
            };
            match ViewState::from_json(body) {
                Ok(state) => match session.frame_jpeg(&state, q) {
                    Ok((jpeg, hud)) => {
                        let mut r = Reply::ok("image/jpeg", jpeg);
                        r.headers.push((
                            "X-Femto-Hud",
                            serde_json::to_string(&hud).expect("a hud serialises"),
                        ));
                        r
                    }
                    Err(e) => e.into(),
                },
                Err(e) => e.into(),
            }
        }
        ("POST", "/api/hud") => match ViewState::from_json(body) {
            Ok(state) => match session.render_srgb8(&state) {
                Ok((_, hud)) => Reply::json(&hud),
                Err(e) => e.into(),
            },
            Err(e) => e.into(),
        },
        ("POST", "/api/state.toml") => match ViewState::from_json(body) {
            Ok(state) => match state.path() {
                Ok(_) => Reply::ok(
                    "application/toml",
                    state.path_toml(&session.info().render_inputs).into_bytes(),
                ),
                Err(e) => e.into(),
            },
            Err(e) => e.into(),
        },
        ("POST", "/api/curve") => match ViewState::from_json(body) {
            Ok(state) => match session.light_curve(&state) {
                Ok(curve) => Reply::json(&curve),
                Err(e) => e.into(),
            },
            Err(e) => e.into(),
        },
        ("POST", "/api/probe") => {
            let (x, y, range) = match parse_probe_query(query) {
                Ok(q) => q,
                Err(e) => return Reply::error(400, e),
            };
            match ViewState::from_json(body) {
                Ok(state) => match session.probe(&state, x, y, range) {
                    Ok(probe) => Reply::json(&probe),
                    Err(e) => e.into(),
                },
                Err(e) => e.into(),
            }
        }
        ("GET", "/api/video") => Reply::json(&session.video_progress().status()),
        ("POST", "/api/video") => {
            let format = match parse_video_query(query) {
                Ok(f) => f,
                Err(e) => return Reply::error(400, e),
            };
            match keyframes_of_json(body) {
                Ok(states) => match session.video(&states, format) {
                    Ok(bytes) => {
                        let (kind, name) = match format {
                            crate::video::VideoFormat::Gif => ("image/gif", "femto-path.gif"),
                            _ => ("video/mp4", "femto-path.mp4"),
                        };
                        let mut r = Reply::ok(kind, bytes);
                        r.headers.push((
                            "Content-Disposition",
                            format!("attachment; filename=\"{name}\""),
                        ));
                        r
                    }
                    Err(e) => e.into(),
                },
                Err(e) => e.into(),
            }
        }
        ("GET", "/api/keyframes") => Reply::json(&session.keyframes()),
        ("POST", "/api/keyframes") => match ViewState::from_json(body) {
            Ok(state) => match session.add_keyframe(state) {
                Ok(k) => Reply::json(&k),
                Err(e) => e.into(),
            },
            Err(e) => e.into(),
        },
        ("DELETE", "/api/keyframes") => {
            session.clear_keyframes();
            Reply::json(&session.keyframes())
        }
        ("GET", "/api/path.toml") => match session.path_toml() {
            Ok(text) => Reply::ok("application/toml", text.into_bytes()),
            Err(e) => e.into(),
        },
        ("POST", "/api/path.toml") => match keyframes_of_json(body) {
            Ok(states) => {
                match super::keyframes::export_path(&states, &session.info().render_inputs) {
                    Ok(text) => Reply::ok("application/toml", text.into_bytes()),
                    Err(e) => e.into(),
                }
            }
            Err(e) => e.into(),
        },
        ("POST", "/api/path") => {
            let Ok(text) = std::str::from_utf8(body) else {
                return Reply::error(400, "path: the body is not UTF-8 text");
            };
            match ViewSession::load_path(text, &session.latest_state()) {
                Ok(loaded) => Reply::json(&loaded),
                Err(e) => e.into(),
            }
        }
        _ => {
            if let Some(index) = path.strip_prefix("/api/keyframes/") {
                if method != "DELETE" {
                    return Reply::error(405, format!("{method} {path}: only DELETE"));
                }
                return match index.parse::<usize>() {
                    Ok(i) => match session.delete_keyframe(i) {
                        Ok(k) => Reply::json(&k),
                        Err(e) => e.into(),
                    },
                    Err(_) => Reply::error(400, format!("{path}: not a keyframe number")),
                };
            }
            let known = [
                "/api/info",
                "/api/state",
                "/api/still",
                "/api/frame",
                "/api/hud",
                "/api/state.toml",
                "/api/keyframes",
                "/api/path.toml",
                "/api/path",
                "/api/curve",
                "/api/probe",
                "/api/video",
            ];
            if known.contains(&path) {
                Reply::error(405, format!("{method} {path}: not allowed (docs/view.md)"))
            } else {
                Reply::error(404, format!("{path}: no such page"))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_queries_parse_and_bad_ones_are_refused() {
        assert_eq!(parse_frame_query("").unwrap(), FrameOptions::default());
        let q = parse_frame_query("scale=0.5&quality=70").unwrap();
        assert_eq!((q.scale, q.quality), (0.5, 70));
        for bad in [
            "scale=0",
            "scale=2",
            "scale=nan",
            "quality=0",
            "quality=101",
            "x=1",
        ] {
            assert!(parse_frame_query(bad).is_err(), "{bad}");
        }
    }
}
