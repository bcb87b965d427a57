//! Resolving an ingest: from what the user named to a typed [`IngestPlan`].
//!
//! Inputs ([`InputSpec`]):
//!
//! - a capture folder holding `manifest.toml`, or the manifest itself (as `femto simulate`
//!   writes it, see [`crate::manifest`]): the scanline files, the image size and the time
//!   axis come from it;
//! - a glob pattern (`'scans/scan_*.png'`): the matches, sorted; when every file name holds
//!   a number (its last run of digits), that number minus the smallest one is the
//!   scanline, so a gap in the numbering is a missing scanline;
//! - a printf pattern (`scans/scan_%04d.png`) with a number of scanlines `N`: rows `0..N`;
//! - a 3-D dataset of an HDF5 file: `ny` streak images `[y][t][x]` (or `[y][x][t]` with
//!   `transpose`), read with [`crate::container::read_image_stack`];
//! - a single scanline file (`.png`, `.tif`, `.tiff`, `.exr`, `.hdr`, `.img`): a capture of
//!   one scanline. A folder without `manifest.toml` is refused with the image files it holds
//!   counted by extension, so the caller can suggest a glob.
//!
//! The time axis (the camera time of the recorded rows) comes from the manifest, else from
//! the `.img` time table of the first scanline, else from the bin width and start given
//! explicitly ([`IngestOptions::dt_ps`], [`IngestOptions::t0_ps`]); explicit values that
//! contradict the manifest or the table are refused rather than silently ignored, unless
//! [`IngestOptions::resample_time`] asks for the recorded rows to be resampled onto them
//! ([`super::time_axis`], which also makes sure no resampling drops signal). The
//! `.img` table is read as the start of each row's bin (femto's writer convention,
//! [`crate::formats::hamamatsu::write_img`]), the last row's end one spacing after its
//! start; a table whose spacing varies by more than 1e-4 of its mean is a non-linear sweep,
//! corrected by resampling onto a uniform axis spanning the same interval.
//!
//! The laser wavelength ([`IngestPlan::laser`]) comes from the manifest's `[capture]
//! laser_wavelength_nm`, else from [`IngestOptions::laser_nm`]; a value given that
//! contradicts the manifest's is refused. HPD-TA `.img` comments record no laser wavelength
//! (their `[Spectrograph] Wavelength` is the spectrograph's centre wavelength).
//!
//! Sweep calibration ([`IngestOptions::sweep_table`]): a text or CSV file of `nt + 1`
//! increasing bin-edge times in ps (numbers separated by commas, spaces or new lines; `#`
//! starts a comment; a first line without numbers is taken as a header), the true camera
//! time of each edge of the recorded rows, as a lab's sweep calibration gives it. A simulated
//! capture records the true edges in its manifest as `[imperfections.sweep] bin_times_ps`.
//!
//! Manifest corrections: a capture folder's manifest records what the lab measured with it,
//! and ingest applies it by default, as it applies an `.img` file's own time table: the dark
//! frame and the flat field named in `[files]` (`dark`, `flat`) and the sweep's bin times
//! (`[imperfections.sweep] bin_times_ps`, the sweep calibration). A flag given for one of
//! them replaces it; [`IngestOptions::ignore_manifest_corrections`] leaves all three out.
//! Without them a realistic simulated capture (5 % sweep non-linearity) fits `t0` 10 ps
//! (2.6 bins) early.
//!
//! Values: the samples read from the files times a value scale, which defaults to the
//! manifest's `png_value_per_count` for scanlines that store integer counts (16-bit PNG,
//! HPD-TA `.img`) and to 1 otherwise; the dark level and the saturation level are in these
//! scaled units. A dark frame with integer samples is scaled like the scanlines; one with
//! float samples (EXR, as `femto simulate` writes `dark.exr`) is taken as signal values.

use std::path::{Path, PathBuf};

use super::corrections::{check_flat, check_sweep_edges, RefRegion};
use super::row_offsets::RowOffsetFit;
use super::time_axis::{self, AxisRequest, Recorded, RecordedEdges};
use super::IngestError;
use crate::cube::TimeAxis;
use crate::formats::{read_streak, streak_extension, PixelType, StreakImage};
use crate::limits::{bounded_count, check_memory};
use crate::manifest::Manifest;

pub use super::time_axis::edges_from_starts;

/// Relative difference above which a laser wavelength given contradicts the manifest's.
const LASER_AGREEMENT_TOLERANCE: f64 = 1e-6;

/// What the user named as the capture.
#[derive(Clone, Debug, PartialEq)]
pub enum InputSpec {
    /// A manifest file (a capture folder resolves to its `manifest.toml`).
    Manifest(PathBuf),
    /// A glob pattern matching one file per scanline.
    Glob(String),
    /// A printf pattern (one `%d`, `%Nd` or `%0Nd`) for scanlines `0..rows`.
    Printf { pattern: String, rows: usize },
    /// A 3-D dataset of an HDF5 file holding the streak images.
    Stack { path: PathBuf, dataset: String },
    /// One scanline file: a capture of one scanline.
    File(PathBuf),
}

/// A printf pattern split around its one integer conversion.
#[derive(Clone, Debug, PartialEq)]
struct Printf {
    prefix: String,
    suffix: String,
    width: usize,
    zero_pad: bool,
}

impl Printf {
    /// Parse `pattern`; `Ok(None)` when it holds no conversion at all.
    fn parse(pattern: &str) -> Result<Option<Printf>, IngestError> {
        let bad = |message: &str| IngestError::BadPrintf {
            pattern: pattern.to_string(),
            message: message.to_string(),
        };
        let mut found: Option<Printf> = None;
        let mut literal = String::new();
        let chars: Vec<char> = pattern.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            if chars[i] != '%' {
                literal.push(chars[i]);
                i += 1;
                continue;
            }
            if chars.get(i + 1) == Some(&'%') {
                literal.push('%');
                i += 2;
                continue;
            }
            let mut j = i + 1;
            let zero_pad = chars.get(j) == Some(&'0');
            if zero_pad {
                j += 1;
            }
            let digits_start = j;
            while chars.get(j).is_some_and(|c| c.is_ascii_digit()) {
                j += 1;
            }
            if chars.get(j) != Some(&'d') {
                return Err(bad("only %d, %Nd and %0Nd are understood"));
            }
            if found.is_some() {
                return Err(bad("more than one conversion"));
            }
            let width: String = chars[digits_start..j].iter().collect();
            found = Some(Printf {
                prefix: std::mem::take(&mut literal),
                suffix: String::new(),
                width: width.parse().unwrap_or(0),
                zero_pad,
            });
            i = j + 1;
        }
        Ok(found.map(|mut p| {
            p.suffix = literal;
            p
        }))
    }

    fn format(&self, n: usize) -> String {
        let number = if self.zero_pad {
            format!("{n:0width$}", width = self.width)
        } else {
            format!("{n:width$}", width = self.width)
        };
        format!("{}{number}{}", self.prefix, self.suffix)
    }
}

