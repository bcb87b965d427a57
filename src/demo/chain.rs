//! One scene through the chain: simulate, ingest, calibrate, unwarp, pyramid; and the errors
//! of the fitted calibration against the simulator's truth.
//!
//! Calibration (seed Sec. 3; [`crate::calibrate`]):
//!
//! - Spatial: the fiducial markers' true pixel positions, with 0.5 px of seeded Gaussian noise
//!   added to each coordinate (the noise the calibrate issue's tolerances are stated for), are
//!   fitted for the pose and the focal length, with square pixels and the principal point at
//!   the image centre (both true of the simulated camera; with `cx, cy` free the principal
//!   point trades off against the rotation, which then misses 0.05 degrees). The markers are
//!   "detected" in an image of [`DemoSizes::fiducial_nx`] x [`DemoSizes::fiducial_ny`] pixels
//!   taken from the capture camera's pose with its field of view (a lab photographs its
//!   markers with a camera of its own), and the fitted intrinsics are scaled to the capture's
//!   size. Why so large an image: the fit's depth error shifts the fitted `t0` by the same
//!   amount of flight time (every direct path changes by it), and the t0 tolerance, a tenth of
//!   a 4 ps bin, is 0.12 mm of path. Measured over 8 noise seeds on the cube scene (1388 to
//!   1426 markers, 160 x 120 x 256 capture at 16 spp, no capture flaws), RMS / worst:
//!   - 672 x 504: position 0.27 / 0.42 mm/m, rotation 0.005 / 0.008 deg, focal 0.03 / 0.05 %,
//!     t0 0.19 / 0.31 bins (0.02 bins through the true camera);
//!   - 2688 x 2016: position 0.08 / 0.15 mm/m, t0 0.06 / 0.11 bins;
//!   - 4032 x 3024: position 0.05 / 0.10 mm/m, rotation 0.001 deg, focal 0.005 / 0.011 %,
//!     t0 0.045 / 0.078 bins (the demo's choice).
//!
//!   At the capture's own size each pixel spans several bins of arrival times (64 x 48: 5
//!   bins of 4 ps typically): the first arrival alone is 0.35 to 0.6 bins early even through
//!   the true camera, which the direct-light centroid over each pixel's footprint corrects
//!   (0.01 to 0.03 bins through the true camera on the true cube at 4 to 64 spp).
//! - Temporal: the direct light in every pixel of the ingested cube that sees the mesh
//!   (through the fitted camera), first arrivals and then centroids over each pixel's
//!   footprint ([`crate::calibrate::calibrate_time`]), fitted to
//!   `t_first = t0 + eta (|laser - p| + |p - o|) / c` ([`crate::calibrate::temporal`]).
//!
//! Errors ([`CalibrationErrors`]): the camera centre's distance from the truth in mm per metre
//! of the distance from the true camera to the fiducials' centroid; the angle of the rotation
//! between the fitted and the true orientation, degrees; the larger relative error of `fx`
//! and `fy`, percent; `|t0 - t0_true|` in time bins of the ingested cube.

use super::{DemoError, DemoSizes, Stages};
use crate::calibrate::{
    calibrate_time, fit_camera, load_points, register, ArrivalOptions, Correspondence,
    SpatialOptions,
};
use crate::camera::{Calibration, Intrinsics};
use crate::container::{read_cube, write_cube, CubeCompression, Provenance};
use crate::cube::Cube;
use crate::formats::read_streak;
use crate::geometry::bvh::Bvh;
use crate::geometry::load::load_mesh;
use crate::ingest::assemble::ingest;
use crate::ingest::plan::{
    DarkInput, IngestOptions, IngestPlan, InputSpec, PowerRef, SaturationInput,
};
use crate::manifest::Manifest;
use crate::pyramid::Pyramid;
use crate::render::RenderScene;
use crate::scene::Scene;
use crate::simulate::{simulate_capture, Flaws, SimulateOptions};
use crate::unwarp::{unwarp_cube, Direction};
use nalgebra::Point3;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Noise added to each fiducial pixel coordinate, pixels (standard deviation).
pub const FIDUCIAL_NOISE_PX: f64 = 0.5;
/// Seed of that noise (and of the simulated capture).
pub const DEMO_SEED: u64 = 20130721;

