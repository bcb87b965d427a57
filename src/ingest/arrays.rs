//! The ingest route of array files ([`crate::readers`]: `.npy`, `.npz`, `.mat`, `.hspy`,
//! plain HDF5, Delmic SPARC HDF5, PicoQuant PTU): the [`Capture`] read becomes a cube on a uniform camera-time axis, with the
//! saturation mask of streak ingest, a confocal scan's wall (the `tal` group), and the file's
//! other axes and scalars as cube attributes; written atomically.
//!
//! The time axis, in order: the one the file records (a bin width given that contradicts it
//! is refused); a recorded bin width with the start given (default 0 ps); a non-uniform
//! recorded table is resampled onto the uniform axis over its span, conserving each pixel's
//! integral ([`crate::resample::rebin_add`]); with nothing recorded, `--dt-ps` (and
//! `--t0-ps`, default 0) must be given.

use crate::container::{self, Provenance};
use crate::cube::{Cube, TimeAxis, TimeFrame};
use crate::ingest::corrections::saturation_mask;
use crate::ingest::plan::SaturationInput;
use crate::ingest::time_axis::edges_from_starts;
use crate::interop::geometry_group;
use crate::interop::tal::{self, LaserSpot, TalGeometry};
use crate::readers::{self, Axis, Capture, Format, ReadOptions, ReaderError, TimeSpec};
use std::path::Path;

/// A confocal capture: each pixel's laser point is its own wall point (O'Toole et al.
/// 2018), on a square wall patch `wall_size_m` on a side. Recorded as the cube's `tal` group
/// ([`Confocal::geometry`]), which `femto unwarp`, `femto export --to tal` and `femto render`
/// read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Confocal {
    pub wall_size_m: f64,
    /// Where the laser and the detector are (one device, as in a confocal system), metres;
    /// None when the file does not say (a world-time cube needs none; `femto unwarp` of a
    /// camera-time one refuses without it).
    pub device_m: Option<[f64; 3]>,
}

impl Confocal {
    /// The wall of an `nx` x `ny` scan: the plane z = 0, centred on the origin, pixel `(x, y)`
    /// at `((x + 0.5) / nx - 1/2, (y + 0.5) / ny - 1/2, 0)` times the side, normals towards
    /// z < 0, where the device is expected; laser and sensor at the device (NaN: unknown).
    pub fn geometry(&self, nx: usize, ny: usize) -> TalGeometry {
        let w = self.wall_size_m;
        let at = |i: usize, n: usize| ((i as f64 + 0.5) / n as f64 - 0.5) * w;
        let device = self.device_m.unwrap_or([f64::NAN; 3]);
        TalGeometry {
            sensor_grid_m: (0..nx * ny)
                .map(|p| [at(p % nx, nx), at(p / nx, ny), 0.0])
                .collect(),
            sensor_normals: Some(vec![[0.0, 0.0, -1.0]; nx * ny]),
            sensor_m: device,
            laser_origin_m: device,
            laser_spot_m: LaserSpot::Confocal,
            t_spot_ps: 0.0,
            time_scale: 1.0,
        }
    }
}

/// What to do with an array file.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrayIngest {
    pub read: ReadOptions,
    /// Bin width and start, ps, for files that record none (or no start).
    pub dt_ps: Option<f64>,
    pub t0_ps: Option<f64>,
    pub saturation: Option<SaturationInput>,
    pub confocal: Option<Confocal>,
    /// The clock of the file's time: camera (what the detector recorded, the default) or
    /// world (the time already starts at each pixel's point: both wall legs removed, as in
    /// most public confocal NLOS data).
    pub clock: TimeFrame,
}

impl Default for ArrayIngest {
    fn default() -> Self {
        ArrayIngest {
            read: ReadOptions::default(),
            dt_ps: None,
            t0_ps: None,
            saturation: None,
            confocal: None,
            clock: TimeFrame::Camera,
        }
    }
}

