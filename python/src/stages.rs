//! The file stages with the options of their `femto` flags: `ingest` (streak captures),
//! `calibrate`, `unwarp`, `pyramid`, and the y-tal / mitransient interop (`export_tal`,
//! `ingest_tal`, `ingest_mitransient`). Each starts from the library's `Default` options
//! (what the CLI does without flags), sets the arguments given, runs the library's stage
//! on a worker thread ([`run_stage`]) and returns the figures the CLI prints as a dict.

use crate::errors::{error_line, value_error, IntoPy};
use crate::runner::run_stage;
use femto::container::{CubeCompression, Provenance};
use femto::cube::{TimeAxis, TimeFrame};
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::ingest::assemble::{self, Pass};
use femto::ingest::plan::{
    DarkInput, IngestOptions, IngestPlan, InputSpec, PowerRef, SaturationInput,
};
use femto::pipeline::calibrate::{
    calibrate_cube, default_calibration_path, laser_spot, read_intrinsics, write_calibration,
    CalibrateOptions, DetectionFloor,
};
use femto::pipeline::overwrite::refuse_existing;
use femto::pipeline::pyramid::{pyramid_file, PyramidOptions};
use femto::pipeline::unwarp::{unwarp_file, Distances, UnwarpOptions};
use femto::pipeline::StageError;
use femto::unwarp::Direction;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// The provenance a stage called from Python records.
fn provenance(stage: &str) -> String {
    format!("python: femto.{stage}")
}

/// `saturation=`: a level (a number) or `"auto"`, as `--saturation`.
pub(crate) fn saturation_input(
    saturation: Option<Bound<'_, PyAny>>,
) -> PyResult<Option<SaturationInput>> {
    let Some(s) = saturation else {
        return Ok(None);
    };
    Ok(Some(match s.extract::<f64>() {
        Ok(level) => SaturationInput::Level(level),
        Err(_) => {
            let text: String = s.extract()?;
            SaturationInput::parse(&text)
                .map_err(|e| value_error(format!("--saturation {text}: {e}")))?
        }
    }))
}

/// Parse a `--compression` value (`"none"` or a deflate level 0-9).
fn compression(flag: &str, value: Option<&str>) -> PyResult<Option<CubeCompression>> {
    value
        .map(|v| CubeCompression::parse(v).map_err(|e| value_error(format!("--{flag} {v}: {e}"))))
        .transpose()
}

/// `femto pyramid CUBE`: the cube's prefix sums and mip levels, into its file or `side_file`.
#[pyfunction]
#[pyo3(signature = (cube, levels, side_file, compression, force, progress))]
pub fn pyramid<'py>(
    py: Python<'py>,
    cube: PathBuf,
    levels: Option<usize>,
    side_file: Option<PathBuf>,
    compression: Option<String>,
    force: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    if let Some(side) = &side_file {
        refuse_existing(side, &[cube.as_path()], force, "side-file").py_err()?;
    }
    let mut options = PyramidOptions {
        levels,
        side_file: side_file.clone(),
        ..PyramidOptions::default()
    };
    if let Some(c) = self::compression("compression", compression.as_deref())? {
        options.compression = c;
    }
    let info = run_stage(py, progress.as_ref(), |shared| {
        pyramid_file(&cube, &options, shared).py_err()
    })?;
    let d = PyDict::new(py);
    d.set_item("path", side_file.as_ref().unwrap_or(&cube))?;
    d.set_item("shape", (info.ny, info.nx, info.axis.nt))?;
    d.set_item("levels", info.levels)?;
    d.set_item("level_nts", info.level_nts())?;
    Ok(d)
}

