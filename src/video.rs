//! Video and frame-sequence output: PNG and EXR frame sequences, H.264 MP4, animated GIF.
//!
//! The renderer hands over one [`Frame`] per output time step; a [`VideoWriter`] turns the
//! stream into files. No system binary is involved: H.264 is encoded by OpenH264 (built from
//! its bundled source by the `openh264` crate) and wrapped in an MP4 container by `muxide`.
//!
//! Output is atomic (crate::atomic): a single MP4 or GIF appears only when [`VideoWriter::finish`]
//! succeeds (the compressed stream is held in memory until then), and a sequence's frames,
//! `frame_NNNNN.png` / `frame_NNNNN.exr` numbered from a first index so that a partial render
//! (`--frames A..B`) writes frames with their global numbers, go to a temporary folder beside
//! the destination that `finish` puts in place, replacing an earlier sequence whole (no stale
//! frames of a longer one stay; a partial render keeps the earlier frames of its own sequence,
//! [`VideoWriter::sequence_length`], so split renders into one folder add up). A destination
//! folder that holds anything but frames (and the [`sequence`] file of a part) is refused when
//! the writer is created, before anything is written. The folder of a render of part of a
//! sequence (`--frames A..B`) records the sequence it belongs to ([`sequence`]), so that
//! `femto encode` can refuse a set of parts that falls short of it.
//!
//! Colour handling (no tone mapping happens here; the caller decides how radiance becomes a
//! displayable value):
//! - EXR frames store [`Frame::linear_rgb`] as 32-bit float R, G, B (scene-linear).
//! - PNG, GIF and MP4 use [`Frame::srgb8`], 8-bit sRGB-encoded values.
//! - MP4: R'G'B' (sRGB-encoded) goes to Y'CbCr with the ITU-R BT.709 matrix
//!   (Kr = 0.2126, Kb = 0.0722) in limited ("studio") range, Y' in 16..=235 and Cb, Cr in
//!   16..=240, and chroma is subsampled 4:2:0 by averaging each 2x2 block (centred siting).
//!   The H.264 VUI says so: colour primaries BT.709 (the sRGB primaries), transfer
//!   characteristics IEC 61966-2-1 (sRGB), matrix BT.709, limited range. BT.709 rather than
//!   BT.601 because it is what players assume for computer-generated and HD content and because
//!   its primaries are those of sRGB. Width and height must be even (4:2:0), and OpenH264 limits
//!   the size to 3840x2160 (either orientation). Every frame is encoded (frame skipping off), at
//!   a constant frame rate; an IDR frame starts every two seconds so players can seek. Quality
//!   is set by a quantiser range (16..=22, see `MP4_QP_MIN`), not by a bit rate. Constrained
//!   baseline profile (OpenH264's default), which every player decodes.
//! - GIF: each frame gets its own 256-colour palette (NeuQuant quantisation in the `gif` crate);
//!   the frame delay is stored in whole hundredths of a second, so `100 / fps` is rounded to the
//!   nearest (25 fps plays exactly, 30 fps plays at 1/0.03 = 33.3 fps).

use std::fmt;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use image::codecs::gif::{GifEncoder, Repeat};
use image::codecs::png::PngEncoder;
use image::{Delay, ExtendedColorType, ImageEncoder, RgbaImage};
use openh264::encoder::{
    BitRate, Encoder, EncoderConfig, FrameRate, FrameType, IntraFramePeriod, QpRange,
    RateControlMode, TransferCharacteristics, UsageType, VuiConfig,
};
use openh264::formats::YUVSource;
use openh264::OpenH264API;
use thiserror::Error;

use crate::atomic::write_atomically_with;

/// Smallest side OpenH264 encodes: one macroblock (`EncodeFrameInternal` refuses a frame
/// narrower or lower than 16 pixels with its bare error code 5).
const MP4_MIN_SIDE: usize = 16;

/// Largest side OpenH264 accepts (3840x2160 or 2160x3840).
const MP4_MAX_LONG_SIDE: usize = 3840;
const MP4_MAX_SHORT_SIDE: usize = 2160;

