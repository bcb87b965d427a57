//! HPD-TA files as instruments write them: the real `.img` and TIFF files of
//! `../shared/data/real` against an independent reader's numbers, and synthetic HPD-TA TIFF
//! files (a TIFF whose ImageDescription holds the HPD-TA header and whose time table follows
//! the image data) built here with the `tiff` crate's encoder, through `femto info` and
//! `femto ingest` as a user runs them.
//!
//! The reference numbers were computed with /tmp/venv/bin/python (rosettasciio 0.15.0 and
//! pillow 10.3; neither is needed to run these tests):
//!
//! ```text
//! from rsciio.hamamatsu import file_reader
//! d = file_reader(PATH, use_uniform_signal_axis=False)[0]
//! d["data"].astype(float).sum(); d["data"][t, x]; d["axes"][0]["axis"][i]
//! # the TIFF (rosettasciio's TIFF reader needs tifffile, absent there): pillow and numpy
//! a = np.array(PIL.Image.open("scene5.tif")); a.astype(float).sum(); a[t, x]
//! tab = np.frombuffer(open("scene5.tif", "rb").read(), "<f4", count=1016, offset=2716148)
//! rows_ps = tab[4:1012] * 1e3    # [Acquisition] areSource="0,4,1344,1008"
//! ```

use femto::container;
use femto::formats::read_streak;
use std::io::Cursor;
use std::path::{Path, PathBuf};
#[path = "common/cli.rs"]
mod cli;
#[path = "common/shared.rs"]
mod shared;
use cli::{arg, FemtoCmd};

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-300)
}

/// The sum of an image's values, in f64.
fn total(data: &[f32]) -> f64 {
    data.iter().map(|&v| v as f64).sum()
}

/// Each `(row, ps)` of `want` is the image's time axis at that row within 0.1 of the row's
/// width there.
fn check_rows(time_ps: &[f64], want: &[(usize, f64)]) {
    for &(row, ps) in want {
        let width = if row + 1 < time_ps.len() {
            time_ps[row + 1] - time_ps[row]
        } else {
            time_ps[row] - time_ps[row - 1]
        };
        assert!(
            (time_ps[row] - ps).abs() <= 0.1 * width,
            "row {row}: {} ps, recorded {ps} ps (row width {width} ps)",
            time_ps[row]
        );
    }
}

