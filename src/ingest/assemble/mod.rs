//! Streaming assembly of a capture into the HDF5 cube, scanline by scanline.
//!
//! Each scanline `y` is a streak image `[t][x]` (recorded rows); it becomes row `y` of the cube,
//! layout `[x][t]` on the uniform camera-time axis of the plan (`docs/cube-format.md`). The
//! corrections of [`super::corrections`] are applied in the reverse order of the flaws of a
//! streak capture (the simulator applies: sweep non-linearity, trigger jitter, laser power,
//! vignetting, photon noise, dark signal, saturation, quantisation):
//!
//! 1. saturation mask, on the raw (scaled) values: a pixel with any bin at the level is
//!    masked (its values are kept);
//! 2. dark subtraction (a level or a frame);
//! 3. flat-field division (a pixel whose gain is not positive is zeroed and masked);
//! 4. laser power normalisation: the row's reference region (recorded bins) is integrated,
//!    and the row multiplied by `median / own` over all rows; or, with no reference in view
//!    (`auto`), the log of each pixel's integral is compared with the same pixel in the
//!    neighbouring rows ([`super::row_offsets`]) and the row multiplied by `exp(-offset)` (a
//!    row that cannot be normalised is masked);
//! 5. sweep-linearity resampling from the recorded bin edges onto the uniform axis,
//!    conserving each pixel's integral;
//! 6. jitter removal: each pixel's pulse time (after 1-5) is predicted from the same pixel
//!    in the neighbouring rows, the rows' offsets are solved for ([`super::row_offsets`]),
//!    and each row is shifted back by its offset.
//!
//! A gain commutes with the resampling, so step 4's factor is measured before step 5 (in the
//! recorded bins the reference region is given in) and applied after it.
//!
//! Streaming. Rows are decoded, corrected and compressed on worker threads, at most
//! `2 x threads + 2` rows in flight, and written in order by the calling thread through
//! [`CubeWriter`] (so writing overlaps the decoding of the next rows), so the memory in use
//! is a few rows per thread whatever the number of scanlines (plus the `ny x nx` byte mask).
//! Row buffers go back to a pool once written and decoding reuses a per-thread sample
//! buffer, so streaming allocates a few rows, not one per scanline; a 16-bit PNG is scaled
//! and transposed into the row in one pass; an uncompressed row goes to the file from its
//! own buffer. Steps 4 and 6 need every row before any row can
//! be finished (the median power, the neighbouring rows). For those, ingest makes two passes
//! and keeps the rows on disk, not in memory: pass 1 decodes and applies steps 1-3 and 5,
//! records each row's power factor or each pixel's integral and pulse time (`ny x nx`
//! values, like the mask), and writes the row (f32, uncompressed) to an
//! anonymous scratch file beside the output (deleted when the ingest ends, whatever the
//! outcome); pass 2 reads the rows back, applies the gains and shifts and writes the cube.
//! Re-reading the scratch file costs far less than decoding the images twice; the price is
//! free disk space for one uncompressed copy of the cube.
//!
//! Missing scanlines (only with `allow_missing`, see [`super::plan`]) are filled by linear
//! interpolation between the nearest present rows above and below (a copy of the one
//! neighbour at either end of the capture), after all corrections, and masked.
//!
//! On any error the output is not created: the writer's temporary file and the scratch file
//! are deleted, and an earlier file at the output path is left untouched.

mod provenance;
mod row;
mod stream;

use std::path::{Path, PathBuf};

use super::corrections::power_gains;
use super::plan::{DarkCorrection, IngestPlan, PowerCorrection, RowSource};
use super::row_offsets::{
    estimate_row_offsets, jitter_report, power_report, OffsetReport, RowOffset,
};
use super::IngestError;
use crate::container::{CubeCompression, CubeWriter, Provenance};
use crate::cube::TimeFrame;
use provenance::notes;
pub use provenance::{rms, JITTER_SHIFTS_NOTE, TRUE_JITTER_NOTE};
use row::{decode_file, file_size, final_row, load_row, prepare, Context, Decoded, Finished};
use row::{Prepared, SAMPLES};
use stream::{ordered_pipeline, RowPool, Scratch};

/// Which pass a progress report is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// First pass of a two-pass ingest: measuring power factors and arrival fronts.
    Scan,
    /// The pass that writes the cube.
    Write,
}

