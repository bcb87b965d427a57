//! The calibrate stage: the capture camera from 2D-3D correspondences, every pixel registered
//! to the mesh, and the time origin `t0` from the cube's direct light (seed Sec. 3; physics.md
//! "Transient path tracing": `t_first = t0 + eta (|laser - p| + |p - o|) / c`).
//!
//! `femto calibrate` and `femto demo` both call [`calibrate_cube`] then [`write_calibration`];
//! the defaults of [`CalibrateOptions`] are what a user gets.
//!
//! **Detection floor.** A pixel's first arrival is searched from the first bin at or above
//! 0.3 of its maximum; on a noisy cube a pixel whose maximum is a noise spike, or a spike
//! before a weak pulse, passes for an early arrival, and the robust fit of many such pixels
//! settles on a confident, wrong `t0` (measured on the demo's quick capture with no floor:
//! -18.0 ps, truth 0, at 4.9 ps rms; with the floor below: 0.02 ps at 0.85 ps rms). By default
//! a pixel is used only when its maximum reaches [`NOISE_SIGMAS`] times the cube's noise, the
//! robust standard deviation of its values ([`noise_sigma`]), so that the 0.3 threshold lies at
//! 6 sigma.
//!
//! **Stability.** The fit is repeated with the floor doubled (and at least the automatic
//! floor); when `t0` moves by more than [`MAX_T0_SHIFT_BINS`] of a bin or four standard
//! errors, the detection is not what decides it and the stage refuses
//! ([`StageError::UnstableTime`]) rather than return a confident wrong `t0`. The outcome
//! reports `t0`'s standard error (the inliers' robust sigma over the square root of their
//! number) and the two fits.

use super::{Progress, StageError, StageOption};
use crate::calibrate::mixed::footprint_spread_m;
use crate::calibrate::scanline_time::{
    fill_missing, fit_scanline_offsets, DirectTime, DIM_ROW_FLOOR,
};
use crate::calibrate::{
    arrival_samples, direct_arrival_samples, fit_camera, fit_direct_time, footprints, register,
    ArrivalOptions, ArrivalSample, CalibrateError, Correspondence, Footprints, Registration,
    SpatialFit, SpatialOptions, TimeFit,
};
use crate::camera::{Calibration, Intrinsics, KnownIntrinsics};
use crate::container::{CubeMeta, CubeReader, GroupUpdate};
use crate::cube::{row_slabs, Cube, TimeFrame};
use crate::geometry::bvh::Bvh;
use crate::ingest::assemble::{JITTER_SHIFTS_NOTE, TRUE_JITTER_NOTE};
use crate::ingest::row_offsets::{scanline_report, OffsetReport};
use crate::row_offset::RowOffset;
use crate::stats::{quantile, MAD_TO_SIGMA};
use crate::store::registration::{self, FitSummary};
use nalgebra::Point3;
use std::path::{Path, PathBuf};

/// Default detection floor, in noise standard deviations (module doc).
pub const NOISE_SIGMAS: f64 = 20.0;
/// Largest move of `t0`, in bins, between the fit and its check with the floor doubled.
pub const MAX_T0_SHIFT_BINS: f64 = 0.1;
/// Rows of the cube read at once while fitting, bytes.
const SLAB_BYTES: usize = 32 << 20;

/// The floor under which a pixel's maximum is too weak for a first arrival.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DetectionFloor {
    /// This many times the cube's noise ([`noise_sigma`]).
    NoiseSigmas(f64),
    /// A fixed level, in the cube's value units.
    Level(f32),
}