impl InputSpec {
    /// Decide what kind of input `input` is: with a `dataset` it is an HDF5 stack; a `%d`
    /// conversion makes a printf pattern (which needs `rows`); `*`, `?` or `[` a glob; a
    /// folder with `manifest.toml` a capture folder (one without is refused, naming the
    /// image files it holds); a `.toml` file a manifest; a file that [`read_streak`] reads
    /// a capture of one scanline.
    pub fn classify(
        input: &str,
        rows: Option<usize>,
        dataset: Option<&str>,
    ) -> Result<InputSpec, IngestError> {
        if let Some(dataset) = dataset {
            return Ok(InputSpec::Stack {
                path: PathBuf::from(input),
                dataset: dataset.to_string(),
            });
        }
        if Printf::parse(input)?.is_some() {
            return match rows {
                Some(rows) if rows > 0 => Ok(InputSpec::Printf {
                    pattern: input.to_string(),
                    rows: bounded_count(
                        rows as f64,
                        MAX_SCANLINES,
                        format_args!("the scanlines of {input} (--rows)"),
                        "lower --rows",
                    )?,
                }),
                _ => Err(IngestError::PrintfNeedsRows {
                    pattern: input.to_string(),
                }),
            };
        }
        if input.contains(['*', '?', '[']) {
            return Ok(InputSpec::Glob(input.to_string()));
        }
        let path = Path::new(input);
        if path.is_dir() {
            let manifest = path.join("manifest.toml");
            if !manifest.exists() {
                return Err(IngestError::FolderWithoutManifest {
                    dir: path.to_path_buf(),
                    found: streak_files_by_extension(path),
                });
            }
            return Ok(InputSpec::Manifest(manifest));
        }
        let is_toml = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        if is_toml {
            return Ok(InputSpec::Manifest(path.to_path_buf()));
        }
        if !path.exists() {
            return Err(IngestError::NoSuchInput {
                input: input.to_string(),
            });
        }
        if path.is_file() && streak_extension(path).is_some() {
            return Ok(InputSpec::File(path.to_path_buf()));
        }
        Err(IngestError::NotAnInput {
            input: input.to_string(),
        })
    }

    /// The input as the user would write it, for messages and provenance.
    pub fn describe(&self) -> String {
        match self {
            InputSpec::Manifest(p) => p.display().to_string(),
            InputSpec::Glob(g) => g.clone(),
            InputSpec::Printf { pattern, rows } => format!("{pattern} (rows 0..{rows})"),
            InputSpec::Stack { path, dataset } => format!("{}:/{dataset}", path.display()),
            InputSpec::File(p) => p.display().to_string(),
        }
    }
}

/// The files of `dir` that [`read_streak`] reads, counted by extension (lower case), most
/// first, then by name; an unreadable folder counts none.
pub fn streak_files_by_extension(dir: &Path) -> Vec<(String, usize)> {
    let mut counts: std::collections::BTreeMap<&'static str, usize> = Default::default();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if let Some(ext) = streak_extension(&path).filter(|_| path.is_file()) {
            *counts.entry(ext).or_default() += 1;
        }
    }
    let mut found: Vec<(String, usize)> = counts
        .into_iter()
        .map(|(e, n)| (e.to_string(), n))
        .collect();
    found.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    found
}

/// The dark signal asked for.
#[derive(Clone, Debug, PartialEq)]
pub enum DarkInput {
    /// A constant level (scaled value units).
    Level(f64),
    /// A dark frame: a streak image of the scanlines' size (read like them; integer samples
    /// are scaled by the value scale, float samples taken as they are).
    File(PathBuf),
}

/// The laser power normalisation asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PowerRef {
    /// A block of every scanline that sees a fixed part of the scene (the laser spot, a
    /// reference fibre): rows are scaled to the median of its integral.
    Region(RefRegion),
    /// No reference in view: each row's pixel integrals against the same pixels in the
    /// neighbouring rows ([`super::row_offsets`]).
    Auto,
}

/// Laser power normalisation, resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PowerCorrection {
    /// Reference region (recorded bins), rows scaled to the median of its integral.
    Region(RefRegion),
    /// Pixel integrals against the same pixels in the neighbouring rows
    /// ([`super::row_offsets`]).
    Auto(RowOffsetFit),
}

/// The saturation level asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SaturationInput {
    /// A level in scaled value units.
    Level(f64),
    /// The largest value the files' integer sample type can store, times the value scale.
    Auto,
}

