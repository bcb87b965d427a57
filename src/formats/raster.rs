//! Streak images in general-purpose raster formats: PNG and TIFF (integers, via `image` and
//! `tiff`), OpenEXR (half and single floats, via `exr`) and Radiance `.hdr` (RGBE, via
//! `image`; other transient renderers write one such file per scanline).
//!
//! Readers return the pixels row-major as stored (top row first) with one value per pixel by
//! the channel rule of [`super`]: grey is read as is; integer colour must be grey (R = G = B
//! in every pixel) or the file is refused; float colour becomes `(R + G + B) / 3`; alpha is
//! ignored. For EXR a channel named `Y` wins over `R, G, B`; a single channel of any name is
//! read as is.
//!
//! Writers: [`write_png16`] stores `round(v / value_per_count)` clamped to `0..=65535` (so
//! `v ≈ stored * value_per_count`; the value per count goes into the capture manifest), and
//! [`write_exr_f32`] stores one `f32` channel named `Y` (lossless ZIP compression).

use super::{write_file_atomically, FormatError, PixelType, StreakImage};
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// Pixels of a raster file as stored: `height` rows of `width` values, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct RasterPixels {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Row-major values, one per pixel.
    pub data: Vec<f32>,
    /// How the file stored them.
    pub pixel_type: PixelType,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> FormatError + '_ {
    move |source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn decode_err(path: &Path, e: impl std::fmt::Display) -> FormatError {
    FormatError::Decode {
        path: path.to_path_buf(),
        message: e.to_string().replace('\n', " "),
    }
}

/// Reduce interleaved integer samples with `channels` per pixel (colour first, alpha last if
/// `has_alpha`) to one value per pixel, requiring grey colour.
fn grey_from_interleaved<T: Copy + PartialEq + Into<f64>>(
    path: &Path,
    samples: &[T],
    width: usize,
    channels: usize,
    has_alpha: bool,
) -> Result<Vec<f32>, FormatError> {
    let colour = channels - usize::from(has_alpha);
    let mut out = Vec::with_capacity(samples.len() / channels);
    for (i, px) in samples.chunks_exact(channels).enumerate() {
        let first = px[0];
        if px[1..colour].iter().any(|&c| c != first) {
            return Err(FormatError::ChannelLayout {
                path: path.to_path_buf(),
                message: format!(
                    "colour image with unequal R, G, B at x {}, row {} (a streak image is \
                     monochrome; integer colour files must be grey)",
                    i % width,
                    i / width
                ),
            });
        }
        out.push(first.into() as f32);
    }
    Ok(out)
}

/// Mean of the first three samples of each pixel (`channels` per pixel, alpha ignored).
fn mean_rgb(samples: &[f32], channels: usize) -> Vec<f32> {
    samples
        .chunks_exact(channels)
        .map(|px| (px[0] + px[1] + px[2]) / 3.0)
        .collect()
}

