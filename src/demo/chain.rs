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
    calibrate_time, register, save_points_toml, ArrivalOptions, Correspondence,
};
use crate::camera::Calibration;
use crate::container::{read_cube, Provenance};
use crate::geometry::bvh::Bvh;
use crate::geometry::load::load_mesh;
use crate::ingest::assemble::ingest;
use crate::ingest::plan::{IngestOptions, IngestPlan, InputSpec, PowerRef, SaturationInput};
use crate::pipeline::calibrate::{calibrate_cube, write_calibration, CalibrateOptions, Calibrated};
use crate::pipeline::pyramid::{pyramid_file, PyramidOptions};
use crate::pipeline::render::{open_render_inputs, RenderInputs, SceneGeometry};
use crate::pipeline::unwarp::{unwarp_file, Distances, UnwarpOptions};
use crate::pipeline::Quiet;
use crate::render::RenderScene;
use crate::scene::Scene;
use crate::simulate::{simulate_capture, Flaws, SimulateOptions};
use nalgebra::Point3;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Noise added to each fiducial pixel coordinate of the demo's photo, pixels (standard
/// deviation): the same figure as `simulate --realistic`'s.
pub const FIDUCIAL_NOISE_PX: f64 = crate::simulate::flaws::REALISTIC_FIDUCIAL_PHOTO_PX;
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
    /// The same in pixels of the capture, as `femto calibrate` prints it.
    pub rms_capture_px: f64,
    /// True camera centre to the fiducials' centroid, metres.
    pub camera_distance_m: f64,
    pub position_error_mm: f64,
    pub position_error_mm_per_m: f64,
    pub rotation_error_deg: f64,
    pub focal_error_percent: f64,
    /// Fitted and true time origin, ps; the cube's bin width; their difference in bins.
    pub t0_fit_ps: f64,
    /// Standard error of the fitted `t0`, ps (the calibrate stage's).
    pub t0_std_error_ps: f64,
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
    /// The calibrate stage's detection floor (20 noise sigmas), cube value units.
    pub detection_floor: f64,
    /// The calibrate stage's warnings.
    pub warnings: Vec<String>,
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
    /// The world cube, fitted calibration and mesh opened by the render stage
    /// ([`open_render_inputs`]), as `femto render` opens them.
    pub render: RenderInputs,
    pub errors: CalibrationErrors,
    /// Files written under the data folder.
    pub data_files: Vec<PathBuf>,
    /// The CLI commands that reproduce the data products from the capture.
    pub commands: Vec<String>,
}

impl Chain {
    /// The renderer's view of this chain's result.
    pub fn render_scene(&self) -> Result<RenderScene<'_>, DemoError> {
        Ok(self.render.scene()?)
    }
}

