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

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Condvar, Mutex};

use super::corrections::{
    apply_gain, check_sample_type, divide_flat, power_factor, power_gains, remove_shift,
    resample_sweep, saturation_mask, subtract_dark, Dark,
};
use super::plan::{
    stack_image, to_row_layout, to_row_layout_u16, DarkCorrection, IngestPlan, PowerCorrection,
    RowSource,
};
use super::row_offsets::{estimate_row_offsets, pixel_log_integrals, pixel_pulse_times};
use super::IngestError;
use crate::container::{CubeCompression, CubeWriter, Provenance};
use crate::cube::TimeFrame;
use crate::formats::raster::read_png_grey16_into;
use crate::formats::{read_streak, PixelType, StreakImage};

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
        .find(|input| crate::pipeline::output_holds(out, input))
    {
        Some(input) => Err(IngestError::OutputIsInput {
            out: out.to_path_buf(),
            input,
        }),
        None => Ok(()),
    }
}

/// Rows in flight per worker thread (decoded or being written).
const ROWS_IN_FLIGHT_PER_THREAD: usize = 2;

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
    let mut mask = vec![1u8; ny * nx];
    let mut bytes_read = 0u64;
    let mut saturated_pixels = 0usize;
    let out_dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };

    // Pass 1 (when needed): steps 1-3 and 5, power factors and fronts, rows to scratch.
    let mut globals = Globals::default();
    let scratch = if plan.needs_two_passes() {
        let scratch = Scratch::create(&out_dir, nx * plan.out_axis.nt)?;
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
                globals.gains = Some(offsets.iter().map(|o| o.map(|o| (-o).exp())).collect());
            }
            None => {}
        }
        if let Some(fit) = &plan.jitter {
            let offsets = estimate_row_offsets(&edges, nx, fit);
            globals.shifts_ps = Some(offsets.iter().map(|o| o.unwrap_or(0.0)).collect());
        }
        Some(scratch)
    } else {
        None
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
        pass1_mask: scratch.is_some().then_some(&mask[..]),
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
        passes: if plan.needs_two_passes() { 2 } else { 1 },
        corrections: plan.corrections(),
    })
}

/// Decode every scanline file of `plan` and nothing else (no corrections, no output), with
/// the same decoder (16-bit grey PNG into integer samples, other files through
/// [`read_streak`]) and the same parallel, bounded streaming as [`ingest`]: the baseline of
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
struct Globals {
    gains: Option<Vec<Option<f64>>>,
    shifts_ps: Option<Vec<f64>>,
}

