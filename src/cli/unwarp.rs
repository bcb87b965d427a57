//! `femto unwarp CUBE.h5 --out OUT.h5 [--to world|camera]`: move a cube between the camera
//! clock and the world clock, pixel by pixel, with the distances of its registration
//! (`t_world = t_camera - eta |p - o| / c`, physics.md; the kernel is [`femto::unwarp`]).
//!
//! The distances and `eta` come from the cube's `registration` group, or from a calibration
//! and a mesh (`--calibration CAL.toml --mesh MESH`: the cube's pixels are taken to be that
//! camera's pixels, and the rays are cast anew). The registration used is stored in the
//! output, so that `--to camera` can undo `--to world`. Flags map onto
//! [`femto::pipeline::unwarp::UnwarpOptions`]; the stage is
//! [`femto::pipeline::unwarp::unwarp_file`].

use super::values::{self, Clock};
use clap::Args;
use femto::camera::Calibration;
use femto::container::CubeCompression;
use femto::cube::TimeAxis;
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::pipeline::overwrite::refuse_existing;
use femto::pipeline::unwarp::{unwarp_file, Distances, UnwarpOptions, Unwarped};
use femto::unwarp::Direction;
use std::path::{Path, PathBuf};

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
    /// Compression of the output cube: a deflate level 0-9 (with shuffle) or 'none'
    /// [default: the input cube's]. Level 1, `femto ingest`'s default, compresses camera data
    /// about 2.5 times faster than level 4 for about 4 % more bytes
    #[arg(long, value_parser = values::compression)]
    pub compression: Option<CubeCompression>,
    /// Replace --out if it exists, whole: a pyramid or registration it held is dropped with
    /// it (they describe the old data; run femto pyramid again). Without it, an existing
    /// --out is refused.
    #[arg(long)]
    pub force: bool,
    /// Mask the pixels whose footprint spans more than this many bins of path (the
    /// registration's footprint_spread_m): one distance cannot move their light, whose centre
    /// in time can sit half the spread off. `inf` keeps every pixel, smeared.
    #[arg(long, value_name = "BINS", default_value_t = femto::calibrate::mixed::MASK_SPREAD_BINS,
          value_parser = spread_bins)]
    pub mask_spread_bins: f64,
}

/// A positive number of bins, or `inf`.
fn spread_bins(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err("must be > 0 (or inf)".into())
    }
}

pub fn run(args: UnwarpArgs) -> anyhow::Result<()> {
    let mut inputs = vec![args.cube.as_path()];
    inputs.extend(args.calibration.as_deref());
    inputs.extend(args.mesh.as_deref());
    refuse_existing(&args.out, &inputs, args.force, "out")?;
    let dropped = dropped_groups(&args.out);
    let direction = match args.to {
        Clock::World => Direction::CameraToWorld,
        Clock::Camera => Direction::WorldToCamera,
    };
    let axis = match (args.t0_ps, args.nt) {
        (Some(t0_ps), Some(nt)) => {
            let dt_ps = match args.dt_ps {
                Some(d) => d,
                None => femto::container::read_meta(&args.cube)?.axis.dt_ps,
            };
            Some(TimeAxis { t0_ps, dt_ps, nt })
        }
        _ => None,
    };
    let options = UnwarpOptions {
        direction,
        axis,
        compression: args.compression,
        command_line: super::command_line(),
        mask_spread_bins: args.mask_spread_bins,
    };
    let cast = match (&args.calibration, &args.mesh) {
        (Some(cal_path), Some(mesh_path)) => Some((
            Calibration::load(cal_path)?,
            cal_path.display().to_string(),
            Bvh::new(load_mesh(mesh_path)?),
            mesh_path.display().to_string(),
        )),
        _ => None,
    };
    let distances = match &cast {
        Some((calibration, calibration_name, mesh, mesh_name)) => Distances::Cast {
            calibration,
            calibration_name,
            mesh,
            mesh_name,
        },
        None => Distances::Stored,
    };
    let done = unwarp_file(
        &args.cube,
        &args.out,
        distances,
        &options,
        &super::Bar::default(),
    )?;
    if !dropped.is_empty() {
        eprintln!(
            "femto unwarp: replaced {} whole; its {} group(s) were dropped with the old data \
             (run femto pyramid {} again for a pyramid)",
            args.out.display(),
            dropped.join(", "),
            args.out.display()
        );
    }
    print_summary(&args, &done, direction);
    Ok(())
}

/// What `femto unwarp` prints once the output is written: the axes, the pixels shifted and
/// masked, the scanlines moved.
fn print_summary(args: &UnwarpArgs, done: &Unwarped, direction: Direction) {
    let (a, o) = (done.input_axis, done.output_axis);
    println!(
        "wrote {}: {} -> {} time, {} x {} pixels, {} bins of {} ps from {} ps (input: {} bins from {} ps)",
        args.out.display(),
        done.from,
        done.to,
        done.nx,
        done.ny,
        o.nt,
        o.dt_ps,
        o.t0_ps,
        a.nt,
        a.t0_ps
    );
    match done.dist_range_m {
        Some((lo, hi)) => {
            let (a, b) = (
                direction.shift_ps(done.eta, lo),
                direction.shift_ps(done.eta, hi),
            );
            println!(
                "{} of {} pixels shifted (eta {}, distances {lo:.4} .. {hi:.4} m, shifts {:+.3} .. {:+.3} ps); the others are masked",
                done.valid_pixels,
                done.nx * done.ny,
                done.eta,
                a.min(b),
                a.max(b)
            )
        }
        None => println!("no pixel sees geometry: every pixel is masked"),
    }
    if done.straddling_pixels > 0 {
        let bins = args.mask_spread_bins;
        let masked = if bins.is_finite() {
            format!(
                "{} spanning more than {bins} bins are masked as mixed: no single distance moves \
                 their light",
                done.mixed_pixels
            )
        } else {
            "none is masked (--mask-spread-bins inf): their light is shifted by one distance, \
             smeared"
                .to_string()
        };
        println!(
            "{} pixels have footprints spanning more than one bin of path (the registration's \
             {}); {masked}",
            done.straddling_pixels,
            femto::store::registration::FOOTPRINT_SPREAD,
        );
    }
    if done.scanlines_moved > 0 {
        println!(
            "{} scanlines moved by their time offsets against the geometry (the registration's \
             {}, measured by femto calibrate)",
            done.scanlines_moved,
            femto::store::registration::SCANLINE_OFFSETS
        );
    }
}

/// The groups (pyramid, registration, ...) an existing `out` holds, which replacing it drops.
fn dropped_groups(out: &Path) -> Vec<String> {
    femto::container::GroupReader::open(out)
        .map(|r| r.groups().to_vec())
        .unwrap_or_default()
}
