//! Atomic file output: write into a temporary file in the destination's folder, then rename.
//!
//! A failed or interrupted write leaves no partial file behind and keeps any earlier file of
//! the same name untouched.

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
    let tmp = temp_beside(dest)?;
    let value = write(&tmp)?;
    persist(tmp, dest)?;
    Ok(value)
}

/// A new, empty temporary file in `dest`'s folder, named `.<name>.XXXX.tmp`, deleted when
/// dropped. The handle is released, so writers that open by path work.
pub fn temp_beside(dest: &Path) -> io::Result<tempfile::TempPath> {
    let dir = match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let stem = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    Ok(tempfile::Builder::new()
        .prefix(&format!(".{stem}."))
        .suffix(".tmp")
        .tempfile_in(&dir)?
        .into_temp_path())
}

/// Write `bytes` into a temporary file beside `dest` and keep it there, for outputs that
/// must appear together with others: [`persist`] renames it onto `dest` once everything else
/// has succeeded; dropping it deletes the temporary file.
pub fn stage_beside(dest: &Path, bytes: &[u8]) -> io::Result<tempfile::TempPath> {
    let tmp = temp_beside(dest)?;
    std::fs::write(&tmp, bytes)?;
    Ok(tmp)
}

/// Rename a temporary file ([`temp_beside`], [`stage_beside`]) onto `dest`, as an ordinary
/// (0644) file: tempfile creates files readable by the owner only.
pub fn persist(tmp: tempfile::TempPath, dest: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.persist(dest).map_err(|e| e.error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
