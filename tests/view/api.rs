//! The HTTP API and the frame stream of a running `femto view`.

use super::{fixture, input_args, request, Server};
use serde_json::{json, Value};
use std::path::Path;

fn info(server: &Server) -> Value {
    let (status, body) = request("GET", &format!("{}/api/info", server.url), None);
    assert_eq!(status, 200);
    serde_json::from_slice(&body).expect("info is JSON")
}

/// The capture state at 160 x 120, moving along its view at `beta`.
pub fn moving_state(info: &Value, beta: f64) -> Value {
    let mut s = info["capture_state"].clone();
    let rows = &s["world_from_camera"];
    let forward: Vec<f64> = (0..3).map(|i| rows[i][2].as_f64().unwrap()).collect();
    s["beta"] = json!([beta * forward[0], beta * forward[1], beta * forward[2]]);
    s["width"] = json!(160);
    s["height"] = json!(120);
    s
}

/// The `femto render` flags in the header of a path TOML the server wrote, between
/// `--path THIS.toml` and `--out`.
fn header_flags(toml: &str) -> Vec<String> {
    let line = toml
        .lines()
        .find(|l| l.contains("femto render"))
        .expect("the header names the command");
    let after = line
        .split("--path THIS.toml")
        .nth(1)
        .expect("--path THIS.toml");
    let flags = after.split("--out").next().unwrap();
    flags.split_whitespace().map(str::to_string).collect()
}

/// Render `path_toml` with `femto render` as its header says; the PNG frames, in order.
pub fn render_path(root: &Path, path_toml: &str, name: &str) -> Vec<Vec<u8>> {
    let path_file = root.join(format!("{name}.toml"));
    std::fs::write(&path_file, path_toml).unwrap();
    let out = root.join(name);
    super::cli::FemtoCmd::new()
        .arg("render")
        .args(input_args(root))
        .arg("--path")
        .arg(&path_file)
        .args(header_flags(path_toml))
        .arg("--out")
        .arg(&out)
        .ok();
    let mut files: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files.iter().map(|f| std::fs::read(f).unwrap()).collect()
}

fn brightest(png: &[u8]) -> u8 {
    let img = image::load_from_memory(png).expect("a PNG").to_rgb8();
    img.as_raw().iter().copied().max().unwrap_or(0)
}

