//! Writing a simulated capture folder: render the scene's true transient cubes, turn each
//! scanline into a streak image with the capture's imperfections ([`super::flaws`]), and
//! write the folder a real lab would hand over plus the ground truth (layout in
//! [`super`]'s doc).
//!
//! The folder is built in a temporary folder beside the destination and renamed onto it only
//! once every file is written, so an interrupted or failed run leaves nothing half-written.

use super::budget::BAND_TARGET_BYTES;
use super::fiducials::fiducials;
use super::flaws::{CaptureModel, Peaks, MAX_COUNT};
use super::options::{
    SimulateError, SimulateOptions, Stage, CALIBRATION_FILE, DARK_FILE, FIDUCIALS_FILE, FLAT_FILE,
    GEOMETRY_FILE, MANIFEST_FILE, TRUTH_CAMERA_FILE, TRUTH_DIRECT_FILE, TRUTH_WORLD_FILE,
};
use crate::atomic::write_atomically;
use crate::calibrate::points::save_points_toml;
use crate::container::{CubeReader, CubeWriter, Provenance, DEFAULT_UNITS};
use crate::cube::TimeFrame;
use crate::formats::hamamatsu::write_img;
use crate::formats::raster::{write_exr_f32, write_png16};
use crate::formats::StreakImage;
use crate::geometry::bvh::Bvh;
use crate::geometry::glb::write_glb;
use crate::manifest::{CaptureFiles, CaptureInfo, Manifest, Scanline, StreakFormat};
use crate::render::truth::TruthSummary;
use crate::scene::Scene;
use crate::tracer::{TraceOptions, TraceStats, Tracer};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SimulateError + '_ {
    move |source| SimulateError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// What a finished capture cost and produced.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulateSummary {
    /// The capture folder.
    pub out_dir: PathBuf,
    /// Camera paths traced.
    pub paths: u64,
    /// Rays cast (camera, bounce and shadow rays).
    pub rays: u64,
    /// Wall-clock time of the render, seconds.
    pub render_seconds: f64,
    /// CPU time of the render (all threads), seconds.
    pub render_cpu_seconds: f64,
    /// Wall-clock time of the whole capture (render, imperfections, files), seconds.
    pub seconds: f64,
    /// Paths per second of the render.
    pub paths_per_second: f64,
    /// Every file of the capture folder, in its final place.
    pub files: Vec<PathBuf>,
    /// Fiducials written.
    pub fiducials: usize,
    /// Streak-image values at the top count (65535): clipped by saturation or overflow.
    pub values_at_top_count: usize,
    /// The truth frames of a moving camera written into the capture (`--truth-path`).
    pub truth: Option<TruthSummary>,
}

