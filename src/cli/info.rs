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
    /// .glb), a streak image (.png, .tif, .tiff, .exr, .hdr, .img), or a file `femto ingest`
    /// reads (.npy, .npz, .mat, .hspy, HDF5, Delmic HDF5, .ptu, a y-tal capture).
    pub file: PathBuf,
    /// Print every stored value whole (the cube's notes: per-scanline jitter shifts and
    /// power gains, source file names, sweep edges) instead of counting long lists and
    /// rounding numbers to the digits they carry.
    #[arg(long, conflicts_with = "json")]
    pub full: bool,
    /// Print one JSON object on stdout instead of text (every value whole).
    #[arg(long)]
    pub json: bool,
    /// Array files: describe this dataset, variable, `.npz` array, signal or Delmic
    /// acquisition (the file's candidates are listed without it).
    #[arg(long)]
    pub dataset: Option<String>,
    /// Array files: describe the layout `femto ingest --time-axis N` would read.
    #[arg(long, value_name = "N")]
    pub time_axis: Option<usize>,
    /// Array, Delmic and PTU files: as `femto ingest --select AXIS=I`.
    #[arg(long, value_name = "AXIS=I", value_parser = super::values::axis_index)]
    pub select: Vec<(femto::readers::AxisRef, usize)>,
    /// Array files: as `femto ingest --sum AXIS`.
    #[arg(long, value_name = "AXIS", value_parser = super::values::axis_ref)]
    pub sum: Vec<femto::readers::AxisRef>,
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let options = DescribeOptions {
        array: femto::readers::ReadOptions {
            dataset: args.dataset,
            layout: femto::readers::LayoutOptions {
                time_axis: args.time_axis,
                transpose: false,
                select: args.select,
                sum: args.sum,
            },
        },
        ..Default::default()
    };
    let description = describe_file(&args.file, &options, &super::Bar::default())?;
    if args.json {
        println!("{}", description.to_json());
    } else if args.full {
        print!("{description:#}");
    } else {
        print!("{description}");
    }
    Ok(())
}
