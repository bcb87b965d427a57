//! `femto pyramid CUBE.h5 [--levels N] [--side-file PATH]`: store the temporal prefix sums and
//! time-only mip levels of a cube (the renderer's interval queries), in the cube's `pyramid`
//! group or in a side file. Glue only: the kernels are [`femto::pyramid`], the streaming
//! writer and the schema [`femto::store::pyramid`].

use anyhow::bail;
use clap::Args;
use femto::container::{CubeCompression, CubeReader, GroupUpdate};
use femto::pyramid::top_level;
use femto::store::pyramid::{self as stored, write_pyramid};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct PyramidArgs {
    /// The cube (.h5).
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
    /// pyramid is derived data, rebuilt from the cube in seconds: uncompressed it is written
    /// at disk speed; level 1 stores noisy camera data in about 60 % of the bytes in about
    /// twice the time (tools/bench_commands.sh)
    #[arg(long, default_value = "none", value_parser = super::parse_compression)]
    pub compression: CubeCompression,
}

pub fn run(args: PyramidArgs) -> anyhow::Result<()> {
    let reader = CubeReader::open(&args.cube)?;
    let meta = reader.meta().clone();
    let top = top_level(meta.axis.nt);
    let levels = args.levels.unwrap_or(top);
    if levels > top {
        bail!(
            "--levels {levels}: a cube of {} bins has at most {top} mip levels (level k sums 2^k bins)",
            meta.axis.nt
        );
    }
    if let Some(side) = &args.side_file {
        let same = match (
            std::fs::canonicalize(side),
            std::fs::canonicalize(&args.cube),
        ) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if same {
            bail!(
                "--side-file {} is the cube itself; leave --side-file out to store the pyramid in the cube",
                side.display()
            );
        }
    }
    let mut out = match &args.side_file {
        Some(side) => GroupUpdate::side_file(side)?,
        None => GroupUpdate::open(&args.cube)?,
    };
    let bar = super::progress(meta.ny as u64, "pyramid");
    let info = write_pyramid(
        &reader,
        &mut out,
        levels,
        &args.cube.display().to_string(),
        args.compression,
        &|rows| bar.set_position(rows as u64),
    )?;
    bar.finish_and_clear();
    drop(reader);
    out.finish()?;
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