/// Simulate a streak capture of `scene` and write the capture folder `out_dir` (layout in
/// the [`super`] doc). `out_dir` must not exist or be an empty folder, unless
/// `opts.force`, which replaces it. `progress` is told of each finished row ([`Stage`]).
pub fn simulate_capture(
    scene: &Scene,
    opts: &SimulateOptions,
    out_dir: &Path,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<SimulateSummary, SimulateError> {
    simulate_capture_and(scene, opts, out_dir, progress, |_| Ok(None))
}

/// [`simulate_capture`], with `extra` writing more into the capture's temporary folder (its
/// argument) once the capture is there and before the folder is put in place: the truth
/// frames of a moving camera (`crate::pipeline::truth`). An error of `extra` leaves nothing
/// written, like any other.
pub fn simulate_capture_and(
    scene: &Scene,
    opts: &SimulateOptions,
    out_dir: &Path,
    progress: &(dyn Fn(Stage, usize) + Sync),
    extra: impl FnOnce(&Path) -> Result<Option<TruthSummary>, SimulateError>,
) -> Result<SimulateSummary, SimulateError> {
    let started = Instant::now();
    opts.validate(scene)?;
    let staged = stage_and_install(out_dir, opts.force, |tmp| {
        let capture = stage_capture(scene, opts, tmp, progress)?;
        Ok((capture, extra(tmp)?))
    })?;
    let ((stats, written, fiducials, values_at_top_count), truth) = staged;

    Ok(SimulateSummary {
        out_dir: out_dir.to_path_buf(),
        paths: stats.paths,
        rays: stats.rays,
        render_seconds: stats.seconds,
        render_cpu_seconds: stats.cpu_seconds,
        seconds: started.elapsed().as_secs_f64(),
        paths_per_second: stats.paths_per_second(),
        files: written.iter().map(|f| out_dir.join(f)).collect(),
        fiducials,
        values_at_top_count,
        truth,
    })
}

/// Write a folder with `stage` into a temporary folder beside `out_dir` and put it in place
/// as `out_dir` once `stage` succeeds ([`install`]); `out_dir` must not exist or be an empty
/// folder, unless `force`. An error of `stage` names its file by its place in `out_dir`.
pub(crate) fn stage_and_install<T>(
    out_dir: &Path,
    force: bool,
    stage: impl FnOnce(&Path) -> Result<T, SimulateError>,
) -> Result<T, SimulateError> {
    check_destination(out_dir, force)?;
    let parent = match out_dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).map_err(io_err(&parent))?;
    // Registered for removal on SIGINT/SIGTERM; named so that a killed run's is removed by
    // the next (crate::atomic).
    let tmp = crate::atomic::temp_dir_beside(out_dir).map_err(io_err(&parent))?;
    // Everything is written into the temporary folder; an error names the file by its place
    // in `out_dir`, where the user looks for it, not by the temporary folder's name.
    let staged = stage(tmp.path()).map_err(|e| SimulateError::Staged {
        message: e.to_string().replace(
            &tmp.path().display().to_string(),
            &out_dir.display().to_string(),
        ),
    })?;
    install(tmp, out_dir, force)?;
    Ok(staged)
}

/// Everything [`simulate_capture`] writes, written into the folder `dir` (the temporary
/// folder beside the output): the truth cubes, the scanlines, the side files and the
/// manifest. Returns the render's counters, the files written (relative to `dir`), the
/// number of fiducial markers and of streak-image values at the top count.
fn stage_capture(
    scene: &Scene,
    opts: &SimulateOptions,
    dir: &Path,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<(TraceStats, Vec<PathBuf>, usize, usize), SimulateError> {
    if opts.transient_only {
        let (stats, written) = super::transient::stage(scene, opts, dir, progress)?;
        set_folder_permissions(&[dir.to_path_buf()])?;
        return Ok((stats, written, 0, 0));
    }
    let bvh = Bvh::new(scene.mesh.clone());
    let ny = scene.camera.intrinsics.height;
    let shape = capture_shape(scene, opts)?;
    let (peaks, stats) = render_truths(
        scene,
        &bvh,
        &trace_options(opts),
        &shape,
        0..ny,
        dir,
        &provenance(scene, opts),
        progress,
    )?;
    let (written, n_points, values_at_top_count) =
        finish_capture(scene, opts, &bvh, shape, &peaks, dir, progress)?;
    Ok((stats, written, n_points, values_at_top_count))
}

/// The tracer's options of a capture made with `opts`.
pub(crate) fn trace_options(opts: &SimulateOptions) -> TraceOptions {
    TraceOptions {
        spp: opts.spp,
        max_bounces: opts.max_bounces,
        seed: opts.seed,
        split_bounces: true,
        world_time: true,
        ..TraceOptions::default()
    }
}

/// The provenance of a capture's truth cubes.
pub(crate) fn provenance(scene: &Scene, opts: &SimulateOptions) -> Provenance {
    Provenance::new(opts.created_by.clone())
        .with_note("scene", scene.name.clone())
        .with_note("seed", opts.seed.to_string())
        .with_note("spp", opts.spp.to_string())
        .with_note("max_bounces", opts.max_bounces.to_string())
        // The wavelength `femto render` colours a truth cube with (pipeline::render's
        // LASER_NM_NOTES), as it does an ingested capture's.
        .with_note("laser_nm", scene.laser.wavelength_nm.to_string())
        .with_note(
            "values",
            "radiance integrated over each time bin (tracer units, proportional to the pulse energy)",
        )
}

/// The capture model of `scene` with `opts` before the clean cube's scale is known.
pub(crate) fn capture_shape(
    scene: &Scene,
    opts: &SimulateOptions,
) -> Result<CaptureModel, SimulateError> {
    let (nx, ny, axis) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
        scene.camera.axis,
    );
    Ok(CaptureModel::unscaled(
        &opts.flaws,
        nx,
        ny,
        axis,
        opts.seed,
    )?)
}