/// File names under a chain's data folder.
pub const CAPTURE_DIR: &str = "capture";
pub const CUBE_FILE: &str = "cube.h5";
pub const WORLD_FILE: &str = "world.h5";
pub const CALIBRATION_FILE: &str = "calibration.toml";
pub const POINTS_FILE: &str = "fiducials_detected.toml";

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
    simulate_stage(&scene, sizes, &capture_dir, label, stages)?;
    files.push(capture_dir.clone());

    // 2. Ingest.
    let cube_path = data_dir.join(CUBE_FILE);
    stages.run(
        &format!("{label}ingest"),
        if INGEST_JITTER {
            "the manifest's dark frame, flat field and sweep bin times; jitter, laser power, saturation"
        } else {
            "the manifest's dark frame, flat field and sweep bin times; laser power, saturation (jitter left in)"
        },
        || ingest_capture(&capture_dir, &cube_path),
    )?;
    files.push(cube_path.clone());

    // 3. Calibrate: the calibrate stage, as `femto calibrate` runs it, on the markers
    //    "detected" in the high-resolution image (module doc), written in capture pixels.
    let truth = Calibration::load(&capture_dir.join(crate::simulate::options::CALIBRATION_FILE))?;
    let mesh_path = capture_dir.join(crate::simulate::options::GEOMETRY_FILE);
    let bvh = Bvh::new(load_mesh(&mesh_path)?);
    let calib_path = data_dir.join(CALIBRATION_FILE);
    let points_path = data_dir.join(POINTS_FILE);
    let options = calibrate_options();
    let world_path = data_dir.join(WORLD_FILE);
    let paths = ChainFiles {
        capture: &capture_dir,
        cube: &cube_path,
        points: &points_path,
        calibration: &calib_path,
        world: &world_path,
        mesh: &mesh_path,
    };
    let errors = stages.run(
        &format!("{label}calibrate"),
        &format!(
            "camera from fiducials ({}x{} image, {FIDUCIAL_NOISE_PX} px noise), t0 from the direct light",
            sizes.fiducial_nx, sizes.fiducial_ny
        ),
        || calibrate_and_score(&scene, sizes, &paths, &truth, &bvh, &options),
    )?;
    files.push(points_path.clone());
    files.push(calib_path.clone());

    // 4. Unwarp: the unwarp stage with its defaults.
    stages.run(
        &format!("{label}unwarp"),
        "camera time to world time, t_world = t_camera - eta |p - o| / c",
        || {
            let options = UnwarpOptions {
                command_line: "femto demo".into(),
                ..UnwarpOptions::default()
            };
            unwarp_file(&cube_path, &world_path, Distances::Stored, &options, &Quiet)?;
            Ok(())
        },
    )?;
    files.push(world_path.clone());

    // 5. Pyramid: the pyramid stage with its defaults, then the render stage's inputs.
    let render = stages.run(&format!("{label}pyramid"), "temporal prefix sums", || {
        pyramid_file(&world_path, &PyramidOptions::default(), &Quiet)?;
        let geometry = SceneGeometry::Files {
            calibration: &calib_path,
            mesh: &mesh_path,
        };
        Ok(open_render_inputs(&world_path, None, geometry, None)?)
    })?;

    let commands = commands(data_dir, &paths, truth.laser_m, &options);
    Ok(Chain {
        scene_name: scene.name.clone(),
        render,
        errors,
        data_files: files,
        commands,
    })
}

/// The simulate stage of [`run_chain`]: `scene` captured into `capture_dir` with the demo's
/// flaws, a line said at every tenth of the rows rendered.
fn simulate_stage(
    scene: &Scene,
    sizes: &DemoSizes,
    capture_dir: &Path,
    label: &str,
    stages: &mut Stages<'_>,
) -> Result<(), DemoError> {
    let say = stages.say();
    stages.run(
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
                    // The demo detects its fiducials in its own photo of the scene
                    // (calibrate_and_score), with FIDUCIAL_NOISE_PX there.
                    fiducial_photo_px: None,
                    ..Flaws::realistic()
                },
                force: true,
                created_by: "femto demo".into(),
                ..SimulateOptions::default()
            };
            // Rows rendered so far; a line at every tenth of the capture (the slow stage).
            let rows = std::sync::atomic::AtomicUsize::new(0);
            let ny = sizes.capture_ny;
            let tick = |stage: crate::simulate::Stage, n: usize| {
                if stage != crate::simulate::Stage::Render {
                    return;
                }
                let before = rows.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
                let after = before + n;
                if (10 * after) / ny > (10 * before) / ny {
                    say(&format!(
                        "{label}simulate: {after} of {ny} rows rendered ({} %)",
                        100 * after / ny
                    ));
                }
            };
            Ok(simulate_capture(scene, &opts, capture_dir, &tick)?)
        },
    )?;
    Ok(())
}

