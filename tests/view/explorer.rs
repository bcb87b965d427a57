//! The explorer as a first-time user meets it (issue 42), in headless Chromium at 1280 x 800
//! through real input events, on the world cube of `femto demo --quick` as `femto view
//! --cube ... --calibration ... --mesh ...` serves it: light that follows the camera, Play
//! that stays in the scene and never shows a black frame, the kinds of dark drawn apart, a
//! still and a video saved from the page, the pixel probe, the state in the URL, a tab told
//! that its server restarted, honest colour and readouts, and a layout that holds still.

use super::browser::{Browser, ELEMENT};
use super::{cli, request, required, Server};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// `femto demo --quick`'s data folder (made once), and the flags that serve its world cube.
fn demo() -> &'static (tempfile::TempDir, Vec<String>) {
    static DEMO: OnceLock<(tempfile::TempDir, Vec<String>)> = OnceLock::new();
    DEMO.get_or_init(|| {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let out = dir.path().join("demo");
        cli::FemtoCmd::new()
            .args(["demo", "--quick", "--out"])
            .arg(&out)
            .ok();
        let data = out.join("data");
        let inputs = [
            ("--cube", data.join("world.h5")),
            ("--calibration", data.join("calibration.toml")),
            ("--mesh", data.join("capture/scene.glb")),
        ]
        .iter()
        .flat_map(|(flag, p)| [flag.to_string(), p.display().to_string()])
        .collect();
        (dir, inputs)
    })
}

/// FNV-1a of `bytes`, as the page's test hook computes it for what it saved.
fn fnv1a(bytes: &[u8]) -> u32 {
    bytes.iter().fold(0x811c_9dc5u32, |h, &b| {
        (h ^ b as u32).wrapping_mul(0x0100_0193)
    })
}

impl Browser {
    fn hud(&self) -> Value {
        self.run("return window.femto.hud")
    }

    fn lit_fraction(&self) -> f64 {
        self.hud()["lit_fraction"].as_f64().unwrap_or(0.0)
    }

    fn element(&self, css: &str) -> String {
        let found = self
            .call(
                "POST",
                "/element",
                Some(json!({"using": "css selector", "value": css})),
            )
            .unwrap_or_else(|e| panic!("{css}: {e}"));
        found[ELEMENT].as_str().expect("an element id").to_string()
    }

    /// Type `text` into the field `css` (cleared first) and leave it with Tab, as a user does.
    fn type_into(&self, css: &str, text: &str) {
        let id = self.element(css);
        self.call("POST", &format!("/element/{id}/clear"), Some(json!({})))
            .expect("the field clears");
        self.call(
            "POST",
            &format!("/element/{id}/value"),
            Some(json!({ "text": format!("{text}\u{E004}") })),
        )
        .expect("typed");
    }

    /// A real mouse click on pixel `(i, j)` of the picture (frame pixels, scaled to the
    /// canvas's size on screen).
    fn click_pixel(&self, i: usize, j: usize) {
        let r = self.run(
            "const c = document.getElementById('view'), r = c.getBoundingClientRect(); \
             return [r.width / c.width, r.height / c.height, r.width, r.height];",
        );
        let f = |k: usize| r[k].as_f64().unwrap();
        // Offsets from the element's centre, CSS pixels.
        let x = ((i as f64 + 0.5) * f(0) - f(2) / 2.0).round() as i64;
        let y = ((j as f64 + 0.5) * f(1) - f(3) / 2.0).round() as i64;
        let id = self.element("#view");
        let origin = json!({ ELEMENT: id });
        self.call(
            "POST",
            "/actions",
            Some(json!({"actions": [{"type": "pointer", "id": "mouse",
            "parameters": {"pointerType": "mouse"},
            "actions": [
                {"type": "pointerMove", "origin": origin, "x": x, "y": y},
                {"type": "pointerDown", "button": 0},
                {"type": "pointerUp", "button": 0}
            ]}]})),
        )
        .expect("a click");
    }

    /// Positions of the controls that must not move when a text changes.
    fn control_rects(&self) -> Value {
        self.run(
            "const r = (id) => { const b = document.getElementById(id).getBoundingClientRect(); \
               return [Math.round(b.left), Math.round(b.top), Math.round(b.width)]; }; \
             return ['play', 'time', 'light-curve', 'view', 'spectrum'].map(r);",
        )
    }