/// The options of an ingest, as typed values (the command line maps its flags onto these);
/// `Default` is what `femto ingest` does without flags: the manifest's corrections and jitter
/// removal.
#[derive(Clone, Debug, PartialEq)]
pub struct IngestOptions {
    /// Width of a time bin, ps, when the capture records none.
    pub dt_ps: Option<f64>,
    /// Start of bin 0, ps, when the capture records none.
    pub t0_ps: Option<f64>,
    /// The files store time across and x down.
    pub transpose: bool,
    /// Dark subtraction.
    pub dark: Option<DarkInput>,
    /// Flat-field division by the per-pixel gains of this image (`nx` wide, `ny` or 1 high).
    pub flat: Option<PathBuf>,
    /// Sweep calibration table (`nt + 1` true bin-edge times, ps).
    pub sweep_table: Option<PathBuf>,
    /// Estimate and remove per-scanline trigger jitter (on by default).
    pub jitter: bool,
    /// Laser power normalisation (a reference region in recorded bins, or automatic).
    pub power_ref: Option<PowerRef>,
    /// Mask saturated pixels.
    pub saturation: Option<SaturationInput>,
    /// Fill missing scanlines by interpolation (and mask them) instead of refusing.
    pub allow_missing: bool,
    /// Multiply the samples read by this (for 16-bit PNG: the signal per count).
    pub value_scale: Option<f64>,
    /// Where `dt_ps` or `t0_ps` contradict the axis the capture records (manifest, `.img`
    /// time table), resample the recorded rows onto them (conserving each pixel's
    /// integral) instead of refusing them.
    pub resample_time: bool,
    /// Laser wavelength, nm, for captures without a manifest (must agree with a
    /// manifest's).
    pub laser_nm: Option<f64>,
    /// Do not apply the corrections a manifest records (module doc, "Manifest
    /// corrections"): its dark frame, flat field and sweep bin times.
    pub ignore_manifest_corrections: bool,
}

impl Default for IngestOptions {
    fn default() -> Self {
        IngestOptions {
            dt_ps: None,
            t0_ps: None,
            transpose: false,
            dark: None,
            flat: None,
            sweep_table: None,
            jitter: true,
            power_ref: None,
            saturation: None,
            allow_missing: false,
            value_scale: None,
            resample_time: false,
            laser_nm: None,
            ignore_manifest_corrections: false,
        }
    }
}

/// The corrections a manifest records, applied unless given otherwise (module doc).
#[derive(Clone, Debug, Default, PartialEq)]
struct ManifestCorrections {
    dark: Option<DarkInput>,
    flat: Option<PathBuf>,
    sweep: Option<RecordedEdges>,
}

impl ManifestCorrections {
    /// The dark frame and flat field named in `[files]` (relative to the manifest's folder)
    /// and the sweep's bin times of `[imperfections.sweep]`.
    fn of(m: &Manifest, path: &Path) -> ManifestCorrections {
        let dir = path.parent().unwrap_or(Path::new("."));
        ManifestCorrections {
            dark: m.files.dark.as_ref().map(|d| DarkInput::File(dir.join(d))),
            flat: m.files.flat.as_ref().map(|f| dir.join(f)),
            sweep: m.imperfections.sweep.as_ref().map(|s| RecordedEdges {
                edges_ps: s.bin_times_ps.clone(),
                source: format!("sweep bin times of {}", path.display()),
            }),
        }
    }
}

/// The laser wavelength of the capture, with where it comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserWavelength {
    /// Wavelength, nm.
    pub nm: f64,
    /// `manifest PATH` or `given`.
    pub source: String,
}

/// Where the scanlines come from.
#[derive(Clone, Debug, PartialEq)]
pub enum RowSource {
    /// One file per scanline; `None` for a missing scanline (only with `allow_missing`).
    Files(Vec<Option<PathBuf>>),
    /// A stack read from one HDF5 dataset: `ny` images of `a x b` values, `[y][a][b]`, with
    /// `(a, b) = (nt, nx)`, or `(nx, nt)` with `transpose`.
    Stack {
        path: PathBuf,
        dataset: String,
        values: Vec<f32>,
    },
}

/// Dark signal, resolved.
#[derive(Clone, Debug, PartialEq)]
pub enum DarkCorrection {
    /// A constant level, scaled value units.
    Level(f32),
    /// A dark frame in the row layout `[x][t]` (recorded bins), scaled value units.
    Frame { path: PathBuf, values_xt: Vec<f32> },
}

/// Flat field, resolved: per-pixel gains (1 = nominal).
#[derive(Clone, Debug, PartialEq)]
pub struct FlatCorrection {
    pub path: PathBuf,
    /// `ny * nx` gains (`[y][x]`), or `nx` gains applied to every scanline.
    pub gains: Vec<f32>,
}

impl FlatCorrection {
    /// The gains of scanline `y`.
    pub fn row(&self, y: usize, nx: usize) -> &[f32] {
        if self.gains.len() == nx {
            &self.gains
        } else {
            &self.gains[y * nx..(y + 1) * nx]
        }
    }
}

/// Sweep-linearity correction, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepCorrection {
    /// True camera time of each recorded row edge (`nt + 1`, increasing), ps.
    pub edges_ps: Vec<f64>,
    /// Where the edges come from (for provenance).
    pub source: String,
}

/// Saturation masking, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct SaturationCorrection {
    /// The level, scaled value units.
    pub level: f32,
    /// A raw value at or above this is saturated: the level, less half a count for integer
    /// files (a value clipped at the level is stored rounded to the nearest count).
    pub threshold: f32,
    /// How the level was chosen (for provenance).
    pub source: String,
}

/// Most scanlines of one capture (the seed's has 600): a printf pattern's `--rows` beyond it
/// is refused before a file name is formatted.
pub const MAX_SCANLINES: u64 = 1 << 20;

/// Memory of the process before the stage allocates anything (code, threads, HDF5), bytes.
const BASE_BYTES: f64 = 24e6;

/// Bytes held per pixel of the cube: the masks of both passes, the row-offset fit's edge and
/// the power fit's log integral (`Option<f64>` each).
const BYTES_PER_PIXEL: f64 = 36.0;

/// Everything an ingest needs, resolved and checked: the files, the sizes, the axes and the
/// corrections with their parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct IngestPlan {
    /// The input as the user named it.
    pub input: String,
    pub source: RowSource,
    /// Columns (x) of each scanline.
    pub nx: usize,
    /// Number of scanlines.
    pub ny: usize,
    /// Recorded time rows of each streak image.
    pub nt_recorded: usize,
    /// The files store time across and x down.
    pub transpose: bool,
    /// Multiplies every sample read.
    pub value_scale: f32,
    /// Sample type of the first scanline.
    pub pixel_type: PixelType,
    /// The first scanline read (sizes and pixel types are checked against it).
    pub reference: PathBuf,
    /// The `.img` time table of the reference scanline (bin starts, ps) when it gave the
    /// time axis; every other scanline's table must agree with it.
    pub img_time_table_ps: Option<Vec<f64>>,
    /// The uniform camera-time axis of the output cube.
    pub out_axis: TimeAxis,
    /// Which time axis was used and where it comes from (for provenance).
    pub axis_source: String,
    /// The laser wavelength, when the manifest records it or it was given.
    pub laser: Option<LaserWavelength>,
    pub dark: Option<DarkCorrection>,
    pub flat: Option<FlatCorrection>,
    pub power: Option<PowerCorrection>,
    pub sweep: Option<SweepCorrection>,
    pub jitter: Option<RowOffsetFit>,
    pub saturation: Option<SaturationCorrection>,
    /// Scanlines without a file, filled by interpolation and masked.
    pub missing: Vec<usize>,
}

