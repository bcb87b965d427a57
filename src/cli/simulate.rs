//! `femto simulate`: write a simulated streak capture of a scene. The flags map onto a
//! [`SimulateRequest`], which the library checks, plans and runs
//! ([`femto::pipeline::simulate`], also `femto.simulate` in Python); this module parses the
//! flags, draws the progress bars and prints the summary.

use super::values::{
    offset_sigma, positive_finite, row_range, EffectsArg, EnumArg, FrameRange, RadiometryArg, Size,
    StreakFormatArg, TimeFilterArg,
};
use clap::Args;
use femto::pipeline::render::RenderOptions;
use femto::pipeline::simulate::{self, SimulateRequest, MAX_BOUNCES, MAX_NT};
use femto::pipeline::truth::TruthRequest;
use femto::render::Effects;
use femto::simulate::{Flaws, SimulateSummary, Stage};
use std::path::PathBuf;
use std::sync::Mutex;

#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Scene: a built-in name (cube, cornell, bunny) or a scene file (.toml).
    #[arg(long, default_value = "cube")]
    pub scene: String,
    /// Capture folder to create (must not exist or be empty, unless --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace the capture folder if it exists.
    #[arg(long)]
    pub force: bool,
    /// Mesh file of the bunny scene (e.g. the Stanford bunny OBJ).
    #[arg(long, value_name = "PATH")]
    pub bunny: Option<PathBuf>,
    /// Scanline formats, comma-separated: png16, exr, img16 (or img), img32. The first is the
    /// manifest's primary file.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "png16",
        value_name = "LIST",
        ignore_case = true,
        value_parser = EnumArg::<StreakFormatArg>::new()
    )]
    pub format: Vec<StreakFormatArg>,
    /// Camera paths per pixel.
    #[arg(
        long,
        default_value_t = 64,
        allow_negative_numbers = true,
        value_name = "N",
        value_parser = clap::value_parser!(u32).range(1..)
    )]
    pub spp: u32,
    /// Random seed (0 to 2^63 - 1).
    #[arg(
        long,
        default_value_t = 0,
        allow_negative_numbers = true,
        value_name = "S",
        value_parser = clap::value_parser!(i64).range(0..)
    )]
    pub seed: i64,
    /// Most surface interactions per path (1 = direct light only).
    #[arg(
        long,
        default_value_t = 4,
        allow_negative_numbers = true,
        value_name = "N",
        value_parser = clap::value_parser!(u32).range(1..=MAX_BOUNCES as i64)
    )]
    pub bounces: u32,
    /// Image size in pixels, e.g. 64x48 (default: the scene's; at most 32768 a side, and
    /// the capture must fit in memory).
    #[arg(long, value_name = "WxH")]
    pub size: Option<Size>,
    /// Number of time bins (default: the scene's).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        value_parser = clap::value_parser!(u64).range(1..=MAX_NT as u64)
    )]
    pub nt: Option<u64>,
    /// Width of a time bin, ps (default: the scene's).
    #[arg(long, allow_negative_numbers = true, value_name = "PS", value_parser = positive_finite)]
    pub dt_ps: Option<f64>,
    /// The capture size of Jarabo et al. 2013 (the paper femto implements): 672 x 600
    /// pixels, 512 bins of 1.71 ps.
    #[arg(long = "paper-size", alias = "seed-size", conflicts_with_all = ["size", "nt", "dt_ps"])]
    pub seed_size: bool,
    /// Write only the true transient cube in camera time (truth_camera.h5) and the render's
    /// counters (render.json: paths, rays, wall and CPU seconds): the path tracer alone, as a
    /// transient renderer is run; no streak images, imperfections, fiducials or side files.
    #[arg(long, conflicts_with_all = ["format", "realistic", "photon_noise", "dark", "vignetting",
          "jitter_ps", "power_sigma", "sweep", "saturation", "fiducial_photo_px", "marker_spacing_m"])]
    pub transient_only: bool,
    /// How arrival times are binned: sensor (the laser pulse and the streak sensor's
    /// one-bin response: femto's cubes) or box (a histogram of arrival times, each path sample
    /// whole in the bin it falls in: what mitransient's box time bins estimate; only with
    /// --transient-only).
    #[arg(long, value_name = "FILTER", default_value = "sensor", requires = "transient_only",
          ignore_case = true, value_parser = EnumArg::<TimeFilterArg>::new())]
    pub time_filter: TimeFilterArg,
    /// First bounce at which Russian roulette may end a path (1 = the surface the camera ray
    /// hits; default 3); only with --transient-only, to match another renderer's setting.
    #[arg(long, value_name = "N", requires = "transient_only", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub rr_start_bounce: Option<u32>,
    /// Render only image rows A..B (B excluded) into a band folder: the true cubes of those
    /// rows and band.toml, bit-identical to the same rows of a whole run; `femto merge`
    /// assembles the bands into the capture folder (docs/cluster.md).
    #[arg(long, value_name = "A..B", value_parser = row_range, conflicts_with = "transient_only")]
    pub rows: Option<std::ops::Range<usize>>,
    #[command(flatten)]
    pub threads: super::threads::ThreadsArg,
    /// Spacing of the fiducial marker grid on flat surfaces, metres.
    #[arg(long, default_value_t = femto::simulate::fiducials::DEFAULT_MARKER_SPACING_M,
          allow_negative_numbers = true, value_name = "M", value_parser = positive_finite)]
    pub marker_spacing_m: f64,

    /// Start from the realistic set of imperfections (the flags below override it).
    #[arg(long, help_heading = "Imperfections")]
    pub realistic: bool,
    /// Photon (Poisson) noise: expected photons at the clean cube's maximum.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        help_heading = "Imperfections"
    )]
    pub photon_noise: Option<f64>,
    /// Dark signal: offset and noise sigma, fractions of the clean maximum.
    #[arg(
        long,
        allow_hyphen_values = true,
        value_name = "OFFSET,SIGMA",
        help_heading = "Imperfections",
        value_parser = offset_sigma
    )]
    pub dark: Option<(f64, f64)>,
    /// Vignetting strength in [0, 1): gain 1 - S r^2 (r = 1 at the corners).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "S",
        help_heading = "Imperfections"
    )]
    pub vignetting: Option<f64>,
    /// Per-scanline trigger jitter, standard deviation in ps.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "PS",
        help_heading = "Imperfections"
    )]
    pub jitter_ps: Option<f64>,
    /// Per-scanline laser power fluctuation, relative standard deviation.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "S",
        help_heading = "Imperfections"
    )]
    pub power_sigma: Option<f64>,
    /// Sweep non-linearity strength in [0, 1): largest relative change of a bin's width.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "S",
        help_heading = "Imperfections"
    )]
    pub sweep: Option<f64>,
    /// Saturation level, fraction of the clean maximum.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "LEVEL",
        help_heading = "Imperfections"
    )]
    pub saturation: Option<f64>,
    /// Fiducial detection noise: standard deviation of the markers' positions in a
    /// 4032-pixel-wide photo of the scene, pixels (--realistic: 0.5); fiducials.toml holds
    /// them in capture pixels, so the noise there is PX x width / 4032.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "PX",
        help_heading = "Imperfections"
    )]
    pub fiducial_photo_px: Option<f64>,

    /// Also render the direct truth of a moving camera on this camera path (the TOML file
    /// `femto render --path` reads): each pixel's rays, spread over the pixel and aberrated,
    /// traced through the scene from the moving camera with the transient path tracer, into
    /// DIR/truth/frame_NNNNN.exr (linear) and .png (display). `femto render --cube
    /// DIR/truth_world.h5 --calibration DIR/calibration.toml --mesh DIR/scene.glb --path
    /// PATH` renders the same frames from the capture; the difference is the image-based
    /// renderer's error (docs/truth.md, `femto ibr-error`).
    #[arg(long, value_name = "PATH.toml", conflicts_with_all = ["transient_only", "rows"],
          help_heading = "Truth of a moving camera")]
    pub truth_path: Option<PathBuf>,
    /// Paths per pixel of the truth frames [default: --spp].
    #[arg(long, value_name = "N", requires = "truth_path",
          value_parser = clap::value_parser!(u32).range(1..),
          help_heading = "Truth of a moving camera")]
    pub truth_spp: Option<u32>,
    /// Render only truth frames A..B (B excluded) of the path; identical to the same frames
    /// of a whole run.
    #[arg(
        long,
        value_name = "A..B",
        requires = "truth_path",
        help_heading = "Truth of a moving camera"
    )]
    pub frames: Option<FrameRange>,
    /// Effects of the truth frames, as `femto render --effects`: a comma-separated list of
    /// unwarp, aberration, doppler, searchlight, dilation, rotation; or all; or none.
    #[arg(long, value_name = "LIST", default_value = "all", value_parser = EffectsArg,
          requires = "truth_path", help_heading = "Truth of a moving camera")]
    pub effects: Effects,
    /// Radiometry of the truth frames, as `femto render --radiometry`.
    #[arg(long, value_name = "MODE", value_enum, default_value_t = RadiometryArg::Consistent,
          requires = "truth_path", help_heading = "Truth of a moving camera")]
    pub radiometry: RadiometryArg,
    /// Exposure multiplier of the truth's PNG frames, relative to the automatic exposure
    /// `femto render` gives the capture's truth_world.h5.
    #[arg(
        long,
        value_name = "X",
        default_value_t = 1.0,
        requires = "truth_path",
        help_heading = "Truth of a moving camera"
    )]
    pub exposure: f64,
    /// World time of the path's time 0, ps after the pulse leaves the laser spot [default: 0].
    #[arg(
        long,
        value_name = "PS",
        allow_negative_numbers = true,
        requires = "truth_path",
        help_heading = "Truth of a moving camera"
    )]
    pub time_offset_ps: Option<f64>,
}

