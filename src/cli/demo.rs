//! `femto demo`: the whole chain on the built-in scenes in one command (the library's
//! [`femto::demo::run_demo`]); prints a line per stage and a summary.

use anyhow::Context;
use clap::Args;
use femto::demo::{run_demo, DemoOptions, OutputKind};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Folder for the figures, the report and the intermediate data (created if missing;
    /// refused when it holds anything, unless --force, which replaces an earlier demo's).
    #[arg(long, value_name = "DIR", default_value = "femto-demo")]
    pub out: PathBuf,
    /// Small sizes: 160 x 120 pixels and 64 samples per pixel instead of 320 x 240 and 4096
    /// (measured times: benches/demo_results.md).
    #[arg(long)]
    pub quick: bool,
    /// A bunny mesh (e.g. the Stanford bunny OBJ): also run the Cornell box with the bunny
    /// and write fig7_bunny.mp4.
    #[arg(long, value_name = "PATH")]
    pub bunny: Option<PathBuf>,
    /// Replace an earlier demo in --out (a folder holding other files is refused even so).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    if let Some(b) = &args.bunny {
        if !b.is_file() {
            anyhow::bail!("--bunny {}: no such file", b.display());
        }
    }
    let started = Instant::now();
    let opts = DemoOptions {
        out_dir: args.out.clone(),
        quick: args.quick,
        bunny: args.bunny.clone(),
        force: args.force,
    };
    let progress = |line: &str| {
        eprintln!("[{:6.1} s] {line}", started.elapsed().as_secs_f64());
    };
    let summary = run_demo(&opts, &progress)
        .with_context(|| format!("femto demo into {}", args.out.display()))?;
    let count = |k: OutputKind| summary.outputs.iter().filter(|o| o.kind == k).count();
    println!(
        "femto demo: {} stills, {} contact sheets, {} videos and {} data files in {} ({:.1} s)",
        count(OutputKind::Image),
        count(OutputKind::Sheet),
        count(OutputKind::Video),
        summary.data_files.len(),
        args.out.display(),
        summary.total_seconds
    );
    for c in &summary.calibrations {
        println!(
            "calibration ({}): position {:.3} mm/m, rotation {:.4} deg, focal {:.3} %, t0 {:.3} bins: {}",
            c.scene,
            c.position_error_mm_per_m,
            c.rotation_error_deg,
            c.focal_error_percent,
            c.t0_error_bins,
            if c.within_tolerance {
                "within tolerance"
            } else {
                "OUT OF TOLERANCE"
            }
        );
    }
    for o in &summary.outputs {
        println!("  {}", args.out.join(&o.path).display());
    }
    println!("report: {}", args.out.join(&summary.report).display());
    Ok(())
}
