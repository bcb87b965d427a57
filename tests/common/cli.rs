//! Running the `femto` binary as a user would, for end-to-end tests (ripgrep's `TestCommand`):
//! one place that builds the command, checks the exit code and hands back the output.
//! Included by the tests that run the binary with `#[path = "common/cli.rs"] mod cli;`
//! (not from `common/mod.rs`, which examples and benches include too).
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// What a finished `femto` run printed.
pub struct Run {
    pub stdout: String,
    pub stderr: String,
    pub code: Option<i32>,
}

/// One `femto` command line, built up and then run: the only place in the tests that starts
/// the binary, so that every end-to-end test runs it the same way (its own working folder
/// or the test's, extra environment, arguments that are paths or strings).
pub struct FemtoCmd {
    cmd: Command,
    shown: Vec<String>,
}

impl FemtoCmd {
    /// `femto` with no arguments yet, run in the test's working directory.
    pub fn new() -> FemtoCmd {
        FemtoCmd {
            cmd: Command::new(env!("CARGO_BIN_EXE_femto")),
            shown: Vec::new(),
        }
    }

    pub fn arg(mut self, a: impl AsRef<OsStr>) -> FemtoCmd {
        self.shown.push(a.as_ref().to_string_lossy().into_owned());
        self.cmd.arg(a);
        self
    }

    pub fn args<S: AsRef<OsStr>>(self, args: impl IntoIterator<Item = S>) -> FemtoCmd {
        args.into_iter().fold(self, FemtoCmd::arg)
    }

    /// Run in `dir` instead of the test's working directory.
    pub fn current_dir(mut self, dir: &Path) -> FemtoCmd {
        self.cmd.current_dir(dir);
        self
    }

    pub fn env(mut self, key: &str, value: impl AsRef<OsStr>) -> FemtoCmd {
        self.cmd.env(key, value);
        self
    }

    /// The command line as a user would type it, for failure messages.
    pub fn shown(&self) -> String {
        format!("femto {}", self.shown.join(" "))
    }

    /// The configured command, for a test that must start it itself (to signal it, to
    /// watch its memory, to limit its file sizes).
    pub fn command(self) -> Command {
        self.cmd
    }

    /// Run to the end, whatever the exit code.
    pub fn output(mut self) -> Output {
        self.cmd.output().expect("femto runs")
    }

    /// Run to the end, whatever the exit code, with the output as text.
    pub fn run(self) -> Run {
        let Output {
            status,
            stdout,
            stderr,
        } = self.output();
        Run {
            stdout: String::from_utf8_lossy(&stdout).into_owned(),
            stderr: String::from_utf8_lossy(&stderr).into_owned(),
            code: status.code(),
        }
    }

    /// Run and require exit code 0; returns what it printed.
    pub fn ok(self) -> Run {
        let shown = self.shown();
        let run = self.run();
        assert_eq!(run.code, Some(0), "{shown}: {}{}", run.stdout, run.stderr);
        run
    }

    /// Run and require the bad-input exit code 2 with a one-line error; returns the line.
    pub fn refused(self) -> String {
        let shown = self.shown();
        let run = self.run();
        assert_eq!(run.code, Some(2), "{shown}: {}", run.stderr);
        let err = run.stderr.trim_end().to_string();
        assert_eq!(err.lines().count(), 1, "{shown}: one line: {err}");
        err
    }
}

/// Run `femto args...` in `dir` (None: the test's working directory).
pub fn femto_in(dir: Option<&Path>, args: &[&str]) -> Run {
    femto_env(dir, args, &[])
}

/// Run `femto args...` in `dir` with extra environment variables (`FEMTO_MEMORY_LIMIT_BYTES`
/// to make memory refusals independent of the machine).
pub fn femto_env(dir: Option<&Path>, args: &[&str], env: &[(&str, &str)]) -> Run {
    let mut cmd = FemtoCmd::new().args(args);
    for (k, v) in env {
        cmd = cmd.env(k, v);
    }
    if let Some(d) = dir {
        cmd = cmd.current_dir(d);
    }
    cmd.run()
}

/// Run `femto args...` and require success; returns what it printed.
pub fn femto_ok(args: &[&str]) -> Run {
    FemtoCmd::new().args(args).ok()
}

/// Run `femto args...` and require bad-input exit code 2 with a one-line error; returns it.
pub fn femto_refused(args: &[&str]) -> String {
    FemtoCmd::new().args(args).refused()
}

/// A path as a command-line argument.
pub fn arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// Every file under a folder (hidden ones included, recursively) with its contents: what a
/// refused command must leave exactly as it was.
#[derive(Debug, PartialEq, Eq)]
pub struct Snapshot(std::collections::BTreeMap<std::path::PathBuf, Vec<u8>>);