/// The calibrate issue's tolerances.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tolerances {
    /// Camera position, mm per metre of camera distance.
    pub position_mm_per_m: f64,
    /// Camera orientation, degrees.
    pub rotation_deg: f64,
    /// Focal length, percent.
    pub focal_percent: f64,
    /// Time origin, time bins.
    pub t0_bins: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            position_mm_per_m: 1.0,
            rotation_deg: 0.05,
            focal_percent: 0.2,
            t0_bins: 0.1,
        }
    }
}

/// A fitted calibration compared with the truth (module doc).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CalibrationErrors {
    /// The scene (`cube`, `bunny`).
    pub scene: String,
    /// Fiducials fitted, and the image size they were detected in.
    pub fiducials: usize,
    pub fiducial_width: usize,
    pub fiducial_height: usize,
    /// Noise added to each pixel coordinate, pixels.
    pub noise_px: f64,
    /// Outliers flagged by the fit.
    pub outliers: usize,
    /// RMS reprojection error of the fit, pixels of the fiducial image.
    pub rms_px: f64,
    /// True camera centre to the fiducials' centroid, metres.
    pub camera_distance_m: f64,
    pub position_error_mm: f64,
    pub position_error_mm_per_m: f64,
    pub rotation_error_deg: f64,
    pub focal_error_percent: f64,
    /// Fitted and true time origin, ps; the cube's bin width; their difference in bins.
    pub t0_fit_ps: f64,
    pub t0_true_ps: f64,
    pub dt_ps: f64,
    pub t0_error_bins: f64,
    /// The temporal stage alone: `|t0 - t0_true|` in bins when the direct light is fitted
    /// through the true camera instead of the fitted one (how the calibrate issue states the
    /// t0 tolerance). The difference from `t0_error_bins` is the camera's depth error, which
    /// shifts every direct path and so `t0` by `eta * error / c`.
    pub t0_true_camera_error_bins: f64,
    /// Direct-light samples of the temporal fit, inliers among them, and the fit's RMS, ps.
    pub arrival_samples: usize,
    pub arrival_inliers: usize,
    pub t0_rms_ps: f64,
    /// Whether every error is within [`Tolerances::default`].
    pub within_tolerance: bool,
}

impl CalibrationErrors {
    /// Whether every error is within `tol`.
    pub fn check(&self, tol: &Tolerances) -> bool {
        self.position_error_mm_per_m <= tol.position_mm_per_m
            && self.rotation_error_deg <= tol.rotation_deg
            && self.focal_error_percent <= tol.focal_percent
            && self.t0_error_bins <= tol.t0_bins
    }
}

/// The spatial fit of the demo: unknown intrinsics with square pixels and the principal point
/// at the image centre (both true of the simulated camera), no distortion, outliers rejected.
pub fn spatial_options(sizes: &DemoSizes) -> SpatialOptions {
    SpatialOptions {
        square_pixels: true,
        principal_point_at_centre: true,
        ..SpatialOptions::unknown_intrinsics(sizes.fiducial_nx, sizes.fiducial_ny)
    }
}

/// Position (mm), position per camera distance (mm/m), rotation (deg) and focal (%) errors of
/// `fit` against `truth`; the distance is from the true camera to `centroid_m`.
pub fn spatial_errors(
    fit: &Calibration,
    truth: &Calibration,
    centroid_m: &Point3<f64>,
) -> (f64, f64, f64, f64) {
    let distance_m = (centroid_m - truth.pose.position_m).norm();
    let position_mm = 1e3 * (fit.pose.position_m - truth.pose.position_m).norm();
    let relative = fit.pose.world_from_camera.inverse() * truth.pose.world_from_camera;
    let rotation_deg = relative.angle().to_degrees();
    let (kf, kt) = (&fit.intrinsics, &truth.intrinsics);
    let focal_percent = 100.0 * ((kf.fx - kt.fx).abs() / kt.fx).max((kf.fy - kt.fy).abs() / kt.fy);
    (
        position_mm,
        position_mm / distance_m,
        rotation_deg,
        focal_percent,
    )
}

/// Intrinsics fitted on a `from_w x from_h` image, for a `to_w x to_h` image of the same field
/// of view: continuous pixel coordinates scale by `to / from` (pixel edges at integers in both
/// images), distortion (in normalised coordinates) is unchanged.
pub fn scale_intrinsics(k: &Intrinsics, to_w: usize, to_h: usize) -> Intrinsics {
    let sx = to_w as f64 / k.width as f64;
    let sy = to_h as f64 / k.height as f64;
    Intrinsics {
        width: to_w,
        height: to_h,
        fx: k.fx * sx,
        fy: k.fy * sy,
        cx: k.cx * sx,
        cy: k.cy * sy,
        k1: k.k1,
        k2: k.k2,
    }
}

