//! `femto merge`: assemble the band folders of `femto simulate --rows A..B` into the capture
//! folder one `femto simulate` writes, bit for bit (library: [`femto::simulate::band`]).
//!
//! The capture is re-planned from the first band's recorded command line, with its `--rows`
//! and `--threads` dropped and its `--out` replaced by the merge's, so the capture records
//! the equivalent single command that makes it in one process; bands whose settings differ from it or from each other,
//! rows in two bands and rows in none are refused before anything is written.

use anyhow::Context;
use clap::{Args, Parser};
use femto::simulate::band::{check_bands, merge_bands};
use femto::simulate::{SimulateError, Stage};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Band folders written by `femto simulate --rows A..B`, in any order; together they
    /// must hold every row of the image once.
    #[arg(required = true, value_name = "BAND_DIR")]
    pub bands: Vec<PathBuf>,
    /// Capture folder to create (must not exist or be empty, unless --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace the capture folder if it exists.
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub threads: super::threads::ThreadsArg,
}

/// `command` (a band's `femto simulate` command line) as the equivalent single command
/// that writes the whole capture to `out`: `--rows` dropped, `--threads` dropped (a thread
/// count changes no byte of the capture, so a single run without it writes the same files)
/// and the value of `--out` replaced.
pub fn whole_command(command: &[String], out: &Path) -> Vec<String> {
    let out = out.display().to_string();
    let mut whole = Vec::with_capacity(command.len());
    let mut args = command.iter();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--rows" | "--threads" => {
                args.next();
            }
            _ if a.starts_with("--threads=") => {}
            "--out" => {
                whole.push(a.clone());
                args.next();
                whole.push(out.clone());
            }
            _ if a.starts_with("--rows=") => {}
            _ if a.starts_with("--out=") => whole.push(format!("--out={out}")),
            _ => whole.push(a.clone()),
        }
    }
    whole
}

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    args.threads.init()?;
    let band_paths: Vec<&Path> = args.bands.iter().map(PathBuf::as_path).collect();
    femto::pipeline::refuse_same_file(&args.out, &band_paths, "out")?;
    let bands = check_bands(&args.bands)?;
    let (first_dir, first) = &bands[0];
    let command = whole_command(&first.command, &args.out);
    let band_file = first_dir.join(femto::simulate::band::BAND_FILE);
    let parsed = super::Cli::try_parse_from(&command).map_err(|e| {
        anyhow::anyhow!(
            "{}: its command line no longer parses: {}",
            band_file.display(),
            super::clap_error_line(&e, &command.iter().map(Into::into).collect::<Vec<_>>())
        )
    })?;
    let super::Command::Simulate(simulate) = parsed.command else {
        anyhow::bail!(
            "{}: its command is not femto simulate: {}",
            band_file.display(),
            command.join(" ")
        );
    };
    let femto::pipeline::simulate::SimulatePlan { scene, mut opts } =
        femto::pipeline::simulate::plan(&super::simulate::request(&simulate))
            .with_context(|| format!("{}: its command line", band_file.display()))?;
    opts.force = args.force;
    opts.created_by = command.join(" ");
    femto::simulate::capture::check_destination(&args.out, opts.force)
        .map_err(|e| anyhow::anyhow!("--out {e} (--force replaces it)"))?;
    let ny = scene.camera.intrinsics.height;
    println!(
        "femto merge: {} bands of scene {}, {} x {ny} pixels, {} bins, spp {}, seed {}",
        bands.len(),
        scene.name,
        scene.camera.intrinsics.width,
        scene.camera.axis.nt,
        opts.spp,
        opts.seed
    );
    let bar = super::progress(ny as u64, "writing");
    let on_progress = |stage: Stage, n: usize| {
        if stage == Stage::Write {
            bar.inc(n as u64)
        }
    };
    let summary = merge_bands(&scene, &opts, &args.bands, &args.out, &on_progress);
    bar.finish_and_clear();
    let summary = summary.map_err(|e| match e {
        SimulateError::OutputExists { .. } => anyhow::anyhow!("--out {e} (--force replaces it)"),
        other => other.into(),
    })?;
    println!("capture written to {}", summary.out_dir.display());
    super::simulate::print_capture_lines(&summary);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_command_drops_rows_and_replaces_out() {
        let band: Vec<String> =
            "femto simulate --rows 0..4 --threads 1 --out b0 --spp 2 --rows=1..2 --out=x --threads=2"
            .split(' ')
            .map(String::from)
            .collect();
        assert_eq!(
            whole_command(&band, Path::new("cap")).join(" "),
            "femto simulate --out cap --spp 2 --out=cap"
        );
    }
}
