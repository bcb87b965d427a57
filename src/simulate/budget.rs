//! What a simulated capture asks of the machine, estimated from the scene and the options
//! before anything is rendered or allocated ([`crate::limits`]): every count that drives a
//! loop or a buffer (pixels per side, camera paths, time bins, the pulse's span in bins, the
//! world-time bins, the fiducial grid's nodes) is capped, and the peak memory of the stage is compared
//! with what the machine has available. A refusal names the flag that fixes it.
//!
//! The estimate follows [`super::capture::simulate_capture`]'s buffers: the render holds one
//! band of rows of the four cubes (camera, one-bounce, multi-bounce, world time) and the
//! time-response tables; the scanline pass one band of the truth cube and a few scanlines
//! per thread; the fiducial pass every grid node as a named point; the flat field, the
//! per-scanline values and the manifest are held throughout.

use super::fiducials::marker_candidates;
use crate::limits::{bounded_count, check_memory, short_number, LimitError, MAX_COUNT};
use crate::scene::Scene;
use crate::tracer::binning::ResponseTable;
use crate::units::flight_time_ps;

/// Bytes of tracer output a band of rows may hold while the truth cubes are rendered.
pub(crate) const BAND_TARGET_BYTES: usize = 64 << 20;

/// Most pixels along either side of a simulated image (the seed's capture is 672 x 600).
pub const MAX_SIDE: u64 = 1 << 15;

/// Most time bins of the camera axis and of the world-time axis derived from it.
pub const MAX_BINS: u64 = 1 << 22;

/// Most bins one sample may weigh (the pulse's span in bins): each splat walks them.
pub const MAX_PULSE_BINS: u64 = 1 << 16;

/// Most fiducial grid nodes tested (each is projected and checked for occlusion).
pub const MAX_MARKER_CANDIDATES: u64 = 1 << 24;

/// Memory of the process before the stage allocates anything: code, the thread pool, the
/// HDF5 library, the scene and its BVH at the sizes of the built-in scenes.
const BASE_BYTES: f64 = 24e6;

/// Bytes per fiducial grid node: the point and its name while the grid is built, the
/// correspondence and the separation sweep's indices after.
const BYTES_PER_MARKER: f64 = 160.0;

/// Bytes per scanline held throughout: its jitter and power values, its manifest entry (three
/// paths) and the manifest's text.
const BYTES_PER_SCANLINE: f64 = 400.0;

/// The sizes a capture's buffers follow, each capped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    pub nx: usize,
    pub ny: usize,
    pub nt: usize,
    /// An upper bound of the world-time axis's bins (the render's own axis is computed by
    /// probing every pixel, which this must not do first).
    pub world_nt: usize,
    /// Fiducial grid nodes.
    pub marker_candidates: usize,
    /// Image rows the render holds at once, and the bytes of their four cubes.
    pub band_rows: usize,
    pub band_bytes: f64,
    /// Peak memory of the stage, bytes.
    pub bytes: f64,
}

