//! HPD-TA `.img` variants through `femto info` and `femto ingest`, as a user runs them.
//!
//! Every file here is built byte by byte from the documented layout (64-byte header, the
//! `[Section],Key=Value` comment, the pixels row by row, then float32 axis tables at the
//! offset the comment names; see `../shared/data/hamamatsu/FACTS.md` and
//! `femto::formats::hamamatsu`), independently of femto's writer. The variants are those
//! HPD-TA writes and rosettasciio reads: a `Time Range` that is a bare sweep-range index,
//! 8-, 16- and 32-bit pixels, time tables in ps, ns, us and ms, and files whose time axis is
//! not calibrated (sensor rows), which `femto ingest` reads once `--dt-ps` gives the time per
//! row. Each axis is checked against the numbers put into the file. The two real files of
//! `../shared` must read as before (`skipped: ...` without them; a failure under `CI=true`).

use femto::container;
use std::path::{Path, PathBuf};
#[path = "common/cli.rs"]
mod cli;
use cli::{arg, FemtoCmd};

/// How the file calibrates its rows (the time axis).
enum Rows<'a> {
    /// `ScalingYType=2`: a float32 table in `unit`.
    Table { unit: &'a str, values: Vec<f32> },
    /// `ScalingYType=1` with no unit, as HPD-TA writes in Focus mode: sensor rows.
    Pixels,
    /// No `[Scaling]` section at all.
    NoScaling,
}

/// Pixel `(x, t)` of the test images: distinct values that use the high bytes of each depth.
fn pixel(file_type: i16, x: usize, t: usize) -> u32 {
    let v = (x * 7 + t * 13) as u64;
    (match file_type {
        0 => v % 251,
        2 => v * 257 % 65521,
        _ => v * 16_777_259 % 4_294_967_291,
    }) as u32
}

