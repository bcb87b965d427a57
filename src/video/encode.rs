//! Encoding the frame sequences of a split render (`femto render --frames A..B`, one folder
//! per part) into one MP4 or GIF, identical to the file a single render writes: the PNG
//! frames hold the same 8-bit sRGB values ([`super::Frame::srgb8`]) the MP4 and GIF encoders
//! read, and they are pushed to one [`super::VideoWriter`] in frame order.
//!
//! The folders must together hold frames `A..B` once each (`frame_NNNNN.png`, their global
//! numbers, [`super::sequence_file_name`]), all of one size, and, when the parts record the
//! sequence their render planned ([`super::sequence`]), every frame of it; gaps, repeats, a
//! short set and EXR frames (linear values, not the displayed ones) are refused before
//! anything is written.

use super::{VideoError, VideoFormat, VideoWriter};
use std::path::{Path, PathBuf};

/// What [`encode_sequences`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct EncodeSummary {
    /// The global numbers of the frames encoded.
    pub frames: std::ops::Range<usize>,
    /// Frame size, pixels.
    pub width: usize,
    pub height: usize,
}

fn refuse(message: String) -> VideoError {
    VideoError::Sequence { message }
}

/// The largest frame number a sequence may use (2^40, [`crate::limits::MAX_COUNT`]): far
/// beyond any render, and small enough that `n + 1` cannot overflow.
const MAX_FRAME_NUMBER: u64 = crate::limits::MAX_COUNT;

/// The frame number of a sequence file name `frame_NNNNN.EXT`, and its extension; `None`
/// for a name of another form. `Err(digits)`: a frame name whose number cannot be ordered
/// (above [`MAX_FRAME_NUMBER`], such as a 23-digit one), which must not be skipped silently.
fn frame_number(name: &str) -> Option<Result<(usize, &str), &str>> {
    let (stem, ext) = name.strip_prefix("frame_")?.split_once('.')?;
    if stem.is_empty() || !stem.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(
        stem.parse::<u64>()
            .ok()
            .filter(|&n| n <= MAX_FRAME_NUMBER)
            .map(|n| (n as usize, ext))
            .ok_or(stem),
    )
}

/// The PNG frames of the folders `dirs`, in frame order, checked to be frames `A..B` once
/// each (see the module doc).
pub fn list_frames(dirs: &[PathBuf]) -> Result<(std::ops::Range<usize>, Vec<PathBuf>), VideoError> {
    let mut frames: Vec<(usize, PathBuf, &Path)> = Vec::new();
    for dir in dirs {
        let entries = std::fs::read_dir(dir).map_err(|source| VideoError::Folder {
            path: dir.clone(),
            source,
        })?;
        for entry in entries {
            let entry = entry.map_err(|source| VideoError::Folder {
                path: dir.clone(),
                source,
            })?;
            let name = entry.file_name().to_string_lossy().into_owned();
            match frame_number(&name) {
                Some(Err(digits)) => {
                    return Err(refuse(format!(
                        "{}: frame number {digits} cannot be ordered (at most \
                         {MAX_FRAME_NUMBER}): rename it frame_NNNNN with its place in the \
                         sequence, or move it out of the folder",
                        entry.path().display()
                    )))
                }
                Some(Ok((n, ext))) if ext.eq_ignore_ascii_case("png") => {
                    frames.push((n, entry.path(), dir))
                }
                Some(Ok((_, ext))) if ext.eq_ignore_ascii_case("exr") => {
                    return Err(refuse(format!(
                        "{}: an EXR frame holds linear values, not the displayed ones: render the \
                         parts with --format png to encode them",
                        entry.path().display()
                    )))
                }
                _ => {}
            }
        }
    }
    if frames.is_empty() {
        let names: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
        return Err(refuse(format!(
            "{}: no PNG frames (frame_NNNNN.png)",
            names.join(", ")
        )));
    }
    frames.sort_by_key(|f| f.0);
    for w in frames.windows(2) {
        let ((a, pa, da), (b, pb, db)) = (&w[0], &w[1]);
        if a == b {
            return Err(refuse(format!(
                "frame {a} is in two folders: {} and {}",
                pa.display(),
                pb.display()
            )));
        }
        if b - a > 1 {
            return Err(refuse(format!(
                "frames {}..{b} are in no folder ({} ends at frame {a}, {} goes on at frame {b})",
                a + 1,
                da.display(),
                db.display()
            )));
        }
    }
    let range = frames[0].0..frames[frames.len() - 1].0 + 1;
    Ok((range, frames.into_iter().map(|f| f.1).collect()))
}