/// Read a PNG: 8- or 16-bit grey, grey+alpha, or RGB(A) / palette with equal channels.
pub fn read_png(path: &Path) -> Result<RasterPixels, FormatError> {
    use image::ImageDecoder;
    let file = std::fs::File::open(path).map_err(io_err(path))?;
    // The crate's default limits, as `ImageReader::decode` applies them.
    let decoder =
        image::codecs::png::PngDecoder::with_limits(BufReader::new(file), image::Limits::default())
            .map_err(|e| decode_err(path, e))?;
    let (w, h) = decoder.dimensions();
    let stored = decoder.color_type().bytes_per_pixel() as usize;
    super::check_image_size(path, w as usize, h as usize, stored)?;
    let image = image::DynamicImage::from_decoder(decoder).map_err(|e| decode_err(path, e))?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    use image::DynamicImage as D;
    let (data, pixel_type) = match &image {
        D::ImageLuma8(b) => (
            b.as_raw().iter().map(|&v| v as f32).collect(),
            PixelType::U8,
        ),
        D::ImageLuma16(b) => (
            b.as_raw().iter().map(|&v| v as f32).collect(),
            PixelType::U16,
        ),
        D::ImageLumaA8(b) => (
            grey_from_interleaved(path, b.as_raw(), width, 2, true)?,
            PixelType::U8,
        ),
        D::ImageLumaA16(b) => (
            grey_from_interleaved(path, b.as_raw(), width, 2, true)?,
            PixelType::U16,
        ),
        D::ImageRgb8(b) => (
            grey_from_interleaved(path, b.as_raw(), width, 3, false)?,
            PixelType::RgbU8,
        ),
        D::ImageRgba8(b) => (
            grey_from_interleaved(path, b.as_raw(), width, 4, true)?,
            PixelType::RgbU8,
        ),
        D::ImageRgb16(b) => (
            grey_from_interleaved(path, b.as_raw(), width, 3, false)?,
            PixelType::RgbU16,
        ),
        D::ImageRgba16(b) => (
            grey_from_interleaved(path, b.as_raw(), width, 4, true)?,
            PixelType::RgbU16,
        ),
        other => {
            return Err(FormatError::ChannelLayout {
                path: path.to_path_buf(),
                message: format!("PNG colour type {:?}", other.color()),
            })
        }
    };
    Ok(RasterPixels {
        width,
        height,
        data,
        pixel_type,
    })
}

/// Decode a 16-bit single-channel (grey) PNG into `samples` (caller-owned, reused between
/// calls: resized, never shrunk), row-major as stored; returns `(width, height)`, or `None`
/// when the file is a PNG of another layout (8-bit, alpha, colour), which [`read_png`] reads.
///
/// The fast path of ingest: it skips [`read_png`]'s `f32` copy and its allocations, so a
/// caller converting to `f32` (with a scale, into its own layout) does so in one pass.
pub fn read_png_grey16_into(
    path: &Path,
    samples: &mut Vec<u16>,
) -> Result<Option<(usize, usize)>, FormatError> {
    use image::ImageDecoder;
    let file = std::fs::File::open(path).map_err(io_err(path))?;
    let decoder = image::codecs::png::PngDecoder::new(BufReader::with_capacity(1 << 16, file))
        .map_err(|e| decode_err(path, e))?;
    if decoder.color_type() != image::ColorType::L16 {
        return Ok(None);
    }
    let (w, h) = decoder.dimensions();
    let (width, height) = (w as usize, h as usize);
    super::check_image_size(path, width, height, 2)?;
    samples.resize(width * height, 0);
    // `read_image` writes native-endian samples.
    decoder
        .read_image(bytemuck::cast_slice_mut(&mut samples[..]))
        .map_err(|e| decode_err(path, e))?;
    Ok(Some((width, height)))
}

/// Read the first (and only) image of a TIFF: grey or grey+alpha of any integer or float
/// sample type, RGB(A) integer with equal channels, or RGB(A) float (mean of R, G, B).
pub fn read_tiff(path: &Path) -> Result<RasterPixels, FormatError> {
    let file = std::fs::File::open(path).map_err(io_err(path))?;
    let file_bytes = file.metadata().map_err(io_err(path))?.len();
    read_tiff_from(path, BufReader::new(file), file_bytes).map(|(pixels, _)| pixels)
}

