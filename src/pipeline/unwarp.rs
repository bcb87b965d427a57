//! The unwarp stage: a cube file moved between the camera clock and the world clock, pixel by
//! pixel, with the distances of a registration (seed Eq. 2, physics.md:
//! `t_world = t_camera - eta |p - o| / c`; the kernel is [`crate::unwarp::unwarp_rows`]).
//!
//! The distances and `eta` come from the cube's `registration` group, else from its `tal`
//! group (a y-tal capture: each pixel's sensor point and the sensor's origin, eta 1; for a
//! confocal scan the pixel's own first bounce, laser origin to wall point, is removed too, see
//! [`crate::interop::tal`]), or from a calibration and a mesh (the cube's pixels are taken to
//! be that camera's pixels and the rays are cast anew). The registration used is stored in the
//! output (the `tal` group is carried over), so that the reverse direction can undo it. The output time axis covers every shifted sample, aligned with the input's bins,
//! unless one is given. Pixels the registration marks as seeing nothing are masked, whatever
//! their distance says. The cube is streamed by row slabs; the output keeps the input's
//! compression and provenance notes (the laser wavelength `laser_nm` among them) unless told
//! otherwise.

use super::{refuse_same_file, Progress, StageError, StageOption};
use crate::calibrate::register;
use crate::camera::Calibration;
use crate::container::{CubeCompression, CubeMeta, CubeReader, CubeWriter, GroupData, Provenance};
use crate::cube::{row_slabs, TimeAxis, TimeFrame};
use crate::geometry::bvh::Bvh;
use crate::interop::geometry_from_group;
use crate::interop::tal::{self, LaserSpot};
use crate::limits::check_memory;
use crate::store::registration::{self, StoredRegistration};
use crate::unwarp::{covering_axis, unwarp_rows, Direction};
use std::path::Path;

/// Largest slab of input plus output rows moved at once, bytes: 16 MiB, so that a caller
/// polling between slabs (the Python package's Ctrl-C) waits for one slab's compression at
/// most (64 MiB took 1.0 s at a load of 4.5 per CPU).
const SLAB_BYTES: usize = 16 << 20;

/// Memory of the process before the stage allocates anything (code, threads, HDF5), bytes.
const BASE_BYTES: f64 = 24e6;

/// Bytes held per pixel: the registration group as read and as typed (distance, mask,
/// normal and point per pixel), the distances used, the input and output masks.
const BYTES_PER_PIXEL: f64 = 64.0;

/// Peak memory of [`unwarp_file`] on an `nx` x `ny` cube of `nt_in` bins unwarped onto
/// `nt_out` bins, bytes: the per-pixel maps and one slab of input and output rows (at least
/// one row, however long). A float, so that no product of file sizes can overflow.
pub fn memory_estimate(nx: usize, ny: usize, nt_in: usize, nt_out: usize) -> f64 {
    let (fx, fy) = (nx as f64, ny as f64);
    let row_bytes = 4.0 * fx * (nt_in as f64 + nt_out as f64);
    let rows = (SLAB_BYTES as f64 / row_bytes.max(1.0))
        .floor()
        .clamp(1.0, fy.max(1.0));
    BASE_BYTES + BYTES_PER_PIXEL * fx * fy + rows * row_bytes
}

/// Refuse an unwarp of `input` whose [`memory_estimate`] exceeds the memory available; the
/// fix is the output axis's flags when they set it, else the input's own axis and distances.
fn check_unwarp_memory(
    input: &Path,
    (nx, ny, nt_in): (usize, usize, usize),
    nt_out: usize,
    axis_given: bool,
) -> Result<(), StageError> {
    let fix = if axis_given {
        "lower --nt or raise --dt-ps"
    } else {
        "check the cube's dt_ps and the registration's dist_m, or give a shorter output axis \
         (--t0-ps, --nt, --dt-ps)"
    };
    check_memory(
        memory_estimate(nx, ny, nt_in, nt_out),
        format_args!(
            "unwarping {} ({nx} x {ny} pixels) onto {nt_out} bins",
            input.display()
        ),
        fix,
    )?;
    Ok(())
}

