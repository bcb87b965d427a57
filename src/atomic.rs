//! Atomic output: write into a temporary file or folder in the destination's folder, then
//! rename it into place.
//!
//! A failed or interrupted write leaves no partial output behind and keeps any earlier output
//! of the same name untouched. Temporary paths are named `.<name>.femto-<pid>-<random>.tmp`
//! and registered with [`crate::interrupt`] while they exist, so SIGINT and SIGTERM remove
//! them; one left by a run that was killed outright (SIGKILL, the OOM killer) is recognised by
//! its name and removed by the next run that writes the same destination, once no process of
//! that id is alive.
//!
//! Files go through one type, [`AtomicFile`] (stage, write, commit by rename; dropped
//! uncommitted, removed), or its one-call forms [`write_atomically`] and
//! [`write_atomically_with`]; folders (a frame sequence, a capture) through [`TempDir`] and
//! [`replace_dir`]. Both keep their temporary path in one private `Staged` value, which
//! removes and unregisters it when dropped.

use crate::interrupt::{self, Registration};
use std::io;
use std::path::{Path, PathBuf};

/// Run `write` on a temporary path beside `dest`; on success rename it onto `dest`.
///
/// The temporary file is removed if `write` fails. `E` must be constructible from an
/// `io::Error` so that failures to create or rename the temporary file are reported too.
pub fn write_atomically<T, E, F>(dest: &Path, write: F) -> Result<T, E>
where
    F: FnOnce(&Path) -> Result<T, E>,
    E: From<io::Error>,
{
    write_atomically_with(dest, E::from, write)
}

/// [`write_atomically`] for a writer whose error type has no `From<io::Error>`: `io` turns a
/// failure to create or rename the temporary file into the writer's error (naming `dest`,
/// typically).
pub fn write_atomically_with<T, E>(
    dest: &Path,
    io: impl Fn(io::Error) -> E,
    write: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<T, E> {
    let file = AtomicFile::create(dest).map_err(&io)?;
    let value = write(file.path())?;
    file.commit().map_err(io)?;
    Ok(value)
}

/// A temporary path (file or folder) registered with [`crate::interrupt`]: removed, and
/// unregistered, when dropped unless [`Staged::release`]d. What [`AtomicFile`] and
/// [`TempDir`] share.
#[derive(Debug)]
struct Staged {
    path: PathBuf,
    registration: Option<Registration>,
    is_dir: bool,
}

impl Staged {
    /// Unregister the path and keep it: it has been renamed into place.
    fn release(&mut self) {
        if let Some(r) = self.registration.take() {
            interrupt::unregister(r);
        }
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(r) = self.registration.take() {
            let _ = if self.is_dir {
                std::fs::remove_dir_all(&self.path)
            } else {
                std::fs::remove_file(&self.path)
            };
            interrupt::unregister(r);
        }
    }
}

/// One output file written atomically: staged under a temporary name beside its
/// destination (see the module doc), written by path, and renamed onto the destination by
/// [`AtomicFile::commit`]. Dropped uncommitted (a write failed, a command gave up), the
/// temporary file is removed and any earlier file at the destination stays as it was.
///
/// [`write_atomically`] is the one-call form; a writer that holds its output open across
/// calls (a streamed cube), or a command that must commit several outputs together, keeps
/// the `AtomicFile`.
#[derive(Debug)]
pub struct AtomicFile {
    staged: Staged,
    dest: PathBuf,
}

impl AtomicFile {
    /// A new, empty temporary file beside `dest`. No handle is kept, so writers that open
    /// by path work.
    pub fn create(dest: &Path) -> io::Result<AtomicFile> {
        let (path, registration) = create_beside(dest, |p| {
            std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(p)
                .map(drop)
        })?;
        Ok(AtomicFile {
            staged: Staged {
                path,
                registration: Some(registration),
                is_dir: false,
            },
            dest: dest.to_path_buf(),
        })
    }

    /// A temporary file beside `dest` holding `bytes`, for an output that must appear
    /// together with others: [`AtomicFile::commit`] it once everything else has succeeded.
    pub fn stage(dest: &Path, bytes: &[u8]) -> io::Result<AtomicFile> {
        let file = AtomicFile::create(dest)?;
        std::fs::write(file.path(), bytes)?;
        Ok(file)
    }

    /// The temporary path, to write.
    pub fn path(&self) -> &Path {
        &self.staged.path
    }

    /// The destination the file is committed to.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Rename the temporary file onto the destination, as an ordinary (0644) file, inside a
    /// [`interrupt::commit`] section.
    pub fn commit(mut self) -> io::Result<()> {
        let _commit = interrupt::commit();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&self.staged.path, std::fs::Permissions::from_mode(0o644))?;
        }
        std::fs::rename(&self.staged.path, &self.dest)?;
        self.staged.release();
        Ok(())
    }
}

