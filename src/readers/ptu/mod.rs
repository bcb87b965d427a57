//! PicoQuant PTU files (PQTTTR): the time-tagged photon records that PicoHarp, HydraHarp,
//! TimeHarp and MultiHarp TCSPC units write, read directly and histogrammed into the cube's
//! `[y][x][t]` with the file's bin width (`MeasDesc_Resolution`).
//!
//! - T3 image scans (`Measurement_SubMode` 3): the scanner's line start, line stop and frame
//!   markers (`ImgHdr_LineStart`, `LineStop`, `Frame`) place each photon in a pixel of an
//!   `ImgHdr_PixX` x `ImgHdr_PixY` image; the pixel time is `ImgHdr_TimePerPixel`, else the
//!   mean line time over `PixX`. Frames and channels are summed, or one is kept with
//!   `--select frame=I` / `--select channel=I` (I indexes the frames and the channels with
//!   photons, from the first, as `femto info` and `ptufile` number them).
//! - T3 point measurements (sub-modes 0 to 1): one pixel, every photon.
//! - Line scans, sinusoidal scanning and T2 records are refused in one line naming them.
//!
//! The cube has one bin per start-stop time up to the last one holding a photon, from 0 ps.
//! The records are streamed twice ([`histogram`]); only the histogram is held, and its size
//! is checked against the memory budget first. Counts and peak bins equal `ptufile`'s
//! (`decode_image(frame=-1, channel=-1)`, `decode_histogram`): the rules are its rules.
//!
//! No Rust crate was found that does this: `tttr-toolbox` 0.4.5 (crates.io) decodes PicoHarp
//! T2 and HydraHarp T2/T3 records for correlations, but not PicoHarp T3 (the record type of
//! the real scan in `../shared/data/real/ptu`) nor image reconstruction from markers, and
//! depends on pyo3 0.19, clap 2 and ndarray 0.15.

pub mod histogram;
pub mod records;
pub mod tags;

pub use tags::MAGIC;

use super::layout::{AxisRef, LayoutOptions};
use super::{Capture, Dtype, Format, ReaderError, TimeSpec};
use histogram::{ImagePlan, Markers, Scan};
use records::RecordType;
use std::path::Path;
use tags::Header;

fn bad(path: &Path, key: &str, m: impl Into<String>) -> ReaderError {
    ReaderError::invalid(path, key, m)
}

/// What the header says of the measurement.
struct Measurement {
    kind: RecordType,
    records_at: u64,
    records: u64,
    /// Records the header declares beyond those the file holds.
    missing: u64,
    dt_ps: f64,
    global_resolution_s: f64,
    image: Option<(usize, usize, Markers)>,
}

/// A required numeric tag.
fn need(path: &Path, h: &Header, key: &str) -> Result<f64, ReaderError> {
    h.float(key).ok_or_else(|| {
        bad(
            path,
            key,
            "missing from the header (a PTU file of a T3 measurement has it)",
        )
    })
}

