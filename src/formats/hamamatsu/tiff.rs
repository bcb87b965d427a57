//! HPD-TA TIFF files: a TIFF whose ImageDescription tag holds the HPD-TA header, the same
//! `[Section],Key=Value` text as an `.img` comment ([`super::parse_comment`]).
//!
//! HPD-TA 9.x saves a frame as a one-page TIFF (16-bit grey, say) and puts its header in the
//! ImageDescription; `[Scaling] ScalingYScalingFile="#offset,count"` then points at `count`
//! float32 little-endian row times at byte `offset` of the TIFF file, after the image data,
//! and `[Acquisition] areSource` says which rows of that table the image holds
//! (`hamamatsu/scaling.rs`). Everything after the pixels are decoded is the `.img` path
//! (`build_image`): the axes, Focus mode and uncalibrated units, the settings.
//!
//! A TIFF is HPD-TA when its ImageDescription starts with `[Application]`, the first section
//! HPD-TA writes, or parses as sections among which `[Scaling]`, `[Streak camera]` or
//! `[Acquisition]`; any other TIFF is a plain raster image.

use super::{build_image, decode_comment, parse_comment, HpdContainer, HpdPixels};
use crate::formats::raster::{read_tiff_from, RasterPixels};
use crate::formats::{FileRegions, FormatError, StreakImage};
use std::collections::BTreeMap;
use std::path::Path;

/// Sections that only an HPD-TA header has.
const HPD_SECTIONS: [&str; 3] = ["Scaling", "Streak camera", "Acquisition"];

/// The HPD-TA header held by a TIFF's ImageDescription `description` (raw bytes), parsed, or
/// `None` when the description is not one. A description that starts with `[Application]`
/// but does not parse is an error naming the file and the byte.
#[allow(clippy::type_complexity)]
pub fn hpd_tiff_header(
    path: &Path,
    description: &[u8],
) -> Result<Option<(String, BTreeMap<String, BTreeMap<String, String>>)>, FormatError> {
    let text = decode_comment(description);
    let trimmed = text.trim_start();
    if !trimmed.starts_with('[') {
        return Ok(None);
    }
    let claims_hpd = trimmed.starts_with("[Application]");
    match parse_comment(&text) {
        Ok(sections) if claims_hpd || HPD_SECTIONS.iter().any(|s| sections.contains_key(*s)) => {
            Ok(Some((text, sections)))
        }
        Ok(_) => Ok(None),
        Err((offset, message)) if claims_hpd => Err(FormatError::BadComment {
            path: path.to_path_buf(),
            offset,
            message: format!("{message} (in the TIFF ImageDescription)"),
        }),
        Err(_) => Ok(None),
    }
}

/// A TIFF as [`read_hpd_tiff`] reads it.
pub enum TiffImage {
    /// An HPD-TA TIFF: the image with its axes and `img_meta`, laid out as asked.
    Hpd(Box<StreakImage>),
    /// Any other TIFF: its pixels as stored, for the caller to lay out.
    Plain(RasterPixels),
}

/// Read a TIFF, as an HPD-TA image when its ImageDescription holds an HPD-TA header, else as
/// a plain raster image.
pub fn read_hpd_tiff(path: &Path, transpose: bool) -> Result<TiffImage, FormatError> {
    let io = |source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let regions = FileRegions::new(&file).map_err(io)?;
    let (raster, description) = read_tiff_from(path, std::io::BufReader::new(&file), regions.len)?;
    let header = match description {
        Some(d) => hpd_tiff_header(path, &d)?,
        None => None,
    };
    let Some(header) = header else {
        return Ok(TiffImage::Plain(raster));
    };
    let RasterPixels {
        width,
        height,
        data,
        pixel_type,
    } = raster;
    let pixels = HpdPixels {
        container: HpdContainer::Tiff { width, height },
        width,
        height,
        data,
        pixel_type,
    };
    build_image(path, pixels, header, &regions, transpose)
        .map(|image| TiffImage::Hpd(Box::new(image)))
}