/// `femto unwarp CUBE --out OUT`: camera time to world time (or back with `to="camera"`).
#[pyfunction]
#[pyo3(signature = (
    cube, out, to, t0_ps, nt, dt_ps, calibration, mesh, compression, mask_spread_bins, force,
    progress
))]
#[allow(clippy::too_many_arguments)]
pub fn unwarp<'py>(
    py: Python<'py>,
    cube: PathBuf,
    out: PathBuf,
    to: &str,
    t0_ps: Option<f64>,
    nt: Option<usize>,
    dt_ps: Option<f64>,
    calibration: Option<PathBuf>,
    mesh: Option<PathBuf>,
    compression: Option<String>,
    mask_spread_bins: Option<f64>,
    force: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut inputs = vec![cube.as_path()];
    inputs.extend(calibration.as_deref());
    inputs.extend(mesh.as_deref());
    refuse_existing(&out, &inputs, force, "out").py_err()?;
    let mut options = UnwarpOptions {
        command_line: provenance("unwarp"),
        ..UnwarpOptions::default()
    };
    options.direction = match TimeFrame::parse(to) {
        Some(TimeFrame::World) => Direction::CameraToWorld,
        Some(TimeFrame::Camera) => Direction::WorldToCamera,
        None => return Err(value_error(format!("--to {to}: expected world or camera"))),
    };
    options.axis = match (t0_ps, nt) {
        (Some(t0_ps), Some(nt)) => {
            let dt_ps = match dt_ps {
                Some(d) => d,
                None => femto::container::read_meta(&cube).py_err()?.axis.dt_ps,
            };
            Some(TimeAxis { t0_ps, dt_ps, nt })
        }
        (None, None) if dt_ps.is_none() => None,
        _ => return Err(value_error("t0_ps= and nt= go together (dt_ps= optional)")),
    };
    options.compression = self::compression("compression", compression.as_deref())?;
    if let Some(bins) = mask_spread_bins {
        // Checked by the library (a positive number of bins, or infinity: keep every pixel).
        options.mask_spread_bins = bins;
    }
    let cast = match (&calibration, &mesh) {
        (Some(c), Some(m)) => Some((
            femto::camera::Calibration::load(c).py_err()?,
            c.display().to_string(),
            Bvh::new(load_mesh(m).py_err()?),
            m.display().to_string(),
        )),
        (None, None) => None,
        _ => return Err(value_error("--calibration and --mesh go together")),
    };
    let done = run_stage(py, progress.as_ref(), |shared| {
        let distances = match &cast {
            Some((calibration, calibration_name, mesh, mesh_name)) => Distances::Cast {
                calibration,
                calibration_name,
                mesh,
                mesh_name,
            },
            None => Distances::Stored,
        };
        unwarp_file(&cube, &out, distances, &options, shared).py_err()
    })?;
    let d = PyDict::new(py);
    d.set_item("path", &out)?;
    d.set_item("from_clock", done.from.as_str())?;
    d.set_item("to_clock", done.to.as_str())?;
    d.set_item("shape", (done.ny, done.nx, done.output_axis.nt))?;
    d.set_item("t0_ps", done.output_axis.t0_ps)?;
    d.set_item("dt_ps", done.output_axis.dt_ps)?;
    d.set_item("input_t0_ps", done.input_axis.t0_ps)?;
    d.set_item("input_nt", done.input_axis.nt)?;
    d.set_item("eta", done.eta)?;
    d.set_item("valid_pixels", done.valid_pixels)?;
    d.set_item("dist_range_m", done.dist_range_m)?;
    d.set_item("straddling_pixels", done.straddling_pixels)?;
    d.set_item("mixed_pixels", done.mixed_pixels)?;
    d.set_item("mask_spread_bins", options.mask_spread_bins)?;
    d.set_item("scanlines_moved", done.scanlines_moved)?;
    Ok(d)
}

