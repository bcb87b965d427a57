//! `femto unwarp CUBE.h5 --out OUT.h5 [--to world|camera]`: move a cube between the camera
//! clock and the world clock, pixel by pixel, with the distances of its registration
//! (`t_world = t_camera - eta |p - o| / c`, physics.md; the kernel is [`femto::unwarp`]).
//!
//! The distances and `eta` come from the cube's `registration` group, or from a calibration
//! and a mesh (`--calibration CAL.toml --mesh MESH`: the cube's pixels are taken to be that
//! camera's pixels, and the rays are cast anew). The registration used is stored in the
//! output, so that `--to camera` can undo `--to world`. The cube is streamed by row slabs.

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use femto::calibrate::register;
use femto::camera::Calibration;
use femto::container::{CubeCompression, CubeReader, CubeWriter, GroupData, Provenance};
use femto::cube::{TimeAxis, TimeFrame};
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::store::registration::{self, StoredRegistration};
use femto::unwarp::{covering_axis, unwarp_rows, Direction};
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Clock {
    /// World time: when light is at the surface point.
    World,
    /// Camera time: when light reaches the sensor.
    Camera,
}

#[derive(Args, Debug)]
pub struct UnwarpArgs {
    /// The cube to convert (.h5).
    pub cube: PathBuf,
    /// The output cube (.h5).
    #[arg(long, short)]
    pub out: PathBuf,
    /// The clock of the output.
    #[arg(long, value_enum, default_value_t = Clock::World)]
    pub to: Clock,
    /// Start of the output time axis, ps (with --nt) [default: an axis covering all shifted
    /// data, aligned with the input's bins].
    #[arg(long, requires = "nt", allow_hyphen_values = true)]
    pub t0_ps: Option<f64>,
    /// Number of output bins (with --t0-ps).
    #[arg(long, requires = "t0_ps")]
    pub nt: Option<usize>,
    /// Output bin width, ps (with --t0-ps and --nt) [default: the input's].
    #[arg(long, requires = "t0_ps")]
    pub dt_ps: Option<f64>,
    /// Cast the distances through this calibration instead of reading the cube's
    /// registration group (needs --mesh).
    #[arg(long, requires = "mesh")]
    pub calibration: Option<PathBuf>,
    /// The mesh for --calibration (.obj, .gltf or .glb).
    #[arg(long, requires = "calibration")]
    pub mesh: Option<PathBuf>,
    /// Compression of the output cube: a deflate level 0-9 (with shuffle) or 'none'. Level 1,
    /// as `femto ingest` writes, compresses camera data about 2.5 times faster than level 4
    /// for about 4 % more bytes
    #[arg(long, default_value = "1", value_parser = super::parse_compression)]
    pub compression: CubeCompression,
}

/// Largest slab of input plus output rows moved at once, bytes.
const SLAB_TARGET_BYTES: usize = 64 << 20;