/// An HPD-TA file of `w` x `h` pixels of `file_type` (0 = 8-bit, 2 = 16-bit, 3 = 32-bit)
/// whose comment holds `sections` followed by the `[Scaling]` of `rows` (X uncalibrated).
fn build_img(file_type: i16, w: usize, h: usize, sections: &str, rows: &Rows) -> Vec<u8> {
    let bytes_per_pixel = match file_type {
        0 => 1,
        2 => 2,
        _ => 4,
    };
    let pixel_bytes = w * h * bytes_per_pixel;
    let scaling = |offset: usize| match rows {
        Rows::Table { unit, .. } => format!(
            "[Scaling],ScalingXType=1,ScalingXScale=1,ScalingXUnit=\"\",\
             ScalingXScalingFile=\"Other\",ScalingYType=2,ScalingYScale=1,\
             ScalingYUnit=\"{unit}\",ScalingYScalingFile=\"#{offset},{h:04}\""
        ),
        Rows::Pixels => "[Scaling],ScalingXType=1,ScalingXScale=1,ScalingXUnit=\"\",\
                         ScalingXScalingFile=\"Other\",ScalingYType=1,ScalingYScale=2,\
                         ScalingYUnit=\"\",ScalingYScalingFile=\"Focus mode\""
            .to_string(),
        Rows::NoScaling => String::new(),
    };
    // The table offset is written inside the comment: iterate to the fixed point.
    let mut comment = format!("{sections}{}[Comment],UserComment=\"\"", scaling(0));
    loop {
        let offset = 64 + comment.len() + pixel_bytes;
        let next = format!("{sections}{}[Comment],UserComment=\"\"", scaling(offset));
        if next.len() == comment.len() {
            comment = next;
            break;
        }
        comment = next;
    }
    let mut b = Vec::new();
    b.extend_from_slice(b"IM");
    b.extend_from_slice(&(comment.len() as i16).to_le_bytes());
    b.extend_from_slice(&(w as i16).to_le_bytes());
    b.extend_from_slice(&(h as i16).to_le_bytes());
    b.extend_from_slice(&[0; 4]); // x and y offset
    b.extend_from_slice(&file_type.to_le_bytes());
    b.resize(64, 0);
    b.extend_from_slice(comment.as_bytes());
    for t in 0..h {
        for x in 0..w {
            let v = pixel(file_type, x, t);
            match file_type {
                0 => b.push(v as u8),
                2 => b.extend_from_slice(&(v as u16).to_le_bytes()),
                _ => b.extend_from_slice(&v.to_le_bytes()),
            }
        }
    }
    if let Rows::Table { values, .. } = rows {
        assert_eq!(values.len(), h);
        for v in values {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    b
}

/// What HPD-TA writes before `[Scaling]`, with `time_range` as the `Time Range` value.
fn sections(time_range: &str, mode: &str) -> String {
    format!(
        "[Application],Enconding=UTF-8,Date=\"29/08/2018\",Time=\"10:11:12.000\",\
         Software=\"HPD-TA\",Application=2,SoftwareVersion=\"9.3 pf5\"\r\n\
         [Acquisition],NrExposure=10,NrTrigger=0,ExposureTime=100 ms,AcqMode=4,\
         pntBinning=\"2,2\",BytesPerPixel=4,IsLineData=0,BacksubCorr=0,ShadingCorr=0,\
         ZAxisLabel=Intensity,ZAxisUnit=Count\r\n\
         [Streak camera],UseDevice=-1,DeviceName=\"C5680\",Time Range=\"{time_range}\",\
         Mode=\"{mode}\",MCP Gain=\"40\"\r\n"
    )
}

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

fn info_json(path: &Path) -> serde_json::Value {
    json(
        &FemtoCmd::new()
            .args(["info", arg(path), "--json"])
            .ok()
            .stdout,
    )
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-300)
}

/// `femto ingest FILE -o cube.h5 --no-jitter EXTRA...`; the cube must hold the file's pixels
/// unchanged (no correction asked for) on `expected_axis` (t0, dt, nt) within `rel`.
fn ingest_and_check(
    path: &Path,
    extra: &[&str],
    file_type: i16,
    (w, h): (usize, usize),
    (t0_ps, dt_ps): (f64, f64),
    rel: f64,
) -> femto::container::CubeMeta {
    let out = path.with_extension("h5");
    FemtoCmd::new()
        .args([
            "ingest",
            arg(path),
            "-o",
            arg(&out),
            "--no-jitter",
            "--force",
        ])
        .args(extra)
        .ok();
    let cube = container::read_cube(&out).unwrap();
    assert_eq!((cube.nx, cube.ny, cube.axis.nt), (w, 1, h));
    assert!(
        close(cube.axis.t0_ps, t0_ps, rel) && close(cube.axis.dt_ps, dt_ps, rel),
        "{}: axis {:?}, want t0 {t0_ps} dt {dt_ps}",
        path.display(),
        cube.axis
    );
    for x in 0..w {
        let profile = cube.profile(x, 0);
        for (t, &v) in profile.iter().enumerate() {
            assert_eq!(v, pixel(file_type, x, t) as f32, "x {x} t {t}");
        }
    }
    container::read_meta(&out).unwrap()
}

fn note<'a>(meta: &'a femto::container::CubeMeta, key: &str) -> &'a str {
    meta.notes
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
        .unwrap_or_else(|| panic!("no note {key}"))
}

