//! `femto pyramid CUBE.h5 [--levels N] [--side-file PATH]`: store the temporal prefix sums and
//! time-only mip levels of a cube. Flags map onto [`femto::pipeline::pyramid::PyramidOptions`];
//! the stage is [`femto::pipeline::pyramid::pyramid_file`].

use clap::Args;
use femto::container::CubeCompression;
use femto::pipeline::pyramid::{pyramid_file, PyramidOptions};
use femto::store::pyramid as stored;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct PyramidArgs {
    /// The cube (.h5). Its `/cube` is copied as it is stored (compression kept).
    pub cube: PathBuf,
    /// Mip levels to store above level 0 (level k sums 2^k bins) [default: all, up to one
    /// sample per pixel].
    #[arg(long)]
    pub levels: Option<usize>,
    /// Write the pyramid into this HDF5 file (holding the group only) instead of the cube's
    /// file.
    #[arg(long)]
    pub side_file: Option<PathBuf>,
    /// Compression of the pyramid: a deflate level 0-9 (with shuffle) or 'none'. The
    /// pyramid is derived data, rebuilt from the cube at any time: uncompressed it is
    /// written at disk speed; level 1 stores noisy camera data in about 73 % of the bytes in
    /// about twice the time (tools/bench_commands.sh measures both)
    #[arg(long, default_value = "none", value_parser = super::values::compression)]
    pub compression: CubeCompression,
    /// Replace --side-file if it exists (without it, refused). A pyramid in the cube itself is
    /// derived data and always replaced by the new one.
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: PyramidArgs) -> anyhow::Result<()> {
    if let Some(side) = &args.side_file {
        femto::pipeline::overwrite::refuse_existing(
            side,
            &[args.cube.as_path()],
            args.force,
            "side-file",
        )?;
    }
    let options = PyramidOptions {
        levels: args.levels,
        side_file: args.side_file.clone(),
        compression: args.compression,
    };
    let info = pyramid_file(&args.cube, &options, &super::Bar::default())?;
    let dest = args.side_file.as_ref().unwrap_or(&args.cube);
    println!(
        "wrote /{} of {}: prefix sums ({} x {} x {}, f32 within blocks of 8 bins, f64 at their \
         starts) and {} mip level(s) {:?} samples per pixel",
        stored::GROUP,
        dest.display(),
        info.ny,
        info.nx,
        info.axis.nt + 1,
        info.levels,
        info.level_nts()
    );
    Ok(())
}