/// The files of a capture folder `dir` that follow the truth cubes (written in `dir` by the
/// time this runs, with their camera-time `peaks`): the streak images, the side files and
/// the manifest. Returns every file of the folder (relative to `dir`), the number of
/// fiducial markers and of streak-image values at the top count.
pub(crate) fn finish_capture(
    scene: &Scene,
    opts: &SimulateOptions,
    bvh: &Bvh,
    shape: CaptureModel,
    peaks: &Peaks,
    dir: &Path,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<(Vec<PathBuf>, usize, usize), SimulateError> {
    let ny = scene.camera.intrinsics.height;
    let model = shape.scaled(peaks);
    let (mut written, values_at_top_count) = write_scanlines(
        dir,
        &dir.join(TRUTH_CAMERA_FILE),
        &model,
        &opts.formats,
        progress,
    )?;
    written.extend(
        [TRUTH_CAMERA_FILE, TRUTH_WORLD_FILE, TRUTH_DIRECT_FILE]
            .into_iter()
            .map(PathBuf::from),
    );
    let scanlines = scanline_entries(ny, &opts.formats);

    let (capture_files, n_points) = write_side_files(scene, opts, bvh, &model, dir, &mut written)?;

    let manifest = Manifest {
        capture: capture_info(scene, opts, &model),
        files: capture_files,
        imperfections: model.imperfections(),
        scanlines,
    };
    manifest.save(&dir.join(MANIFEST_FILE))?;
    written.push(MANIFEST_FILE.into());

    set_folder_permissions(&[dir.to_path_buf(), dir.join("scanlines")])?;
    Ok((written, n_points, values_at_top_count))
}

/// Outputs are ordinary folders, not tempfile's owner-only ones.
pub(crate) fn set_folder_permissions(dirs: &[PathBuf]) -> Result<(), SimulateError> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        for d in dirs {
            std::fs::set_permissions(d, std::fs::Permissions::from_mode(0o755))
                .map_err(io_err(d))?;
        }
    }
    Ok(())
}
/// The files of the capture folder `dir` but the truth cubes and the scanlines (written in
/// `dir` by the time this runs): the scene as glTF, the true calibration, the fiducial
/// markers, and the flat field and dark frame when the flaws have them. Each file written is
/// added to `written`; returns the manifest's `[files]` and how many markers were written.
fn write_side_files(
    scene: &Scene,
    opts: &SimulateOptions,
    bvh: &Bvh,
    model: &CaptureModel,
    dir: &Path,
    written: &mut Vec<PathBuf>,
) -> Result<(CaptureFiles, usize), SimulateError> {
    let (nx, ny, axis) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
        scene.camera.axis,
    );
    write_glb(&scene.mesh, &dir.join(GEOMETRY_FILE))?;
    written.push(GEOMETRY_FILE.into());

    let calibration = scene.calibration();
    let calib_path = dir.join(CALIBRATION_FILE);
    write_atomically(&calib_path, |t| std::fs::write(t, calibration.to_toml()))
        .map_err(io_err(&calib_path))?;
    written.push(CALIBRATION_FILE.into());

    let mut points = fiducials(scene, bvh, opts.marker_spacing_m);
    if let Some(photo_px) = opts.flaws.fiducial_photo_px {
        let sigma_px = super::flaws::fiducial_capture_px(photo_px, nx);
        points = super::flaws::add_fiducial_noise(&points, sigma_px, opts.seed);
    }
    save_points_toml(&dir.join(FIDUCIALS_FILE), &points)?;
    written.push(FIDUCIALS_FILE.into());

    let mut capture_files = CaptureFiles {
        geometry: Some(GEOMETRY_FILE.into()),
        calibration: Some(CALIBRATION_FILE.into()),
        fiducials: Some(FIDUCIALS_FILE.into()),
        truth_camera: Some(TRUTH_CAMERA_FILE.into()),
        truth_world: Some(TRUTH_WORLD_FILE.into()),
        truth_direct: Some(TRUTH_DIRECT_FILE.into()),
        flat: None,
        dark: None,
    };
    if opts.flaws.vignetting.is_some() {
        let flat = StreakImage::new(nx, ny, model.flat_field());
        write_exr_f32(&dir.join(FLAT_FILE), &flat)?;
        written.push(FLAT_FILE.into());
        capture_files.flat = Some(FLAT_FILE.into());
    }
    if let Some(counts) = model.dark_frame_counts() {
        let frame = transpose_to_streak(&counts, axis.nt, nx, model.value_per_count);
        write_exr_f32(&dir.join(DARK_FILE), &frame)?;
        written.push(DARK_FILE.into());
        capture_files.dark = Some(DARK_FILE.into());
    }
    Ok((capture_files, points.len()))
}