/// What [`calibrate_cube`] fits and how; `Default` is what `femto calibrate` does.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrateOptions {
    /// Known intrinsics (only the pose is fitted, from 4 points or more); None: fitted.
    pub intrinsics: Option<Intrinsics>,
    /// Unknown intrinsics: constrain `fx = fy`.
    pub square_pixels: bool,
    /// Unknown intrinsics: the principal point at the image centre.
    pub centred_principal_point: bool,
    /// Unknown intrinsics: fit the radial distortion too.
    pub fit_distortion: bool,
    /// Keep the points flagged as outliers in the camera fit.
    pub keep_outliers: bool,
    /// Refractive index of the medium.
    pub eta: f64,
    /// Fit a time-scale factor of the sweep besides `t0`.
    pub fit_time_scale: bool,
    /// First-arrival search threshold, a fraction of each pixel's maximum.
    pub threshold_fraction: f64,
    /// The detection floor (module doc).
    pub floor: DetectionFloor,
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        CalibrateOptions {
            intrinsics: None,
            square_pixels: false,
            centred_principal_point: false,
            fit_distortion: false,
            keep_outliers: false,
            eta: 1.0,
            fit_time_scale: false,
            threshold_fraction: ArrivalOptions::default().threshold_fraction,
            floor: DetectionFloor::NoiseSigmas(NOISE_SIGMAS),
        }
    }
}

/// The `--intrinsics` file ([`KnownIntrinsics`]: the same tables and keys as a calibration
/// file) for a cube of `nx x ny` pixels: its intrinsics, and its laser spot and medium when
/// it records them.
pub fn read_intrinsics(path: &Path, nx: usize, ny: usize) -> Result<KnownIntrinsics, StageError> {
    let known = KnownIntrinsics::load(path)?;
    let k = known.intrinsics;
    if (k.width, k.height) != (nx, ny) {
        return Err(StageError::Input {
            path: path.display().to_string(),
            message: format!(
                "the intrinsics are for {} x {} pixels but the cube is {nx} x {ny}",
                k.width, k.height
            ),
        });
    }
    Ok(known)
}

/// The laser spot of a calibration: `given` (`--laser`), else the `--intrinsics` file's.
pub fn laser_spot(
    given: Option<[f64; 3]>,
    from_file: Option<[f64; 3]>,
) -> Result<Point3<f64>, StageError> {
    match given.or(from_file) {
        Some(l) => Ok(Point3::from(l)),
        None => Err(StageError::Missing(
            "the laser spot is unknown: give --laser X,Y,Z (metres, mesh frame), or an \
             --intrinsics file with a [laser] section",
        )),
    }
}

/// Where the calibration TOML of the cube at `cube` goes by default:
/// `<dir>/<stem>.calibration.toml`.
pub fn default_calibration_path(cube: &Path) -> PathBuf {
    let stem = cube
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "cube".into());
    cube.with_file_name(format!("{stem}.calibration.toml"))
}

/// One time fit and the floor it was made with.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeFitRun {
    pub fit: TimeFit,
    /// Pixels with direct light used by the fit.
    pub samples: usize,
    /// The detection floor, cube value units.
    pub floor: f32,
    /// Standard error of `t0`: the inliers' robust sigma over the square root of their
    /// number, ps.
    pub t0_std_error_ps: f64,
}

/// What [`calibrate_cube`] found.
#[derive(Clone, Debug)]
pub struct Calibrated {
    /// The calibration (camera, `t0`, laser, medium).
    pub calibration: Calibration,
    pub spatial: SpatialFit,
    pub registration: Registration,
    /// The fit that gives `t0`.
    pub time: TimeFitRun,
    /// The same fit with the floor doubled (module doc, "Stability").
    pub check: TimeFitRun,
    /// The cube's noise, robust standard deviation in value units.
    pub noise_sigma: f64,
    /// The cube's bin width, ps.
    pub dt_ps: f64,
    /// Each scanline's time offset against the geometry ([`crate::calibrate::scanline_time`];
    /// None: too little direct light to estimate), which `femto unwarp` removes; empty for a
    /// cube whose scanlines ingest did not take as separately triggered (no jitter note).
    pub scanlines: Vec<Option<RowOffset>>,
    /// `scanlines` in words (with the truth, for a simulated capture).
    pub scanline_report: OffsetReport,
    /// Each pixel's spread of distances over its footprint, metres
    /// ([`crate::calibrate::mixed`]): `femto unwarp` masks the mixed pixels.
    pub footprint_spread_m: Vec<f32>,
    /// Things the user should know (printed by the CLI, kept in the demo's report).
    pub warnings: Vec<String>,
}