/// scene5.tif, a calibrated HPD-TA TIFF: pixels and the total of pillow's reading, the row
/// times of the table at byte 2716148 (rows 4..1011 of 1016, areSource), and the peak of
/// `femto ingest` with defaults against the table.
#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn scene5_tif_reads_its_embedded_time_table() {
    let Some(path) = shared::file("data/real/hpdta-tiff/scene5.tif") else {
        return;
    };
    let img = read_streak(&path, false).unwrap();
    assert_eq!((img.nx, img.nt), (1344, 1008));
    // pillow: a.astype(float).sum() = 598192311.0; a[0,0], a[500,700], a[1007,1343],
    // a[100,5] = 118, 127, 111, 138; (a == 65535).sum() = 4.
    assert!(close(total(&img.data), 598192311.0, 1e-6));
    for (t, x, v) in [
        (0, 0, 118.0),
        (500, 700, 127.0),
        (1007, 1343, 111.0),
        (100, 5, 138.0),
    ] {
        assert_eq!(img.at(x, t), v, "t {t} x {x}");
    }
    assert_eq!(img.data.iter().filter(|&&v| v == 65535.0).count(), 4);
    let time = img.time_axis_ps.as_ref().expect("a time axis");
    assert_eq!(time.len(), 1008);
    // numpy: rows_ps[0], [1], [143], [500], [1007].
    check_rows(
        time,
        &[
            (0, 75.11234283447266),
            (1, 93.89114379882812),
            (143, 2765.604019165039),
            (500, 9566.08772277832),
            (1007, 19621.280670166016),
        ],
    );
    let meta = img.img_meta.as_ref().unwrap();
    assert_eq!(meta.mode.as_deref(), Some("Operate"));
    assert_eq!(meta.time_range_ps, Some(20e3));
    assert!(meta.img_header().is_none() && meta.time_uncalibrated.is_none());

    let info = FemtoCmd::new().args(["info", arg(&path)]).ok().stdout;
    assert!(
        info.contains("time axis     75.11234 .. 19621.28 ps over 1008 rows"),
        "{info}"
    );
    assert!(info.contains("saturated     4 pixels"), "{info}");

    // femto ingest with defaults: the non-uniform table is resampled onto 1008 uniform bins
    // over its span, every count kept; the brightest time bin lies where the table puts the
    // brightest row (numpy: row 143, 2765.604 to 2784.464 ps), not where a uniform 20 ns /
    // 1008 guess would (2837.3 ps, 3.7 rows later).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cube.h5");
    FemtoCmd::new()
        .args(["ingest", arg(&path), "-o", arg(&out)])
        .ok();
    let cube = container::read_cube(&out).unwrap();
    assert_eq!((cube.nx, cube.ny, cube.axis.nt), (1344, 1, 1008));
    assert!(close(cube.axis.t0_ps, 75.11234283447266, 1e-9));
    let mut per_bin = vec![0.0f64; cube.axis.nt];
    let mut sum = 0.0;
    for x in 0..cube.nx {
        for (t, &v) in cube.profile(x, 0).iter().enumerate() {
            per_bin[t] += v as f64;
            sum += v as f64;
        }
    }
    assert!(close(sum, 598192311.0, 1e-6), "cube total {sum}");
    let peak = (0..per_bin.len())
        .max_by(|&a, &b| per_bin[a].total_cmp(&per_bin[b]))
        .unwrap();
    let centre_ps = cube.axis.t0_ps + (peak as f64 + 0.5) * cube.axis.dt_ps;
    let recorded_mid_ps = (2765.604019165039 + 2784.463882446289) / 2.0;
    assert!(
        (centre_ps - recorded_mid_ps).abs() <= cube.axis.dt_ps,
        "peak bin {peak} at {centre_ps} ps, the table's peak row at {recorded_mid_ps} ps"
    );
    let meta = container::read_meta(&out).unwrap();
    let axis_note = meta
        .notes
        .iter()
        .find(|(k, _)| k == "ingest.time_axis")
        .map(|(_, v)| v.clone())
        .unwrap();
    assert!(
        axis_note.contains("HPD-TA TIFF time table of"),
        "{axis_note}"
    );
}

/// test_file2.img, a Focus-mode 32-bit file whose Y axis is in nm: counts as rosettasciio
/// reads them, no time axis, `femto info` says why, `femto ingest` needs `--dt-ps`.
#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn test_file2_img_is_not_calibrated_in_time() {
    let Some(path) = shared::file("data/real/hpdta/test_file2.img") else {
        return;
    };
    let img = read_streak(&path, false).unwrap();
    assert_eq!((img.nx, img.nt), (640, 512));
    // rosettasciio: sum 186040925; data[0,0], [100,200], [511,511], [256,10], [300,100] =
    // 540, 543, 544, 542, 547; wavelength axis 448.90585 .. 592.4493 nm.
    assert!(close(total(&img.data), 186040925.0, 1e-6));
    for (t, x, v) in [
        (0, 0, 540.0),
        (100, 200, 543.0),
        (511, 511, 544.0),
        (256, 10, 542.0),
        (300, 100, 547.0),
    ] {
        assert_eq!(img.at(x, t), v, "t {t} x {x}");
    }
    let x = img.x_axis.as_ref().unwrap();
    assert_eq!(
        (x.values[0] as f32, x.values[639] as f32),
        (448.90585, 592.4493)
    );
    assert!(img.time_axis_ps.is_none());

    let info = FemtoCmd::new().args(["info", arg(&path)]).ok().stdout;
    let line = info.lines().find(|l| l.starts_with("time axis")).unwrap();
    assert!(
        line.contains("not calibrated in time")
            && line.contains("Mode=\"Focus\"")
            && line.contains("ScalingYUnit=\"nm\""),
        "{line}"
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("focus.h5");
    let err = FemtoCmd::new()
        .args(["ingest", arg(&path), "-o", arg(&out)])
        .refused();
    assert!(
        err.contains("test_file2.img") && err.contains("--dt-ps"),
        "{err}"
    );
    assert!(!out.exists());
    FemtoCmd::new()
        .args(["ingest", arg(&path), "-o", arg(&out), "--dt-ps", "1"])
        .ok();
    let cube = container::read_cube(&out).unwrap();
    assert_eq!(
        (cube.axis.t0_ps, cube.axis.dt_ps, cube.axis.nt),
        (0.0, 1.0, 512)
    );
}