/// [`read_tiff`] from `reader` (the file at `path`, `file_bytes` long), with the raw bytes of
/// the image's ImageDescription tag (NUL padding included) when it has one: HPD-TA writes
/// its header there ([`super::hamamatsu::read_hpd_tiff`]).
pub fn read_tiff_from<R: std::io::Read + std::io::Seek>(
    path: &Path,
    mut reader: R,
    file_bytes: u64,
) -> Result<(RasterPixels, Option<Vec<u8>>), FormatError> {
    use tiff::decoder::{Decoder, DecodingResult as R};
    check_tiff_directory(path, &mut reader, file_bytes)?;
    reader.rewind().map_err(io_err(path))?;
    let mut decoder = Decoder::new(reader).map_err(|e| decode_err(path, e))?;
    let description = tiff_description(path, &mut decoder, file_bytes)?;
    let (w, h) = decoder.dimensions().map_err(|e| decode_err(path, e))?;
    let (width, height) = (w as usize, h as usize);
    let colour = decoder.colortype().map_err(|e| decode_err(path, e))?;
    let (channels, has_alpha, bits) = tiff_layout(path, colour)?;
    let declared_bytes = width as f64 * height as f64 * channels as f64 * bits as f64 / 8.0;
    let image = format!("an image of {width} x {height} pixels");
    check_declared_bytes(path, &image, declared_bytes, file_bytes)?;
    super::check_image_size(path, width, height, (channels * bits as usize).div_ceil(8))?;
    // A strip or tile holds at most the file's bytes: the crate allocates what the header
    // claims before reading (266 MB for a 3 kB file).
    let mut limits = tiff::decoder::Limits::default();
    limits.intermediate_buffer_size = file_bytes as usize;
    let mut decoder = decoder.with_limits(limits);
    let mut result = R::U8(Vec::new());
    decoder
        .read_image_to_buffer(&mut result)
        .map_err(|e| match e {
            tiff::TiffError::LimitsExceeded => FormatError::Unsupported {
                path: path.to_path_buf(),
                what: format!(
                    "a strip or tile that claims more bytes than the file's {file_bytes} \
                     (a damaged header)"
                ),
            },
            e => decode_err(path, e),
        })?;
    if decoder.more_images() {
        return Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            what: "multi-page TIFF (one streak image per file)".into(),
        });
    }
    let expected = width * height * channels;
    let n = sample_count(&result);
    if n != expected {
        return Err(FormatError::SizeMismatch {
            path: path.to_path_buf(),
            what: "TIFF samples (planar colour TIFFs are not read)".into(),
            expected,
            found: n,
        });
    }
    let (data, pixel_type) = tiff_grey(path, result, width, channels, has_alpha)?;
    let pixels = RasterPixels {
        width,
        height,
        data,
        pixel_type,
    };
    Ok((pixels, description))
}

/// The raw bytes of the current image's ImageDescription tag, if it has one (read as bytes:
/// the `tiff` crate's own reading refuses text that is not UTF-8, and older HPD-TA versions
/// write `µ` in Latin-1). A tag claiming more bytes than the file holds is refused.
fn tiff_description<R: std::io::Read + std::io::Seek>(
    path: &Path,
    decoder: &mut tiff::decoder::Decoder<R>,
    file_bytes: u64,
) -> Result<Option<Vec<u8>>, FormatError> {
    use tiff::tags::Tag;
    let mut ifd = decoder.image_ifd();
    let Some(entry) = ifd.find_entry(Tag::ImageDescription) else {
        return Ok(None);
    };
    if entry.count() > file_bytes {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            what: "the TIFF ImageDescription".into(),
            needed: entry.count(),
            available: file_bytes,
        });
    }
    let mut buf = vec![0u8; entry.count() as usize];
    let n = ifd
        .find_tag_bytes(Tag::ImageDescription, &mut buf, 0)
        .map_err(|e| decode_err(path, e))?
        .unwrap_or(0);
    buf.truncate(n);
    Ok(Some(buf))
}

/// The channels of a TIFF colour type (grey, grey+alpha, RGB or RGBA; anything else is an
/// error), whether the last is alpha, and the bits of a sample.
fn tiff_layout(path: &Path, colour: tiff::ColorType) -> Result<(usize, bool, u8), FormatError> {
    use tiff::ColorType;
    let (channels, has_alpha) = match colour {
        ColorType::Gray(_) => (1, false),
        ColorType::GrayA(_) => (2, true),
        ColorType::RGB(_) => (3, false),
        ColorType::RGBA(_) => (4, true),
        other => {
            return Err(FormatError::ChannelLayout {
                path: path.to_path_buf(),
                message: format!("TIFF colour type {other:?} (expected grey or RGB)"),
            })
        }
    };
    let bits: u8 = match colour {
        ColorType::Gray(b) | ColorType::GrayA(b) | ColorType::RGB(b) | ColorType::RGBA(b) => b,
        _ => 8,
    };
    Ok((channels, has_alpha, bits))
}

