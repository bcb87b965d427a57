//! `femto simulate`: write a simulated streak capture of a scene (library:
//! [`femto::simulate`]). Flags are checked here and named in errors; the scene, the render,
//! the imperfections and the files are the library's.

use super::values::{
    offset_sigma, positive_finite, row_range, EnumArg, Size, StreakFormatArg, TimeFilterArg,
};
use anyhow::{bail, Context};
use clap::Args;
use femto::scene::{Scene, BUILTIN_NAMES};
use femto::simulate::{
    simulate_capture, Flaw, Flaws, SimulateError, SimulateOption, SimulateOptions, SimulateSummary,
    Stage,
};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The seed's capture size: 672 x 600 pixels, 512 bins of 1.71 ps.
const SEED_SIZE: (usize, usize, usize, f64) = (672, 600, 512, 1.71);
/// The most bounces `--bounces` may ask for.
const MAX_BOUNCES: i64 = 1000;
/// The most time bins `--nt` may ask for.
const MAX_NT: u64 = 1 << 20;

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
        value_parser = clap::value_parser!(u32).range(1..=MAX_BOUNCES)
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
        value_parser = clap::value_parser!(u64).range(1..=MAX_NT)
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
}

/// The flag that sets each imperfection.
fn flaw_flag(flaw: Flaw) -> &'static str {
    match flaw {
        Flaw::PhotonNoise => "--photon-noise",
        Flaw::Dark => "--dark",
        Flaw::Vignetting => "--vignetting",
        Flaw::JitterPs => "--jitter-ps",
        Flaw::PowerSigma => "--power-sigma",
        Flaw::Sweep => "--sweep",
        Flaw::Saturation => "--saturation",
        Flaw::FiducialPhotoPx => "--fiducial-photo-px",
    }
}

/// The flag that sets each option [`SimulateOptions::validate`] checks.
fn option_flag(option: SimulateOption) -> &'static str {
    match option {
        SimulateOption::Spp => "--spp",
        SimulateOption::MaxBounces => "--bounces",
        SimulateOption::Seed => "--seed",
        SimulateOption::Formats => "--format",
        SimulateOption::MarkerSpacingM => "--marker-spacing-m",
        SimulateOption::TimeFilter => "--time-filter",
    }
}

fn load_scene(args: &SimulateArgs) -> anyhow::Result<Scene> {
    let name = args.scene.as_str();
    if BUILTIN_NAMES.contains(&name) {
        if name == "bunny" && args.bunny.is_none() {
            bail!("--scene bunny needs --bunny PATH (a mesh file, e.g. the Stanford bunny OBJ)");
        }
        if name != "bunny" && args.bunny.is_some() {
            bail!("--bunny applies only to --scene bunny");
        }
        return Scene::builtin(name, args.bunny.as_deref()).context("--scene");
    }
    if args.bunny.is_some() {
        bail!("--bunny applies only to --scene bunny");
    }
    let path = Path::new(name);
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
        || path.exists()
    {
        return Scene::load(path).context("--scene");
    }
    bail!(
        "--scene: '{name}' is neither a built-in scene ({}) nor a scene file (.toml)",
        BUILTIN_NAMES.join(", ")
    )
}

/// Everything the flags ask for, checked.
pub(super) struct Plan {
    pub scene: Scene,
    pub opts: SimulateOptions,
}