/// Errors of the video writers.
#[derive(Debug, Error)]
pub enum VideoError {
    /// The format name or extension is not one of png, exr, mp4, gif.
    #[error(
        "unknown video format '{0}': expected png (frame sequence), exr (frame sequence), mp4 or gif"
    )]
    UnknownFormat(String),
    /// Width or height is zero.
    #[error("video size {width}x{height} is empty: width and height must be at least 1")]
    EmptySize { width: usize, height: usize },
    /// H.264 with 4:2:0 chroma needs even sides.
    #[error(
        "MP4 (H.264, 4:2:0) needs an even width and height, got {width}x{height}: \
         render at {even_width}x{even_height} instead"
    )]
    OddSize {
        width: usize,
        height: usize,
        even_width: usize,
        even_height: usize,
    },
    /// The frame is larger than the format allows.
    #[error("{format} output cannot be {width}x{height}: the largest size is {limit}")]
    TooLarge {
        format: VideoFormat,
        width: usize,
        height: usize,
        limit: &'static str,
    },
    /// The frame is smaller than the format allows.
    #[error(
        "{format} output cannot be {width}x{height}: the smallest size is {limit}; render \
         larger, or write PNG frames"
    )]
    TooSmall {
        format: VideoFormat,
        width: usize,
        height: usize,
        limit: &'static str,
    },
    /// The frame rate is not a positive finite number.
    #[error("frame rate {0} fps is not a positive finite number")]
    BadFrameRate(f64),
    /// A pushed frame does not have the size the writer was created with.
    #[error("frame {index} is {got_width}x{got_height}, but the video is {width}x{height}")]
    FrameSize {
        index: usize,
        width: usize,
        height: usize,
        got_width: usize,
        got_height: usize,
    },
    /// A pushed frame lacks the pixel buffer this format needs, or it has the wrong length.
    #[error("frame {index}: {format} output needs {field} with {expected} values (width x height x 3), got {got}")]
    FrameData {
        index: usize,
        format: VideoFormat,
        field: &'static str,
        expected: usize,
        got: usize,
    },
    /// `finish` on an MP4 or GIF writer that received no frame.
    #[error("no frame was pushed, so {path} was not written")]
    NoFrames { path: PathBuf },
    /// The output folder is missing, or the sequence folder cannot be created.
    #[error("cannot use output folder {path}: {source}")]
    Folder { path: PathBuf, source: io::Error },
    /// A sequence's folder exists and holds something that is not a frame, which replacing
    /// the sequence would delete.
    #[error(
        "{path} holds {file}, which is not a frame of a sequence: a sequence replaces its \
         folder whole, so give a new folder or one that holds only frame_NNNNN files"
    )]
    NotASequence { path: PathBuf, file: String },
    /// Writing or renaming an output file failed.
    #[error("cannot write {path}: {source}")]
    Io { path: PathBuf, source: io::Error },
    /// Frame sequences that cannot be encoded into one video ([`encode`]): a gap, a frame
    /// in two folders, EXR frames, frames of different sizes.
    #[error("{message}")]
    Sequence { message: String },
    /// The PNG or GIF encoder failed.
    #[error("cannot encode {path}: {source}")]
    Image {
        path: PathBuf,
        source: image::ImageError,
    },
    /// The EXR writer failed.
    #[error("cannot write {path}: {source}")]
    Exr {
        path: PathBuf,
        source: exr::error::Error,
    },
    /// A frame file could not be opened or read.
    #[error("cannot read {path}: {source}")]
    Read { path: PathBuf, source: io::Error },
    /// A PNG frame could not be decoded (`femto encode`'s input).
    #[error("cannot read {path}: {source}")]
    Decode {
        path: PathBuf,
        source: image::ImageError,
    },
    /// An EXR frame could not be read (not an EXR file, damaged, missing).
    #[error("cannot read {path}: {source}")]
    ExrRead {
        path: PathBuf,
        source: exr::error::Error,
    },
    /// The frame an EXR file's header declares would not fit in the memory budget.
    #[error("{path}: {source}")]
    Limit {
        path: PathBuf,
        source: crate::limits::LimitError,
    },
    /// OpenH264 refused a setting or a frame (internal failure).
    #[error("H.264 encoder failed for {path}: {message}")]
    Encoder { path: PathBuf, message: String },
    /// The MP4 muxer rejected the stream (internal failure).
    #[error("MP4 muxer failed for {path}: {source}")]
    Mux {
        path: PathBuf,
        source: muxide::api::MuxerError,
    },
}

/// Output kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VideoFormat {
    /// A folder of `frame_NNNNN.png` files, 8-bit sRGB.
    PngSequence,
    /// A folder of `frame_NNNNN.exr` files, 32-bit float linear RGB.
    ExrSequence,
    /// One H.264 MP4 file.
    Mp4,
    /// One animated GIF file.
    Gif,
}

impl VideoFormat {
    /// Parse a format name: `png`, `exr`, `mp4`, `gif` (case-insensitive, a leading dot is
    /// allowed so that an extension works too).
    pub fn parse(name: &str) -> Result<VideoFormat, VideoError> {
        match name.trim_start_matches('.').to_ascii_lowercase().as_str() {
            "png" => Ok(VideoFormat::PngSequence),
            "exr" => Ok(VideoFormat::ExrSequence),
            "mp4" => Ok(VideoFormat::Mp4),
            "gif" => Ok(VideoFormat::Gif),
            _ => Err(VideoError::UnknownFormat(name.to_string())),
        }
    }