/// What an ingest did.
#[derive(Clone, Debug, PartialEq)]
pub struct IngestSummary {
    /// Scanlines in the cube (present and filled).
    pub rows: usize,
    /// Pixels per row and bins of the output axis.
    pub nx: usize,
    pub nt: usize,
    /// Scanlines that were missing, filled by interpolation and masked.
    pub missing_rows: Vec<usize>,
    /// Bytes of the input files read (each file counted once).
    pub bytes_read: u64,
    /// Bytes of compressed cube data written.
    pub stored_bytes: u64,
    /// Pixels masked as saturated.
    pub saturated_pixels: usize,
    /// Pixels masked for any reason (saturation, flat gain, power, missing row).
    pub masked_pixels: usize,
    /// Estimated trigger delay of each scanline, ps (positive = recorded late), when jitter
    /// removal was on; the shifts removed.
    pub jitter_shifts_ps: Option<Vec<f64>>,
    /// Laser power gain of each scanline, when power normalisation was on (`None` for rows
    /// that could not be normalised).
    pub power_gains: Option<Vec<Option<f64>>>,
    /// Each scanline's jitter estimate (ps) with its standard error, when jitter removal was
    /// on (`None`: not estimated), and the report of it.
    pub jitter: Option<(Vec<Option<RowOffset>>, OffsetReport)>,
    /// The same for automatic laser power normalisation (log gains).
    pub power: Option<(Vec<Option<RowOffset>>, OffsetReport)>,
    /// Passes over the scanlines (1, or 2 with power normalisation or jitter removal).
    pub passes: usize,
    /// The corrections applied, in order, with their parameters.
    pub corrections: Vec<String>,
}

/// What decoding alone did (the baseline of the ingest benchmark).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodeSummary {
    pub rows: usize,
    /// Bytes of the input files read.
    pub bytes_read: u64,
    /// Samples decoded.
    pub values: u64,
}

/// Every file of the capture of `plan`: the scanlines or the stack, the dark frame, the flat
/// field, the reference, and for a capture with a manifest the manifest and every file it
/// names (geometry, calibration, fiducials, truths), read by ingest or not.
pub fn input_files(plan: &IngestPlan) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = match &plan.source {
        RowSource::Files(rows) => rows.iter().flatten().cloned().collect(),
        RowSource::Stack { path, .. } => vec![path.clone()],
    };
    if let Some(DarkCorrection::Frame { path, .. }) = &plan.dark {
        files.push(path.clone());
    }
    if let Some(flat) = &plan.flat {
        files.push(flat.path.clone());
    }
    files.push(plan.reference.clone());
    let input = Path::new(&plan.input);
    let manifest = if input.is_dir() {
        input.join("manifest.toml")
    } else {
        input.to_path_buf()
    };
    if let Ok(m) = crate::manifest::Manifest::load(&manifest) {
        let dir = manifest.parent().unwrap_or(Path::new("."));
        let f = &m.files;
        for name in [
            &f.geometry,
            &f.calibration,
            &f.fiducials,
            &f.truth_camera,
            &f.truth_world,
            &f.truth_direct,
            &f.flat,
            &f.dark,
        ]
        .into_iter()
        .flatten()
        {
            files.push(dir.join(name));
        }
        files.push(manifest);
    }
    files
}

/// Refuse an output that is (or whose folder holds) a file of the capture, before anything
/// is written.
fn refuse_output_over_inputs(plan: &IngestPlan, out: &Path) -> Result<(), IngestError> {
    match input_files(plan)
        .into_iter()
        .find(|input| crate::atomic::output_holds(out, input))
    {
        Some(input) => Err(IngestError::OutputIsInput {
            out: out.to_path_buf(),
            input,
        }),
        None => Ok(()),
    }
}