/// What [`ingest_array`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrayReport {
    pub format: Format,
    pub source: String,
    pub dtype: readers::Dtype,
    pub nx: usize,
    pub ny: usize,
    pub axis: TimeAxis,
    /// How the time axis was decided.
    pub time_axis: String,
    pub saturated_pixels: usize,
    /// Which stored axis became time, rows and columns, and what became of the others.
    pub layout: String,
    /// Integer samples f32 does not hold exactly (a warning), and the largest.
    pub inexact: usize,
    pub largest_inexact: f64,
}

fn flag(path: &Path, key: &str, message: impl Into<String>) -> ReaderError {
    ReaderError::invalid(path, key, message)
}

/// The cube's axis and the samples on it (resampled from a non-uniform table).
fn time_axis(
    c: &Capture,
    opts: &ArrayIngest,
) -> Result<(TimeAxis, String, Option<Vec<f32>>), ReaderError> {
    let p = c.path.as_path();
    let nt = c.nt;
    if let Some(dt) = opts.dt_ps {
        readers::check_dt(p, "--dt-ps", dt)?;
    }
    if let Some(t0) = opts.t0_ps {
        readers::check_time(p, "--t0-ps", t0)?;
    }
    let agree = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-3);
    let contradicts = |what: &str, given: f64, recorded: f64| {
        flag(
            p,
            what,
            format!(
                "{given} ps contradicts the file's time axis ({recorded} ps, {}); leave it out",
                c.time_source
            ),
        )
    };
    let from_file = |s: &str| format!("recorded: {s}");
    match &c.time {
        TimeSpec::Uniform { t0_ps, dt_ps } => {
            if let Some(d) = opts.dt_ps.filter(|d| !agree(*d, *dt_ps)) {
                return Err(contradicts("--dt-ps", d, *dt_ps));
            }
            if let Some(t) = opts.t0_ps.filter(|t| !agree(*t, *t0_ps)) {
                return Err(contradicts("--t0-ps", t, *t0_ps));
            }
            let axis = TimeAxis {
                t0_ps: *t0_ps,
                dt_ps: *dt_ps,
                nt,
            };
            Ok((axis, from_file(&c.time_source), None))
        }
        TimeSpec::Width { dt_ps } => {
            if let Some(d) = opts.dt_ps.filter(|d| !agree(*d, *dt_ps)) {
                return Err(contradicts("--dt-ps", d, *dt_ps));
            }
            let t0 = opts.t0_ps.unwrap_or(0.0);
            let start = match opts.t0_ps {
                Some(_) => "start given (--t0-ps)",
                None => "start not recorded: 0 ps (--t0-ps to set it)",
            };
            let axis = TimeAxis {
                t0_ps: t0,
                dt_ps: *dt_ps,
                nt,
            };
            Ok((
                axis,
                format!("{}; {start}", from_file(&c.time_source)),
                None,
            ))
        }
        TimeSpec::Table(starts) => {
            if opts.dt_ps.is_some() || opts.t0_ps.is_some() {
                return Err(flag(
                    p,
                    "--dt-ps/--t0-ps",
                    format!(
                        "the file records a non-uniform time axis ({}), resampled onto its \
                         own span; leave them out",
                        c.time_source
                    ),
                ));
            }
            let edges = edges_from_starts(starts);
            let axis = TimeAxis {
                t0_ps: edges[0],
                dt_ps: (edges[nt] - edges[0]) / nt as f64,
                nt,
            };
            let mut out = vec![0.0f32; c.samples.len()];
            for (src, dst) in c.samples.chunks_exact(nt).zip(out.chunks_exact_mut(nt)) {
                crate::resample::rebin_add(&edges, src, &axis, dst);
            }
            let how = format!(
                "{}: non-uniform, resampled onto {nt} uniform bins over its span",
                from_file(&c.time_source)
            );
            Ok((axis, how, Some(out)))
        }
        TimeSpec::Uncalibrated { reason } => {
            let Some(dt) = opts.dt_ps else {
                return Err(flag(
                    p,
                    "time axis",
                    format!("{reason}; give the bin width and start: --dt-ps PS [--t0-ps PS, default 0]"),
                ));
            };
            let t0 = opts.t0_ps.unwrap_or(0.0);
            let axis = TimeAxis {
                t0_ps: t0,
                dt_ps: dt,
                nt,
            };
            Ok((axis, "given: --dt-ps, --t0-ps (default 0)".into(), None))
        }
    }
}

