//! `femto view` end to end: the binary started as a user starts it, with defaults, on a
//! small simulated capture with `--realistic` flaws taken through the chain; its HTTP API
//! (stills bit-identical to `femto render`, keyframes, path export), hostile requests, and
//! the page in a real browser (headless Chromium driven over WebDriver).

#[path = "../common/cli.rs"]
mod cli;

mod api;
mod browser;
mod hostile;

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
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

/// A running `femto view` on a free port; stopped with SIGINT when dropped.
pub struct Server {
    child: Child,
    pub url: String,
    stderr: Option<std::thread::JoinHandle<String>>,
}

impl Server {
    pub fn start(root: &Path) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_femto"))
            .arg("view")
            .args(input_args(root))
            .args(["--port", "0"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("femto view starts");
        let mut stdout = BufReader::new(child.stdout.take().expect("stdout"));
        let mut url = String::new();
        stdout
            .read_line(&mut url)
            .expect("femto view prints its URL");
        let url = url.trim().trim_end_matches('/').to_string();
        assert!(url.starts_with("http://127.0.0.1:"), "first line: {url:?}");
        let mut stderr = child.stderr.take().expect("stderr");
        let stderr = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = stderr.read_to_string(&mut s);
            s
        });
        Server {
            child,
            url,
            stderr: Some(stderr),
        }
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

/// Status and body of a request.
pub fn request(method: &str, url: &str, body: Option<&[u8]>) -> (u16, Vec<u8>) {
    let agent = agent();
    let mut response = match (method, body) {
        ("GET", _) => agent.get(url).call(),
        ("DELETE", _) => agent.delete(url).call(),
        ("POST", Some(b)) => agent.post(url).send(b),
        ("POST", None) => agent.post(url).send_empty(),
        ("PUT", Some(b)) => agent.put(url).send(b),
        _ => panic!("{method} not used by the tests"),
    }
    .unwrap_or_else(|e| panic!("{method} {url}: {e}"));
    let status = response.status().as_u16();
    let body = response
        .body_mut()
        .with_config()
        .limit(64 << 20)
        .read_to_vec()
        .expect("a body");
    (status, body)
}

/// Whether tests that need an outside program must run (CI) rather than say they skipped.
pub fn required() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}
