//! The page in a real browser: headless Chromium from the distribution's packages, driven
//! over the W3C WebDriver protocol (plain HTTP to chromedriver). `.ci/run` installs
//! `chromium` and `chromium-driver` when they are absent; without them this test says it
//! skipped, and fails under `CI=true`.

use super::api::render_path;
use super::{agent, fixture, request, required, Server};
use base64::Engine;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

pub const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

fn find_program(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    names.iter().find_map(|name| {
        std::env::split_paths(&path)
            .map(|dir| dir.join(name))
            .find(|p| p.is_file())
    })
}

/// A chromedriver process and one headless Chromium session.
pub struct Browser {
    driver: Child,
    base: String,
    _profile: tempfile::TempDir,
}

impl Browser {
    /// Start chromedriver and a session, or None (with the reason) when either program is
    /// missing.
    pub fn start() -> Result<Browser, String> {
        let driver = find_program(&["chromedriver"]).ok_or("chromedriver is not installed")?;
        let chromium = find_program(&["chromium", "chromium-browser", "google-chrome"])
            .ok_or("chromium is not installed")?;
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map_err(|e| e.to_string())?
            .port();
        let child = Command::new(driver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("chromedriver: {e}"))?;
        let profile = tempfile::tempdir().map_err(|e| e.to_string())?;
        let mut browser = Browser {
            driver: child,
            base: format!("http://127.0.0.1:{port}"),
            _profile: profile,
        };
        let started = Instant::now();
        while agent()
            .get(format!("{}/status", browser.base))
            .call()
            .is_err()
        {
            if started.elapsed() > Duration::from_secs(20) {
                return Err("chromedriver did not answer within 20 s".into());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": chromium,
                "args": ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                         "--no-first-run", "--disable-background-networking",
                         "--disable-component-update", "--disable-sync",
                         "--window-size=1280,800",
                         format!("--user-data-dir={}", browser._profile.path().display())]
            }
        }}});
        let session = browser.call("POST", "/session", Some(caps))?;
        let id = session["sessionId"]
            .as_str()
            .ok_or_else(|| format!("no session: {session}"))?;
        browser.base = format!("{}/session/{id}", browser.base);
        Ok(browser)
    }

    pub fn call(&self, method: &str, path: &str, body: Option<Value>) -> Result<Value, String> {
        let url = format!("{}{path}", self.base);
        let agent = agent();
        let reply = match method {
            "GET" => agent.get(&url).call(),
            "DELETE" => agent.delete(&url).call(),
            _ => agent
                .post(&url)
                .header("Content-Type", "application/json")
                .send(&serde_json::to_vec(&body.unwrap_or(json!({}))).expect("JSON")[..]),
        };
        let mut reply = reply.map_err(|e| format!("{method} {path}: {e}"))?;
        let bytes = reply
            .body_mut()
            .with_config()
            .limit(64 << 20)
            .read_to_vec()
            .map_err(|e| format!("{method} {path}: {e}"))?;
        let value: Value =
            serde_json::from_slice(&bytes).map_err(|e| format!("{method} {path}: {e}"))?;
        if reply.status().as_u16() != 200 {
            return Err(format!("{method} {path}: {}", value["value"]));
        }
        Ok(value["value"].clone())
    }

    pub fn run(&self, script: &str) -> Value {
        self.call(
            "POST",
            "/execute/sync",
            Some(json!({"script": script, "args": []})),
        )
        .unwrap_or_else(|e| panic!("{script}: {e}"))
    }

    pub fn click(&self, css: &str) {
        let found = self
            .call(
                "POST",
                "/element",
                Some(json!({"using": "css selector", "value": css})),
            )
            .unwrap_or_else(|e| panic!("{css}: {e}"));
        let id = found[ELEMENT]
            .as_str()
            .unwrap_or_else(|| panic!("{css}: no element in {found}"))
            .to_string();
        self.call("POST", &format!("/element/{id}/click"), Some(json!({})))
            .unwrap_or_else(|e| panic!("click {css}: {e}"));
    }

    /// Wait until `script` returns true, up to `seconds`.
    pub fn wait_for(&self, script: &str, seconds: u64, what: &str) {
        let started = Instant::now();
        while self.run(script) != json!(true) {
            if started.elapsed() > Duration::from_secs(seconds) {
                let status = self.run("return document.getElementById('status').textContent");
                panic!("{what}: not within {seconds} s (page status: {status})");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Wait until the page has shown a full-resolution frame of its current state and has
    /// nothing more to send.
    pub fn wait_settled(&self, what: &str) {
        self.wait_for(
            "const f = window.femto; return !!(f && f.hud && f.hud.width === f.state.width \
             && f.settled);",
            60,
            what,
        );
    }

    /// Mean and largest value of the canvas's RGB, and a hash of its pixels.
    pub fn canvas(&self) -> (f64, f64, u64) {
        let v = self.run(
            "const c = document.getElementById('view'); \
             const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; \
             let s = 0, m = 0, h = 0; \
             for (let i = 0; i < d.length; i += 4) { const v = d[i] + d[i+1] + d[i+2]; \
               s += v; if (v > m) m = v; h = (h * 31 + d[i] * 7 + d[i+1] * 3 + d[i+2]) >>> 0; } \
             return [s / (3 * d.length / 4), m / 3, h];",
        );
        (
            v[0].as_f64().unwrap(),
            v[1].as_f64().unwrap(),
            v[2].as_u64().unwrap(),
        )
    }

    /// Press and release `keys` (WebDriver key values: "w", "\u{E013}" for the up arrow)
    /// as a user types them: to whatever has the focus.
    pub fn keys(&self, keys: &[&str]) {
        let actions: Vec<Value> = keys
            .iter()
            .flat_map(|k| {
                [
                    json!({"type": "keyDown", "value": k}),
                    json!({"type": "keyUp", "value": k}),
                ]
            })
            .collect();
        self.call(
            "POST",
            "/actions",
            Some(json!({"actions": [{"type": "key", "id": "keyboard", "actions": actions}]})),
        )
        .unwrap_or_else(|e| panic!("keys {keys:?}: {e}"));
    }

    /// The camera position of the page's state, as the page writes it in JSON.
    pub fn position(&self) -> String {
        self.run("return JSON.stringify(window.femto.state.position_m)")
            .as_str()
            .expect("a string")
            .to_string()
    }

    /// Set a `<select>` or range input by script, as a user's choice (a change event).
    pub fn choose(&self, id: &str, value: &str, event: &str) {
        self.run(&format!(
            "const e = document.getElementById('{id}'); e.value = '{value}'; \
             e.dispatchEvent(new Event('{event}', {{bubbles: true}}));"
        ));
    }

    pub fn screenshot(&self, to: &Path) {
        let b64 = self.call("GET", "/screenshot", None).expect("a screenshot");
        let png = base64::engine::general_purpose::STANDARD
            .decode(b64.as_str().unwrap())
            .unwrap();
        std::fs::write(to, png).unwrap();
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.call("DELETE", "", None);
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

/// The standard deviation of a screenshot's grey levels and the fraction of its pixels
/// brighter than 40: a blank page has neither.
pub fn screenshot_spread(png: &Path) -> (f64, f64) {
    let img = image::open(png).expect("a PNG screenshot").to_luma8();
    let v: Vec<f64> = img.as_raw().iter().map(|&p| p as f64).collect();
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64;
    let lit = v.iter().filter(|&&x| x > 40.0).count() as f64 / v.len() as f64;
    (var.sqrt(), lit)
}

#[test]
#[cfg_attr(
    femto_skip_browser,
    ignore = "needs chromium and chromedriver on PATH (apt-get install chromium chromium-driver)"
)]
fn the_page_shows_frames_follows_the_beta_slider_and_exports_a_path_femto_render_renders() {
    let browser = match Browser::start() {
        Ok(b) => b,
        Err(why) if !required() => {
            eprintln!("SKIPPED the browser test: {why} (apt-get install chromium chromium-driver; .ci/run does)");
            return;
        }
        Err(why) => panic!("CI=true and the browser test cannot run: {why}"),
    };
    let fx = fixture();
    let server = Server::start(&fx.root);
    // The URL femto view printed, with its token: the page's first visit sets the cookie
    // that its requests and WebSocket carry from then on.
    browser
        .call("POST", "/url", Some(json!({"url": server.page_url()})))
        .expect("the page loads");
    browser.wait_settled("the first frame");
    let shown_url = browser.run("return location.href");
    assert!(
        !shown_url.as_str().unwrap().contains("token"),
        "the token stays in the address bar: {shown_url}"
    );
    let (mean, max, _) = browser.canvas();
    assert!(
        max > 60.0 && mean > 2.0,
        "the canvas is black: mean {mean}, max {max}"
    );

    // The layout at 1280 x 800: the Keyframes and Export sections in sight without
    // scrolling; neither the panel nor the heads-up line covers the picture.
    let layout = browser.run(
        "const r = (id) => document.getElementById(id).getBoundingClientRect(); \
         const v = r('view'), p = r('panel'), h = r('hud'); \
         const apart = (a, b) => a.right <= b.left || b.right <= a.left || a.bottom <= b.top || b.bottom <= a.top; \
         return {keyframes: r('keyframes-section').bottom, export: r('export-section').bottom, \
                 viewport: innerHeight, panel: apart(v, p), hud: apart(v, h)};",
    );
    let viewport = layout["viewport"].as_f64().unwrap();
    assert!(
        layout["keyframes"].as_f64().unwrap() <= viewport
            && layout["export"].as_f64().unwrap() <= viewport,
        "Keyframes or Export below the fold: {layout}"
    );
    assert!(
        layout["panel"] == json!(true) && layout["hud"] == json!(true),
        "the picture is covered: {layout}"
    );

    // The light curve: drawn under the time slider, the first picture inside its lit range.
    let curve = browser.run(
        "const f = window.femto, c = f.curve, [a, b] = c.lit_range_ps; \
         const g = document.getElementById('light-curve'); \
         const d = g.getContext('2d').getImageData(0, 0, g.width, g.height).data; \
         let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; \
         return {samples: c.t_ps.length, inside: f.state.t_world_ps >= a && f.state.t_world_ps <= b, \
                 painted: n / (g.width * g.height)};",
    );
    assert_eq!(curve["samples"], json!(64), "{curve}");
    assert_eq!(curve["inside"], json!(true), "{curve}");
    assert!(curve["painted"].as_f64().unwrap() > 0.05, "{curve}");

    // Honest readouts: the frame rate says idle when nothing is drawn; the frame interval
    // is rounded; edge beta is off without a sensor rotation.
    std::thread::sleep(Duration::from_millis(1600));
    let readouts = browser.run(
        "return [document.getElementById('hud').textContent, \
                 document.getElementById('dtau').value, document.getElementById('spin-beta').disabled];",
    );
    assert!(readouts[0].as_str().unwrap().contains("idle"), "{readouts}");
    assert!(readouts[1].as_str().unwrap().len() <= 6, "{readouts}");
    assert_eq!(readouts[2], json!(true), "{readouts}");

    // Keys fly the camera after a click on a slider (which keeps its value) and on a button.
    let exposure = browser.run("return document.getElementById('exposure').value");
    let at = browser.position();
    browser.click("#exposure");
    browser.keys(&["\u{E013}", "\u{E013}"]);
    browser.wait_for(
        &format!("return JSON.stringify(window.femto.state.position_m) !== '{at}'"),
        10,
        "the up arrow after clicking the exposure slider moves the camera",
    );
    assert_eq!(
        browser.run("return document.getElementById('exposure').value"),
        exposure,
        "the up arrow moved the slider"
    );
    browser.click("#reset");
    let at = browser.position();
    browser.keys(&["w"]);
    browser.wait_for(
        &format!("return JSON.stringify(window.femto.state.position_m) !== '{at}'"),
        10,
        "W after clicking Reset moves the camera",
    );
    browser.click("#reset");
    browser.wait_settled("the capture view again");
    let (_, _, before) = browser.canvas();
    let range_at_rest = browser.run("return document.getElementById('legend-text').dataset.range");

    // The beta slider (forward at 0.5 c): a new frame, another picture.
    let seq = browser.run("return window.femto.shownSeq");
    browser.run(
        "const b = document.getElementById('beta'); b.value = '0.5'; \
         b.dispatchEvent(new Event('input', {bubbles: true}));",
    );
    browser.wait_for(
        &format!("return window.femto.shownSeq > {seq}"),
        30,
        "a frame after the beta slider moved",
    );
    browser.wait_settled("the frame at beta 0.5");
    let (_, max_fast, after) = browser.canvas();
    assert_ne!(before, after, "the picture did not change with beta");
    assert!(max_fast > 30.0, "black at beta 0.5");
    let hud = browser.run("return window.femto.hud");
    assert!((hud["beta"].as_f64().unwrap() - 0.5).abs() < 1e-9, "{hud}");

    // The legend: the received wavelengths move with beta; at 0.9 the Doppler toggle
    // changes the picture (its light is drawn at the laser's colour) and says what it did.
    let range_moving = browser.run("return document.getElementById('legend-text').dataset.range");
    assert_ne!(
        range_at_rest, range_moving,
        "the legend's range did not move with beta"
    );
    browser.choose("beta", "0.9", "input");
    browser.wait_settled("the frame at beta 0.9");
    let (_, _, doppler_on) = browser.canvas();
    browser.click("[data-effect=doppler]");
    browser.wait_settled("the frame at beta 0.9 without Doppler");
    let (_, _, doppler_off) = browser.canvas();
    assert_ne!(
        doppler_on, doppler_off,
        "the Doppler toggle did not change the picture at beta 0.9"
    );
    let said = browser.run(
        "return [document.getElementById('legend-text').textContent, \
                 document.getElementById('effect-note').textContent]",
    );
    assert!(
        said[0]
            .as_str()
            .unwrap()
            .to_lowercase()
            .contains("doppler off")
            && said[1].as_str().unwrap().starts_with("doppler:"),
        "{said}"
    );
    if let Some(shot) = std::env::var_os("FEMTO_VIEW_LEGEND_SCREENSHOT") {
        browser.click("[data-effect=doppler]");
        browser.wait_settled("the frame at beta 0.9 with Doppler");
        browser.screenshot(Path::new(&shot));
        browser.click("[data-effect=doppler]");
        browser.wait_settled("the frame at beta 0.9 without Doppler");
    }
    browser.click("[data-effect=doppler]");
    browser.choose("beta", "0.5", "input");
    browser.wait_settled("the frame at beta 0.5 again");

    // Isochrones: a colour bar of their times replaces the wavelength legend.
    browser.choose("view-kind", "isochrones", "change");
    browser.wait_settled("the isochrone frame");
    let iso = browser.run(
        "return [document.getElementById('iso-legend').hidden, \
                 document.getElementById('iso-text').textContent, window.femto.hud.isochrones]",
    );
    assert_eq!(iso[0], json!(false), "{iso}");
    assert!(iso[1].as_str().unwrap().contains("ps (blue)"), "{iso}");
    assert!(
        iso[2]["t_min_ps"].as_f64().unwrap() < iso[2]["t_max_ps"].as_f64().unwrap(),
        "{iso}"
    );
    browser.choose("view-kind", "transient", "change");
    browser.wait_settled("the transient frame again");

    // Two keyframes: here, and after a few frames of play.
    browser.click("#add-keyframe");
    browser.wait_for(
        "return document.querySelectorAll('#keyframes li').length === 1",
        10,
        "the first keyframe",
    );
    let shown = browser
        .run("return window.femto.framesShown")
        .as_u64()
        .unwrap();
    browser.click("#play");
    browser.wait_for(
        &format!("return window.femto.framesShown >= {}", shown + 8),
        60,
        "eight frames of play",
    );
    browser.click("#play");
    browser.wait_settled("the frame after pausing");
    browser.click("#add-keyframe");
    browser.wait_for(
        "return document.querySelectorAll('#keyframes li').length === 2",
        10,
        "the second keyframe",
    );
    // With keyframes listed the Export section is still in sight.
    let export = browser.run(
        "return document.getElementById('export-section').getBoundingClientRect().bottom <= innerHeight",
    );
    assert_eq!(
        export,
        json!(true),
        "two keyframes push Export below the fold"
    );
    browser.click("#export-path");
    browser.wait_for(
        "return document.getElementById('path-toml').value.includes('[[keyframe]]')",
        10,
        "the exported path",
    );
    let toml = browser.run("return document.getElementById('path-toml').value");
    let toml = toml.as_str().unwrap().to_string();

    let shot = std::env::var_os("FEMTO_VIEW_SCREENSHOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| fx.root.join("view.png"));
    browser.screenshot(&shot);
    eprintln!("screenshot of the page: {}", shot.display());
    let (spread, lit) = screenshot_spread(&shot);
    assert!(
        spread > 20.0 && lit > 0.02,
        "the screenshot is blank: spread {spread}, lit fraction {lit}"
    );

    // The exported path loads back into the page (Load path) and plays to its last frame.
    let path_file = fx.root.join("browser_loaded.toml");
    std::fs::write(&path_file, &toml).unwrap();
    let input = browser
        .call(
            "POST",
            "/element",
            Some(json!({"using": "css selector", "value": "#load-path"})),
        )
        .expect("the file input");
    let id = input[ELEMENT].as_str().expect("an element id").to_string();
    browser
        .call(
            "POST",
            &format!("/element/{id}/value"),
            Some(json!({"text": path_file.display().to_string()})),
        )
        .expect("a file chosen");
    browser.wait_for(
        "return document.getElementById('status').textContent.startsWith('loaded ')",
        20,
        "the path loaded",
    );
    let frames_in_path = browser.run("return document.getElementById('status').textContent");
    browser.click("#play");
    browser.wait_settled("the loaded path played to its end");
    let played_to = browser
        .run("return window.femto.state.t_world_ps")
        .as_f64()
        .unwrap();
    let (_, loaded) = request(
        "POST",
        &format!("{}/api/path", server.url),
        Some(toml.as_bytes()),
    );
    let loaded: Value = serde_json::from_slice(&loaded).unwrap();
    let last = loaded["frames"].as_array().unwrap().last().unwrap()["t_world_ps"]
        .as_f64()
        .unwrap();
    assert_eq!(
        played_to, last,
        "{frames_in_path}: play stopped before the last frame"
    );

    // A reload, without the token in the URL: the cookie lets the page in, its frames come.
    browser
        .call("POST", "/refresh", Some(json!({})))
        .expect("the page reloads");
    browser.wait_settled("the first frame after a reload");
    let (mean, max, _) = browser.canvas();
    assert!(
        max > 60.0 && mean > 2.0,
        "the canvas is black after a reload: mean {mean}, max {max}"
    );
    let listed = browser.run("return document.querySelectorAll('#keyframes li').length");
    assert_eq!(
        listed,
        json!(2),
        "the reloaded page (the same tab) lists its keyframes"
    );

    // femto render renders the exported path; its frame 0 is the first keyframe's still.
    let frames = render_path(&fx.root, &toml, "browser_path");
    assert!(frames.len() >= 8, "{} frames", frames.len());
    // The keyframes are the page's own: the server's list stays empty.
    let (_, on_server) = request("GET", &format!("{}/api/keyframes", server.url), None);
    assert_eq!(on_server, b"[]", "the page's keyframes went to the server");
    let keyframes = browser.run("return window.femto.keyframes");
    let keyframes = keyframes.as_array().unwrap();
    let body = serde_json::to_vec(&keyframes[0]).unwrap();
    let (status, still) = request("POST", &format!("{}/api/still", server.url), Some(&body));
    assert_eq!(status, 200);
    assert!(
        frames[0] == still,
        "frame 0 of the exported path differs from the keyframe's still"
    );
}
