//! `femto calibrate CUBE.h5 --mesh MESH --points POINTS [--laser X,Y,Z] [--intrinsics CAL.toml]`:
//! fit the capture camera to 2D-3D correspondences, register every pixel to the mesh, fit the
//! time offset from the cube's direct light (first arrivals, then direct-light centroids over
//! each pixel's footprint), then write the calibration TOML and the cube's
//! `registration` group, and print the report.
//!
//! Glue only: the fits are [`femto::calibrate`], the group schema [`femto::store::registration`].

use anyhow::{bail, Context};
use clap::Args;
use femto::calibrate::{
    arrival_samples, direct_arrival_samples, fit_camera, fit_direct_time, footprints, load_points,
    register, ArrivalOptions, ArrivalSample, CalibrateError, Footprints, Registration,
    SpatialOptions,
};
use femto::camera::{one_line_toml_error, Intrinsics, LaserFile, MediumFile};
use femto::container::{self, CubeReader};
use femto::cube::{Cube, TimeFrame};
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::store::registration::{self, FitSummary};
use nalgebra::Point3;
use serde::Deserialize;
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
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
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
    #[arg(long, default_value_t = 0.3)]
    pub threshold: f64,
    /// Time fit: skip pixels whose maximum (over the direct-light window, after the first
    /// pass) is below this value.
    #[arg(long, default_value_t = 0.0)]
    pub min_peak: f32,
    /// Where to write the calibration TOML [default: next to the cube, <stem>.calibration.toml].
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Parse "x,y,z" (metres).
pub fn parse_point(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("'{s}' is not X,Y,Z in metres: {e}"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("'{s}' is not three finite numbers X,Y,Z")),
    }
}

/// The parts of a calibration TOML that `--intrinsics` uses (other tables are ignored).
#[derive(Deserialize)]
struct IntrinsicsFile {
    intrinsics: Intrinsics,
    #[serde(default)]
    laser: Option<LaserFile>,
    #[serde(default)]
    medium: Option<MediumFile>,
}

fn read_intrinsics(
    path: &Path,
    nx: usize,
    ny: usize,
) -> anyhow::Result<(Intrinsics, Option<[f64; 3]>, Option<f64>)> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).with_context(|| name.clone())?;
    let file: IntrinsicsFile = toml::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{name}: {}", one_line_toml_error(&e, &text)))?;
    let k = file.intrinsics;
    for (key, v) in [("fx", k.fx), ("fy", k.fy)] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name}: intrinsics.{key} must be a positive number, got {v}");
        }
    }
    if (k.width, k.height) != (nx, ny) {
        bail!(
            "{name}: the intrinsics are for {} x {} pixels but the cube is {nx} x {ny}",
            k.width,
            k.height
        );
    }
    Ok((
        k,
        file.laser.map(|l| l.position_m),
        file.medium.map(|m| m.eta),
    ))
}

/// The calibration TOML's default path: `<dir>/<stem>.calibration.toml`.
fn default_out(cube: &Path) -> PathBuf {
    let stem = cube
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "cube".into());
    cube.with_file_name(format!("{stem}.calibration.toml"))
}