/// `femto calibrate CUBE --mesh --points [--laser]`: camera, registration and `t0`.
#[pyfunction]
#[pyo3(signature = (
    cube, mesh, points, laser, intrinsics, eta, square_pixels, centred_principal_point,
    fit_distortion, fit_time_scale, keep_outliers, threshold, min_peak, out, force, progress
))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate<'py>(
    py: Python<'py>,
    cube: PathBuf,
    mesh: PathBuf,
    points: PathBuf,
    laser: Option<[f64; 3]>,
    intrinsics: Option<PathBuf>,
    eta: Option<f64>,
    square_pixels: bool,
    centred_principal_point: bool,
    fit_distortion: bool,
    fit_time_scale: bool,
    keep_outliers: bool,
    threshold: Option<f64>,
    min_peak: Option<f32>,
    out: Option<PathBuf>,
    force: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let out = out.unwrap_or_else(|| default_calibration_path(&cube));
    let mut inputs = vec![cube.as_path(), mesh.as_path(), points.as_path()];
    inputs.extend(intrinsics.as_deref());
    refuse_existing(&out, &inputs, force, "out").py_err()?;
    let meta = femto::container::read_meta(&cube).py_err()?;
    // The input files before the values, as the command: a missing mesh is named as missing.
    let bvh = py.detach(|| load_mesh(&mesh).map(Bvh::new)).py_err()?;
    let correspondences = femto::calibrate::load_points(&points).py_err()?;
    let (known, file_laser, file_eta) = match &intrinsics {
        Some(p) => {
            let known = read_intrinsics(p, meta.nx, meta.ny).py_err()?;
            let laser = known.laser_m.map(|l| l.coords.into());
            (Some(known.intrinsics), laser, known.eta)
        }
        None => (None, None, None),
    };
    if known.is_some() && (square_pixels || centred_principal_point || fit_distortion) {
        return Err(value_error(
            "--intrinsics: cannot be used with --square-pixels, --centred-principal-point or \
             --fit-distortion (the intrinsics are known)",
        ));
    }
    let laser_m = laser_spot(laser, file_laser).py_err()?;
    let defaults = CalibrateOptions::default();
    let options = CalibrateOptions {
        intrinsics: known,
        square_pixels,
        centred_principal_point,
        fit_distortion,
        keep_outliers,
        eta: eta.or(file_eta).unwrap_or(defaults.eta),
        fit_time_scale,
        threshold_fraction: threshold.unwrap_or(defaults.threshold_fraction),
        floor: match min_peak {
            Some(v) => DetectionFloor::Level(v),
            None => defaults.floor,
        },
    };
    let result = run_stage(py, progress.as_ref(), |shared| {
        let result = calibrate_cube(&cube, &bvh, &correspondences, laser_m, &options, shared)
            .map_err(|e| match e {
                // As the CLI names them: the points file, the mesh.
                StageError::Points { source } => {
                    value_error(format!("{}: {}", points.display(), error_line(&source)))
                }
                StageError::NothingSeen => value_error(format!("{}: {e}", mesh.display())),
                other => crate::errors::to_py(&other),
            })?;
        let mut inputs = vec![mesh.as_path(), points.as_path()];
        inputs.extend(intrinsics.as_deref());
        let header = format!("# made by: {}\n", provenance("calibrate"));
        write_calibration(
            &cube,
            &result,
            correspondences.len(),
            &mesh.display().to_string(),
            &out,
            &inputs,
            &header,
        )
        .py_err()?;
        Ok(result)
    })?;
    let d = PyDict::new(py);
    let t = &result.time;
    d.set_item("calibration", &out)?;
    d.set_item("t0_ps", t.fit.t0_ps)?;
    d.set_item("t0_std_error_ps", t.t0_std_error_ps)?;
    d.set_item("time_scale", t.fit.time_scale)?;
    d.set_item("time_residual_rms_ps", t.fit.rms_ps)?;
    d.set_item("time_residual_sigma_ps", t.fit.sigma_ps)?;
    d.set_item("time_samples", t.samples)?;
    d.set_item("time_inliers", t.fit.inlier_count())?;
    d.set_item("detection_floor", t.floor)?;
    d.set_item("check_t0_ps", result.check.fit.t0_ps)?;
    d.set_item("noise_sigma", result.noise_sigma)?;
    d.set_item("reprojection_rms_px", result.spatial.rms_px)?;
    d.set_item("reprojection_median_px", result.spatial.median_px)?;
    d.set_item("per_point_px", result.spatial.per_point_px.clone())?;
    d.set_item("outliers", result.spatial.outliers.clone())?;
    d.set_item("points", correspondences.len())?;
    d.set_item(
        "scanline_offset_ps",
        femto::row_offset::applied_ps(&result.scanlines),
    )?;
    d.set_item("scanline_report", result.scanline_report.lines())?;
    d.set_item("warnings", result.warnings.clone())?;
    Ok(d)
}

