//! The inputs of `femto ingest` that other tools write: a y-tal capture (HDF5), a
//! mitransient transient array (`.npy` with its binning), and files as labs and instruments
//! save them (`.npy`, `.npz`, `.mat`, `.hspy`, plain HDF5 datasets, Delmic SPARC HDF5,
//! PicoQuant PTU: [`femto::readers`]). Their flags, mapped onto the library's kind decision
//! ([`femto::ingest::kind::decide`]), and the call to the library's stages ([`femto::interop::ingest_tal`],
//! [`femto::interop::ingest_mitransient`], [`femto::ingest::arrays::ingest_array`]). They
//! hold rendered or already assembled data, so the streak corrections of `ingest` (dark,
//! flat, sweep, jitter, power) do not apply and their flags are refused; `--saturation`
//! applies to all of them.

use super::ingest_args::{ChannelsArg, Foreign, IngestArgs, OplClock};
use femto::container::Provenance;
use femto::cube::TimeFrame;
use femto::ingest::arrays::{ingest_array, ArrayIngest, Confocal};
use femto::ingest::kind::{InputKind, KindHints};
use femto::interop::mitransient::{Channels, OplBinning};
use femto::interop::{ingest_mitransient, ingest_tal};
use femto::readers::{Format, LayoutOptions, ReadOptions};
use std::path::Path;

/// The library's decision of what `args.input` is ([`femto::ingest::kind::decide`]), from
/// the flags that bear on it; `None`: a streak capture.
fn kind(args: &IngestArgs) -> anyhow::Result<Option<Foreign>> {
    let i = &args.interop;
    let hints = KindHints {
        from: i.from.map(|f| match f {
            Foreign::Tal => InputKind::Tal,
            Foreign::Mitransient => InputKind::Mitransient,
            Foreign::Array => InputKind::Array(Format::Npy),
        }),
        dataset: args.dataset.as_deref(),
        mitransient_flags: i.start_opl_m.is_some()
            || i.bin_width_opl_m.is_some()
            || i.channels.is_some()
            || i.opl_clock.is_some(),
    };
    Ok(match femto::ingest::kind::decide(&args.input, &hints)? {
        InputKind::Streak => None,
        InputKind::Tal => Some(Foreign::Tal),
        InputKind::Mitransient => Some(Foreign::Mitransient),
        InputKind::Array(_) => Some(Foreign::Array),
    })
}

/// The streak-capture flags given, which do not apply to another tool's file.
fn streak_flags(args: &IngestArgs, kind: Foreign) -> Vec<&'static str> {
    let array = kind == Foreign::Array;
    let given = [
        (args.rows.is_some(), "--rows"),
        (args.dt_ps.is_some() && !array, "--dt-ps"),
        (args.t0_ps.is_some() && !array, "--t0-ps"),
        (args.resample_time, "--resample-time"),
        (args.transpose && !array, "--transpose"),
        (args.dark.is_some(), "--dark"),
        (args.flat.is_some(), "--flat"),
        (args.sweep_table.is_some(), "--sweep-table"),
        (args.jitter, "--jitter"),
        (args.power_ref.is_some(), "--power-ref"),
        (
            args.saturation.is_some() && kind == Foreign::Mitransient,
            "--saturation",
        ),
        (args.interop.confocal && !array, "--confocal"),
        (
            args.interop.wall_size_m.is_some() && !array,
            "--wall-size-m",
        ),
        (args.interop.device_m.is_some() && !array, "--device-m"),
        (args.interop.clock.is_some() && !array, "--clock"),
        (args.interop.time_axis.is_some() && !array, "--time-axis"),
        (!args.interop.select.is_empty() && !array, "--select"),
        (!args.interop.sum.is_empty() && !array, "--sum"),
        (args.allow_missing, "--allow-missing"),
        (args.value_scale.is_some(), "--value-scale"),
        (args.compression.is_some(), "--compression"),
        (args.decode_only, "--decode-only"),
    ];
    given.iter().filter(|(g, _)| *g).map(|(_, f)| *f).collect()
}

