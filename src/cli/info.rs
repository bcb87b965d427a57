//! `femto info FILE [--json]`: describe a file femto reads or writes.
//!
//! The kind of file is decided from its contents, not its name, where the format allows (an
//! HDF5 signature means a cube, or a pyramid side file when there is no `/cube`); meshes and
//! streak images by their extension. Each kind has its own arm below. The JSON object of
//! `--json` is documented in docs/cube-format.md.

use anyhow::{bail, Context};
use clap::Args;
use femto::container::{AttrValue, CubeMeta, CubeReader, DataBuf, GroupReader};
use femto::formats::{read_streak, PixelType, StreakImage};
use femto::geometry::load::load_mesh;
use femto::geometry::TriangleMesh;
use femto::pyramid::coarse_len;
use femto::store::{pyramid as stored_pyramid, registration as stored_registration};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The file to describe: a femto cube or pyramid side file (.h5), a mesh (.obj, .gltf,
    /// .glb) or a streak image (.png, .tif, .tiff, .exr, .hdr, .img).
    pub file: PathBuf,
    /// Print one JSON object on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What a file is, decided before describing it.
enum FileKind {
    /// A femto cube: an HDF5 file with a `/cube` dataset.
    Cube,
    /// An HDF5 file with groups but no `/cube` (a `femto pyramid --side-file`).
    SideFile,
    /// A triangle mesh.
    Mesh,
    /// A streak image.
    Streak,
}

const MESH_EXTENSIONS: [&str; 3] = ["obj", "gltf", "glb"];
const STREAK_EXTENSIONS: [&str; 6] = ["png", "tif", "tiff", "exr", "hdr", "img"];

fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

fn identify(path: &Path) -> anyhow::Result<FileKind> {
    let is_hdf5 = femto::container::is_hdf5(path).with_context(|| format!("{}", path.display()))?;
    if is_hdf5 {
        let groups = GroupReader::open(path)?;
        if groups.has_cube() {
            return Ok(FileKind::Cube);
        }
        if groups.groups().iter().any(|g| g == stored_pyramid::GROUP) {
            return Ok(FileKind::SideFile);
        }
        // Not ours: let the cube reader say why.
        return Ok(FileKind::Cube);
    }
    let ext = extension(path);
    if MESH_EXTENSIONS.contains(&ext.as_str()) {
        return Ok(FileKind::Mesh);
    }
    if STREAK_EXTENSIONS.contains(&ext.as_str()) {
        return Ok(FileKind::Streak);
    }
    bail!(
        "{}: not a femto cube (HDF5) file, a mesh (.obj, .gltf, .glb) or a streak image \
         (.png, .tif, .tiff, .exr, .hdr, .img)",
        path.display()
    )
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let (json_out, text_out) = match identify(&args.file)? {
        FileKind::Cube => {
            let s = cube_summary(&args.file)?;
            (cube_json(&args.file, &s), cube_text(&args.file, &s))
        }
        FileKind::SideFile => side_file_info(&args.file)?,
        FileKind::Mesh => {
            let mesh = load_mesh(&args.file)?;
            (mesh_json(&args.file, &mesh), mesh_text(&args.file, &mesh))
        }
        FileKind::Streak => {
            let img = read_streak(&args.file, false)?;
            (streak_json(&args.file, &img), streak_text(&args.file, &img))
        }
    };
    if args.json {
        println!("{json_out}");
    } else {
        print!("{text_out}");
    }
    Ok(())
}

/// Everything `info` says about a cube, computed once for both output forms.
struct CubeSummary {
    meta: CubeMeta,
    value_range: Option<(f32, f32)>,
    /// `(valid, total)` pixels when the cube has a mask.
    mask: Option<(usize, usize)>,
    /// The `registration` group, summarised (None without one).
    registration: Option<Value>,
    /// The `pyramid` group, summarised (None without one).
    pyramid: Option<Value>,
}

fn cube_summary(path: &Path) -> anyhow::Result<CubeSummary> {
    let reader = CubeReader::open(path)?;
    let meta = reader.meta().clone();
    let bar = super::progress(meta.ny as u64, "scanning");
    let value_range = reader.value_range(&|rows| bar.set_position(rows as u64))?;
    bar.finish_and_clear();
    let mask = reader
        .read_mask()?
        .map(|m| (m.iter().filter(|&&v| v != 0).count(), m.len()));
    let has = |g: &str| meta.groups.iter().any(|n| n == g);
    let registration = if has(stored_registration::GROUP) {
        Some(registration_summary(path, &reader, &meta)?)
    } else {
        None
    };
    let pyramid = if has(stored_pyramid::GROUP) {
        let attrs = reader.read_group_attrs(stored_pyramid::GROUP)?;
        let names = reader.group_dataset_names(stored_pyramid::GROUP)?;
        Some(pyramid_summary(path, attrs, &names, Some(&meta)))
    } else {
        None
    };
    Ok(CubeSummary {
        meta,
        value_range,
        mask,
        registration,
        pyramid,
    })
}

/// The registration group: the calibration (when its `calibration` attribute parses), the
/// fraction of pixels that see geometry (from `mask`) and the distance range (from `dist_m`).
fn registration_summary(
    path: &Path,
    reader: &CubeReader,
    meta: &CubeMeta,
) -> anyhow::Result<Value> {
    let g = stored_registration::GROUP;
    let attrs = reader.read_group_attrs(g)?;
    let data = femto::container::GroupData {
        attrs,
        datasets: Vec::new(),
    };
    let names = reader.group_dataset_names(g)?;
    let pixels = meta.nx * meta.ny;
    let plane = |name: &str| -> anyhow::Result<Option<DataBuf>> {
        if !names.iter().any(|n| n == name) {
            return Ok(None);
        }
        let (shape, _) = reader.group_dataset_shape(g, name)?;
        if shape != [meta.ny, meta.nx] {
            return Ok(None);
        }
        Ok(Some(reader.read_group_rows(g, name, 0, meta.ny)?))
    };
    let mask = match plane("mask")? {
        Some(DataBuf::U8(m)) => Some(m),
        _ => None,
    };
    let hit_pixels = mask.as_ref().map(|m| m.iter().filter(|&&v| v != 0).count());
    let dist_range = match plane("dist_m")? {
        Some(DataBuf::F32(d)) => d
            .iter()
            .enumerate()
            .filter(|&(p, v)| v.is_finite() && mask.as_ref().is_none_or(|m| m[p] != 0))
            .map(|(_, &v)| v)
            .fold(None, |r: Option<(f32, f32)>, v| {
                Some(r.map_or((v, v), |(a, b)| (a.min(v), b.max(v))))
            }),
        _ => None,
    };
    let (calibration, calibration_error) =
        match stored_registration::stored_calibration(path, &data) {
            Ok(c) => {
                let k = c.intrinsics;
                let o = c.pose.position_m;
                let f = c.pose.forward();
                (
                    json!({
                        "width": k.width, "height": k.height,
                        "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy, "k1": k.k1, "k2": k.k2,
                        "camera_m": [o.x, o.y, o.z],
                        "forward": [f.x, f.y, f.z],
                        "t0_ps": c.t0_ps,
                        "time_scale": c.time_scale,
                        "laser_m": [c.laser_m.x, c.laser_m.y, c.laser_m.z],
                        "eta": c.eta,
                    }),
                    Value::Null,
                )
            }
            Err(e) => (Value::Null, Value::String(e.to_string())),
        };
    let num = |name: &str| match data.attr(name) {
        Some(AttrValue::F64(v)) => json!(v),
        Some(AttrValue::I64(v)) => json!(v),
        _ => Value::Null,
    };
    let fit = if data.attr("points").is_some() {
        json!({
            "points": num("points"),
            "outliers": num("outliers"),
            "reprojection_rms_px": num("reprojection_rms_px"),
            "time_samples": num("time_samples"),
            "time_inliers": num("time_inliers"),
            "time_residual_rms_ps": num("time_residual_rms_ps"),
        })
    } else {
        Value::Null
    };
    Ok(json!({
        "calibration": calibration,
        "calibration_error": calibration_error,
        "mesh": match data.attr("mesh") { Some(AttrValue::Str(s)) => json!(s), _ => Value::Null },
        "pixels": pixels,
        "hit_pixels": hit_pixels,
        "hit_fraction": hit_pixels.map(|h| h as f64 / pixels as f64),
        "dist_m": dist_range.map(|(lo, hi)| json!({ "min": lo, "max": hi })),
        "fit": fit,
        "datasets": names,
    }))
}

/// The pyramid group from its attributes and dataset names; `meta` is the cube it is checked
/// against.
fn pyramid_summary(
    path: &Path,
    attrs: Vec<(String, AttrValue)>,
    datasets: &[String],
    meta: Option<&CubeMeta>,
) -> Value {
    let has = |name: &str| datasets.iter().any(|d| d == name);
    match stored_pyramid::info_from_attrs(path, attrs) {
        Ok(info) => json!({
            "levels": info.levels,
            "level_nt": info.level_nts(),
            "prefix": if has(stored_pyramid::COARSE) || !has("prefix") {
                json!({
                    "layout": "two-level",
                    "coarse_shape": [info.ny, info.nx, coarse_len(info.axis.nt)],
                    "fine_shape": [info.ny, info.nx, info.axis.nt + 1],
                })
            } else {
                json!({"layout": "f64", "shape": [info.ny, info.nx, info.axis.nt + 1]})
            },
            "time_axis": {
                "t0_ps": info.axis.t0_ps,
                "dt_ps": info.axis.dt_ps,
                "nt": info.axis.nt,
            },
            "time_frame": info.frame.as_str(),
            "source": info.source,
            "matches_cube": meta.map(|m| info.check_matches(path, m).is_ok()),
            "error": Value::Null,
        }),
        Err(e) => json!({ "error": e.to_string() }),
    }
}

fn side_file_info(path: &Path) -> anyhow::Result<(Value, String)> {
    let reader = GroupReader::open(path)?;
    let attrs = reader.read_group_attrs(stored_pyramid::GROUP)?;
    let names = reader.group_dataset_names(stored_pyramid::GROUP)?;
    let p = pyramid_summary(path, attrs, &names, None);
    let j = json!({
        "file": path.display().to_string(),
        "kind": "pyramid",
        "groups": reader.groups(),
        "pyramid": p,
    });
    let mut out = String::new();
    let mut line = |k: &str, v: String| out.push_str(&format!("{k:<14}{v}\n"));
    line("file", path.display().to_string());
    line("kind", "femto pyramid side file (HDF5, no cube)".into());
    line("pyramid", pyramid_text(&p));
    Ok((j, out))
}

fn pyramid_text(p: &Value) -> String {
    if let Some(e) = p["error"].as_str() {
        return format!("unreadable: {e}");
    }
    let prefix = &p["prefix"];
    let prefix = if prefix["layout"] == "f64" {
        format!("{} (f64, an older femto's layout)", prefix["shape"])
    } else {
        format!(
            "{} (f32 within blocks of 8 bins, f64 {} at their starts)",
            prefix["fine_shape"], prefix["coarse_shape"]
        )
    };
    let mut s = format!(
        "prefix sums {prefix}, {} mip level(s) with {} samples per pixel; built from {}",
        p["levels"],
        p["level_nt"],
        p["source"].as_str().unwrap_or("?")
    );
    if p["matches_cube"] == json!(false) {
        s.push_str(" (STALE: the cube's shape or time axis has changed)");
    }
    s
}

fn registration_text(r: &Value) -> Vec<String> {
    let mut lines = Vec::new();
    let c = &r["calibration"];
    if c.is_null() {
        lines.push(format!(
            "calibration unreadable: {}",
            r["calibration_error"].as_str().unwrap_or("?")
        ));
    } else {
        let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
        let v3 = |v: &Value| format!("({:.4}, {:.4}, {:.4})", f(&v[0]), f(&v[1]), f(&v[2]));
        lines.push(format!(
            "camera at {} m looking along {}, fx {:.2} fy {:.2} cx {:.2} cy {:.2} px",
            v3(&c["camera_m"]),
            v3(&c["forward"]),
            f(&c["fx"]),
            f(&c["fy"]),
            f(&c["cx"]),
            f(&c["cy"])
        ));
        lines.push(format!(
            "t0 {:.3} ps, time scale {}, laser at {} m, eta {}",
            f(&c["t0_ps"]),
            f(&c["time_scale"]),
            v3(&c["laser_m"]),
            f(&c["eta"])
        ));
    }
    if let (Some(h), Some(fr)) = (r["hit_pixels"].as_u64(), r["hit_fraction"].as_f64()) {
        lines.push(format!(
            "{h} of {} pixels see geometry ({:.1} %)",
            r["pixels"],
            100.0 * fr
        ));
    }
    let num = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    if !r["dist_m"].is_null() {
        lines.push(format!(
            "distance to the camera {:.4} .. {:.4} m",
            num(&r["dist_m"]["min"]),
            num(&r["dist_m"]["max"])
        ));
    }
    let fit = &r["fit"];
    if !fit.is_null() {
        lines.push(format!(
            "fit: {} points, {} outlier(s), reprojection rms {:.3} px; time residual rms {:.3} ps over {} of {} pixels",
            fit["points"],
            fit["outliers"],
            num(&fit["reprojection_rms_px"]),
            num(&fit["time_residual_rms_ps"]),
            fit["time_inliers"],
            fit["time_samples"]
        ));
    }
    lines
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
        "registration": s.registration,
        "pyramid": s.pyramid,
        "femto_version": m.femto_version,
        "command_line": m.command_line,
        "notes": notes,
    })
}