#[test]
fn the_still_of_a_state_is_the_frame_femto_render_writes_for_its_path() {
    let fx = fixture();
    let server = Server::start(&fx.root);
    let info = info(&server);
    let state = moving_state(&info, 0.6);
    let body = serde_json::to_vec(&state).unwrap();
    let (status, png) = request("POST", &format!("{}/api/still", server.url), Some(&body));
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&png));
    assert!(brightest(&png) > 40, "the still is black");
    let (status, toml) = request(
        "POST",
        &format!("{}/api/state.toml", server.url),
        Some(&body),
    );
    assert_eq!(status, 200);
    let toml = String::from_utf8(toml).unwrap();
    let frames = render_path(&fx.root, &toml, "state_still");
    assert_eq!(frames.len(), 1);
    assert!(
        frames[0] == png,
        "the still differs from femto render's frame"
    );
    // The state is what the page sent last.
    let (_, latest) = request("GET", &format!("{}/api/state", server.url), None);
    let latest: Value = serde_json::from_slice(&latest).unwrap();
    assert_eq!(latest, state);
    let (code, err) = server.stop();
    assert_eq!(code, Some(130), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn keyframes_export_a_path_whose_first_frame_is_the_first_keyframes_still() {
    let fx = fixture();
    let server = Server::start(&fx.root);
    let info = info(&server);
    let url = |p: &str| format!("{}{p}", server.url);
    let (status, _) = request("GET", &url("/api/path.toml"), None);
    assert_eq!(status, 400, "no keyframes yet");
    // Two keyframes along the first one's straight motion, 30.5 frame intervals apart.
    let a = moving_state(&info, 0.5);
    let mut b = a.clone();
    let dtau = a["dtau_ps"].as_f64().unwrap();
    let gamma = 1.0 / (1.0f64 - 0.25).sqrt();
    let dt = 30.5 * dtau * gamma;
    b["t_world_ps"] = json!(a["t_world_ps"].as_f64().unwrap() + dt);
    for i in 0..3 {
        let p = a["position_m"][i].as_f64().unwrap();
        let v = a["beta"][i].as_f64().unwrap();
        b["position_m"][i] = json!(p + v * femto::units::C_M_PER_PS * dt);
    }
    let extra = moving_state(&info, 0.1);
    for k in [&a, &extra, &b] {
        let (status, _) = request(
            "POST",
            &url("/api/keyframes"),
            Some(&serde_json::to_vec(k).unwrap()),
        );
        assert_eq!(status, 200);
    }
    let (status, list) = request("DELETE", &url("/api/keyframes/1"), None);
    assert_eq!(status, 200);
    let list: Vec<Value> = serde_json::from_slice(&list).unwrap();
    assert_eq!(list, vec![a.clone(), b.clone()]);
    assert_eq!(request("DELETE", &url("/api/keyframes/7"), None).0, 400);
    assert_eq!(request("DELETE", &url("/api/keyframes/x"), None).0, 400);

    let (status, toml) = request("GET", &url("/api/path.toml"), None);
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&toml));
    let toml = String::from_utf8(toml).unwrap();
    // A page's own keyframes (POST, a JSON array of states): the same path.
    let (status, posted) = request(
        "POST",
        &url("/api/path.toml"),
        Some(&serde_json::to_vec(&vec![b.clone(), a.clone()]).unwrap()),
    );
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&posted));
    assert_eq!(String::from_utf8(posted).unwrap(), toml);
    let mut bad = b.clone();
    bad["vfov_deg"] = json!(200.0);
    let (status, why) = request(
        "POST",
        &url("/api/path.toml"),
        Some(&serde_json::to_vec(&vec![a.clone(), bad]).unwrap()),
    );
    let why = String::from_utf8_lossy(&why);
    assert_eq!(status, 400, "{why}");
    assert!(why.starts_with("keyframes[1].vfov_deg:"), "{why}");
    let frames = render_path(&fx.root, &toml, "keyframes_path");
    assert_eq!(
        frames.len(),
        31,
        "frames from the first keyframe to the last"
    );
    let (_, still) = request(
        "POST",
        &url("/api/still"),
        Some(&serde_json::to_vec(&a).unwrap()),
    );
    assert!(
        frames[0] == still,
        "frame 0 differs from the first keyframe's still"
    );
    // The path loads back into the viewer as 31 states, the first being the keyframe.
    let (status, loaded) = request("POST", &url("/api/path"), Some(toml.as_bytes()));
    assert_eq!(status, 200);
    let loaded: Value = serde_json::from_slice(&loaded).unwrap();
    let frames = loaded["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 31);
    assert_eq!(frames[0]["position_m"], a["position_m"]);
    assert_eq!(frames[0]["beta"], a["beta"]);
}