/// Assemble the capture of `plan` into the cube file `out` (camera time), streaming.
///
/// `provenance` gives the command line and any notes of the caller; the plan's inputs and
/// corrections, and the jitter and power estimates, are added as `ingest.*` notes.
/// `compression` is the storage of `/cube` (`docs/cube-format.md`; the command line's
/// default is deflate level 1, see `docs/ingest.md`). `progress` is called on the calling thread with the pass and the
/// rows done in it.
pub fn ingest(
    plan: &IngestPlan,
    out: &Path,
    provenance: &Provenance,
    compression: CubeCompression,
    progress: &dyn Fn(Pass, usize),
) -> Result<IngestSummary, IngestError> {
    refuse_output_over_inputs(plan, out)?;
    let (nx, ny) = (plan.nx, plan.ny);
    let out_dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // Pass 1 (when needed): steps 1-3 and 5, power factors and fronts, rows to scratch.
    let (scratch, globals, pass1_mask, mut bytes_read, mut saturated_pixels) =
        if plan.needs_two_passes() {
            let FirstPass {
                scratch,
                globals,
                mask,
                bytes_read,
                saturated_pixels,
            } = first_pass(plan, &out_dir, progress)?;
            (
                Some(scratch),
                globals,
                Some(mask),
                bytes_read,
                saturated_pixels,
            )
        } else {
            (None, Globals::default(), None, 0u64, 0usize)
        };

    // The output, created now that every provenance note is known.
    let mut prov = provenance.clone();
    prov.notes.extend(notes(plan, &globals));
    prov.notes.push((
        "ingest.compression".into(),
        match compression {
            CubeCompression::Deflate(level) => format!("shuffle + deflate level {level}"),
            CubeCompression::None => "none".into(),
        },
    ));
    let mut writer = CubeWriter::create_with(
        out,
        nx,
        ny,
        plan.out_axis,
        TimeFrame::Camera,
        crate::container::DEFAULT_UNITS,
        &prov,
        compression,
    )?;
    let compressor = writer.row_compressor();
    let ctx = Context {
        plan,
        globals: &globals,
        scratch: scratch.as_ref(),
        pass1_mask: pass1_mask.as_deref(),
        pool: RowPool::new(nx * plan.nt_recorded),
    };
    let mut stored_bytes = 0u64;
    let mut final_mask = vec![1u8; ny * nx];
    let work = |y: usize| -> Result<(crate::container::CompressedRow, Finished), IngestError> {
        let mut f = final_row(&ctx, y)?;
        let row = std::mem::take(&mut f.row);
        Ok((compressor.compress_owned(row), f))
    };
    ordered_pipeline(ny, &work, &mut |y, (compressed, f)| {
        writer.write_compressed_row(y, &compressed)?;
        stored_bytes += compressed.stored_bytes() as u64;
        ctx.pool.give(compressed.into_buffer());
        final_mask[y * nx..(y + 1) * nx].copy_from_slice(&f.mask);
        if ctx.scratch.is_none() {
            bytes_read += f.bytes;
            saturated_pixels += f.saturated;
        }
        progress(Pass::Write, y + 1);
        Ok(())
    })?;
    if writes_mask(plan) {
        writer.write_mask(&final_mask)?;
    }
    writer.finish()?;
    drop(scratch);

    Ok(IngestSummary {
        rows: ny,
        nx,
        nt: plan.out_axis.nt,
        missing_rows: plan.missing.clone(),
        bytes_read,
        stored_bytes,
        saturated_pixels,
        masked_pixels: final_mask.iter().filter(|&&m| m == 0).count(),
        jitter_shifts_ps: globals.shifts_ps.clone(),
        power_gains: globals.gains.clone(),
        jitter: globals.jitter_report(plan),
        power: globals.power_report(plan),
        passes: if plan.needs_two_passes() { 2 } else { 1 },
        corrections: plan.corrections(),
    })
}

/// What the first pass of a two-pass ingest leaves for the second.
struct FirstPass {
    /// The rows after steps 1-3 and 5, on disk.
    scratch: Scratch,
    /// Power gains and jitter shifts.
    globals: Globals,
    /// Pixels masked so far (`ny x nx`).
    mask: Vec<u8>,
    bytes_read: u64,
    saturated_pixels: usize,
}

/// Pass 1 of a two-pass ingest: steps 1-3 and 5 on every scanline, the power factors and
/// pulse fronts measured, the rows to a scratch file in `out_dir`; then the power gains and
/// the jitter shifts solved for.
fn first_pass(
    plan: &IngestPlan,
    out_dir: &Path,
    progress: &dyn Fn(Pass, usize),
) -> Result<FirstPass, IngestError> {
    let (nx, ny) = (plan.nx, plan.ny);
    let mut mask = vec![1u8; ny * nx];
    let mut bytes_read = 0u64;
    let mut saturated_pixels = 0usize;
    let mut globals = Globals::default();
    let scratch = Scratch::create(out_dir, nx * plan.out_axis.nt)?;
    let mut factors = vec![f64::NAN; ny];
    // Per-pixel measurements for the row offsets (`ny x nx`; only when asked for).
    let mut edges: Vec<Option<f64>> = Vec::new();
    let mut log_integrals: Vec<Option<f64>> = Vec::new();
    if plan.jitter.is_some() {
        edges = vec![None; ny * nx];
    }
    if matches!(plan.power, Some(PowerCorrection::Auto(_))) {
        log_integrals = vec![None; ny * nx];
    }
    let pool = RowPool::new(nx * plan.nt_recorded);
    let work = |y: usize| -> Result<Option<Prepared>, IngestError> {
        Ok(load_row(plan, y, &pool)?.map(|raw| prepare(plan, y, raw)))
    };
    ordered_pipeline(ny, &work, &mut |y, prepared| {
        if let Some(p) = prepared {
            scratch.write_row(y, &p.row)?;
            pool.give(p.row);
            mask[y * nx..(y + 1) * nx].copy_from_slice(&p.mask);
            factors[y] = p.power_factor.unwrap_or(f64::NAN);
            if let Some(e) = &p.edges_ps {
                edges[y * nx..(y + 1) * nx].copy_from_slice(e);
            }
            if let Some(l) = &p.log_integrals {
                log_integrals[y * nx..(y + 1) * nx].copy_from_slice(l);
            }
            bytes_read += p.bytes;
            saturated_pixels += p.saturated;
        }
        progress(Pass::Scan, y + 1);
        Ok(())
    })?;
    match &plan.power {
        Some(PowerCorrection::Region(_)) => globals.gains = Some(power_gains(&factors)),
        Some(PowerCorrection::Auto(fit)) => {
            let offsets = estimate_row_offsets(&log_integrals, nx, fit);
            // A row whose log gain could not be estimated is masked (gain `None`).
            globals.gains = Some(
                offsets
                    .iter()
                    .map(|o| o.map(|o| (-o.applied).exp()))
                    .collect(),
            );
            globals.power_offsets = Some(offsets);
        }
        None => {}
    }
    if let Some(fit) = &plan.jitter {
        let offsets = estimate_row_offsets(&edges, nx, fit);
        globals.shifts_ps = Some(
            offsets
                .iter()
                .map(|o| o.map_or(0.0, |o| o.applied))
                .collect(),
        );
        globals.jitter_offsets = Some(offsets);
    }
    Ok(FirstPass {
        scratch,
        globals,
        mask,
        bytes_read,
        saturated_pixels,
    })
}