/// `femto ingest INPUT -o OUT` of a streak capture (a folder with manifest.toml, a manifest,
/// a glob, a printf pattern with `rows`, an HDF5 stack with `dataset`, or one scanline).
#[pyfunction]
#[pyo3(signature = (
    source, out, rows, dataset, dt_ps, t0_ps, resample_time, laser_nm, transpose, dark, flat,
    sweep_table, no_manifest_corrections, jitter, power_ref, saturation, allow_missing,
    value_scale, compression, force, progress
))]
#[allow(clippy::too_many_arguments)]
pub fn ingest<'py>(
    py: Python<'py>,
    source: String,
    out: PathBuf,
    rows: Option<usize>,
    dataset: Option<String>,
    dt_ps: Option<f64>,
    t0_ps: Option<f64>,
    resample_time: bool,
    laser_nm: Option<f64>,
    transpose: bool,
    dark: Option<Bound<'py, PyAny>>,
    flat: Option<PathBuf>,
    sweep_table: Option<PathBuf>,
    no_manifest_corrections: bool,
    jitter: Option<bool>,
    power_ref: Option<String>,
    saturation: Option<Bound<'py, PyAny>>,
    allow_missing: bool,
    value_scale: Option<f64>,
    compression: Option<String>,
    force: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    refuse_existing(&out, &[Path::new(&source)], force, "out").py_err()?;
    let flagged = |e: femto::ingest::IngestError| match femto::ingest::flags::flag_message(&e) {
        Some(line) => value_error(line),
        None => crate::errors::to_py(&e),
    };
    let dark = match dark {
        None => None,
        Some(d) => match d.extract::<f64>() {
            Ok(level) => Some(DarkInput::Level(level)),
            Err(_) => Some(DarkInput::File(d.extract::<PathBuf>()?)),
        },
    };
    let power_ref = power_ref
        .map(|s| PowerRef::parse(&s).map_err(|e| value_error(format!("--power-ref {s}: {e}"))))
        .transpose()?;
    let saturation = saturation_input(saturation)?;
    let defaults = IngestOptions::default();
    let options = IngestOptions {
        dt_ps,
        t0_ps,
        resample_time,
        laser_nm,
        transpose,
        dark,
        flat,
        sweep_table,
        ignore_manifest_corrections: no_manifest_corrections,
        jitter: jitter.unwrap_or(defaults.jitter),
        power_ref,
        saturation,
        allow_missing,
        value_scale,
    };
    let compression = self::compression("compression", compression.as_deref())?
        .unwrap_or(femto::pipeline::INGEST_COMPRESSION);
    let (plan, summary) = run_stage(py, progress.as_ref(), |shared| {
        let input = InputSpec::classify(&source, rows, dataset.as_deref()).map_err(flagged)?;
        let plan = IngestPlan::resolve(&input, &options).map_err(flagged)?;
        let ny = plan.ny as u64;
        let two = plan.needs_two_passes();
        let passes = if two { 2 } else { 1 };
        femto::pipeline::Progress::start(shared, "ingest", passes * ny);
        let on_rows = |pass: Pass, n: usize| {
            shared.set(match pass {
                Pass::Write if two => ny + n as u64,
                _ => n as u64,
            })
        };
        let p = Provenance::new(provenance("ingest"));
        let summary = assemble::ingest(&plan, &out, &p, compression, &on_rows).map_err(flagged)?;
        Ok((plan, summary))
    })?;
    let d = PyDict::new(py);
    d.set_item("path", &out)?;
    d.set_item("rows", summary.rows)?;
    d.set_item("shape", (plan.ny, summary.nx, summary.nt))?;
    d.set_item("t0_ps", plan.out_axis.t0_ps)?;
    d.set_item("dt_ps", plan.out_axis.dt_ps)?;
    d.set_item("time_axis", plan.axis_source.to_string())?;
    d.set_item("laser_nm", plan.laser.as_ref().map(|l| l.nm))?;
    d.set_item("missing_rows", summary.missing_rows.clone())?;
    d.set_item("saturated_pixels", summary.saturated_pixels)?;
    d.set_item("masked_pixels", summary.masked_pixels)?;
    d.set_item("jitter_shifts_ps", summary.jitter_shifts_ps.clone())?;
    d.set_item("power_gains", summary.power_gains.clone())?;
    d.set_item("passes", summary.passes)?;
    d.set_item("corrections", summary.corrections.clone())?;
    d.set_item("bytes_read", summary.bytes_read)?;
    d.set_item("stored_bytes", summary.stored_bytes)?;
    Ok(d)
}

