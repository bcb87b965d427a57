//! One overwrite rule for every command: an output that already exists is refused unless
//! the user adds `--force`, and then it is replaced whole.
//!
//! "Output" means a file the command writes (`ingest --out`, `unwarp --out`,
//! `calibrate --out`, `export --out`, `pyramid --side-file`, a video), the frame files of a
//! frame sequence (the frames a split job would write, not the folder, so that jobs of one
//! video share a folder), or a capture or demo folder. The group that `calibrate`
//! (registration) and `pyramid` (prefix sums) keep in a cube is that command's own state of
//! the cube, replaced by each run with the rest of the file kept. The check runs before any
//! work, so a refused command costs nothing and writes nothing. docs/faults.md,
//! "Overwriting", is the user's statement of this rule.

use super::StageError;
use std::path::Path;

/// Refuse `out` (given with `--flag`) when it is one of `inputs` (even with `force`: see
/// [`super::refuse_same_file`]), or when it exists and `force` is false.
pub fn refuse_existing(
    out: &Path,
    inputs: &[&Path],
    force: bool,
    flag: &'static str,
) -> Result<(), StageError> {
    super::refuse_same_file(out, inputs, flag)?;
    if force || std::fs::symlink_metadata(out).is_err() {
        return Ok(());
    }
    Err(StageError::OutputExists {
        flag,
        path: out.display().to_string(),
        what: if out.is_dir() { "folder" } else { "file" }.to_string(),
    })
}

/// Refuse the first of `outputs` (files a frame sequence would write into the folder
/// `--flag`) that exists, when `force` is false.
pub fn refuse_existing_any(
    outputs: impl IntoIterator<Item = std::path::PathBuf>,
    force: bool,
    flag: &'static str,
) -> Result<(), StageError> {
    if force {
        return Ok(());
    }
    for out in outputs {
        refuse_existing(&out, &[], false, flag)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_existing_output_is_refused_unless_forced() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("c.h5");
        assert!(refuse_existing(&file, &[], false, "out").is_ok());
        std::fs::write(&file, "x").unwrap();
        let e = refuse_existing(&file, &[], false, "out")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            format!(
                "--out {}: file exists; add --force to replace it",
                file.display()
            )
        );
        assert!(refuse_existing(&file, &[], true, "out").is_ok());
        // An input is refused even with --force.
        let input = file.as_path();
        assert!(refuse_existing(&file, &[input], true, "out").is_err());
        let frames = [dir.path().join("frame_0000.png"), file.clone()];
        assert!(refuse_existing_any(frames.clone(), false, "out").is_err());
        assert!(refuse_existing_any(frames, true, "out").is_ok());
    }
}