/// uv_vis_file.img, a 16-bit spectrograph file with a ps table: counts and row times as
/// rosettasciio reads them (its wavelength axis reversed to increase, as femto's).
#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn uv_vis_img_reads_as_rosettasciio_does() {
    let Some(path) = shared::file("data/real/hpdta/uv_vis_file.img") else {
        return;
    };
    let img = read_streak(&path, false).unwrap();
    assert_eq!((img.nx, img.nt), (512, 512));
    // rosettasciio: sum 48912623; data[100,200], [511,511], [200,256] = 593, 116, 59;
    // max 4946; time axis [0], [1], [255], [510], [511] = 0, 1.5927181, 399.65317,
    // 798.2893, 799.8743 ps.
    assert!(close(total(&img.data), 48912623.0, 1e-6));
    for (t, x, v) in [(100, 200, 593.0), (511, 511, 116.0), (200, 256, 59.0)] {
        assert_eq!(img.at(x, t), v, "t {t} x {x}");
    }
    assert_eq!(img.data.iter().copied().fold(0.0f32, f32::max), 4946.0);
    check_rows(
        img.time_axis_ps.as_ref().unwrap(),
        &[
            (0, 0.0),
            (1, 1.5927181),
            (255, 399.65317),
            (510, 798.2893),
            (511, 799.8743),
        ],
    );
}

/// The pixel at column `x`, row `t` of the synthetic images.
fn pixel(x: usize, t: usize) -> u16 {
    ((x * 131 + t * 17) % 4000) as u16
}

/// A 16-bit HPD-TA TIFF of `w` x `h` pixels whose ImageDescription is `header(address)`,
/// `address` the `"#offset,count"` of `table` (float32, little-endian) appended after the
/// TIFF's own bytes; `keep` bytes of the table are kept (all: `usize::MAX`).
fn hpd_tiff(
    w: usize,
    h: usize,
    header: &dyn Fn(&str) -> String,
    table: &[f32],
    keep: usize,
) -> Vec<u8> {
    let encode = |description: &str| -> Vec<u8> {
        let mut cursor = Cursor::new(Vec::new());
        let mut encoder = tiff::encoder::TiffEncoder::new(&mut cursor).unwrap();
        let mut image = encoder
            .new_image::<tiff::encoder::colortype::Gray16>(w as u32, h as u32)
            .unwrap();
        image
            .encoder()
            .write_tag(tiff::tags::Tag::ImageDescription, description)
            .unwrap();
        let data: Vec<u16> = (0..h)
            .flat_map(|t| (0..w).map(move |x| pixel(x, t)))
            .collect();
        image.write_data(&data).unwrap();
        cursor.into_inner()
    };
    // The address is written with a fixed width, so the second encoding has the length of
    // the first and the table starts where the first ended.
    let address = |offset: usize| format!("#{offset:010},{:04}", table.len());
    let offset = encode(&header(&address(0))).len();
    let mut bytes = encode(&header(&address(offset)));
    assert_eq!(bytes.len(), offset);
    let table_bytes: Vec<u8> = table.iter().flat_map(|v| v.to_le_bytes()).collect();
    bytes.extend_from_slice(&table_bytes[..keep.min(table_bytes.len())]);
    bytes
}

/// An HPD-TA header as HPD-TA 9.5 writes it in a TIFF, with `mode`, `area` (areSource) and
/// the row scaling `y_scaling` (`ScalingY...` entries).
fn header(mode: &str, area: &str, y_scaling: &str) -> String {
    format!(
        "[Application],Enconding=UTF-8,Date=\"5/2/2021\",Time=\"2781.169ms\",\
         Software=\"HPD-TA\",Application=2,SoftwareVersion=\"9.5 pf4\"\r\n\
         [Acquisition],NrExposure=1,NrTrigger=1,ExposureTime=300 ms,AcqMode=1,\
         areSource=\"{area}\",BytesPerPixel=2\r\n\
         [Grabber],Type=5,SubType=0[Streak camera],DeviceName=\"C13410\",\
         Time Range=\"20 ns\",Mode=\"{mode}\",MCP Gain=\"27\"\r\n\
         [Scaling],ScalingXType=1,ScalingXScale=1,ScalingXUnit=\"\",\
         ScalingXScalingFile=\"Other\",{y_scaling}[Comment],UserComment=\"\""
    )
}

