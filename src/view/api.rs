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

/// A route's answer: a reply, or a refusal (also a reply), so that routes use `?`.
type Routed = Result<Reply, Reply>;

/// A route: method, path, and the function that answers it from the session, the query and
/// the body.
type Route = (
    &'static str,
    &'static str,
    fn(&ViewSession, &str, &[u8]) -> Routed,
);

/// Every route of the API (docs/view.md, "HTTP API"), the one table that both dispatch and
/// the 404/405 refusals read. `DELETE /api/keyframes/N` is matched by its prefix.
const ROUTES: &[Route] = &[
    ("GET", "/api/info", |s, _, _| Ok(Reply::json(s.info()))),
    ("GET", "/api/state", |s, _, _| {
        Ok(Reply::json(&s.latest_state()))
    }),
    ("POST", "/api/still", still),
    ("POST", "/api/frame", frame),
    ("POST", "/api/hud", |s, _, body| {
        let state = ViewState::from_json(body)?;
        Ok(Reply::json(&s.render_srgb8(&state)?.1))
    }),
    ("POST", "/api/state.toml", |s, _, body| {
        let state = ViewState::from_json(body)?;
        state.path()?;
        let text = state.path_toml(&s.info().render_inputs);
        Ok(Reply::ok("application/toml", text.into_bytes()))
    }),
    ("GET", "/api/keyframes", |s, _, _| {
        Ok(Reply::json(&s.keyframes()))
    }),
    ("POST", "/api/keyframes", |s, _, body| {
        Ok(Reply::json(&s.add_keyframe(ViewState::from_json(body)?)?))
    }),
    ("DELETE", "/api/keyframes", |s, _, _| {
        s.clear_keyframes();
        Ok(Reply::json(&s.keyframes()))
    }),
    ("GET", "/api/path.toml", |s, _, _| {
        Ok(Reply::ok("application/toml", s.path_toml()?.into_bytes()))
    }),
    ("POST", "/api/path.toml", |s, _, body| {
        let states = keyframes_of_json(body)?;
        let text = super::keyframes::export_path(&states, &s.info().render_inputs)?;
        Ok(Reply::ok("application/toml", text.into_bytes()))
    }),
    ("POST", "/api/path", |s, _, body| {
        let text = std::str::from_utf8(body)
            .map_err(|_| Reply::error(400, "path: the body is not UTF-8 text"))?;
        Ok(Reply::json(&ViewSession::load_path(
            text,
            &s.latest_state(),
        )?))
    }),
    ("POST", "/api/curve", |s, _, body| {
        Ok(Reply::json(&s.light_curve(&ViewState::from_json(body)?)?))
    }),
    ("POST", "/api/probe", |s, query, body| {
        let (x, y, range) = parse_probe_query(query).map_err(|e| Reply::error(400, e))?;
        let state = ViewState::from_json(body)?;
        Ok(Reply::json(&s.probe(&state, x, y, range)?))
    }),
    ("GET", "/api/video", |s, _, _| {
        Ok(Reply::json(&s.video_progress().status()))
    }),
    ("POST", "/api/video", video),
];

fn still(session: &ViewSession, _: &str, body: &[u8]) -> Routed {
    let state = ViewState::from_json(body)?;
    Ok(Reply::ok("image/png", session.still_png(&state)?))
}

fn frame(session: &ViewSession, query: &str, body: &[u8]) -> Routed {
    let q = parse_frame_query(query).map_err(|e| Reply::error(400, e))?;
    let state = ViewState::from_json(body)?;
    let (jpeg, hud) = session.frame_jpeg(&state, q)?;
    let mut r = Reply::ok("image/jpeg", jpeg);
    r.headers.push((
        "X-Femto-Hud",
        serde_json::to_string(&hud).expect("a hud serialises"),
    ));
    Ok(r)
}

fn video(session: &ViewSession, query: &str, body: &[u8]) -> Routed {
    let format = parse_video_query(query).map_err(|e| Reply::error(400, e))?;
    let states = keyframes_of_json(body)?;
    let bytes = session.video(&states, format)?;
    let (kind, name) = match format {
        crate::video::VideoFormat::Gif => ("image/gif", "femto-path.gif"),
        _ => ("video/mp4", "femto-path.mp4"),
    };
    let mut r = Reply::ok(kind, bytes);
    r.headers.push((
        "Content-Disposition",
        format!("attachment; filename=\"{name}\""),
    ));
    Ok(r)
}

/// `DELETE /api/keyframes/N`.
fn delete_keyframe(session: &ViewSession, method: &str, path: &str, index: &str) -> Routed {
    if method != "DELETE" {
        return Err(Reply::error(405, format!("{method} {path}: only DELETE")));
    }
    let i = index
        .parse::<usize>()
        .map_err(|_| Reply::error(400, format!("{path}: not a keyframe number")))?;
    Ok(Reply::json(&session.delete_keyframe(i)?))
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
    let answered =
        if let Some((_, _, answer)) = ROUTES.iter().find(|(m, p, _)| *m == method && *p == path) {
            answer(session, query, body)
        } else if let Some(index) = path.strip_prefix("/api/keyframes/") {
            delete_keyframe(session, method, path, index)
        } else if ROUTES.iter().any(|(_, p, _)| *p == path) {
            Err(Reply::error(
                405,
                format!("{method} {path}: not allowed (docs/view.md)"),
            ))
        } else {
            Err(Reply::error(404, format!("{path}: no such page")))
        };
    answered.unwrap_or_else(|refusal| refusal)
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
