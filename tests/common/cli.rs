//! Running the `femto` binary as a user would, for end-to-end tests (ripgrep's `TestCommand`):
//! one place that builds the command, checks the exit code and hands back the output.
//! Included by the tests that run the binary with `#[path = "common/cli.rs"] mod cli;`
//! (not from `common/mod.rs`, which examples and benches include too).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// What a finished `femto` run printed.
pub struct Run {
    pub stdout: String,
    pub stderr: String,
    pub code: Option<i32>,
}

/// Run `femto args...` in `dir` (None: the test's working directory).
pub fn femto_in(dir: Option<&Path>, args: &[&str]) -> Run {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_femto"));
    cmd.args(args);
    if let Some(d) = dir {
        cmd.current_dir(d);
    }
    let Output {
        status,
        stdout,
        stderr,
    } = cmd.output().expect("femto runs");
    Run {
        stdout: String::from_utf8_lossy(&stdout).into_owned(),
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
        code: status.code(),
    }
}

/// Run `femto args...` and require success; returns what it printed.
pub fn femto_ok(args: &[&str]) -> Run {
    let run = femto_in(None, args);
    assert_eq!(
        run.code,
        Some(0),
        "femto {}: {}{}",
        args.join(" "),
        run.stdout,
        run.stderr
    );
    run
}

/// Run `femto args...` and require bad-input exit code 2 with a one-line error; returns it.
pub fn femto_refused(args: &[&str]) -> String {
    let run = femto_in(None, args);
    assert_eq!(
        run.code,
        Some(2),
        "femto {}: {}",
        args.join(" "),
        run.stderr
    );
    let err = run.stderr.trim_end().to_string();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    err
}

/// A path as a command-line argument.
pub fn arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}
