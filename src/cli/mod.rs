//! Command-line definition and dispatch. Each subcommand lives in its own module here; they
//! parse flags, open files, draw progress bars and call the library.
//!
//! Exit codes: 0 success, 2 bad input (the default for any reported error: a missing file,
//! a bad flag, a malformed capture), 1 internal failure (errors wrapped in [`Internal`]).

pub mod calibrate;
pub mod compare;
pub mod demo;
pub mod encode;
pub mod export;
pub mod info;
pub mod ingest;
pub mod ingest_args;
pub mod ingest_interop;
pub mod merge;
pub mod pyramid;
pub mod render;
pub mod render_inputs;
pub mod simulate;
pub mod threads;
pub mod unwarp;
pub mod values;
pub mod view;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::process::ExitCode;

/// femto: imaging light in flight. Simulate streak captures, assemble them into x-y-t cubes,
/// calibrate them against geometry, convert camera time to world time, and render
/// relativistic novel-view videos.
#[derive(Parser, Debug)]
#[command(name = "femto", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run the whole chain on the built-in scenes (simulate, ingest, calibrate, unwarp,
    /// pyramid, render) and write the figures of Jarabo et al. 2013 with a report.
    Demo(demo::DemoArgs),
    /// Describe a file: a cube (shape, time axis, value range, registration, pyramid), a
    /// pyramid side file, a mesh or a streak image.
    Info(info::InfoArgs),
    /// Fit the capture camera and time offset to correspondences and the cube's first
    /// arrivals; write the calibration TOML and the cube's registration group.
    Calibrate(calibrate::CalibrateArgs),
    /// Convert a cube between camera time and world time with its registration's distances.
    Unwarp(unwarp::UnwarpArgs),
    /// Store a cube's temporal prefix sums and mip levels (group `pyramid` or a side file).
    Pyramid(pyramid::PyramidArgs),
    /// Simulate a streak-camera capture of a scene: streak images per scanline, manifest,
    /// geometry, true calibration, fiducials and ground-truth cubes.
    Simulate(Box<simulate::SimulateArgs>),
    /// Assemble the band folders of `simulate --rows A..B` (separate processes or cluster
    /// jobs) into the capture folder one `simulate` writes, bit for bit.
    Merge(merge::MergeArgs),
    /// Render a relativistic novel-view video of a world-time cube: a camera moving at
    /// speeds close to that of light (aberration, Doppler colour, searchlight, time dilation).
    Render(Box<render::RenderArgs>),
    /// Encode the PNG frame folders of a split render (`render --frames A..B`) into one MP4
    /// or GIF, identical to a single render's.
    Encode(encode::EncodeArgs),
    /// Assemble a streak capture (one image per scanline) into an x-y-t cube, correcting
    /// the camera's flaws.
    Ingest(Box<ingest_args::IngestArgs>),
    /// Write a cube for another tool: a y-tal capture (--to tal).
    Export(export::ExportArgs),
    /// Explore a world-time cube interactively in the browser: fly a relativistic camera
    /// through the scene, scrub time, record keyframes and export them as a camera path.
    View(view::ViewArgs),
    /// Measure rendered frames against the traced truth of the same camera path (`simulate
    /// --truth-path`): relative L1, holes, ghosts and PSNR per frame, and error images.
    Compare(compare::CompareArgs),
}

/// Run one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Demo(args) => demo::run(args),
        Command::Info(args) => info::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        Command::Unwarp(args) => unwarp::run(args),
        Command::Pyramid(args) => pyramid::run(args),
        Command::Simulate(args) => simulate::run(*args),
        Command::Render(args) => render::run(*args),
        Command::Merge(args) => merge::run(args),
        Command::Encode(args) => encode::run(args),
        Command::Ingest(args) => ingest::run(*args),
        Command::View(args) => view::run(args),
        Command::Export(args) => export::run(args),
        Command::Compare(args) => compare::run(args),
    }
}

/// Parse the command line. `--help` and `--version` print as clap prints them and give exit
/// code 0; any other parse error is printed as one line on stderr ([`clap_error_line`]) and
/// gives exit code 2, like every other bad input.
pub fn parse_args() -> Result<Cli, ExitCode> {
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    Cli::try_parse_from(&args).map_err(|e| {
        use clap::error::ErrorKind;
        match e.kind() {
            ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                // Ignored like any write to a closed stdout (`femto --help | head`).
                let _ = e.print();
                ExitCode::SUCCESS
            }
            _ => {
                eprintln!("femto: error: {}", clap_error_line(&e, &args));
                ExitCode::from(2)
            }
        }
    })
}