fn table_scaling(unit: &str, address: &str) -> String {
    format!(
        "ScalingYType=2,ScalingYScale=1,ScalingYUnit=\"{unit}\",ScalingYScalingFile=\"{address}\""
    )
}

fn info_json(path: &Path) -> serde_json::Value {
    let text = FemtoCmd::new()
        .args(["info", arg(path), "--json"])
        .ok()
        .stdout;
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// A TIFF with an HPD-TA header and a table longer than the image: the rows areSource names
/// are the time axis, in ps; the pixels are those written; `femto ingest` uses the table.
/// The same TIFF without the header is a plain TIFF with no time axis.
#[test]
fn hpd_tiff_with_an_embedded_table() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (5usize, 6usize);
    // 10 entries in ns, 0.25 ns apart; the image holds entries 3..9.
    let table: Vec<f32> = (0..10).map(|i| 1.0 + 0.25 * i as f32).collect();
    let bytes = hpd_tiff(
        w,
        h,
        &|a| header("Operate", "0,3,5,6", &table_scaling("ns", a)),
        &table,
        usize::MAX,
    );
    let path = write(dir.path(), "frame.tif", &bytes);
    let img = read_streak(&path, false).unwrap();
    assert_eq!((img.nx, img.nt), (w, h));
    let want: Vec<f64> = table[3..9].iter().map(|&v| v as f64 * 1e3).collect();
    assert_eq!(img.time_axis_ps.as_ref().unwrap(), &want);
    for t in 0..h {
        for x in 0..w {
            assert_eq!(img.at(x, t), pixel(x, t) as f32);
        }
    }
    let j = info_json(&path);
    assert_eq!(j["time_axis"]["first_ps"], 1750.0, "{j}");
    assert_eq!(j["time_axis"]["last_ps"], 3000.0, "{j}");
    assert_eq!(j["img"]["container"], "tiff", "{j}");
    assert!(j["img"]["file_type"].is_null(), "{j}");

    let out = dir.path().join("frame.h5");
    FemtoCmd::new()
        .args(["ingest", arg(&path), "-o", arg(&out), "--no-jitter"])
        .ok();
    let cube = container::read_cube(&out).unwrap();
    assert_eq!(
        (cube.axis.t0_ps, cube.axis.dt_ps, cube.axis.nt),
        (1750.0, 250.0, h)
    );
    for x in 0..w {
        for (t, &v) in cube.profile(x, 0).iter().enumerate() {
            assert_eq!(v, pixel(x, t) as f32, "x {x} t {t}");
        }
    }

    // No HPD-TA header: a plain TIFF, as before.
    let plain = hpd_tiff(w, h, &|_| "made by a camera".to_string(), &[], 0);
    let path = write(dir.path(), "plain.tif", &plain);
    let j = info_json(&path);
    assert!(j["time_axis"].is_null() && j["img"].is_null(), "{j}");
}

/// A table that runs past the end of the file, and tables that are not an axis (constant,
/// back and forth, NaN): `femto info` and `femto ingest` refuse in one line naming the file
/// and the key, exit 2, nothing written.
#[test]
fn bad_hpd_tiff_tables_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (4usize, 5usize);
    let good: Vec<f32> = (0..h).map(|i| i as f32 * 2.0).collect();
    let full = |table: &[f32]| {
        hpd_tiff(
            w,
            h,
            &|a| header("Operate", "0,0,4,5", &table_scaling("ps", a)),
            table,
            usize::MAX,
        )
    };
    let truncated = hpd_tiff(
        w,
        h,
        &|a| header("Operate", "0,0,4,5", &table_scaling("ps", a)),
        &good,
        4 * h - 3,
    );
    let cases = [
        ("truncated.tif", truncated, "truncated"),
        (
            "constant.tif",
            full(&[0.0, 2.0, 2.0, 4.0, 6.0]),
            "neither increasing",
        ),
        (
            "zigzag.tif",
            full(&[0.0, 2.0, 1.0, 4.0, 6.0]),
            "neither increasing",
        ),
        ("nan.tif", full(&[0.0, 2.0, f32::NAN, 4.0, 6.0]), "finite"),
    ];
    for (name, bytes, why) in cases {
        let path = write(dir.path(), name, &bytes);
        let err = FemtoCmd::new().args(["info", arg(&path)]).refused();
        assert!(
            err.contains(name) && err.contains("ScalingYScalingFile") && err.contains(why),
            "{err}"
        );
        let out = dir.path().join(format!("{name}.h5"));
        let err = FemtoCmd::new()
            .args(["ingest", arg(&path), "-o", arg(&out), "--dt-ps", "1"])
            .refused();
        assert!(
            err.contains(name) && err.contains("ScalingYScalingFile"),
            "{err}"
        );
        assert!(
            !out.exists(),
            "{name}: a refused ingest wrote {}",
            out.display()
        );
    }
}