/// Ingest another tool's file when `args` names one (`None`: a streak capture).
pub fn run(args: &IngestArgs) -> Option<anyhow::Result<()>> {
    let kind = match kind(args) {
        Ok(k) => k,
        Err(e) => return Some(Err(e)),
    };
    let Some(kind) = kind else {
        let i = &args.interop;
        let mitransient_only = [
            (i.start_opl_m.is_some(), "--start-opl-m"),
            (i.bin_width_opl_m.is_some(), "--bin-width-opl-m"),
            (i.channels.is_some(), "--channels"),
            (i.opl_clock.is_some(), "--opl-clock"),
        ];
        let given: Vec<&str> = mitransient_only
            .iter()
            .filter(|(g, _)| *g)
            .map(|(_, f)| *f)
            .collect();
        if given.is_empty() {
            let confocal = [
                (i.confocal, "--confocal"),
                (i.wall_size_m.is_some(), "--wall-size-m"),
                (i.device_m.is_some(), "--device-m"),
                (i.clock.is_some(), "--clock"),
                (i.time_axis.is_some(), "--time-axis"),
                (!i.select.is_empty(), "--select"),
                (!i.sum.is_empty(), "--sum"),
            ];
            let c: Vec<&str> = confocal
                .iter()
                .filter(|(g, _)| *g)
                .map(|(_, f)| *f)
                .collect();
            if c.is_empty() {
                return None;
            }
            return Some(Err(anyhow::anyhow!(
                "{}: only for array files (.npy, .npz, .mat, .hspy, HDF5 datasets, Delmic, \
                 .ptu); {} is a streak capture",
                c.join(", "),
                args.input
            )));
        }
        return Some(Err(anyhow::anyhow!(
            "{}: only for a mitransient array (.npy, or --from mitransient); {} is a streak \
             capture",
            given.join(", "),
            args.input
        )));
    };
    Some(ingest(args, kind))
}

fn ingest(args: &IngestArgs, kind: Foreign) -> anyhow::Result<()> {
    let input = Path::new(&args.input);
    let name = match kind {
        Foreign::Tal => "a y-tal capture",
        Foreign::Mitransient => "a mitransient array",
        Foreign::Array => "an array file",
    };
    let refused = streak_flags(args, kind);
    if !refused.is_empty() {
        anyhow::bail!(
            "{}: {name}, whose data are assembled already; {} apply only to streak captures",
            input.display(),
            refused.join(", ")
        );
    }
    let out = args.out.as_ref().expect("clap requires --out");
    femto::pipeline::refuse_same_file(out, &[input], "out")?;
    let mut provenance = Provenance::new(super::command_line());
    if let Some(nm) = args.laser_nm {
        if !(nm.is_finite() && nm > 0.0) {
            anyhow::bail!("--laser-nm {nm}: must be a positive number of nanometres");
        }
        provenance = provenance.with_note("laser_nm", nm.to_string());
    }
    let cube = match kind {
        Foreign::Tal => {
            let i = &args.interop;
            if i.start_opl_m.is_some() || i.bin_width_opl_m.is_some() || i.channels.is_some() {
                anyhow::bail!(
                    "{}: a y-tal capture records its own delta_t and t_start and has one \
                     channel (leave out --start-opl-m, --bin-width-opl-m, --channels)",
                    input.display()
                );
            }
            ingest_tal(input, out, args.saturation, &provenance)?
        }
        Foreign::Array => return ingest_arrays(args, input, out, &provenance),
        Foreign::Mitransient => {
            let i = &args.interop;
            let (Some(start_opl_m), Some(bin_width_opl_m)) = (i.start_opl_m, i.bin_width_opl_m)
            else {
                anyhow::bail!(
                    "{}: a mitransient array does not record its binning; give the film's \
                     start_opl and bin_width_opl (--start-opl-m M --bin-width-opl-m M)",
                    input.display()
                );
            };
            let channels = match i.channels.unwrap_or(ChannelsArg::Mean) {
                ChannelsArg::Mean => Channels::Mean,
                ChannelsArg::R => Channels::R,
                ChannelsArg::G => Channels::G,
                ChannelsArg::B => Channels::B,
                ChannelsArg::Luminance => Channels::Luminance,
            };
            let frame = match i.opl_clock.unwrap_or(OplClock::Camera) {
                OplClock::Camera => TimeFrame::Camera,
                OplClock::World => TimeFrame::World,
            };
            let binning = OplBinning {
                start_opl_m,
                bin_width_opl_m,
            };
            ingest_mitransient(input, out, binning, channels, frame, &provenance)?
        }
    };
    println!(
        "ingested {name}: {} x {} pixels, {} bins of {} ps from {} ps ({} time) -> {}",
        cube.nx,
        cube.ny,
        cube.axis.nt,
        cube.axis.dt_ps,
        cube.axis.t0_ps,
        match cube.frame {
            TimeFrame::Camera => "camera",
            TimeFrame::World => "world",
        },
        out.display()
    );
    Ok(())
}