    /// The format implied by a path's extension (`out.mp4`, `out.gif`); `None` when the path has
    /// no extension (a sequence folder), whose format must then be given by name.
    pub fn from_path(path: &Path) -> Option<Result<VideoFormat, VideoError>> {
        path.extension()
            .map(|e| VideoFormat::parse(&e.to_string_lossy()))
    }

    /// Whether the output is a folder of one file per frame.
    pub fn is_sequence(self) -> bool {
        matches!(self, VideoFormat::PngSequence | VideoFormat::ExrSequence)
    }

    pub fn as_str(self) -> &'static str {
        match self {
            VideoFormat::PngSequence => "png",
            VideoFormat::ExrSequence => "exr",
            VideoFormat::Mp4 => "mp4",
            VideoFormat::Gif => "gif",
        }
    }
}

impl fmt::Display for VideoFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            VideoFormat::PngSequence => "PNG sequence",
            VideoFormat::ExrSequence => "EXR sequence",
            VideoFormat::Mp4 => "MP4",
            VideoFormat::Gif => "GIF",
        })
    }
}

/// One output frame, row-major from the top row, RGB interleaved.
///
/// Only the buffer the chosen format reads must be filled (the other may be empty):
/// `linear_rgb` for EXR, `srgb8` for PNG, GIF and MP4.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    pub width: usize,
    pub height: usize,
    /// Scene-linear RGB, `width * height * 3` floats.
    pub linear_rgb: Vec<f32>,
    /// sRGB-encoded 8-bit RGB, `width * height * 3` bytes.
    pub srgb8: Vec<u8>,
}

/// File name of sequence frame `index`: `frame_00042.png`.
pub fn sequence_file_name(index: usize, format: VideoFormat) -> String {
    format!("frame_{index:05}.{}", format.as_str())
}

/// Convert an sRGB-encoded 8-bit RGB image (even width and height) to planar Y'CbCr 4:2:0 with
/// the BT.709 matrix in limited range (see the module doc), into caller-owned planes:
/// `y.len() == width * height`, `cb.len() == cr.len() == width * height / 4`.
pub fn srgb8_to_yuv420_bt709(
    srgb8: &[u8],
    width: usize,
    height: usize,
    y: &mut [u8],
    cb: &mut [u8],
    cr: &mut [u8],
) {
    debug_assert!(width.is_multiple_of(2) && height.is_multiple_of(2));
    debug_assert_eq!(srgb8.len(), width * height * 3);
    const KR: f32 = 0.2126;
    const KB: f32 = 0.0722;
    const KG: f32 = 1.0 - KR - KB;
    let luma = |r: f32, g: f32, b: f32| KR * r + KG * g + KB * b;
    let to_u8 = |v: f32| v.round().clamp(0.0, 255.0) as u8;
    for (i, px) in srgb8.chunks_exact(3).enumerate() {
        let e = luma(px[0] as f32, px[1] as f32, px[2] as f32) / 255.0;
        y[i] = to_u8(16.0 + 219.0 * e);
    }
    let half_w = width / 2;
    for cy in 0..height / 2 {
        for cx in 0..half_w {
            let mut sum = [0.0f32; 3];
            for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let o = ((2 * cy + dy) * width + 2 * cx + dx) * 3;
                for c in 0..3 {
                    sum[c] += srgb8[o + c] as f32;
                }
            }
            let [r, g, b] = sum.map(|s| s / (4.0 * 255.0));
            let e = luma(r, g, b);
            let j = cy * half_w + cx;
            cb[j] = to_u8(128.0 + 224.0 * (b - e) / (2.0 * (1.0 - KB)));
            cr[j] = to_u8(128.0 + 224.0 * (r - e) / (2.0 * (1.0 - KR)));
        }
    }
}

/// Planar 4:2:0 frame handed to OpenH264.
struct Yuv420 {
    width: usize,
    height: usize,
    y: Vec<u8>,
    u: Vec<u8>,
    v: Vec<u8>,
}