/// The provenance notes of an ingest.
fn notes(plan: &IngestPlan, globals: &Globals) -> Vec<(String, String)> {
    let json = |v: serde_json::Value| v.to_string();
    let mut n = vec![
        ("ingest.input".to_string(), plan.input.clone()),
        (
            "ingest.source_files".to_string(),
            json(serde_json::json!(plan.source_files())),
        ),
        ("ingest.time_axis".to_string(), plan.axis_source.clone()),
        (
            "ingest.recorded_size".to_string(),
            format!(
                "{} x {} (x by t), {:?} samples",
                plan.nx, plan.nt_recorded, plan.pixel_type
            ),
        ),
        (
            "ingest.value_scale".to_string(),
            plan.value_scale.to_string(),
        ),
        (
            "ingest.corrections".to_string(),
            json(serde_json::json!(plan.corrections())),
        ),
    ];
    if let Some(laser) = &plan.laser {
        // The number alone, as `femto render` and `femto unwarp` read it.
        n.push(("laser_nm".to_string(), laser.nm.to_string()));
        n.push(("ingest.laser_nm".to_string(), laser.source.clone()));
    }
    if let RowSource::Stack { path, dataset, .. } = &plan.source {
        n.push((
            "ingest.stack".to_string(),
            format!("{}:/{dataset}", path.display()),
        ));
    }
    if plan.transpose {
        n.push(("ingest.transpose".to_string(), "true".to_string()));
    }
    match &plan.dark {
        Some(DarkCorrection::Level(v)) => n.push(("ingest.dark".into(), format!("level {v}"))),
        Some(DarkCorrection::Frame { path, .. }) => {
            n.push(("ingest.dark".into(), format!("frame {}", path.display())))
        }
        None => {}
    }
    if let Some(f) = &plan.flat {
        n.push(("ingest.flat".into(), f.path.display().to_string()));
    }
    match &plan.power {
        Some(PowerCorrection::Region(r)) => n.push((
            "ingest.power_ref".into(),
            format!("x {}..{}, bins {}..{}", r.x0, r.x1, r.t0_bin, r.t1_bin),
        )),
        Some(PowerCorrection::Auto(_)) => n.push((
            "ingest.power_ref".into(),
            "auto (pixel integrals against the same pixels in the neighbouring rows)".into(),
        )),
        None => {}
    }
    if let Some(g) = &globals.gains {
        n.push(("ingest.power_gains".into(), json(serde_json::json!(g))));
    }
    if let Some(s) = &plan.sweep {
        n.push(("ingest.sweep".into(), s.source.clone()));
        n.push((
            "ingest.sweep_edges_ps".into(),
            json(serde_json::json!(s.edges_ps)),
        ));
    }
    if let Some(s) = &globals.shifts_ps {
        n.push(("ingest.jitter_shifts_ps".into(), json(serde_json::json!(s))));
        n.push(("ingest.jitter_rms_ps".into(), rms(s).to_string()));
    }
    if let Some(s) = &plan.saturation {
        n.push((
            "ingest.saturation_level".into(),
            format!("{} ({})", s.level, s.source),
        ));
    }
    if !plan.missing.is_empty() {
        n.push((
            "ingest.missing_rows".into(),
            json(serde_json::json!(plan.missing)),
        ));
    }
    n
}