/// Cap every count of the capture of `scene` at `spp` camera paths per pixel with fiducial
/// markers `marker_spacing_m` apart, and estimate its peak memory (module doc); refuse a
/// count beyond its cap. Does not look at the memory available.
pub fn budget(scene: &Scene, spp: u32, marker_spacing_m: f64) -> Result<Budget, LimitError> {
    let cam = &scene.camera;
    let nx = bounded_count(
        cam.intrinsics.width as f64,
        MAX_SIDE,
        "the image width (pixels)",
        "lower --size",
    )?;
    let ny = bounded_count(
        cam.intrinsics.height as f64,
        MAX_SIDE,
        "the image height (pixels)",
        "lower --size",
    )?;
    bounded_count(
        nx as f64 * ny as f64 * spp as f64,
        MAX_COUNT,
        format_args!(
            "the camera paths of {nx} x {ny} pixels at {} per pixel",
            spp
        ),
        "lower --spp or --size",
    )?;
    let axis = cam.axis;
    let nt = bounded_count(axis.nt as f64, MAX_BINS, "the time bins", "lower --nt")?;
    let sigma_ps = scene.laser.pulse_sigma_ps();
    bounded_count(
        ResponseTable::weights_per_sample(axis.dt_ps, sigma_ps),
        MAX_PULSE_BINS,
        format!(
            "the laser pulse (pulse_width_fs = {}) measured in bins of {} ps (bins per sample)",
            short_number(scene.laser.pulse_width_fs),
            short_number(axis.dt_ps)
        ),
        "raise --dt-ps or shorten the pulse",
    )?;
    let world_nt = bounded_count(
        world_bins_bound(scene),
        MAX_BINS,
        format!(
            "the world-time bins of {} ps covering the scene",
            short_number(axis.dt_ps)
        ),
        "raise --dt-ps",
    )?;
    let marker_candidates = bounded_count(
        marker_candidates(scene, marker_spacing_m),
        MAX_MARKER_CANDIDATES,
        format!(
            "the fiducial grid at {} m spacing (nodes)",
            short_number(marker_spacing_m)
        ),
        "raise --marker-spacing-m",
    )?;

    let threads = rayon::current_num_threads().max(1) as f64;
    let (fx, fy, ft, fw) = (nx as f64, ny as f64, nt as f64, world_nt as f64);
    // Render: one band of the four f32 cubes, per-thread f64 accumulators, the tables.
    let row_bytes = 4.0 * fx * (3.0 * ft + fw);
    let band = (BAND_TARGET_BYTES as f64 / row_bytes.max(1.0))
        .floor()
        .max(4.0 * threads)
        .min(fy);
    let tables = ResponseTable::bytes_estimate(axis.dt_ps, sigma_ps) * 2.0;
    let band_bytes = band * row_bytes;
    let render = band_bytes + threads * 8.0 * (3.0 * ft + fw) + tables;
    // Scanlines: a band of the truth cube read back, and per thread the counts and two
    // streak images of one scanline with its encoded file.
    let scan_row = 4.0 * fx * ft;
    let scan_band = (BAND_TARGET_BYTES as f64 / scan_row.max(1.0))
        .floor()
        .max(4.0 * threads)
        .min(fy);
    let scanlines = scan_band * scan_row + threads * 4.0 * scan_row;
    let markers = marker_candidates as f64 * BYTES_PER_MARKER;
    // Held throughout: the flat field, the dark frame, the per-scanline values.
    let held = 4.0 * fx * fy + 8.0 * fx * ft + BYTES_PER_SCANLINE * fy;
    let bytes = BASE_BYTES + held + render.max(scanlines).max(markers);
    Ok(Budget {
        nx,
        ny,
        nt,
        world_nt,
        marker_candidates,
        band_rows: band as usize,
        band_bytes,
        bytes,
    })
}

/// Refuse a capture whose counts exceed their caps or whose peak memory ([`budget`]) exceeds
/// what the machine has available.
pub fn check(scene: &Scene, spp: u32, marker_spacing_m: f64) -> Result<Budget, LimitError> {
    let b = budget(scene, spp, marker_spacing_m)?;
    check_memory(
        b.bytes,
        format!(
            "the simulated capture of {} x {} pixels, {} bins (at most {} in world time)",
            b.nx, b.ny, b.nt, b.world_nt
        ),
        "lower --size or --nt",
    )?;
    Ok(b)
}

