//! The HPD-TA `.img` writer ([`write_img`]; the layout it writes is in the [`super`] doc):
//! the argument checks, the comment with its self-referencing table offset, the header, the
//! rounded and clamped counts and the float32 time table.

use super::{ImgFileType, HEADER_LEN};
use crate::formats::{write_file_atomically, FormatError, StreakImage};
use std::path::{Path, PathBuf};

/// A duration in the largest of ps, ns, us that keeps the number at least 1, with six
/// significant digits (`"1.9 ns"`, `"640 ps"`).
pub(super) fn format_time_range(span_ps: f64) -> String {
    let (value, unit) = if span_ps.abs() >= 1e6 {
        (span_ps / 1e6, "us")
    } else if span_ps.abs() >= 1e3 {
        (span_ps / 1e3, "ns")
    } else {
        (span_ps, "ps")
    };
    let rounded: f64 = format!("{value:.5e}")
        .parse()
        .expect("formatted float parses");
    format!("{rounded} {unit}")
}

/// The comment [`write_img`] stores, for an image `nx` wide and `nt` high with a table at
/// `table_offset`.
///
/// It carries every key the open readers of HPD-TA files need, with the values HPD-TA
/// writes for a single acquisition: rosettasciio (`rsciio.hamamatsu`) reads
/// `[Acquisition] AcqMode` (1 live, 2 acquire, 3 photon counting, 4 analog integration;
/// without it the reader fails) and `NrExposure`, the corrections applied
/// (`BacksubCorr`, `ShadingCorr`, `CurveCorr`, `DefectCorrection`: -1 yes, 0 no; femto
/// applies none), `pntBinning`, `ZAxisLabel`/`ZAxisUnit`, and both axes' `[Scaling]` type,
/// unit and scaling file. No `ExposureTime`, `Date` or `Time`: a simulation has none, and
/// the file stays the same from run to run.
fn writer_comment(
    bytes_per_pixel: usize,
    (nx, nt): (usize, usize),
    time_range: &str,
    table_offset: usize,
) -> String {
    format!(
        "[Application],Software=\"femto\",SoftwareVersion=\"{version}\",\
         ApplicationTitle=\"femto streak-camera simulator\"\r\n\
         [Acquisition],NrExposure=1,NrTrigger=0,AcqMode=2,CurveCorr=0,DefectCorrection=0,\
         areSource=\"0,0,{nx},{nt}\",areGRBScan=\"0,0,{nx},{nt}\",pntOrigCh=\"0,0\",\
         pntOrigFB=\"0,0\",pntBinning=\"1,1\",BytesPerPixel={bytes_per_pixel},IsLineData=0,\
         BacksubCorr=0,ShadingCorr=0,ZAxisLabel=Intensity,ZAxisUnit=Count\r\n\
         [Streak camera],Time Range=\"{time_range}\",Mode=\"Operate\"\r\n\
         [Scaling],ScalingXType=1,ScalingXScale=1,ScalingXUnit=\"\",ScalingXScalingFile=\"\",\
         ScalingYType=2,ScalingYScale=1,ScalingYUnit=\"ps\",ScalingYScalingFile=\"#{table_offset},{nt:04}\"\r\n\
         [Comment],UserComment=\"\"",
        version = env!("CARGO_PKG_VERSION"),
    )
}

/// Check what [`write_img`] is given: the bit depth (16 or 32; its file type is returned),
/// the image's size, and a finite, strictly increasing time per row over finite pixels.
pub(super) fn check_write_args(
    path: &Path,
    img: &StreakImage,
    bits: u32,
    time_axis_ps: &[f64],
) -> Result<ImgFileType, FormatError> {
    let invalid = |message: String| FormatError::InvalidArgument {
        path: path.to_path_buf(),
        message,
    };
    let file_type = match bits {
        16 => ImgFileType::U16,
        32 => ImgFileType::U32,
        _ => {
            return Err(invalid(format!(
                "HPD-TA bit depth {bits} (the writer supports 16 and 32)"
            )))
        }
    };
    let (nx, nt) = (img.nx, img.nt);
    if img.data.len() != nx * nt {
        return Err(FormatError::SizeMismatch {
            path: path.to_path_buf(),
            what: "image data length (nx * nt)".into(),
            expected: nx * nt,
            found: img.data.len(),
        });
    }
    let max_dim = i16::MAX as usize;
    if nx == 0 || nt == 0 || nx > max_dim || nt > max_dim {
        return Err(invalid(format!(
            "HPD-TA image size {nx} x {nt} (each side must be 1..={max_dim})"
        )));
    }
    if time_axis_ps.len() != nt {
        return Err(FormatError::SizeMismatch {
            path: path.to_path_buf(),
            what: "time axis length (one time per row)".into(),
            expected: nt,
            found: time_axis_ps.len(),
        });
    }
    if let Some(i) = time_axis_ps.iter().position(|t| !t.is_finite()) {
        return Err(invalid(format!(
            "time axis value {} at row {i} is not finite",
            time_axis_ps[i]
        )));
    }
    if let Some(i) = time_axis_ps.windows(2).position(|w| w[1] <= w[0]) {
        return Err(invalid(format!(
            "time axis is not strictly increasing at row {}",
            i + 1
        )));
    }
    if let Some(i) = img.data.iter().position(|v| !v.is_finite()) {
        return Err(FormatError::NonFinite {
            path: path.to_path_buf(),
            x: i % nx,
            t: i / nx,
            value: img.data[i],
        });
    }
    Ok(file_type)
}

