//! The inputs of `femto ingest` that other tools write: a y-tal capture (HDF5) and a
//! mitransient transient array (`.npy`). Their flags, their detection, and the call to the
//! library's stages ([`femto::interop::ingest_tal`], [`femto::interop::ingest_mitransient`]).
//! They hold rendered or already assembled data, so the streak corrections of `ingest`
//! (dark, flat, sweep, jitter, power, saturation) do not apply and their flags are refused.

use super::ingest::IngestArgs;
use clap::{Args, ValueEnum};
use femto::container::Provenance;
use femto::cube::TimeFrame;
use femto::interop::mitransient::{Channels, OplBinning};
use femto::interop::{ingest_mitransient, ingest_tal, is_tal_capture};
use std::path::Path;

/// Another tool's file as input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Foreign {
    /// A y-tal capture (tal.io.write_capture, tal render): H (T, Sx, Sy), delta_t, t_start.
    Tal,
    /// A mitransient transient array (H, W, T, C) saved with np.save.
    Mitransient,
}

/// How colour channels become one value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ChannelsArg {
    Mean,
    R,
    G,
    B,
    /// Rec. 709 luminance of linear RGB.
    Luminance,
}

/// The clock of a mitransient render.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OplClock {
    /// Path length from the emitter to the sensor (mitransient's default).
    Camera,
    /// Rendered with camera_unwarp = true: path length from the emitter to the surface point.
    World,
}

#[derive(Args, Debug)]
pub struct InteropArgs {
    /// Read INPUT as another tool's file (detected without it: an HDF5 file with y-tal's H
    /// and H_format, or a .npy file).
    #[arg(long, value_enum)]
    pub from: Option<Foreign>,
    /// mitransient: the film's start_opl, metres of optical path (t0 = start_opl / c).
    #[arg(long, allow_hyphen_values = true)]
    pub start_opl_m: Option<f64>,
    /// mitransient: the film's bin_width_opl, metres of optical path (dt = bin_width_opl / c).
    #[arg(long)]
    pub bin_width_opl_m: Option<f64>,
    /// mitransient: how the colour channels become the cube's value [default: mean].
    #[arg(long, value_enum)]
    pub channels: Option<ChannelsArg>,
    /// mitransient: the render's clock [default: camera].
    #[arg(long, value_enum)]
    pub opl_clock: Option<OplClock>,
}

/// Which foreign input `args` names, if any.
fn kind(args: &IngestArgs) -> Option<Foreign> {
    if let Some(f) = args.interop.from {
        return Some(f);
    }
    let path = Path::new(&args.input);
    let npy = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"));
    if npy {
        return Some(Foreign::Mitransient);
    }
    // y-tal's H is (T, Sx, Sy), not a stack of (ny, nt, nx) streak images: read as a capture.
    let tal_dataset = args
        .dataset
        .as_deref()
        .is_none_or(|d| d.trim_start_matches('/') == "H");
    (tal_dataset && path.is_file() && is_tal_capture(path)).then_some(Foreign::Tal)
}

/// The streak-capture flags given, which do not apply to another tool's file.
fn streak_flags(args: &IngestArgs) -> Vec<&'static str> {
    let given = [
        (args.rows.is_some(), "--rows"),
        (args.dt_ps.is_some(), "--dt-ps"),
        (args.t0_ps.is_some(), "--t0-ps"),
        (args.resample_time, "--resample-time"),
        (args.transpose, "--transpose"),
        (args.dark.is_some(), "--dark"),
        (args.flat.is_some(), "--flat"),
        (args.sweep_table.is_some(), "--sweep-table"),
        (args.jitter, "--jitter"),
        (args.power_ref.is_some(), "--power-ref"),
        (args.saturation.is_some(), "--saturation"),
        (args.allow_missing, "--allow-missing"),
        (args.value_scale.is_some(), "--value-scale"),
        (args.compression.is_some(), "--compression"),
        (args.decode_only, "--decode-only"),
    ];
    given.iter().filter(|(g, _)| *g).map(|(_, f)| *f).collect()
}

/// Ingest another tool's file when `args` names one (`None`: a streak capture).
pub fn run(args: &IngestArgs) -> Option<anyhow::Result<()>> {
    let Some(kind) = kind(args) else {
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
            return None;
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
    };
    let refused = streak_flags(args);
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
            ingest_tal(input, out, &provenance)?
        }
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
