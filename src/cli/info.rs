//! `femto info FILE [--full | --json]`: describe a file femto reads or writes. The stage is
//! [`femto::pipeline::describe::describe_file`]; this prints its description as a summary
//! (rounded numbers, long lists counted), as text with every stored value (`--full`), or as
//! the JSON object documented in docs/cube-format.md.

use clap::Args;
use femto::pipeline::describe::{describe_file, DescribeOptions};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The file to describe: a femto cube or pyramid side file (.h5), a mesh (.obj, .gltf,
    /// .glb) or a streak image (.png, .tif, .tiff, .exr, .hdr, .img).
    pub file: PathBuf,
    /// Print every stored value whole (the cube's notes: per-scanline jitter shifts and
    /// power gains, source file names, sweep edges) instead of counting long lists and
    /// rounding numbers to the digits they carry.
    #[arg(long, conflicts_with = "json")]
    pub full: bool,
    /// Print one JSON object on stdout instead of text (every value whole).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let description = describe_file(
        &args.file,
        &DescribeOptions::default(),
        &super::Bar::default(),
    )?;
    if args.json {
        println!("{}", description.to_json());
    } else if args.full {
        print!("{description:#}");
    } else {
        print!("{description}");
    }
    Ok(())
}
