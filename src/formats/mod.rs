//! Streak images on disk: one capture of one scanline, x across and time down.
//!
//! A streak camera images a slit (one row of the scene, the x axis) and sweeps the
//! photoelectrons vertically in time, so its output is a 2-D image whose columns are x and
//! whose rows are successive time bins (the seed's capture: 672 x by 512 time pixels per
//! scanline). [`StreakImage`] holds one such image row-major as `[t][x]`, exactly as the
//! files store it; `--transpose` ([`read_streak`]'s `transpose`) is for files written the
//! other way round (time across, x down).
//!
//! Readers (dispatched on the extension, case-insensitively):
//!
//! | extension       | module        | sample types                                          |
//! |-----------------|---------------|-------------------------------------------------------|
//! | `.png`          | [`raster`]    | 8- and 16-bit grey (or grey stored as RGB)            |
//! | `.tif`, `.tiff` | [`raster`]    | 8/16/32-bit unsigned, 16/32-bit signed, 16/32/64-bit float; an HPD-TA header in the ImageDescription is read as for `.img` ([`hamamatsu::read_hpd_tiff`]) |
//! | `.exr`          | [`raster`]    | f16, f32, u32 (channel `Y`, or the mean of `R,G,B`)   |
//! | `.hdr`          | [`raster`]    | Radiance RGBE (the mean of `R,G,B`)                   |
//! | `.img`          | [`hamamatsu`] | Hamamatsu HPD-TA, 8/16/32-bit, typed metadata and axis tables |
//!
//! Channel rule. A streak camera is monochrome, so every reader returns one value per pixel:
//! integer colour images (PNG, TIFF) are accepted only when every pixel has equal R, G and B
//! (grey stored as colour), otherwise the reader refuses them; float colour images (EXR, HDR,
//! float TIFF) are reduced to the mean `(R + G + B) / 3`, which is exact for the grey RGB that
//! transient renderers write. An alpha channel is ignored. NaN and infinite values are read
//! faithfully (ingest checks them and names the file).
//!
//! Writers: [`raster::write_png16`] (counts with a recorded value per count),
//! [`raster::write_exr_f32`] and [`hamamatsu::write_img`] (the real HPD-TA container with a
//! time table). Every writer goes through [`crate::atomic::write_atomically_with`].

pub mod hamamatsu;
pub mod raster;

use std::path::{Path, PathBuf};

/// How the samples were stored in the file the image came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelType {
    /// 8-bit unsigned integers.
    U8,
    /// 16-bit unsigned integers.
    U16,
    /// 32-bit unsigned integers (values above 2^24 lose precision in `f32`).
    U32,
    /// 16-bit signed integers (TIFF).
    I16,
    /// 32-bit signed integers (TIFF).
    I32,
    /// IEEE half floats.
    F16,
    /// IEEE single floats.
    F32,
    /// IEEE double floats (TIFF), rounded to `f32`.
    F64,
    /// 8-bit RGB(A) whose three colour channels are equal in every pixel.
    RgbU8,
    /// 16-bit RGB(A) whose three colour channels are equal in every pixel.
    RgbU16,
    /// Half-float RGB(A), reduced to the mean of R, G and B.
    RgbF16,
    /// Single-float RGB(A), reduced to the mean of R, G and B.
    RgbF32,
    /// Radiance RGBE (shared exponent), reduced to the mean of R, G and B.
    Rgbe,
}

impl PixelType {
    /// The largest value the file could store (the saturation level of an integer file),
    /// or `None` for floating-point samples.
    pub fn max_stored_value(self) -> Option<f64> {
        match self {
            PixelType::U8 | PixelType::RgbU8 => Some(u8::MAX as f64),
            PixelType::U16 | PixelType::RgbU16 => Some(u16::MAX as f64),
            PixelType::U32 => Some(u32::MAX as f64),
            PixelType::I16 => Some(i16::MAX as f64),
            PixelType::I32 => Some(i32::MAX as f64),
            _ => None,
        }
    }
}