impl Calibrated {
    /// The fit figures stored with the registration.
    pub fn summary(&self, points: usize) -> FitSummary {
        FitSummary {
            points,
            outliers: self.spatial.outliers.len(),
            reprojection_rms_px: self.spatial.rms_px,
            time_samples: self.time.samples,
            time_inliers: self.time.fit.inlier_count(),
            time_residual_rms_ps: self.time.fit.rms_ps,
        }
    }
}

/// Robust standard deviation of a set of cube values: 1.4826 times the median absolute
/// deviation from their median, both medians nearest-rank ([`quantile`] at 0.5: the upper
/// middle value of an even count). Light fills few of the bins of a transient cube, so this
/// measures the noise of the empty ones. 0 for no finite value.
pub fn noise_sigma(values: &[f32]) -> f64 {
    let mut v: Vec<f64> = values
        .iter()
        .map(|&x| x as f64)
        .filter(|x| x.is_finite())
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    let median = quantile(&mut v, 0.5);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - median).abs()).collect();
    MAD_TO_SIGMA * quantile(&mut dev, 0.5)
}

/// [`noise_sigma`] of a cube file, over about 2^20 values taken from rows spread over it.
pub fn cube_noise_sigma(reader: &CubeReader) -> Result<f64, StageError> {
    let meta = reader.meta();
    let row_len = meta.row_len();
    let rows_wanted = ((1usize << 20) / row_len.max(1)).clamp(1, meta.ny);
    let step = meta.ny / rows_wanted;
    let mut values = Vec::with_capacity(rows_wanted * row_len);
    for k in 0..rows_wanted {
        values.extend(reader.read_rows(k * step.max(1), 1)?);
    }
    let stride = (values.len() >> 20).max(1);
    let sub: Vec<f32> = values.iter().step_by(stride).copied().collect();
    Ok(noise_sigma(&sub))
}

/// Fit the camera to `points`, register the cube's pixels to `mesh`, and fit `t0` to the
/// direct light of the camera-time cube at `cube_path` (streamed by row slabs). Writes
/// nothing: [`write_calibration`] does.
pub fn calibrate_cube(
    cube_path: &Path,
    mesh: &Bvh,
    points: &[Correspondence],
    laser_m: Point3<f64>,
    options: &CalibrateOptions,
    progress: &dyn Progress,
) -> Result<Calibrated, StageError> {
    let reader = CubeReader::open(cube_path)?;
    let meta = reader.meta().clone();
    let at = |e: CalibrateError| calibrate_error(cube_path, e);
    if meta.frame != TimeFrame::Camera {
        return Err(at(CalibrateError::WorldTimeCube));
    }
    check_options(options)?;

    // The camera, and what each pixel sees through it.
    let spatial = spatial_options(options, cube_path, meta.nx, meta.ny)?;
    let fit = fit_camera(points, &spatial).map_err(|e| StageError::Points { source: e })?;
    progress.poll();
    let camera = fit.calibration(0.0, 1.0, laser_m, options.eta);
    let reg = register(&camera, mesh, meta.nx, meta.ny).map_err(at)?;
    if reg.hit_count() == 0 {
        return Err(StageError::NothingSeen);
    }
    progress.poll();
    let footprint_spread_m = footprint_spread_m(&camera, mesh, &reg);
    progress.poll();

    // t0 from the direct light above the detection floor, checked at twice the floor.
    let noise = cube_noise_sigma(&reader)?;
    let auto_floor = (NOISE_SIGMAS * noise) as f32;
    let floor = match options.floor {
        DetectionFloor::NoiseSigmas(k) => (k * noise) as f32,
        DetectionFloor::Level(v) => v,
    };
    let prints = footprints(&reg, &laser_m);
    let mask = reader.read_mask()?;
    let fitter = TimeFitter {
        cube_path,
        slabs: Slabs {
            reader: &reader,
            mask: mask.as_deref(),
            reg: &reg,
            prints: &prints,
        },
        laser_m,
        options,
        progress,
    };
    let time = fitter.fit_t0(floor, "t0")?;
    let check = fitter.fit_t0((2.0 * floor).max(auto_floor), "t0 check")?;
    let dt_ps = meta.axis.dt_ps;
    let shift_ps = (check.fit.t0_ps - time.fit.t0_ps).abs();
    let allowed_ps =
        (MAX_T0_SHIFT_BINS * dt_ps).max(4.0 * time.t0_std_error_ps.hypot(check.t0_std_error_ps));
    if shift_ps > allowed_ps {
        return Err(StageError::UnstableTime {
            path: cube_path.display().to_string(),
            t0_ps: time.fit.t0_ps,
            floor: time.floor,
            check_t0_ps: check.fit.t0_ps,
            check_floor: check.floor,
            noise_sigma: noise,
        });
    }
    let warnings = time_warnings(&time, &check, auto_floor, dt_ps);

    // Each scanline's offset against the geometry.
    let model = DirectTime {
        t0_ps: time.fit.t0_ps,
        time_scale: time.fit.time_scale,
        eta: options.eta,
    };
    let (scanlines, scanline_report) = fitter.scanline_times(&meta, &model, floor)?;
    let calibration = fit.calibration(time.fit.t0_ps, time.fit.time_scale, laser_m, options.eta);
    Ok(Calibrated {
        calibration,
        spatial: fit,
        registration: reg,
        time,
        check,
        noise_sigma: noise,
        dt_ps,
        scanlines,
        scanline_report,
        footprint_spread_m,
        warnings,
    })
}