impl IngestPlan {
    /// Resolve `input` with `options`: list the scanlines, read the first one (size, sample
    /// type, time table), read the dark frame, flat field and sweep table, and check that
    /// every part fits the others. The scanlines themselves are read by
    /// [`super::assemble`].
    pub fn resolve(input: &InputSpec, options: &IngestOptions) -> Result<IngestPlan, IngestError> {
        if let Some(v) = options.value_scale {
            if !(v.is_finite() && v > 0.0) {
                return Err(IngestError::BadValue {
                    what: "value scale".into(),
                    value: v.to_string(),
                    message: "must be finite and > 0".into(),
                });
            }
        }
        for (what, v) in [("dt_ps", options.dt_ps), ("t0_ps", options.t0_ps)] {
            if let Some(v) = v {
                let ok = v.is_finite() && (what == "t0_ps" || v > 0.0);
                if !ok {
                    return Err(IngestError::BadValue {
                        what: what.into(),
                        value: v.to_string(),
                        message: "must be finite (and dt_ps > 0)".into(),
                    });
                }
            }
        }
        if let Some(v) = options.laser_nm {
            if !(v.is_finite() && v > 0.0) {
                return Err(IngestError::BadValue {
                    what: "laser_nm".into(),
                    value: v.to_string(),
                    message: "must be a positive wavelength in nm".into(),
                });
            }
        }
        let describe = input.describe();
        let listed = list_rows(input, options)?;
        let in_manifest = match &listed.manifest {
            Some((m, path)) if !options.ignore_manifest_corrections => {
                ManifestCorrections::of(m, path)
            }
            _ => ManifestCorrections::default(),
        };
        let with_recorded = IngestOptions {
            dark: options.dark.clone().or(in_manifest.dark),
            flat: options.flat.clone().or(in_manifest.flat),
            ..options.clone()
        };
        let options = &with_recorded;
        let missing: Vec<usize> = match &listed.source {
            RowSource::Files(files) => (0..files.len()).filter(|&y| files[y].is_none()).collect(),
            RowSource::Stack { .. } => Vec::new(),
        };
        let ny = listed.ny;
        if missing.len() == ny {
            return Err(IngestError::AllMissing { input: describe });
        }

        // The reference scanline: the first present one.
        let (probe, reference) = match &listed.source {
            RowSource::Files(files) => {
                let path = files.iter().flatten().next().expect("one present").clone();
                (read_streak(&path, options.transpose)?, path)
            }
            RowSource::Stack {
                path,
                dataset,
                values,
            } => {
                let (nx, nt) = listed.stack_nx_nt.expect("stack sizes");
                let mut img =
                    StreakImage::new(nx, nt, stack_image(values, 0, nx, nt, options.transpose));
                img.pixel_type = listed.stack_pixel_type;
                (img, PathBuf::from(format!("{}:/{dataset}", path.display())))
            }
        };
        let (nx, nt) = (probe.nx, probe.nt);
        let value_scale = match options.value_scale {
            Some(v) => v,
            None => listed.default_value_scale(probe.pixel_type),
        };

        // Time axis: manifest, else .img table, else explicit values (`time_axis`).
        let mut img_time_table_ps = None;
        let recorded = if let Some((m, mpath)) = &listed.manifest {
            let c = &m.capture;
            for (what, want, found) in [("nx", c.nx, nx), ("nt", c.nt, nt)] {
                if want != found {
                    return Err(IngestError::ManifestSize {
                        manifest: mpath.clone(),
                        what: what.into(),
                        manifest_value: want,
                        file: reference.clone(),
                        found,
                    });
                }
            }
            let axis = TimeAxis {
                t0_ps: c.t0_ps,
                dt_ps: c.dt_ps,
                nt,
            };
            Some(Recorded {
                edges: RecordedEdges::uniform(&axis, format!("manifest {}", mpath.display())),
                axis,
            })
        } else if let Some(table) = probe.time_axis_ps.as_ref().filter(|t| t.len() >= 2) {
            img_time_table_ps = Some(table.clone());
            let edges = RecordedEdges {
                edges_ps: edges_from_starts(table),
                source: format!(".img time table of {}", reference.display()),
            };
            Some(Recorded {
                axis: edges.span_axis(),
                edges,
            })
        } else {
            None
        };
        let sweep_table = match &options.sweep_table {
            Some(path) => {
                let edges_ps = read_sweep_table(path)?;
                check_sweep_edges(&edges_ps, nt).map_err(|source| IngestError::Correction {
                    what: path.display().to_string(),
                    source,
                })?;
                Some(RecordedEdges {
                    edges_ps,
                    source: format!("table {}", path.display()),
                })
            }
            None => in_manifest.sweep,
        };
        let request = AxisRequest {
            dt_ps: options.dt_ps,
            t0_ps: options.t0_ps,
            resample: options.resample_time,
        };
        let resolved = time_axis::resolve(
            recorded.as_ref(),
            sweep_table.as_ref(),
            &request,
            nt,
            &describe,
        )?;
        let out_axis = resolved.out_axis;
        let axis_source = resolved.description;
        let sweep = resolved.resample_from.map(|e| SweepCorrection {
            edges_ps: e.edges_ps,
            source: e.source,
        });

        let laser = match (&listed.manifest, options.laser_nm) {
            (Some((m, mpath)), given) => {
                let recorded = m.capture.laser_wavelength_nm;
                if let Some(g) = given {
                    if (g - recorded).abs() > LASER_AGREEMENT_TOLERANCE * recorded {
                        return Err(IngestError::LaserConflict {
                            given: g,
                            manifest: mpath.clone(),
                            recorded,
                        });
                    }
                }
                Some(LaserWavelength {
                    nm: recorded,
                    source: format!("manifest {}", mpath.display()),
                })
            }
            (None, Some(nm)) => Some(LaserWavelength {
                nm,
                source: "given".into(),
            }),
            (None, None) => None,
        };

        let dark = match &options.dark {
            None => None,
            Some(DarkInput::Level(v)) => {
                if !v.is_finite() {
                    return Err(IngestError::BadValue {
                        what: "dark level".into(),
                        value: v.to_string(),
                        message: "must be finite".into(),
                    });
                }
                Some(DarkCorrection::Level(*v as f32))
            }
            Some(DarkInput::File(path)) => {
                let img = read_streak(path, options.transpose)?;
                if (img.nx, img.nt) != (nx, nt) {
                    return Err(IngestError::SizeMismatch {
                        path: path.clone(),
                        what: "dark frame".into(),
                        found_nx: img.nx,
                        found_nt: img.nt,
                        nx,
                        nt,
                        reference: reference.clone(),
                    });
                }
                // Counts are scaled like the scanlines; float samples are signal already.
                let scale = match img.pixel_type.max_stored_value() {
                    Some(_) => value_scale as f32,
                    None => 1.0,
                };
                let mut values_xt = vec![0.0f32; nx * nt];
                to_row_layout(&img.data, nx, nt, scale, &mut values_xt).map_err(
                    |(x, t, value)| IngestError::NonFinite {
                        path: path.clone(),
                        x,
                        t,
                        value,
                    },
                )?;
                Some(DarkCorrection::Frame {
                    path: path.clone(),
                    values_xt,
                })
            }
        };

        let flat = match &options.flat {
            None => None,
            Some(path) => {
                let img = read_streak(path, false)?;
                if img.nx != nx || (img.nt != ny && img.nt != 1) {
                    return Err(IngestError::FlatSize {
                        path: path.clone(),
                        width: img.nx,
                        height: img.nt,
                        nx,
                        ny,
                    });
                }
                check_flat(&img.data[..nx], nx).map_err(|source| IngestError::Correction {
                    what: path.display().to_string(),
                    source,
                })?;
                Some(FlatCorrection {
                    path: path.clone(),
                    gains: img.data,
                })
            }
        };

        let power = match options.power_ref {
            None => None,
            Some(PowerRef::Auto) => Some(PowerCorrection::Auto(RowOffsetFit::default())),
            Some(PowerRef::Region(region)) => {
                region
                    .check(nx, nt)
                    .map_err(|source| IngestError::Correction {
                        what: "power reference region".into(),
                        source,
                    })?;
                Some(PowerCorrection::Region(region))
            }
        };

        let saturation = match options.saturation {
            None => None,
            Some(sat) => {
                let quantum = match probe.pixel_type.max_stored_value() {
                    Some(_) => value_scale,
                    None => 0.0,
                };
                let (level, source) = match sat {
                    SaturationInput::Level(v) => {
                        if !(v.is_finite() && v > 0.0) {
                            return Err(IngestError::BadValue {
                                what: "saturation level".into(),
                                value: v.to_string(),
                                message: "must be finite and > 0".into(),
                            });
                        }
                        (v, "given".to_string())
                    }
                    SaturationInput::Auto => match probe.pixel_type.max_stored_value() {
                        Some(max) => (
                            max * value_scale,
                            format!(
                                "auto: {max} ({:?}) x value scale {value_scale}",
                                probe.pixel_type
                            ),
                        ),
                        None => {
                            return Err(IngestError::SaturationAuto {
                                path: reference.clone(),
                                pixel_type: format!("{:?}", probe.pixel_type),
                            })
                        }
                    },
                };
                Some(SaturationCorrection {
                    level: level as f32,
                    threshold: (level - 0.5 * quantum) as f32,
                    source,
                })
            }
        };

        let plan = IngestPlan {
            input: describe,
            source: listed.source,
            nx,
            ny,
            nt_recorded: nt,
            transpose: options.transpose,
            value_scale: value_scale as f32,
            pixel_type: probe.pixel_type,
            reference,
            // A sweep table replaces the files' own tables, which then need not agree.
            img_time_table_ps: img_time_table_ps.filter(|_| sweep_table.is_none()),
            out_axis,
            axis_source,
            laser,
            dark,
            flat,
            power,
            sweep,
            jitter: options.jitter.then(RowOffsetFit::default),
            saturation,
            missing,
        };
        check_memory(
            plan.memory_estimate(),
            format_args!(
                "ingesting {} ({} x {} pixels, {} recorded and {} output bins)",
                plan.input, plan.nx, plan.ny, plan.nt_recorded, plan.out_axis.nt
            ),
            "ingest fewer scanlines, or raise --dt-ps when resampling",
        )?;
        Ok(plan)
    }

