//! Hostile requests: malformed JSON, huge numbers, unknown fields, oversized bodies, wrong
//! methods, path traversal. Each gets a one-line 4xx; the server never panics, never serves
//! anything but its own assets and API, and goes on answering.

use super::{fixture, raw_request, request, Server};
use rand::{Rng, SeedableRng};
use serde_json::{json, Value};
use std::path::Path;

#[test]
fn hostile_requests_get_one_line_refusals_and_the_server_goes_on() {
    let fx = fixture();
    let mut server = Server::start(&fx.root);
    let url = server.url.clone();
    let (_, info) = request("GET", &format!("{url}/api/info"), None);
    let good: Value = serde_json::from_slice::<Value>(&info).unwrap()["capture_state"].clone();

    // Path traversal in every spelling: 404, and nothing of the file system in the reply.
    for target in [
        "/../../../../etc/passwd",
        "/%2e%2e/%2e%2e/etc/passwd",
        "/api/../../Cargo.toml",
        "//etc/passwd",
        "/app.js/../../../etc/passwd",
        "/..%2f..%2fetc%2fpasswd",
        "/world.h5",
        "/cube.calibration.toml",
        "/api/keyframes/../../etc/passwd",
        "/index.html%00.png",
    ] {
        let host = url.trim_start_matches("http://");
        let token = &server.token;
        let (status, body) = raw_request(
            &url,
            &format!(
                "GET {target} HTTP/1.1\r\nHost: {host}\r\nAuthorization: token {token}\r\n\
                 Connection: close\r\n\r\n"
            ),
        );
        assert!(matches!(status, 400 | 404 | 405), "{target}: {status}");
        assert!(
            !body.contains("root:") && !body.contains("[package]"),
            "{target}: {body}"
        );
        assert_eq!(body.trim_end().lines().count(), 1, "{target}: {body}");
    }

    // Malformed and out-of-range states on every route that takes one.
    let mut bodies: Vec<Vec<u8>> = vec![
        b"".to_vec(),
        b"{".to_vec(),
        b"null".to_vec(),
        b"[1, 2, 3]".to_vec(),
        "\u{feff}{}".as_bytes().to_vec(),
        vec![0xFF, 0xFE, 0x00],
        "[".repeat(100_000).into_bytes(),
    ];
    let variant = |f: &dyn Fn(&mut Value)| {
        let mut s = good.clone();
        f(&mut s);
        serde_json::to_vec(&s).unwrap()
    };
    bodies.push(variant(&|s| {
        s["beta"] = json!([0.0, 0.0, 0.9999999999999999999])
    }));
    bodies.push(variant(&|s| s["beta"] = json!([1e308, 0, 0])));
    bodies.push(variant(&|s| s["width"] = json!(1u64 << 40)));
    bodies.push(variant(&|s| s["width"] = json!(4097)));
    bodies.push(variant(&|s| s["width"] = json!(-1)));
    bodies.push(variant(&|s| s["height"] = json!(0)));
    bodies.push(variant(&|s| s["dtau_ps"] = json!(0)));
    bodies.push(variant(&|s| s["t_world_ps"] = json!(1e300)));
    bodies.push(variant(&|s| s["zoom"] = json!(2)));
    bodies.push(variant(&|s| s["effects"]["warp"] = json!(true)));
    bodies.push(variant(&|s| s["view"] = json!("../../etc/passwd")));
    bodies.push(variant(&|s| s["laser_nm"] = json!("670")));
    bodies.push(variant(&|s| {
        s["world_from_camera"] = json!([[1, 0, 0], [0, 1, 0], [0, 0, 2]])
    }));
    bodies.push(variant(&|s| s["position_m"] = json!([0.0, 0.05, 0.0])));
    bodies.push(br#"{"position_m": [1e999, 0, 0]}"#.to_vec());
    // Random bytes and random JSON-looking text, seeded.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(18);
    for _ in 0..40 {
        let n = rng.random_range(0..400);
        bodies.push((0..n).map(|_| rng.random::<u8>()).collect());
        let mut s = good.to_string().into_bytes();
        for _ in 0..rng.random_range(1..6) {
            let i = rng.random_range(0..s.len());
            s[i] = b"{}[],:\"0123456789.eE-+ntrufals"[rng.random_range(0..30)];
        }
        bodies.push(s);
    }
    for body in &bodies {
        for route in [
            "/api/still",
            "/api/frame?scale=0.5",
            "/api/hud",
            "/api/state.toml",
            "/api/keyframes",
        ] {
            let (status, reply) = request("POST", &format!("{url}{route}"), Some(body));
            if status == 200 {
                // A random mutation may still be a valid state.
                continue;
            }
            assert_eq!(
                status,
                400,
                "{route} {:?}: {status}",
                String::from_utf8_lossy(body)
            );
            let text = String::from_utf8(reply).unwrap();
            assert_eq!(text.trim_end().lines().count(), 1, "{route}: {text}");
        }
    }
    let (status, _) = request("POST", &format!("{url}/api/path"), Some(b"width = 1e999\n"));
    assert_eq!(status, 400);
    let (status, _) = request(
        "POST",
        &format!("{url}/api/frame?scale=9"),
        Some(&serde_json::to_vec(&good).unwrap()),
    );
    assert_eq!(status, 400);
    let (status, _) = request(
        "POST",
        &format!("{url}/api/still"),
        Some(&vec![b' '; 5 << 20]),
    );
    assert_eq!(status, 413);
    for (method, route) in [
        ("DELETE", "/api/info"),
        ("POST", "/app.js"),
        ("GET", "/api/still"),
        ("PUT", "/api/state"),
    ] {
        let (status, _) = request(method, &format!("{url}{route}"), Some(b"{}"));
        assert_eq!(status, 405, "{method} {route}");
    }
    // Garbage on the WebSocket: refusals, then a frame.
    let mut socket = server.ws();
    for junk in [
        "",
        "{",
        "{\"seq\": -1}",
        "{\"seq\": 1, \"state\": {}}",
        "[[[[[[[[[[[[",
    ] {
        socket.send(tungstenite::Message::text(junk)).unwrap();
        assert!(
            matches!(socket.read().unwrap(), tungstenite::Message::Text(_)),
            "{junk}"
        );
    }
    socket
        .send(tungstenite::Message::text(
            json!({"seq": 2, "scale": 0.25, "state": good}).to_string(),
        ))
        .unwrap();
    assert!(matches!(
        socket.read().unwrap(),
        tungstenite::Message::Binary(_)
    ));

    // Still alive and answering; no panic on stderr.
    assert!(server.alive());
    let (status, _) = request("GET", &format!("{url}/api/info"), None);
    assert_eq!(status, 200);
    let (code, err) = server.stop();
    assert_eq!(code, Some(130));
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn the_servers_code_never_opens_a_file() {
    // The page is embedded at compile time and the inputs are opened before the server
    // starts (`femto::pipeline::render::open_render_inputs`); nothing under src/view may
    // reach the file system, so no request can make it read one.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/view");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&path).unwrap();
            for needle in [
                "std::fs",
                "fs::",
                "File::",
                "OpenOptions",
                "read_dir",
                "Path::new",
            ] {
                assert!(!text.contains(needle), "{} uses {needle}", path.display());
            }
            checked += 1;
        }
    }
    assert!(checked >= 6, "{checked} files under {}", dir.display());
}

#[test]
fn bad_command_lines_are_refused_in_one_line_with_exit_2() {
    let fx = fixture();
    let inputs = super::input_args(&fx.root);
    // A missing cube names its flag.
    let mut args: Vec<String> = vec!["view".into()];
    args.extend(inputs.iter().cloned());
    args[2] = fx.root.join("missing.h5").display().to_string();
    let err = super::cli::FemtoCmd::new().args(&args).refused();
    assert!(
        err.contains("--cube") && err.contains("missing.h5"),
        "{err}"
    );
    // A port that is taken names --port.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let err = super::cli::FemtoCmd::new()
        .arg("view")
        .args(&inputs)
        .args(["--port", &port])
        .refused();
    assert!(err.contains("--port"), "{err}");
    let err = super::cli::FemtoCmd::new()
        .arg("view")
        .args(&inputs)
        .args(["--bind", "the-lab"])
        .refused();
    assert!(err.contains("--bind"), "{err}");
}
