//! `--threads`, shared by the commands that render (simulate, render, view).

use anyhow::anyhow;
use clap::Args;

/// The most worker threads `--threads` may ask for: far beyond any machine's cores, and low
/// enough that the threads' stacks cannot exhaust memory.
const MAX_THREADS: i64 = 1024;

#[derive(Args, Debug, Clone, Copy)]
pub struct ThreadsArg {
    /// Worker threads, 1 to 1024 (default: all cores).
    #[arg(
        long,
        value_name = "N",
        value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS)
    )]
    pub threads: Option<u16>,
}

impl ThreadsArg {
    /// Size rayon's global pool (once, before any parallel work).
    pub fn init(self) -> anyhow::Result<()> {
        if let Some(n) = self.threads {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n.into())
                .build_global()
                .map_err(|e| anyhow!("--threads {n}: {e}"))?;
        }
        Ok(())
    }
}