/// Root mean square of a list (0 for an empty one).
pub fn rms(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

fn file_size(path: &Path) -> u64 {
    std::fs::metadata(path).map(|m| m.len()).unwrap_or(0)
}

// ---------------------------------------------------------------------------------------------
// One row.

/// A decoded scanline in the row layout `[x][t]` (recorded bins), scaled.
struct RawRow {
    values_xt: Vec<f32>,
    bytes: u64,
}

thread_local! {
    /// Samples of the scanline file being decoded on this thread (reused: one allocation per
    /// worker, not one per scanline).
    static SAMPLES: std::cell::RefCell<Vec<u16>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A decoded scanline file.
enum Decoded {
    /// A 16-bit grey PNG, its samples in the caller's buffer: `[t][x]`, or `[x][t]` (the
    /// cube's row layout already) when the plan transposes.
    Grey16 { nx: usize, nt: usize },
    /// Any other file, read by [`read_streak`].
    Image(Box<StreakImage>),
}

/// Decode the scanline file `path`: 16-bit grey PNG into `samples` (ingest's fast path, no
/// `f32` copy), everything else through [`read_streak`].
fn decode_file(
    path: &Path,
    transpose: bool,
    samples: &mut Vec<u16>,
) -> Result<Decoded, IngestError> {
    let is_png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        if let Some((width, height)) = read_png_grey16_into(path, samples)? {
            let (nx, nt) = if transpose {
                (height, width)
            } else {
                (width, height)
            };
            return Ok(Decoded::Grey16 { nx, nt });
        }
    }
    Ok(Decoded::Image(Box::new(read_streak(path, transpose)?)))
}

/// A scanline file after [`decode_row`].
enum Loaded {
    /// Converted into the row layout, scaled (16-bit grey PNG).
    Row(Vec<f32>),
    /// Read by [`read_streak`], for [`load_row`] to check and convert.
    Image(Box<StreakImage>),
}

/// Decode scanline file `path`; a 16-bit grey PNG goes from this thread's sample buffer
/// straight into a row of `pool` (scaled, in the row layout: one pass, no `f32` image).
fn decode_row(plan: &IngestPlan, path: &Path, pool: &RowPool) -> Result<Loaded, IngestError> {
    let (nx, nt) = (plan.nx, plan.nt_recorded);
    SAMPLES.with_borrow_mut(
        |samples| match decode_file(path, plan.transpose, samples)? {
            Decoded::Grey16 {
                nx: found_nx,
                nt: found_nt,
            } => {
                if (found_nx, found_nt) != (nx, nt) {
                    return Err(IngestError::SizeMismatch {
                        path: path.to_path_buf(),
                        what: "scanline".into(),
                        found_nx,
                        found_nt,
                        nx,
                        nt,
                        reference: plan.reference.clone(),
                    });
                }
                let scale = plan.value_scale;
                let mut values_xt = pool.take();
                if plan.transpose {
                    for (v, &s) in values_xt.iter_mut().zip(samples.iter()) {
                        *v = f32::from(s) * scale;
                    }
                } else {
                    to_row_layout_u16(samples, nx, nt, scale, &mut values_xt);
                }
                Ok(Loaded::Row(values_xt))
            }
            Decoded::Image(img) => Ok(Loaded::Image(img)),
        },
    )
}

/// Read scanline `y` (`None` when it is missing) into a row of `pool`, checking its size, its
/// time table and its values.
fn load_row(plan: &IngestPlan, y: usize, pool: &RowPool) -> Result<Option<RawRow>, IngestError> {
    let (nx, nt) = (plan.nx, plan.nt_recorded);
    match &plan.source {
        RowSource::Files(files) => {
            let Some(path) = &files[y] else {
                return Ok(None);
            };
            let img = match decode_row(plan, path, pool)? {
                Loaded::Row(values_xt) => {
                    check_sample_type(path, PixelType::U16, plan.pixel_type, &plan.reference)?;
                    return Ok(Some(RawRow {
                        values_xt,
                        bytes: file_size(path),
                    }));
                }
                Loaded::Image(img) => img,
            };
            check_sample_type(path, img.pixel_type, plan.pixel_type, &plan.reference)?;
            if (img.nx, img.nt) != (nx, nt) {
                return Err(IngestError::SizeMismatch {
                    path: path.clone(),
                    what: "scanline".into(),
                    found_nx: img.nx,
                    found_nt: img.nt,
                    nx,
                    nt,
                    reference: plan.reference.clone(),
                });
            }
            if let (Some(want), Some(got)) = (&plan.img_time_table_ps, &img.time_axis_ps) {
                // A thousandth of the reference table's mean row width (not of the output
                // bins, which resampling may make far finer or coarser).
                let tolerance = 1e-3 * (want[nt - 1] - want[0]) / (nt - 1).max(1) as f64;
                if let Some(row) = (0..nt).find(|&i| (want[i] - got[i]).abs() > tolerance) {
                    return Err(IngestError::TimeTableMismatch {
                        path: path.clone(),
                        reference: plan.reference.clone(),
                        row,
                        found_ps: got[row],
                        expected_ps: want[row],
                    });
                }
            }
            let mut values_xt = pool.take();
            to_row_layout(&img.data, nx, nt, plan.value_scale, &mut values_xt).map_err(
                |(x, t, value)| IngestError::NonFinite {
                    path: path.clone(),
                    x,
                    t,
                    value,
                },
            )?;
            Ok(Some(RawRow {
                values_xt,
                bytes: file_size(path),
            }))
        }
        RowSource::Stack { values, .. } => {
            let image = stack_image(values, y, nx, nt, plan.transpose);
            let mut values_xt = pool.take();
            to_row_layout(&image, nx, nt, plan.value_scale, &mut values_xt)
                .expect("stack values checked finite when the plan was made");
            Ok(Some(RawRow {
                values_xt,
                bytes: (nx * nt * 4) as u64,
            }))
        }
    }
}

/// A scanline after the corrections that need no other row.
struct Prepared {
    /// `[x][t]` on the output axis.
    row: Vec<f32>,
    mask: Vec<u8>,
    power_factor: Option<f64>,
    /// Per-pixel pulse times (ps), for jitter.
    edges_ps: Option<Vec<Option<f64>>>,
    /// Per-pixel log integrals, for automatic power normalisation.
    log_integrals: Option<Vec<Option<f64>>>,
    saturated: usize,
    bytes: u64,
}

/// Steps 1-3 and 5 (and the measurements for 4 and 6) on one scanline.
fn prepare(plan: &IngestPlan, y: usize, raw: RawRow) -> Prepared {
    let (nx, nt) = (plan.nx, plan.nt_recorded);
    let mut row = raw.values_xt;
    let mut mask = match &plan.saturation {
        Some(s) => saturation_mask(&row, nx, nt, s.threshold),
        None => vec![1u8; nx],
    };
    let saturated = mask.iter().filter(|&&m| m == 0).count();
    match &plan.dark {
        Some(DarkCorrection::Level(v)) => subtract_dark(&mut row, Dark::Constant(*v)),
        Some(DarkCorrection::Frame { values_xt, .. }) => {
            subtract_dark(&mut row, Dark::Frame(values_xt))
        }
        None => {}
    }
    if let Some(flat) = &plan.flat {
        divide_flat(&mut row, flat.row(y, nx), &mut mask);
    }
    let power_factor = match plan.power {
        Some(PowerCorrection::Region(r)) => Some(power_factor(&row, nx, nt, r)),
        _ => None,
    };
    let log_integrals = matches!(plan.power, Some(PowerCorrection::Auto(_)))
        .then(|| pixel_log_integrals(&row, nx, nt));
    if let Some(sweep) = &plan.sweep {
        let mut out = vec![0.0f32; nx * plan.out_axis.nt];
        resample_sweep(&row, nx, &sweep.edges_ps, &plan.out_axis, &mut out);
        row = out;
    }
    let edges_ps = plan
        .jitter
        .map(|_| pixel_pulse_times(&row, nx, &plan.out_axis));
    Prepared {
        row,
        mask,
        power_factor,
        edges_ps,
        log_integrals,
        saturated,
        bytes: raw.bytes,
    }
}

/// A finished row of the cube.
struct Finished {
    row: Vec<f32>,
    mask: Vec<u8>,
    saturated: usize,
    bytes: u64,
}

/// What the final pass reads.
struct Context<'a> {
    plan: &'a IngestPlan,
    globals: &'a Globals,
    scratch: Option<&'a Scratch>,
    /// Masks from pass 1 (`ny x nx`), when there was one.
    pass1_mask: Option<&'a [u8]>,
    /// Buffers of decoded rows.
    pool: RowPool,
}