    /// Peak memory of [`super::assemble::ingest`] for this plan, bytes: the per-pixel maps,
    /// the rows in flight (each decoded, in recorded bins, and corrected, in output bins, for
    /// `2 threads + 2` rows) and an HDF5 stack input, which is read whole. A float, so that no
    /// product of sizes can overflow.
    pub fn memory_estimate(&self) -> f64 {
        let (fx, fy) = (self.nx as f64, self.ny as f64);
        let (rec, out) = (self.nt_recorded as f64, self.out_axis.nt as f64);
        let threads = rayon::current_num_threads().max(1) as f64;
        let in_flight = 2.0 * threads + 2.0;
        let row = 4.0 * fx * (2.0 * rec + out);
        let stack = match &self.source {
            RowSource::Stack { values, .. } => 4.0 * values.len() as f64,
            RowSource::Files(_) => 0.0,
        };
        BASE_BYTES + BYTES_PER_PIXEL * fx * fy + in_flight * row + stack
    }

    /// Whether the plan needs a first pass over every scanline before the cube can be
    /// written (laser power gains are relative to the median row; jitter is estimated
    /// against the neighbouring rows).
    pub fn needs_two_passes(&self) -> bool {
        self.power.is_some() || self.jitter.is_some()
    }

    /// The corrections this plan applies, in the order they are applied, with parameters.
    pub fn corrections(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(s) = &self.saturation {
            out.push(format!(
                "saturation mask (level {}, {}; on raw values)",
                s.level, s.source
            ));
        }
        match &self.dark {
            Some(DarkCorrection::Level(v)) => out.push(format!("dark subtraction (level {v})")),
            Some(DarkCorrection::Frame { path, .. }) => {
                out.push(format!("dark subtraction (frame {})", path.display()))
            }
            None => {}
        }
        if let Some(f) = &self.flat {
            let kind = if f.gains.len() == self.nx {
                "one row for all scanlines"
            } else {
                "one row per scanline"
            };
            out.push(format!(
                "flat-field division ({}, {kind})",
                f.path.display()
            ));
        }
        match &self.power {
            Some(PowerCorrection::Region(r)) => out.push(format!(
                "laser power normalisation (reference x {}..{}, bins {}..{})",
                r.x0, r.x1, r.t0_bin, r.t1_bin
            )),
            Some(PowerCorrection::Auto(_)) => out.push(
                "laser power normalisation (automatic: pixel integrals against the \
                 neighbouring rows)"
                    .into(),
            ),
            None => {}
        }
        if let Some(s) = &self.sweep {
            let what = if time_axis::edges_are_uniform(&s.edges_ps) {
                "time resampling"
            } else {
                "sweep linearity resampling"
            };
            let a = &self.out_axis;
            out.push(format!(
                "{what} ({} onto {} bins of {} ps from {} ps)",
                s.source, a.nt, a.dt_ps, a.t0_ps
            ));
        }
        if self.jitter.is_some() {
            out.push("jitter removal".into());
        }
        if !self.missing.is_empty() {
            out.push(format!(
                "{} missing scanlines interpolated and masked",
                self.missing.len()
            ));
        }
        out
    }