/// `femto export CUBE --to tal -o OUT`: a y-tal capture (HDF5) of a cube with a
/// registration or tal group.
#[pyfunction]
#[pyo3(signature = (cube, out, laser_origin_m))]
pub fn export_tal<'py>(
    py: Python<'py>,
    cube: PathBuf,
    out: PathBuf,
    laser_origin_m: Option<[f64; 3]>,
) -> PyResult<Bound<'py, PyDict>> {
    femto::pipeline::refuse_same_file(&out, &[cube.as_path()], "out").py_err()?;
    let e = py
        .detach(|| femto::interop::export_tal(&cube, &out, laser_origin_m))
        .py_err()?;
    let c = &e.capture;
    let d = PyDict::new(py);
    d.set_item("path", &out)?;
    d.set_item("H_shape", (c.nt, c.sx, c.sy))?;
    d.set_item("delta_t_m", c.delta_t_m)?;
    d.set_item("t_start_m", c.t_start_m)?;
    d.set_item(
        "t_accounts_first_and_last_bounces",
        c.t_accounts_first_and_last_bounces,
    )?;
    d.set_item("unseen_points", e.unseen_points)?;
    Ok(d)
}

/// `femto ingest CAPTURE.hdf5 -o OUT` of a y-tal capture.
#[pyfunction]
#[pyo3(signature = (source, out, saturation))]
pub fn ingest_tal<'py>(
    py: Python<'py>,
    source: PathBuf,
    out: PathBuf,
    saturation: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let p = Provenance::new(provenance("ingest"));
    let cube = py
        .detach(|| {
            femto::interop::ingest_tal(&source, &out, saturation.map(SaturationInput::Level), &p)
        })
        .py_err()?;
    cube_figures(py, &out, &cube)
}

fn cube_figures<'py>(
    py: Python<'py>,
    out: &Path,
    cube: &femto::cube::Cube,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("path", out)?;
    d.set_item("shape", cube.shape())?;
    d.set_item("t0_ps", cube.axis.t0_ps)?;
    d.set_item("dt_ps", cube.axis.dt_ps)?;
    d.set_item("clock", cube.frame.as_str())?;
    Ok(d)
}

/// `femto ingest RENDER.npy --start-opl-m --bin-width-opl-m -o OUT` of a mitransient
/// array `(H, W, T, C)`.
#[pyfunction]
#[pyo3(signature = (source, out, start_opl_m, bin_width_opl_m, channels, opl_clock))]
pub fn ingest_mitransient<'py>(
    py: Python<'py>,
    source: PathBuf,
    out: PathBuf,
    start_opl_m: f64,
    bin_width_opl_m: f64,
    channels: &str,
    opl_clock: &str,
) -> PyResult<Bound<'py, PyDict>> {
    use femto::interop::mitransient::{Channels, OplBinning};
    let channels = match channels {
        "mean" => Channels::Mean,
        "r" => Channels::R,
        "g" => Channels::G,
        "b" => Channels::B,
        "luminance" => Channels::Luminance,
        other => {
            return Err(value_error(format!(
                "--channels {other}: expected mean, r, g, b or luminance"
            )))
        }
    };
    let frame = TimeFrame::parse(opl_clock)
        .ok_or_else(|| value_error(format!("--opl-clock {opl_clock}: expected camera or world")))?;
    let binning = OplBinning {
        start_opl_m,
        bin_width_opl_m,
    };
    let p = Provenance::new(provenance("ingest"));
    let cube = py
        .detach(|| femto::interop::ingest_mitransient(&source, &out, binning, channels, frame, &p))
        .py_err()?;
    cube_figures(py, &out, &cube)
}
