//! Interrupts: SIGINT and SIGTERM end a command promptly and remove its temporary files.
//!
//! Every temporary file or folder that femto makes beside an output ([`crate::atomic`]) is
//! registered here while it exists. [`install`] (called once by the binary) starts a thread
//! that waits for SIGINT or SIGTERM, removes every registered path and exits with 128 + the
//! signal's number (130 for SIGINT, 143 for SIGTERM), the shell's convention.
//!
//! Renames that put outputs in place run inside a [`commit`] section, which the handler waits
//! for: a signal comes either before an output is renamed (its temporary file is removed, any
//! earlier output is kept) or after (the new output is whole), never in between; a command
//! that commits several outputs together (calibrate's TOML and cube) holds one section for
//! all of them.

use std::cell::Cell;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};

/// The temporary paths that exist now, by registration number.
static REGISTRY: Mutex<BTreeMap<u64, PathBuf>> = Mutex::new(BTreeMap::new());
/// Files being appended to in place, by registration number: cut back to their old length
/// on an interrupt (what was appended is not referenced by the old file).
static APPENDS: Mutex<BTreeMap<u64, (PathBuf, u64)>> = Mutex::new(BTreeMap::new());
/// Numbers for [`Registration`]s.
static NEXT: Mutex<u64> = Mutex::new(0);
/// Held by [`commit`] sections and by the signal handler.
static COMMIT: Mutex<()> = Mutex::new(());

thread_local! {
    /// How deep this thread is in [`commit`] sections (they nest).
    static DEPTH: Cell<u32> = const { Cell::new(0) };
}

/// A registered temporary path; hand it back with [`unregister`].
#[derive(Debug)]
pub struct Registration(u64);

/// Record `path` (a temporary file or folder) as one to remove if the command is
/// interrupted.
pub fn register(path: &Path) -> Registration {
    let id = {
        let mut next = NEXT.lock().unwrap_or_else(|e| e.into_inner());
        *next += 1;
        *next
    };
    REGISTRY
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(id, path.to_path_buf());
    Registration(id)
}

/// Record `path` as a file being appended to in place, to be truncated to `old_len` bytes if
/// the command is interrupted before its [`commit`] section.
pub fn register_append(path: &Path, old_len: u64) -> Registration {
    let id = {
        let mut next = NEXT.lock().unwrap_or_else(|e| e.into_inner());
        *next += 1;
        *next
    };
    APPENDS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(id, (path.to_path_buf(), old_len));
    Registration(id)
}

/// Forget a registered path (it was renamed into place or removed).
pub fn unregister(registration: Registration) {
    REGISTRY
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .remove(&registration.0);
    APPENDS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .remove(&registration.0);
}

/// The paths registered now (for tests).
pub fn registered() -> Vec<PathBuf> {
    REGISTRY
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .values()
        .cloned()
        .collect()
}

/// A section that a signal does not interrupt: the handler waits until it ends. Sections
/// nest on one thread.
pub struct Commit {
    _guard: Option<MutexGuard<'static, ()>>,
}

/// Enter a [`Commit`] section (until the value is dropped).
pub fn commit() -> Commit {
    let depth = DEPTH.with(|d| d.get());
    let guard = (depth == 0).then(|| COMMIT.lock().unwrap_or_else(|e| e.into_inner()));
    DEPTH.with(|d| d.set(depth + 1));
    Commit { _guard: guard }
}

impl Drop for Commit {
    fn drop(&mut self) {
        DEPTH.with(|d| d.set(d.get().saturating_sub(1)));
    }
}

/// Remove every registered path, and cut every file being appended to back to its old
/// length.
fn remove_registered() {
    let paths = REGISTRY.lock().unwrap_or_else(|e| e.into_inner());
    remove_paths(paths.values());
    for (path, old_len) in APPENDS.lock().unwrap_or_else(|e| e.into_inner()).values() {
        if let Ok(f) = std::fs::OpenOptions::new().write(true).open(path) {
            let _ = f.set_len(*old_len);
        }
    }
}

/// Remove files and folders; what is already gone is skipped.
fn remove_paths<'a>(paths: impl Iterator<Item = &'a PathBuf>) {
    for path in paths {
        match std::fs::symlink_metadata(path) {
            Ok(m) if m.is_dir() => {
                // A worker may still add an entry while the folder is emptied: try again.
                for _ in 0..3 {
                    if std::fs::remove_dir_all(path).is_ok() {
                        break;
                    }
                }
            }
            Ok(_) => {
                let _ = std::fs::remove_file(path);
            }
            Err(_) => {}
        }
    }
}

/// Start the thread that handles SIGINT and SIGTERM (once; later calls do nothing). Fails
/// only if the handlers cannot be registered.
pub fn install() -> std::io::Result<()> {
    static INSTALLED: OnceLock<()> = OnceLock::new();
    if INSTALLED.get().is_some() {
        return Ok(());
    }
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
        std::thread::Builder::new()
            .name("femto-signals".into())
            .spawn(move || {
                if let Some(signal) = signals.forever().next() {
                    // Wait for a commit in progress, and keep the lock: nothing is renamed
                    // into place after the temporary files are gone.
                    let _commit = COMMIT.lock().unwrap_or_else(|e| e.into_inner());
                    remove_registered();
                    std::process::exit(128 + signal);
                }
            })?;
    }
    let _ = INSTALLED.set(());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registered_paths_are_removed_files_and_folders() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.tmp");
        let folder = dir.path().join("b.tmp");
        std::fs::write(&file, "x").unwrap();
        std::fs::create_dir(&folder).unwrap();
        std::fs::write(folder.join("c"), "y").unwrap();
        let kept = dir.path().join("kept");
        std::fs::write(&kept, "z").unwrap();
        let (a, b) = (register(&file), register(&folder));
        let gone = dir.path().join("gone.tmp");
        let c = register(&gone);
        // Only this test's paths: other tests register theirs in parallel.
        let mine: Vec<PathBuf> = registered()
            .into_iter()
            .filter(|p| p.starts_with(dir.path()))
            .collect();
        assert_eq!(mine.len(), 3);
        remove_paths(mine.iter());
        assert!(!file.exists() && !folder.exists());
        assert!(kept.exists());
        for r in [a, b, c] {
            unregister(r);
        }
        assert!(!registered().contains(&file));
    }

    #[test]
    fn commit_sections_nest() {
        let outer = commit();
        let inner = commit();
        drop(inner);
        assert_eq!(DEPTH.with(|d| d.get()), 1);
        drop(outer);
        assert_eq!(DEPTH.with(|d| d.get()), 0);
    }
}
