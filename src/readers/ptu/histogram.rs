//! The two passes over a PTU file's records, each streamed from disk in blocks (the records
//! are never all in memory):
//!
//! 1. [`scan`]: photons, the start-stop bins and channels in use, the frames and lines the
//!    markers delimit, and the mean line time (the time between a line's start and stop
//!    markers, rounded);
//! 2. [`image()`] and [`point()`]: the photons histogrammed into `[y][x][t]` counts.
//!
//! The rules are `ptufile`'s (`decode_info`, `decode_t3_image`, `decode_t3_histogram`), so
//! that counts agree exactly: a frame starts at the first line start after the start or a
//! frame marker; a first or last frame with fewer lines than `ImgHdr_PixY` is incomplete and
//! left out; a photon belongs to the line whose start marker precedes it, until that line's
//! stop marker, at pixel `(t - line start) / pixel time` when that is inside the line time;
//! lines past `ImgHdr_PixY` in a frame are left out; odd lines of a bidirectional scan run
//! backwards.

use super::records::{Decoder, Event, RecordType};
use crate::readers::ReaderError;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// Records read per block.
const BLOCK_RECORDS: usize = 1 << 16;

/// Call `f` with each of the `count` records from byte `at` of the file, in order, until it
/// returns false.
pub fn each_record(
    path: &Path,
    at: u64,
    count: u64,
    mut f: impl FnMut(u32) -> bool,
) -> Result<(), ReaderError> {
    let io = |source| ReaderError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    file.seek(SeekFrom::Start(at)).map_err(io)?;
    let mut r = BufReader::with_capacity(4 * BLOCK_RECORDS, file);
    let mut buf = vec![0u8; 4 * BLOCK_RECORDS];
    let mut left = count;
    while left > 0 {
        let n = (left.min(BLOCK_RECORDS as u64)) as usize;
        r.read_exact(&mut buf[..4 * n]).map_err(io)?;
        for b in buf[..4 * n].chunks_exact(4) {
            if !f(u32::from_le_bytes([b[0], b[1], b[2], b[3]])) {
                return Ok(());
            }
        }
        left -= n as u64;
    }
    Ok(())
}

/// The marker masks of a scan (`ImgHdr_LineStart`, `LineStop`, `Frame`: marker numbers,
/// 1-based) and the lines of a frame (`ImgHdr_PixY`; 0 when the file is no image).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Markers {
    pub line_start: u32,
    pub line_stop: u32,
    pub frame: u32,
    pub lines_in_frame: u64,
}

/// What the first pass found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scan {
    pub photons: u64,
    pub markers: u64,
    /// One more than the largest start-stop bin of a photon (0: no photon).
    pub bins_used: u32,
    /// Bit `c` set: channel `c` has photons.
    pub channels: u64,
    /// Complete frames, incomplete first and last ones left out.
    pub frames: u64,
    pub lines: u64,
    pub skip_first_frame: bool,
    /// The mean time from a line's start marker to its stop marker, global clock, rounded.
    pub line_time: u64,
}

impl Scan {
    /// The first and last channel with photons (`(0, 0)` when none has).
    pub fn channel_span(&self) -> (u32, u32) {
        if self.channels == 0 {
            return (0, 0);
        }
        (
            self.channels.trailing_zeros(),
            63 - self.channels.leading_zeros(),
        )
    }
}

/// The first pass over the records ([`Scan`]).
pub fn scan(
    path: &Path,
    at: u64,
    count: u64,
    kind: RecordType,
    m: Markers,
) -> Result<Scan, ReaderError> {
    let mut s = Scan::default();
    let mut d = Decoder::new(kind);
    let (mut skip_first, mut skip_last) = (false, false);
    let mut line_start: Option<u64> = None;
    let mut time_in_lines = 0u64;
    let mut max_dtime = 0u32;
    let mut y = 0u64;
    let l = m.lines_in_frame;
    each_record(path, at, count, |r| {
        match d.next(r) {
            (_, Event::Photon { channel, dtime }) => {
                s.photons += 1;
                if channel < kind.max_channels() {
                    s.channels |= 1 << channel;
                }
                if dtime > max_dtime && dtime < kind.max_bins() {
                    max_dtime = dtime;
                }
            }
            (t, Event::Marker(bits)) => {
                s.markers += 1;
                if bits & m.frame != 0 {
                    if l > y + 1 {
                        if s.frames == 1 {
                            skip_first = true;
                        } else {
                            skip_last = true;
                        }
                    } else {
                        skip_last = false;
                    }
                    if bits & m.line_stop == 0 {
                        line_start = None;
                    }
                    y = 0;
                }
                if bits & m.line_stop != 0 {
                    if let Some(t0) = line_start.filter(|_| l == 0 || l >= y) {
                        time_in_lines += t - t0;
                    }
                    line_start = None;
                }
                if bits & m.line_start != 0 {
                    line_start = Some(t);
                    if y == 0 {
                        s.frames += 1;
                    }
                    y += 1;
                    if l == 0 || l >= y {
                        s.lines += 1;
                    }
                }
            }
            (_, Event::None) => {}
        }
        true
    })?;
    s.bins_used = if s.photons > 0 { max_dtime + 1 } else { 0 };
    if s.frames > 1 && y > 0 && l > y + 1 {
        skip_last = true;
    }
    if s.frames == 0 {
        skip_first = false;
    } else {
        if skip_first {
            s.frames -= 1;
        }
        if skip_last && s.frames > 0 {
            s.frames -= 1;
        }
    }
    s.skip_first_frame = skip_first;
    s.line_time = if s.lines > 0 {
        (time_in_lines as f64 / s.lines as f64).round() as u64
    } else {
        0
    };
    Ok(s)
}