/// A calibration error of the cube at `cube_path`.
fn calibrate_error(cube_path: &Path, source: CalibrateError) -> StageError {
    StageError::Calibrate {
        path: cube_path.display().to_string(),
        source,
    }
}

/// What the user should know of the fit of `t0` (`time`) and its check: a floor below the
/// automatic one `auto_floor` (with how well the check agreed), a residual over a bin of
/// `dt_ps`.
fn time_warnings(
    time: &TimeFitRun,
    check: &TimeFitRun,
    auto_floor: f32,
    dt_ps: f64,
) -> Vec<String> {
    let mut warnings = Vec::new();
    let (floor, shift_ps) = (time.floor, (check.fit.t0_ps - time.fit.t0_ps).abs());
    if floor < auto_floor {
        warnings.push(format!(
            "the detection floor {floor} is below {NOISE_SIGMAS} x the cube's noise ({auto_floor:.4}); \
             t0 agreed with the check at {:.4} within {shift_ps:.3} ps",
            check.floor
        ));
    }
    if time.fit.rms_ps > dt_ps {
        warnings.push(format!(
            "the direct light fits t0 with {:.2} ps rms, more than a bin ({dt_ps} ps): check the \
             laser position and the mesh",
            time.fit.rms_ps
        ));
    }
    warnings
}

/// The time fits of [`calibrate_cube`] over one registered cube: `t0` and each scanline's
/// offset, from the cube's row slabs, the laser spot and the options.
struct TimeFitter<'a> {
    cube_path: &'a Path,
    slabs: Slabs<'a>,
    laser_m: Point3<f64>,
    options: &'a CalibrateOptions,
    progress: &'a dyn Progress,
}