impl YUVSource for Yuv420 {
    fn dimensions(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    fn strides(&self) -> (usize, usize, usize) {
        (self.width, self.width / 2, self.width / 2)
    }

    fn y(&self) -> &[u8] {
        &self.y
    }

    fn u(&self) -> &[u8] {
        &self.u
    }

    fn v(&self) -> &[u8] {
        &self.v
    }
}

/// One encoded access unit (Annex B), held until `finish`.
struct Sample {
    annex_b: Vec<u8>,
    is_idr: bool,
}

struct Mp4State {
    encoder: Encoder,
    yuv: Yuv420,
    samples: Vec<Sample>,
}

/// A `Write` into a shared buffer: the GIF encoder owns its writer and writes the trailer when
/// dropped, so the bytes are collected here and written out atomically on `finish`.
#[derive(Clone, Default)]
struct SharedBuffer(Arc<Mutex<Vec<u8>>>);

impl Write for SharedBuffer {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0
            .lock()
            .map_err(|_| io::Error::other("GIF buffer poisoned"))?
            .extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

struct GifState {
    encoder: GifEncoder<SharedBuffer>,
    bytes: SharedBuffer,
}

enum Sink {
    /// Frames go into `tmp`, put in place as the writer's path by `finish`.
    Sequence {
        tmp: crate::atomic::TempDir,
    },
    Mp4(Box<Mp4State>),
    Gif(Box<GifState>),
}

/// Writes a stream of equally sized frames as a frame sequence, an MP4 or a GIF.
pub struct VideoWriter {
    path: PathBuf,
    format: VideoFormat,
    width: usize,
    height: usize,
    fps: f64,
    first_index: usize,
    /// Frames of the whole sequence, of which this writer may write a part (see
    /// [`VideoWriter::sequence_length`]).
    sequence_length: Option<usize>,
    /// Whether the folder records its sequence ([`VideoWriter::record_sequence`]).
    record_sequence: bool,
    pushed: usize,
    sink: Sink,
}

/// Run `write` through [`write_atomically_with`], naming `dest` in an error of the temporary
/// file.
fn write_file_atomically(
    dest: &Path,
    write: impl FnOnce(&Path) -> Result<(), VideoError>,
) -> Result<(), VideoError> {
    let io = |source| VideoError::Io {
        path: dest.to_path_buf(),
        source,
    };
    write_atomically_with(dest, io, write)
}

impl VideoWriter {
    /// Start a video of `width` x `height` frames at `fps` frames per second.
    ///
    /// For a sequence, `path` is a folder (its parent folders are created if missing; an
    /// existing one must hold only frames); for MP4 and GIF it is the file, whose folder must
    /// exist. Nothing is written to `path` until the writer is finished.
    pub fn create(
        path: &Path,
        format: VideoFormat,
        width: usize,
        height: usize,
        fps: f64,
    ) -> Result<VideoWriter, VideoError> {
        if width == 0 || height == 0 {
            return Err(VideoError::EmptySize { width, height });
        }
        if !(fps.is_finite() && fps > 0.0) {
            return Err(VideoError::BadFrameRate(fps));
        }
        let sink = match format {
            VideoFormat::PngSequence | VideoFormat::ExrSequence => {
                check_sequence_folder(path)?;
                let folder = |source| VideoError::Folder {
                    path: path.to_path_buf(),
                    source,
                };
                if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
                    fs::create_dir_all(parent).map_err(folder)?;
                }
                Sink::Sequence {
                    tmp: crate::atomic::temp_dir_beside(path).map_err(folder)?,
                }
            }
            VideoFormat::Mp4 | VideoFormat::Gif => {
                check_parent(path)?;
                stream_sink(path, format, width, height, fps)?
            }
        };
        Ok(VideoWriter {
            path: path.to_path_buf(),
            format,
            width,
            height,
            fps,
            first_index: 0,
            sequence_length: None,
            record_sequence: false,
            pushed: 0,
            sink,
        })
    }

    /// Start an MP4 or GIF of `width` x `height` frames at `fps` frames per second kept in
    /// memory ([`VideoWriter::finish_bytes`]); `name` stands for its file in messages.
    /// Nothing touches the file system (`femto view`'s saved videos).
    pub fn in_memory(
        name: &str,
        format: VideoFormat,
        width: usize,
        height: usize,
        fps: f64,
    ) -> Result<VideoWriter, VideoError> {
        let path = PathBuf::from(name);
        if format.is_sequence() {
            return Err(VideoError::Io {
                path,
                source: io::Error::other("a frame sequence is a folder of files, not one stream"),
            });
        }
        if width == 0 || height == 0 {
            return Err(VideoError::EmptySize { width, height });
        }
        if !(fps.is_finite() && fps > 0.0) {
            return Err(VideoError::BadFrameRate(fps));
        }
        let sink = stream_sink(&path, format, width, height, fps)?;
        Ok(VideoWriter {
            path,
            format,
            width,
            height,
            fps,
            first_index: 0,
            sequence_length: None,
            record_sequence: false,
            pushed: 0,
            sink,
        })
    }

    /// Number the first pushed frame `first_index` (sequences only: a render of frames `A..B`
    /// writes `frame_A` to `frame_{B-1}`). MP4 and GIF files always start at their first frame.
    pub fn first_frame_index(mut self, first_index: usize) -> VideoWriter {
        self.first_index = first_index;
        self
    }

    /// The whole sequence has `frames` frames, of which this writer writes a part (a render
    /// of `--frames A..B`): on `finish`, frames of this format numbered below `frames` and
    /// outside the written ones are kept from the folder's earlier sequence (split renders
    /// into one folder add up), and every other file goes. Without it the folder is replaced
    /// by exactly the written frames.
    pub fn sequence_length(mut self, frames: usize) -> VideoWriter {
        self.sequence_length = Some(frames);
        self
    }

