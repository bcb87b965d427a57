//! `femto view` end to end: the binary started as a user starts it, with defaults, on a
//! small simulated capture with `--realistic` flaws taken through the chain; its HTTP API
//! (stills bit-identical to `femto render`, keyframes, path export), hostile requests, who
//! it answers (token, Host, Origin) and how many renders it runs at once, and the page in a
//! real browser (headless Chromium driven over WebDriver).

#[path = "../common/cli.rs"]
mod cli;

mod access;
mod api;
mod browser;
mod explorer;
mod hostile;
mod lying_client;

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// A capture of the built-in `cube` scene, 32 x 24 (or `FEMTO_VIEW_CAPTURE`, e.g. `160x120`
/// for the README's screenshot), with realistic flaws, taken through ingest, calibrate,
/// unwarp and pyramid with defaults.
pub fn fixture() -> &'static cli::Fixture {
    static FIXTURE: OnceLock<cli::Fixture> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        cli::realistic_chain(
            &std::env::var("FEMTO_VIEW_CAPTURE").unwrap_or_else(|_| "32x24".into()),
        )
    })
}

/// The input flags of `femto view` and `femto render` for the fixture.
pub fn input_args(root: &Path) -> Vec<String> {
    [
        ("--cube", "world.h5"),
        ("--calibration", "cube.calibration.toml"),
        ("--mesh", "cap/scene.glb"),
    ]
    .iter()
    .flat_map(|(flag, file)| [flag.to_string(), root.join(file).display().to_string()])
    .collect()
}

/// The token of each server the tests started, by its base URL: [`request`] sends it.
static TOKENS: Mutex<BTreeMap<String, String>> = Mutex::new(BTreeMap::new());

/// The token of the server whose base URL starts `url`.
pub fn token_of(url: &str) -> Option<String> {
    let tokens = TOKENS.lock().unwrap_or_else(|p| p.into_inner());
    tokens
        .iter()
        .find(|(base, _)| url.starts_with(base.as_str()))
        .map(|(_, t)| t.clone())
}

/// A running `femto view` on a free port; stopped with SIGINT when dropped.
pub struct Server {
    child: Child,
    /// `http://127.0.0.1:PORT`, without the token.
    pub url: String,
    /// This run's token.
    pub token: String,
    stderr: Option<std::thread::JoinHandle<String>>,
}

impl Server {
    pub fn start(root: &Path) -> Server {
        Server::start_with(root, None)
    }

    /// Start under an address-space limit of `ulimit_kb` kB (`ulimit -v`), when given.
    pub fn start_with(root: &Path, ulimit_kb: Option<u64>) -> Server {
        Server::launch(&input_args(root), 0, ulimit_kb)
    }

    /// Start on the inputs `inputs` (`--cube ... --mesh ...`) and `port` (0: a free one).
    pub fn start_on(inputs: &[String], port: u16) -> Server {
        Server::launch(inputs, port, None)
    }

