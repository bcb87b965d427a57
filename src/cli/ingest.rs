//! `femto ingest INPUT --out CUBE.h5`: assemble a streak capture into an x-y-t cube.
//!
//! Flags map onto [`femto::ingest::plan::IngestOptions`]; the library resolves the plan and
//! streams the rows ([`femto::ingest::assemble`]). This module draws the progress bar and
//! prints the summary.

use super::ingest_args::IngestArgs;
use femto::container::Provenance;
use femto::ingest::assemble::{self, Pass};
use femto::ingest::plan::{DarkInput, IngestOptions, IngestPlan, InputSpec};
use femto::ingest::IngestError;
use std::path::PathBuf;
use std::time::Instant;

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