/// The manifest's `[capture]` table of a capture of `scene` made with `opts` and `model`.
fn capture_info(scene: &Scene, opts: &SimulateOptions, model: &CaptureModel) -> CaptureInfo {
    let axis = scene.camera.axis;
    let (nx, ny) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
    );
    CaptureInfo {
        scene: scene.name.clone(),
        nx,
        ny,
        nt: axis.nt,
        dt_ps: axis.dt_ps,
        t0_ps: axis.t0_ps,
        exposure_s: None,
        exposure_note: Some(format!(
            "simulated: one laser pulse of energy {} per scanline, {} paths per pixel, at \
             most {} bounces; signal = counts x png_value_per_count (the .png and .img \
             files hold counts, the .exr files signal), in the units of {TRUTH_CAMERA_FILE}",
            scene.laser.energy, opts.spp, opts.max_bounces
        )),
        sensor_fwhm_ps: None,
        png_value_per_count: Some(model.value_per_count),
        eta: scene.eta,
        laser_wavelength_nm: scene.laser.wavelength_nm,
        pulse_width_fs: scene.laser.pulse_width_fs,
        formats: opts.formats.clone(),
        seed: Some(opts.seed),
        spp: Some(opts.spp),
        created_by: Some(opts.created_by.clone()),
    }
}