/// Values of one axis with their unit, one value per pixel along that axis.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisTable {
    /// One value per pixel, increasing.
    pub values: Vec<f64>,
    /// Unit as the file names it (e.g. `nm`, `mm`); not converted.
    pub unit: String,
}

/// One streak image: `nx` columns (slit position) by `nt` rows (time bins).
#[derive(Clone, Debug, PartialEq)]
pub struct StreakImage {
    /// Number of columns (x, along the slit).
    pub nx: usize,
    /// Number of rows (time bins).
    pub nt: usize,
    /// Row-major `[t][x]`: row `t` is one time line, as the files store them.
    pub data: Vec<f32>,
    /// How the file stored the samples.
    pub pixel_type: PixelType,
    /// Per-row times read from the file (HPD-TA time tables or linear time scaling),
    /// converted to picoseconds, increasing; `None` when the file has no time calibration.
    pub time_axis_ps: Option<Vec<f64>>,
    /// Per-column positions read from the file (HPD-TA X scaling), in the file's unit.
    pub x_axis: Option<AxisTable>,
    /// The HPD-TA header and comment, for `.img` files and HPD-TA TIFF files.
    pub img_meta: Option<hamamatsu::ImgMeta>,
}

impl StreakImage {
    /// An `f32` image with no axes or metadata, as the simulator produces it.
    ///
    /// # Panics
    /// If `data.len() != nx * nt` (a programming error, not bad input).
    pub fn new(nx: usize, nt: usize, data: Vec<f32>) -> StreakImage {
        assert_eq!(data.len(), nx * nt, "StreakImage::new: data is not nx * nt");
        StreakImage {
            nx,
            nt,
            data,
            pixel_type: PixelType::F32,
            time_axis_ps: None,
            x_axis: None,
            img_meta: None,
        }
    }

    /// The value at column `x`, time row `t`.
    #[inline]
    pub fn at(&self, x: usize, t: usize) -> f32 {
        self.data[t * self.nx + x]
    }

    /// One time line (row `t`, all x).
    pub fn row(&self, t: usize) -> &[f32] {
        &self.data[t * self.nx..(t + 1) * self.nx]
    }
}