/// Time tables in each unit HPD-TA writes, with a duration or a bare index as time range,
/// at each bit depth: `femto info` and `femto ingest` give the axis put into the file.
#[test]
fn time_tables_in_ps_ns_us_ms_at_every_depth() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (5usize, 64usize);
    // (unit, ps per unit, first value, step, time range, file type)
    let cases: [(&str, f64, f32, f32, &str, i16); 5] = [
        // A 32-bit file with a ps table of 4.7 ps per row and a bare range index.
        ("ps", 1.0, 0.0, 4.7, "1", 3),
        // A bare sweep-range index with an ns table, 16-bit.
        ("ns", 1e3, 1.5, 0.1, "4", 2),
        ("us", 1e6, 0.0, 0.002, "200 ns", 2),
        ("ms", 1e9, 0.0, 1e-6, "100 ns", 0),
        ("ps", 1.0, -20.0, 2.0, "128 ps", 3),
    ];
    for (i, &(unit, per, first, step, range, file_type)) in cases.iter().enumerate() {
        let values: Vec<f32> = (0..h).map(|k| first + step * k as f32).collect();
        let path = dir.path().join(format!("table_{i}_{unit}.img"));
        let rows = Rows::Table {
            unit,
            values: values.clone(),
        };
        std::fs::write(
            &path,
            build_img(file_type, w, h, &sections(range, "Operate"), &rows),
        )
        .unwrap();
        let want_first = values[0] as f64 * per;
        let want_last = values[h - 1] as f64 * per;
        let want_dt = (want_last - want_first) / (h - 1) as f64;

        let info = info_json(&path);
        let axis = &info["time_axis"];
        assert!(
            close(axis["first_ps"].as_f64().unwrap(), want_first, 1e-12)
                && close(axis["last_ps"].as_f64().unwrap(), want_last, 1e-12)
                && axis["nt"] == h,
            "{unit}: {info}"
        );
        let img = &info["img"];
        assert_eq!(img["file_type"], file_type, "{info}");
        if range.contains(' ') {
            assert!(img["time_range_ps"].as_f64().is_some(), "{info}");
            assert!(img["time_range_index"].is_null(), "{info}");
        } else {
            assert_eq!(img["time_range_index"], range.parse::<u32>().unwrap());
            assert!(img["time_range_ps"].is_null(), "{info}");
        }
        assert!(img["time_uncalibrated"].is_null(), "{info}");

        // The cube's axis is the table's span over as many bins (the last row one step
        // long): start at the first entry, bin width (last - first) / (nt - 1).
        let meta = ingest_and_check(&path, &[], file_type, (w, h), (want_first, want_dt), 1e-6);
        assert!(
            note(&meta, "ingest.time_axis").contains(".img time table"),
            "{:?}",
            meta.notes
        );
    }
}

/// A file whose rows are sensor pixels (Focus-mode scaling, a bare range index): `femto
/// info` says the time axis is not calibrated, `femto ingest` asks for `--dt-ps` in one
/// line naming the file and the header key and writes nothing, and with `--dt-ps` ingests.
#[test]
fn uncalibrated_rows_ask_for_dt_ps_and_ingest_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (6usize, 40usize);
    for (name, rows, key, file_type) in [
        ("focus.img", Rows::Pixels, "ScalingYType=1", 0i16),
        ("bare.img", Rows::NoScaling, "no [Scaling] section", 3),
    ] {
        let path = dir.path().join(name);
        std::fs::write(
            &path,
            build_img(file_type, w, h, &sections("2", "Focus"), &rows),
        )
        .unwrap();

        let info = FemtoCmd::new().args(["info", arg(&path)]).ok().stdout;
        let line = info
            .lines()
            .find(|l| l.starts_with("time axis"))
            .unwrap_or_else(|| panic!("{info}"));
        assert!(
            line.contains("not calibrated") && line.contains(key) && line.contains("--dt-ps"),
            "{line}"
        );
        let j = info_json(&path);
        assert!(j["time_axis"].is_null(), "{j}");
        let why = j["img"]["time_uncalibrated"].as_str().unwrap();
        assert!(
            why.contains(key) && why.contains("Time Range=\"2\""),
            "{why}"
        );
        assert_eq!(j["img"]["time_range_index"], 2);

        let out = dir.path().join("refused.h5");
        let err = FemtoCmd::new()
            .args(["ingest", arg(&path), "-o", arg(&out)])
            .refused();
        assert!(
            err.contains(&path.display().to_string())
                && err.contains(key)
                && err.contains("--dt-ps"),
            "{err}"
        );
        assert!(!out.exists(), "a refused ingest wrote {}", out.display());

        // --dt-ps alone: the first row starts at 0 ps.
        let meta = ingest_and_check(
            &path,
            &["--dt-ps", "3.5"],
            file_type,
            (w, h),
            (0.0, 3.5),
            0.0,
        );
        assert!(
            note(&meta, "ingest.time_axis").contains("not calibrated"),
            "{:?}",
            meta.notes
        );
        // --t0-ps moves the start.
        ingest_and_check(
            &path,
            &["--dt-ps", "3.5", "--t0-ps", "-10"],
            file_type,
            (w, h),
            (-10.0, 3.5),
            0.0,
        );
    }
}