    /// The folder records the sequence it is part of ([`sequence`]: N, the
    /// [`VideoWriter::sequence_length`]): a render of part of a sequence sets it, so that
    /// `femto encode` can refuse a set of parts that falls short of the whole. A whole
    /// sequence's folder holds its frames only.
    pub fn record_sequence(mut self, record: bool) -> VideoWriter {
        self.record_sequence = record;
        self
    }

    pub fn format(&self) -> VideoFormat {
        self.format
    }

    /// Frames pushed so far.
    pub fn frames_pushed(&self) -> usize {
        self.pushed
    }

    /// Add the next frame.
    pub fn push(&mut self, frame: &Frame) -> Result<(), VideoError> {
        let index = self.first_index + self.pushed;
        if frame.width != self.width || frame.height != self.height {
            return Err(VideoError::FrameSize {
                index,
                width: self.width,
                height: self.height,
                got_width: frame.width,
                got_height: frame.height,
            });
        }
        let expected = self.width * self.height * 3;
        let (field, got) = match self.format {
            VideoFormat::ExrSequence => ("linear_rgb", frame.linear_rgb.len()),
            _ => ("srgb8", frame.srgb8.len()),
        };
        if got != expected {
            return Err(VideoError::FrameData {
                index,
                format: self.format,
                field,
                expected,
                got,
            });
        }
        let (width, height) = (self.width, self.height);
        match &mut self.sink {
            Sink::Sequence { tmp } => {
                let name = sequence_file_name(index, self.format);
                let dest = tmp.path().join(&name);
                match self.format {
                    VideoFormat::PngSequence => write_png(&dest, &frame.srgb8, width, height),
                    _ => write_exr(&dest, &frame.linear_rgb, width, height),
                }
                .map_err(|e| e.at(self.path.join(&name)))?;
            }
            Sink::Mp4(state) => {
                let state = &mut **state;
                let yuv = &mut state.yuv;
                srgb8_to_yuv420_bt709(
                    &frame.srgb8,
                    width,
                    height,
                    &mut yuv.y,
                    &mut yuv.u,
                    &mut yuv.v,
                );
                let encoded =
                    state
                        .encoder
                        .encode(&state.yuv)
                        .map_err(|e| VideoError::Encoder {
                            path: self.path.clone(),
                            message: format!("frame {index}: {e}"),
                        })?;
                let annex_b = encoded.to_vec();
                if annex_b.is_empty() {
                    return Err(VideoError::Encoder {
                        path: self.path.clone(),
                        message: format!(
                            "frame {index}: no bitstream (frame type {:?})",
                            encoded.frame_type()
                        ),
                    });
                }
                let is_idr = encoded.frame_type() == FrameType::IDR;
                state.samples.push(Sample { annex_b, is_idr });
            }
            Sink::Gif(state) => {
                let image = rgba_image(&frame.srgb8, width, height);
                let delay = gif_delay(self.fps);
                state
                    .encoder
                    .encode_frame(image::Frame::from_parts(image, 0, 0, delay))
                    .map_err(|source| VideoError::Image {
                        path: self.path.clone(),
                        source,
                    })?;
            }
        }
        self.pushed += 1;
        Ok(())
    }

    /// Complete the output: write the MP4 or GIF file (atomically), or put a sequence's
    /// folder in place (replacing an earlier one whole). Returns the number of frames written.
    pub fn finish(self) -> Result<usize, VideoError> {
        if !self.format.is_sequence() {
            let path = self.path.clone();
            let (pushed, data) = self.finish_bytes()?;
            write_file_atomically(&path, |tmp| {
                let io = |source| VideoError::Io {
                    path: path.clone(),
                    source,
                };
                let mut file = fs::File::create(tmp).map_err(io)?;
                file.write_all(&data).map_err(io)?;
                file.sync_all().map_err(io)
            })?;
            return Ok(pushed);
        }
        let path = self.path;
        match self.sink {
            Sink::Sequence { tmp } => {
                // Checked again: the folder may have changed while the frames were made.
                check_sequence_folder(&path)?;
                if let Some(total) = self.sequence_length {
                    let written = self.first_index..self.first_index + self.pushed;
                    keep_earlier_frames(&path, tmp.path(), self.format, total, written)?;
                    if self.record_sequence {
                        let frames = sequence::SequenceFile { frames: total };
                        sequence::write_sequence_file(tmp.path(), frames)?;
                    }
                }
                crate::atomic::replace_dir(tmp, &path)
                    .map_err(|source| VideoError::Io { path, source })?;
                Ok(self.pushed)
            }
            Sink::Mp4(_) | Sink::Gif(_) => unreachable!("streams are finished above"),
        }
    }