/// The time samples of one pass of [`fit_direct_time`], streaming the cube by row slabs:
/// first arrivals (`model` None) or direct-light centroids under `model = (t0_ps, scale)`.
fn time_samples(
    reader: &CubeReader,
    reg: &Registration,
    prints: &Footprints,
    laser_m: &Point3<f64>,
    eta: f64,
    model: Option<(f64, f64)>,
    options: &ArrivalOptions,
) -> anyhow::Result<Vec<ArrivalSample>> {
    let meta = reader.meta();
    let (nx, ny) = (meta.nx, meta.ny);
    let mask = reader.read_mask()?;
    let rows_per_slab = ((32usize << 20) / (meta.row_len() * 4)).clamp(1, ny);
    let what = if model.is_some() {
        "direct light"
    } else {
        "first arrivals"
    };
    let bar = super::progress(ny as u64, what);
    let mut samples = Vec::new();
    for y0 in (0..ny).step_by(rows_per_slab) {
        let n = rows_per_slab.min(ny - y0);
        let (a, b) = (y0 * nx, (y0 + n) * nx);
        let slab = Cube {
            nx,
            ny: n,
            axis: meta.axis,
            frame: meta.frame,
            data: reader.read_rows(y0, n)?,
            mask: mask.as_ref().map(|m| m[a..b].to_vec()),
        };
        let found = match model {
            None => {
                let slab_reg = Registration {
                    nx,
                    ny: n,
                    camera_m: reg.camera_m,
                    point_m: reg.point_m[a..b].to_vec(),
                    dist_m: reg.dist_m[a..b].to_vec(),
                    normal: reg.normal[a..b].to_vec(),
                    triangle: reg.triangle[a..b].to_vec(),
                    mask: reg.mask[a..b].to_vec(),
                };
                arrival_samples(&slab, &slab_reg, laser_m, options)?
            }
            Some((t0_ps, scale)) => {
                direct_arrival_samples(&slab, &prints.rows(y0, n), eta, t0_ps, scale, options)?
            }
        };
        samples.extend(
            found
                .into_iter()
                .map(|s| ArrivalSample { y: s.y + y0, ..s }),
        );
        bar.set_position((y0 + n) as u64);
    }
    bar.finish_and_clear();
    Ok(samples)
}

pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let reader = CubeReader::open(&args.cube)?;
    let meta = reader.meta().clone();
    if meta.frame != TimeFrame::Camera {
        return Err(anyhow::Error::new(CalibrateError::WorldTimeCube)
            .context(args.cube.display().to_string()));
    }
    if !(args.threshold > 0.0 && args.threshold <= 1.0) {
        bail!("--threshold must be in (0, 1], got {}", args.threshold);
    }
    let points = load_points(&args.points)?;
    let (mut options, file_laser, file_eta) = match &args.intrinsics {
        Some(p) => {
            let (k, laser, eta) = read_intrinsics(p, meta.nx, meta.ny)?;
            (SpatialOptions::known_intrinsics(k), laser, eta)
        }
        None => (
            SpatialOptions::unknown_intrinsics(meta.nx, meta.ny),
            None,
            None,
        ),
    };
    options.square_pixels = args.square_pixels;
    options.principal_point_at_centre = args.centred_principal_point;
    options.fit_distortion = args.fit_distortion;
    options.reject_outliers = !args.keep_outliers;
    let laser_m = match args.laser.or(file_laser) {
        Some(l) => Point3::from(l),
        None => bail!(
            "the laser spot is unknown: give --laser X,Y,Z (metres, mesh frame), or an \
             --intrinsics file with a [laser] section"
        ),
    };
    let eta = args.eta.or(file_eta).unwrap_or(1.0);
    if !(eta.is_finite() && eta >= 1.0) {
        bail!("--eta must be a number >= 1, got {eta}");
    }

    let fit =
        fit_camera(&points, &options).with_context(|| format!("{}", args.points.display()))?;
    let mesh = load_mesh(&args.mesh)?;
    let bvh = Bvh::new(mesh);
    let spatial = fit.calibration(0.0, 1.0, laser_m, eta);
    let reg = register(&spatial, &bvh, meta.nx, meta.ny)?;
    if reg.hit_count() == 0 {
        bail!(
            "{}: no pixel of the fitted camera sees the mesh; check that the points and the \
             mesh use the same frame and units",
            args.mesh.display()
        );
    }
    let arrival = ArrivalOptions {
        threshold_fraction: args.threshold,
        min_peak: args.min_peak,
        ..ArrivalOptions::default()
    };
    let prints = footprints(&reg, &laser_m);
    let (tfit, samples) = fit_direct_time(eta, args.fit_time_scale, &mut |model| {
        time_samples(&reader, &reg, &prints, &laser_m, eta, model, &arrival)
    })
    .with_context(|| format!("{}", args.cube.display()))?;
    drop(reader);
    let cal = fit.calibration(tfit.t0_ps, tfit.time_scale, laser_m, eta);

    let summary = FitSummary {
        points: points.len(),
        outliers: fit.outliers.len(),
        reprojection_rms_px: fit.rms_px,
        time_samples: samples.len(),
        time_inliers: tfit.inlier_count(),
        time_residual_rms_ps: tfit.rms_ps,
    };
    let mesh_name = args.mesh.display().to_string();
    let group = registration::registration_group(&reg, &cal, &mesh_name, Some(&summary));
    container::write_groups(&args.cube, &[(registration::GROUP, group)])?;
    let out = args.out.clone().unwrap_or_else(|| default_out(&args.cube));
    let text = format!(
        "# made by: {}\n{}",
        super::command_line().replace('\n', " "),
        cal.to_toml()
    );
    femto::atomic::write_atomically(&out, |tmp| std::fs::write(tmp, &text))
        .with_context(|| out.display().to_string())?;

    // The report.
    let mut r = String::new();
    let mut line = |s: String| {
        r.push_str(&s);
        r.push('\n');
    };
    line(format!(
        "calibration of {} ({} x {} pixels) against {} ({} triangles)",
        args.cube.display(),
        meta.nx,
        meta.ny,
        args.mesh.display(),
        bvh.mesh().triangle_count()
    ));
    line(format!(
        "{} points from {}; intrinsics {}{}",
        points.len(),
        args.points.display(),
        if fit.intrinsics_fitted {
            "fitted"
        } else {
            "known"
        },
        match (args.fit_distortion, fit.distortion_fitted) {
            (_, true) => ", distortion fitted",
            (true, false) => ", distortion not fitted (needs 10 points or more)",
            _ => "",
        }
    ));
    line(format!(
        "{:>5}  {:<24} {:>10} {:>10} {:>10}",
        "#", "point", "x_px", "y_px", "error_px"
    ));
    for (i, (p, e)) in points.iter().zip(&fit.per_point_px).enumerate() {
        let flag = if fit.outliers.contains(&i) {
            "  OUTLIER"
        } else {
            ""
        };
        line(format!(
            "{:>5}  {:<24} {:>10.2} {:>10.2} {:>10.3}{flag}",
            i + 1,
            p.name.as_deref().unwrap_or("-"),
            p.pixel.0,
            p.pixel.1,
            e
        ));
    }
    line(format!(
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
    let k = &cal.intrinsics;
    let o = cal.pose.position_m;
    let f = cal.pose.forward();
    line(format!(
        "camera: centre ({:.4}, {:.4}, {:.4}) m, looking along ({:.4}, {:.4}, {:.4})",
        o.x, o.y, o.z, f.x, f.y, f.z
    ));
    line(format!(
        "intrinsics: fx {:.3} fy {:.3} cx {:.3} cy {:.3} px, k1 {:.5} k2 {:.5}",
        k.fx, k.fy, k.cx, k.cy, k.k1, k.k2
    ));
    let hits = reg.hit_count();
    let (dmin, dmax) = registration::dist_range_m(&reg).unwrap_or((f32::NAN, f32::NAN));
    line(format!(
        "registration: {hits} of {} pixels see the mesh ({:.1} %), distance {dmin:.4} .. {dmax:.4} m",
        meta.nx * meta.ny,
        100.0 * hits as f64 / (meta.nx * meta.ny) as f64
    ));
    line(format!(
        "time: t0 {:.3} ps (bin coordinate {:.4} on the cube's axis of {} ps bins), time scale {}{}",
        tfit.t0_ps,
        meta.axis.bin_coord(tfit.t0_ps),
        meta.axis.dt_ps,
        tfit.time_scale,
        if args.fit_time_scale {
            " (fitted)"
        } else {
            " (fixed)"
        }
    ));
    line(format!(
        "time residuals: rms {:.3} ps over {} inliers of {} pixels with direct light, robust sigma {:.3} ps",
        tfit.rms_ps,
        tfit.inlier_count(),
        samples.len(),
        tfit.sigma_ps
    ));
    line(format!(
        "wrote {} and the /{} group of {}",
        out.display(),
        registration::GROUP,
        args.cube.display()
    ));
    print!("{r}");
    Ok(())
}