/// Where the per-pixel distances come from.
#[derive(Clone, Copy)]
pub enum Distances<'a> {
    /// The cube's own geometry: its `registration` group (written by `femto calibrate`), else
    /// its `tal` group (written by `femto ingest` of a y-tal capture).
    Stored,
    /// Rays cast anew through `calibration` into `mesh`.
    Cast {
        calibration: &'a Calibration,
        /// Name of the calibration file, for provenance.
        calibration_name: &'a str,
        mesh: &'a Bvh,
        /// Name of the mesh file, for provenance and the stored registration.
        mesh_name: &'a str,
    },
}

/// How [`unwarp_file`] converts; `Default` is what `femto unwarp` does.
#[derive(Clone, Debug, PartialEq)]
pub struct UnwarpOptions {
    pub direction: Direction,
    /// The output's time axis; None: one covering every shifted sample, aligned with the
    /// input's bins.
    pub axis: Option<TimeAxis>,
    /// The output's compression; None: the input's.
    pub compression: Option<CubeCompression>,
    /// The command line recorded in the output.
    pub command_line: String,
    /// Pixels whose footprint spans more bins of path than this are masked as mixed
    /// ([`crate::calibrate::mixed`]; infinity keeps every pixel).
    pub mask_spread_bins: f64,
}

impl Default for UnwarpOptions {
    fn default() -> Self {
        UnwarpOptions {
            direction: Direction::CameraToWorld,
            axis: None,
            compression: None,
            command_line: String::new(),
            mask_spread_bins: crate::calibrate::mixed::MASK_SPREAD_BINS,
        }
    }
}

/// What [`unwarp_file`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct Unwarped {
    pub nx: usize,
    pub ny: usize,
    pub from: TimeFrame,
    pub to: TimeFrame,
    pub input_axis: TimeAxis,
    pub output_axis: TimeAxis,
    pub eta: f64,
    /// Pixels shifted (valid in the output).
    pub valid_pixels: usize,
    /// Smallest and largest distance of the pixels shifted, metres (None: none sees geometry).
    pub dist_range_m: Option<(f64, f64)>,
    /// Pixels whose footprint spans more than one bin of path: their light is smeared over
    /// that many bins by the one distance they are shifted by ([`crate::calibrate::mixed`]).
    pub straddling_pixels: usize,
    /// Of those, the pixels masked as mixed: their footprint spans more than
    /// [`crate::calibrate::mixed::MASK_SPREAD_BINS`] bins.
    pub mixed_pixels: usize,
    /// Scanlines moved by their time offsets (the registration's
    /// [`registration::SCANLINE_OFFSETS`]).
    pub scanlines_moved: usize,
    pub compression: CubeCompression,
}