    /// Make the page's viewport `width` x `height` (the window is larger by its frame).
    fn set_viewport(&self, width: u32, height: u32) {
        let frame = self.run("return [outerWidth - innerWidth, outerHeight - innerHeight]");
        let (fw, fh) = (
            frame[0].as_u64().unwrap() as u32,
            frame[1].as_u64().unwrap() as u32,
        );
        self.call(
            "POST",
            "/window/rect",
            Some(json!({"width": width + fw, "height": height + fh})),
        )
        .expect("the window resizes");
    }
}

fn start_browser() -> Option<Browser> {
    match Browser::start() {
        Ok(b) => Some(b),
        Err(why) if !required() => {
            eprintln!("SKIPPED the explorer test: {why} (apt-get install chromium chromium-driver; .ci/run does)");
            None
        }
        Err(why) => panic!("CI=true and the explorer test cannot run: {why}"),
    }
}

/// Where the screenshots go: `FEMTO_VIEW_SHOTS` (docs/view.md's pictures), else a temporary
/// folder.
fn shots(fallback: &Path) -> PathBuf {
    std::env::var_os("FEMTO_VIEW_SHOTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| fallback.to_path_buf())
}

#[test]
#[cfg_attr(
    femto_skip_browser,
    ignore = "needs chromium and chromedriver on PATH (apt-get install chromium chromium-driver)"
)]
fn the_explorer_keeps_the_light_in_view_plays_in_the_scene_and_saves_what_it_shows() {
    let Some(browser) = start_browser() else {
        return;
    };
    let (dir, inputs) = demo();
    let shots = shots(dir.path());
    std::fs::create_dir_all(&shots).unwrap();
    let server = Server::start_on(inputs, 0);
    browser
        .call("POST", "/url", Some(json!({"url": server.page_url()})))
        .expect("the page loads");
    browser.wait_settled("the first frame");
    let first_lit = browser.lit_fraction();
    assert!(first_lit > 0.02, "the first view is dark: {first_lit}");

    // Honest colour at rest: nothing is shifted, and the legend says so.
    let legend = browser.run("return document.getElementById('legend-text').textContent");
    let legend = legend.as_str().unwrap().to_lowercase();
    assert!(
        legend.contains("at rest nothing is shifted") && !legend.contains("shifted out"),
        "{legend}"
    );

    // 1. Five real presses of W: the light curve follows the camera, and the picture keeps
    // at least a quarter of the first view's light.
    let rects = browser.control_rects();
    let curve_before = browser.run("return window.femto.curve.lit_range_ps");
    browser.keys(&["w", "w", "w", "w", "w"]);
    browser.wait_settled("the frame after five presses of W");
    let lit = browser.lit_fraction();
    assert!(
        lit >= 0.25 * first_lit,
        "after five presses of W {lit} lit, the first view {first_lit}; curve {curve_before} -> {}",
        browser.run("return window.femto.curve.lit_range_ps")
    );
    let t = browser
        .run("return window.femto.state.t_world_ps")
        .as_f64()
        .unwrap();
    let lit_range = browser.run("return window.femto.curve.lit_range_ps");
    assert!(
        t >= lit_range[0].as_f64().unwrap() && t <= lit_range[1].as_f64().unwrap(),
        "the cursor {t} left the view's lit range {lit_range}"
    );
    browser.screenshot(&shots.join("view_after_w.png"));

    // 2. Play at beta 0.9 (typed) with a 60 ps interval: never black at 4, 8 and 12 s, the
    // camera stays in front of the geometry and comes back at each loop; Space pauses.
    browser.type_into("#beta-num", "0.9");
    browser.type_into("#dtau", "60");
    browser.wait_settled("the frame at beta 0.9");
    let start = browser.run("return window.femto.state.position_m");
    let travel = browser.run("return window.femto.curve.travel_m");
    browser.click("#play");
    let play_rects = browser.control_rects();
    let played = Instant::now();
    for (k, at) in [4u64, 8, 12].iter().enumerate() {
        while played.elapsed() < Duration::from_secs(*at) {
            std::thread::sleep(Duration::from_millis(50));
        }
        let (mean, max, _) = browser.canvas();
        let shot = shots.join(format!("view_play_{at}s.png"));
        browser.screenshot(&shot);
        assert!(
            max > 30.0 && mean > 0.2 && browser.lit_fraction() > 0.0,
            "black while playing at {at} s (shot {k}): mean {mean}, max {max}, {}",
            browser.hud()
        );
        let p = browser.run("return window.femto.state.position_m");
        let moved: f64 = (0..3)
            .map(|i| (p[i].as_f64().unwrap() - start[i].as_f64().unwrap()).powi(2))
            .sum::<f64>()
            .sqrt();
        if let Some(room) = travel.as_f64() {
            assert!(moved <= room + 1e-6, "moved {moved} m, room {room} m");
        }
    }
    assert_eq!(
        browser.run("return window.femto.playing"),
        json!(true),
        "Play stopped by itself"
    );
    assert_eq!(play_rects, rects, "a control moved when Play became Pause");
    browser.keys(&["\u{E00D}"]);
    browser.wait_settled("paused with Space");
    assert_eq!(browser.run("return window.femto.playing"), json!(false));

    // 3. At rest, moved sideways to see what the capture camera did not: the dark kinds
    // drawn apart, and told by the probe of a clicked pixel.
    browser.click("#reset");
    browser.wait_settled("the capture view again");
    browser.keys(&["d", "d", "d", "d", "d", "d", "d", "d"]);
    browser.wait_settled("the view from the side");
    browser.screenshot(&shots.join("view_dark_kinds.png"));
    let state = browser.run("return window.femto.state");
    let kinds = find_kinds(&server, &state);
    for (kind, (i, j)) in &kinds {
        browser.click_pixel(*i, *j);
        browser.wait_for(
            &format!(
                "const p = window.femto.probe; return !!p && p.pixel[0] === {i} && p.pixel[1] === {j};"
            ),
            30,
            "the probe of a clicked pixel",
        );
        let probe = browser.run("return window.femto.probe");
        assert_eq!(probe["kind"], json!(kind), "{probe}");
        if kind == "seen" {
            assert!(probe["point_m"].is_array() && probe["distance_m"].as_f64().unwrap() > 0.0);
            assert!(
                probe["capture"]["value"].as_array().unwrap().len() > 1,
                "{probe}"
            );
            assert!(probe["received"]["value"]
                .as_array()
                .unwrap()
                .iter()
                .any(|v| v.as_f64().unwrap() > 0.0));
            browser.screenshot(&shots.join("view_probe.png"));
        }
    }
    let still_state = browser.run("return window.femto.state");
    let body = serde_json::to_vec(&still_state).unwrap();
    let (status, png) = request("POST", &format!("{}/api/still", server.url), Some(&body));
    assert_eq!(status, 200);
    let img = image::load_from_memory(&png).unwrap().to_rgb8();
    let has = |rgb: [u8; 3]| img.pixels().any(|p| p.0 == rgb);
    assert!(
        has(femto::render::dark::UNSEEN_RGB[1]),
        "no unseen hatch in the capture view's still"
    );

    // 4. Save PNG: the bytes of /api/still, which are femto render's (tests/view/api.rs).
    browser.click("#save-still");
    browser.wait_for(
        "const s = window.femto.lastSave; return !!s && s.name.endsWith('.png');",
        30,
        "the saved still",
    );
    let saved = browser.run("return window.femto.lastSave");
    assert_eq!(saved["hash"], json!(fnv1a(&png)), "{saved}");
    browser.click("#reset");
    browser.wait_settled("the capture view before the keyframes");

    // 5. Keyframes: preview in place (readouts follow the path), then save a video.
    browser.click("#add-keyframe");
    browser.type_into("#beta-num", "0.3");
    browser.keys(&["w", "w"]);
    browser.wait_settled("the second keyframe's view");
    let t2 = browser
        .run("return window.femto.state.t_world_ps")
        .as_f64()
        .unwrap();
    browser.run(&format!(
        "const e = document.getElementById('time'); e.value = '{}'; \
         e.dispatchEvent(new Event('input', {{bubbles: true}}));",
        t2 + 300.0
    ));
    browser.wait_settled("the second keyframe's time");
    browser.click("#add-keyframe");
    browser.click("#preview-path");
    browser.wait_for(
        "return window.femto.playing === true",
        20,
        "the preview plays",
    );
    browser.wait_for(
        "const b = document.getElementById('beta-num').value; \
         const s = window.femto.state.beta; \
         return Math.abs(+b - Math.hypot(s[0], s[1], s[2])) < 6e-4;",
        20,
        "the typed beta field follows the previewed path",
    );
    browser.wait_for(
        "return window.femto.playing === false",
        120,
        "the preview ends",
    );
    browser.click("#save-video");
    browser.wait_for(
        "const s = window.femto.lastSave; return !!s && s.name.endsWith('.mp4');",
        300,
        "the saved video",
    );
    let saved = browser.run("return window.femto.lastSave");
    assert!(saved["bytes"].as_u64().unwrap() > 1000, "{saved}");
    assert!(
        browser
            .run("return window.femto.videoFramesSeen")
            .as_u64()
            .unwrap()
            > 1,
        "no progress was shown while the video rendered"
    );

    // 6. The laser field: -5 and 1e9 are refused in the status line and put back; frames go on.
    for bad in ["-5", "1e9"] {
        browser.type_into("#laser", bad);
        browser.wait_for(
            "return document.getElementById('status').textContent.startsWith('laser:')",
            10,
            "the refusal of a bad wavelength",
        );
        let field = browser.run("return document.getElementById('laser').value");
        assert_ne!(field, json!(bad), "the bad wavelength stayed in the field");
    }
    browser.keys(&["s"]);
    browser.wait_settled("a frame after the refused wavelengths");
    assert_eq!(browser.run("return window.femto.error"), Value::Null);

    // 7. The state lives in the URL: a reload keeps the camera.
    let before = browser.position();
    browser
        .call("POST", "/refresh", Some(json!({})))
        .expect("the page reloads");
    browser.wait_settled("the first frame after a reload");
    assert_eq!(browser.position(), before, "a reload lost the camera");

    // 8. The layout: every part of the stage in a viewport from 1024 x 700 to 1920 x 1080,
    // and the picture drawn at its own size when it fits.
    for (w, h) in [(1024, 700), (1920, 1080)] {
        browser.set_viewport(w, h);
        std::thread::sleep(Duration::from_millis(300));
        let fits = browser.run(
            "const v = (id) => document.getElementById(id).getBoundingClientRect(); \
             const inside = (r) => r.left >= 0 && r.top >= 0 && r.right <= innerWidth + 1 && r.bottom <= innerHeight + 1; \
             const c = document.getElementById('view'); \
             return {stage: ['hud', 'view', 'play', 'time', 'spectrum', 'status'].filter((id) => !inside(v(id))).map((id) => [id, JSON.stringify(v(id)), innerWidth, innerHeight]), \
                     hud: document.getElementById('hud').scrollHeight <= document.getElementById('hud').clientHeight + 1, \
                     scale: v('view').width / c.width};",
        );
        assert_eq!(
            fits["stage"],
            json!([]),
            "{w} x {h}: outside the window: {fits}"
        );
        assert_eq!(
            fits["hud"],
            json!(true),
            "{w} x {h}: the heads-up line wraps"
        );
        if w == 1920 {
            assert!(
                (fits["scale"].as_f64().unwrap() - 1.0).abs() < 1e-3,
                "{fits}"
            );
        }
    }
    browser.set_viewport(1280, 800);

    // 9. A restarted server: the open tab is told to open the new URL.
    let port: u16 = server.url.rsplit(':').next().unwrap().parse().unwrap();
    drop(server);
    let _again = Server::start_on(inputs, port);
    browser.wait_for(
        "return document.getElementById('status').textContent.includes('restarted')",
        30,
        "the tab told that the server restarted",
    );
}

