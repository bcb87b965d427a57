//! `femto ingest INPUT --out CUBE.h5`: assemble a streak capture into an x-y-t cube.
//!
//! Flags map onto [`femto::ingest::plan::IngestOptions`]; the library resolves the plan and
//! streams the rows ([`femto::ingest::assemble`]). This module draws the progress bar and
//! prints the summary.

use super::values;
use clap::Args;
use femto::container::{CubeCompression, Provenance};
use femto::ingest::assemble::{self, Pass};
use femto::ingest::plan::{
    DarkInput, IngestOptions, IngestPlan, InputSpec, PowerRef, SaturationInput,
};
use femto::ingest::IngestError;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct IngestArgs {
    /// The capture: a folder with manifest.toml, a manifest, a glob ('scan_*.png', quoted),
    /// a printf pattern (scan_%04d.png, with --rows), an HDF5 file (with --dataset), or one
    /// scanline file (.png, .tif, .tiff, .exr, .hdr, .img: a capture of one scanline); or
    /// another tool's file: a y-tal capture (.hdf5) or a mitransient array (.npy).
    pub input: String,
    /// The cube to write (HDF5, camera time).
    #[arg(long, short = 'o', required_unless_present = "decode_only")]
    pub out: Option<PathBuf>,
    /// Replace --out if it exists (without it, an existing --out is refused).
    #[arg(long)]
    pub force: bool,
    /// Number of scanlines of a printf pattern (rows 0..N).
    #[arg(long)]
    pub rows: Option<usize>,
    /// Dataset of an HDF5 input holding the streak images, shape (ny, nt, nx), or
    /// (ny, nx, nt) with --transpose.
    #[arg(long)]
    pub dataset: Option<String>,
    /// Width of a time bin, ps, for files that record no time axis. A value that contradicts
    /// the manifest's axis or an .img time table is refused, unless --resample-time.
    #[arg(long)]
    pub dt_ps: Option<f64>,
    /// Camera time of the start of the first bin, ps (likewise; 0 when only --dt-ps is given
    /// for an .img file whose rows are not calibrated).
    #[arg(long, allow_hyphen_values = true)]
    pub t0_ps: Option<f64>,
    /// Resample the recorded rows onto the axis --dt-ps/--t0-ps ask for where it contradicts
    /// the capture's own (manifest, .img time table), conserving each pixel's integral; the
    /// cube gets as many bins as cover every recorded row (at most 16 per recorded row).
    #[arg(long)]
    pub resample_time: bool,
    /// Laser wavelength, nm, stored as the cube's laser_nm attribute (femto render's
    /// colours). A manifest's [capture] laser_wavelength_nm is used without it; a value that
    /// contradicts it is refused.
    #[arg(long, allow_hyphen_values = true)]
    pub laser_nm: Option<f64>,
    /// The files store time across and x down.
    #[arg(long)]
    pub transpose: bool,
    /// Dark signal to subtract: a constant (in value units) or a dark-frame image file.
    #[arg(long, allow_hyphen_values = true)]
    pub dark: Option<String>,
    /// Flat-field gains: an image nx wide, one row per scanline or a single row.
    #[arg(long)]
    pub flat: Option<PathBuf>,
    /// Sweep calibration: text/CSV of nt+1 true bin-edge times, ps.
    #[arg(long)]
    pub sweep_table: Option<PathBuf>,
    /// Leave out the corrections a capture's manifest records and ingest applies by default:
    /// its dark frame and flat field ([files] dark, flat) and its sweep bin times
    /// ([imperfections.sweep]). --dark, --flat or --sweep-table replace one of them.
    #[arg(long)]
    pub no_manifest_corrections: bool,
    /// Estimate and remove per-scanline trigger jitter (the default: every scanline is a
    /// separate sweep with its own trigger). A shift is applied only where it exceeds 4
    /// standard errors. Measured on a simulated realistic capture (cube scene, 320 x 240,
    /// 64 paths per pixel, 2 ps rms jitter): 1.2 ps rms left, 4.7 ps at most (20 of 240
    /// scanlines more than 2 ps off, 11 made worse by more than 1 ps), of which the
    /// row-to-row part 0.6 ps rms, 3.9 ps at most; the slow part of the jitter (runs of
    /// scanlines late together) cannot be told from the scene's tilt here, and stays until
    /// `femto calibrate` measures each scanline against the geometry and `femto unwarp`
    /// removes that too (with both: 0.19 ps rms, 0.76 ps at most, none made worse).
    /// Costs a second pass over the scanlines.
    #[arg(long, overrides_with = "no_jitter")]
    pub jitter: bool,
    /// Keep the scanlines' trigger jitter (one pass; for captures without jitter).
    #[arg(long)]
    pub no_jitter: bool,
    /// Laser power normalisation: a reference region x0:x1,t0:t1 (recorded bins, half-open)
    /// that sees a fixed part of the scene in every scanline, or 'auto' (each pixel's
    /// pulse integral against the same pixel in the neighbouring scanlines; a gain is applied only
    /// where it exceeds 4 standard errors: on the simulated realistic capture above, 3 %
    /// power, it removes about a quarter of the scanline-to-scanline error).
    #[arg(long, value_parser = values::power_ref)]
    pub power_ref: Option<PowerRef>,
    /// Mask saturated pixels: a level (value units) or 'auto' (the sample type's maximum).
    #[arg(long, value_parser = values::saturation)]
    pub saturation: Option<SaturationInput>,
    /// Fill missing scanlines by interpolation (masked) instead of failing.
    #[arg(long)]
    pub allow_missing: bool,
    /// Signal value of one stored count (default: the manifest's png_value_per_count for
    /// PNG scanlines, else 1).
    #[arg(long)]
    pub value_scale: Option<f64>,
    /// Compression of the cube: shuffle + deflate at a level 0-9, or 'none'. The default, 1,
    /// is the fastest level: real Hamamatsu streak data shrinks 2.1x (a signal capture) to
    /// 3.5x (a focus frame), the simulated benchmark 3.0x. Level 4 (femto's other writers,
    /// h5py's gzip default) is about 8 % smaller for about 1.5x the CPU time. 'none' is
    /// fastest, about 1.7x the time of decoding the images alone, for 2-3.5x the bytes (see
    /// docs/ingest.md).
    #[arg(long, value_parser = values::compression)]
    pub compression: Option<CubeCompression>,
    /// Another tool's file (y-tal, mitransient): see `ingest_interop`.
    #[command(flatten)]
    pub interop: super::ingest_interop::InteropArgs,
    /// Only decode the scanlines (benchmark baseline); writes nothing.
    #[arg(long, hide = true)]
    pub decode_only: bool,
}

