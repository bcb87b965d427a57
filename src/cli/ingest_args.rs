//! The flags of `femto ingest`: a streak capture's ([`IngestArgs`], mapped onto the
//! library's options by `cli/ingest.rs`) and other tools' and instruments' files
//! ([`InteropArgs`], mapped by `cli/ingest_interop.rs`). Both modules read these; neither
//! reads the other's.

use super::values;
use clap::{Args, ValueEnum};
use femto::container::CubeCompression;
use femto::ingest::plan::{PowerRef, SaturationInput};
use femto::readers::AxisRef;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct IngestArgs {
    /// The capture: a folder with manifest.toml, a manifest, a glob ('scan_*.png', quoted),
    /// a printf pattern (scan_%04d.png, with --rows), an HDF5 file (with --dataset), or one
    /// scanline file (.png, .tif, .tiff, .exr, .hdr, .img: a capture of one scanline); or
    /// another tool's file: a y-tal capture (.hdf5) or a mitransient array (.npy).
    pub input: String,
    /// The cube to write (HDF5, camera time).
    #[arg(long, short = 'o', required_unless_present = "decode_only")]
    pub out: Option<PathBuf>,
    /// Replace --out if it exists (without it, an existing --out is refused).
    #[arg(long)]
    pub force: bool,
    /// Number of scanlines of a printf pattern (rows 0..N).
    #[arg(long)]
    pub rows: Option<usize>,
    /// Dataset of an HDF5 input holding the streak images, shape (ny, nt, nx), or
    /// (ny, nx, nt) with --transpose.
    #[arg(long)]
    pub dataset: Option<String>,
    /// Width of a time bin, ps, for files that record no time axis. A value that contradicts
    /// the manifest's axis or an .img time table is refused, unless --resample-time.
    #[arg(long)]
    pub dt_ps: Option<f64>,
    /// Camera time of the start of the first bin, ps (likewise; 0 when only --dt-ps is given
    /// for an .img file whose rows are not calibrated).
    #[arg(long, allow_hyphen_values = true)]
    pub t0_ps: Option<f64>,
    /// Resample the recorded rows onto the axis --dt-ps/--t0-ps ask for where it contradicts
    /// the capture's own (manifest, .img time table), conserving each pixel's integral; the
    /// cube gets as many bins as cover every recorded row (at most 16 per recorded row).
    #[arg(long)]
    pub resample_time: bool,
    /// Laser wavelength, nm, stored as the cube's laser_nm attribute (femto render's
    /// colours). A manifest's [capture] laser_wavelength_nm is used without it; a value that
    /// contradicts it is refused.
    #[arg(long, allow_hyphen_values = true)]
    pub laser_nm: Option<f64>,
    /// The files store time across and x down.
    #[arg(long)]
    pub transpose: bool,
    /// Dark signal to subtract: a constant (in value units) or a dark-frame image file.
    #[arg(long, allow_hyphen_values = true)]
    pub dark: Option<String>,
    /// Flat-field gains: an image nx wide, one row per scanline or a single row.
    #[arg(long)]
    pub flat: Option<PathBuf>,
    /// Sweep calibration: text/CSV of nt+1 true bin-edge times, ps.
    #[arg(long)]
    pub sweep_table: Option<PathBuf>,
    /// Leave out the corrections a capture's manifest records and ingest applies by default:
    /// its dark frame and flat field ([files] dark, flat) and its sweep bin times
    /// ([imperfections.sweep]). --dark, --flat or --sweep-table replace one of them.
    #[arg(long)]
    pub no_manifest_corrections: bool,
    /// Estimate and remove per-scanline trigger jitter (the default: every scanline is a
    /// separate sweep with its own trigger). A shift is applied only where it exceeds 4
    /// standard errors. Measured on a simulated realistic capture (cube scene, 320 x 240,
    /// 64 paths per pixel, 2 ps rms jitter): 1.2 ps rms left, 4.7 ps at most (20 of 240
    /// scanlines more than 2 ps off, 11 made worse by more than 1 ps), of which the
    /// row-to-row part 0.6 ps rms, 3.9 ps at most; the slow part of the jitter (runs of
    /// scanlines late together) cannot be told from the scene's tilt here, and stays until
    /// `femto calibrate` measures each scanline against the geometry and `femto unwarp`
    /// removes that too (with both: 0.19 ps rms, 0.76 ps at most, none made worse).
    /// Costs a second pass over the scanlines.
    #[arg(long, overrides_with = "no_jitter")]
    pub jitter: bool,
    /// Keep the scanlines' trigger jitter (one pass; for captures without jitter).
    #[arg(long)]
    pub no_jitter: bool,
    /// Laser power normalisation: a reference region x0:x1,t0:t1 (recorded bins, half-open)
    /// that sees a fixed part of the scene in every scanline, or 'auto' (each pixel's
    /// pulse integral against the same pixel in the neighbouring scanlines; a gain is applied only
    /// where it exceeds 4 standard errors: on the simulated realistic capture above, 3 %
    /// power, it removes about a quarter of the scanline-to-scanline error).
    #[arg(long, value_parser = values::power_ref)]
    pub power_ref: Option<PowerRef>,
    /// Mask saturated pixels: a level (value units) or 'auto' (the sample type's maximum).
    #[arg(long, value_parser = values::saturation)]
    pub saturation: Option<SaturationInput>,
    /// Fill missing scanlines by interpolation (masked) instead of failing.
    #[arg(long)]
    pub allow_missing: bool,
    /// Signal value of one stored count (default: the manifest's png_value_per_count for
    /// PNG scanlines, else 1).
    #[arg(long)]
    pub value_scale: Option<f64>,
    /// Compression of the cube: shuffle + deflate at a level 0-9, or 'none'. The default, 1,
    /// is the fastest level: real Hamamatsu streak data shrinks 2.1x (a signal capture) to
    /// 3.5x (a focus frame), the simulated benchmark 3.0x. Level 4 (femto's other writers,
    /// h5py's gzip default) is about 8 % smaller for about 1.5x the CPU time. 'none' is
    /// fastest, about 1.7x the time of decoding the images alone, for 2-3.5x the bytes (see
    /// docs/ingest.md).
    #[arg(long, value_parser = values::compression)]
    pub compression: Option<CubeCompression>,
    /// Another tool's file (y-tal, mitransient): see `ingest_interop`'s module.
    #[command(flatten)]
    pub interop: InteropArgs,
    /// Only decode the scanlines (benchmark baseline); writes nothing.
    #[arg(long, hide = true)]
    pub decode_only: bool,
}