/// How many samples a decoded TIFF holds.
fn sample_count(result: &tiff::decoder::DecodingResult) -> usize {
    use tiff::decoder::DecodingResult as R;
    match result {
        R::U8(v) => v.len(),
        R::U16(v) => v.len(),
        R::U32(v) => v.len(),
        R::U64(v) => v.len(),
        R::F16(v) => v.len(),
        R::F32(v) => v.len(),
        R::F64(v) => v.len(),
        R::I8(v) => v.len(),
        R::I16(v) => v.len(),
        R::I32(v) => v.len(),
        R::I64(v) => v.len(),
    }
}

/// One grey value a pixel from the `channels` interleaved samples of a decoded TIFF
/// `width` pixels wide, and how the file stored them: integer colour must have equal
/// channels, float colour is averaged; sample types with no grey reading are errors.
fn tiff_grey(
    path: &Path,
    result: tiff::decoder::DecodingResult,
    width: usize,
    channels: usize,
    has_alpha: bool,
) -> Result<(Vec<f32>, PixelType), FormatError> {
    use tiff::decoder::DecodingResult as R;
    let integer = |samples: Result<Vec<f32>, FormatError>, grey: PixelType, rgb: PixelType| {
        samples.map(|d| (d, if channels <= 2 { grey } else { rgb }))
    };
    let float = |samples: Vec<f32>, grey: PixelType, rgb: PixelType| {
        if channels <= 2 {
            (samples.chunks_exact(channels).map(|p| p[0]).collect(), grey)
        } else {
            (mean_rgb(&samples, channels), rgb)
        }
    };
    let unsupported = |what: &str| FormatError::ChannelLayout {
        path: path.to_path_buf(),
        message: format!("TIFF sample type {what}"),
    };
    Ok(match result {
        R::U8(v) => integer(
            grey_from_interleaved(path, &v, width, channels, has_alpha),
            PixelType::U8,
            PixelType::RgbU8,
        )?,
        R::U16(v) => integer(
            grey_from_interleaved(path, &v, width, channels, has_alpha),
            PixelType::U16,
            PixelType::RgbU16,
        )?,
        R::U32(v) if channels <= 2 => (
            grey_from_interleaved(path, &v, width, channels, has_alpha)?,
            PixelType::U32,
        ),
        R::I16(v) if channels <= 2 => (
            grey_from_interleaved(path, &v, width, channels, has_alpha)?,
            PixelType::I16,
        ),
        R::I32(v) if channels <= 2 => (
            grey_from_interleaved(path, &v, width, channels, has_alpha)?,
            PixelType::I32,
        ),
        R::F16(v) => float(
            v.iter().map(|x| x.to_f32()).collect(),
            PixelType::F16,
            PixelType::RgbF16,
        ),
        R::F32(v) => float(v, PixelType::F32, PixelType::RgbF32),
        R::F64(v) if channels <= 2 => float(
            v.iter().map(|&x| x as f32).collect(),
            PixelType::F64,
            PixelType::F64,
        ),
        R::U32(_) | R::I16(_) | R::I32(_) | R::F64(_) => {
            return Err(unsupported("of this bit depth in colour (grey only)"))
        }
        R::U64(_) => return Err(unsupported("u64")),
        R::I8(_) => return Err(unsupported("i8")),
        R::I64(_) => return Err(unsupported("i64")),
    })
}