fn options(args: &IngestArgs) -> anyhow::Result<IngestOptions> {
    let dark = match &args.dark {
        None => None,
        Some(s) => match s.parse::<f64>() {
            Ok(v) if !std::path::Path::new(s).exists() => Some(DarkInput::Level(v)),
            _ => Some(DarkInput::File(PathBuf::from(s))),
        },
    };
    Ok(IngestOptions {
        dt_ps: args.dt_ps,
        t0_ps: args.t0_ps,
        transpose: args.transpose,
        dark,
        flat: args.flat.clone(),
        sweep_table: args.sweep_table.clone(),
        jitter: !args.no_jitter,
        power_ref: args.power_ref,
        saturation: args.saturation,
        allow_missing: args.allow_missing,
        value_scale: args.value_scale,
        resample_time: args.resample_time,
        laser_nm: args.laser_nm,
        ignore_manifest_corrections: args.no_manifest_corrections,
    })
}

/// The error as `femto ingest` reports it: the line naming the flag where the library has
/// one ([`femto::ingest::flags::flag_message`]), else the error with its causes.
fn with_hint(e: IngestError) -> anyhow::Error {
    match femto::ingest::flags::flag_message(&e) {
        Some(line) => anyhow::anyhow!(line),
        None => anyhow::Error::new(e),
    }
}