    /// The file of each scanline (`None` for missing ones, or for a stack), for provenance.
    pub fn source_files(&self) -> Vec<Option<String>> {
        match &self.source {
            RowSource::Files(files) => files
                .iter()
                .map(|f| f.as_ref().map(|p| p.display().to_string()))
                .collect(),
            RowSource::Stack { .. } => vec![None; self.ny],
        }
    }
}

/// Read a sweep calibration table: numbers separated by commas, blanks or new lines; `#`
/// starts a comment; a first line with no number is a header.
pub fn read_sweep_table(path: &Path) -> Result<Vec<f64>, IngestError> {
    let text = std::fs::read_to_string(path).map_err(|e| IngestError::SweepTable {
        path: path.to_path_buf(),
        line: 0,
        message: e.to_string(),
    })?;
    let mut values = Vec::new();
    let mut seen_data = false;
    for (i, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        let tokens: Vec<&str> = content
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .collect();
        if tokens.is_empty() {
            continue;
        }
        let parsed: Vec<Option<f64>> = tokens.iter().map(|t| t.parse::<f64>().ok()).collect();
        if !seen_data && parsed.iter().all(Option::is_none) {
            // A header line.
            seen_data = true;
            continue;
        }
        seen_data = true;
        for (t, v) in tokens.iter().zip(parsed) {
            match v {
                Some(v) => values.push(v),
                None => {
                    return Err(IngestError::SweepTable {
                        path: path.to_path_buf(),
                        line: i + 1,
                        message: format!("'{t}' is not a number (edge times in ps)"),
                    })
                }
            }
        }
    }
    Ok(values)
}

/// Convert a streak image `[t][x]` into the cube's row layout `[x][t]`, multiplying by
/// `scale`; the first non-finite sample (in file order) is an error `(x, t, value)`.
pub fn to_row_layout(
    image_tx: &[f32],
    nx: usize,
    nt: usize,
    scale: f32,
    out_xt: &mut [f32],
) -> Result<(), (usize, usize, f32)> {
    debug_assert_eq!(image_tx.len(), nx * nt);
    if let Some(i) = image_tx.iter().position(|v| !v.is_finite()) {
        return Err((i % nx, i / nx, image_tx[i]));
    }
    transpose_scaled(image_tx, nx, nt, out_xt, |v| v * scale);
    Ok(())
}

/// [`to_row_layout`] of integer samples (16-bit PNG scanlines): `[t][x]` in, `f32 [x][t]`
/// times `scale` out, in one pass (integers are always finite).
pub fn to_row_layout_u16(image_tx: &[u16], nx: usize, nt: usize, scale: f32, out_xt: &mut [f32]) {
    transpose_scaled(image_tx, nx, nt, out_xt, |v| f32::from(v) * scale);
}

/// `out_xt[x * nt + t] = value(image_tx[t * nx + x])`.
///
/// The transpose goes by 8 x 8 blocks gathered in a local array (a plain loop writes with a
/// stride of `nt` values and was a fifth of ingest's time; 32 x 32 tiles with indexed loops
/// were twice as slow as these blocks, which the compiler turns into vector shuffles).
fn transpose_scaled<S: Copy>(
    image_tx: &[S],
    nx: usize,
    nt: usize,
    out_xt: &mut [f32],
    value: impl Fn(S) -> f32,
) {
    const B: usize = 8;
    assert_eq!(image_tx.len(), nx * nt, "transpose: input size");
    assert_eq!(out_xt.len(), nx * nt, "transpose: output size");
    let (bx, bt) = (nx / B * B, nt / B * B);
    for x0 in (0..bx).step_by(B) {
        for t0 in (0..bt).step_by(B) {
            let mut block = [[0.0f32; B]; B]; // [x][t]
            for (dt, column) in (0..B).map(|dt| (dt, (t0 + dt) * nx + x0)) {
                let src: &[S; B] = image_tx[column..column + B].try_into().expect("block of B");
                for dx in 0..B {
                    block[dx][dt] = value(src[dx]);
                }
            }
            for (dx, line) in block.iter().enumerate() {
                let o = (x0 + dx) * nt + t0;
                out_xt[o..o + B].copy_from_slice(line);
            }
        }
    }
    // The edges: columns past the last whole block, then rows past it.
    for t in 0..nt {
        let x_start = if t < bt { bx } else { 0 };
        for x in x_start..nx {
            out_xt[x * nt + t] = value(image_tx[t * nx + x]);
        }
    }
}

