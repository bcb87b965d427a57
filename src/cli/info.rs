//! `femto info FILE [--json]`: describe a file femto reads or writes.
//!
//! The kind of file is decided from its contents, not its name, where the format allows
//! (an HDF5 signature means a cube); each kind has its own arm below. The JSON object of
//! `--json` is documented in docs/cube-format.md.

use anyhow::{bail, Context};
use clap::Args;
use femto::container::{CubeMeta, CubeReader};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The file to describe (a femto cube, .h5).
    pub file: PathBuf,
    /// Print one JSON object on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What a file is, decided before describing it.
enum FileKind {
    /// A femto cube: an HDF5 file with a `/cube` dataset.
    Cube,
}

fn identify(path: &Path) -> anyhow::Result<FileKind> {
    let is_hdf5 = femto::container::is_hdf5(path).with_context(|| format!("{}", path.display()))?;
    if is_hdf5 {
        return Ok(FileKind::Cube);
    }
    bail!("{}: not a femto cube (HDF5) file", path.display())
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    match identify(&args.file)? {
        FileKind::Cube => cube_info(&args.file, args.json),
    }
}

/// Everything `info` says about a cube, computed once for both output forms.
struct CubeSummary {
    meta: CubeMeta,
    value_range: Option<(f32, f32)>,
    /// `(valid, total)` pixels when the cube has a mask.
    mask: Option<(usize, usize)>,
}

fn cube_info(path: &Path, as_json: bool) -> anyhow::Result<()> {
    let reader = CubeReader::open(path)?;
    let meta = reader.meta().clone();
    let bar = super::progress(meta.ny as u64, "scanning");
    let value_range = reader.value_range(&|rows| bar.set_position(rows as u64))?;
    bar.finish_and_clear();
    let mask = reader
        .read_mask()?
        .map(|m| (m.iter().filter(|&&v| v != 0).count(), m.len()));
    let s = CubeSummary {
        meta,
        value_range,
        mask,
    };
    if as_json {
        println!("{}", cube_json(path, &s));
    } else {
        print!("{}", cube_text(path, &s));
    }
    Ok(())
}

fn cube_json(path: &Path, s: &CubeSummary) -> Value {
    let m = &s.meta;
    let notes: Map<String, Value> = m
        .notes
        .iter()
        .map(|(k, v)| (k.clone(), Value::String(v.clone())))
        .collect();
    json!({
        "file": path.display().to_string(),
        "kind": "cube",
        "shape": { "ny": m.ny, "nx": m.nx, "nt": m.axis.nt },
        "time_axis": {
            "t0_ps": m.axis.t0_ps,
            "dt_ps": m.axis.dt_ps,
            "nt": m.axis.nt,
            "end_ps": m.axis.end_ps(),
            "unit": "ps",
        },
        "time_frame": m.frame.as_str(),
        "units": m.units,
        "value_range": s.value_range.map(|(lo, hi)| json!({ "min": lo, "max": hi })),
        "mask": s.mask.map(|(valid, total)| json!({ "valid_pixels": valid, "pixels": total })),
        "size_bytes": m.size_bytes(),
        "groups": m.groups,
        "femto_version": m.femto_version,
        "command_line": m.command_line,
        "notes": notes,
    })
}

fn cube_text(path: &Path, s: &CubeSummary) -> String {
    let m = &s.meta;
    let mut out = String::new();
    let mut line = |k: &str, v: String| out.push_str(&format!("{k:<12}{v}\n"));
    line("file", path.display().to_string());
    line("kind", "femto cube (HDF5)".into());
    line(
        "shape",
        format!("{} x {} x {} (ny, nx, nt)", m.ny, m.nx, m.axis.nt),
    );
    line(
        "time axis",
        format!(
            "t0 {} ps, dt {} ps, {} bins, ends at {} ps",
            m.axis.t0_ps,
            m.axis.dt_ps,
            m.axis.nt,
            m.axis.end_ps()
        ),
    );
    line("time frame", m.frame.as_str().into());
    line("units", m.units.clone());
    line(
        "values",
        s.value_range.map_or("no finite values".into(), |(lo, hi)| {
            format!("{lo} .. {hi}")
        }),
    );
    line(
        "mask",
        s.mask.map_or("none".into(), |(valid, total)| {
            format!("{valid} of {total} pixels valid")
        }),
    );
    line(
        "size",
        format!("{} in memory", human_bytes(m.size_bytes() as u64)),
    );
    line(
        "groups",
        if m.groups.is_empty() {
            "none".into()
        } else {
            m.groups.join(", ")
        },
    );
    if let Some(v) = &m.femto_version {
        line("femto", v.clone());
    }
    if let Some(c) = &m.command_line {
        line("made by", c.clone());
    }
    for (k, v) in &m.notes {
        line("note", format!("{k} = {v}"));
    }
    out
}

/// Bytes in binary units, e.g. "1.5 MiB".
fn human_bytes(n: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = n as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{n} B")
    } else {
        format!("{v:.1} {} ({n} bytes)", UNITS[u])
    }
}

#[cfg(test)]
mod tests {
    use super::human_bytes;

    #[test]
    fn human_bytes_uses_binary_units() {
        assert_eq!(human_bytes(1000), "1000 B");
        assert_eq!(human_bytes(3 * 1024 * 1024 / 2), "1.5 MiB (1572864 bytes)");
    }
}
