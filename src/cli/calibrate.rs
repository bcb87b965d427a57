//! `femto calibrate CUBE.h5 --mesh MESH --points POINTS [--laser X,Y,Z] [--intrinsics CAL.toml]`:
//! fit the capture camera to 2D-3D correspondences, register every pixel to the mesh, fit the
//! time offset from the cube's direct light (first arrivals, then direct-light centroids over
//! each pixel's footprint), then write the calibration TOML and the cube's
//! `registration` group, and print the report.
//!
//! Flags map onto [`femto::pipeline::calibrate::CalibrateOptions`]; the stage is
//! [`femto::pipeline::calibrate::calibrate_cube`] and
//! [`femto::pipeline::calibrate::write_calibration`] (both files or neither).

use clap::Args;
use femto::calibrate::load_points;
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::pipeline::calibrate::{
    calibrate_cube, default_calibration_path, laser_spot, read_intrinsics, write_calibration,
    CalibrateOptions, Calibrated, DetectionFloor, NOISE_SIGMAS,
};
use femto::pipeline::StageError;
use femto::store::registration;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct CalibrateArgs {
    /// The camera-time cube to calibrate (.h5); its `registration` group is (re)written.
    pub cube: PathBuf,
    /// The scene's mesh (.obj, .gltf or .glb), in metres.
    #[arg(long)]
    pub mesh: PathBuf,
    /// 2D-3D correspondences, .toml or .csv (pixel x, y; mesh point X, Y, Z in metres).
    #[arg(long)]
    pub points: PathBuf,
    /// The laser spot on the scene, mesh frame, metres: X,Y,Z. Required unless the
    /// --intrinsics file has a [laser] section.
    #[arg(long, value_parser = super::values::point, allow_hyphen_values = true)]
    pub laser: Option<[f64; 3]>,
    /// Known intrinsics: a calibration TOML whose [intrinsics] table is used (its [laser] and
    /// [medium] too, unless --laser or --eta are given). Only the pose is fitted then, from
    /// 4 points or more.
    #[arg(long)]
    pub intrinsics: Option<PathBuf>,
    /// Refractive index of the medium [default: 1, or the --intrinsics file's medium].
    #[arg(long)]
    pub eta: Option<f64>,
    /// Unknown intrinsics: constrain fx = fy.
    #[arg(long, conflicts_with = "intrinsics")]
    pub square_pixels: bool,
    /// Unknown intrinsics: fix the principal point at the image centre.
    #[arg(long, conflicts_with = "intrinsics")]
    pub centred_principal_point: bool,
    /// Unknown intrinsics: fit the radial distortion k1, k2 too (10 points or more).
    #[arg(long, conflicts_with = "intrinsics")]
    pub fit_distortion: bool,
    /// Fit a time-scale factor of the sweep besides the time offset t0.
    #[arg(long)]
    pub fit_time_scale: bool,
    /// Keep points flagged as outliers in the camera fit (they are still reported).
    #[arg(long)]
    pub keep_outliers: bool,
    /// First-arrival detection (the first pass of the time fit): the direct pulse is searched
    /// from the first bin at or above this fraction of a pixel's maximum.
    #[arg(long, default_value_t = CalibrateOptions::default().threshold_fraction)]
    pub threshold: f64,
    /// Time fit: skip pixels whose maximum is below this value, in the cube's value units
    /// [default: 20 times the cube's noise, its values' robust standard deviation, so that a
    /// noise spike does not pass for a first arrival]. The fit is checked with this floor
    /// doubled and refused (exit 2) when t0 depends on it.
    #[arg(long)]
    pub min_peak: Option<f32>,
    /// Where to write the calibration TOML [default: next to the cube, <stem>.calibration.toml].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the --out file if it exists (without it, refused). The cube's registration
    /// group always follows the calibration written last.
    #[arg(long)]
    pub force: bool,
}

/// Above this many correspondences the report lists only the worst (and every outlier).
const MAX_POINTS_LISTED: usize = 40;

pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| default_calibration_path(&args.cube));
    let mut inputs = vec![
        args.cube.as_path(),
        args.mesh.as_path(),
        args.points.as_path(),
    ];
    inputs.extend(args.intrinsics.as_deref());
    femto::pipeline::overwrite::refuse_existing(&out, &inputs, args.force, "out")?;
    let meta = femto::container::read_meta(&args.cube)?;
    // The input files before the values: a missing mesh is named as missing, whatever
    // else is wrong.
    let bvh = Bvh::new(load_mesh(&args.mesh)?);
    let points = load_points(&args.points)?;
    let (intrinsics, file_laser, file_eta) = match &args.intrinsics {
        Some(p) => {
            let known = read_intrinsics(p, meta.nx, meta.ny)?;
            let laser = known.laser_m.map(|l| l.coords.into());
            (Some(known.intrinsics), laser, known.eta)
        }
        None => (None, None, None),
    };
    let laser_m = laser_spot(args.laser, file_laser)?;
    let options = CalibrateOptions {
        intrinsics,
        square_pixels: args.square_pixels,
        centred_principal_point: args.centred_principal_point,
        fit_distortion: args.fit_distortion,
        keep_outliers: args.keep_outliers,
        eta: args
            .eta
            .or(file_eta)
            .unwrap_or(CalibrateOptions::default().eta),
        fit_time_scale: args.fit_time_scale,
        threshold_fraction: args.threshold,
        floor: match args.min_peak {
            Some(v) => DetectionFloor::Level(v),
            None => CalibrateOptions::default().floor,
        },
    };
    let result = calibrate_cube(
        &args.cube,
        &bvh,
        &points,
        laser_m,
        &options,
        &super::Bar::default(),
    )
    .map_err(|e| match e {
        StageError::Points { source } => {
            anyhow::Error::new(source).context(args.points.display().to_string())
        }
        StageError::NothingSeen => anyhow::anyhow!("{}: {e}", args.mesh.display()),
        other => other.into(),
    })?;
    let header = format!("# made by: {}\n", super::command_line().replace('\n', " "));
    let mesh_name = args.mesh.display().to_string();
    let mut inputs = vec![args.mesh.as_path(), args.points.as_path()];
    inputs.extend(args.intrinsics.as_deref());
    write_calibration(
        &args.cube,
        &result,
        points.len(),
        &mesh_name,
        &out,
        &inputs,
        &header,
    )?;
    print!("{}", report(&args, &meta, &bvh, &points, &result, &out));
    for w in &result.warnings {
        eprintln!("femto calibrate: warning: {w}");
    }
    Ok(())
}

/// The report printed after a calibration: the inputs, the camera fit, the registration and
/// the time fit, each in print order.
fn report(
    args: &CalibrateArgs,
    meta: &femto::container::CubeMeta,
    bvh: &Bvh,
    points: &[femto::calibrate::Correspondence],
    result: &Calibrated,
    out: &Path,
) -> String {
    let mut lines = vec![
        format!(
            "calibration of {} ({} x {} pixels) against {} ({} triangles)",
            args.cube.display(),
            meta.nx,
            meta.ny,
            args.mesh.display(),
            bvh.mesh().triangle_count()
        ),
        format!(
            "{} points from {}; intrinsics {}{}",
            points.len(),
            args.points.display(),
            if result.spatial.intrinsics_fitted {
                "fitted"
            } else {
                "known"
            },
            match (args.fit_distortion, result.spatial.distortion_fitted) {
                (_, true) => ", distortion fitted",
                (true, false) => ", distortion not fitted (needs 10 points or more)",
                _ => "",
            }
        ),
    ];
    lines.extend(point_lines(args, points, &result.spatial));
    lines.extend(camera_lines(meta, result));
    lines.extend(time_lines(args, meta, result));
    lines.push(format!(
        "wrote {} and the /{} group of {}",
        out.display(),
        registration::GROUP,
        args.cube.display()
    ));
    lines.iter().map(|l| format!("{l}\n")).collect()
}