    fn launch(inputs: &[String], port: u16, ulimit_kb: Option<u64>) -> Server {
        let bin = env!("CARGO_BIN_EXE_femto");
        let mut command = match ulimit_kb {
            Some(kb) => {
                let mut c = Command::new("sh");
                c.arg("-c")
                    .arg(format!("ulimit -v {kb} && exec \"$0\" \"$@\""))
                    .arg(bin);
                c
            }
            None => Command::new(bin),
        };
        let mut child = command
            .arg("view")
            .args(inputs)
            .args(["--port", &port.to_string()])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("femto view starts");
        let mut stdout = BufReader::new(child.stdout.take().expect("stdout"));
        let mut url = String::new();
        stdout
            .read_line(&mut url)
            .expect("femto view prints its URL");
        let line = url.trim().to_string();
        assert!(
            line.starts_with("http://127.0.0.1:"),
            "first line: {line:?}"
        );
        let (url, token) = line
            .split_once("/?token=")
            .unwrap_or_else(|| panic!("first line without ?token=: {line:?}"));
        assert!(
            token.len() == 64 && token.bytes().all(|b| b.is_ascii_hexdigit()),
            "token: {token:?}"
        );
        let (url, token) = (url.to_string(), token.to_string());
        TOKENS
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .insert(url.clone(), token.clone());
        let mut stderr = child.stderr.take().expect("stderr");
        let stderr = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = stderr.read_to_string(&mut s);
            s
        });
        Server {
            child,
            url,
            token,
            stderr: Some(stderr),
        }
    }

    /// The URL to open in a browser: the page with the token.
    pub fn page_url(&self) -> String {
        format!("{}/?token={}", self.url, self.token)
    }

    /// A WebSocket request for the frame stream, with the token unless `token` is None and
    /// with `origin` as its Origin header when given.
    pub fn ws_request(
        &self,
        token: Option<&str>,
        origin: Option<&str>,
    ) -> tungstenite::handshake::client::Request {
        use tungstenite::client::IntoClientRequest;
        let mut r = (self.url.replace("http://", "ws://") + "/ws")
            .into_client_request()
            .expect("a WebSocket URL");
        if let Some(t) = token {
            let value = format!("token {t}").parse().expect("a header value");
            r.headers_mut().insert("Authorization", value);
        }
        if let Some(o) = origin {
            r.headers_mut()
                .insert("Origin", o.parse().expect("a header value"));
        }
        r
    }

    /// The frame stream, opened with the token.
    pub fn ws(
        &self,
    ) -> tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<std::net::TcpStream>> {
        tungstenite::connect(self.ws_request(Some(&self.token), None))
            .expect("the WebSocket opens")
            .0
    }

    /// Stop with SIGINT (Ctrl-C) and return the exit code and what it printed on stderr.
    pub fn stop(mut self) -> (Option<i32>, String) {
        self.interrupt()
    }

    fn interrupt(&mut self) -> (Option<i32>, String) {
        // SAFETY: kill(2) with the child's own pid.
        unsafe {
            libc::kill(self.child.id() as i32, libc::SIGINT);
        }
        let started = Instant::now();
        let code = loop {
            if let Some(status) = self.child.try_wait().expect("wait") {
                break status.code();
            }
            if started.elapsed() > Duration::from_secs(10) {
                let _ = self.child.kill();
                panic!("femto view did not stop within 10 s of SIGINT");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let err = self
            .stderr
            .take()
            .map(|h| h.join().unwrap_or_default())
            .unwrap_or_default();
        (code, err)
    }

    /// Whether the process is still running.
    pub fn alive(&mut self) -> bool {
        self.child.try_wait().expect("wait").is_none()
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if self.stderr.is_some() {
            let _ = self.interrupt();
        }
    }
}

/// An HTTP agent that hands back 4xx and 5xx replies instead of failing on them.
pub fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(Duration::from_secs(60)))
        .build()
        .into()
}

/// Status and body of a request as a script sends it: with the server's token
/// (`Authorization: token ...`) and, with a body, its content type (`application/toml` for
/// `/api/path`, else `application/json`).
pub fn request(method: &str, url: &str, body: Option<&[u8]>) -> (u16, Vec<u8>) {
    let mut headers = Vec::new();
    if let Some(t) = token_of(url) {
        headers.push(("Authorization", format!("token {t}")));
    }
    if body.is_some() {
        let path = url.split('?').next().unwrap_or(url);
        let json = if path.ends_with("/api/path") {
            "application/toml"
        } else {
            "application/json"
        };
        headers.push(("Content-Type", json.to_string()));
    }
    let (status, _, body) = request_with(method, url, body, &headers);
    (status, body)
}

/// Status, headers and body of a request with exactly `headers` besides the client's own.
pub fn request_with(
    method: &str,
    url: &str,
    body: Option<&[u8]>,
    headers: &[(&str, String)],
) -> (u16, Vec<(String, String)>, Vec<u8>) {
    let agent = agent();
    let mut response = match (method, body) {
        ("GET", _) => headers
            .iter()
            .fold(agent.get(url), |r, (k, v)| r.header(*k, v))
            .call(),
        ("DELETE", _) => headers
            .iter()
            .fold(agent.delete(url), |r, (k, v)| r.header(*k, v))
            .call(),
        ("POST", b) => headers
            .iter()
            .fold(agent.post(url), |r, (k, v)| r.header(*k, v))
            .send(b.unwrap_or(&[])),
        ("PUT", Some(b)) => headers
            .iter()
            .fold(agent.put(url), |r, (k, v)| r.header(*k, v))
            .send(b),
        _ => panic!("{method} not used by the tests"),
    }
    .unwrap_or_else(|e| panic!("{method} {url}: {e}"));
    let status = response.status().as_u16();
    let reply_headers = response
        .headers()
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_str().unwrap_or("").to_string()))
        .collect();
    let body = response
        .body_mut()
        .with_config()
        .limit(64 << 20)
        .read_to_vec()
        .expect("a body");
    (status, reply_headers, body)
}

/// Whether tests that need an outside program must run (CI) rather than say they skipped.
pub fn required() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

/// Send `raw` as it is (no client normalises the path) and return the status and body.
pub fn raw_request(url: &str, raw: &str) -> (u16, String) {
    let addr = url.trim_start_matches("http://");
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    std::io::Write::write_all(&mut s, raw.as_bytes()).unwrap();
    let mut reply = String::new();
    let _ = s.read_to_string(&mut reply);
    let status = reply
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = reply.split("\r\n\r\n").nth(1).unwrap_or("").to_string();
    (status, body)
}