/// `--from array` or a detected array file: [`ingest_array`].
fn ingest_arrays(
    args: &IngestArgs,
    input: &Path,
    out: &Path,
    provenance: &Provenance,
) -> anyhow::Result<()> {
    let i = &args.interop;
    let mitransient = [
        (i.start_opl_m.is_some(), "--start-opl-m"),
        (i.bin_width_opl_m.is_some(), "--bin-width-opl-m"),
        (i.channels.is_some(), "--channels"),
        (i.opl_clock.is_some(), "--opl-clock"),
    ];
    if let Some((_, f)) = mitransient.iter().find(|(g, _)| *g) {
        anyhow::bail!("{}: {f} is only for a mitransient array", input.display());
    }
    if i.device_m.is_some() && !i.confocal {
        anyhow::bail!(
            "{}: --device-m places a confocal scan's device; give --confocal too",
            input.display()
        );
    }
    let confocal = match (i.confocal, i.wall_size_m) {
        (true, Some(m)) => Some(Confocal {
            wall_size_m: m,
            device_m: i.device_m,
        }),
        (false, None) => None,
        (true, None) => anyhow::bail!(
            "{}: --confocal needs --wall-size-m M (the full side of the scanned wall patch)",
            input.display()
        ),
        (false, Some(_)) => anyhow::bail!(
            "{}: --wall-size-m is the wall patch of a confocal capture; give --confocal too",
            input.display()
        ),
    };
    let hints = KindHints {
        from: Some(InputKind::Array(Format::Npy)),
        ..KindHints::default()
    };
    let InputKind::Array(format) = femto::ingest::kind::decide(&args.input, &hints)? else {
        unreachable!("decide answers an array format for --from array")
    };
    let opts = ArrayIngest {
        read: ReadOptions {
            dataset: args.dataset.clone(),
            layout: LayoutOptions {
                time_axis: i.time_axis,
                transpose: args.transpose,
                select: i.select.clone(),
                sum: i.sum.clone(),
            },
        },
        dt_ps: args.dt_ps,
        t0_ps: args.t0_ps,
        saturation: args.saturation,
        confocal,
        clock: match i.clock {
            Some(super::values::Clock::World) => TimeFrame::World,
            _ => TimeFrame::Camera,
        },
    };
    let r = ingest_array(input, format, out, &opts, provenance)?;
    if r.inexact > 0 {
        eprintln!(
            "femto: warning: {}: {} integer values above 2^24 were rounded to float32 (largest \
             {}); recorded as ingest.inexact_values",
            input.display(),
            r.inexact,
            r.largest_inexact
        );
    }
    let source = if r.source.is_empty() {
        String::new()
    } else {
        format!(" ({})", r.source)
    };
    let masked = if args.saturation.is_some() {
        format!(", {} saturated pixel(s) masked", r.saturated_pixels)
    } else {
        String::new()
    };
    println!(
        "ingested {}{source}, {}: {} x {} pixels, {} bins of {} ps from {} ps ({} time; \
         {}){masked}{} -> {}",
        r.format.name(),
        r.dtype.name(),
        r.nx,
        r.ny,
        r.axis.nt,
        r.axis.dt_ps,
        r.axis.t0_ps,
        opts.clock,
        r.time_axis,
        if confocal.is_some() {
            ", confocal (the wall grid in the tal group)"
        } else {
            ""
        },
        out.display()
    );
    Ok(())
}