/// The library's request for these flags ([`femto::pipeline::simulate`]), recording this
/// process's command line.
pub(super) fn request(args: &SimulateArgs) -> SimulateRequest {
    SimulateRequest {
        scene: args.scene.clone(),
        bunny: args.bunny.clone(),
        out: args.out.clone(),
        force: args.force,
        formats: args.format.iter().map(|&f| f.into()).collect(),
        spp: args.spp,
        seed: args.seed as u64,
        bounces: args.bounces,
        size: args.size.map(Size::pair),
        nt: args.nt.map(|n| n as usize),
        dt_ps: args.dt_ps,
        paper_size: args.seed_size,
        transient_only: args.transient_only,
        time_filter: args.time_filter.into(),
        rr_start_bounce: args.rr_start_bounce,
        rows: args.rows.clone(),
        marker_spacing_m: args.marker_spacing_m,
        realistic: args.realistic,
        flaws: Flaws {
            photon_noise: args.photon_noise,
            dark: args.dark,
            vignetting: args.vignetting,
            jitter_ps: args.jitter_ps,
            power_sigma: args.power_sigma,
            sweep: args.sweep,
            saturation: args.saturation,
            fiducial_photo_px: args.fiducial_photo_px,
        },
        created_by: super::command_line(),
        command: std::env::args().collect(),
        truth: args.truth_path.as_ref().map(|path| TruthRequest {
            path: path.clone(),
            spp: args.truth_spp,
            options: RenderOptions {
                frames: args.frames.clone().map(|f| f.0),
                time_offset_ps: args.time_offset_ps,
                effects: args.effects,
                radiometry: args.radiometry.into(),
                exposure: args.exposure,
                ..RenderOptions::default()
            },
        }),
    }
}