pub fn run(args: UnwarpArgs) -> anyhow::Result<()> {
    let reader = CubeReader::open(&args.cube)?;
    let meta = reader.meta().clone();
    let (nx, ny) = (meta.nx, meta.ny);
    let direction = match args.to {
        Clock::World => Direction::CameraToWorld,
        Clock::Camera => Direction::WorldToCamera,
    };
    if meta.frame != direction.source_frame() {
        bail!(
            "{}: the cube is already in {} time (give --to {} to convert it back)",
            args.cube.display(),
            meta.frame,
            match meta.frame {
                TimeFrame::Camera => "world",
                TimeFrame::World => "camera",
            }
        );
    }

    // Distances: cast anew, or read from the cube's registration group.
    let (stored, group): (StoredRegistration, GroupData) = match (&args.calibration, &args.mesh) {
        (Some(cal_path), Some(mesh_path)) => {
            let cal = Calibration::load(cal_path)?;
            let bvh = Bvh::new(load_mesh(mesh_path)?);
            let reg =
                register(&cal, &bvh, nx, ny).with_context(|| cal_path.display().to_string())?;
            let mesh = mesh_path.display().to_string();
            let group = registration::registration_group(&reg, &cal, &mesh, None);
            (
                StoredRegistration {
                    registration: reg,
                    calibration: cal,
                    mesh,
                    fit: None,
                },
                group,
            )
        }
        _ => {
            if !meta.groups.iter().any(|g| g == registration::GROUP) {
                bail!(
                    "{}: no /{} group: run `femto calibrate` on it first, or give \
                     --calibration CAL.toml --mesh MESH",
                    args.cube.display(),
                    registration::GROUP
                );
            }
            let group = reader.read_group(registration::GROUP)?;
            (registration::from_group(&args.cube, &group)?, group)
        }
    };
    let reg = &stored.registration;
    if (reg.nx, reg.ny) != (nx, ny) {
        bail!(
            "{}: the registration is {} x {} pixels but the cube is {nx} x {ny}",
            args.cube.display(),
            reg.nx,
            reg.ny
        );
    }
    let eta = stored.calibration.eta;
    let mask = reader.read_mask()?;
    let valid = |p: usize| reg.mask[p] != 0 && mask.as_ref().is_none_or(|m| m[p] != 0);
    let dist_range = (0..nx * ny)
        .filter(|&p| valid(p) && reg.dist_m[p].is_finite())
        .map(|p| reg.dist_m[p] as f64)
        .fold(None, |r: Option<(f64, f64)>, d| {
            Some(r.map_or((d, d), |(a, b)| (a.min(d), b.max(d))))
        });

    let axis = match (args.t0_ps, args.nt) {
        (Some(t0_ps), Some(nt)) => {
            let dt_ps = args.dt_ps.unwrap_or(meta.axis.dt_ps);
            if !t0_ps.is_finite() {
                bail!("--t0-ps must be a finite number, got {t0_ps}");
            }
            if !(dt_ps.is_finite() && dt_ps > 0.0) {
                bail!("--dt-ps must be a positive number, got {dt_ps}");
            }
            if nt == 0 {
                bail!("--nt must be at least 1");
            }
            TimeAxis { t0_ps, dt_ps, nt }
        }
        _ => match dist_range {
            Some((lo, hi)) => covering_axis(&meta.axis, lo, hi, eta, direction),
            None => meta.axis,
        },
    };

    let mut notes: Vec<(String, String)> = meta
        .notes
        .iter()
        .filter(|(k, _)| !k.starts_with("unwarp."))
        .cloned()
        .collect();
    notes.push((
        "unwarp.direction".into(),
        format!("{} -> {}", meta.frame, direction.target_frame()),
    ));
    notes.push(("unwarp.source".into(), args.cube.display().to_string()));
    notes.push((
        "unwarp.distances".into(),
        match &args.calibration {
            Some(c) => format!("cast through {} into {}", c.display(), stored.mesh),
            None => format!("/{} group of the source", registration::GROUP),
        },
    ));
    let provenance = Provenance {
        command_line: super::command_line(),
        notes,
    };
    let mut writer = CubeWriter::create_with(
        &args.out,
        nx,
        ny,
        axis,
        direction.target_frame(),
        &meta.units,
        &provenance,
        args.compression,
    )?;

    let (nt_in, nt_out) = (meta.axis.nt, axis.nt);
    let rows_per_slab = (SLAB_TARGET_BYTES / (nx * (nt_in + nt_out) * 4)).clamp(1, ny);
    let mut src = vec![0.0f32; rows_per_slab * nx * nt_in];
    let mut dst = vec![0.0f32; rows_per_slab * nx * nt_out];
    let mut out_mask = vec![0u8; nx * ny];
    let bar = super::progress(ny as u64, "unwarp");
    for y0 in (0..ny).step_by(rows_per_slab) {
        let n = rows_per_slab.min(ny - y0);
        let (a, b) = (y0 * nx, (y0 + n) * nx);
        let src = &mut src[..n * nx * nt_in];
        let dst = &mut dst[..n * nx * nt_out];
        reader.read_rows_into(y0, src)?;
        // Pixels the registration marks as seeing nothing get no shift, whatever dist_m says.
        let dist: Vec<f32> = (a..b)
            .map(|p| {
                if reg.mask[p] != 0 {
                    reg.dist_m[p]
                } else {
                    f32::NAN
                }
            })
            .collect();
        unwarp_rows(
            src,
            nx,
            n,
            &meta.axis,
            &dist,
            mask.as_ref().map(|m| &m[a..b]),
            eta,
            direction,
            &axis,
            dst,
            &mut out_mask[a..b],
        );
        writer.write_rows(y0, dst)?;
        bar.set_position((y0 + n) as u64);
    }
    bar.finish_and_clear();
    drop(reader);
    writer.write_mask(&out_mask)?;
    writer.write_group(registration::GROUP, &group)?;
    writer.finish()?;

    let valid_count = out_mask.iter().filter(|&&m| m != 0).count();
    println!(
        "wrote {}: {} -> {} time, {} x {} pixels, {} bins of {} ps from {} ps (input: {} bins from {} ps)",
        args.out.display(),
        meta.frame,
        direction.target_frame(),
        nx,
        ny,
        axis.nt,
        axis.dt_ps,
        axis.t0_ps,
        meta.axis.nt,
        meta.axis.t0_ps
    );
    match dist_range {
        Some((lo, hi)) => {
            let (a, b) = (direction.shift_ps(eta, lo), direction.shift_ps(eta, hi));
            println!(
                "{valid_count} of {} pixels shifted (eta {eta}, distances {lo:.4} .. {hi:.4} m, shifts {:+.3} .. {:+.3} ps); the others are masked",
                nx * ny,
                a.min(b),
                a.max(b)
            )
        }
        None => println!("no pixel sees geometry: every pixel is masked"),
    }
    Ok(())
}