/// The most bytes of samples an image file may declare: 64 MB, plus 16 bytes for each byte
/// of the file (a streak image of 1344 x 1024 floats is 5.5 MB). The `exr` and `tiff` crates
/// allocate the declared image before they read a chunk, so a damaged header of a 6 kB EXR
/// asked for 4 GB, and one of a 3 kB TIFF for 266 MB. `image` names what was declared
/// (`a data window of 16777194 x 64 pixels`).
fn check_declared_bytes(
    path: &Path,
    image: &str,
    declared_bytes: f64,
    file_bytes: u64,
) -> Result<(), FormatError> {
    if declared_bytes > 64e6 + 16.0 * file_bytes as f64 {
        return Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "{image} ({} of samples) in a file of {file_bytes} bytes (a damaged header, \
                 or an image far larger than a streak image)",
                crate::limits::human_bytes(declared_bytes)
            ),
        });
    }
    Ok(())
}

/// Refuse a TIFF whose first image directory has an entry claiming more values than the
/// file holds: the `tiff` crate allocates a 32-byte value for each one the entry claims
/// before it reads them (266 MB for a 3 kB file whose `SamplesPerPixel` claims 8,323,073
/// shorts). Entries of unknown type are left to the crate; a directory that cannot be read
/// here is left to the crate to refuse with its own words.
fn check_tiff_directory<F: std::io::Read + std::io::Seek>(
    path: &Path,
    file: &mut F,
    file_bytes: u64,
) -> Result<(), FormatError> {
    use std::io::SeekFrom;
    let mut read_at = |at: u64, n: usize| -> Option<Vec<u8>> {
        let mut buf = vec![0; n];
        file.seek(SeekFrom::Start(at)).ok()?;
        file.read_exact(&mut buf).ok()?;
        Some(buf)
    };
    let Some(header) = read_at(0, 16) else {
        return Ok(());
    };
    let little = match &header[..2] {
        b"II" => true,
        b"MM" => false,
        _ => return Ok(()),
    };
    let uint = |b: &[u8]| {
        let mut v = 0u64;
        for i in 0..b.len() {
            let byte = if little { b[b.len() - 1 - i] } else { b[i] };
            v = v << 8 | byte as u64;
        }
        v
    };
    // Classic TIFF: 2-byte entry count, 12-byte entries with 4-byte counts and 4 inline
    // bytes; BigTIFF: 8-byte entry count, 20-byte entries with 8-byte counts and 8 inline.
    let (directory_at, count_bytes, entry_bytes, field_bytes) = match uint(&header[2..4]) {
        42 => (uint(&header[4..8]), 2, 12, 4),
        43 => (uint(&header[8..16]), 8, 20, 8),
        _ => return Ok(()),
    };
    let Some(n) = read_at(directory_at, count_bytes).map(|b| uint(&b)) else {
        return Ok(());
    };
    let n = n.min(file_bytes / entry_bytes as u64) as usize;
    // Checked: a BigTIFF directory offset near 2^64 must not wrap.
    let Some(entries_at) = directory_at.checked_add(count_bytes as u64) else {
        return Ok(());
    };
    let Some(entries) = read_at(entries_at, n * entry_bytes) else {
        return Ok(());
    };
    for entry in entries.chunks_exact(entry_bytes) {
        let value_bytes = match uint(&entry[2..4]) {
            1 | 2 | 6 | 7 => 1,
            3 | 8 => 2,
            4 | 9 | 11 | 13 => 4,
            5 | 10 | 12 | 16 | 17 | 18 => 8,
            _ => continue,
        };
        let count = uint(&entry[4..4 + field_bytes]);
        if count.saturating_mul(value_bytes) > file_bytes {
            return Err(FormatError::Unsupported {
                path: path.to_path_buf(),
                what: format!(
                    "TIFF tag {} claims {count} values in a file of {file_bytes} bytes \
                     (a damaged header)",
                    uint(&entry[..2])
                ),
            });
        }
    }
    Ok(())
}