/// Append `data` to `out` as little-endian unsigned integers of `bits` (16 or 32) bits,
/// rounded half away from zero and clamped to `0..=2^bits - 1`; returns how many were
/// clamped at the top (saturated).
pub(super) fn push_counts(out: &mut Vec<u8>, data: &[f32], bits: u32) -> usize {
    let max = if bits == 16 {
        u16::MAX as f64
    } else {
        u32::MAX as f64
    };
    let mut saturated = 0;
    for &v in data {
        let r = (v as f64).round();
        if r > max {
            saturated += 1;
        }
        let stored = r.clamp(0.0, max);
        if bits == 16 {
            out.extend_from_slice(&(stored as u16).to_le_bytes());
        } else {
            out.extend_from_slice(&(stored as u32).to_le_bytes());
        }
    }
    saturated
}

/// Write `img` as an HPD-TA `.img` file with `bits` = 16 or 32 per pixel and the per-row
/// times `time_axis_ps` (one per row, strictly increasing) as a float32 table in ps. The
/// reader hands the table back unchanged; femto's simulator passes the start of each row's
/// bin, `t0_ps + i * dt_ps` (the [`crate::cube::TimeAxis`] convention), and the
/// `[Streak camera] Time Range` it records is `nt` times the mean row spacing.
///
/// Values are rounded to the nearest integer (half away from zero) and clamped to
/// `0..=2^bits - 1`; returns how many were clamped at the top (saturated). Negative values
/// become 0 (a real sensor cannot report less than zero counts). Non-finite values are an
/// error. The file is written atomically.
pub fn write_img(
    path: &Path,
    img: &StreakImage,
    bits: u32,
    time_axis_ps: &[f64],
) -> Result<usize, FormatError> {
    let file_type = check_write_args(path, img, bits, time_axis_ps)?;
    let (nx, nt) = (img.nx, img.nt);
    let invalid = |message: String| FormatError::InvalidArgument {
        path: path.to_path_buf(),
        message,
    };
    let span_ps = if nt > 1 {
        (time_axis_ps[nt - 1] - time_axis_ps[0]) * nt as f64 / (nt - 1) as f64
    } else {
        0.0
    };
    let time_range = format_time_range(span_ps);
    let bpp = file_type.bytes();
    let pixel_bytes = nx * nt * bpp;
    // The table offset is written inside the comment, whose length moves the offset: iterate
    // to the fixed point (at most a couple of rounds, as the offset only grows in digits).
    let mut comment = writer_comment(bpp, (nx, nt), &time_range, 0);
    loop {
        let offset = HEADER_LEN + comment.len() + pixel_bytes;
        let next = writer_comment(bpp, (nx, nt), &time_range, offset);
        if next.len() == comment.len() {
            comment = next;
            break;
        }
        comment = next;
    }
    if comment.len() > i16::MAX as usize {
        return Err(invalid("HPD-TA comment longer than 32767 bytes".into()));
    }

    let mut out = Vec::with_capacity(HEADER_LEN + comment.len() + pixel_bytes + 4 * nt);
    out.extend_from_slice(b"IM");
    out.extend_from_slice(&(comment.len() as i16).to_le_bytes());
    out.extend_from_slice(&(nx as i16).to_le_bytes());
    out.extend_from_slice(&(nt as i16).to_le_bytes());
    out.extend_from_slice(&0i16.to_le_bytes()); // x offset
    out.extend_from_slice(&0i16.to_le_bytes()); // y offset
    out.extend_from_slice(&file_type.code().to_le_bytes());
    out.extend_from_slice(&0i32.to_le_bytes()); // number of images, as HPD-TA writes it
    out.extend_from_slice(&0i16.to_le_bytes()); // additional channels
    out.extend_from_slice(&0i16.to_le_bytes()); // channel number
    out.extend_from_slice(&0f64.to_le_bytes()); // time stamp
    out.resize(HEADER_LEN, 0); // marker and additional information
    out.extend_from_slice(comment.as_bytes());
    let saturated = push_counts(&mut out, &img.data, bits);
    debug_assert_eq!(out.len(), HEADER_LEN + comment.len() + pixel_bytes);
    for &t in time_axis_ps {
        out.extend_from_slice(&(t as f32).to_le_bytes());
    }
    write_file_atomically(path, |tmp| {
        std::fs::write(tmp, &out).map_err(|source| FormatError::Io {
            path: PathBuf::from(path),
            source,
        })
    })?;
    Ok(saturated)
}