pub fn run(args: SimulateArgs) -> anyhow::Result<()> {
    args.threads.init()?;
    let req = request(&args);
    let plan = simulate::prepare(&req)?;
    let truth_frames = req.truth.as_ref().map(|t| match &t.options.frames {
        Some(f) => f.len(),
        None => femto::camera_path::CameraPath::load(&t.path).map_or(0, |p| p.spec().frames),
    });
    // On stdout, with the summary: a failure later (a full disk) is then the only line on
    // stderr.
    println!("{}", plan.describe(rayon::current_num_threads()));
    let ny = plan.scene.camera.intrinsics.height;
    let render_bar = super::progress(plan.rows_rendered(req.rows.as_ref()) as u64, "rendering");
    let write_bar: Mutex<Option<indicatif::ProgressBar>> = Mutex::new(None);
    let truth_bar: Mutex<Option<indicatif::ProgressBar>> = Mutex::new(None);
    let on_progress = |stage: Stage, n: usize| match stage {
        Stage::Truth => {
            let mut bar = truth_bar.lock().unwrap_or_else(|e| e.into_inner());
            bar.get_or_insert_with(|| {
                if let Some(w) = write_bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
                    w.finish_and_clear();
                }
                super::progress(truth_frames.unwrap_or(0) as u64, "truth frames")
            })
            .inc(n as u64);
        }
        Stage::Render => render_bar.inc(n as u64),
        Stage::Write => {
            let mut bar = write_bar.lock().unwrap_or_else(|e| e.into_inner());
            bar.get_or_insert_with(|| {
                render_bar.finish_and_clear();
                super::progress(ny as u64, "writing")
            })
            .inc(n as u64);
        }
    };
    let summary = simulate::run(&req, &plan, &on_progress);
    render_bar.finish_and_clear();
    for bar in [&write_bar, &truth_bar] {
        if let Some(bar) = bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            bar.finish_and_clear();
        }
    }
    let summary = summary?;
    if let Some(rows) = &args.rows {
        println!(
            "band of rows {}..{} written to {} (femto merge assembles the bands)",
            rows.start,
            rows.end,
            summary.out_dir.display()
        );
        print_render_line(&summary);
        return Ok(());
    }
    if plan.opts.transient_only {
        println!(
            "transient cube written to {}",
            summary
                .out_dir
                .join(femto::simulate::options::TRUTH_CAMERA_FILE)
                .display()
        );
        println!(
            "  paths: {} ({} rays) in {:.3} s wall, {:.3} CPU s: {:.0} paths/s",
            summary.paths,
            summary.rays,
            summary.render_seconds,
            summary.render_cpu_seconds,
            summary.paths_per_second
        );
        println!(
            "  counters: {}",
            summary
                .out_dir
                .join(femto::simulate::transient::COUNTERS_FILE)
                .display()
        );
        return Ok(());
    }
    println!("capture written to {}", summary.out_dir.display());
    print_capture_lines(&summary);
    if let Some(t) = &summary.truth {
        println!(
            "  truth: frames {}..{} of {}x{} at {} spp in {}/ ({} paths, {} rays) in {:.1} s; \
             PNG exposure {:.4e}",
            t.frames.start,
            t.frames.end,
            t.width,
            t.height,
            t.spp,
            summary
                .out_dir
                .join(femto::pipeline::truth::TRUTH_DIR)
                .display(),
            t.stats.paths,
            t.stats.rays,
            t.seconds,
            t.exposure
        );
    }
    Ok(())
}