/// Convert the cube at `input` into a new cube at `output` (written beside itself and renamed;
/// `output` may not be `input`).
pub fn unwarp_file(
    input: &Path,
    output: &Path,
    distances: Distances<'_>,
    options: &UnwarpOptions,
    progress: &dyn Progress,
) -> Result<Unwarped, StageError> {
    let mut inputs = vec![input];
    if let Distances::Cast {
        calibration_name,
        mesh_name,
        ..
    } = distances
    {
        inputs.extend([Path::new(calibration_name), Path::new(mesh_name)]);
    }
    refuse_same_file(output, &inputs, "out")?;
    let bins = options.mask_spread_bins;
    if bins.is_nan() || bins <= 0.0 {
        return Err(StageError::Option {
            name: StageOption::MaskSpreadBins,
            message: format!("{bins}: must be > 0 (or inf)"),
        });
    }
    let reader = CubeReader::open(input)?;
    let meta = reader.meta().clone();
    let (nx, ny) = (meta.nx, meta.ny);
    let direction = options.direction;
    let shape = (nx, ny, meta.axis.nt);
    // Before the registration is read or cast: the cube's own size and a given axis.
    let nt_given = options.axis.map_or(meta.axis.nt, |a| a.nt);
    check_unwarp_memory(input, shape, nt_given, options.axis.is_some())?;
    if meta.frame != direction.source_frame() {
        return Err(StageError::Input {
            path: input.display().to_string(),
            message: format!(
                "the cube is already in {} time (convert it to {} time instead)",
                meta.frame,
                direction.source_frame()
            ),
        });
    }

    let mask = reader.read_mask()?;
    let mut paths = load_paths(&reader, input, &meta, distances)?;
    let eta = paths.eta;
    let (straddling_pixels, mixed_pixels) =
        mask_mixed(&mut paths, meta.axis.dt_ps, options.mask_spread_bins);
    let dist = masked_distances(nx * ny, &paths.valid, &paths.dist_m, mask.as_deref());
    let dist_range_m = finite_range_m(&dist);
    let axis = output_axis(
        input,
        &meta.axis,
        options.axis,
        dist_range_m,
        eta,
        direction,
    )?;
    let axis = match (options.axis, &paths.scanline_offset_ps) {
        (None, Some(delays)) => widened_by(axis, delays),
        _ => axis,
    };
    check_unwarp_memory(input, shape, axis.nt, options.axis.is_some())?;

    let provenance = Provenance {
        command_line: options.command_line.clone(),
        notes: unwarp_notes(&meta.notes, meta.frame, direction, input, &paths.described),
    };
    let compression = options
        .compression
        .unwrap_or_else(|| reader.stored_compression());
    let mut writer = CubeWriter::create_with(
        output,
        nx,
        ny,
        axis,
        direction.target_frame(),
        &meta.units,
        &provenance,
        compression,
    )?;
    writer.keep_foreign_from(input);
    let slabs = Slabs {
        meta: &meta,
        dist: &dist,
        row_delay_ps: paths.scanline_offset_ps.as_deref().unwrap_or(&[]),
        mask: mask.as_deref(),
        eta,
        direction,
        axis: &axis,
    };
    let out_mask = stream_slabs(&reader, &mut writer, &slabs, progress)?;
    drop(reader);
    writer.write_mask(&out_mask)?;
    if let Some(group) = &paths.registration_group {
        writer.write_group(registration::GROUP, group)?;
    }
    writer.finish()?;
    Ok(Unwarped {
        nx,
        ny,
        from: meta.frame,
        to: direction.target_frame(),
        input_axis: meta.axis,
        output_axis: axis,
        eta,
        valid_pixels: out_mask.iter().filter(|&&m| m != 0).count(),
        dist_range_m,
        straddling_pixels,
        mixed_pixels,
        scanlines_moved: paths.scanline_offset_ps.as_deref().map_or(0, |o| {
            o.iter().filter(|d| d.is_finite() && **d != 0.0).count()
        }),
        compression,
    })
}

/// The per-pixel paths between the clocks that [`unwarp_file`] removes (or adds), with where
/// they came from.
struct ClockPaths {
    /// Optical path between the two clocks per pixel `[y][x]`, metres (in the medium: the
    /// shift is `eta * dist / c`).
    dist_m: Vec<f32>,
    /// 1 where the geometry gives the pixel a path.
    valid: Vec<u8>,
    eta: f64,
    /// The registration group the output gets (None: the source's `tal` group is carried
    /// over as it is).
    registration_group: Option<GroupData>,
    /// Where the paths came from, for the provenance note `unwarp.distances`.
    described: String,
    /// Each scanline's time offset against the geometry, from the registration group
    /// (`femto calibrate`), ps (NaN: not estimated); None when the group has none.
    scanline_offset_ps: Option<Vec<f64>>,
    /// Each pixel's spread of distances over its footprint, metres
    /// ([`crate::calibrate::mixed`]); None without that dataset.
    footprint_spread_m: Option<Vec<f32>>,
}