/// A temporary folder beside an output, removed with its contents when dropped unless
/// [`replace_dir`] put it in place.
#[derive(Debug)]
pub struct TempDir {
    staged: Staged,
}

impl TempDir {
    pub fn path(&self) -> &Path {
        &self.staged.path
    }
}

/// The folder of `dest` (`.` for a bare name) and its file name.
fn folder_and_name(dest: &Path) -> (PathBuf, String) {
    let dir = match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    (dir, name)
}

/// The prefix of every temporary path of destination `name`: `.<name>.femto-`.
fn temp_prefix(name: &str) -> String {
    format!(".{name}.femto-")
}

/// Whether a process of id `pid` exists (one we may not signal exists too).
fn alive(pid: i32) -> bool {
    #[cfg(unix)]
    {
        // SAFETY: kill with signal 0 only checks that the process exists.
        let r = unsafe { libc::kill(pid, 0) };
        r == 0 || io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// Remove the temporary files and folders of `dest` left by runs that no longer exist
/// (killed before they could clean up). Returns how many were removed.
pub fn remove_stale_temps(dest: &Path) -> usize {
    let (dir, name) = folder_and_name(dest);
    let prefix = temp_prefix(&name);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return 0;
    };
    let me = std::process::id() as i32;
    let mut removed = 0;
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name
            .to_str()
            .and_then(|n| n.strip_prefix(&prefix))
            .filter(|r| r.ends_with(".tmp"))
        else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<i32>().ok()) else {
            continue;
        };
        if pid <= 0 || pid == me || alive(pid) {
            continue;
        }
        let path = entry.path();
        let gone = match entry.file_type() {
            Ok(t) if t.is_dir() => std::fs::remove_dir_all(&path),
            _ => std::fs::remove_file(&path),
        };
        if gone.is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Create a new temporary path beside `dest` with `make` (a file or a folder, failing if the
/// name exists), registered for removal on interrupt.
fn create_beside(
    dest: &Path,
    make: impl Fn(&Path) -> io::Result<()>,
) -> io::Result<(PathBuf, Registration)> {
    remove_stale_temps(dest);
    let (dir, name) = folder_and_name(dest);
    let prefix = format!("{}{}-", temp_prefix(&name), std::process::id());
    for _ in 0..64 {
        let path = dir.join(format!("{prefix}{:08x}.tmp", rand::random::<u32>()));
        // No signal between creating and registering.
        let _commit = interrupt::commit();
        match make(&path) {
            Ok(()) => {
                let registration = interrupt::register(&path);
                return Ok((path, registration));
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(io::Error::new(
        io::ErrorKind::AlreadyExists,
        format!("no free temporary name beside {}", dest.display()),
    ))
}

/// A new, empty temporary folder in `dest`'s folder, for outputs that are folders (a frame
/// sequence, a capture); put in place by [`replace_dir`], removed when dropped.
pub fn temp_dir_beside(dest: &Path) -> io::Result<TempDir> {
    let (path, registration) = create_beside(dest, |p| std::fs::create_dir(p))?;
    Ok(TempDir {
        staged: Staged {
            path,
            registration: Some(registration),
            is_dir: true,
        },
    })
}

/// Put the finished temporary folder `tmp` in place as `dest`, replacing whatever folder is
/// there whole (the caller decides whether it may), inside a [`interrupt::commit`] section.
/// Where the system allows, the two folders are exchanged in one step and the old one is then
/// removed under its temporary name, so no moment leaves `dest` missing.
pub fn replace_dir(mut tmp: TempDir, dest: &Path) -> io::Result<()> {
    let _commit = interrupt::commit();
    let tmp = &mut tmp.staged;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&tmp.path, std::fs::Permissions::from_mode(0o755))?;
    }
    let exists = std::fs::symlink_metadata(dest).is_ok_and(|m| m.is_dir());
    if !exists {
        std::fs::rename(&tmp.path, dest)?;
    } else if !exchange(&tmp.path, dest)? {
        // No exchange on this system: the old folder moves aside under a temporary name
        // (still inside the commit section), the new one takes its place.
        let aside = create_beside(dest, |_| Ok(()))?;
        let (aside, reg) = aside;
        std::fs::rename(dest, &aside)?;
        if let Err(e) = std::fs::rename(&tmp.path, dest) {
            let _ = std::fs::rename(&aside, dest);
            interrupt::unregister(reg);
            return Err(e);
        }
        // `tmp` is unregistered below; the old folder is removed as `tmp` would have been.
        let old = Staged {
            path: aside,
            registration: Some(reg),
            is_dir: true,
        };
        tmp.release();
        drop(old);
        return Ok(());
    }
    // After an exchange `tmp.path` holds the old folder: dropping `tmp` removes it.
    if !exists {
        tmp.release();
    }
    Ok(())
}

/// Swap two paths in one step (Linux `renameat2(RENAME_EXCHANGE)`); false where the system
/// or the file system cannot.
fn exchange(a: &Path, b: &Path) -> io::Result<bool> {
    #[cfg(target_os = "linux")]
    {
        use std::ffi::CString;
        use std::os::unix::ffi::OsStrExt;
        let c = |p: &Path| {
            CString::new(p.as_os_str().as_bytes())
                .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "NUL in a path"))
        };
        let (ca, cb) = (c(a)?, c(b)?);
        // SAFETY: two valid NUL-terminated paths, relative to the working directory.
        let r = unsafe {
            libc::renameat2(
                libc::AT_FDCWD,
                ca.as_ptr(),
                libc::AT_FDCWD,
                cb.as_ptr(),
                libc::RENAME_EXCHANGE,
            )
        };
        if r == 0 {
            return Ok(true);
        }
        let e = io::Error::last_os_error();
        match e.raw_os_error() {
            Some(libc::EINVAL) | Some(libc::ENOSYS) | Some(libc::EOPNOTSUPP) => Ok(false),
            _ => Err(e),
        }
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = (a, b);
        Ok(false)
    }
}

/// Whether writing `out` would overwrite or delete `input`: the same file through any path
/// (symbolic links, `..`, hard links: device and inode are compared where both exist), or an
/// input inside the output folder. The stages refuse such an output before writing
/// ([`crate::pipeline::refuse_same_file`], ingest's own check).
pub fn output_holds(out: &Path, input: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(a), Ok(b)) = (std::fs::metadata(out), std::fs::metadata(input)) {
            if (a.dev(), a.ino()) == (b.dev(), b.ino()) {
                return true;
            }
        }
    }
    let (Some(out_c), Some(in_c)) = (resolved(out), resolved(input)) else {
        return out == input;
    };
    // The same path, or an input inside the output folder.
    in_c.starts_with(&out_c)
}

