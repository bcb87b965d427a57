//! The real data in `../shared` (the Stanford bunny, two Hamamatsu streak files), or in the
//! folder `$FEMTO_SHARED` names: one place that finds a file and, when it is missing, says
//! that the test skipped (`skipped: <why>` on stdout) or, under `CI=true`, fails the test.
//! Included by the tests that use it with `#[path = "common/shared.rs"] mod shared;`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// `$FEMTO_SHARED`, else `../shared` beside the crate.
pub fn dir() -> PathBuf {
    match std::env::var_os("FEMTO_SHARED") {
        Some(d) => PathBuf::from(d),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"),
    }
}

/// Whether a missing input must fail the test rather than skip it (`CI=true`).
pub fn required() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

/// The file `rel` under [`dir`], if it is there. If not, the test skips (prints
/// `skipped: <file> not found` and gets `None`) or, under `CI=true`, fails here.
pub fn file(rel: &str) -> Option<PathBuf> {
    let path = dir().join(rel);
    if path.is_file() {
        return Some(path);
    }
    let why = format!(
        "{} not found (set FEMTO_SHARED to the shared data folder)",
        path.display()
    );
    assert!(!required(), "CI=true and {why}");
    println!("skipped: {why}");
    None
}