/// The paths [`unwarp_file`] uses: cast anew through a calibration into a mesh, or read from
/// the cube's own `registration` group, else its `tal` group. Refuses a cube with no group to
/// read, and a geometry whose size is not the cube's.
fn load_paths(
    reader: &CubeReader,
    input: &Path,
    meta: &CubeMeta,
    distances: Distances<'_>,
) -> Result<ClockPaths, StageError> {
    let (nx, ny) = (meta.nx, meta.ny);
    let has = |g: &str| meta.groups.iter().any(|n| n == g);
    let mut scanline_offset_ps = None;
    let footprint_spread_m;
    let (stored, group, described) = match distances {
        Distances::Cast {
            calibration,
            calibration_name,
            mesh,
            mesh_name,
        } => {
            let reg =
                register(calibration, mesh, nx, ny).map_err(|source| StageError::Calibrate {
                    path: calibration_name.to_string(),
                    source,
                })?;
            let mut group = registration::registration_group(&reg, calibration, mesh_name, None);
            let spread = crate::calibrate::mixed::footprint_spread_m(calibration, mesh, &reg);
            registration::add_footprint_spread(&mut group, nx, ny, spread.clone());
            footprint_spread_m = Some(spread);
            let stored = StoredRegistration {
                registration: reg,
                calibration: *calibration,
                mesh: mesh_name.to_string(),
                fit: None,
            };
            let described = format!("cast through {calibration_name} into {mesh_name}");
            (stored, group, described)
        }
        Distances::Stored if !has(registration::GROUP) && has(tal::GROUP) => {
            return tal_paths(reader, input, nx, ny);
        }
        Distances::Stored => {
            if !has(registration::GROUP) {
                return Err(StageError::Input {
                    path: input.display().to_string(),
                    message: format!(
                        "no /{} group: run `femto calibrate` on it first, or give \
                         --calibration CAL.toml --mesh MESH",
                        registration::GROUP
                    ),
                });
            }
            let group = reader.read_group(registration::GROUP)?;
            let stored = registration::from_group(input, &group)?;
            scanline_offset_ps = registration::scanline_offsets(input, &group, ny)?;
            footprint_spread_m = registration::footprint_spread(input, &group, nx, ny)?;
            (
                stored,
                group,
                format!("/{} group of the source", registration::GROUP),
            )
        }
    };
    let reg = stored.registration;
    if (reg.nx, reg.ny) != (nx, ny) {
        return Err(StageError::Input {
            path: input.display().to_string(),
            message: format!(
                "the registration is {} x {} pixels but the cube is {nx} x {ny}",
                reg.nx, reg.ny
            ),
        });
    }
    Ok(ClockPaths {
        dist_m: reg.dist_m,
        valid: reg.mask,
        eta: stored.calibration.eta,
        registration_group: Some(group),
        described,
        scanline_offset_ps,
        footprint_spread_m,
    })
}

/// The paths of a cube's `tal` group: each pixel's sensor point to the sensor's origin, and
/// for a confocal scan the laser's origin to the point as well ([`tal::TalGeometry::clock_path_m`]).
fn tal_paths(
    reader: &CubeReader,
    input: &Path,
    nx: usize,
    ny: usize,
) -> Result<ClockPaths, StageError> {
    let group = reader.read_group(tal::GROUP)?;
    let geo = geometry_from_group(input, &group, nx, ny).map_err(|e| StageError::Input {
        path: input.display().to_string(),
        message: e.to_string(),
    })?;
    let origins = [
        ("sensor_m", geo.sensor_m),
        ("laser_origin_m", geo.laser_origin_m),
    ];
    let needed = match geo.laser_spot_m {
        LaserSpot::Confocal => &origins[..],
        LaserSpot::Single(_) => &origins[..1],
    };
    if let Some((key, _)) = needed
        .iter()
        .find(|(_, p)| p.iter().any(|c| !c.is_finite()))
    {
        return Err(StageError::Input {
            path: input.display().to_string(),
            message: format!(
                "/{}/{key} is not recorded, so the legs to the wall cannot be removed (for an \
                 array ingested with --confocal: give --device-m X,Y,Z, or --clock world when \
                 its time starts at the wall)",
                tal::GROUP
            ),
        });
    }
    let dist_m: Vec<f32> = (0..nx * ny).map(|p| geo.clock_path_m(p) as f32).collect();
    let valid = dist_m.iter().map(|d| u8::from(d.is_finite())).collect();
    let described = match geo.laser_spot_m {
        LaserSpot::Confocal => format!(
            "/{} group of the source (confocal: sensor point to sensor and laser origin to \
             sensor point, eta 1)",
            tal::GROUP
        ),
        LaserSpot::Single(_) => format!(
            "/{} group of the source (sensor point to sensor, eta 1)",
            tal::GROUP
        ),
    };
    Ok(ClockPaths {
        dist_m,
        valid,
        eta: 1.0,
        registration_group: None,
        described,
        scanline_offset_ps: None,
        footprint_spread_m: None,
    })
}