/// A real file of `../shared/data/hamamatsu`, or `None` after printing `skipped: ...`
/// (a failure under `CI=true`, where the data must be present).
fn real_file(name: &str) -> Option<PathBuf> {
    let dir = match std::env::var_os("FEMTO_SHARED") {
        Some(d) => PathBuf::from(d),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"),
    };
    let path = dir.join("data/hamamatsu").join(name);
    if path.is_file() {
        return Some(path);
    }
    let why = format!("skipped: {} not found", path.display());
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{why} (CI=true requires it)"
    );
    println!("{why}");
    None
}

/// The two real files read as before: operate_mode.img with its microsecond table (values of
/// FACTS.md), focus_mode.img with its uncalibrated rows, now ingested with `--dt-ps`.
#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn real_files_read_as_before() {
    let (Some(operate), Some(focus)) = (real_file("operate_mode.img"), real_file("focus_mode.img"))
    else {
        return;
    };
    let j = info_json(&operate);
    // FACTS.md: the first table values, in us: 0.0, 0.031080816, ...
    assert_eq!(j["time_axis"]["first_ps"], 0.0, "{j}");
    assert_eq!(j["time_axis"]["nt"], 512);
    assert_eq!(j["img"]["time_range_ps"], 2e7);
    assert_eq!(j["img"]["file_type"], 3);
    assert!(j["img"]["time_uncalibrated"].is_null());

    let j = info_json(&focus);
    assert!(j["time_axis"].is_null(), "{j}");
    assert_eq!(j["img"]["time_range_ps"], 5000.0);
    let why = j["img"]["time_uncalibrated"].as_str().unwrap();
    assert!(why.contains("ScalingYType=1"), "{why}");

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("focus.h5");
    let err = FemtoCmd::new()
        .args(["ingest", arg(&focus), "-o", arg(&out)])
        .refused();
    assert!(
        err.contains("focus_mode.img") && err.contains("ScalingYType") && err.contains("--dt-ps"),
        "{err}"
    );
    FemtoCmd::new()
        .args(["ingest", arg(&focus), "-o", arg(&out), "--dt-ps", "10"])
        .ok();
    let cube = container::read_cube(&out).unwrap();
    assert_eq!((cube.nx, cube.ny, cube.axis.nt), (672, 1, 512));
    assert_eq!((cube.axis.t0_ps, cube.axis.dt_ps), (0.0, 10.0));
    // FACTS.md: the last 3 rows by last 3 columns, [[0, 0, 36], [0, 0, 0], [21, 0, 0]].
    let facts = [[0.0, 0.0, 36.0], [0.0, 0.0, 0.0], [21.0, 0.0, 0.0]];
    for (dt, row) in facts.iter().enumerate() {
        for (dx, &v) in row.iter().enumerate() {
            assert_eq!(cube.profile(669 + dx, 0)[509 + dt], v);
        }
    }
}

