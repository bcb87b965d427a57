//! Who a running `femto view` answers and how much it renders at once (issue 28): the token
//! of its URL (header, query or cookie), only its own names in `Host`, only its own page's
//! `Origin` for changes and the frame stream, JSON content types for changes, the range
//! checks of `/api/frame` on the WebSocket too, and concurrent large stills under an
//! address-space limit answered (200 or 503) without the server falling over.

use super::{fixture, raw_request, request, request_with, Server};
use serde_json::{json, Value};
use tungstenite::Message;

/// Send `raw` as it is and return the status line's code and the body.
fn raw(server: &Server, raw: &str) -> (u16, String) {
    raw_request(&server.url, raw)
}

fn one_line(body: &[u8]) -> String {
    let text = String::from_utf8_lossy(body).to_string();
    assert_eq!(text.trim_end().lines().count(), 1, "{text}");
    text
}

fn keyframe_count(server: &Server) -> usize {
    let (status, body) = request("GET", &format!("{}/api/keyframes", server.url), None);
    assert_eq!(status, 200);
    serde_json::from_slice::<Vec<Value>>(&body).unwrap().len()
}

#[test]
fn only_the_token_holder_on_this_servers_own_names_and_origin_is_answered() {
    let fx = fixture();
    let server = Server::start(&fx.root);
    let url = &server.url;
    let token = server.token.clone();
    let host = url.trim_start_matches("http://").to_string();
    let port = host.rsplit_once(':').unwrap().1.to_string();
    let auth = ("Authorization", format!("token {token}"));

    // No token, a wrong one: 403, one line, for the page, the API and the stream.
    for path in ["/", "/app.js", "/api/info", "/api/keyframes"] {
        let (status, _, body) = request_with("GET", &format!("{url}{path}"), None, &[]);
        assert_eq!(status, 403, "{path} without the token");
        assert!(one_line(&body).contains("token"), "{path}");
    }
    let wrong = ("Authorization", format!("token {}", "0".repeat(64)));
    let (status, _, _) = request_with("GET", &format!("{url}/api/info"), None, &[wrong]);
    assert_eq!(status, 403);
    let (status, _, _) = request_with("GET", &format!("{url}/api/info?token=x"), None, &[]);
    assert_eq!(status, 403);

    // The token by header, by query (which sets the cookie) and by that cookie: 200.
    let (status, _, _) = request_with(
        "GET",
        &format!("{url}/api/info"),
        None,
        std::slice::from_ref(&auth),
    );
    assert_eq!(status, 200);
    let (status, headers, page) = request_with("GET", &format!("{url}/?token={token}"), None, &[]);
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&page).contains("<canvas"));
    let cookie = headers
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case("set-cookie"))
        .map(|(_, v)| v.clone())
        .expect("the first visit sets a cookie");
    assert!(
        cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"),
        "{cookie}"
    );
    let pair = cookie.split(';').next().unwrap().to_string();
    assert!(pair.ends_with(&token) && pair.contains(&port), "{pair}");
    let (status, _, _) = request_with(
        "GET",
        &format!("{url}/api/keyframes"),
        None,
        &[("Cookie", pair.clone())],
    );
    assert_eq!(status, 200);
    // The token in the query of an API request is taken out before the query is read.
    let (status, _, body) = request_with(
        "POST",
        &format!("{url}/api/frame?token={token}&scale=0.25"),
        Some(&serde_json::to_vec(&info_state(&server)).unwrap()),
        &[("Content-Type", "application/json".into())],
    );
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));

    // Another name for 127.0.0.1 (DNS rebinding): refused even with the token or cookie.
    for h in [
        format!("rebind.example:{port}"),
        format!("localhost.evil.example:{port}"),
    ] {
        let (status, body) = raw(
            &server,
            &format!(
                "GET /api/keyframes HTTP/1.1\r\nHost: {h}\r\nCookie: {pair}\r\n\
                 Connection: close\r\n\r\n"
            ),
        );
        assert_eq!(status, 403, "Host {h}");
        assert!(body.contains("Host"), "{body}");
    }
    for h in [format!("localhost:{port}"), format!("[::1]:{port}")] {
        let (status, _) = raw(
            &server,
            &format!(
                "GET /api/info HTTP/1.1\r\nHost: {h}\r\nAuthorization: token {token}\r\n\
                 Connection: close\r\n\r\n"
            ),
        );
        assert_eq!(status, 200, "Host {h}");
    }

    // Request forgery: a page elsewhere posts text/plain (a "simple" request, sent without
    // asking) with the browser's cookie. Refused, and no keyframe is added.
    let state = serde_json::to_vec(&info_state(&server)).unwrap();
    let before = keyframe_count(&server);
    for (origin, content_type) in [
        (Some("http://evil.example"), "text/plain"),
        (Some("http://evil.example"), "application/json"),
        (Some("null"), "application/json"),
        (None, "text/plain"),
        (None, "application/x-www-form-urlencoded"),
    ] {
        let mut headers = vec![
            ("Cookie", pair.clone()),
            ("Content-Type", content_type.to_string()),
        ];
        if let Some(o) = origin {
            headers.push(("Origin", o.to_string()));
        }
        let (status, _, body) = request_with(
            "POST",
            &format!("{url}/api/keyframes"),
            Some(&state),
            &headers,
        );
        assert!(
            matches!(status, 403 | 415),
            "{origin:?} {content_type}: {status}"
        );
        one_line(&body);
    }
    let (status, _, _) = request_with(
        "DELETE",
        &format!("{url}/api/keyframes"),
        None,
        &[auth.clone(), ("Origin", "http://evil.example".into())],
    );
    assert_eq!(status, 403);
    assert_eq!(
        keyframe_count(&server),
        before,
        "a forged request added a keyframe"
    );
    // The page's own request (its origin, JSON) is served.
    let (status, _, _) = request_with(
        "POST",
        &format!("{url}/api/keyframes"),
        Some(&state),
        &[
            ("Cookie", pair.clone()),
            ("Content-Type", "application/json".into()),
            ("Origin", format!("http://{host}")),
        ],
    );
    assert_eq!(status, 200);
    assert_eq!(keyframe_count(&server), before + 1);

    // The frame stream: refused from another origin and without the token.
    for (t, origin) in [
        (Some(token.as_str()), Some("http://evil.example")),
        (Some(token.as_str()), Some("null")),
        (None, None),
    ] {
        match tungstenite::connect(server.ws_request(t, origin)) {
            Err(tungstenite::Error::Http(response)) => {
                assert_eq!(response.status(), 403, "{t:?} {origin:?}")
            }
            Err(e) => panic!("{t:?} {origin:?}: {e}"),
            Ok(_) => panic!("the WebSocket opened for {t:?} {origin:?}"),
        }
    }
    let own = format!("http://{host}");
    let (mut socket, _) = tungstenite::connect(server.ws_request(Some(&token), Some(&own)))
        .expect("the page's own origin opens the stream");
    socket
        .send(Message::text(
            json!({"seq": 1, "scale": 0.25, "state": info_state(&server)}).to_string(),
        ))
        .unwrap();
    assert!(matches!(socket.read().unwrap(), Message::Binary(_)));
}