/// Image `y` of a stack as a streak image `[t][x]`.
pub fn stack_image(values: &[f32], y: usize, nx: usize, nt: usize, transpose: bool) -> Vec<f32> {
    let image = &values[y * nx * nt..(y + 1) * nx * nt];
    if transpose {
        let mut out = vec![0.0f32; nx * nt];
        for x in 0..nx {
            for t in 0..nt {
                out[t * nx + x] = image[x * nt + t];
            }
        }
        out
    } else {
        image.to_vec()
    }
}

/// The scanlines of an input, before any file is read.
struct Listed {
    source: RowSource,
    ny: usize,
    manifest: Option<(Manifest, PathBuf)>,
    stack_nx_nt: Option<(usize, usize)>,
    stack_pixel_type: PixelType,
}

impl Listed {
    /// The manifest's value per count for scanlines that store integer counts (16-bit PNG,
    /// HPD-TA `.img`), else 1.
    fn default_value_scale(&self, pixel_type: PixelType) -> f64 {
        match &self.manifest {
            Some((m, _)) if pixel_type.max_stored_value().is_some() => {
                m.capture.png_value_per_count.unwrap_or(1.0)
            }
            _ => 1.0,
        }
    }
}

fn list_rows(input: &InputSpec, options: &IngestOptions) -> Result<Listed, IngestError> {
    let files_only = |files: Vec<Option<PathBuf>>, manifest| Listed {
        ny: files.len(),
        source: RowSource::Files(files),
        manifest,
        stack_nx_nt: None,
        stack_pixel_type: PixelType::F32,
    };
    match input {
        InputSpec::Manifest(path) => {
            let m = Manifest::load(path)?;
            let dir = path.parent().unwrap_or(Path::new("."));
            let mut files = Vec::with_capacity(m.capture.ny);
            for y in 0..m.capture.ny {
                let file = m
                    .scanline_path(dir, y)
                    .expect("validated manifest covers 0..ny");
                if file.is_file() {
                    files.push(Some(file));
                } else if options.allow_missing {
                    files.push(None);
                } else {
                    return Err(IngestError::ManifestFileMissing {
                        manifest: path.clone(),
                        row: y,
                        file,
                    });
                }
            }
            Ok(files_only(files, Some((m, path.clone()))))
        }
        InputSpec::Printf { pattern, rows } => {
            let p = Printf::parse(pattern)?.expect("classified as printf");
            let mut files = Vec::with_capacity(*rows);
            for y in 0..*rows {
                let file = PathBuf::from(p.format(y));
                if file.is_file() {
                    files.push(Some(file));
                } else if options.allow_missing {
                    files.push(None);
                } else {
                    return Err(IngestError::MissingScanline {
                        row: y,
                        expected: format!("expected file {}", file.display()),
                    });
                }
            }
            Ok(files_only(files, None))
        }
        InputSpec::Glob(pattern) => {
            let bad = |message: String| IngestError::BadGlob {
                pattern: pattern.clone(),
                message,
            };
            let mut matches: Vec<PathBuf> = glob::glob(pattern)
                .map_err(|e| bad(e.to_string()))?
                .filter_map(Result::ok)
                .filter(|p| p.is_file())
                .collect();
            if matches.is_empty() {
                return Err(IngestError::NoMatches {
                    pattern: pattern.clone(),
                });
            }
            matches.sort();
            let numbers: Option<Vec<u64>> = matches.iter().map(|p| file_number(p)).collect();
            let Some(numbers) = numbers else {
                return Ok(files_only(matches.into_iter().map(Some).collect(), None));
            };
            let first = *numbers.iter().min().expect("non-empty");
            let last = *numbers.iter().max().expect("non-empty");
            let ny = usize::try_from(last - first + 1).unwrap_or(usize::MAX);
            if ny > 16 * matches.len() + 1024 {
                return Err(bad(format!(
                    "file numbers run from {first} to {last} for only {} files",
                    matches.len()
                )));
            }
            let mut files: Vec<Option<PathBuf>> = vec![None; ny];
            for (p, n) in matches.iter().zip(&numbers) {
                let y = (n - first) as usize;
                if let Some(prev) = &files[y] {
                    return Err(IngestError::DuplicateNumber {
                        number: *n,
                        first: prev.clone(),
                        second: p.clone(),
                    });
                }
                files[y] = Some(p.clone());
            }
            if !options.allow_missing {
                if let Some(y) = files.iter().position(Option::is_none) {
                    let before = files[..y].iter().flatten().next_back();
                    return Err(IngestError::MissingScanline {
                        row: y,
                        expected: format!(
                            "no file numbered {} matches {pattern} (after {})",
                            first + y as u64,
                            before.map_or("-".into(), |p| p.display().to_string())
                        ),
                    });
                }
            }
            Ok(files_only(files, None))
        }
        InputSpec::File(path) => Ok(files_only(vec![Some(path.clone())], None)),
        InputSpec::Stack { path, dataset } => {
            let (shape, values) = crate::container::read_image_stack(path, dataset)?;
            if shape.contains(&0) {
                return Err(IngestError::StackShape {
                    path: path.clone(),
                    dataset: dataset.trim_start_matches('/').to_string(),
                    shape,
                    message: "every axis needs length > 0".into(),
                });
            }
            let (ny, a, b) = (shape[0], shape[1], shape[2]);
            let (nx, nt) = if options.transpose { (a, b) } else { (b, a) };
            let name = dataset.trim_start_matches('/').to_string();
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                let (y, rest) = (i / (a * b), i % (a * b));
                let (x, t) = if options.transpose {
                    (rest / b, rest % b)
                } else {
                    (rest % b, rest / b)
                };
                return Err(IngestError::NonFinite {
                    path: PathBuf::from(format!("{}:/{name} image {y}", path.display())),
                    x,
                    t,
                    value: values[i],
                });
            }
            Ok(Listed {
                source: RowSource::Stack {
                    path: path.clone(),
                    dataset: name,
                    values,
                },
                ny,
                manifest: None,
                stack_nx_nt: Some((nx, nt)),
                stack_pixel_type: PixelType::F32,
            })
        }
    }
}