/// The measurement the header describes, refused in one line where femto does not read it.
fn measurement(path: &Path, h: &Header, len: u64) -> Result<Measurement, ReaderError> {
    let code = h
        .int("TTResultFormat_TTTRRecType")
        .ok_or_else(|| bad(path, "TTResultFormat_TTTRRecType", "missing"))?;
    let kind = RecordType::from_code(code).map_err(|what| {
        bad(
            path,
            "TTResultFormat_TTTRRecType",
            format!(
                "{what} records are not read (T3 records of PicoHarp, HydraHarp, TimeHarp and \
                 MultiHarp are: measure in T3 mode, or histogram the time tags first)"
            ),
        )
    })?;
    if let Some(bits) = h
        .int("TTResultFormat_BitsPerRecord")
        .filter(|&b| b != 32 && b != 0)
    {
        return Err(bad(
            path,
            "TTResultFormat_BitsPerRecord",
            format!("{bits}: records of 32 bits are read"),
        ));
    }
    let dt_ps = need(path, h, "MeasDesc_Resolution")? * 1e12;
    super::check_dt(path, "MeasDesc_Resolution", dt_ps)?;
    let global = need(path, h, "MeasDesc_GlobalResolution")?;
    let available = len.saturating_sub(h.records_at) / 4;
    let declared = h.int("TTResult_NumberOfRecords").unwrap_or(0);
    let records = if declared > 0 {
        (declared as u64).min(available)
    } else {
        available
    };
    let submode = h.int("Measurement_SubMode").unwrap_or(0);
    let dims = h.int("ImgHdr_Dimensions");
    let image = match submode {
        3 if dims.unwrap_or(3) == 3 => Some(image_header(path, h)?),
        2 if dims.unwrap_or(2) == 2 => {
            return Err(bad(
                path,
                "Measurement_SubMode",
                "2: a line scan; femto reads T3 image scans and point measurements",
            ))
        }
        _ => None,
    };
    Ok(Measurement {
        kind,
        records_at: h.records_at,
        records,
        missing: (declared.max(0) as u64).saturating_sub(records),
        dt_ps,
        global_resolution_s: global,
        image,
    })
}

/// An image scan's size and markers.
fn image_header(path: &Path, h: &Header) -> Result<(usize, usize, Markers), ReaderError> {
    if h.int("ImgHdr_SinCorrection").unwrap_or(0) != 0 {
        return Err(bad(
            path,
            "ImgHdr_SinCorrection",
            "sinusoidal scanning is not read",
        ));
    }
    let int = |k: &str| -> Result<i64, ReaderError> {
        h.int(k)
            .ok_or_else(|| bad(path, k, "missing from the header of an image scan"))
    };
    let (px, py) = (int("ImgHdr_PixX")?, int("ImgHdr_PixY")?);
    if !(1..=1 << 16).contains(&px) || !(1..=1 << 16).contains(&py) {
        return Err(bad(path, "ImgHdr_PixX", format!("{px} x {py} pixels")));
    }
    let mask = |k: &str| -> Result<u32, ReaderError> {
        match int(k)? {
            b @ 1..=15 => Ok(1 << (b - 1)),
            b => Err(bad(path, k, format!("marker {b}: markers 1 to 15 exist"))),
        }
    };
    let m = Markers {
        line_start: mask("ImgHdr_LineStart")?,
        line_stop: mask("ImgHdr_LineStop")?,
        frame: mask("ImgHdr_Frame")?,
        lines_in_frame: py as u64,
    };
    if m.line_start == m.line_stop || m.frame == m.line_start || m.frame == m.line_stop {
        return Err(bad(
            path,
            "ImgHdr_LineStart",
            "the line start, line stop and frame markers must differ",
        ));
    }
    Ok((px as usize, py as usize, m))
}

/// Index `i` kept of the axis `name` (`frame`/`T`, `channel`/`C`), from `--select`.
fn selected(opts: &LayoutOptions, names: &[&str]) -> Option<usize> {
    opts.select.iter().find_map(|(r, i)| match r {
        AxisRef::Name(n) if names.iter().any(|m| m.eq_ignore_ascii_case(n)) => Some(*i),
        _ => None,
    })
}

/// Refuse layout flags that do not apply: PTU files name their axes.
fn check_options(path: &Path, opts: &LayoutOptions, image: bool) -> Result<(), ReaderError> {
    if opts.time_axis.is_some() || opts.transpose {
        return Err(bad(
            path,
            "--time-axis",
            "a PTU file's time axis is its start-stop time; leave out --time-axis and --transpose",
        ));
    }
    let known: &[&str] = if image {
        &["frame", "T", "channel", "C"]
    } else {
        &["channel", "C"]
    };
    let refs = opts.select.iter().map(|(r, _)| r).chain(opts.sum.iter());
    for r in refs {
        let ok = matches!(r, AxisRef::Name(n) if known.iter().any(|k| k.eq_ignore_ascii_case(n)));
        if !ok {
            return Err(bad(
                path,
                "--select",
                format!(
                    "{r}: a PTU {} has the extra axes {}",
                    if image { "image" } else { "point measurement" },
                    if image {
                        "frame and channel"
                    } else {
                        "channel"
                    }
                ),
            ));
        }
    }
    Ok(())
}