/// [`check_declared_bytes`] for the data windows of an EXR file's headers.
fn check_exr_size(path: &Path, file_bytes: u64) -> Result<(), FormatError> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| decode_err(path, e))?;
    let declared_bytes: f64 = meta
        .headers
        .iter()
        .map(|h| h.layer_size.0 as f64 * h.layer_size.1 as f64 * h.channels.list.len() as f64 * 4.0)
        .sum();
    let (w, h) = meta
        .headers
        .first()
        .map_or((0, 0), |h| (h.layer_size.0, h.layer_size.1));
    let image = format!("a data window of {w} x {h} pixels");
    check_declared_bytes(path, &image, declared_bytes, file_bytes)?;
    for h in &meta.headers {
        let (w, ht) = (h.layer_size.0, h.layer_size.1);
        super::check_image_size(path, w, ht, 4 * h.channels.list.len())?;
    }
    Ok(())
}

/// Read the single layer of an OpenEXR file: channel `Y`, else the mean of `R, G, B`, else
/// its only non-alpha channel. Half, single and u32 samples are accepted.
pub fn read_exr(path: &Path) -> Result<RasterPixels, FormatError> {
    use exr::prelude::{FlatSamples, ReadChannels, ReadLayers};
    // Check existence first so that a missing file is an I/O error, not a decode error.
    let file_bytes = std::fs::metadata(path).map_err(io_err(path))?.len();
    check_exr_size(path, file_bytes)?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| decode_err(path, e))?;
    if image.layer_data.len() != 1 {
        return Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "{} layers in one EXR file (one streak image per file)",
                image.layer_data.len()
            ),
        });
    }
    let layer = &image.layer_data[0];
    let (width, height) = (layer.size.0, layer.size.1);
    let channels = &layer.channel_data.list;
    // Channel names may carry a layer prefix ("streak.Y"); match on the last component.
    let short = |name: &str| name.rsplit('.').next().unwrap_or(name).to_string();
    let names: Vec<String> = channels
        .iter()
        .map(|c| short(&c.name.to_string()))
        .collect();
    let find = |want: &str| names.iter().position(|n| n == want);
    let to_f32 = |s: &FlatSamples| -> Vec<f32> {
        match s {
            FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
        }
    };
    let grey_type = |s: &FlatSamples| match s {
        FlatSamples::F16(_) => PixelType::F16,
        FlatSamples::F32(_) => PixelType::F32,
        FlatSamples::U32(_) => PixelType::U32,
    };
    let non_alpha: Vec<usize> = (0..names.len()).filter(|&i| names[i] != "A").collect();
    let (data, pixel_type) = if let Some(y) = find("Y") {
        let s = &channels[y].sample_data;
        (to_f32(s), grey_type(s))
    } else if let (Some(r), Some(g), Some(b)) = (find("R"), find("G"), find("B")) {
        let (r, g, b) = (
            to_f32(&channels[r].sample_data),
            to_f32(&channels[g].sample_data),
            to_f32(&channels[b].sample_data),
        );
        let pixel_type = match &channels[find("R").expect("found")].sample_data {
            FlatSamples::F16(_) => PixelType::RgbF16,
            _ => PixelType::RgbF32,
        };
        let mean = r
            .iter()
            .zip(&g)
            .zip(&b)
            .map(|((r, g), b)| (r + g + b) / 3.0)
            .collect();
        (mean, pixel_type)
    } else if non_alpha.len() == 1 {
        let s = &channels[non_alpha[0]].sample_data;
        (to_f32(s), grey_type(s))
    } else {
        return Err(FormatError::ChannelLayout {
            path: path.to_path_buf(),
            message: format!(
                "EXR channels {names:?} (expected Y, or R, G and B, or a single channel)"
            ),
        });
    };
    if data.len() != width * height {
        return Err(FormatError::SizeMismatch {
            path: path.to_path_buf(),
            what: "EXR samples (subsampled channels are not read)".into(),
            expected: width * height,
            found: data.len(),
        });
    }
    Ok(RasterPixels {
        width,
        height,
        data,
        pixel_type,
    })
}