/// Row `y` of the cube: a present row finished, or a missing one interpolated.
fn final_row(ctx: &Context, y: usize) -> Result<Finished, IngestError> {
    let plan = ctx.plan;
    if plan.missing.binary_search(&y).is_err() {
        return finished_present(ctx, y);
    }
    let present = |r: &usize| plan.missing.binary_search(r).is_err();
    let below = (0..y).rev().find(present);
    let above = (y + 1..plan.ny).find(present);
    let row = match (below, above) {
        (Some(b), Some(a)) => {
            let (rb, ra) = (finished_present(ctx, b)?.row, finished_present(ctx, a)?.row);
            let w = (y - b) as f32 / (a - b) as f32;
            rb.iter()
                .zip(&ra)
                .map(|(vb, va)| (1.0 - w) * vb + w * va)
                .collect()
        }
        (Some(n), None) | (None, Some(n)) => finished_present(ctx, n)?.row,
        (None, None) => unreachable!("the plan refuses a capture with every scanline missing"),
    };
    Ok(Finished {
        row,
        mask: vec![0; plan.nx],
        saturated: 0,
        bytes: 0,
    })
}

/// A present row with every correction applied.
fn finished_present(ctx: &Context, y: usize) -> Result<Finished, IngestError> {
    let plan = ctx.plan;
    let nx = plan.nx;
    let (mut row, mut mask, saturated, bytes) = match ctx.scratch {
        Some(scratch) => {
            let mask = ctx.pass1_mask.expect("pass 1 masks")[y * nx..(y + 1) * nx].to_vec();
            (scratch.read_row(y)?, mask, 0, 0)
        }
        None => {
            let raw = load_row(plan, y, &ctx.pool)?.expect("present row");
            let p = prepare(plan, y, raw);
            (p.row, p.mask, p.saturated, p.bytes)
        }
    };
    if let Some(gains) = &ctx.globals.gains {
        match gains[y] {
            Some(g) => apply_gain(&mut row, g),
            None => mask.fill(0),
        }
    }
    if let Some(shifts) = &ctx.globals.shifts_ps {
        if shifts[y] != 0.0 {
            let mut out = vec![0.0f32; row.len()];
            remove_shift(&row, nx, &plan.out_axis, shifts[y], &mut out);
            row = out;
        }
    }
    Ok(Finished {
        row,
        mask,
        saturated,
        bytes,
    })
}