/// The calibrate stage of [`run_chain`]: the fiducials "detected" in the high-resolution
/// image (with noise, written in capture pixels to `files.points`), the calibration fitted
/// and written to `files.calibration`, and its errors against `truth` (the temporal stage
/// alone run through the true camera for the reference `t0`).
fn calibrate_and_score(
    scene: &Scene,
    sizes: &DemoSizes,
    files: &ChainFiles<'_>,
    truth: &Calibration,
    bvh: &Bvh,
    options: &CalibrateOptions,
) -> Result<CalibrationErrors, DemoError> {
    let hi = scene.with_resolution(sizes.fiducial_nx, sizes.fiducial_ny, sizes.nt, sizes.dt_ps);
    let truth_bvh = Bvh::new(hi.mesh.clone());
    let points = crate::simulate::fiducials::fiducials(
        &hi,
        &truth_bvh,
        crate::simulate::fiducials::DEFAULT_MARKER_SPACING_M,
    );
    let noisy = add_pixel_noise(&points, FIDUCIAL_NOISE_PX, DEMO_SEED);
    let in_capture_px = scale_points(
        &noisy,
        sizes.capture_nx as f64 / sizes.fiducial_nx as f64,
        sizes.capture_ny as f64 / sizes.fiducial_ny as f64,
    );
    save_points_toml(files.points, &in_capture_px)?;
    let fitted = calibrate_cube(
        files.cube,
        bvh,
        &in_capture_px,
        truth.laser_m,
        options,
        &Quiet,
    )?;
    write_calibration(
        files.cube,
        &fitted,
        in_capture_px.len(),
        &files.mesh.display().to_string(),
        files.calibration,
        &[files.mesh, files.points],
        "# made by: femto demo\n",
    )?;
    // The temporal stage alone: the same fit through the true camera.
    let cube = read_cube(files.cube)?;
    let true_reg = register(truth, bvh, cube.nx, cube.ny)?;
    let arrival = ArrivalOptions {
        min_peak: fitted.time.floor,
        ..ArrivalOptions::default()
    };
    let (true_time, _) =
        calibrate_time(&cube, &true_reg, &truth.laser_m, truth.eta, false, &arrival)?;
    Ok(calibration_errors(
        &scene.name,
        sizes,
        &points,
        &fitted,
        truth,
        true_time.t0_ps,
    ))
}

/// The spatial fit of the demo, as `femto calibrate --square-pixels
/// --centred-principal-point` does it: unknown intrinsics with square pixels and the
/// principal point at the image centre (both true of the simulated camera); every other
/// option at the calibrate stage's default.
pub fn calibrate_options() -> CalibrateOptions {
    CalibrateOptions {
        square_pixels: true,
        centred_principal_point: true,
        ..CalibrateOptions::default()
    }
}

/// `points` with their pixel coordinates scaled by `sx, sy` (pixel edges at integers in both
/// images: continuous coordinates scale as they are).
pub fn scale_points(points: &[Correspondence], sx: f64, sy: f64) -> Vec<Correspondence> {
    points
        .iter()
        .map(|c| Correspondence {
            pixel: (c.pixel.0 * sx, c.pixel.1 * sy),
            ..c.clone()
        })
        .collect()
}

/// The fitted calibration's errors against the truth (module doc); `points` are the markers
/// without noise (their centroid sets the camera distance), `t0_true_camera_ps` the time fit
/// through the true camera.
fn calibration_errors(
    scene: &str,
    sizes: &DemoSizes,
    points: &[Correspondence],
    fitted: &Calibrated,
    truth: &Calibration,
    t0_true_camera_ps: f64,
) -> CalibrationErrors {
    let cal = &fitted.calibration;
    let centroid = Point3::from(
        points
            .iter()
            .map(|c| c.point_m.coords)
            .sum::<nalgebra::Vector3<f64>>()
            / points.len() as f64,
    );
    let (position_mm, position_mm_per_m, rotation_deg, focal_percent) =
        spatial_errors(cal, truth, &centroid);
    let dt_ps = fitted.dt_ps;
    let mut errors = CalibrationErrors {
        scene: scene.to_string(),
        fiducials: points.len(),
        fiducial_width: sizes.fiducial_nx,
        fiducial_height: sizes.fiducial_ny,
        noise_px: FIDUCIAL_NOISE_PX,
        outliers: fitted.spatial.outliers.len(),
        rms_px: fitted.spatial.rms_px * sizes.fiducial_nx as f64 / sizes.capture_nx as f64,
        rms_capture_px: fitted.spatial.rms_px,
        camera_distance_m: (centroid - truth.pose.position_m).norm(),
        position_error_mm: position_mm,
        position_error_mm_per_m: position_mm_per_m,
        rotation_error_deg: rotation_deg,
        focal_error_percent: focal_percent,
        t0_fit_ps: cal.t0_ps,
        t0_std_error_ps: fitted.time.t0_std_error_ps,
        t0_true_ps: truth.t0_ps,
        dt_ps,
        t0_error_bins: (cal.t0_ps - truth.t0_ps).abs() / dt_ps,
        t0_true_camera_error_bins: (t0_true_camera_ps - truth.t0_ps).abs() / dt_ps,
        arrival_samples: fitted.time.samples,
        arrival_inliers: fitted.time.fit.inlier_count(),
        t0_rms_ps: fitted.time.fit.rms_ps,
        detection_floor: fitted.time.floor as f64,
        warnings: fitted.warnings.clone(),
        within_tolerance: false,
    };
    errors.within_tolerance = errors.check(&Tolerances::default());
    errors
}