/// Refuse frames `range` (from the folders `dirs`) when their render planned a longer
/// sequence: the folder of each part records the sequence's frames N ([`super::sequence`]);
/// every part must name the same N and together they must hold frames 0..N, so a part left
/// out (or not written yet) is refused rather than encoded into a shorter video. Folders
/// that record nothing (a whole render's, another tool's frames) are taken as they are.
fn check_planned(range: &std::ops::Range<usize>, dirs: &[PathBuf]) -> Result<(), VideoError> {
    let mut planned: Option<(usize, &PathBuf)> = None;
    for dir in dirs {
        let Some(sequence) = super::sequence::read_sequence_file(dir)? else {
            continue;
        };
        match planned {
            None => planned = Some((sequence.frames, dir)),
            Some((n, other)) if n != sequence.frames => {
                return Err(refuse(format!(
                    "{}: part of a {}-frame render, but {} is part of a {n}-frame one: the \
                     parts of one video come from one render's --frame-count",
                    dir.display(),
                    sequence.frames,
                    other.display()
                )))
            }
            Some(_) => {}
        }
    }
    let Some((n, _)) = planned else {
        return Ok(());
    };
    if range.start > 0 {
        return Err(refuse(format!(
            "frames 0..{} of the {n} the render planned are in no folder (the frames given \
             start at frame {}): give every part",
            range.start, range.start
        )));
    }
    if range.end < n {
        return Err(refuse(format!(
            "frames {}..{n} of the {n} the render planned are in no folder (the frames given \
             end at frame {}): give every part, once each has been written",
            range.end,
            range.end - 1
        )));
    }
    Ok(())
}

/// Read one PNG frame as 8-bit sRGB RGB, its decoded size checked against the memory
/// budget from its header first (RGBA and the RGB copy: 7 bytes a pixel).
fn read_frame(path: &Path) -> Result<super::Frame, VideoError> {
    let image_err = |source| VideoError::Decode {
        path: path.to_path_buf(),
        source,
    };
    let (w, h) = image::ImageReader::open(path)
        .map_err(|source| VideoError::Read {
            path: path.to_path_buf(),
            source,
        })?
        .into_dimensions()
        .map_err(image_err)?;
    crate::limits::check_decoded(
        &[h as usize, w as usize],
        7,
        1,
        format_args!("a frame of {w} x {h} pixels"),
        "is the file damaged?",
    )
    .map_err(|source| VideoError::Limit {
        path: path.to_path_buf(),
        source,
    })?;
    let image = image::open(path).map_err(image_err)?;
    if !matches!(
        image.color(),
        image::ColorType::Rgb8 | image::ColorType::Rgba8
    ) {
        return Err(refuse(format!(
            "{}: {:?} pixels, not the 8-bit RGB frames femto render writes",
            path.display(),
            image.color()
        )));
    }
    let rgb = image.into_rgb8();
    Ok(super::Frame {
        width: rgb.width() as usize,
        height: rgb.height() as usize,
        linear_rgb: Vec::new(),
        srgb8: rgb.into_raw(),
    })
}

/// Encode the PNG frames of the folders `dirs` ([`list_frames`]) into the MP4 or GIF `out`
/// at `fps` frames per second (written atomically, as [`VideoWriter`] writes it).
pub fn encode_sequences(
    dirs: &[PathBuf],
    out: &Path,
    format: VideoFormat,
    fps: f64,
) -> Result<EncodeSummary, VideoError> {
    if format.is_sequence() {
        return Err(refuse(format!(
            "{}: encode writes an MP4 or GIF, not a {format}",
            out.display()
        )));
    }
    let (range, files) = list_frames(dirs)?;
    check_planned(&range, dirs)?;
    let first = read_frame(&files[0])?;
    let (width, height) = (first.width, first.height);
    let mut writer = VideoWriter::create(out, format, width, height, fps)?;
    writer.push(&first)?;
    for file in &files[1..] {
        let frame = read_frame(file)?;
        if (frame.width, frame.height) != (width, height) {
            return Err(refuse(format!(
                "{}: {}x{} pixels, but {} is {width}x{height}",
                file.display(),
                frame.width,
                frame.height,
                files[0].display()
            )));
        }
        writer.push(&frame)?;
    }
    writer.finish()?;
    Ok(EncodeSummary {
        frames: range,
        width,
        height,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_numbers_come_from_sequence_names_only() {
        assert_eq!(frame_number("frame_00042.png"), Some(Ok((42, "png"))));
        assert_eq!(frame_number("frame_123456.exr"), Some(Ok((123456, "exr"))));
        // Numbers that cannot be ordered are named, not skipped.
        let huge = "12345678901234567890123";
        assert_eq!(frame_number(&format!("frame_{huge}.png")), Some(Err(huge)));
        assert_eq!(
            frame_number("frame_18446744073709551615.png"),
            Some(Err("18446744073709551615"))
        );
        assert_eq!(
            frame_number("frame_1099511627776.png"),
            Some(Ok((1 << 40, "png")))
        );
        for name in [
            "frame_.png",
            "frame_12a.png",
            "image_00001.png",
            "frame_00001",
        ] {
            assert_eq!(frame_number(name), None, "{name}");
        }
    }
}