// ---------------------------------------------------------------------------------------------
// Row buffers.

/// Row buffers handed back after a row is written, for the next rows to decode into: so
/// streaming allocates (and the kernel zero-fills) a few rows per thread, not one per
/// scanline.
struct RowPool {
    free: Mutex<Vec<Vec<f32>>>,
    row_len: usize,
}

impl RowPool {
    fn new(row_len: usize) -> RowPool {
        RowPool {
            free: Mutex::new(Vec::new()),
            row_len,
        }
    }

    /// A buffer of `row_len` values (contents unspecified: the caller overwrites them all).
    fn take(&self) -> Vec<f32> {
        let mut row = self
            .free
            .lock()
            .expect("pool lock")
            .pop()
            .unwrap_or_default();
        row.resize(self.row_len, 0.0);
        row
    }

    /// Keep `row` for a later [`RowPool::take`] (at most a window's worth are kept).
    fn give(&self, row: Vec<f32>) {
        let mut free = self.free.lock().expect("pool lock");
        if row.capacity() >= self.row_len && free.len() < 64 {
            free.push(row);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Scratch rows on disk.

/// Uncompressed rows of a two-pass ingest in an anonymous temporary file (removed by the
/// operating system when closed).
struct Scratch {
    file: Mutex<File>,
    row_len: usize,
    dir: PathBuf,
}

impl Scratch {
    fn create(dir: &Path, row_len: usize) -> Result<Scratch, IngestError> {
        let file = tempfile::tempfile_in(dir).map_err(|source| IngestError::Scratch {
            dir: dir.to_path_buf(),
            source,
        })?;
        Ok(Scratch {
            file: Mutex::new(file),
            row_len,
            dir: dir.to_path_buf(),
        })
    }

    fn err(&self) -> impl FnOnce(std::io::Error) -> IngestError + '_ {
        move |source| IngestError::Scratch {
            dir: self.dir.clone(),
            source,
        }
    }

    fn write_row(&self, y: usize, row: &[f32]) -> Result<(), IngestError> {
        debug_assert_eq!(row.len(), self.row_len);
        let mut bytes = Vec::with_capacity(row.len() * 4);
        for v in row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let mut f = self.file.lock().expect("scratch lock");
        f.seek(SeekFrom::Start((y * self.row_len * 4) as u64))
            .map_err(self.err())?;
        f.write_all(&bytes).map_err(self.err())
    }

    fn read_row(&self, y: usize) -> Result<Vec<f32>, IngestError> {
        let mut bytes = vec![0u8; self.row_len * 4];
        {
            let mut f = self.file.lock().expect("scratch lock");
            f.seek(SeekFrom::Start((y * self.row_len * 4) as u64))
                .map_err(self.err())?;
            f.read_exact(&mut bytes).map_err(self.err())?;
        }
        Ok(bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}

// ---------------------------------------------------------------------------------------------
// Ordered parallel streaming.

/// Compute `work(i)` for `i in 0..n` on worker threads and hand the results to `sink` on the
/// calling thread in order of `i`, with at most `window` items claimed beyond the last one
/// sunk (so memory stays bounded whatever `n`). The first error in order of `i` stops the
/// workers and is returned.
fn ordered_pipeline<T: Send>(
    n: usize,
    work: &(dyn Fn(usize) -> Result<T, IngestError> + Sync),
    sink: &mut dyn FnMut(usize, T) -> Result<(), IngestError>,
) -> Result<(), IngestError> {
    let threads = rayon::current_num_threads().max(1);
    let window = ROWS_IN_FLIGHT_PER_THREAD * threads + 2;

    struct State {
        next: usize,
        done: usize,
        abort: bool,
    }
    let state = Mutex::new(State {
        next: 0,
        done: 0,
        abort: false,
    });
    let wake = Condvar::new();
    let stop = |state: &Mutex<State>| {
        state.lock().expect("pipeline lock").abort = true;
        wake.notify_all();
    };

    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel::<(usize, Result<T, IngestError>)>();
        for _ in 0..threads.min(n) {
            let tx = tx.clone();
            let (state, wake) = (&state, &wake);
            scope.spawn(move || loop {
                let i = {
                    let mut s = state.lock().expect("pipeline lock");
                    while !s.abort && s.next < n && s.next >= s.done + window {
                        s = wake.wait(s).expect("pipeline lock");
                    }
                    if s.abort || s.next >= n {
                        return;
                    }
                    s.next += 1;
                    s.next - 1
                };
                if tx.send((i, work(i))).is_err() {
                    return;
                }
            });
        }
        drop(tx);

        let mut pending: BTreeMap<usize, Result<T, IngestError>> = BTreeMap::new();
        let mut done = 0;
        while done < n {
            let Ok((i, result)) = rx.recv() else {
                break; // every worker ended: only after a panic, which the scope re-raises
            };
            pending.insert(i, result);
            while let Some(result) = pending.remove(&done) {
                if let Err(e) = result.and_then(|t| sink(done, t)) {
                    stop(&state);
                    return Err(e);
                }
                done += 1;
                state.lock().expect("pipeline lock").done = done;
                wake.notify_all();
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn pipeline_sinks_in_order_with_bounded_lead() {
        let threads = rayon::current_num_threads().max(1);
        let window = ROWS_IN_FLIGHT_PER_THREAD * threads + 2;
        let sunk = AtomicUsize::new(0);
        let worst_lead = AtomicUsize::new(0);
        let work = |i: usize| -> Result<usize, IngestError> {
            // Items are claimed in order, and never more than `window` ahead of the sink.
            let lead = i - sunk.load(Ordering::SeqCst).min(i);
            worst_lead.fetch_max(lead, Ordering::SeqCst);
            if i.is_multiple_of(7) {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            Ok(i * i)
        };
        let mut seen = Vec::new();
        ordered_pipeline(200, &work, &mut |i, v| {
            assert_eq!(v, i * i);
            seen.push(i);
            sunk.store(i + 1, Ordering::SeqCst);
            Ok(())
        })
        .unwrap();
        assert_eq!(seen, (0..200).collect::<Vec<_>>());
        assert!(worst_lead.load(Ordering::SeqCst) <= window);
    }

    #[test]
    fn pipeline_reports_the_first_error_in_order() {
        let work = |i: usize| -> Result<usize, IngestError> {
            if i == 37 || i == 90 {
                Err(IngestError::AllMissing {
                    input: format!("item {i}"),
                })
            } else {
                Ok(i)
            }
        };
        let mut last = None;
        let e = ordered_pipeline(500, &work, &mut |i, _| {
            last = Some(i);
            Ok(())
        })
        .unwrap_err();
        assert!(e.to_string().contains("item 37"), "{e}");
        assert_eq!(last, Some(36));
    }
}