/// The histogram's memory, checked before it is allocated.
fn allocate(path: &Path, ny: usize, nx: usize, nt: usize) -> Result<Vec<u32>, ReaderError> {
    let n = (ny as u128)
        .checked_mul(nx as u128)
        .and_then(|v| v.checked_mul(nt as u128));
    super::check_bytes(
        path,
        n.and_then(|n| n.checked_mul(4)),
        &format!("the histogram of {ny} x {nx} pixels x {nt} bins"),
    )?;
    Ok(vec![0u32; n.expect("checked above") as usize])
}

/// Read the PTU file at `path` into a [`Capture`] (module documentation).
pub fn read(path: &Path, opts: &LayoutOptions) -> Result<Capture, ReaderError> {
    let io = |source| ReaderError::Io {
        path: path.to_path_buf(),
        source,
    };
    let len = std::fs::metadata(path).map_err(io)?.len();
    let mut f = std::io::BufReader::new(std::fs::File::open(path).map_err(io)?);
    let h = tags::read_header(path, &mut f, len)?;
    drop(f);
    let m = measurement(path, &h, len)?;
    check_options(path, opts, m.image.is_some())?;
    let markers = m.image.map_or(
        Markers {
            line_start: 0,
            line_stop: 0,
            frame: 0,
            lines_in_frame: 0,
        },
        |(_, _, mk)| mk,
    );
    let s = histogram::scan(path, m.records_at, m.records, m.kind, markers)?;
    if s.photons == 0 {
        return Err(bad(
            path,
            "records",
            format!("{} records, no photon", m.records),
        ));
    }
    let (first, last) = s.channel_span();
    let n_channels = (last - first + 1) as usize;
    let channel = selected(opts, &["channel", "C"]);
    if let Some(c) = channel.filter(|&c| c >= n_channels) {
        return Err(bad(path, "--select", format!("channel={c}: the file has {n_channels} channel(s) with photons (0 to {}: hardware channels {first} to {last})", n_channels - 1)));
    }
    let channels = match channel {
        Some(c) => (first + c as u32, first + c as u32 + 1),
        None => (first, last + 1),
    };
    let nt = s.bins_used as usize;
    let mut notes = vec![
        ("ptu.record_type".to_string(), m.kind.name().to_string()),
        ("ptu.photons_in_file".to_string(), s.photons.to_string()),
    ];
    if let Some(hw) = h.text("HW_Type") {
        notes.push(("ptu.hardware".into(), hw.to_string()));
    }
    if let Some(r) = h.int("TTResult_SyncRate") {
        notes.push(("ptu.sync_rate_hz".into(), r.to_string()));
    }
    if m.missing > 0 {
        notes.push((
            "ptu.records_missing".into(),
            format!(
                "the header declares {} records more than the file holds; read those it holds",
                m.missing
            ),
        ));
    }
    let channel_words = match channel {
        Some(c) => format!("channel {c} of {n_channels} kept"),
        None => format!("{n_channels} channel(s) summed"),
    };
    let (ny, nx, hist, counted, stored_shape, layout) = match m.image {
        Some((px, py, mk)) => {
            let (hist, counted, shape, words) =
                read_image(path, &h, &m, &s, (px, py, mk), channels, opts)?;
            (
                py,
                px,
                hist,
                counted,
                shape,
                format!("{words}, {channel_words}"),
            )
        }
        None => {
            let mut hist = allocate(path, 1, 1, nt)?;
            let counted =
                histogram::point(path, m.records_at, m.records, m.kind, channels, &mut hist)?;
            let shape = vec![n_channels, nt];
            (
                1,
                1,
                hist,
                counted,
                shape,
                format!("point measurement (C, H) = ({n_channels}, {nt}): {channel_words}"),
            )
        }
    };
    notes.push(("ptu.photons_in_cube".into(), counted.to_string()));
    let largest = hist.iter().copied().max().unwrap_or(0);
    let inexact = hist.iter().filter(|&&c| c > 1 << 24).count();
    let samples: Vec<f32> = hist.into_iter().map(|c| c as f32).collect();
    Ok(Capture {
        path: path.to_path_buf(),
        format: Format::Ptu,
        source: format!("{} records", m.kind.name()),
        stored_shape,
        dtype: Dtype::U32,
        ny,
        nx,
        nt,
        time: TimeSpec::Uniform {
            t0_ps: 0.0,
            dt_ps: m.dt_ps,
        },
        time_source: "MeasDesc_Resolution; start-stop time from 0".into(),
        layout: format!(
            "{layout}; time: the start-stop time H ({nt} bins up to the last with a photon)"
        ),
        y: None,
        x: None,
        samples,
        attributes: notes,
        inexact,
        largest_inexact: if inexact > 0 { f64::from(largest) } else { 0.0 },
    })
}