/// A clap error as one line: clap's message with its continuation lines (the missing
/// arguments, a tip, the possible values) joined on, the command it is about, and where to
/// read more, e.g. `unexpected argument '--frobnicate' for 'femto render' (see 'femto render
/// --help')`. clap's own form takes 3-4 lines (message, blank, usage, help hint). `args` is
/// the command line that failed (program name first).
pub fn clap_error_line(e: &clap::Error, args: &[std::ffi::OsString]) -> String {
    use clap::CommandFactory;
    let cli = Cli::command();
    // The subcommand is the first word that is not a flag (femto itself takes no values).
    let sub = args
        .iter()
        .skip(1)
        .filter_map(|a| a.to_str())
        .find(|a| !a.starts_with('-'))
        .filter(|a| cli.find_subcommand(a).is_some());
    let command = match sub {
        Some(s) => format!("femto {s}"),
        None => "femto".to_string(),
    };
    if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand && sub.is_none()
    {
        let names: Vec<&str> = cli.get_subcommands().map(|c| c.get_name()).collect();
        return format!(
            "no command given, one of: {} (see 'femto --help')",
            names.join(", ")
        );
    }
    let text = e.render().to_string();
    let mut lines = text
        .lines()
        .map(str::trim)
        .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
        .filter(|l| !l.is_empty());
    let first = lines.next().unwrap_or("invalid command line");
    let mut line = first.strip_prefix("error: ").unwrap_or(first).to_string();
    if let Some(stripped) = line.strip_suffix(" found") {
        line = format!("{stripped} for '{command}'");
    }
    let more: Vec<&str> = lines
        .map(|l| l.trim_start_matches('[').trim_end_matches(']'))
        .collect();
    if !more.is_empty() {
        let sep = if line.ends_with(':') { " " } else { "; " };
        line = format!("{line}{sep}{}", more.join(", "));
    }
    format!("{line} (see '{command} --help')")
}

/// Marks an error as an internal failure (exit code 1) rather than bad input (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("internal error: {0}")]
pub struct Internal(pub String);

/// Print an error as one line on stderr and choose the exit code.
pub fn report(e: &anyhow::Error) -> ExitCode {
    let mut line = format!("femto: error: {e}");
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !line.contains(&c) {
            line.push_str(": ");
            line.push_str(&c);
        }
    }
    eprintln!("{}", line.replace('\n', " "));
    if e.chain().any(|c| c.is::<Internal>()) {
        ExitCode::from(1)
    } else {
        ExitCode::from(2)
    }
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{msg:>12} [{bar:32}] {pos}/{len} {per_sec} eta {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}

/// A [`femto::pipeline::Progress`] drawn as a progress bar on stderr (hidden when stderr is
/// not a terminal), one bar per pass.
#[derive(Default)]
pub struct Bar {
    bar: std::sync::Mutex<Option<ProgressBar>>,
}

impl femto::pipeline::Progress for Bar {
    fn start(&self, what: &str, len: u64) {
        if let Ok(mut b) = self.bar.lock() {
            *b = Some(progress(len, what));
        }
    }
    fn set(&self, done: u64) {
        if let Ok(b) = self.bar.lock() {
            if let Some(b) = b.as_ref() {
                b.set_position(done);
            }
        }
    }
    fn finish(&self) {
        if let Ok(mut b) = self.bar.lock() {
            if let Some(b) = b.take() {
                b.finish_and_clear();
            }
        }
    }
}

/// The command line that made an output, for provenance attributes.
pub fn command_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}

/// Restore the default SIGPIPE action so `femto info x | head` ends quietly.
pub fn reset_sigpipe() {
    #[cfg(unix)]
    // SAFETY: setting a signal disposition to SIG_DFL at start-up, before any threads exist.
    unsafe {
        libc_sigpipe_default();
    }
}

#[cfg(unix)]
unsafe fn libc_sigpipe_default() {
    extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
    }
    const SIGPIPE: i32 = 13;
    const SIG_DFL: usize = 0;
    signal(SIGPIPE, SIG_DFL);
}