/// Render image rows `rows` of the true cubes band by band, writing the three truth files
/// (of `rows.len()` rows) into `dir` as the bands come (so only one band of rows is ever
/// held), and return the camera-time peaks of those rows that scale the capture (`shape`:
/// the capture model before scaling) with the render's counters (`seconds`: the tracer's
/// time, without the file writes).
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_truths(
    scene: &Scene,
    bvh: &Bvh,
    trace_opts: &TraceOptions,
    shape: &CaptureModel,
    rows: std::ops::Range<usize>,
    dir: &Path,
    provenance: &Provenance,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<(Peaks, TraceStats), SimulateError> {
    let started = Instant::now();
    let tracer = Tracer::new(scene, bvh, trace_opts);
    let mut render_seconds = started.elapsed().as_secs_f64();
    let mut render_cpu_seconds = 0.0;
    let world_axis = tracer
        .world_axis()
        .expect("the tracer was asked for world time");
    let (nx, ny, axis) = (scene.camera.intrinsics.width, rows.len(), scene.camera.axis);
    let writer = |file: &str, axis, frame, what: &str| {
        CubeWriter::create(
            &dir.join(file),
            nx,
            ny,
            axis,
            frame,
            DEFAULT_UNITS,
            &provenance.clone().with_note("content", what),
        )
    };
    let mut camera_file = writer(
        TRUTH_CAMERA_FILE,
        axis,
        TimeFrame::Camera,
        "all light, camera time",
    )?;
    let mut world_file = writer(
        TRUTH_WORLD_FILE,
        world_axis,
        TimeFrame::World,
        "all light, world time (when the light is at the surface seen by the pixel)",
    )?;
    let mut direct_file = writer(
        TRUTH_DIRECT_FILE,
        axis,
        TimeFrame::Camera,
        "one-bounce light only, camera time",
    )?;
    let mut peaks = Peaks::default();
    // Camera, one-bounce, multi-bounce and world-time values of one row, as f32.
    let row_bytes = 4 * nx * (3 * axis.nt + world_axis.nt);
    let band = (BAND_TARGET_BYTES / row_bytes.max(1)).max(4 * rayon::current_num_threads());
    let row_len = nx * axis.nt;
    let mut stats = TraceStats::default();
    for y0 in rows.clone().step_by(band.max(1)) {
        let r = tracer.render_rows(y0..(y0 + band).min(rows.end), &|n| {
            progress(Stage::Render, n)
        });
        stats.add(&r.stats);
        render_seconds += r.stats.seconds;
        render_cpu_seconds += r.stats.cpu_seconds;
        peaks = r
            .camera_time
            .data
            .par_chunks(row_len.max(1))
            .enumerate()
            .map(|(dy, row)| shape.row_peaks(y0 + dy, row))
            .reduce(|| peaks, Peaks::max);
        let y = y0 - rows.start;
        camera_file.write_rows(y, &r.camera_time.data)?;
        let world = r.world_time.expect("the tracer was asked for world time");
        world_file.write_rows(y, &world.data)?;
        let direct = r.direct.expect("the tracer was asked for the bounce split");
        direct_file.write_rows(y, &direct.data)?;
    }
    camera_file.finish()?;
    world_file.finish()?;
    direct_file.finish()?;
    stats.seconds = render_seconds;
    stats.cpu_seconds = render_cpu_seconds;
    Ok((peaks, stats))
}

/// Refuse a destination that is a file, or a non-empty folder without `force` (checked again
/// by [`simulate_capture`]; callers may check first, before they print anything).
pub fn check_destination(out_dir: &Path, force: bool) -> Result<(), SimulateError> {
    let exists = |message: &str| {
        Err(SimulateError::OutputExists {
            path: out_dir.to_path_buf(),
            message: message.into(),
        })
    };
    match std::fs::symlink_metadata(out_dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(io_err(out_dir)(e)),
        Ok(m) if !m.is_dir() => exists("exists and is not a folder"),
        Ok(_) => {
            let non_empty = std::fs::read_dir(out_dir)
                .map_err(io_err(out_dir))?
                .next()
                .is_some();
            if non_empty && !force {
                exists("folder exists and is not empty")
            } else {
                Ok(())
            }
        }
    }
}

/// Put the finished temporary folder in place as `out_dir`, replacing an existing one
/// (empty, or any with `force`) whole ([`crate::atomic::replace_dir`]).
fn install(tmp: crate::atomic::TempDir, out_dir: &Path, force: bool) -> Result<(), SimulateError> {
    check_destination(out_dir, force)?;
    crate::atomic::replace_dir(tmp, out_dir).map_err(io_err(out_dir))
}

/// A `[x][t]` row of counts as a streak image `[t][x]` of `counts x scale`.
fn transpose_to_streak(counts_xt: &[f32], nt: usize, nx: usize, scale: f64) -> StreakImage {
    let mut data = vec![0.0f32; nx * nt];
    for x in 0..nx {
        for t in 0..nt {
            data[t * nx + x] = (counts_xt[x * nt + t] as f64 * scale) as f32;
        }
    }
    StreakImage::new(nx, nt, data)
}

/// Relative path of scanline `y` in format `f`.
fn scanline_file(y: usize, f: StreakFormat) -> PathBuf {
    Manifest::default_scanline_name(y, f.extension())
}

fn scanline_entries(ny: usize, formats: &[StreakFormat]) -> Vec<Scanline> {
    let pick = |y: usize, wanted: &[StreakFormat]| {
        formats
            .iter()
            .find(|f| wanted.contains(f))
            .map(|&f| scanline_file(y, f))
    };
    (0..ny)
        .map(|y| Scanline {
            index: y,
            file: scanline_file(y, formats[0]),
            png: pick(y, &[StreakFormat::Png16]),
            exr: pick(y, &[StreakFormat::ExrF32]),
            img: pick(y, &[StreakFormat::Img16, StreakFormat::Img32]),
        })
        .collect()
}

/// Apply the imperfections to every scanline of the clean camera-time cube in `truth_file`
/// (read back in bands, so it is never held whole) and write its streak images; returns the
/// relative paths written and the number of values at the top count.
fn write_scanlines(
    dir: &Path,
    truth_file: &Path,
    model: &CaptureModel,
    formats: &[StreakFormat],
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<(Vec<PathBuf>, usize), SimulateError> {
    let sub = dir.join("scanlines");
    std::fs::create_dir(&sub).map_err(io_err(&sub))?;
    let (nx, ny, nt) = (model.nx, model.ny, model.axis.nt);
    let axis = model.axis;
    // The time table of an .img file is the instrument's calibration of its sweep: the true
    // start of every recorded row (the non-linear sweep's edges when there is one).
    let row_starts_ps: Vec<f64> = match &model.sweep_edges_ps {
        Some(edges) => edges[..nt].to_vec(),
        None => (0..nt).map(|i| axis.bin_start_ps(i)).collect(),
    };
    let reader = CubeReader::open(truth_file)?;
    let row_len = nx * nt;
    let band = (BAND_TARGET_BYTES / (4 * row_len).max(1)).max(4 * rayon::current_num_threads());
    let mut top = 0;
    for y0 in (0..ny).step_by(band.max(1)) {
        let rows = band.min(ny - y0);
        let truth = reader.read_rows(y0, rows)?;
        let per_row: Vec<Result<usize, SimulateError>> = truth
            .par_chunks(row_len.max(1))
            .enumerate()
            .map(|(dy, truth_row)| {
                let y = y0 + dy;
                let mut counts = vec![0.0f32; nx * nt];
                model.apply_row(y, truth_row, &mut counts);
                let top = counts.iter().filter(|&&c| c as f64 >= MAX_COUNT).count();
                let as_counts = transpose_to_streak(&counts, nt, nx, 1.0);
                for &f in formats {
                    let path = dir.join(scanline_file(y, f));
                    match f {
                        StreakFormat::Png16 => {
                            write_png16(&path, &as_counts, 1.0)?;
                        }
                        StreakFormat::ExrF32 => {
                            let signal =
                                transpose_to_streak(&counts, nt, nx, model.value_per_count);
                            write_exr_f32(&path, &signal)?;
                        }
                        StreakFormat::Img16 => {
                            write_img(&path, &as_counts, 16, &row_starts_ps)?;
                        }
                        StreakFormat::Img32 => {
                            write_img(&path, &as_counts, 32, &row_starts_ps)?;
                        }
                    }
                }
                progress(Stage::Write, 1);
                Ok(top)
            })
            .collect();
        for r in per_row {
            top += r?;
        }
    }
    let files = (0..ny)
        .flat_map(|y| formats.iter().map(move |&f| scanline_file(y, f)))
        .collect();
    Ok((files, top))
}