/// The distance of each of the `n_pixels` pixels, metres, NaN where the registration's mask (`reg_mask`) or the
/// cube's (`cube_mask`) marks it as seeing nothing: such pixels get no shift, whatever
/// `dist_m` says.
fn masked_distances(
    n_pixels: usize,
    reg_mask: &[u8],
    dist_m: &[f32],
    cube_mask: Option<&[u8]>,
) -> Vec<f32> {
    (0..n_pixels)
        .map(|p| {
            let valid = reg_mask[p] != 0 && cube_mask.is_none_or(|m| m[p] != 0);
            if valid {
                dist_m[p]
            } else {
                f32::NAN
            }
        })
        .collect()
}

/// Smallest and largest finite distance, metres; None when no pixel has one.
fn finite_range_m(dist: &[f32]) -> Option<(f64, f64)> {
    dist.iter()
        .filter(|d| d.is_finite())
        .map(|&d| d as f64)
        .fold(None, |r: Option<(f64, f64)>, d| {
            Some(r.map_or((d, d), |(a, b)| (a.min(d), b.max(d))))
        })
}

/// The output's time axis: the one `given` (checked), else one covering every sample of
/// `input_axis` shifted by distances in `dist_range_m`, else (no pixel shifted) the input's.
fn output_axis(
    input: &Path,
    input_axis: &TimeAxis,
    given: Option<TimeAxis>,
    dist_range_m: Option<(f64, f64)>,
    eta: f64,
    direction: Direction,
) -> Result<TimeAxis, StageError> {
    Ok(match given {
        Some(a) => {
            if !(a.t0_ps.is_finite() && a.dt_ps.is_finite() && a.dt_ps > 0.0 && a.nt > 0) {
                return Err(StageError::Option {
                    name: StageOption::OutputAxis,
                    message: format!(
                        "need a finite start, a positive bin width and at least one bin, got \
                         {} ps, {} ps, {} bins",
                        a.t0_ps, a.dt_ps, a.nt
                    ),
                });
            }
            for (flag, v, range) in [
                ("--t0-ps", a.t0_ps, crate::ranges::TIME_PS),
                ("--dt-ps", a.dt_ps, crate::ranges::BIN_WIDTH_PS),
            ] {
                crate::ranges::check(flag, v, range).map_err(|e| StageError::Option {
                    name: StageOption::OutputAxis,
                    message: e.to_string(),
                })?;
            }
            a
        }
        None => match dist_range_m {
            Some((lo, hi)) => covering_axis(input_axis, lo, hi, eta, direction).map_err(|e| {
                StageError::Input {
                    path: input.display().to_string(),
                    message: e.to_string(),
                }
            })?,
            None => *input_axis,
        },
    })
}