/// The histogram of an image scan, its photons, the stored shape (T, Y, X, C, H) and the
/// words for what was summed or kept.
fn read_image(
    path: &Path,
    h: &Header,
    m: &Measurement,
    s: &Scan,
    (px, py, markers): (usize, usize, Markers),
    channels: (u32, u32),
    opts: &LayoutOptions,
) -> Result<(Vec<u32>, u64, Vec<usize>, String), ReaderError> {
    let (pixel_time, line_time) = pixel_and_line_time(h, m, s, px);
    let frames = s.frames.max(1);
    let frame = selected(opts, &["frame", "T"]);
    if let Some(k) = frame.filter(|&k| k as u64 >= frames) {
        return Err(bad(
            path,
            "--select",
            format!(
                "frame={k}: the scan has {frames} complete frame(s) (0 to {})",
                frames - 1
            ),
        ));
    }
    let nt = s.bins_used as usize;
    let plan = ImagePlan {
        nx: px,
        ny: py,
        nt,
        pixel_time,
        line_time,
        markers,
        frames,
        skip_first_frame: s.skip_first_frame,
        frame: frame.map(|k| k as u64),
        channels,
        bidirectional: h.int("ImgHdr_BiDirect").unwrap_or(0) > 0,
    };
    let mut hist = allocate(path, py, px, nt)?;
    let counted = histogram::image(path, m.records_at, m.records, m.kind, &plan, &mut hist)?;
    let n_channels = (s.channel_span().1 - s.channel_span().0 + 1) as usize;
    let words = format!(
        "image scan (T, Y, X, C, H) = ({frames}, {py}, {px}, {n_channels}, {nt}): {}; pixel time {} and line time {} sync periods",
        match frame {
            Some(k) => format!("frame {k} of {frames} kept"),
            None => format!("{frames} frame(s) summed"),
        },
        pixel_time,
        line_time
    );
    Ok((
        hist,
        counted,
        vec![frames as usize, py, px, n_channels, nt],
        words,
    ))
}

/// The pixel time and line time on the global clock, as `ptufile` takes them:
/// `ImgHdr_TimePerPixel` (ms) when given, else the mean line time over the pixels of a line
/// (rounded half to even, at least 1).
fn pixel_and_line_time(h: &Header, m: &Measurement, s: &Scan, px: usize) -> (u64, u64) {
    let per_pixel_ms = h.float("ImgHdr_TimePerPixel").unwrap_or(0.0);
    let pixel = if per_pixel_ms > 0.0 {
        per_pixel_ms / m.global_resolution_s / 1e3
    } else if s.lines > 0 {
        s.line_time as f64 / px as f64
    } else {
        1e-3 / m.global_resolution_s
    };
    let pixel = (pixel.round_ties_even() as u64).max(1);
    let line = if h.has("ImgHdr_TimePerPixel") {
        px as u64 * pixel
    } else if s.lines > 0 {
        s.line_time
    } else {
        (1e-3 / m.global_resolution_s).round_ties_even() as u64
    };
    (pixel, line)
}