impl TimeFitter<'_> {
    /// The first-arrival search of the options, counting only pixels whose maximum reaches
    /// `min_peak`.
    fn arrival(&self, min_peak: f32) -> ArrivalOptions {
        ArrivalOptions {
            threshold_fraction: self.options.threshold_fraction,
            min_peak,
            ..ArrivalOptions::default()
        }
    }

    /// One fit of `t0` (and the time scale, if asked) to the direct light of the pixels above
    /// `floor`; `what` names the pass in the progress.
    fn fit_t0(&self, floor: f32, what: &str) -> Result<TimeFitRun, StageError> {
        let options = self.options;
        let arrival = self.arrival(floor);
        let (fit, samples) = fit_direct_time(options.eta, options.fit_time_scale, &mut |model| {
            time_samples(
                &self.slabs,
                &self.laser_m,
                options.eta,
                model,
                &[],
                &arrival,
                what,
                self.progress,
            )
        })
        .map_err(|e| match e {
            StageError::Calibrate { source, .. } => calibrate_error(self.cube_path, source),
            other => other,
        })?;
        let n = fit.inlier_count().max(1) as f64;
        Ok(TimeFitRun {
            t0_std_error_ps: fit.sigma_ps / n.sqrt(),
            samples: samples.len(),
            fit,
            floor,
        })
    }

    /// Each scanline's offset against `model` from the pixels above `min_peak`
    /// ([`fit_scanline_offsets`]).
    fn scanline_offsets(
        &self,
        model: &DirectTime,
        ny: usize,
        min_peak: f32,
        what: &str,
    ) -> Result<Vec<Option<RowOffset>>, StageError> {
        let arrival = self.arrival(min_peak);
        fit_scanline_offsets(model, ny, |shift_ps| {
            time_samples(
                &self.slabs,
                &self.laser_m,
                self.options.eta,
                Some((model.t0_ps, model.time_scale)),
                shift_ps,
                &arrival,
                what,
                self.progress,
            )
        })
    }

    /// The scanline offsets of a cube whose scanlines were triggered one by one, measured
    /// above `floor` and, for the rows left without an estimate, above
    /// [`DIM_ROW_FLOOR`] of it; with their report (against the truth of a simulated capture).
    ///
    /// Only such a capture has scanline offsets to find: ingest records it by removing their
    /// jitter. Elsewhere (a cube from an array file, a tracer, another tool) a row's median
    /// residual is the time model's error along the row, which on an analytic cube of 40 ps
    /// bins reached 7 ps "beyond 4 standard errors"; those get no offsets and say why.
    fn scanline_times(
        &self,
        meta: &CubeMeta,
        model: &DirectTime,
        floor: f32,
    ) -> Result<(Vec<Option<RowOffset>>, OffsetReport), StageError> {
        let triggered = meta.notes.iter().any(|(k, _)| k == JITTER_SHIFTS_NOTE);
        if !triggered {
            let report = OffsetReport {
                summary: format!(
                    "scanline times: not measured (the cube has no {JITTER_SHIFTS_NOTE} note: \
                     its scanlines were not ingested as separately triggered sweeps)"
                ),
                ..OffsetReport::default()
            };
            return Ok((Vec::new(), report));
        }
        let mut scanlines = self.scanline_offsets(model, meta.ny, floor, "scanline times")?;
        if scanlines.iter().any(Option::is_none) {
            let dim = self.scanline_offsets(
                model,
                meta.ny,
                floor * DIM_ROW_FLOOR,
                "scanline times, dim rows",
            )?;
            fill_missing(&mut scanlines, &dim);
        }
        let truth = jitter_truth(&meta.notes, meta.ny);
        let report = scanline_report(
            &scanlines,
            truth.as_ref().map(|(t, i)| (t.as_slice(), i.as_slice())),
        );
        Ok((scanlines, report))
    }
}

/// A simulated capture's true scanline delays and the shifts ingest removed (zeros when it
/// removed none), from the cube's notes; None unless the truth is there, for `ny` rows.
fn jitter_truth(notes: &[(String, String)], ny: usize) -> Option<(Vec<f64>, Vec<f64>)> {
    let list = |key: &str| -> Option<Vec<f64>> {
        let (_, v) = notes.iter().find(|(k, _)| k == key)?;
        serde_json::from_str::<Vec<f64>>(v)
            .ok()
            .filter(|l| l.len() == ny)
    };
    let truth = list(TRUE_JITTER_NOTE)?;
    let removed = list(JITTER_SHIFTS_NOTE).unwrap_or_else(|| vec![0.0; ny]);
    Some((truth, removed))
}