/// How the second pass histograms an image scan.
#[derive(Clone, Debug, PartialEq)]
pub struct ImagePlan {
    pub nx: usize,
    pub ny: usize,
    pub nt: usize,
    /// Global clock per pixel and per line (the part of a line that holds pixels).
    pub pixel_time: u64,
    pub line_time: u64,
    pub markers: Markers,
    /// Complete frames ([`Scan::frames`], at least 1) and whether the first is skipped.
    pub frames: u64,
    pub skip_first_frame: bool,
    /// The frame kept (`None`: all summed).
    pub frame: Option<u64>,
    /// Channels counted: `lo..hi`.
    pub channels: (u32, u32),
    pub bidirectional: bool,
}

/// The second pass of an image scan: counts `[y][x][t]` into `hist` (`ny * nx * nt`).
/// Returns the photons counted.
pub fn image(
    path: &Path,
    at: u64,
    count: u64,
    kind: RecordType,
    p: &ImagePlan,
    hist: &mut [u32],
) -> Result<u64, ReaderError> {
    let mut d = Decoder::new(kind);
    let m = p.markers;
    let mut line_start: Option<u64> = None;
    let mut frame: i64 = if p.skip_first_frame { -2 } else { -1 };
    let mut iy: i64 = -1;
    let mut row = 0usize;
    let mut counted = 0u64;
    let (nt, nx) = (p.nt as u32, p.nx as u64);
    let keep_frame = |f: i64| p.frame.is_none_or(|k| k as i64 == f);
    each_record(path, at, count, |r| {
        match d.next(r) {
            (t, Event::Photon { channel, dtime }) => {
                let Some(t0) = line_start else { return true };
                if channel < p.channels.0 || channel >= p.channels.1 || dtime >= nt {
                    return true;
                }
                let mut dt = t as i64 - t0 as i64;
                if p.bidirectional && row % 2 == 1 {
                    dt = p.line_time as i64 - 1 - dt;
                }
                if dt < 0 || dt >= p.line_time as i64 {
                    return true;
                }
                let ix = dt as u64 / p.pixel_time;
                if ix < nx {
                    hist[(row * p.nx + ix as usize) * p.nt + dtime as usize] += 1;
                    counted += 1;
                }
            }
            (t, Event::Marker(bits)) => {
                if bits & m.frame != 0 {
                    line_start = None;
                    iy = -1;
                }
                if bits & m.line_stop != 0 {
                    line_start = None;
                }
                if bits & m.line_start != 0 {
                    iy += 1;
                    if iy == 0 {
                        frame += 1;
                        if frame == p.frames as i64 {
                            return false;
                        }
                    }
                    if frame >= 0 && (iy as usize) < p.ny && keep_frame(frame) {
                        row = iy as usize;
                        line_start = Some(t);
                    } else {
                        line_start = None;
                    }
                }
            }
            (_, Event::None) => {}
        }
        true
    })?;
    Ok(counted)
}

/// The histogram of a point measurement: every photon of channels `lo..hi` with a
/// start-stop bin below `nt`, into `hist` (`nt`). Returns the photons counted.
pub fn point(
    path: &Path,
    at: u64,
    count: u64,
    kind: RecordType,
    channels: (u32, u32),
    hist: &mut [u32],
) -> Result<u64, ReaderError> {
    let mut d = Decoder::new(kind);
    let mut counted = 0u64;
    each_record(path, at, count, |r| {
        if let (_, Event::Photon { channel, dtime }) = d.next(r) {
            if channel >= channels.0 && channel < channels.1 && (dtime as usize) < hist.len() {
                hist[dtime as usize] += 1;
                counted += 1;
            }
        }
        true
    })?;
    Ok(counted)
}