/// `points` with seeded Gaussian noise of `sigma_px` added to each pixel coordinate.
pub fn add_pixel_noise(points: &[Correspondence], sigma_px: f64, seed: u64) -> Vec<Correspondence> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let normal = Normal::new(0.0, sigma_px).expect("a finite, non-negative sigma");
    points
        .iter()
        .map(|c| Correspondence {
            pixel: (
                c.pixel.0 + normal.sample(&mut rng),
                c.pixel.1 + normal.sample(&mut rng),
            ),
            ..c.clone()
        })
        .collect()
}

/// What the chain leaves for the renderer.
pub struct Chain {
    pub scene_name: String,
    /// The capture's mesh (read back from the capture folder).
    pub bvh: Bvh,
    /// The fitted calibration (capture size).
    pub calibration: Calibration,
    /// Prefix sums of the unwarped (world-time) cube.
    pub world: Pyramid,
    pub laser_nm: f64,
    pub errors: CalibrationErrors,
    /// Files written under the data folder.
    pub data_files: Vec<PathBuf>,
}

impl Chain {
    /// The renderer's view of this chain's result.
    pub fn render_scene(&self) -> Result<RenderScene<'_>, DemoError> {
        Ok(RenderScene::new(
            &self.bvh,
            self.calibration,
            &self.world,
            self.laser_nm,
        )?)
    }
}

/// File names under a chain's data folder.
pub const CAPTURE_DIR: &str = "capture";
pub const CUBE_FILE: &str = "cube.h5";
pub const WORLD_FILE: &str = "world.h5";
pub const CALIBRATION_FILE: &str = "calibration.toml";