/// A pixel of each kind in `state`'s frame, found through the probe API: `seen` (with
/// light now), `unseen` (the capture never saw it).
fn find_kinds(server: &Server, state: &Value) -> Vec<(String, (usize, usize))> {
    let (w, h) = (
        state["width"].as_u64().unwrap() as usize,
        state["height"].as_u64().unwrap() as usize,
    );
    let body = serde_json::to_vec(state).unwrap();
    let t = state["t_world_ps"].as_f64().unwrap();
    let mut found: Vec<(String, (usize, usize))> = Vec::new();
    for gj in 1..12 {
        for gi in 1..16 {
            let (i, j) = (gi * w / 16, gj * h / 12);
            let (status, reply) = request(
                "POST",
                &format!(
                    "{}/api/probe?x={i}&y={j}&t0={}&t1={}",
                    server.url,
                    t - 500.0,
                    t + 500.0
                ),
                Some(&body),
            );
            assert_eq!(status, 200, "{}", String::from_utf8_lossy(&reply));
            let p: Value = serde_json::from_slice(&reply).unwrap();
            let kind = p["kind"].as_str().unwrap().to_string();
            let lit_now = p["value"].as_f64().unwrap() > 0.0;
            let wanted = (kind == "seen" && lit_now) || kind == "unseen";
            if wanted && !found.iter().any(|(k, _)| *k == kind) {
                found.push((kind, (i, j)));
            }
        }
    }
    let names: Vec<&str> = found.iter().map(|(k, _)| k.as_str()).collect();
    assert!(
        names.contains(&"seen") && names.contains(&"unseen"),
        "the capture view lacks a lit or an unseen pixel: {names:?}"
    );
    found
}