fn cube_text(path: &Path, s: &CubeSummary) -> String {
    let m = &s.meta;
    let mut out = String::new();
    let mut line = |k: &str, v: String| out.push_str(&format!("{k:<14}{v}\n"));
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
    if let Some(r) = &s.registration {
        for l in registration_text(r) {
            line("registration", l);
        }
    }
    if let Some(p) = &s.pyramid {
        line("pyramid", pyramid_text(p));
    }
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

fn mesh_json(path: &Path, mesh: &TriangleMesh) -> Value {
    let b = mesh.bounds();
    let bounds = if b.is_empty() {
        Value::Null
    } else {
        json!({
            "min": [b.min.x, b.min.y, b.min.z],
            "max": [b.max.x, b.max.y, b.max.z],
            "size": [b.max.x - b.min.x, b.max.y - b.min.y, b.max.z - b.min.z],
        })
    };
    // Triangles and area per material index, in increasing index order.
    let mut materials: std::collections::BTreeMap<u32, (usize, f64)> = Default::default();
    for (i, &m) in mesh.material.iter().enumerate() {
        let e = materials.entry(m).or_default();
        e.0 += 1;
        e.1 += mesh.area(i) as f64;
    }
    let total_area: f64 = materials.values().map(|v| v.1).sum();
    json!({
        "file": path.display().to_string(),
        "kind": "mesh",
        "format": extension(path),
        "triangles": mesh.triangle_count(),
        "vertices": mesh.positions.len(),
        "bounds_m": bounds,
        "surface_area_m2": total_area,
        "materials": materials
            .iter()
            .map(|(m, (n, a))| json!({ "index": m, "triangles": n, "area_m2": a }))
            .collect::<Vec<_>>(),
    })
}

fn mesh_text(path: &Path, mesh: &TriangleMesh) -> String {
    let j = mesh_json(path, mesh);
    let mut out = String::new();
    let mut line = |k: &str, v: String| out.push_str(&format!("{k:<14}{v}\n"));
    line("file", path.display().to_string());
    line("kind", format!("triangle mesh ({})", extension(path)));
    line(
        "triangles",
        format!(
            "{} ({} vertices)",
            mesh.triangle_count(),
            mesh.positions.len()
        ),
    );
    let b = mesh.bounds();
    line(
        "bounds",
        if b.is_empty() {
            "empty".into()
        } else {
            format!(
                "({:.6}, {:.6}, {:.6}) .. ({:.6}, {:.6}, {:.6}) m, size {:.6} x {:.6} x {:.6} m",
                b.min.x,
                b.min.y,
                b.min.z,
                b.max.x,
                b.max.y,
                b.max.z,
                b.max.x - b.min.x,
                b.max.y - b.min.y,
                b.max.z - b.min.z
            )
        },
    );
    line(
        "area",
        format!("{:.6} m^2", j["surface_area_m2"].as_f64().unwrap_or(0.0)),
    );
    for m in j["materials"].as_array().into_iter().flatten() {
        line(
            "material",
            format!(
                "{}: {} triangles, {:.6} m^2",
                m["index"],
                m["triangles"],
                m["area_m2"].as_f64().unwrap_or(0.0)
            ),
        );
    }
    out
}

/// The documented name of a pixel type.
fn pixel_type_name(t: PixelType) -> &'static str {
    match t {
        PixelType::U8 => "u8",
        PixelType::U16 => "u16",
        PixelType::U32 => "u32",
        PixelType::I16 => "i16",
        PixelType::I32 => "i32",
        PixelType::F16 => "f16",
        PixelType::F32 => "f32",
        PixelType::F64 => "f64",
        PixelType::RgbU8 => "rgb_u8",
        PixelType::RgbU16 => "rgb_u16",
        PixelType::RgbF16 => "rgb_f16",
        PixelType::RgbF32 => "rgb_f32",
        PixelType::Rgbe => "rgbe",
    }
}