/// The correspondences' reprojection errors (every point when there are few; else the
/// outliers and the worst of the others) and their summary.
fn point_lines(
    args: &CalibrateArgs,
    points: &[femto::calibrate::Correspondence],
    fit: &femto::calibrate::SpatialFit,
) -> Vec<String> {
    let mut lines = Vec::new();
    let mut shown: Vec<usize> = (0..points.len()).collect();
    if points.len() > MAX_POINTS_LISTED {
        shown.sort_by(|&a, &b| fit.per_point_px[b].total_cmp(&fit.per_point_px[a]));
        let keep = fit.outliers.len().max(MAX_POINTS_LISTED / 2);
        shown.truncate(keep);
        shown.sort_unstable();
        lines.push(format!(
            "{} points; the {} with the largest errors:",
            points.len(),
            shown.len()
        ));
    }
    lines.push(format!(
        "{:>5}  {:<24} {:>10} {:>10} {:>10}",
        "#", "point", "x_px", "y_px", "error_px"
    ));
    for i in shown {
        let (p, e) = (&points[i], fit.per_point_px[i]);
        let flag = if fit.outliers.contains(&i) {
            "  OUTLIER"
        } else {
            ""
        };
        lines.push(format!(
            "{:>5}  {:<24} {:>10.2} {:>10.2} {:>10.3}{flag}",
            i + 1,
            p.name.as_deref().unwrap_or("-"),
            p.pixel.0,
            p.pixel.1,
            e
        ));
    }
    lines.push(format!(
        "reprojection: rms {:.3} px, median {:.3} px over the points used; outlier threshold {:.2} px; {} outlier(s){}",
        fit.rms_px,
        fit.median_px,
        fit.outlier_threshold_px,
        fit.outliers.len(),
        if fit.outliers.is_empty() || args.keep_outliers {
            ""
        } else {
            " (left out of the fit)"
        }
    ));
    lines
}

/// The camera found and the pixels it registers to the mesh.
fn camera_lines(meta: &femto::container::CubeMeta, result: &Calibrated) -> Vec<String> {
    let cal = &result.calibration;
    let reg = &result.registration;
    let k = &cal.intrinsics;
    let o = cal.pose.position_m;
    let f = cal.pose.forward();
    let hits = reg.hit_count();
    let (dmin, dmax) = registration::dist_range_m(reg).unwrap_or((f32::NAN, f32::NAN));
    vec![
        format!(
            "camera: centre ({:.4}, {:.4}, {:.4}) m, looking along ({:.4}, {:.4}, {:.4})",
            o.x, o.y, o.z, f.x, f.y, f.z
        ),
        format!(
            "intrinsics: fx {:.3} fy {:.3} cx {:.3} cy {:.3} px, k1 {:.5} k2 {:.5}",
            k.fx, k.fy, k.cx, k.cy, k.k1, k.k2
        ),
        format!(
            "registration: {hits} of {} pixels see the mesh ({:.1} %), distance {dmin:.4} .. {dmax:.4} m",
            meta.nx * meta.ny,
            100.0 * hits as f64 / (meta.nx * meta.ny) as f64
        ),
    ]
}

/// The time fit: `t0`, its residuals, the scanline offsets and the detection floor with its
/// check.
fn time_lines(
    args: &CalibrateArgs,
    meta: &femto::container::CubeMeta,
    result: &Calibrated,
) -> Vec<String> {
    let tfit = &result.time.fit;
    let mut lines = vec![
        format!(
            "time: t0 {:.3} +- {:.3} ps (bin coordinate {:.4} on the cube's axis of {} ps bins), time scale {}{}",
            tfit.t0_ps,
            result.time.t0_std_error_ps,
            meta.axis.bin_coord(tfit.t0_ps),
            meta.axis.dt_ps,
            tfit.time_scale,
            if args.fit_time_scale {
                " (fitted)"
            } else {
                " (fixed)"
            }
        ),
        format!(
            "time residuals: rms {:.3} ps over {} inliers of {} pixels with direct light, robust sigma {:.3} ps",
            tfit.rms_ps,
            tfit.inlier_count(),
            result.time.samples,
            tfit.sigma_ps
        ),
    ];
    lines.extend(result.scanline_report.lines());
    lines.push(format!(
        "detection floor {:.4} ({}; the cube's noise sigma {:.4}); check with the floor at {:.4}: t0 {:.3} ps over {} pixels",
        result.time.floor,
        match args.min_peak {
            Some(_) => "--min-peak".to_string(),
            None => format!("{NOISE_SIGMAS} x noise"),
        },
        result.noise_sigma,
        result.check.floor,
        result.check.fit.t0_ps,
        result.check.samples
    ));
    lines
}