/// Another tool's file as input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Foreign {
    /// A y-tal capture (tal.io.write_capture, tal render): H (T, Sx, Sy), delta_t, t_start.
    Tal,
    /// A mitransient transient array (H, W, T, C) saved with np.save.
    Mitransient,
    /// An assembled x-y-t array: .npy, .mat (v5, v7.3), .hspy, or an HDF5 dataset
    /// (A[i, j, k] is row i, column j, bin k).
    Array,
}

/// How colour channels become one value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ChannelsArg {
    Mean,
    R,
    G,
    B,
    /// Rec. 709 luminance of linear RGB.
    Luminance,
}

/// The clock of a mitransient render.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OplClock {
    /// Path length from the emitter to the sensor (mitransient's default).
    Camera,
    /// Rendered with camera_unwarp = true: path length from the emitter to the surface point.
    World,
}

#[derive(Args, Debug)]
pub struct InteropArgs {
    /// Read INPUT as another tool's file (detected without it: an HDF5 file with y-tal's H
    /// and H_format, or a .npy file).
    #[arg(long, value_enum)]
    pub from: Option<Foreign>,
    /// mitransient: the film's start_opl, metres of optical path (t0 = start_opl / c).
    #[arg(long, allow_hyphen_values = true)]
    pub start_opl_m: Option<f64>,
    /// mitransient: the film's bin_width_opl, metres of optical path (dt = bin_width_opl / c).
    #[arg(long)]
    pub bin_width_opl_m: Option<f64>,
    /// mitransient: how the colour channels become the cube's value [default: mean].
    #[arg(long, value_enum)]
    pub channels: Option<ChannelsArg>,
    /// mitransient: the render's clock [default: camera].
    #[arg(long, value_enum)]
    pub opl_clock: Option<OplClock>,
    /// Array files: a confocal capture (each pixel's laser point is its own wall point);
    /// needs --wall-size-m.
    #[arg(long)]
    pub confocal: bool,
    /// Array files with --confocal: the full side of the scanned square wall patch, metres.
    #[arg(long)]
    pub wall_size_m: Option<f64>,
    /// Array files with --confocal: where the laser and detector are, X,Y,Z metres, the wall
    /// being the plane z = 0 centred on the origin (needed to unwarp a camera-time cube).
    #[arg(long, value_parser = super::values::point, allow_hyphen_values = true)]
    pub device_m: Option<[f64; 3]>,
    /// Array files: the clock of the file's time: camera (what the detector recorded) or
    /// world (it starts at each pixel's own point, as in most public confocal NLOS data,
    /// whose time zero is at the wall) [default: camera].
    #[arg(long, value_enum)]
    pub clock: Option<super::values::Clock>,
    /// Array files: which axis of the stored array is time, N indexing the shape `femto info`
    /// prints (MATLAB's order for .mat). Without it, the file's own axis names decide, else
    /// the last axis when no other is twice as long or more (else ingest asks for this flag).
    #[arg(long, value_name = "N")]
    pub time_axis: Option<usize>,
    /// Array, Delmic and PTU files: keep one index of an extra axis (channels, wavelengths,
    /// frames, z) instead of summing it: AXIS=I, AXIS a name `femto info` prints (frame,
    /// channel, C, Z) or an axis number. Repeatable.
    #[arg(long, value_name = "AXIS=I", value_parser = super::values::axis_index)]
    pub select: Vec<(AxisRef, usize)>,
    /// Array files: sum an extra axis of an unnamed array with more than three (AXIS a number
    /// or name). Axes a file names as extra are summed without it. Repeatable.
    #[arg(long, value_name = "AXIS", value_parser = super::values::axis_ref)]
    pub sum: Vec<AxisRef>,
}