/// The capture state of the server's session.
fn info_state(server: &Server) -> Value {
    let (status, body) = request("GET", &format!("{}/api/info", server.url), None);
    assert_eq!(status, 200);
    serde_json::from_slice::<Value>(&body).unwrap()["capture_state"].clone()
}

#[test]
fn the_websocket_refuses_the_frame_options_the_http_api_refuses() {
    let fx = fixture();
    let server = Server::start(&fx.root);
    let state = info_state(&server);
    let body = serde_json::to_vec(&state).unwrap();
    let mut socket = server.ws();
    for (quality, scale) in [
        (0, 0.25),
        (101, 0.25),
        (255, 0.25),
        (-1, 0.25),
        (85, 0.0),
        (85, 2.0),
    ] {
        let (status, reply) = request(
            "POST",
            &format!("{}/api/frame?scale={scale}&quality={quality}", server.url),
            Some(&body),
        );
        assert_eq!(status, 400, "HTTP quality {quality} scale {scale}");
        let http = one_line(&reply);
        socket
            .send(Message::text(
                json!({"seq": 5, "quality": quality, "scale": scale, "state": state}).to_string(),
            ))
            .unwrap();
        let Message::Text(text) = socket.read().unwrap() else {
            panic!("WebSocket quality {quality} scale {scale}: a frame, not a refusal")
        };
        let refusal: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(refusal["seq"], 5);
        let ws = refusal["error"].as_str().unwrap();
        let field = if quality == 85 { "scale" } else { "quality" };
        assert!(
            ws.starts_with(field) && http.starts_with(field),
            "{ws} / {http}"
        );
        assert_eq!(ws, http.trim_end(), "the same check, the same words");
    }
    for quality in [1, 100] {
        socket
            .send(Message::text(
                json!({"seq": 6, "quality": quality, "scale": 0.25, "state": state}).to_string(),
            ))
            .unwrap();
        assert!(
            matches!(socket.read().unwrap(), Message::Binary(_)),
            "{quality}"
        );
    }
}

#[test]
fn concurrent_large_stills_under_an_address_space_limit_are_answered_and_the_server_lives() {
    let fx = fixture();
    // 4,000,000 kB of address space: about 4.1 GB, for eight stills of 4096 x 4096.
    let mut server = Server::start_with(&fx.root, Some(4_000_000));
    let mut state = info_state(&server);
    state["width"] = json!(4096);
    state["height"] = json!(4096);
    let body = serde_json::to_vec(&state).unwrap();
    let url = format!("{}/api/still", server.url);
    let replies: Vec<(u16, Vec<u8>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..8)
            .map(|_| s.spawn(|| request("POST", &url, Some(&body))))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let mut served = 0;
    for (status, reply) in &replies {
        match status {
            200 => {
                assert_eq!(&reply[..8], b"\x89PNG\r\n\x1a\n");
                served += 1;
            }
            503 => assert!(one_line(reply).starts_with("busy"), "{}", one_line(reply)),
            other => panic!("{other}: {}", String::from_utf8_lossy(reply)),
        }
    }
    assert!(served >= 1, "no still was served");
    assert!(server.alive(), "the server fell over");
    let (status, _) = request("GET", &format!("{}/api/info", server.url), None);
    assert_eq!(status, 200);
    let (code, err) = server.stop();
    assert_eq!(code, Some(130), "{err}");
    assert!(
        !err.contains("panicked") && !err.contains("memory allocation"),
        "{err}"
    );
    eprintln!(
        "{served} of 8 stills of 4096 x 4096 served, {} refused as busy",
        8 - served
    );
}