/// Refuse a threshold fraction outside (0, 1], an index of refraction below 1 and a
/// detection floor that is not a finite level >= 0; the error names the option.
fn check_options(options: &CalibrateOptions) -> Result<(), StageError> {
    let t = options.threshold_fraction;
    if !(t > 0.0 && t <= 1.0) {
        return Err(StageError::Option {
            name: StageOption::Threshold,
            message: format!("must be in (0, 1], got {t}"),
        });
    }
    if !(options.eta.is_finite() && options.eta >= 1.0) {
        return Err(StageError::Option {
            name: StageOption::Eta,
            message: format!("must be a number >= 1, got {}", options.eta),
        });
    }
    if let DetectionFloor::Level(v) = options.floor {
        if !(v.is_finite() && v >= 0.0) {
            return Err(StageError::Option {
                name: StageOption::MinPeak,
                message: format!("must be a finite number >= 0, got {v}"),
            });
        }
    }
    Ok(())
}

/// The spatial fit's options for a cube of `nx` x `ny` pixels at `cube_path`: the given
/// intrinsics (which must be for that size), or unknown ones with the shape constraints
/// asked for.
fn spatial_options(
    options: &CalibrateOptions,
    cube_path: &Path,
    nx: usize,
    ny: usize,
) -> Result<SpatialOptions, StageError> {
    let mut spatial = match options.intrinsics {
        Some(k) => {
            if (k.width, k.height) != (nx, ny) {
                return Err(StageError::Option {
                    name: StageOption::Intrinsics,
                    message: format!(
                        "are for {} x {} pixels but {} is {} x {}",
                        k.width,
                        k.height,
                        cube_path.display(),
                        nx,
                        ny
                    ),
                });
            }
            SpatialOptions::known_intrinsics(k)
        }
        None => SpatialOptions::unknown_intrinsics(nx, ny),
    };
    if options.intrinsics.is_none() {
        spatial.square_pixels = options.square_pixels;
        spatial.principal_point_at_centre = options.centred_principal_point;
        spatial.fit_distortion = options.fit_distortion;
    }
    spatial.reject_outliers = !options.keep_outliers;
    Ok(spatial)
}

/// The cube read by row slabs, with what every pixel sees.
struct Slabs<'a> {
    reader: &'a CubeReader,
    mask: Option<&'a [u8]>,
    reg: &'a Registration,
    prints: &'a Footprints,
}

/// The time samples of one pass of [`fit_direct_time`], streaming the cube by row slabs:
/// first arrivals (`model` None) or direct-light centroids under `model = (t0_ps, scale)`,
/// row `y`'s windows moved by `row_shift_ps[y]` (empty: none).
#[allow(clippy::too_many_arguments)]
fn time_samples(
    cube: &Slabs<'_>,
    laser_m: &Point3<f64>,
    eta: f64,
    model: Option<(f64, f64)>,
    row_shift_ps: &[f64],
    options: &ArrivalOptions,
    what: &str,
    progress: &dyn Progress,
) -> Result<Vec<ArrivalSample>, StageError> {
    let meta = cube.reader.meta();
    let (nx, ny) = (meta.nx, meta.ny);
    let pass = if model.is_some() {
        "direct light"
    } else {
        "first arrivals"
    };
    progress.start(&format!("{what}: {pass}"), ny as u64);
    let mut samples = Vec::new();
    for rows in row_slabs(ny, meta.row_len() * 4, SLAB_BYTES) {
        let (y0, n) = (rows.start, rows.len());
        let (a, b) = (y0 * nx, (y0 + n) * nx);
        let slab = Cube {
            nx,
            ny: n,
            axis: meta.axis,
            frame: meta.frame,
            data: cube.reader.read_rows(y0, n)?,
            mask: cube.mask.map(|m| m[a..b].to_vec()),
        };
        let found = match model {
            None => arrival_samples(&slab, &cube.reg.rows(y0, n), laser_m, options),
            Some((t0_ps, scale)) => direct_arrival_samples(
                &slab,
                &cube.prints.rows(y0, n),
                eta,
                t0_ps,
                scale,
                row_shift_ps.get(y0..y0 + n).unwrap_or(&[]),
                options,
            ),
        }?;
        samples.extend(
            found
                .into_iter()
                .map(|s| ArrivalSample { y: s.y + y0, ..s }),
        );
        progress.set(rows.end as u64);
    }
    progress.finish();
    Ok(samples)
}