    /// Finish an MP4 or GIF: the frames written and the file's bytes, written nowhere.
    pub fn finish_bytes(self) -> Result<(usize, Vec<u8>), VideoError> {
        let path = self.path;
        match self.sink {
            Sink::Sequence { .. } => Err(VideoError::Io {
                path,
                source: io::Error::other("a frame sequence is a folder of files, not one stream"),
            }),
            Sink::Mp4(state) => {
                if state.samples.is_empty() {
                    return Err(VideoError::NoFrames { path });
                }
                let data = mp4_bytes(&path, &state.samples, self.width, self.height, self.fps)?;
                Ok((self.pushed, data))
            }
            Sink::Gif(state) => {
                if self.pushed == 0 {
                    return Err(VideoError::NoFrames { path });
                }
                let GifState { encoder, bytes } = *state;
                // Dropping the encoder writes the GIF trailer into `bytes`.
                drop(encoder);
                let data = std::mem::take(&mut *bytes.0.lock().map_err(|_| VideoError::Io {
                    path: path.clone(),
                    source: io::Error::other("GIF buffer poisoned"),
                })?);
                Ok((self.pushed, data))
            }
        }
    }
}

/// GIF delays are whole hundredths of a second: `100 / fps` rounded to the nearest, within
/// 1..=65535.
fn gif_delay(fps: f64) -> Delay {
    let centis = (100.0 / fps).round().clamp(1.0, u16::MAX as f64) as u32;
    Delay::from_numer_denom_ms(centis * 10, 1)
}

/// Whether `name` is a frame of a sequence in either format (`frame_` digits `.png`/`.exr`).
fn is_frame_name(name: &str) -> bool {
    name.strip_prefix("frame_")
        .and_then(|r| r.strip_suffix(".png").or_else(|| r.strip_suffix(".exr")))
        .is_some_and(|digits| !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()))
}

/// Link (or copy) into `tmp` the frames of `format` of the folder `dest` that belong to a
/// sequence of `total` frames and were not `written` now.
fn keep_earlier_frames(
    dest: &Path,
    tmp: &Path,
    format: VideoFormat,
    total: usize,
    written: std::ops::Range<usize>,
) -> Result<(), VideoError> {
    let Ok(entries) = fs::read_dir(dest) else {
        return Ok(());
    };
    let suffix = format!(".{}", format.as_str());
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let index = name
            .strip_prefix("frame_")
            .and_then(|r| r.strip_suffix(suffix.as_str()))
            .and_then(|d| d.parse::<usize>().ok());
        let Some(k) = index else { continue };
        if k >= total || written.contains(&k) || name != sequence_file_name(k, format) {
            continue;
        }
        let (from, to) = (entry.path(), tmp.join(&name));
        fs::hard_link(&from, &to)
            .or_else(|_| fs::copy(&from, &to).map(drop))
            .map_err(|source| VideoError::Io { path: from, source })?;
    }
    Ok(())
}

/// A sequence's destination must be missing, or a folder that holds frames only (it is
/// replaced whole).
fn check_sequence_folder(path: &Path) -> Result<(), VideoError> {
    let folder = |source| VideoError::Folder {
        path: path.to_path_buf(),
        source,
    };
    match fs::symlink_metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(folder(e)),
        Ok(m) if !m.is_dir() => Err(folder(io::Error::new(
            io::ErrorKind::AlreadyExists,
            "it exists and is not a folder",
        ))),
        Ok(_) => {
            for entry in fs::read_dir(path).map_err(folder)? {
                let entry = entry.map_err(folder)?;
                let name = entry.file_name().to_string_lossy().into_owned();
                let is_file = entry.file_type().is_ok_and(|t| t.is_file());
                if !(is_file && (is_frame_name(&name) || name == sequence::SEQUENCE_FILE)) {
                    return Err(VideoError::NotASequence {
                        path: path.to_path_buf(),
                        file: name,
                    });
                }
            }
            Ok(())
        }
    }
}

/// The sink of an MP4 or GIF stream of `width` x `height` frames (`path` names it in errors).
fn stream_sink(
    path: &Path,
    format: VideoFormat,
    width: usize,
    height: usize,
    fps: f64,
) -> Result<Sink, VideoError> {
    Ok(match format {
        VideoFormat::Gif => {
            if width > u16::MAX as usize || height > u16::MAX as usize {
                return Err(VideoError::TooLarge {
                    format,
                    width,
                    height,
                    limit: "65535x65535",
                });
            }
            let bytes = SharedBuffer::default();
            let mut encoder = GifEncoder::new_with_speed(bytes.clone(), 10);
            encoder
                .set_repeat(Repeat::Infinite)
                .map_err(|source| VideoError::Image {
                    path: path.to_path_buf(),
                    source,
                })?;
            Sink::Gif(Box::new(GifState { encoder, bytes }))
        }
        _ => Sink::Mp4(Box::new(mp4_state(path, width, height, fps)?)),
    })
}