/// The files of one chain, for [`commands`].
struct ChainFiles<'a> {
    capture: &'a Path,
    cube: &'a Path,
    points: &'a Path,
    calibration: &'a Path,
    world: &'a Path,
    mesh: &'a Path,
}

/// The `femto` commands that reproduce this chain's data products from its capture folder
/// (written by the demo into `commands.sh`), with paths relative to the demo's folder; run
/// there, they replace the demo's own products, so each carries `--force`.
fn commands(
    data_dir: &Path,
    f: &ChainFiles<'_>,
    laser_m: Point3<f64>,
    options: &CalibrateOptions,
) -> Vec<String> {
    // The demo's output folder: the parent of the `data` folder above `data_dir`.
    let base = data_dir
        .ancestors()
        .find(|a| a.file_name() == Some(std::ffi::OsStr::new(super::DATA_DIR)))
        .and_then(Path::parent)
        .unwrap_or(data_dir);
    let rel = |p: &Path| super::relative(base, p);
    let ingest = format!(
        "femto ingest {} -o {}{} --force",
        rel(f.capture),
        rel(f.cube),
        ingest_flags()
    );
    let mut calibrate = format!(
        "femto calibrate {} --mesh {} --points {} --laser={},{},{} --out {} --force",
        rel(f.cube),
        rel(f.mesh),
        rel(f.points),
        laser_m.x,
        laser_m.y,
        laser_m.z,
        rel(f.calibration)
    );
    if options.square_pixels {
        calibrate.push_str(" --square-pixels");
    }
    if options.centred_principal_point {
        calibrate.push_str(" --centred-principal-point");
    }
    vec![
        ingest,
        calibrate,
        format!(
            "femto unwarp {} --out {} --force",
            rel(f.cube),
            rel(f.world)
        ),
        format!("femto pyramid {} --force", rel(f.world)),
    ]
}

fn provenance(content: &str) -> Provenance {
    Provenance::new("femto demo").with_note("content", content)
}

/// Whether ingest estimates and removes trigger jitter (the per-pixel row-offset estimator of
/// [`crate::ingest::row_offsets`]: on the cube scene at 64 x 48 it leaves about 1 ps rms of a
/// 2 ps rms jitter, after its slow part, which no estimator can tell from the scene's tilt).
pub const INGEST_JITTER: bool = true;
/// Whether ingest normalises the laser power automatically (`femto ingest --power-ref auto`).
pub const INGEST_POWER_AUTO: bool = true;

/// Assemble the capture folder into `cube_path` (camera time) as `femto ingest` does with
/// the flags of [`ingest_flags`]: the manifest's own corrections (dark frame, flat field,
/// sweep bin times) by default, plus jitter, laser power and saturation.
fn ingest_capture(capture_dir: &Path, cube_path: &Path) -> Result<(), DemoError> {
    let manifest_path = capture_dir.join(crate::simulate::options::MANIFEST_FILE);
    let options = IngestOptions {
        jitter: INGEST_JITTER,
        power_ref: INGEST_POWER_AUTO.then_some(PowerRef::Auto),
        saturation: Some(SaturationInput::Auto),
        ..IngestOptions::default()
    };
    let plan = IngestPlan::resolve(&InputSpec::Manifest(manifest_path), &options)?;
    ingest(
        &plan,
        cube_path,
        &provenance("ingested capture, camera time"),
        crate::pipeline::INGEST_COMPRESSION,
        &|_, _| {},
    )?;
    Ok(())
}

/// The `femto ingest` flags that give [`ingest_capture`]'s options.
fn ingest_flags() -> String {
    let mut flags = String::new();
    if !INGEST_JITTER {
        flags.push_str(" --no-jitter");
    }
    if INGEST_POWER_AUTO {
        flags.push_str(" --power-ref auto");
    }
    flags.push_str(" --saturation auto");
    flags
}