fn streak_json(path: &Path, img: &StreakImage) -> Value {
    let range = femto::cube::value_range(&img.data);
    let saturated = img
        .pixel_type
        .max_stored_value()
        .map(|top| img.data.iter().filter(|&&v| v as f64 >= top).count());
    let time_axis = img.time_axis_ps.as_ref().map(|t| {
        let n = t.len();
        json!({
            "first_ps": t.first(),
            "last_ps": t.last(),
            "mean_dt_ps": if n > 1 { (t[n - 1] - t[0]) / (n - 1) as f64 } else { f64::NAN },
            "nt": n,
        })
    });
    let x_axis = img
        .x_axis
        .as_ref()
        .map(|a| json!({ "first": a.values.first(), "last": a.values.last(), "unit": a.unit }));
    let img_meta = img.img_meta.as_ref().map(|m| {
        json!({
            "width": m.header.width,
            "height": m.header.height,
            "file_type": m.header.file_type.code(),
            "mode": m.mode,
            "time_range_ps": m.time_range_ps,
            "mcp_gain": m.mcp_gain,
            "n_exposures": m.n_exposures,
            "exposure_time_s": m.exposure_time_s,
            "total_exposure_s": m.total_exposure_s,
            "sections": m.sections.keys().collect::<Vec<_>>(),
            "columns_reversed": m.columns_reversed,
            "rows_reversed": m.rows_reversed,
        })
    });
    json!({
        "file": path.display().to_string(),
        "kind": "streak_image",
        "format": extension(path),
        "nx": img.nx,
        "nt": img.nt,
        "pixel_type": pixel_type_name(img.pixel_type),
        "value_range": range.map(|(lo, hi)| json!({ "min": lo, "max": hi })),
        "saturated_pixels": saturated,
        "time_axis": time_axis,
        "x_axis": x_axis,
        "img": img_meta,
    })
}