/// The threshold and provenance of `--saturation` for samples of `dtype`: a raw value at or
/// above the threshold is saturated (the level less half a count for integer samples, as
/// streak ingest does).
fn saturation_threshold(c: &Capture, input: SaturationInput) -> Result<(f32, String), ReaderError> {
    let p = c.path.as_path();
    let (level, how) = match input {
        SaturationInput::Level(v) => {
            if !(v.is_finite() && v > 0.0) {
                return Err(flag(
                    p,
                    "--saturation",
                    format!("{v}: must be finite and > 0"),
                ));
            }
            (v, "given".to_string())
        }
        SaturationInput::Auto => match c.dtype.max_value() {
            Some(m) => (m, format!("auto: the largest {}", c.dtype.name())),
            None => {
                return Err(flag(
                    p,
                    "--saturation",
                    format!(
                        "auto needs integer samples; these are {} (use --saturation LEVEL)",
                        c.dtype.name()
                    ),
                ))
            }
        },
    };
    let quantum = if c.dtype.is_integer() { 1.0 } else { 0.0 };
    Ok(((level - 0.5 * quantum) as f32, format!("{level} ({how})")))
}

/// The attributes of a non-time axis: `axis.ROLE.name`, `.units`, `.scale`, `.offset` or
/// `.values` (JSON).
fn axis_notes(role: &str, a: &Axis) -> Vec<(String, String)> {
    let mut n = vec![
        (format!("axis.{role}.name"), a.name.clone()),
        (format!("axis.{role}.units"), a.units.clone()),
    ];
    match &a.values {
        Some(v) => n.push((
            format!("axis.{role}.values"),
            serde_json::to_string(v).expect("finite numbers"),
        )),
        None => {
            if let (Some(s), Some(o)) = (a.scale, a.offset) {
                n.push((format!("axis.{role}.scale"), s.to_string()));
                n.push((format!("axis.{role}.offset"), o.to_string()));
            }
        }
    }
    n
}

/// `--wall-size-m` and `--device-m` in range.
fn check_confocal_flags(input: &Path, opts: &ArrayIngest) -> Result<(), ReaderError> {
    if let Some(c) = opts.confocal {
        if !(c.wall_size_m.is_finite() && c.wall_size_m > 0.0 && c.wall_size_m < 1e4) {
            return Err(flag(
                input,
                "--wall-size-m",
                format!("{}: must be a positive size in metres", c.wall_size_m),
            ));
        }
        if let Some(d) = c
            .device_m
            .filter(|d| d.iter().any(|v| !(v.is_finite() && v.abs() < 1e4)))
        {
            return Err(flag(
                input,
                "--device-m",
                format!("{d:?}: must be three finite coordinates in metres"),
            ));
        }
    }
    Ok(())
}

/// A confocal grid is square, and every value is finite.
fn check_capture(
    input: &Path,
    c: &readers::Capture,
    opts: &ArrayIngest,
) -> Result<(), ReaderError> {
    if opts.confocal.is_some() && c.nx != c.ny {
        return Err(flag(
            input,
            "--confocal",
            format!(
                "the grid is {} x {} (rows x columns, from {:?}; {}), not square as a \
                 confocal scan's is; name the time axis with --time-axis N",
                c.ny, c.nx, c.stored_shape, c.layout
            ),
        ));
    }
    if let Some(i) = c.samples.iter().position(|v| !v.is_finite()) {
        let (p, t) = (i / c.nt, i % c.nt);
        return Err(flag(
            input,
            "values",
            format!(
                "{} at row {}, column {}, bin {t}",
                c.samples[i],
                p / c.nx,
                p % c.nx
            ),
        ));
    }
    Ok(())
}