/// Read a Radiance `.hdr` (RGBE) file; each pixel becomes the mean of R, G and B.
pub fn read_hdr(path: &Path) -> Result<RasterPixels, FormatError> {
    use image::ImageDecoder;
    let file = std::fs::File::open(path).map_err(io_err(path))?;
    let mut decoder = image::codecs::hdr::HdrDecoder::new(BufReader::new(file))
        .map_err(|e| decode_err(path, e))?;
    decoder
        .set_limits(image::Limits::default())
        .map_err(|e| decode_err(path, e))?;
    let (w, h) = decoder.dimensions();
    super::check_image_size(path, w as usize, h as usize, 12)?;
    let image = image::DynamicImage::from_decoder(decoder).map_err(|e| decode_err(path, e))?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    let rgb = image.into_rgb32f();
    Ok(RasterPixels {
        width,
        height,
        data: mean_rgb(rgb.as_raw(), 3),
        pixel_type: PixelType::Rgbe,
    })
}

fn check_len(path: &Path, img: &StreakImage) -> Result<(), FormatError> {
    if img.data.len() != img.nx * img.nt || img.nx == 0 || img.nt == 0 {
        return Err(FormatError::SizeMismatch {
            path: path.to_path_buf(),
            what: format!("image data length for {} x {} (non-empty)", img.nx, img.nt),
            expected: img.nx * img.nt,
            found: img.data.len(),
        });
    }
    if u32::try_from(img.nx).is_err() || u32::try_from(img.nt).is_err() {
        return Err(FormatError::InvalidArgument {
            path: path.to_path_buf(),
            message: format!("image size {} x {} too large", img.nx, img.nt),
        });
    }
    Ok(())
}

/// Write a 16-bit grey PNG: stored = `round(v / value_per_count)` (half away from zero)
/// clamped to `0..=65535`, so that `v ≈ stored * value_per_count`. Returns how many values
/// were clamped at the top (saturated); negative values become 0. Non-finite values and a
/// `value_per_count` that is not finite and positive are errors. Written atomically.
pub fn write_png16(
    path: &Path,
    img: &StreakImage,
    value_per_count: f64,
) -> Result<usize, FormatError> {
    check_len(path, img)?;
    if !(value_per_count.is_finite() && value_per_count > 0.0) {
        return Err(FormatError::InvalidArgument {
            path: path.to_path_buf(),
            message: format!("PNG value per count {value_per_count} (must be finite and > 0)"),
        });
    }
    let mut saturated = 0;
    let mut stored = Vec::with_capacity(img.data.len());
    for (i, &v) in img.data.iter().enumerate() {
        if !v.is_finite() {
            return Err(FormatError::NonFinite {
                path: path.to_path_buf(),
                x: i % img.nx,
                t: i / img.nx,
                value: v,
            });
        }
        let r = (v as f64 / value_per_count).round();
        if r > u16::MAX as f64 {
            saturated += 1;
        }
        stored.push(r.clamp(0.0, u16::MAX as f64) as u16);
    }
    let buffer = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(
        img.nx as u32,
        img.nt as u32,
        stored,
    )
    .expect("buffer length checked");
    write_file_atomically(path, |tmp| {
        buffer
            .save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|e| encode_err(path, e))
    })?;
    Ok(saturated)
}

fn encode_err(path: &Path, e: impl std::fmt::Display) -> FormatError {
    FormatError::Io {
        path: PathBuf::from(path),
        source: std::io::Error::other(e.to_string()),
    }
}