/// Errors of the streak-image readers and writers; every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The extension is not one of the streak-image types this toolkit reads.
    #[error(
        "{}: unknown streak-image file type '{ext}' (expected .png, .tif, .tiff, .exr, .hdr or .img)",
        path.display()
    )]
    UnknownFileType { path: PathBuf, ext: String },
    /// The file ends before the data its header announces.
    #[error("{}: truncated file: {what} needs {needed} bytes, the file has {available}", path.display())]
    Truncated {
        path: PathBuf,
        what: String,
        needed: u64,
        available: u64,
    },
    /// The file is not of the type its extension claims (wrong magic bytes).
    #[error("{}: {message}", path.display())]
    BadMagic { path: PathBuf, message: String },
    /// An HPD-TA file in the compressed storage type (file type 1), which HPD-TA itself does
    /// not write and this reader does not decode.
    #[error("{}: compressed HPD-TA image (file type 1) is not supported", path.display())]
    CompressedImg { path: PathBuf },
    /// An HPD-TA file type code other than 0, 1, 2 or 3.
    #[error("{}: unknown HPD-TA file type {code} (known: 0 = 8-bit, 2 = 16-bit, 3 = 32-bit)", path.display())]
    UnknownImgFileType { path: PathBuf, code: i16 },
    /// A structural feature of the file that this reader does not handle (several images or
    /// channels in one HPD-TA file, a multi-page TIFF, several EXR layers, ...).
    #[error("{}: unsupported: {what}", path.display())]
    Unsupported { path: PathBuf, what: String },
    /// The HPD-TA comment is not `[Section],Key=Value,...` text.
    #[error("{}: HPD-TA comment, byte {offset}: {message}", path.display())]
    BadComment {
        path: PathBuf,
        offset: usize,
        message: String,
    },
    /// A `Scaling{X,Y}Type` other than 1 (linear) or 2 (table).
    #[error("{}: unknown scaling type {value:?} for the {axis} axis (known: 1 = linear, 2 = table)", path.display())]
    UnknownScalingType {
        path: PathBuf,
        axis: char,
        value: String,
    },
    /// A unit that cannot be converted where one is needed (a time axis, a time range).
    #[error("{}: {what}: unknown time unit {unit:?} (known: fs, ps, ns, us, µs, ms, s)", path.display())]
    UnknownUnit {
        path: PathBuf,
        what: String,
        unit: String,
    },
    /// A key in a section whose meaning this reader must know (`[Scaling]`) that it does not.
    #[error("{}: unknown key {key:?} in section [{section}]", path.display())]
    UnknownKey {
        path: PathBuf,
        section: String,
        key: String,
    },
    /// A value that does not parse as what its key requires.
    #[error("{}: [{section}] {key}={value:?}: {expected}", path.display())]
    BadValue {
        path: PathBuf,
        section: String,
        key: String,
        value: String,
        expected: String,
    },
    /// An axis table that is neither strictly increasing nor strictly decreasing.
    #[error("{}: the {axis} axis table ([Scaling] Scaling{axis}ScalingFile) is neither increasing nor decreasing (at index {index})", path.display())]
    NonMonotonicAxis {
        path: PathBuf,
        axis: char,
        index: usize,
    },
    /// The channels of the image cannot be reduced to one value per pixel by the documented
    /// rule (a coloured integer image, a palette, CMYK, EXR channels without Y or R,G,B ...).
    #[error("{}: unsupported channel layout: {message}", path.display())]
    ChannelLayout { path: PathBuf, message: String },
    /// Two sizes that must agree do not (data length, table length, axis length ...).
    #[error("{}: size mismatch: {what}: expected {expected}, found {found}", path.display())]
    SizeMismatch {
        path: PathBuf,
        what: String,
        expected: usize,
        found: usize,
    },
    /// The codec library refused the file (corrupt or truncated PNG, TIFF, EXR or HDR).
    #[error("{}: cannot decode: {message}", path.display())]
    Decode { path: PathBuf, message: String },
    /// A writer was given a NaN or infinite value for an integer format.
    #[error("{}: cannot store non-finite value {value} at x {x}, t {t} in an integer format", path.display())]
    NonFinite {
        path: PathBuf,
        x: usize,
        t: usize,
        value: f32,
    },
    /// A writer was given an argument it cannot honour (bit depth, scale, dimensions ...).
    #[error("{}: {message}", path.display())]
    InvalidArgument { path: PathBuf, message: String },
    /// The image the header declares would not fit in the memory budget
    /// ([`check_image_size`]).
    #[error("{}: {source}", path.display())]
    Limit {
        path: PathBuf,
        source: crate::limits::LimitError,
    },
}

/// Float32 copies of an image a streak-image reader holds at once: the decoded values and
/// their reorder (a transposed or flipped copy).
pub const IMAGE_F32_COPIES: usize = 2;

/// The size check of every streak-image reader (PNG, TIFF, EXR, HDR, HPD-TA `.img`), made
/// from the header alone before any pixel is read or allocated
/// ([`crate::limits::check_decoded`]): `width` x `height` pixels of `stored_bytes` each (all
/// channels, as the codec hands them over) read as one float32 each, with
/// [`IMAGE_F32_COPIES`] copies held, plus the codec's own buffer of the stored samples.
pub fn check_image_size(
    path: &Path,
    width: usize,
    height: usize,
    stored_bytes: usize,
) -> Result<(), FormatError> {
    let copies = IMAGE_F32_COPIES + stored_bytes.div_ceil(4);
    crate::limits::check_decoded(
        &[height, width],
        4,
        copies,
        format_args!(
            "an image of {width} x {height} pixels of {stored_bytes} bytes (read as float32, \
             {copies} copies held)"
        ),
        "a streak image is far smaller: is the header damaged?",
    )
    .map(|_| ())
    .map_err(|source| FormatError::Limit {
        path: path.to_path_buf(),
        source,
    })
}

