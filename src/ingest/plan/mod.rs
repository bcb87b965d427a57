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

//!
//! Layout: [`input`] (what the user named), [`options`] (the options and the check of their
//! numbers), `rows` (the scanlines listed, the reference one, the value scale), `axis` (the
//! time axis and its source), `laser`, `corrections` (dark, flat, power, saturation and the
//! manifest's corrections) and [`layout`] (samples into the row layout); [`IngestPlan::resolve`]
//! composes their decisions in this order.

mod axis;
mod corrections;
pub mod input;
mod laser;
pub mod layout;
pub mod options;
mod rows;

use std::path::PathBuf;

use crate::cube::TimeAxis;
use crate::formats::PixelType;
use crate::ingest::row_offsets::{RowOffsetFit, RowTruth};
use crate::ingest::time_axis::edges_are_uniform;
use crate::ingest::IngestError;
use crate::limits::check_memory;

pub use self::axis::{read_sweep_table, AxisSource};
pub use self::corrections::{
    DarkCorrection, FlatCorrection, PowerCorrection, SaturationCorrection, SaturationSource,
    SweepCorrection,
};
pub use self::input::{streak_files_by_extension, InputSpec};
pub use self::laser::{LaserSource, LaserWavelength};
pub use self::layout::{stack_image, to_row_layout, to_row_layout_u16};
pub use self::options::{DarkInput, IngestOptions, PowerRef, SaturationInput};
pub use self::rows::RowSource;
pub use crate::ingest::time_axis::edges_from_starts;

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
    /// The true jitter and laser power a simulated capture's manifest records (to report the
    /// corrections' residual against).
    pub truth: RowTruth,
}

impl IngestPlan {
    /// Resolve `input` with `options`: list the scanlines, read the first one (size, sample
    /// type, time table), read the dark frame, flat field and sweep table, and check that
    /// every part fits the others. The scanlines themselves are read by
    /// [`crate::ingest::assemble`]. Each decision is a function of its own, taken in this
    /// order (which is the order of the errors a bad input meets).
    pub fn resolve(input: &InputSpec, options: &IngestOptions) -> Result<IngestPlan, IngestError> {
        options.check_values()?;
        let describe = input.describe();
        let listed = rows::list_rows(input, options)?;
        let in_manifest = match &listed.manifest {
            Some((m, path)) if !options.ignore_manifest_corrections => {
                corrections::ManifestCorrections::of(m, path)
            }
            _ => corrections::ManifestCorrections::default(),
        };
        let missing = listed.missing(&describe)?;
        let (probe, reference) = listed.reference(options.transpose)?;
        let (nx, ny, nt) = (probe.nx, listed.ny, probe.nt);
        let value_scale = listed.value_scale(options.value_scale, probe.pixel_type);

        let axis_source = AxisSource::of(listed.manifest.as_ref(), &probe, &reference)?;
        let sweep_edges = axis::sweep_edges(options.sweep_table.as_deref(), in_manifest.sweep, nt)?;
        let time = axis::decide(&axis_source, sweep_edges, options, nt, &describe)?;
        let laser = laser::laser(listed.manifest.as_ref(), options.laser_nm)?;

        let capture = corrections::Capture {
            reference: &reference,
            nx,
            ny,
            nt,
            pixel_type: probe.pixel_type,
            value_scale,
            transpose: options.transpose,
        };
        let dark_input = options.dark.as_ref().or(in_manifest.dark.as_ref());
        let dark = corrections::dark(dark_input, &capture)?;
        let flat_input = options.flat.as_deref().or(in_manifest.flat.as_deref());
        let flat = corrections::flat(flat_input, &capture)?;
        let power = corrections::power(options.power_ref, &capture)?;
        let saturation = corrections::saturation(options.saturation, &capture)?;

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
            img_time_table_ps: time.img_time_table_ps,
            out_axis: time.out_axis,
            axis_source: time.description,
            laser,
            dark,
            flat,
            power,
            sweep: time.sweep,
            jitter: options.jitter.then(RowOffsetFit::default),
            saturation,
            missing,
            truth: listed
                .manifest
                .as_ref()
                .map(|(m, _)| RowTruth {
                    jitter_shifts_ps: m.imperfections.jitter.as_ref().map(|j| j.shifts_ps.clone()),
                    power_factors: m.imperfections.power.as_ref().map(|p| p.factors.clone()),
                })
                .unwrap_or_default(),
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

    /// Peak memory of [`crate::ingest::assemble::ingest`] for this plan, bytes: the per-pixel maps,
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
            let what = if edges_are_uniform(&s.edges_ps) {
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

/// A valid manifest of one scanline, `nx` x `nt`, 2 ps bins from -1 ps, 800 nm, no value
/// per count, nothing recorded in `[files]` or `[imperfections]` (for the decisions' tests).
#[cfg(test)]
fn test_manifest(nx: usize, nt: usize) -> crate::manifest::Manifest {
    let text = format!(
        "[capture]\nscene = \"box\"\nnx = {nx}\nny = 1\nnt = {nt}\ndt_ps = 2.0\n\
         t0_ps = -1.0\neta = 1.0\nlaser_wavelength_nm = 800.0\npulse_width_fs = 100.0\n\
         formats = [\"exr\"]\n\n[[scanline]]\nindex = 0\n\
         file = \"scanlines/scanline_0000.exr\"\n"
    );
    crate::manifest::Manifest::from_toml(&text, std::path::Path::new("test.toml"))
        .expect("a valid manifest")
}