/// Count the pixels of `paths` whose footprint spans more than one bin of `dt_ps`, and mark
/// those spanning more than `mask_bins` as without a path, so that they are masked; returns
/// both counts (among the pixels with a path).
fn mask_mixed(paths: &mut ClockPaths, dt_ps: f64, mask_bins: f64) -> (usize, usize) {
    use crate::calibrate::mixed::spread_bins;
    let Some(spread) = &paths.footprint_spread_m else {
        return (0, 0);
    };
    let (mut straddling, mut masked) = (0, 0);
    for (valid, &s) in paths.valid.iter_mut().zip(spread) {
        if *valid == 0 || s.is_nan() {
            continue;
        }
        let bins = spread_bins(s, dt_ps, paths.eta);
        straddling += (bins > 1.0) as usize;
        if bins > mask_bins {
            *valid = 0;
            masked += 1;
        }
    }
    (straddling, masked)
}

/// `axis` with whole bins added on both sides to hold profiles moved by any of `delays_ps`
/// as well (its bins stay aligned with the input's).
fn widened_by(axis: TimeAxis, delays_ps: &[f64]) -> TimeAxis {
    let most_ps = delays_ps
        .iter()
        .filter(|d| d.is_finite())
        .fold(0.0f64, |m, d| m.max(d.abs()));
    let k = (most_ps / axis.dt_ps).ceil() as usize;
    TimeAxis {
        t0_ps: axis.t0_ps - k as f64 * axis.dt_ps,
        dt_ps: axis.dt_ps,
        nt: axis.nt + 2 * k,
    }
}

/// The output's provenance notes: the input's, less its own `unwarp.*` notes, with a
/// `content` note that ends with the input's clock (`"ingested capture, camera time"`, as
/// the demo and the simulator write them) naming the output's, and this unwarp's direction,
/// source and where its distances came from.
fn unwarp_notes(
    input_notes: &[(String, String)],
    from: TimeFrame,
    direction: Direction,
    input: &Path,
    distances: &str,
) -> Vec<(String, String)> {
    let (from_clock, to_clock) = (
        format!("{from} time"),
        format!("{} time", direction.target_frame()),
    );
    let mut notes: Vec<(String, String)> = input_notes
        .iter()
        .filter(|(k, _)| !k.starts_with("unwarp."))
        .map(|(k, v)| match v.strip_suffix(&from_clock) {
            Some(what) if k == "content" => (k.clone(), format!("{what}{to_clock}")),
            _ => (k.clone(), v.clone()),
        })
        .collect();
    notes.push((
        "unwarp.direction".into(),
        format!("{} -> {}", from, direction.target_frame()),
    ));
    notes.push(("unwarp.source".into(), input.display().to_string()));
    notes.push(("unwarp.distances".into(), distances.to_string()));
    notes
}

/// What each slab of [`stream_slabs`] is unwarped with.
struct Slabs<'a> {
    meta: &'a CubeMeta,
    /// Per-pixel distances, metres (NaN: no shift).
    dist: &'a [f32],
    /// Per-row delays of the camera clock (scanline offsets), ps; empty: none.
    row_delay_ps: &'a [f64],
    mask: Option<&'a [u8]>,
    eta: f64,
    direction: Direction,
    /// The output's time axis.
    axis: &'a TimeAxis,
}