/// The render's counters, one line.
pub(super) fn print_render_line(summary: &SimulateSummary) {
    println!(
        "  paths: {} ({} rays) in {:.2} s: {:.0} paths/s",
        summary.paths, summary.rays, summary.render_seconds, summary.paths_per_second
    );
}

/// The lines a finished capture folder is reported with (simulate and merge).
pub(super) fn print_capture_lines(summary: &SimulateSummary) {
    print_render_line(summary);
    let scanline_files = summary
        .files
        .iter()
        .filter(|f| f.parent().and_then(|p| p.file_name()) == Some("scanlines".as_ref()))
        .count();
    println!(
        "  files: {} ({} streak images in scanlines/, {} fiducials), {:.2} s in all",
        summary.files.len(),
        scanline_files,
        summary.fiducials,
        summary.seconds
    );
    for f in summary
        .files
        .iter()
        .filter(|f| f.parent().and_then(|p| p.file_name()) != Some("scanlines".as_ref()))
    {
        println!("    {}", f.display());
    }
    if summary.values_at_top_count > 0 {
        println!(
            "  note: {} streak-image values at the top count (65535)",
            summary.values_at_top_count
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use femto::manifest::StreakFormat;

    /// `req` through its command line and this command's flags, back to a request.
    fn round_trip(req: &SimulateRequest) -> SimulateRequest {
        let parsed = super::super::Cli::try_parse_from(req.command_line()).unwrap();
        let super::super::Command::Simulate(args) = parsed.command else {
            panic!("not simulate: {:?}", req.command_line());
        };
        SimulateRequest {
            created_by: req.created_by.clone(),
            command: req.command.clone(),
            ..request(&args)
        }
    }

    #[test]
    fn a_requests_command_line_parses_back_to_the_request() {
        let band = SimulateRequest {
            scene: "cornell".into(),
            out: "cap".into(),
            force: true,
            formats: vec![StreakFormat::ExrF32, StreakFormat::Img32],
            spp: 3,
            seed: 9,
            bounces: 2,
            size: Some((16, 12)),
            nt: Some(32),
            dt_ps: Some(2.5),
            rows: Some(2..5),
            marker_spacing_m: 0.01,
            realistic: true,
            flaws: Flaws {
                dark: Some((-0.01, 0.002)),
                sweep: Some(0.1),
                photon_noise: Some(250.0),
                ..Flaws::default()
            },
            ..SimulateRequest::default()
        };
        assert_eq!(round_trip(&band), band);
        let transient = SimulateRequest {
            out: "t".into(),
            paper_size: true,
            transient_only: true,
            time_filter: femto::tracer::TimeFilter::Box,
            rr_start_bounce: Some(6),
            ..SimulateRequest::default()
        };
        assert_eq!(round_trip(&transient), transient);
        assert_eq!(
            SimulateRequest::default().command_line().join(" "),
            "femto simulate --scene cube --out "
        );
    }
}