/// The last run of digits in a file name, if any.
fn file_number(path: &Path) -> Option<u64> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    let bytes = name.as_bytes();
    let end = bytes.iter().rposition(u8::is_ascii_digit)? + 1;
    let start = bytes[..end]
        .iter()
        .rposition(|b| !b.is_ascii_digit())
        .map_or(0, |i| i + 1);
    name[start..end].parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn printf_patterns_parse_and_format() {
        let p = Printf::parse("a/scan_%04d.png").unwrap().unwrap();
        assert_eq!(p.format(7), "a/scan_0007.png");
        assert_eq!(p.format(12345), "a/scan_12345.png");
        let p = Printf::parse("s%d_100%%.exr").unwrap().unwrap();
        assert_eq!(p.format(3), "s3_100%.exr");
        let p = Printf::parse("s%3d.png").unwrap().unwrap();
        assert_eq!(p.format(3), "s  3.png");
        assert_eq!(Printf::parse("plain.png").unwrap(), None);
        assert!(Printf::parse("a%s.png").is_err());
        assert!(Printf::parse("a%d_%d.png").is_err());
    }

    #[test]
    fn inputs_are_classified() {
        assert_eq!(
            InputSpec::classify("x_%03d.png", Some(4), None).unwrap(),
            InputSpec::Printf {
                pattern: "x_%03d.png".into(),
                rows: 4
            }
        );
        assert!(matches!(
            InputSpec::classify("x_%03d.png", None, None),
            Err(IngestError::PrintfNeedsRows { .. })
        ));
        assert_eq!(
            InputSpec::classify("d/x_*.png", None, None).unwrap(),
            InputSpec::Glob("d/x_*.png".into())
        );
        assert_eq!(
            InputSpec::classify("cap/manifest.toml", None, None).unwrap(),
            InputSpec::Manifest("cap/manifest.toml".into())
        );
        assert!(matches!(
            InputSpec::classify("stack.h5", None, Some("images")).unwrap(),
            InputSpec::Stack { .. }
        ));
        assert!(matches!(
            InputSpec::classify("/no/such/thing.png", None, None),
            Err(IngestError::NoSuchInput { .. })
        ));
        // One scanline file; a file of another kind; a folder without a manifest.
        let dir = tempfile::tempdir().unwrap();
        let img = dir.path().join("Scan.IMG");
        std::fs::write(&img, b"").unwrap();
        assert_eq!(
            InputSpec::classify(img.to_str().unwrap(), None, None).unwrap(),
            InputSpec::File(img.clone())
        );
        let txt = dir.path().join("notes.txt");
        std::fs::write(&txt, b"").unwrap();
        assert!(matches!(
            InputSpec::classify(txt.to_str().unwrap(), None, None),
            Err(IngestError::NotAnInput { .. })
        ));
        for name in ["a.png", "b.png", "c.exr"] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        std::fs::create_dir(dir.path().join("sub.png")).unwrap();
        match InputSpec::classify(dir.path().to_str().unwrap(), None, None) {
            Err(IngestError::FolderWithoutManifest { found, .. }) => assert_eq!(
                found,
                [("png".into(), 2), ("exr".into(), 1), ("img".into(), 1)]
            ),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn file_numbers_are_the_last_digit_run() {
        assert_eq!(file_number(Path::new("run2/scan_0017.png")), Some(17));
        assert_eq!(file_number(Path::new("a7b_12x.png")), Some(12));
        assert_eq!(file_number(Path::new("scan.png")), None);
    }

    #[test]
    fn blocked_transpose_matches_the_plain_loop() {
        // Sizes with and without partial 8 x 8 blocks on either side.
        for (nx, nt) in [(1, 1), (8, 8), (19, 27), (16, 5), (3, 40), (672 / 8, 64)] {
            let raw: Vec<u16> = (0..nx * nt)
                .map(|i| ((i * 2_654_435_761usize) >> 9) as u16)
                .collect();
            let scale = 0.37f32;
            let mut expected = vec![0.0f32; nx * nt];
            for t in 0..nt {
                for x in 0..nx {
                    expected[x * nt + t] = f32::from(raw[t * nx + x]) * scale;
                }
            }
            let mut out = vec![f32::NAN; nx * nt];
            to_row_layout_u16(&raw, nx, nt, scale, &mut out);
            assert_eq!(out, expected, "u16 {nx} x {nt}");
            let as_f32: Vec<f32> = raw.iter().map(|&v| f32::from(v)).collect();
            let mut out = vec![f32::NAN; nx * nt];
            to_row_layout(&as_f32, nx, nt, scale, &mut out).unwrap();
            assert_eq!(out, expected, "f32 {nx} x {nt}");
        }
    }

    #[test]
    fn starts_become_edges_and_layout_is_transposed() {
        assert_eq!(edges_from_starts(&[0.0, 2.0, 5.0]), [0.0, 2.0, 5.0, 8.0]);
        // A 3 x 2 image [t][x]: rows t0 = (1, 2, 3), t1 = (4, 5, 6).
        let mut out = vec![0.0; 6];
        to_row_layout(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], 3, 2, 2.0, &mut out).unwrap();
        assert_eq!(out, [2.0, 8.0, 4.0, 10.0, 6.0, 12.0]);
        assert_eq!(
            to_row_layout(&[1.0, 2.0, f32::NAN, 4.0, 5.0, 6.0], 3, 2, 1.0, &mut out)
                .unwrap_err()
                .0,
            2
        );
    }

    #[test]
    fn sweep_tables_accept_csv_headers_and_comments() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sweep.csv");
        std::fs::write(
            &p,
            "edge_ps\n# calibration of 2013-07-01\n0.0\n1.5, 3.25\n4 5e0\n",
        )
        .unwrap();
        assert_eq!(read_sweep_table(&p).unwrap(), [0.0, 1.5, 3.25, 4.0, 5.0]);
        std::fs::write(&p, "0.0\n1.5\nx\n").unwrap();
        let e = read_sweep_table(&p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("'x'"), "{e}");
    }
}
