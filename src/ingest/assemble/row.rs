//! One row of an ingest: a scanline file decoded (16-bit grey PNG straight into the row
//! layout, anything else through [`read_streak`]) and checked, the corrections that need no
//! other row applied (pass 1, [`prepare`]), and the finished row of the cube (pass 2, or the
//! one pass: [`final_row`]), a missing one interpolated from its neighbours.

use std::path::Path;

use super::stream::{RowPool, Scratch};
use super::Globals;
use crate::formats::raster::read_png_grey16_into;
use crate::formats::{read_streak, PixelType, StreakImage};
use crate::ingest::corrections::{
    apply_gain, check_sample_type, divide_flat, power_factor, remove_shift, resample_sweep,
    saturation_mask, subtract_dark, Dark,
};
use crate::ingest::plan::{
    stack_image, to_row_layout, to_row_layout_u16, DarkCorrection, IngestPlan, PowerCorrection,
    RowSource,
};
use crate::ingest::row_offsets::{pixel_log_integrals, pixel_pulse_times};
use crate::ingest::IngestError;

/// Size of a file, bytes (0 when it cannot be read).
pub(super) fn file_size(path: &Path) -> u64 {
    std::fs::metadata(path).map(|m| m.len()).unwrap_or(0)
}

/// A decoded scanline in the row layout `[x][t]` (recorded bins), scaled.
pub(super) struct RawRow {
    pub(super) values_xt: Vec<f32>,
    pub(super) bytes: u64,
}

thread_local! {
    /// Samples of the scanline file being decoded on this thread (reused: one allocation per
    /// worker, not one per scanline).
    pub(super) static SAMPLES: std::cell::RefCell<Vec<u16>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A decoded scanline file.
pub(super) enum Decoded {
    /// A 16-bit grey PNG, its samples in the caller's buffer: `[t][x]`, or `[x][t]` (the
    /// cube's row layout already) when the plan transposes.
    Grey16 { nx: usize, nt: usize },
    /// Any other file, read by [`read_streak`].
    Image(Box<StreakImage>),
}

/// Decode the scanline file `path`: 16-bit grey PNG into `samples` (ingest's fast path, no
/// `f32` copy), everything else through [`read_streak`].
pub(super) fn decode_file(
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
pub(super) fn load_row(
    plan: &IngestPlan,
    y: usize,
    pool: &RowPool,
) -> Result<Option<RawRow>, IngestError> {
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
pub(super) struct Prepared {
    /// `[x][t]` on the output axis.
    pub(super) row: Vec<f32>,
    pub(super) mask: Vec<u8>,
    pub(super) power_factor: Option<f64>,
    /// Per-pixel pulse times (ps), for jitter.
    pub(super) edges_ps: Option<Vec<Option<f64>>>,
    /// Per-pixel log integrals, for automatic power normalisation.
    pub(super) log_integrals: Option<Vec<Option<f64>>>,
    pub(super) saturated: usize,
    pub(super) bytes: u64,
}

/// Steps 1-3 and 5 (and the measurements for 4 and 6) on one scanline.
pub(super) fn prepare(plan: &IngestPlan, y: usize, raw: RawRow) -> Prepared {
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
pub(super) struct Finished {
    pub(super) row: Vec<f32>,
    pub(super) mask: Vec<u8>,
    pub(super) saturated: usize,
    pub(super) bytes: u64,
}

/// What the final pass reads.
pub(super) struct Context<'a> {
    pub(super) plan: &'a IngestPlan,
    pub(super) globals: &'a Globals,
    pub(super) scratch: Option<&'a Scratch>,
    /// Masks from pass 1 (`ny x nx`), when there was one.
    pub(super) pass1_mask: Option<&'a [u8]>,
    /// Buffers of decoded rows.
    pub(super) pool: RowPool,
}

/// Row `y` of the cube: a present row finished, or a missing one interpolated.
pub(super) fn final_row(ctx: &Context, y: usize) -> Result<Finished, IngestError> {
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