/// The comment split as rosettasciio's reader splits it (`rsciio/hamamatsu/_api.py`:
/// sections at `[`, the body after `],`, entries `key=value` or `key="value"` separated by
/// commas), written here independently of femto's parser.
fn rsciio_sections(comment: &str) -> Vec<(String, Vec<(String, String)>)> {
    let mut out = Vec::new();
    for entry in comment[1..].split('[') {
        let close = entry.find(']').expect("section name closes");
        let body = entry[close + 1..]
            .strip_prefix(',')
            .unwrap_or("")
            .trim_end();
        let mut entries = Vec::new();
        let mut rest = body;
        while let Some(eq) = rest.find('=') {
            let key = rest[..eq].to_string();
            let after = &rest[eq + 1..];
            let (value, next) = match after.strip_prefix('"') {
                Some(q) => {
                    let end = q.find('"').expect("quoted value closes");
                    (&q[..end], q[end + 1..].strip_prefix(',').unwrap_or(""))
                }
                None => match after.find(',') {
                    Some(c) => (&after[..c], &after[c + 1..]),
                    None => (after, ""),
                },
            };
            entries.push((key, value.to_string()));
            rest = next;
        }
        out.push((entry[..close].to_string(), entries));
    }
    out
}

/// `femto simulate --format img16` writes files with every key rosettasciio's reader needs
/// (its `file_reader` fails without `[Acquisition] AcqMode`, an integer, and without both
/// axes' `Scaling?Type`), with values HPD-TA writes, and a table that the `[Scaling]`
/// entries point at.
#[test]
fn femto_img_files_carry_the_keys_rosettasciio_needs() {
    let dir = tempfile::tempdir().unwrap();
    let cap = dir.path().join("cap");
    FemtoCmd::new()
        .args(["simulate", "--scene", "cube", "--size", "8x4", "--spp", "1"])
        .args(["--format", "img16", "--out", arg(&cap)])
        .ok();
    let bytes = std::fs::read(cap.join("scanlines/scanline_0000.img")).unwrap();
    let comment_len = i16::from_le_bytes([bytes[2], bytes[3]]) as usize;
    let (w, h) = (
        i16::from_le_bytes([bytes[4], bytes[5]]) as usize,
        i16::from_le_bytes([bytes[6], bytes[7]]) as usize,
    );
    let comment = std::str::from_utf8(&bytes[64..64 + comment_len]).unwrap();
    let sections = rsciio_sections(comment);
    let get = |section: &str, key: &str| -> Option<String> {
        sections
            .iter()
            .find(|(s, _)| s == section)
            .and_then(|(_, e)| e.iter().find(|(k, _)| k == key))
            .map(|(_, v)| v.clone())
    };
    let int = |section: &str, key: &str| -> i64 {
        get(section, key)
            .unwrap_or_else(|| panic!("[{section}] {key} missing: {comment}"))
            .parse()
            .unwrap_or_else(|_| panic!("[{section}] {key} is not an integer: {comment}"))
    };
    // AcqMode: 1 live, 2 acquire, 3 photon counting, 4 analog integration.
    assert!(
        (1..=4).contains(&int("Acquisition", "AcqMode")),
        "{comment}"
    );
    assert_eq!(int("Acquisition", "NrExposure"), 1);
    assert_eq!(int("Acquisition", "BytesPerPixel"), 2);
    for key in [
        "BacksubCorr",
        "ShadingCorr",
        "CurveCorr",
        "DefectCorrection",
    ] {
        assert_eq!(
            int("Acquisition", key),
            0,
            "{key}: femto applies no correction"
        );
    }
    assert_eq!(get("Acquisition", "pntBinning").as_deref(), Some("1,1"));
    assert_eq!(get("Streak camera", "Mode").as_deref(), Some("Operate"));
    let range = get("Streak camera", "Time Range").unwrap();
    assert_eq!(range.split(' ').count(), 2, "a number and a unit: {range}");
    assert_eq!(int("Scaling", "ScalingXType"), 1);
    assert_eq!(int("Scaling", "ScalingYType"), 2);
    assert_eq!(get("Scaling", "ScalingYUnit").as_deref(), Some("ps"));
    let file = get("Scaling", "ScalingYScalingFile").unwrap();
    let (offset, count) = file[1..].split_once(',').unwrap();
    let (offset, count): (usize, usize) = (offset.parse().unwrap(), count.parse().unwrap());
    assert_eq!(offset, 64 + comment_len + 2 * w * h, "{file}");
    assert_eq!((count, bytes.len()), (h, offset + 4 * h));
}