/// `path` made absolute with every link and `..` resolved; for a path that does not exist
/// yet, its folder resolved and its name appended.
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(c) = std::fs::canonicalize(path) {
        return Some(c);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(std::fs::canonicalize(parent).ok()?.join(name))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn failure_keeps_old_file_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("a.txt");
        std::fs::write(&dest, "old").unwrap();
        let r: Result<(), io::Error> = write_atomically(&dest, |p| {
            std::fs::write(p, "half")?;
            Err(io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write_atomically::<_, io::Error, _>(&dest, |p| std::fs::write(p, "new")).unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "new");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&dest).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o644);
        }
    }

    #[test]
    fn temps_are_named_registered_and_unregistered() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("c.h5");
        let tmp = AtomicFile::create(&dest).unwrap();
        assert_eq!(tmp.dest(), dest);
        let name = tmp
            .path()
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let pid = std::process::id();
        assert!(name.starts_with(&format!(".c.h5.femto-{pid}-")), "{name}");
        assert!(name.ends_with(".tmp"), "{name}");
        assert!(interrupt::registered().contains(&tmp.path().to_path_buf()));
        let path = tmp.path().to_path_buf();
        drop(tmp);
        assert!(!path.exists());
        assert!(!interrupt::registered().contains(&path));
        let tmp = AtomicFile::stage(&dest, b"x").unwrap();
        let path = tmp.path().to_path_buf();
        tmp.commit().unwrap();
        assert!(!interrupt::registered().contains(&path));
        assert_eq!(names(dir.path()), ["c.h5"]);
        assert_eq!(std::fs::read(&dest).unwrap(), b"x");
    }

    /// `write_atomically_with` maps a failure of the temporary file with the caller's `io`
    /// and passes the writer's own error through, leaving no temporary file either way.
    #[test]
    fn write_atomically_with_maps_only_the_temporary_files_errors() {
        #[derive(Debug, PartialEq)]
        enum E {
            Io(String),
            Writer,
        }
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no such folder").join("a.gif");
        let r = write_atomically_with(&missing, |e| E::Io(e.kind().to_string()), |_| Ok(()));
        assert_eq!(r, Err(E::Io(io::ErrorKind::NotFound.to_string())));
        let dest = dir.path().join("a.gif");
        let r: Result<(), E> = write_atomically_with(
            &dest,
            |_| unreachable!("the temporary file is fine"),
            |p| {
                std::fs::write(p, "half").unwrap();
                Err(E::Writer)
            },
        );
        assert_eq!(r, Err(E::Writer));
        assert!(names(dir.path()).is_empty());
        let n = write_atomically_with(
            &dest,
            |e| E::Io(e.to_string()),
            |p| {
                std::fs::write(p, "gif").unwrap();
                Ok(3)
            },
        );
        assert_eq!(n, Ok(3));
        assert_eq!(names(dir.path()), ["a.gif"]);
    }

    #[cfg(unix)]
    #[test]
    fn temps_of_dead_runs_are_removed_by_the_next_run_only() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("w.h5");
        // A process that has exited: its id is free (reused only after the id space wraps).
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale_file = dir.path().join(format!(".w.h5.femto-{dead}-0badf00d.tmp"));
        let stale_dir = dir.path().join(format!(".w.h5.femto-{dead}-0badf00e.tmp"));
        std::fs::write(&stale_file, "left by a killed run").unwrap();
        std::fs::create_dir(&stale_dir).unwrap();
        std::fs::write(stale_dir.join("frame_00000.png"), "x").unwrap();
        // A live run's temporary (this process's parent is alive), another destination's
        // stale one and an unrelated hidden file stay.
        let live = dir.path().join(format!(
            ".w.h5.femto-{}-00000001.tmp",
            std::os::unix::process::parent_id()
        ));
        let other = dir.path().join(format!(".v.h5.femto-{dead}-00000002.tmp"));
        let hidden = dir.path().join(".w.h5.notes");
        for p in [&live, &other, &hidden] {
            std::fs::write(p, "keep").unwrap();
        }
        write_atomically::<_, io::Error, _>(&dest, |p| std::fs::write(p, "new")).unwrap();
        let mut expected = vec![
            ".v.h5.femto-".to_string() + &format!("{dead}-00000002.tmp"),
            live.file_name().unwrap().to_string_lossy().into_owned(),
            ".w.h5.notes".into(),
            "w.h5".into(),
        ];
        expected.sort();
        assert_eq!(names(dir.path()), expected);
    }

    #[test]
    fn folders_are_replaced_whole() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("frames");
        std::fs::create_dir(&dest).unwrap();
        for k in 0..3 {
            std::fs::write(dest.join(format!("frame_{k}")), "old").unwrap();
        }
        let tmp = temp_dir_beside(&dest).unwrap();
        std::fs::write(tmp.path().join("frame_0"), "new").unwrap();
        let path = tmp.path().to_path_buf();
        replace_dir(tmp, &dest).unwrap();
        assert_eq!(names(&dest), ["frame_0"]);
        assert_eq!(
            std::fs::read_to_string(dest.join("frame_0")).unwrap(),
            "new"
        );
        assert_eq!(names(dir.path()), ["frames"]);
        assert!(!interrupt::registered().contains(&path));
        // A new destination: a plain rename.
        let fresh = dir.path().join("fresh");
        let tmp = temp_dir_beside(&fresh).unwrap();
        replace_dir(tmp, &fresh).unwrap();
        assert_eq!(names(dir.path()), ["frames", "fresh"]);
        // Dropped unfinished: gone.
        let tmp = temp_dir_beside(&fresh).unwrap();
        std::fs::write(tmp.path().join("x"), "x").unwrap();
        drop(tmp);
        assert_eq!(names(dir.path()), ["frames", "fresh"]);
    }
}
