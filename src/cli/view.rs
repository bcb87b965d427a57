//! `femto view`: the interactive explorer of a world-time cube, in the browser (the
//! library's [`femto::view`]; API and page in docs/view.md).
//!
//! ```text
//! femto view --cube world.h5 --calibration capture.toml --mesh scene.glb --open
//! ssh -L 8765:127.0.0.1:8765 lab-workstation   # then open the printed URL here
//! ```
//!
//! Opens the inputs as `femto render` does (the same flags, [`super::render_inputs`]),
//! binds the server, prints its URL with this run's token
//! (`http://127.0.0.1:8765/?token=...`) as the first line of stdout, and serves until
//! Ctrl-C.

use anyhow::anyhow;
use clap::Args;
use femto::view::{server, Access, ViewSession};
use std::io::Write;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};

/// Port `femto view` listens on unless told otherwise.
pub const DEFAULT_PORT: u16 = 8765;

#[derive(Args, Debug)]
pub struct ViewArgs {
    #[command(flatten)]
    pub inputs: super::render_inputs::RenderInputArgs,
    /// Port to listen on; 0 takes a free one (the URL on stdout says which).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_PORT)]
    pub port: u16,
    /// Address to listen on. The default serves this machine only (reach it from elsewhere
    /// through an SSH tunnel); any other address serves everyone who can reach it and holds
    /// the token of the printed URL, with a warning.
    #[arg(long, value_name = "ADDR", default_value_t = IpAddr::V4(Ipv4Addr::LOCALHOST))]
    pub bind: IpAddr,
    /// Open the page in the desktop's browser (xdg-open, or open on macOS).
    #[arg(long)]
    pub open: bool,
    /// The first view's exposure multiplier relative to the automatic exposure, as
    /// `femto render --exposure` (the page's Exposure slider shows it in stops, 2^stops).
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub exposure: f64,
    #[command(flatten)]
    pub threads: super::threads::ThreadsArg,
}

pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    args.threads.init()?;
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        return Err(femto::pipeline::StageError::Option {
            name: femto::pipeline::StageOption::Exposure,
            message: format!("{}: must be a positive number", args.exposure),
        }
        .into());
    }
    let inputs = args.inputs.open()?;
    let session = ViewSession::new(&inputs, args.inputs.shell_flags(), args.exposure)?;
    let (http, bound) = server::bind(SocketAddr::new(args.bind, args.port))
        .map_err(|e| anyhow!("--port {} --bind {}: {e}", args.port, args.bind))?;
    let access = Access::new(bound).map_err(|e| anyhow!("femto view: a token: {e}"))?;
    let url = access.url();
    // The URL first, alone on its line, for scripts (`--port 0`).
    let mut out = std::io::stdout();
    writeln!(out, "{url}")?;
    out.flush()?;
    for note in &inputs.notes {
        eprintln!("femto view: note: {note}");
    }
    if !args.bind.is_loopback() {
        eprintln!(
            "femto view: warning: serving on {} to anyone who can reach this machine and \
             holds the token, over plain HTTP. Prefer the default 127.0.0.1 and an SSH tunnel",
            args.bind
        );
    }
    let cube = &session.info().cube;
    eprintln!(
        "femto view: {} x {} x {} cube; open {url} (Ctrl-C stops; {} frames render at once)",
        cube.nx,
        cube.ny,
        cube.nt,
        session.max_renders()
    );
    if args.open {
        open_browser(&url);
    }
    server::serve(&http, &session, &access);
    Ok(())
}

fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else {
        "xdg-open"
    };
    if let Err(e) = std::process::Command::new(opener)
        .arg(url)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
    {
        eprintln!("femto view: warning: --open: {opener} {url}: {e}; open the URL by hand");
    }
}
