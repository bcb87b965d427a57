//! The sequence a part belongs to: a render of part of a frame sequence (`femto render
//! --frames A..B` of N frames, PNG or EXR) leaves [`SEQUENCE_FILE`] beside its frames,
//! recording N. `femto encode` reads it to refuse a set of part folders that holds fewer frames
//! than the render planned (a part left out, or its job still running), which would otherwise
//! make a shorter video. A whole sequence's folder holds its frames only, and every frame's
//! bytes are those of any other render of it (a split render's, a `femto view` still).

use super::VideoError;
use std::path::Path;

/// The file of a part's folder that names its sequence.
pub const SEQUENCE_FILE: &str = "sequence.toml";

/// What [`SEQUENCE_FILE`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SequenceFile {
    /// Frames of the whole sequence the render planned (`--frame-count`, or the path's).
    pub frames: usize,
}

/// Write `dir/`[`SEQUENCE_FILE`] (into a sequence's staged folder).
pub fn write_sequence_file(dir: &Path, sequence: SequenceFile) -> Result<(), VideoError> {
    let path = dir.join(SEQUENCE_FILE);
    let text = format!(
        "# The frames of this folder are part of a sequence of {} frames (femto render \
         --frames A..B); femto encode checks that its parts hold every one.\nframes = {}\n",
        sequence.frames, sequence.frames
    );
    std::fs::write(&path, text).map_err(|source| VideoError::Io { path, source })
}

/// The sequence `dir` records, or None when it records none (a whole render's folder, or
/// frames of another tool).
pub fn read_sequence_file(dir: &Path) -> Result<Option<SequenceFile>, VideoError> {
    let path = dir.join(SEQUENCE_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(VideoError::Io { path, source }),
    };
    toml::from_str(&text)
        .map(Some)
        .map_err(|e| VideoError::Sequence {
            message: format!("{}: {}", path.display(), e.message()),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_records_its_sequence_and_reads_it_back() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(read_sequence_file(dir.path()).unwrap(), None);
        write_sequence_file(dir.path(), SequenceFile { frames: 20 }).unwrap();
        assert_eq!(
            read_sequence_file(dir.path()).unwrap(),
            Some(SequenceFile { frames: 20 })
        );
        std::fs::write(dir.path().join(SEQUENCE_FILE), "frames = \"x\"\n").unwrap();
        let e = read_sequence_file(dir.path()).unwrap_err().to_string();
        assert!(e.contains(SEQUENCE_FILE), "{e}");
    }
}