/// A file read by regions at byte offsets, never whole (an HPD-TA image's axis tables).
pub(crate) struct FileRegions<'a> {
    file: &'a std::fs::File,
    /// The file's length, bytes.
    pub len: u64,
}

impl<'a> FileRegions<'a> {
    pub fn new(file: &'a std::fs::File) -> std::io::Result<FileRegions<'a>> {
        let len = file.metadata()?.len();
        Ok(FileRegions { file, len })
    }

    /// `n` bytes at `offset` (the caller has checked that they lie in the file).
    pub fn read(&self, offset: u64, n: usize) -> std::io::Result<Vec<u8>> {
        use std::io::{Read, Seek, SeekFrom};
        let mut f = self.file;
        f.seek(SeekFrom::Start(offset))?;
        let mut buf = vec![0u8; n];
        f.read_exact(&mut buf)?;
        Ok(buf)
    }
}

/// Extensions [`read_streak`] reads (lower case, without the dot).
pub const STREAK_EXTENSIONS: [&str; 6] = ["png", "tif", "tiff", "exr", "hdr", "img"];

/// The extension of `path` in lower case when [`read_streak`] reads it.
pub fn streak_extension(path: &Path) -> Option<&'static str> {
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    STREAK_EXTENSIONS.iter().copied().find(|e| *e == ext)
}

/// Read one streak image, dispatching on the extension (`.png`, `.tif`, `.tiff`, `.exr`,
/// `.hdr`, `.img`, any case).
///
/// With `transpose` the file is taken to store time across and x down; the result is always
/// `[t][x]`. For `.img` files the axis roles swap too: the file's X scaling becomes the time
/// axis and its Y scaling the x axis.
pub fn read_streak(path: &Path, transpose: bool) -> Result<StreakImage, FormatError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "img" => hamamatsu::read_img(path, transpose),
        "png" | "tif" | "tiff" | "exr" | "hdr" => {
            let raw = match ext.as_str() {
                "png" => raster::read_png(path)?,
                "tif" | "tiff" => match hamamatsu::read_hpd_tiff(path, transpose)? {
                    hamamatsu::TiffImage::Hpd(image) => return Ok(*image),
                    hamamatsu::TiffImage::Plain(raw) => raw,
                },
                "exr" => raster::read_exr(path)?,
                _ => raster::read_hdr(path)?,
            };
            let (nx, nt, data) = if transpose {
                (
                    raw.height,
                    raw.width,
                    transpose_rows(&raw.data, raw.width, raw.height),
                )
            } else {
                (raw.width, raw.height, raw.data)
            };
            Ok(StreakImage {
                nx,
                nt,
                data,
                pixel_type: raw.pixel_type,
                time_axis_ps: None,
                x_axis: None,
                img_meta: None,
            })
        }
        _ => Err(FormatError::UnknownFileType {
            path: path.to_path_buf(),
            ext: if ext.is_empty() {
                "(none)".into()
            } else {
                format!(".{ext}")
            },
        }),
    }
}

/// Transpose a row-major `height x width` array into a row-major `width x height` one.
pub(crate) fn transpose_rows(data: &[f32], width: usize, height: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; data.len()];
    for r in 0..height {
        for c in 0..width {
            out[c * height + r] = data[r * width + c];
        }
    }
    out
}

/// Run `write` through [`crate::atomic::write_atomically_with`], naming `dest` in every error.
pub(crate) fn write_file_atomically<T>(
    dest: &Path,
    write: impl FnOnce(&Path) -> Result<T, FormatError>,
) -> Result<T, FormatError> {
    let io = |source| FormatError::Io {
        path: dest.to_path_buf(),
        source,
    };
    crate::atomic::write_atomically_with(dest, io, write)
}