/// Run `scene` (built-in, at its own size; resized here) through the chain, writing into
/// `data_dir`. `label` prefixes the stage names (`""` or `"bunny "`).
pub(crate) fn run_chain(
    scene: &Scene,
    sizes: &DemoSizes,
    data_dir: &Path,
    label: &str,
    stages: &mut Stages<'_>,
) -> Result<Chain, DemoError> {
    std::fs::create_dir_all(data_dir).map_err(|source| DemoError::Io {
        path: data_dir.to_path_buf(),
        source,
    })?;
    let scene = scene.with_resolution(sizes.capture_nx, sizes.capture_ny, sizes.nt, sizes.dt_ps);
    let capture_dir = data_dir.join(CAPTURE_DIR);
    let mut files = Vec::new();

    // 1. Simulate.
    let sim = stages.run(
        &format!("{label}simulate"),
        &format!(
            "{} scene, {}x{} pixels x {} bins of {} ps, {} spp, realistic flaws (low noise)",
            scene.name, sizes.capture_nx, sizes.capture_ny, sizes.nt, sizes.dt_ps, sizes.spp
        ),
        || {
            let opts = SimulateOptions {
                spp: sizes.spp,
                seed: DEMO_SEED,
                max_bounces: sizes.max_bounces,
                // The lab's averaged sweeps (module doc of `demo`).
                flaws: Flaws {
                    photon_noise: Some(30000.0),
                    dark: Some((0.01, 0.001)),
                    ..Flaws::realistic()
                },
                force: true,
                created_by: "femto demo".into(),
                ..SimulateOptions::default()
            };
            Ok(simulate_capture(&scene, &opts, &capture_dir, &|_, _| {})?)
        },
    )?;
    files.push(capture_dir.clone());

    // 2. Ingest.
    let cube_path = data_dir.join(CUBE_FILE);
    let sweep_path = data_dir.join(SWEEP_TABLE_FILE);
    let cube = stages.run(
        &format!("{label}ingest"),
        if INGEST_JITTER {
            "dark frame, flat field, sweep table, jitter, laser power, saturation"
        } else {
            "dark frame, flat field, sweep table, laser power, saturation (jitter left in)"
        },
        || ingest_capture(&capture_dir, &cube_path, &sweep_path),
    )?;
    if sweep_path.exists() {
        files.push(sweep_path);
    }
    files.push(cube_path);

    // 3. Calibrate.
    let truth = Calibration::load(&capture_dir.join(crate::simulate::capture::CALIBRATION_FILE))?;
    let mesh = load_mesh(&capture_dir.join(crate::simulate::capture::GEOMETRY_FILE))?;
    let bvh = Bvh::new(mesh);
    let calib_path = data_dir.join(CALIBRATION_FILE);
    let (calibration, registration, errors) = stages.run(
        &format!("{label}calibrate"),
        &format!(
            "camera from fiducials ({}x{} image, {FIDUCIAL_NOISE_PX} px noise), t0 from the direct light",
            sizes.fiducial_nx, sizes.fiducial_ny
        ),
        || {
            let points = if (sizes.fiducial_nx, sizes.fiducial_ny)
                == (sizes.capture_nx, sizes.capture_ny)
            {
                load_points(&capture_dir.join(crate::simulate::capture::FIDUCIALS_FILE))?
            } else {
                let hi = scene.with_resolution(
                    sizes.fiducial_nx,
                    sizes.fiducial_ny,
                    sizes.nt,
                    sizes.dt_ps,
                );
                let truth_bvh = Bvh::new(hi.mesh.clone());
                crate::simulate::fiducials::fiducials(
                    &hi,
                    &truth_bvh,
                    crate::simulate::fiducials::DEFAULT_MARKER_SPACING_M,
                )
            };
            let noisy = add_pixel_noise(&points, FIDUCIAL_NOISE_PX, DEMO_SEED);
            let fit = fit_camera(&noisy, &spatial_options(sizes))?;
            let mut cal = fit.calibration(0.0, 1.0, truth.laser_m, truth.eta);
            cal.intrinsics = scale_intrinsics(&fit.intrinsics, cube.nx, cube.ny);
            let reg = register(&cal, &bvh, cube.nx, cube.ny)?;
            let arrival = arrival_options(&cube);
            let (time, samples) =
                calibrate_time(&cube, &reg, &cal.laser_m, cal.eta, false, &arrival)?;
            cal.t0_ps = time.t0_ps;
            // The temporal stage alone: the same fit through the true camera.
            let true_reg = register(&truth, &bvh, cube.nx, cube.ny)?;
            let (true_time, _) =
                calibrate_time(&cube, &true_reg, &truth.laser_m, truth.eta, false, &arrival)?;
            let centroid = Point3::from(
                points.iter().map(|c| c.point_m.coords).sum::<nalgebra::Vector3<f64>>()
                    / points.len() as f64,
            );
            let (position_mm, position_mm_per_m, rotation_deg, focal_percent) =
                spatial_errors(&cal, &truth, &centroid);
            let t0_error_bins = (cal.t0_ps - truth.t0_ps).abs() / cube.axis.dt_ps;
            let mut errors = CalibrationErrors {
                scene: scene.name.clone(),
                fiducials: noisy.len(),
                fiducial_width: sizes.fiducial_nx,
                fiducial_height: sizes.fiducial_ny,
                noise_px: FIDUCIAL_NOISE_PX,
                outliers: fit.outliers.len(),
                rms_px: fit.rms_px,
                camera_distance_m: (centroid - truth.pose.position_m).norm(),
                position_error_mm: position_mm,
                position_error_mm_per_m: position_mm_per_m,
                rotation_error_deg: rotation_deg,
                focal_error_percent: focal_percent,
                t0_fit_ps: cal.t0_ps,
                t0_true_ps: truth.t0_ps,
                dt_ps: cube.axis.dt_ps,
                t0_error_bins,
                t0_true_camera_error_bins: (true_time.t0_ps - truth.t0_ps).abs()
                    / cube.axis.dt_ps,
                arrival_samples: samples.len(),
                arrival_inliers: time.inlier_count(),
                t0_rms_ps: time.rms_ps,
                within_tolerance: false,
            };
            errors.within_tolerance = errors.check(&Tolerances::default());
            let text = cal.to_toml();
            super::write_file(&calib_path, text.as_bytes())?;
            Ok((cal, reg, errors))
        },
    )?;
    files.push(calib_path);

    // 4. Unwarp.
    let world_path = data_dir.join(WORLD_FILE);
    let world_cube = stages.run(
        &format!("{label}unwarp"),
        "camera time to world time, t_world = t_camera - eta |p - o| / c",
        || {
            let world = unwarp_cube(
                &cube,
                &registration.dist_m,
                calibration.eta,
                Direction::CameraToWorld,
                None,
            )?;
            write_cube(
                &world_path,
                &world,
                &provenance("unwarped cube, world time"),
            )?;
            Ok(world)
        },
    )?;
    files.push(world_path);

    // 5. Pyramid.
    let world = stages.run(&format!("{label}pyramid"), "temporal prefix sums", || {
        Ok(Pyramid::build(&world_cube))
    })?;

    let _ = sim;
    Ok(Chain {
        scene_name: scene.name.clone(),
        bvh,
        calibration,
        world,
        laser_nm: scene.laser.wavelength_nm,
        errors,
        data_files: files,
    })
}