pub(super) fn plan(args: &SimulateArgs) -> anyhow::Result<Plan> {
    let formats = args.format.iter().map(|&f| f.into()).collect();
    let mut flaws = if args.realistic {
        Flaws::realistic()
    } else {
        Flaws::default()
    };
    let dark = args.dark;
    let set = |slot: &mut Option<f64>, v: Option<f64>| {
        if v.is_some() {
            *slot = v;
        }
    };
    set(&mut flaws.photon_noise, args.photon_noise);
    set(&mut flaws.vignetting, args.vignetting);
    set(&mut flaws.jitter_ps, args.jitter_ps);
    set(&mut flaws.power_sigma, args.power_sigma);
    set(&mut flaws.sweep, args.sweep);
    set(&mut flaws.saturation, args.saturation);
    set(&mut flaws.fiducial_photo_px, args.fiducial_photo_px);
    if dark.is_some() {
        flaws.dark = dark;
    }
    if let Err(e) = flaws.validate() {
        bail!("{}: {}", flaw_flag(e.flaw), e.message);
    }

    let mut scene = load_scene(args)?;
    let cam = &scene.camera;
    let (mut nx, mut ny, mut nt, mut dt_ps) = (
        cam.intrinsics.width,
        cam.intrinsics.height,
        cam.axis.nt,
        cam.axis.dt_ps,
    );
    if args.seed_size {
        (nx, ny, nt, dt_ps) = SEED_SIZE;
    }
    if let Some(size) = args.size {
        (nx, ny) = size.pair();
    }
    if let Some(n) = args.nt {
        nt = n as usize;
    }
    if let Some(d) = args.dt_ps {
        dt_ps = d;
    }
    if (nx, ny, nt, dt_ps)
        != (
            cam.intrinsics.width,
            cam.intrinsics.height,
            cam.axis.nt,
            cam.axis.dt_ps,
        )
    {
        scene = scene.with_resolution(nx, ny, nt, dt_ps);
    }

    let opts = SimulateOptions {
        spp: args.spp,
        seed: args.seed as u64,
        max_bounces: args.bounces,
        formats,
        flaws,
        marker_spacing_m: args.marker_spacing_m,
        force: args.force,
        created_by: super::command_line(),
        transient_only: args.transient_only,
        time_filter: args.time_filter.into(),
    };
    if let Err(e) = opts.validate(&scene) {
        match e {
            SimulateError::InvalidOption { option, message } => {
                bail!("{}: {message}", option_flag(option))
            }
            SimulateError::Flaw(f) => bail!("{}: {}", flaw_flag(f.flaw), f.message),
            other => return Err(other.into()),
        }
    }
    Ok(Plan { scene, opts })
}

pub fn run(args: SimulateArgs) -> anyhow::Result<()> {
    args.threads.init()?;
    // The capture folder replaces --out whole: it may not be or hold an input.
    let scene_file = Path::new(&args.scene);
    let inputs: Vec<&Path> = [
        Some(scene_file).filter(|p| p.is_file()),
        args.bunny.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();
    femto::pipeline::refuse_same_file(&args.out, &inputs, "out")?;
    let Plan { scene, opts } = plan(&args)?;
    femto::simulate::capture::check_destination(&args.out, opts.force)
        .map_err(|e| anyhow::anyhow!("--out {e} (--force replaces it)"))?;
    let (nx, ny) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
    );
    if let Some(rows) = &args.rows {
        if rows.end > ny {
            bail!(
                "--rows {}..{}: beyond the image's {ny} rows (0 <= A < B <= {ny})",
                rows.start,
                rows.end
            );
        }
    }
    // Rows rendered: the band's, or all.
    let rows_len = args.rows.as_ref().map_or(ny, |r| r.len());
    let axis = scene.camera.axis;
    // On stdout, with the summary: a failure later (a full disk) is then the only line on
    // stderr.
    println!(
        "femto simulate: scene {}, {nx} x {ny} pixels, {} bins of {} ps from {} ps, spp {}, \
         bounces {}, seed {}, {} threads{}",
        scene.name,
        axis.nt,
        axis.dt_ps,
        axis.t0_ps,
        opts.spp,
        opts.max_bounces,
        opts.seed,
        rayon::current_num_threads(),
        if opts.transient_only {
            format!(
                ", transient only, time filter {}",
                femto::simulate::transient::time_filter_name(opts.time_filter)
            )
        } else {
            String::new()
        }
    );
    let render_bar = super::progress(rows_len as u64, "rendering");
    let write_bar: Mutex<Option<indicatif::ProgressBar>> = Mutex::new(None);
    let on_progress = |stage: Stage, n: usize| match stage {
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
    let command: Vec<String> = std::env::args().collect();
    let summary = match &args.rows {
        Some(rows) => femto::simulate::band::simulate_band(
            &scene,
            &opts,
            rows.clone(),
            &command,
            &args.out,
            &on_progress,
        ),
        None => simulate_capture(&scene, &opts, &args.out, &on_progress),
    };
    render_bar.finish_and_clear();
    if let Some(bar) = write_bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
        bar.finish_and_clear();
    }
    let summary = summary.map_err(|e| match e {
        SimulateError::OutputExists { .. } => {
            anyhow::anyhow!("--out {e} (--force replaces it)")
        }
        other => other.into(),
    })?;
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
    if opts.transient_only {
        println!(
            "transient cube written to {}",
            summary
                .out_dir
                .join(femto::simulate::capture::TRUTH_CAMERA_FILE)
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