#[test]
fn the_frame_stream_answers_each_request_with_its_sequence_number_or_a_reason() {
    use tungstenite::Message;
    let fx = fixture();
    let server = Server::start(&fx.root);
    let info = info(&server);
    let mut socket = server.ws();
    let state = moving_state(&info, 0.3);
    socket
        .send(Message::text(
            json!({"seq": 7, "scale": 0.5, "state": state}).to_string(),
        ))
        .unwrap();
    let Message::Binary(bytes) = socket.read().unwrap() else {
        panic!("a frame is binary")
    };
    let n = u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
    let header: Value = serde_json::from_slice(&bytes[4..4 + n]).unwrap();
    assert_eq!(header["seq"], 7);
    assert_eq!(
        (
            header["hud"]["width"].as_u64(),
            header["hud"]["height"].as_u64()
        ),
        (Some(80), Some(60))
    );
    let gamma = header["hud"]["gamma"].as_f64().unwrap();
    assert!((gamma - 1.0 / (1.0f64 - 0.09).sqrt()).abs() < 1e-12);
    // Looking along its motion the camera sees light blue-shifted ahead: D < 1 somewhere.
    assert!(header["hud"]["doppler_min"].as_f64().unwrap() < 1.0);
    assert_eq!(&bytes[4 + n..4 + n + 2], &[0xFF, 0xD8], "a JPEG");
    // A state at the speed of light is refused with its sequence number; the socket goes on.
    let mut bad = state.clone();
    bad["beta"] = json!([0.0, 0.0, 1.0]);
    socket
        .send(Message::text(json!({"seq": 8, "state": bad}).to_string()))
        .unwrap();
    let Message::Text(text) = socket.read().unwrap() else {
        panic!("a refusal is text")
    };
    let refusal: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(refusal["seq"], 8);
    assert!(refusal["error"]
        .as_str()
        .unwrap()
        .contains("slower than light"));
    socket
        .send(Message::text(json!({"seq": 9, "state": state}).to_string()))
        .unwrap();
    assert!(matches!(socket.read().unwrap(), Message::Binary(_)));
    // A second tab: both sockets in flight at once, each answered.
    let mut other = server.ws();
    for seq in 10..14 {
        let small = json!({"seq": seq, "scale": 0.25, "state": state}).to_string();
        socket.send(Message::text(small.clone())).unwrap();
        other.send(Message::text(small)).unwrap();
        for s in [&mut socket, &mut other] {
            let Message::Binary(b) = s.read().unwrap() else {
                panic!("a frame")
            };
            let n = u32::from_le_bytes(b[..4].try_into().unwrap()) as usize;
            let header: Value = serde_json::from_slice(&b[4..4 + n]).unwrap();
            assert_eq!(header["seq"], seq);
        }
    }
}

/// Pixels of a PNG in either lighter shade of the dark marks (unseen hatch, masked
/// cross-hatch: `femto::render::dark`).
fn marked_pixels(png: &[u8]) -> usize {
    use femto::render::dark::{MASKED_RGB, UNSEEN_RGB};
    let img = image::load_from_memory(png).expect("a PNG").to_rgb8();
    img.pixels()
        .filter(|p| p.0 == UNSEEN_RGB[1] || p.0 == MASKED_RGB[1])
        .count()
}

#[test]
fn femto_render_draws_the_dark_marks_of_the_viewer_behind_its_flag_and_not_without() {
    let fx = fixture();
    let server = Server::start(&fx.root);
    let info = info(&server);
    // At rest, moved sideways by a fifth of the scene's extent: points the capture never saw
    // come into view.
    let mut state = moving_state(&info, 0.0);
    let right: Vec<f64> = (0..3)
        .map(|i| state["world_from_camera"][i][0].as_f64().unwrap())
        .collect();
    let step = 10.0 * info["move_step_m"].as_f64().unwrap();
    for (i, r) in right.iter().enumerate() {
        let p = state["position_m"][i].as_f64().unwrap();
        state["position_m"][i] = json!(p + step * r);
    }
    assert_eq!(
        state["dark_marks"],
        json!(true),
        "the viewer marks dark pixels by default"
    );
    let body = serde_json::to_vec(&state).unwrap();
    let (status, still) = request("POST", &format!("{}/api/still", server.url), Some(&body));
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&still));
    let (_, toml) = request(
        "POST",
        &format!("{}/api/state.toml", server.url),
        Some(&body),
    );
    let toml = String::from_utf8(toml).unwrap();
    assert!(toml.contains("--dark-marks"), "{toml}");
    let marked = render_path(&fx.root, &toml, "marks_on");
    assert!(
        marked[0] == still,
        "femto render --dark-marks differs from the still"
    );
    let plain = render_path(&fx.root, &toml.replace(" --dark-marks", ""), "marks_off");
    let (with, without) = (marked_pixels(&marked[0]), marked_pixels(&plain[0]));
    assert!(
        with > 500 && without < with / 50,
        "marked pixels: {with} with --dark-marks, {without} without"
    );
}