/// Write `result` as the calibration TOML `toml_path` (headed by `header`, e.g. the command
/// line as a comment) and as the `registration` group of the cube at `cube_path`: both or
/// neither. The TOML is staged beside its destination first, so a folder that does not exist
/// or a full disk fails before the cube is touched; the cube is rewritten beside itself; the
/// two are renamed into place together at the end, in one section that a signal does not
/// split ([`crate::interrupt::commit`]). `toml_path` may be neither the cube nor any of
/// `other_inputs` (the mesh, the points, the intrinsics).
pub fn write_calibration(
    cube_path: &Path,
    result: &Calibrated,
    points: usize,
    mesh_name: &str,
    toml_path: &Path,
    other_inputs: &[&Path],
    header: &str,
) -> Result<(), StageError> {
    let mut inputs = vec![cube_path];
    inputs.extend_from_slice(other_inputs);
    super::refuse_same_file(toml_path, &inputs, "out")?;
    let io = |source| StageError::Io {
        path: toml_path.display().to_string(),
        source,
    };
    let text = format!("{header}{}", result.calibration.to_toml());
    let staged = crate::atomic::AtomicFile::stage(toml_path, text.as_bytes()).map_err(io)?;
    let mut group = registration::registration_group(
        &result.registration,
        &result.calibration,
        mesh_name,
        Some(&result.summary(points)),
    );
    if !result.scanlines.is_empty() {
        registration::add_scanline_offsets(&mut group, &result.scanlines);
    }
    registration::add_footprint_spread(
        &mut group,
        result.registration.nx,
        result.registration.ny,
        result.footprint_spread_m.clone(),
    );
    let mut update = GroupUpdate::open(cube_path)?;
    update.write_group(registration::GROUP, &group)?;
    let cube = update.finish_staged()?;
    let _commit = crate::interrupt::commit();
    cube.persist()?;
    staged.commit().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_out_of_range_are_refused_by_name() {
        assert!(check_options(&CalibrateOptions::default()).is_ok());
        let cases = [
            (
                CalibrateOptions {
                    threshold_fraction: 0.0,
                    ..CalibrateOptions::default()
                },
                StageOption::Threshold,
            ),
            (
                CalibrateOptions {
                    threshold_fraction: 1.5,
                    ..CalibrateOptions::default()
                },
                StageOption::Threshold,
            ),
            (
                CalibrateOptions {
                    eta: 0.9,
                    ..CalibrateOptions::default()
                },
                StageOption::Eta,
            ),
            (
                CalibrateOptions {
                    eta: f64::INFINITY,
                    ..CalibrateOptions::default()
                },
                StageOption::Eta,
            ),
            (
                CalibrateOptions {
                    floor: DetectionFloor::Level(-1.0),
                    ..CalibrateOptions::default()
                },
                StageOption::MinPeak,
            ),
        ];
        for (options, want) in cases {
            match check_options(&options) {
                Err(StageError::Option { name, .. }) => assert_eq!(name, want, "{options:?}"),
                other => panic!("{options:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn given_intrinsics_must_match_the_cube_and_ignore_the_shape_flags() {
        let path = Path::new("cube.h5");
        let k = Intrinsics::from_vfov(64, 48, 40.0);
        let options = CalibrateOptions {
            intrinsics: Some(k),
            square_pixels: true,
            keep_outliers: true,
            ..CalibrateOptions::default()
        };
        let s = spatial_options(&options, path, 64, 48).unwrap();
        assert!(!s.square_pixels && !s.reject_outliers);
        let e = spatial_options(&options, path, 32, 48)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("are for 64 x 48 pixels but cube.h5 is 32 x 48"),
            "{e}"
        );
        let unknown = CalibrateOptions {
            square_pixels: true,
            centred_principal_point: true,
            ..CalibrateOptions::default()
        };
        let s = spatial_options(&unknown, path, 32, 48).unwrap();
        assert!(s.square_pixels && s.principal_point_at_centre && s.reject_outliers);
    }
}