/// An upper bound of the bins of the render's world-time axis ([`crate::tracer::world_axis`]):
/// the camera window widened by the flight times between the nearest and the farthest point
/// of the mesh's bounding box from the camera.
fn world_bins_bound(scene: &Scene) -> f64 {
    let axis = scene.camera.axis;
    let b = scene.mesh.bounds();
    if b.is_empty() {
        return axis.nt as f64;
    }
    let o = scene.camera.pose.position_m;
    let (lo, hi) = (b.min.cast::<f64>(), b.max.cast::<f64>());
    let mut far = 0.0f64;
    for corner in 0..8 {
        let pick = |k: usize, bit: usize| if corner >> bit & 1 == 1 { hi[k] } else { lo[k] };
        let c = nalgebra::Point3::new(pick(0, 0), pick(1, 1), pick(2, 2));
        far = far.max((c - o).norm());
    }
    let nearest = nalgebra::Point3::new(
        o.x.clamp(lo.x, hi.x),
        o.y.clamp(lo.y, hi.y),
        o.z.clamp(lo.z, hi.z),
    );
    let near = (nearest - o).norm();
    let widen_ps = flight_time_ps(scene.eta, far) - flight_time_ps(scene.eta, near);
    (axis.nt as f64 * axis.dt_ps + widen_ps) / axis.dt_ps + 2.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::bvh::Bvh;
    use crate::simulate::fiducials::DEFAULT_MARKER_SPACING_M;

    #[test]
    fn the_world_axis_bound_holds_the_render_s_axis_within_a_factor_two() {
        for name in ["cube", "cornell"] {
            let scene = Scene::builtin(name, None).unwrap();
            let bvh = Bvh::new(scene.mesh.clone());
            let real = crate::tracer::world_axis(&scene, &bvh).nt as f64;
            let bound = world_bins_bound(&scene);
            assert!(
                bound >= real && bound <= 2.0 * real,
                "{name}: {bound} vs {real}"
            );
        }
    }

    #[test]
    fn the_band_estimate_holds_the_tracer_s_band_within_a_factor_two() {
        use crate::tracer::{TraceOptions, Tracer};
        let scene = Scene::builtin("cube", None)
            .unwrap()
            .with_resolution(48, 32, 512, 2.0);
        let b = budget(&scene, 1, DEFAULT_MARKER_SPACING_M).unwrap();
        let bvh = Bvh::new(scene.mesh.clone());
        let trace = TraceOptions {
            spp: 1,
            max_bounces: 1,
            split_bounces: true,
            world_time: true,
            ..TraceOptions::default()
        };
        let r = Tracer::new(&scene, &bvh, &trace).render_rows(0..b.band_rows, &|_| {});
        let cubes = [
            Some(&r.camera_time),
            r.direct.as_ref(),
            r.multi.as_ref(),
            r.world_time.as_ref(),
        ];
        let held: usize = cubes.iter().flatten().map(|c| 4 * c.data.len()).sum();
        assert!(held > 0);
        let held = held as f64;
        assert!(
            b.band_bytes >= held && b.band_bytes <= 2.0 * held,
            "{} vs {held}",
            b.band_bytes
        );
        // The whole estimate is the band, the tables and the process itself: about 30 MB.
        assert!(
            b.bytes > b.band_bytes && b.bytes < b.band_bytes + 40e6,
            "{}",
            b.bytes
        );
    }

    #[test]
    fn counts_beyond_their_caps_are_refused_with_the_flag() {
        let scene = Scene::builtin("cube", None).unwrap();
        let spp = crate::simulate::SimulateOptions::default().spp;
        let ok = budget(&scene, spp, DEFAULT_MARKER_SPACING_M).unwrap();
        assert_eq!((ok.nx, ok.ny), (64, 48));
        let wide = scene.with_resolution(100_000, 100_000, 256, 4.0);
        let e = budget(&wide, spp, DEFAULT_MARKER_SPACING_M)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--size") && e.contains("100000"), "{e}");
        let fine = scene.with_resolution(64, 48, 256, 1e-300);
        let e = budget(&fine, spp, DEFAULT_MARKER_SPACING_M)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--dt-ps"), "{e}");
        let e = budget(&scene, spp, 1e-9).unwrap_err().to_string();
        assert!(e.contains("--marker-spacing-m"), "{e}");
    }
}