fn check_parent(path: &Path) -> Result<(), VideoError> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if parent.is_dir() {
        Ok(())
    } else {
        Err(VideoError::Folder {
            path: parent.to_path_buf(),
            source: io::Error::new(io::ErrorKind::NotFound, "no such folder"),
        })
    }
}

fn rgba_image(srgb8: &[u8], width: usize, height: usize) -> RgbaImage {
    let mut rgba = Vec::with_capacity(width * height * 4);
    for px in srgb8.chunks_exact(3) {
        rgba.extend_from_slice(&[px[0], px[1], px[2], 255]);
    }
    RgbaImage::from_raw(width as u32, height as u32, rgba)
        .expect("buffer length is width * height * 4 by construction")
}

impl VideoError {
    /// The same error naming `path`: a frame written into the sequence's temporary folder is
    /// reported by the name it will have in the destination, where the user looks for it.
    fn at(self, path: PathBuf) -> VideoError {
        match self {
            VideoError::Io { source, .. } => VideoError::Io { path, source },
            VideoError::Image { source, .. } => VideoError::Image { path, source },
            VideoError::Exr { source, .. } => VideoError::Exr { path, source },
            other => other,
        }
    }
}

/// Encode an 8-bit sRGB frame as PNG into `out`: the bytes of a frame of a PNG sequence.
pub fn encode_png(
    srgb8: &[u8],
    width: usize,
    height: usize,
    out: &mut impl Write,
) -> Result<(), image::ImageError> {
    PngEncoder::new(out).write_image(srgb8, width as u32, height as u32, ExtendedColorType::Rgb8)
}

/// Write one 8-bit sRGB frame as the PNG file `dest` (atomically: a temporary file beside it,
/// renamed).
pub fn write_png(dest: &Path, srgb8: &[u8], width: usize, height: usize) -> Result<(), VideoError> {
    write_file_atomically(dest, |tmp| {
        let image_err = |source| VideoError::Image {
            path: dest.to_path_buf(),
            source,
        };
        let file = fs::File::create(tmp).map_err(|source| VideoError::Io {
            path: dest.to_path_buf(),
            source,
        })?;
        let mut out = BufWriter::new(file);
        encode_png(srgb8, width, height, &mut out).map_err(image_err)?;
        out.flush().map_err(|source| VideoError::Io {
            path: dest.to_path_buf(),
            source,
        })
    })
}

/// Read an OpenEXR frame's RGB channels (what [`write_exr`] and EXR sequences write):
/// width, height and the scene-linear RGB, row-major from the top row.
pub fn read_exr(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), VideoError> {
    let read_err = |source| VideoError::ExrRead {
        path: path.to_path_buf(),
        source,
    };
    // The header first: the crate allocates the declared data window before it reads a
    // block (a window of 16777216 x 1048576 pixels asked 211 TB).
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(read_err)?;
    let file_bytes = std::fs::metadata(path)
        .map_err(|e| read_err(exr::error::Error::Io(e)))?
        .len();
    for header in &meta.headers {
        let (w, h) = (header.layer_size.0, header.layer_size.1);
        // Its pixels as stored (2 bytes a sample at the least) cannot be more than the file
        // holds inflated at deflate's largest ratio: a 598-byte file declaring a window of
        // 25 million pixels had the whole frame allocated before its blocks were read.
        let stored = (w as u128) * (h as u128) * (header.channels.list.len() as u128) * 2;
        let most = u128::from(file_bytes) * u128::from(MAX_DEFLATE_RATIO);
        if stored > most {
            return Err(read_err(exr::error::Error::Invalid(
                format!(
                    "a data window of {w} x {h} pixels ({} channels) in a {file_bytes}-byte \
                     file: more than its bytes hold at deflate's 1032:1; is the file truncated or \
                     its header damaged?",
                    header.channels.list.len()
                )
                .into(),
            )));
        }
        crate::limits::check_decoded(
            &[h, w],
            std::mem::size_of::<[f32; 3]>(),
            1,
            format_args!("a frame of {w} x {h} pixels (RGB float32)"),
            "is the header damaged?",
        )
        .map_err(|source| VideoError::Limit {
            path: path.to_path_buf(),
            source,
        })?;
    }
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (size.0, vec![[0.0f32; 3]; size.0 * size.1]),
        |(w, buf): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            buf[pos.1 * *w + pos.0] = [r, g, b];
        },
    )
    .map_err(read_err)?;
    let size = image.layer_data.size;
    Ok((size.0, size.1, image.layer_data.channel_data.pixels.1))
}