/// Decode every scanline file of `plan` and nothing else (no corrections, no output), with
/// the same decoder (16-bit grey PNG into integer samples, other files through
/// [`read_streak`](crate::formats::read_streak)) and the same parallel, bounded streaming as [`ingest`]: the baseline of
/// the benchmark.
pub fn decode_only(
    plan: &IngestPlan,
    progress: &dyn Fn(usize),
) -> Result<DecodeSummary, IngestError> {
    let RowSource::Files(files) = &plan.source else {
        return Ok(DecodeSummary {
            rows: plan.ny,
            bytes_read: 0,
            values: (plan.ny * plan.nx * plan.nt_recorded) as u64,
        });
    };
    let mut summary = DecodeSummary {
        rows: plan.ny,
        bytes_read: 0,
        values: 0,
    };
    let work = |y: usize| -> Result<(u64, u64), IngestError> {
        match &files[y] {
            Some(path) => SAMPLES.with_borrow_mut(|samples| {
                let values = match decode_file(path, plan.transpose, samples)? {
                    Decoded::Grey16 { nx, nt } => nx * nt,
                    Decoded::Image(img) => img.data.len(),
                };
                Ok((file_size(path), values as u64))
            }),
            None => Ok((0, 0)),
        }
    };
    ordered_pipeline(plan.ny, &work, &mut |y, (bytes, values)| {
        summary.bytes_read += bytes;
        summary.values += values;
        progress(y + 1);
        Ok(())
    })?;
    Ok(summary)
}

/// Whether the cube gets a `/mask`: when a correction that can mask pixels is on.
fn writes_mask(plan: &IngestPlan) -> bool {
    plan.saturation.is_some()
        || plan.flat.is_some()
        || plan.power.is_some()
        || !plan.missing.is_empty()
}

/// Results of the first pass that the second needs.
#[derive(Clone, Debug, Default)]
pub(super) struct Globals {
    /// Laser power gain of each scanline (power normalisation).
    pub(super) gains: Option<Vec<Option<f64>>>,
    /// Trigger delay of each scanline, ps (jitter removal).
    pub(super) shifts_ps: Option<Vec<f64>>,
    /// The jitter estimates behind `shifts_ps` (`None`: a scanline not estimated).
    pub(super) jitter_offsets: Option<Vec<Option<RowOffset>>>,
    /// The log power estimates behind `gains` (`--power-ref auto`).
    pub(super) power_offsets: Option<Vec<Option<RowOffset>>>,
}

impl Globals {
    /// The jitter estimates and their report.
    pub(super) fn jitter_report(
        &self,
        plan: &IngestPlan,
    ) -> Option<(Vec<Option<RowOffset>>, OffsetReport)> {
        let o = self.jitter_offsets.as_ref()?;
        Some((
            o.clone(),
            jitter_report(o, plan.truth.jitter_shifts_ps.as_deref()),
        ))
    }

    /// The automatic power estimates and their report.
    pub(super) fn power_report(
        &self,
        plan: &IngestPlan,
    ) -> Option<(Vec<Option<RowOffset>>, OffsetReport)> {
        let o = self.power_offsets.as_ref()?;
        Some((
            o.clone(),
            power_report(o, plan.truth.power_factors.as_deref()),
        ))
    }
}