impl Snapshot {
    pub fn of(dir: &Path) -> Snapshot {
        fn walk(
            dir: &Path,
            root: &Path,
            out: &mut std::collections::BTreeMap<std::path::PathBuf, Vec<u8>>,
        ) {
            for entry in std::fs::read_dir(dir).expect("readable folder") {
                let path = entry.expect("folder entry").path();
                let rel = path.strip_prefix(root).expect("under root").to_path_buf();
                let meta = std::fs::symlink_metadata(&path).expect("metadata");
                if meta.is_dir() {
                    out.insert(rel, Vec::new());
                    walk(&path, root, out);
                } else if meta.file_type().is_symlink() {
                    let target = std::fs::read_link(&path).expect("link");
                    out.insert(rel, target.to_string_lossy().as_bytes().to_vec());
                } else {
                    out.insert(rel, std::fs::read(&path).expect("readable file"));
                }
            }
        }
        let mut files = std::collections::BTreeMap::new();
        walk(dir, dir, &mut files);
        Snapshot(files)
    }

    /// The names that differ between two snapshots (added, removed or changed).
    pub fn changes(&self, after: &Snapshot) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for (k, v) in &self.0 {
            match after.0.get(k) {
                None => names.push(format!("removed {}", k.display())),
                Some(w) if w != v => names.push(format!("changed {}", k.display())),
                _ => {}
            }
        }
        for k in after.0.keys() {
            if !self.0.contains_key(k) {
                names.push(format!("added {}", k.display()));
            }
        }
        names
    }
}

/// Run `femto args...` in `dir` (with `env`) and require what a refused bad input must give:
/// exit code 2, one line on stderr that contains each of `names` (the file, key or flag at
/// fault), and no file under `dir` added, removed or changed. Returns the message.
pub fn refused_unchanged(
    dir: &Path,
    args: &[&str],
    env: &[(&str, &str)],
    names: &[&str],
) -> String {
    let before = Snapshot::of(dir);
    let run = femto_env(Some(dir), args, env);
    let err = run.stderr.trim_end().to_string();
    assert_eq!(
        run.code,
        Some(2),
        "femto {}: exit {:?}: {err}",
        args.join(" "),
        run.code
    );
    assert_eq!(
        err.lines().count(),
        1,
        "femto {}: one line: {err}",
        args.join(" ")
    );
    for name in names {
        assert!(
            err.contains(name),
            "femto {}: the message names {name}: {err}",
            args.join(" ")
        );
    }
    let changes = before.changes(&Snapshot::of(dir));
    assert!(
        changes.is_empty(),
        "femto {}: refused but changed {changes:?}",
        args.join(" ")
    );
    err
}

/// A folder of files made for a test, and its path.
pub struct Fixture {
    _dir: tempfile::TempDir,
    pub root: std::path::PathBuf,
}

/// A capture of the built-in `cube` scene at `size` (e.g. `32x24`), 16 samples per pixel,
/// with realistic flaws, in `cap/` of a new temporary folder, taken through the stages after
/// it ([`chain_after_capture`]): the fixture of the fault corpus and of `femto view`'s tests.
/// The folder is removed when the fixture is dropped.
pub fn realistic_chain(size: &str) -> Fixture {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let root = dir.path().to_path_buf();
    let cap = root.join("cap");
    femto_ok(&[
        "simulate",
        "--scene",
        "cube",
        "--size",
        size,
        "--spp",
        "16",
        "--realistic",
        "--out",
        arg(&cap),
    ]);
    chain_after_capture(&root, &cap);
    Fixture { _dir: dir, root }
}

/// The stages after a simulated capture `cap`, each with defaults, writing into `root`:
/// `cube.h5` (ingest), `cube.calibration.toml` (calibrate against the capture's mesh, fiducials
/// and true laser position), `world.h5` (unwarp) with its pyramid group. The fixtures of the
/// fault corpus and the fuzzers' seeds.
pub fn chain_after_capture(root: &Path, cap: &Path) {
    let cube = root.join("cube.h5");
    femto_ok(&["ingest", arg(cap), "-o", arg(&cube)]);
    let truth = femto::camera::Calibration::load(&cap.join("calibration.toml")).unwrap();
    let l = truth.laser_m;
    femto_ok(&[
        "calibrate",
        arg(&cube),
        "--mesh",
        arg(&cap.join("scene.glb")),
        "--points",
        arg(&cap.join("fiducials.toml")),
        &format!("--laser={},{},{}", l.x, l.y, l.z),
    ]);
    let world = root.join("world.h5");
    femto_ok(&["unwarp", arg(&cube), "--out", arg(&world)]);
    femto_ok(&["pyramid", arg(&world)]);
}

/// Every file under `root` (what a run left behind), by relative path, with its bytes.
pub fn files_under(root: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_path_buf();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}