/// The largest expansion of deflate (RFC 1951): the most an EXR frame read by femto may decode
/// per stored byte. Zip and zips decode at most this, rle 64:1 and none 1:1 (femto writes its
/// frames with the exr crate's default lossless encoding); a piz, b44 or dwa frame of nearly
/// constant content could decode further, and is refused as well.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// Write one frame of scene-linear RGB as the OpenEXR file `dest` (atomically).
pub fn write_exr(
    dest: &Path,
    linear_rgb: &[f32],
    width: usize,
    height: usize,
) -> Result<(), VideoError> {
    write_file_atomically(dest, |tmp| {
        exr::prelude::write_rgb_file(tmp, width, height, |x, y| {
            let o = (y * width + x) * 3;
            (linear_rgb[o], linear_rgb[o + 1], linear_rgb[o + 2])
        })
        .map_err(|source| VideoError::Exr {
            path: dest.to_path_buf(),
            source,
        })
    })
}

/// H.264 quantiser range. OpenH264's buffer-based rate control starts a stream at the top of
/// the range and lowers the quantiser by one per delivered frame down to the bottom (18 is
/// commonly taken as visually lossless), raising it briefly at scene changes. Unlike its
/// bit-rate modes, it keeps every frame without complaining that frame skipping is off.
const MP4_QP_MIN: u8 = 16;
const MP4_QP_MAX: u8 = 22;

/// Nominal bit rate handed to OpenH264: 0.2 bit per pixel per frame (about 12 Mbit/s at
/// 1080p30), within 1..=100 Mbit/s. Buffer-based rate control does not steer towards it; the
/// encoder uses it to pick the H.264 level written in the stream.
fn mp4_bitrate_bps(width: usize, height: usize, fps: f64) -> u32 {
    let bps = 0.2 * width as f64 * height as f64 * fps;
    bps.clamp(1.0e6, 100.0e6) as u32
}

fn mp4_state(path: &Path, width: usize, height: usize, fps: f64) -> Result<Mp4State, VideoError> {
    if !width.is_multiple_of(2) || !height.is_multiple_of(2) {
        return Err(VideoError::OddSize {
            width,
            height,
            even_width: width + width % 2,
            even_height: height + height % 2,
        });
    }
    if width.min(height) < MP4_MIN_SIDE {
        return Err(VideoError::TooSmall {
            format: VideoFormat::Mp4,
            width,
            height,
            limit: "16x16 (OpenH264 encodes whole 16 x 16 macroblocks)",
        });
    }
    if width.max(height) > MP4_MAX_LONG_SIDE || width.min(height) > MP4_MAX_SHORT_SIDE {
        return Err(VideoError::TooLarge {
            format: VideoFormat::Mp4,
            width,
            height,
            limit: "3840x2160 (or 2160x3840)",
        });
    }
    let keyframe_every = (2.0 * fps).round().max(1.0) as u32;
    let config = EncoderConfig::new()
        .usage_type(UsageType::CameraVideoRealTime)
        .rate_control_mode(RateControlMode::Bufferbased)
        .bitrate(BitRate::from_bps(mp4_bitrate_bps(width, height, fps)))
        .max_frame_rate(FrameRate::from_hz(fps as f32))
        .skip_frames(false)
        .qp(QpRange::new(MP4_QP_MIN, MP4_QP_MAX))
        .intra_frame_period(IntraFramePeriod::from_num_frames(keyframe_every))
        .vui(VuiConfig::bt709().transfer_characteristics(TransferCharacteristics::Srgb));
    let encoder = Encoder::with_api_config(OpenH264API::from_source(), config).map_err(|e| {
        VideoError::Encoder {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    })?;
    Ok(Mp4State {
        encoder,
        yuv: Yuv420 {
            width,
            height,
            y: vec![0; width * height],
            u: vec![128; width * height / 4],
            v: vec![128; width * height / 4],
        },
        samples: Vec::new(),
    })
}

/// The MP4 file of `samples` (H.264 access units), as bytes; `path` names it in errors.
fn mp4_bytes(
    path: &Path,
    samples: &[Sample],
    width: usize,
    height: usize,
    fps: f64,
) -> Result<Vec<u8>, VideoError> {
    use muxide::api::{MuxerBuilder, VideoCodec};
    let mux_err = |source| VideoError::Mux {
        path: path.to_path_buf(),
        source,
    };
    let mut muxer = MuxerBuilder::new(io::Cursor::new(Vec::new()))
        .video(VideoCodec::H264, width as u32, height as u32, fps)
        .build()
        .map_err(mux_err)?;
    for (k, s) in samples.iter().enumerate() {
        muxer
            .write_video(k as f64 / fps, &s.annex_b, s.is_idr)
            .map_err(mux_err)?;
    }
    muxer.finish_in_place().map_err(mux_err)?;
    Ok(muxer.into_writer().into_inner())
}

pub mod encode;
pub mod sequence;

#[cfg(test)]
mod tests;
