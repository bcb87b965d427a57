//! `femto info FILE [--json]`: describe a file femto reads or writes. The stage is
//! [`femto::pipeline::describe::describe_file`]; this prints its description as text or as
//! the JSON object documented in docs/cube-format.md.

use clap::Args;
use femto::pipeline::describe::{describe_file, DescribeOptions};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The file to describe: a femto cube or pyramid side file (.h5), a mesh (.obj, .gltf,
    /// .glb) or a streak image (.png, .tif, .tiff, .exr, .hdr, .img).
    pub file: PathBuf,
    /// Print one JSON object on stdout instead of text.
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
    } else {
        print!("{description}");
    }
    Ok(())
}