pub fn run(args: IngestArgs) -> anyhow::Result<()> {
    if let Some(out) = &args.out {
        let input = std::path::Path::new(&args.input);
        femto::pipeline::overwrite::refuse_existing(out, &[input], args.force, "out")?;
    }
    if let Some(done) = super::ingest_interop::run(&args) {
        return done;
    }
    let start = Instant::now();
    let input =
        InputSpec::classify(&args.input, args.rows, args.dataset.as_deref()).map_err(with_hint)?;
    let plan = IngestPlan::resolve(&input, &options(&args)?).map_err(with_hint)?;
    let mb = |bytes: u64| bytes as f64 / 1e6;

    if args.decode_only {
        let bar = super::progress(plan.ny as u64, "decoding");
        let s = assemble::decode_only(&plan, &|n| bar.set_position(n as u64))?;
        bar.finish_and_clear();
        let secs = start.elapsed().as_secs_f64();
        println!(
            "decoded {} scanlines, {:.1} MB in {:.2} s ({:.1} MB/s)",
            s.rows,
            mb(s.bytes_read),
            secs,
            mb(s.bytes_read) / secs
        );
        return Ok(());
    }

    let out = args.out.as_ref().expect("clap requires --out");
    let passes = if plan.needs_two_passes() { 2 } else { 1 };
    let bar = super::progress((passes * plan.ny) as u64, "ingesting");
    let ny = plan.ny as u64;
    let two = passes == 2;
    let progress = |pass: Pass, n: usize| {
        let done = match pass {
            Pass::Scan => n as u64,
            Pass::Write if two => ny + n as u64,
            Pass::Write => n as u64,
        };
        bar.set_position(done);
    };
    let provenance = Provenance::new(super::command_line());
    let s = assemble::ingest(
        &plan,
        out,
        &provenance,
        args.compression
            .unwrap_or(femto::pipeline::INGEST_COMPRESSION),
        &progress,
    )?;
    bar.finish_and_clear();
    let secs = start.elapsed().as_secs_f64();

    println!(
        "ingested {} scanlines ({} x {} bins of {} ps from {} ps) -> {}",
        s.rows,
        s.nx,
        s.nt,
        plan.out_axis.dt_ps,
        plan.out_axis.t0_ps,
        out.display()
    );
    println!(
        "read {:.1} MB in {:.2} s ({:.1} MB/s), wrote {:.1} MB, {} pass{}",
        mb(s.bytes_read),
        secs,
        mb(s.bytes_read) / secs,
        mb(s.stored_bytes),
        s.passes,
        if s.passes == 1 { "" } else { "es" }
    );
    println!("time axis: {}", plan.axis_source);
    match &plan.laser {
        Some(l) => println!("laser wavelength: {} nm ({})", l.nm, l.source),
        None => println!(
            "laser wavelength: not recorded (give --laser-nm NM; femto render falls back to \
             670 nm)"
        ),
    }
    if s.corrections.is_empty() {
        println!("corrections: none");
    } else {
        println!("corrections: {}", s.corrections.join("; "));
    }
    if let Some((_, report)) = &s.jitter {
        report.lines().iter().for_each(|l| println!("{l}"));
    }
    if let Some((_, report)) = &s.power {
        report.lines().iter().for_each(|l| println!("{l}"));
    } else if let Some(gains) = &s.power_gains {
        let usable: Vec<f64> = gains.iter().flatten().copied().collect();
        let (lo, hi) = usable
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), g| (l.min(*g), h.max(*g)));
        println!(
            "power gains: {} of {} scanlines normalised, gains {lo:.4} .. {hi:.4}",
            usable.len(),
            gains.len()
        );
    }
    if s.masked_pixels > 0 {
        println!(
            "masked pixels: {} ({} saturated)",
            s.masked_pixels, s.saturated_pixels
        );
    }
    if !s.missing_rows.is_empty() {
        println!("missing scanlines filled: {:?}", s.missing_rows);
    }
    Ok(())
}
