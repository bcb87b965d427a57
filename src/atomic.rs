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
    let dir = match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let stem = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{stem}."))
        .suffix(".tmp")
        .tempfile_in(&dir)?;
    // Keep the path reserved but release the handle, so writers that open by path work.
    let tmp_path = tmp.into_temp_path();
    let value = write(&tmp_path)?;
    // tempfile creates files readable by the owner only; outputs are ordinary files.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&tmp_path, std::fs::Permissions::from_mode(0o644))?;
    }
    tmp_path.persist(dest).map_err(|e| e.error)?;
    Ok(value)
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