/// Read the cube by row slabs, unwarp each and write it; returns the output's mask.
fn stream_slabs(
    reader: &CubeReader,
    writer: &mut CubeWriter,
    s: &Slabs<'_>,
    progress: &dyn Progress,
) -> Result<Vec<u8>, StageError> {
    let (nx, ny) = (s.meta.nx, s.meta.ny);
    let (nt_in, nt_out) = (s.meta.axis.nt, s.axis.nt);
    let mut out_mask = vec![0u8; nx * ny];
    progress.start("unwarp", ny as u64);
    let mut src = Vec::new();
    let mut dst = Vec::new();
    for rows in row_slabs(ny, nx * (nt_in + nt_out) * 4, SLAB_BYTES) {
        let (y0, n) = (rows.start, rows.len());
        let (a, b) = (y0 * nx, rows.end * nx);
        src.resize(n * nx * nt_in, 0.0f32);
        dst.resize(n * nx * nt_out, 0.0f32);
        reader.read_rows_into(y0, &mut src)?;
        progress.poll();
        unwarp_rows(
            &src,
            nx,
            n,
            &s.meta.axis,
            &s.dist[a..b],
            s.row_delay_ps.get(rows.clone()).unwrap_or(&[]),
            s.mask.map(|m| &m[a..b]),
            s.eta,
            s.direction,
            s.axis,
            &mut dst,
            &mut out_mask[a..b],
        );
        progress.poll();
        writer.write_rows(y0, &dst)?;
        progress.set(rows.end as u64);
    }
    progress.finish();
    Ok(out_mask)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pixel_either_mask_rejects_has_no_distance() {
        let reg_mask = [1, 0, 1, 1];
        let dist_m = [1.0f32, 2.0, 3.0, 4.0];
        let d = masked_distances(4, &reg_mask, &dist_m, Some(&[1, 1, 0, 1]));
        assert_eq!(d[0], 1.0);
        assert!(d[1].is_nan() && d[2].is_nan());
        assert_eq!(d[3], 4.0);
        let d = masked_distances(4, &reg_mask, &dist_m, None);
        assert_eq!((d[2], d[3]), (3.0, 4.0));
        assert!(d[1].is_nan());
    }

    #[test]
    fn the_range_skips_pixels_without_distance() {
        assert_eq!(finite_range_m(&[f32::NAN, f32::NAN]), None);
        assert_eq!(finite_range_m(&[]), None);
        assert_eq!(
            finite_range_m(&[3.0, f32::NAN, 1.5, f32::INFINITY, 2.0]),
            Some((1.5, 3.0))
        );
    }

    #[test]
    fn a_given_axis_must_be_finite_positive_and_not_empty() {
        let input = Path::new("in.h5");
        let cube = TimeAxis {
            t0_ps: 0.0,
            dt_ps: 2.0,
            nt: 10,
        };
        let dir = Direction::CameraToWorld;
        let good = TimeAxis {
            t0_ps: -5.0,
            dt_ps: 1.0,
            nt: 3,
        };
        let a = output_axis(input, &cube, Some(good), Some((1.0, 2.0)), 1.0, dir);
        assert_eq!(a.ok(), Some(good));
        for bad in [
            TimeAxis {
                t0_ps: f64::NAN,
                dt_ps: 1.0,
                nt: 3,
            },
            TimeAxis {
                t0_ps: 0.0,
                dt_ps: 0.0,
                nt: 3,
            },
            TimeAxis {
                t0_ps: 0.0,
                dt_ps: 1.0,
                nt: 0,
            },
        ] {
            let e = output_axis(input, &cube, Some(bad), None, 1.0, dir).unwrap_err();
            assert!(e.to_string().contains("positive bin width"), "{e}");
        }
        // No pixel shifted and no axis given: the input's own axis.
        assert_eq!(
            output_axis(input, &cube, None, None, 1.0, dir).ok(),
            Some(cube)
        );
    }

    #[test]
    fn the_notes_replace_an_earlier_unwarp_and_name_the_source() {
        let old = vec![
            ("laser_nm".to_string(), "532".to_string()),
            ("unwarp.source".to_string(), "older.h5".to_string()),
            (
                "content".to_string(),
                "ingested capture, camera time".to_string(),
            ),
        ];
        let n = unwarp_notes(
            &old,
            TimeFrame::Camera,
            Direction::CameraToWorld,
            Path::new("cam.h5"),
            "/registration group of the source",
        );
        let keys: Vec<&str> = n.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(
            keys,
            [
                "laser_nm",
                "content",
                "unwarp.direction",
                "unwarp.source",
                "unwarp.distances"
            ]
        );
        assert_eq!(n[1].1, "ingested capture, world time");
        assert_eq!(n[3].1, "cam.h5");
        assert_eq!(
            n[4].1,
            format!("/{} group of the source", registration::GROUP)
        );
    }
}