/// Uncalibrated HPD-TA TIFF files: Focus mode (with a table, which it overrides), a table
/// kept in another file, no table named: `femto info` says not calibrated in time and why,
/// `femto ingest` asks for `--dt-ps` (exit 2, nothing written) and works with it.
#[test]
fn uncalibrated_hpd_tiff_asks_for_dt_ps() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (4usize, 5usize);
    let table: Vec<f32> = (0..h).map(|i| i as f32 * 2.0).collect();
    let cases: [(&str, Vec<u8>, &str); 3] = [
        (
            "focus.tif",
            hpd_tiff(
                w,
                h,
                &|a| header("Focus", "0,0,4,5", &table_scaling("ps", a)),
                &table,
                usize::MAX,
            ),
            "Mode=\"Focus\"",
        ),
        (
            "external.tif",
            hpd_tiff(
                w,
                h,
                &|_| {
                    header(
                        "Operate",
                        "0,0,4,5",
                        &table_scaling("ns", "C:\\HPDTA\\t.dat"),
                    )
                },
                &[],
                0,
            ),
            "a table outside this file",
        ),
        (
            "none.tif",
            hpd_tiff(
                w,
                h,
                &|_| {
                    header(
                        "Operate",
                        "0,0,4,5",
                        "ScalingYType=2,ScalingYScale=1,ScalingYUnit=\"ns\"",
                    )
                },
                &[],
                0,
            ),
            "no ScalingYScalingFile",
        ),
    ];
    for (name, bytes, why) in cases {
        let path = write(dir.path(), name, &bytes);
        let info = FemtoCmd::new().args(["info", arg(&path)]).ok().stdout;
        let line = info.lines().find(|l| l.starts_with("time axis")).unwrap();
        assert!(
            line.contains("not calibrated in time") && line.contains(why),
            "{name}: {line}"
        );
        let out = dir.path().join(format!("{name}.h5"));
        let err = FemtoCmd::new()
            .args(["ingest", arg(&path), "-o", arg(&out)])
            .refused();
        assert!(
            err.contains(name) && err.contains(why) && err.contains("--dt-ps"),
            "{err}"
        );
        assert!(
            !out.exists(),
            "{name}: a refused ingest wrote {}",
            out.display()
        );
        FemtoCmd::new()
            .args([
                "ingest",
                arg(&path),
                "-o",
                arg(&out),
                "--dt-ps",
                "2.5",
                "--no-jitter",
            ])
            .ok();
        let cube = container::read_cube(&out).unwrap();
        assert_eq!(
            (cube.axis.t0_ps, cube.axis.dt_ps, cube.axis.nt),
            (0.0, 2.5, h)
        );
        for x in 0..w {
            for (t, &v) in cube.profile(x, 0).iter().enumerate() {
                assert_eq!(v, pixel(x, t) as f32, "{name}: x {x} t {t}");
            }
        }
    }
}

/// An `.img` whose header announces several images is refused in one line, never read as
/// its first image only.
#[test]
fn img_with_several_images_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sequence.img");
    let img = femto::formats::StreakImage::new(3, 2, vec![1.0; 6]);
    femto::formats::hamamatsu::write_img(&path, &img, 16, &[0.0, 1.0]).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[14..18].copy_from_slice(&3i32.to_le_bytes());
    std::fs::write(&path, bytes).unwrap();
    let err = FemtoCmd::new().args(["info", arg(&path)]).refused();
    assert!(
        err.contains("sequence.img") && err.contains("3 images in one HPD-TA file"),
        "{err}"
    );
}
