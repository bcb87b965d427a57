//! `femto simulate --transient-only`: the transient path tracer alone (seed Eq. 1,
//! physics.md "Transient path tracing"), as a transient renderer such as mitransient is run:
//! the scene's true cube in camera time and the render's counters, nothing of the streak
//! camera. The comparison with Mitsuba (`tools/compare_mitsuba.py`) runs this from the
//! release binary, with the same thread count and, with [`TimeFilter::Box`], the same
//! quantity per time bin.
//!
//! | file               | content                                                          |
//! |--------------------|------------------------------------------------------------------|
//! | `truth_camera.h5`  | the true cube, camera time, all light (the capture's file of the same name) |
//! | `render.json`      | [`RenderCounters`]: settings, paths, rays, wall and CPU seconds of the render |

use super::budget::BAND_TARGET_BYTES;
use super::options::{SimulateError, SimulateOptions, Stage, TRUTH_CAMERA_FILE};
use crate::container::{CubeWriter, Provenance, DEFAULT_UNITS};
use crate::cube::TimeFrame;
use crate::geometry::bvh::Bvh;
use crate::scene::Scene;
use crate::tracer::{TimeFilter, TraceOptions, TraceStats, Tracer};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The counters file of a transient-only render.
pub const COUNTERS_FILE: &str = "render.json";

/// What `render.json` holds: the render's settings and counters. Times are the tracer's
/// alone (the BVH is built before, the file written after), as a renderer's own timer would
/// report them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RenderCounters {
    pub scene: String,
    pub nx: usize,
    pub ny: usize,
    pub nt: usize,
    pub t0_ps: f64,
    pub dt_ps: f64,
    pub spp: u32,
    pub seed: u64,
    pub max_bounces: u32,
    /// `"sensor"` or `"box"`.
    pub time_filter: &'static str,
    /// First bounce at which Russian roulette may end a path.
    pub rr_start_bounce: u32,
    /// Rayon worker threads of the render.
    pub threads: usize,
    pub paths: u64,
    pub rays: u64,
    /// Paths ended early because all they could still deliver would arrive after the window.
    pub paths_ended_late: u64,
    /// Light that fell outside the time window, summed over pixels (cube units).
    pub energy_outside_window: f64,
    /// Wall-clock seconds of the render.
    pub render_seconds: f64,
    /// CPU seconds of the render (all threads, user + system).
    pub render_cpu_seconds: f64,
}

/// The name of a time filter in files and flags.
pub fn time_filter_name(filter: TimeFilter) -> &'static str {
    match filter {
        TimeFilter::Sensor => "sensor",
        TimeFilter::Box => "box",
    }
}

/// Render the camera-time cube of `scene` band by band into `dir/truth_camera.h5` and write
/// `dir/render.json`; returns the counters and the files written (relative to `dir`).
pub(super) fn stage(
    scene: &Scene,
    opts: &SimulateOptions,
    dir: &Path,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<(TraceStats, Vec<PathBuf>), SimulateError> {
    let bvh = Bvh::new(scene.mesh.clone());
    let mut trace_opts = TraceOptions {
        spp: opts.spp,
        max_bounces: opts.max_bounces,
        seed: opts.seed,
        split_bounces: false,
        world_time: false,
        time_filter: opts.time_filter,
        ..TraceOptions::default()
    };
    if let Some(b) = opts.rr_start_bounce {
        trace_opts.rr_start_bounce = b;
    }
    let filter = time_filter_name(opts.time_filter);
    let provenance = Provenance::new(opts.created_by.clone())
        .with_note("scene", scene.name.clone())
        .with_note("seed", opts.seed.to_string())
        .with_note("spp", opts.spp.to_string())
        .with_note("max_bounces", opts.max_bounces.to_string())
        .with_note("time_filter", filter)
        .with_note("content", "all light, camera time")
        .with_note(
            "values",
            match opts.time_filter {
                TimeFilter::Sensor => {
                    "radiance integrated over each time bin against the sensor's response \
                     (tracer units, proportional to the pulse energy)"
                }
                TimeFilter::Box => {
                    "radiance of the light arriving within each time bin (a histogram of \
                     arrival times; tracer units, proportional to the pulse energy)"
                }
            },
        );
    let (nx, ny, axis) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
        scene.camera.axis,
    );
    let tracer = Tracer::new(scene, &bvh, &trace_opts);
    let mut file = CubeWriter::create(
        &dir.join(TRUTH_CAMERA_FILE),
        nx,
        ny,
        axis,
        TimeFrame::Camera,
        DEFAULT_UNITS,
        &provenance,
    )?;
    let band =
        (BAND_TARGET_BYTES / (4 * nx * axis.nt).max(1)).max(4 * rayon::current_num_threads());
    let mut stats = TraceStats::default();
    for y0 in (0..ny).step_by(band) {
        let r = tracer.render_rows(y0..y0 + band, &|n| progress(Stage::Render, n));
        stats.add(&r.stats);
        stats.seconds += r.stats.seconds;
        stats.cpu_seconds += r.stats.cpu_seconds;
        file.write_rows(y0, &r.camera_time.data)?;
    }
    file.finish()?;
    let counters = RenderCounters {
        scene: scene.name.clone(),
        nx,
        ny,
        nt: axis.nt,
        t0_ps: axis.t0_ps,
        dt_ps: axis.dt_ps,
        spp: opts.spp,
        seed: opts.seed,
        max_bounces: opts.max_bounces,
        time_filter: filter,
        rr_start_bounce: trace_opts.rr_start_bounce,
        threads: rayon::current_num_threads(),
        paths: stats.paths,
        rays: stats.rays,
        paths_ended_late: stats.paths_ended_late,
        energy_outside_window: stats.energy_outside_window,
        render_seconds: stats.seconds,
        render_cpu_seconds: stats.cpu_seconds,
    };
    let json = serde_json::to_string_pretty(&counters).expect("plain numbers and strings");
    let path = dir.join(COUNTERS_FILE);
    std::fs::write(&path, json + "\n").map_err(|source| SimulateError::Io { path, source })?;
    Ok((
        stats,
        vec![
            PathBuf::from(TRUTH_CAMERA_FILE),
            PathBuf::from(COUNTERS_FILE),
        ],
    ))
}