/// Write a single-layer OpenEXR file with one `f32` channel named `Y` (ZIP-compressed,
/// lossless; NaN and infinities are stored as they are). Written atomically.
pub fn write_exr_f32(path: &Path, img: &StreakImage) -> Result<(), FormatError> {
    use exr::prelude::{
        AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, SmallVec,
        WritableImage,
    };
    check_len(path, img)?;
    let mut list = SmallVec::new();
    list.push(AnyChannel::new("Y", FlatSamples::F32(img.data.clone())));
    let layer = Layer::new(
        (img.nx, img.nt),
        LayerAttributes::named("streak"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = Image::from_layer(layer);
    write_file_atomically(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| encode_err(path, e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey16_fast_path_reads_what_read_png_reads_and_declines_other_layouts() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (13usize, 7usize);
        let counts: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 65_536) as f32).collect();
        let p16 = dir.path().join("a.png");
        write_png16(&p16, &StreakImage::new(w, h, counts.clone()), 1.0).unwrap();
        let mut samples = vec![9u16; 3];
        assert_eq!(
            read_png_grey16_into(&p16, &mut samples).unwrap(),
            Some((w, h))
        );
        let as_f32: Vec<f32> = samples.iter().map(|&v| f32::from(v)).collect();
        assert_eq!(as_f32, counts);
        assert_eq!(as_f32, read_png(&p16).unwrap().data);
        // 8-bit grey: not this path's layout.
        let p8 = dir.path().join("b.png");
        image::GrayImage::from_fn(w as u32, h as u32, |x, y| image::Luma([(x + y) as u8]))
            .save(&p8)
            .unwrap();
        assert_eq!(read_png_grey16_into(&p8, &mut samples).unwrap(), None);
        // A file that is not a PNG is a decode error naming it.
        let bad = dir.path().join("c.png");
        std::fs::write(&bad, b"not a png").unwrap();
        let e = read_png_grey16_into(&bad, &mut samples).unwrap_err();
        assert!(e.to_string().contains("c.png"), "{e}");
    }

    #[test]
    fn tiff_colour_types_give_channels_alpha_and_bits() {
        use tiff::ColorType;
        let p = Path::new("t.tif");
        assert_eq!(tiff_layout(p, ColorType::Gray(16)).unwrap(), (1, false, 16));
        assert_eq!(tiff_layout(p, ColorType::GrayA(8)).unwrap(), (2, true, 8));
        assert_eq!(tiff_layout(p, ColorType::RGB(32)).unwrap(), (3, false, 32));
        assert_eq!(tiff_layout(p, ColorType::RGBA(16)).unwrap(), (4, true, 16));
        let e = tiff_layout(p, ColorType::CMYK(8)).unwrap_err().to_string();
        assert!(
            e.contains("expected grey or RGB") && e.contains("t.tif"),
            "{e}"
        );
    }

    #[test]
    fn tiff_samples_become_grey_by_type() {
        use tiff::decoder::DecodingResult as R;
        let p = Path::new("t.tif");
        assert_eq!(sample_count(&R::I16(vec![0; 5])), 5);
        // Grey+alpha u16: the alpha is dropped.
        let (d, t) = tiff_grey(p, R::U16(vec![7, 65535, 9, 0]), 2, 2, true).unwrap();
        assert_eq!((d, t), (vec![7.0, 9.0], PixelType::U16));
        // RGB float: the mean of R, G, B.
        let (d, t) = tiff_grey(p, R::F32(vec![1.0, 2.0, 6.0]), 1, 3, false).unwrap();
        assert_eq!((d, t), (vec![3.0], PixelType::RgbF32));
        // RGB u8 must have equal channels.
        let (d, t) = tiff_grey(p, R::U8(vec![5, 5, 5]), 1, 3, false).unwrap();
        assert_eq!((d, t), (vec![5.0], PixelType::RgbU8));
        assert!(tiff_grey(p, R::U8(vec![5, 6, 5]), 1, 3, false).is_err());
        // Colour of a grey-only sample type, and types with no grey reading.
        let e = tiff_grey(p, R::I32(vec![1, 1, 1]), 1, 3, false).unwrap_err();
        assert!(e.to_string().contains("grey only"), "{e}");
        let e = tiff_grey(p, R::U64(vec![1]), 1, 1, false).unwrap_err();
        assert!(e.to_string().contains("u64"), "{e}");
    }
}
