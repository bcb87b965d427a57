//! `femto export --to tal CUBE.h5 -o capture.hdf5`: a cube for another tool. The stage is
//! [`femto::interop::export_tal`]; this module parses the flags and prints what was written.

use clap::{Args, ValueEnum};
use femto::interop::tal::LaserSpot;
use femto::interop::{export_tal, LaserOrigin};
use std::path::PathBuf;

/// The formats `femto export` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExportFormat {
    /// A y-tal capture (HDF5, what tal.io.read_capture reads).
    Tal,
}

#[derive(Args, Debug)]
pub struct ExportArgs {
    /// The cube (.h5), with a registration group (femto calibrate) or a tal group (a
    /// capture ingested from y-tal): the wall point each pixel sees.
    pub cube: PathBuf,
    /// The format to write.
    #[arg(long, value_enum)]
    pub to: ExportFormat,
    /// The file to write.
    #[arg(long, short = 'o')]
    pub out: PathBuf,
    /// The laser's own origin X,Y,Z in metres (y-tal's laser_xyz; the calibration records
    /// only the spot) [default: the tal group's, else the camera centre].
    #[arg(long, value_parser = super::values::point, allow_hyphen_values = true)]
    pub laser_origin_m: Option<[f64; 3]>,
    /// Replace the output if it exists (without it, an existing output is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: ExportArgs) -> anyhow::Result<()> {
    match args.to {
        ExportFormat::Tal => {}
    }
    femto::pipeline::overwrite::refuse_existing(&args.out, &[&args.cube], args.force, "out")?;
    let e = export_tal(&args.cube, &args.out, args.laser_origin_m)?;
    let c = &e.capture;
    println!(
        "wrote y-tal capture {}: H ({}, {}, {}), delta_t {} m, t_start {} m, \
         t_accounts_first_and_last_bounces = {}",
        args.out.display(),
        c.nt,
        c.sx,
        c.sy,
        c.delta_t_m,
        c.t_start_m,
        if c.t_accounts_first_and_last_bounces {
            "True (a camera-time cube)"
        } else {
            "False (a world-time cube)"
        }
    );
    let origin = match e.laser_origin {
        LaserOrigin::Given => "given (--laser-origin-m)",
        LaserOrigin::TalGroup => "from the cube's tal group",
        LaserOrigin::CameraCentre => {
            "the camera centre: no calibration records it (give --laser-origin-m)"
        }
    };
    let spot = match c.laser_grid_xyz_m {
        LaserSpot::Single(p) => format!("laser spot {p:?}"),
        LaserSpot::Confocal => "confocal: laser grid = sensor grid".to_string(),
    };
    println!(
        "sensor grid from the {} group ({} of {} points see nothing: NaN); {spot}, \
         laser origin {:?}, {origin}",
        e.geometry_group,
        e.unseen_points,
        c.sx * c.sy,
        c.laser_xyz_m
    );
    Ok(())
}