fn provenance(content: &str) -> Provenance {
    Provenance::new("femto demo").with_note("content", content)
}

/// The lab's sweep calibration of a simulated capture: the true bin edges the simulator
/// records in its manifest (`[imperfections.sweep] bin_times_ps`), written as a table for
/// ingest (one edge per line, ps).
pub const SWEEP_TABLE_FILE: &str = "sweep_table.txt";

/// Whether ingest estimates and removes trigger jitter (the per-pixel row-offset estimator of
/// [`crate::ingest::row_offsets`]: on the cube scene at 64 x 48 it leaves about 1 ps rms of a
/// 2 ps rms jitter, after its slow part, which no estimator can tell from the scene's tilt).
pub const INGEST_JITTER: bool = true;
/// Whether ingest normalises the laser power automatically (`femto ingest --power-ref auto`).
pub const INGEST_POWER_AUTO: bool = true;

/// Robust standard deviation of a cube's noise: 1.4826 times the median absolute deviation
/// of its values from their median, over a regular subsample of at most about 2^20 values.
/// Light fills few of the bins of a transient cube, so the statistic measures the noise of
/// the empty ones.
pub fn noise_sigma(cube: &Cube) -> f64 {
    let step = (cube.data.len() >> 20).max(1);
    let mut v: Vec<f64> = cube
        .data
        .iter()
        .step_by(step)
        .map(|&x| x as f64)
        .filter(|x| x.is_finite())
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let median = *v.select_nth_unstable_by(mid, f64::total_cmp).1;
    let mut dev: Vec<f64> = v.iter().map(|x| (x - median).abs()).collect();
    1.4826 * *dev.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// A pixel's direct pulse must peak at this many noise standard deviations for its first
/// arrival to be used (module doc).
pub const MIN_PEAK_SIGMAS: f64 = 20.0;

/// First-arrival detection for a noisy cube: the default search threshold (0.3 of a pixel's
/// maximum) and pixels skipped unless their maximum reaches [`MIN_PEAK_SIGMAS`] times the
/// cube's noise ([`noise_sigma`]), so that the threshold lies at 6 sigma and a noise spike
/// before the pulse does not pass for it.
pub fn arrival_options(cube: &Cube) -> ArrivalOptions {
    ArrivalOptions {
        min_peak: (MIN_PEAK_SIGMAS * noise_sigma(cube)) as f32,
        ..ArrivalOptions::default()
    }
}

/// Assemble the capture folder into `cube_path` (camera time) with the corrections of the
/// module doc. Returns the cube read back.
fn ingest_capture(
    capture_dir: &Path,
    cube_path: &Path,
    sweep_path: &Path,
) -> Result<Cube, DemoError> {
    let manifest_path = capture_dir.join(crate::simulate::capture::MANIFEST_FILE);
    let manifest = Manifest::load(&manifest_path)?;
    let mut options = IngestOptions {
        jitter: INGEST_JITTER,
        power_ref: INGEST_POWER_AUTO.then_some(PowerRef::Auto),
        saturation: Some(SaturationInput::Auto),
        ..IngestOptions::default()
    };
    if let Some(dark) = &manifest.files.dark {
        let frame = read_streak(&capture_dir.join(dark), false)?;
        let mean = frame.data.iter().map(|&v| v as f64).sum::<f64>() / frame.data.len() as f64;
        options.dark = Some(DarkInput::Level(mean));
    }
    if let Some(flat) = &manifest.files.flat {
        options.flat = Some(capture_dir.join(flat));
    }
    if let Some(sweep) = &manifest.imperfections.sweep {
        let mut table =
            String::from("# true bin edges of the recorded rows, ps (from the manifest)\n");
        for e in &sweep.bin_times_ps {
            table.push_str(&format!("{e}\n"));
        }
        super::write_file(sweep_path, table.as_bytes())?;
        options.sweep_table = Some(sweep_path.to_path_buf());
    }
    let plan = IngestPlan::resolve(&InputSpec::Manifest(manifest_path), &options)?;
    ingest(
        &plan,
        cube_path,
        &provenance("ingested capture, camera time"),
        CubeCompression::default(),
        &|_, _| {},
    )?;
    Ok(read_cube(cube_path)?)
}