/// Read the array file `input` and write its cube to `out`; nothing is written on error.
pub fn ingest_array(
    input: &Path,
    format: Format,
    out: &Path,
    opts: &ArrayIngest,
    provenance: &Provenance,
) -> Result<ArrayReport, ReaderError> {
    check_confocal_flags(input, opts)?;
    let c = readers::open(input, format, &opts.read)?;
    check_capture(input, &c, opts)?;
    let (axis, time_axis, resampled) = time_axis(&c, opts)?;
    let end = axis.end_ps();
    if !end.is_finite() || end.abs() >= 1e18 {
        return Err(flag(input, "time axis", format!("ends at {end} ps")));
    }
    let mut notes: Vec<(String, String)> = vec![
        (
            "ingest.source".into(),
            format!(
                "{} {} ({}{}{} {:?})",
                format.name(),
                input.display(),
                c.source,
                if c.source.is_empty() { "" } else { ", " },
                c.dtype.name(),
                c.stored_shape
            ),
        ),
        ("ingest.time_axis".into(), time_axis.clone()),
        ("ingest.layout".into(), c.layout.clone()),
    ];
    // The mask is taken on the raw values, before any resampling.
    let mut mask = None;
    let mut saturated_pixels = 0;
    if let Some(s) = opts.saturation {
        let (threshold, how) = saturation_threshold(&c, s)?;
        let m: Vec<u8> = c
            .samples
            .chunks(c.nx * c.nt)
            .flat_map(|row| saturation_mask(row, c.nx, c.nt, threshold))
            .collect();
        saturated_pixels = m.iter().filter(|&&v| v == 0).count();
        notes.push(("ingest.saturation_level".into(), how));
        notes.push((
            "ingest.saturated_pixels".into(),
            saturated_pixels.to_string(),
        ));
        mask = Some(m);
    }
    if c.inexact > 0 {
        notes.push((
            "ingest.inexact_values".into(),
            format!(
                "{} integer values above 2^24 rounded to float32 (largest {})",
                c.inexact, c.largest_inexact
            ),
        ));
    }
    if let Some(y) = &c.y {
        notes.extend(axis_notes("y", y));
    }
    if let Some(x) = &c.x {
        notes.extend(axis_notes("x", x));
    }
    notes.extend(c.attributes.iter().cloned());
    if let Some(conf) = opts.confocal {
        notes.push(("wall_size_m".into(), conf.wall_size_m.to_string()));
    }
    let mut provenance = provenance.clone();
    provenance.notes.extend(notes);
    let report = ArrayReport {
        format,
        source: c.source.clone(),
        dtype: c.dtype,
        nx: c.nx,
        ny: c.ny,
        axis,
        time_axis,
        saturated_pixels,
        layout: c.layout.clone(),
        inexact: c.inexact,
        largest_inexact: c.largest_inexact,
    };
    let cube = Cube {
        nx: c.nx,
        ny: c.ny,
        axis,
        frame: opts.clock,
        data: resampled.unwrap_or(c.samples),
        mask,
    };
    let groups: Vec<(&str, container::GroupData)> = opts
        .confocal
        .map(|conf| {
            let geo = conf.geometry(cube.nx, cube.ny);
            (tal::GROUP, geometry_group(&geo, cube.nx, cube.ny))
        })
        .into_iter()
        .collect();
    container::write_cube_with_groups(out, &cube, &provenance, &groups)?;
    Ok(report)
}