fn streak_text(path: &Path, img: &StreakImage) -> String {
    let j = streak_json(path, img);
    let mut out = String::new();
    let mut line = |k: &str, v: String| out.push_str(&format!("{k:<14}{v}\n"));
    line("file", path.display().to_string());
    line("kind", format!("streak image ({})", extension(path)));
    line(
        "size",
        format!("{} x {} (nx, nt): x across, time down", img.nx, img.nt),
    );
    line("pixels", pixel_type_name(img.pixel_type).into());
    line(
        "values",
        match femto::cube::value_range(&img.data) {
            Some((lo, hi)) => format!("{lo} .. {hi}"),
            None => "no finite values".into(),
        },
    );
    if let Some(n) = j["saturated_pixels"].as_u64() {
        line(
            "saturated",
            format!("{n} pixels at the file's largest value"),
        );
    }
    line(
        "time axis",
        match &img.time_axis_ps {
            Some(t) if !t.is_empty() => format!(
                "{} .. {} ps over {} rows (mean {} ps per row)",
                t[0],
                t[t.len() - 1],
                t.len(),
                j["time_axis"]["mean_dt_ps"]
            ),
            _ => "none in the file".into(),
        },
    );
    if let Some(a) = &img.x_axis {
        line(
            "x axis",
            format!(
                "{} .. {} {}",
                a.values.first().copied().unwrap_or(f64::NAN),
                a.values.last().copied().unwrap_or(f64::NAN),
                a.unit
            ),
        );
    }
    if let Some(m) = &img.img_meta {
        let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| x.to_string());
        line(
            "HPD-TA",
            format!(
                "{} x {} stored, file type {}, mode {}, time range {} ps, MCP gain {}",
                m.header.width,
                m.header.height,
                m.header.file_type.code(),
                m.mode.as_deref().unwrap_or("-"),
                opt(m.time_range_ps),
                opt(m.mcp_gain)
            ),
        );
        line(
            "exposure",
            format!(
                "{} x {} s = {} s",
                m.n_exposures.map_or("-".to_string(), |n| n.to_string()),
                opt(m.exposure_time_s),
                opt(m.total_exposure_s)
            ),
        );
        line(
            "sections",
            m.sections.keys().cloned().collect::<Vec<_>>().join(", "),
        );
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
