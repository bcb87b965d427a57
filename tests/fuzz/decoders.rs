//! Fuzz targets of the decoders added since issue 16 (issue 45): `.npy`, MATLAB v5 (plain
//! and compressed) and v7.3, HyperSpy, plain HDF5 arrays, HPD-TA TIFF files with their axis
//! tables, the EXR frames `femto compare` reads, and the `band.toml` of `femto merge`. Each
//! reads its case as the command does (`femto::readers::open` for the array files, as
//! `ingest` and `info` do) and then checks what it returned against its own shape, so that
//! a header that lies about a size shows up as a failure here, not in a command. The seeds
//! are made by the generators below (small, and valid: each must read). The findings of
//! these targets are kept in `tests/fuzz/cases/` ([`regression_files_read_without_panic`]).

use super::{check, Mutation, Target};
use femto::readers::{Format, ReadOptions};
use std::path::Path;

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Open an array file as `ingest` and `info` do and check the samples against the shape;
/// the outcome is that of the default layout. The transposed layout is read too (for
/// panics and lying sizes; a HyperSpy signal refuses it by design).
fn read_array(path: &Path, format: Format) -> Result<(), String> {
    let open = |transpose| {
        let options = ReadOptions {
            dataset: None,
            layout: femto::readers::layout::LayoutOptions {
                transpose,
                ..Default::default()
            },
        };
        let c = femto::readers::open(path, format, &options).map_err(s)?;
        assert_eq!(
            c.samples.len(),
            c.ny * c.nx * c.nt,
            "samples of {:?}",
            c.stored_shape
        );
        assert!(c.ny * c.nx * c.nt > 0, "an empty capture was read");
        Ok::<(), String>(())
    };
    let plain = open(false);
    let _ = open(true);
    plain
}

// ---------------------------------------------------------------- .npy

/// A `.npy` file (version 1, or 2 with a 4-byte header length) of `shape` and `descr` with
/// the raw values `raw`.
pub fn npy_file(shape: &[usize], descr: &str, fortran: bool, version: u8, raw: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let tuple = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let order = if fortran { "True" } else { "False" };
    let mut header =
        format!("{{'descr': '{descr}', 'fortran_order': {order}, 'shape': {tuple}, }}");
    let pre = if version == 1 { 10 } else { 12 };
    while !(pre + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    let mut out = vec![0x93, b'N', b'U', b'M', b'P', b'Y', version, 0];
    if version == 1 {
        out.extend((header.len() as u16).to_le_bytes());
    } else {
        out.extend((header.len() as u32).to_le_bytes());
    }
    out.extend(header.as_bytes());
    out.extend(raw);
    out
}

fn npy_seeds() -> Vec<Vec<u8>> {
    let f4: Vec<u8> = (0..60)
        .flat_map(|i| (i as f32 * 0.5).to_le_bytes())
        .collect();
    let u2: Vec<u8> = (0..15u16).flat_map(|i| (i * 300).to_be_bytes()).collect();
    let u1: Vec<u8> = (0..16u8).collect();
    let f8: Vec<u8> = (0..24).flat_map(|i| (i as f64).to_le_bytes()).collect();
    vec![
        npy_file(&[4, 3, 5], "<f4", false, 1, &f4),
        npy_file(&[3, 5], ">u2", true, 1, &u2),
        npy_file(&[2, 2, 4], "|u1", false, 2, &u1),
        npy_file(&[2, 3, 4], "<f8", true, 3, &f8),
    ]
}

#[test]
fn npy() {
    check(
        Target {
            name: "npy",
            ext: "npy",
            seeds: npy_seeds(),
            mutation: Mutation::Bytes,
            read: |p| read_array(p, Format::Npy),
        },
        400,
    );
}

// ---------------------------------------------------------------- MATLAB

fn mat_seeds(compress: bool) -> Vec<Vec<u8>> {
    use femto::readers::mat::v5_bytes;
    let u2: Vec<u8> = (0..24u16).flat_map(|i| (i * 7).to_le_bytes()).collect();
    let f8: Vec<u8> = (0..30)
        .flat_map(|i| (i as f64 * 0.25).to_le_bytes())
        .collect();
    let width = 0.35f64.to_le_bytes();
    let small: Vec<u8> = (0..12u8).collect();
    vec![
        v5_bytes(
            &[
                ("width", &[1, 1], 6, 9, &width),
                ("rect", &[2, 3, 4], 11, 4, &u2),
            ],
            compress,
        ),
        v5_bytes(&[("d", &[5, 6], 6, 9, &f8)], compress),
        v5_bytes(&[("b", &[2, 2, 3], 9, 2, &small)], compress),
    ]
}

#[test]
fn mat_v5() {
    check(
        Target {
            name: "mat_v5",
            ext: "mat",
            seeds: mat_seeds(false),
            mutation: Mutation::Bytes,
            read: |p| read_array(p, Format::Mat),
        },
        400,
    );
}

#[test]
fn mat_v5_compressed() {
    check(
        Target {
            name: "mat_v5_z",
            ext: "mat",
            seeds: mat_seeds(true),
            mutation: Mutation::Bytes,
            read: |p| read_array(p, Format::Mat),
        },
        400,
    );
}

/// A v7.3 MAT file: HDF5 after a 512-byte user block, a uint16 (4, 3, 2) dataset `rect`
/// and a double scalar `width`, each with its `MATLAB_class`.
fn mat_v73_file() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("v73.mat");
    let f = rust_hdf5::H5File::options()
        .userblock(512)
        .create(&p)
        .unwrap();
    let ds = f
        .new_dataset::<u16>()
        .shape([4, 3, 2])
        .create("rect")
        .unwrap();
    ds.write_raw(&(0..24u16).collect::<Vec<_>>()).unwrap();
    ds.new_attr::<rust_hdf5::VarLenUnicode>()
        .shape(())
        .create("MATLAB_class")
        .unwrap()
        .write_string("uint16")
        .unwrap();
    let w = f
        .new_dataset::<f64>()
        .shape([1, 1])
        .create("width")
        .unwrap();
    w.write_raw(&[0.35f64]).unwrap();
    w.new_attr::<rust_hdf5::VarLenUnicode>()
        .shape(())
        .create("MATLAB_class")
        .unwrap()
        .write_string("double")
        .unwrap();
    f.close().unwrap();
    let mut bytes = std::fs::read(&p).unwrap();
    bytes[..19].copy_from_slice(b"MATLAB 7.3 MAT-file");
    bytes
}

#[test]
fn mat_v73() {
    check(
        Target {
            name: "mat_v73",
            ext: "mat",
            seeds: vec![mat_v73_file()],
            mutation: Mutation::Bytes,
            read: |p| read_array(p, Format::Mat),
        },
        200,
    );
}

// ---------------------------------------------------------------- HDF5 arrays

/// A HyperSpy file of one (2, 3, 4) u16 signal with axes; the time axis `axis-2` in ns,
/// uniform or with explicit values.
fn hspy(explicit: bool) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.hspy");
    let f = rust_hdf5::H5File::create(&p).unwrap();
    f.root_group()
        .set_attr_string("file_format", "HyperSpy")
        .unwrap();
    let g = f
        .create_group("Experiments")
        .unwrap()
        .create_group("s")
        .unwrap();
    g.new_dataset::<u16>()
        .shape([2, 3, 4])
        .create("data")
        .unwrap()
        .write_raw(&(0..24u16).collect::<Vec<_>>())
        .unwrap();
    for (i, (name, units)) in [("Y", "um"), ("X", "um"), ("Time", "ns")]
        .iter()
        .enumerate()
    {
        let a = g.create_group(&format!("axis-{i}")).unwrap();
        a.set_attr_string("name", name).unwrap();
        a.set_attr_string("units", units).unwrap();
        if i == 2 && explicit {
            a.new_dataset::<f64>()
                .shape([4])
                .create("axis")
                .unwrap()
                .write_raw(&[1.0, 1.004, 1.01, 1.012])
                .unwrap();
        } else {
            a.set_attr_numeric("scale", &0.004f64).unwrap();
            a.set_attr_numeric("offset", &1.0f64).unwrap();
        }
    }
    f.close().unwrap();
    std::fs::read(&p).unwrap()
}

#[test]
fn hspy_signal() {
    check(
        Target {
            name: "hspy",
            ext: "hspy",
            seeds: vec![hspy(false), hspy(true)],
            mutation: Mutation::Bytes,
            read: |p| read_array(p, Format::Hspy),
        },
        200,
    );
}

/// A plain HDF5 file: a (3, 4, 5) f32 dataset `/data/counts` and its bin width
/// `/data/timebin_width_ps`.
fn plain_h5() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.h5");
    let f = rust_hdf5::H5File::create(&p).unwrap();
    let g = f.create_group("data").unwrap();
    g.new_dataset::<f32>()
        .shape([3, 4, 5])
        .create("counts")
        .unwrap()
        .write_raw(&(0..60).map(|i| i as f32).collect::<Vec<_>>())
        .unwrap();
    g.new_dataset::<f64>()
        .scalar()
        .create("timebin_width_ps")
        .unwrap()
        .write_raw(&[4.0f64])
        .unwrap();
    f.close().unwrap();
    std::fs::read(&p).unwrap()
}

#[test]
fn hdf5_array() {
    check(
        Target {
            name: "hdf5_array",
            ext: "h5",
            seeds: vec![plain_h5()],
            mutation: Mutation::Bytes,
            read: |p| read_array(p, Format::Hdf5Array),
        },
        200,
    );
}

// ---------------------------------------------------------------- HPD-TA TIFF

/// A one-page 16-bit HPD-TA TIFF of 12 x 8 pixels whose ImageDescription holds the HPD-TA
/// header, and whose time table (16 float32 after the image data) covers rows 4..12.
pub fn hpd_tiff() -> Vec<u8> {
    use tiff::encoder::{colortype::Gray16, TiffEncoder};
    let (w, h) = (12u32, 8u32);
    let comment = |offset: u64| {
        format!(
            "[Application],Software=\"HPD-TA\"\r\n[Acquisition],areSource=\"0,4,{w},{h}\"\r\n\
             [Streak camera],Mode=\"Operate\",Time Range=\"2 ns\"\r\n[Scaling],ScalingXType=1,\
             ScalingXScale=1,ScalingXUnit=\"px\",ScalingYType=2,ScalingYUnit=\"ps\",\
             ScalingYScalingFile=\"#{offset:012},16\"\r\n"
        )
    };
    let encode = |text: &str| {
        let mut out = std::io::Cursor::new(Vec::new());
        let mut enc = TiffEncoder::new(&mut out).unwrap();
        let mut image = enc.new_image::<Gray16>(w, h).unwrap();
        image
            .encoder()
            .write_tag(tiff::tags::Tag::ImageDescription, text)
            .unwrap();
        let pixels: Vec<u16> = (0..w * h).map(|i| (i * 37 % 4000) as u16).collect();
        image.write_data(&pixels).unwrap();
        out.into_inner()
    };
    // The table goes at the end; its offset has a fixed width, so the file's length does not
    // depend on it.
    let offset = encode(&comment(0)).len() as u64;
    let mut bytes = encode(&comment(offset));
    assert_eq!(bytes.len() as u64, offset);
    for i in 0..16 {
        bytes.extend((100.0f32 + 2.0 * i as f32).to_le_bytes());
    }
    bytes
}

fn read_hpd_tiff(path: &Path) -> Result<(), String> {
    for transpose in [false, true] {
        let img = femto::formats::read_streak(path, transpose).map_err(s)?;
        assert_eq!(img.data.len(), img.nx * img.nt, "data length");
        if let Some(t) = &img.time_axis_ps {
            assert_eq!(t.len(), img.nt, "time axis length");
        }
    }
    Ok(())
}

#[test]
fn hpd_tiff_target() {
    check(
        Target {
            name: "hpd_tiff",
            ext: "tif",
            seeds: vec![hpd_tiff()],
            mutation: Mutation::Bytes,
            read: read_hpd_tiff,
        },
        300,
    );
}

// ---------------------------------------------------------------- compare's EXR frames

fn exr_frame(w: usize, h: usize) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("f.exr");
    let rgb: Vec<f32> = (0..w * h * 3).map(|i| (i % 17) as f32 * 0.1).collect();
    femto::video::write_exr(&p, &rgb, w, h).unwrap();
    std::fs::read(&p).unwrap()
}

fn read_exr_frame(path: &Path) -> Result<(), String> {
    let (w, h, rgb) = femto::video::read_exr(path).map_err(s)?;
    assert_eq!(rgb.len(), w * h, "pixels of a {w} x {h} frame");
    Ok(())
}

#[test]
fn exr_frame_target() {
    check(
        Target {
            name: "exr_frame",
            ext: "exr",
            seeds: vec![exr_frame(16, 12), exr_frame(5, 3)],
            mutation: Mutation::Bytes,
            read: read_exr_frame,
        },
        300,
    );
}

// ---------------------------------------------------------------- band.toml

const BAND_TOML: &str = r#"rows_start = 4
rows_end = 8
command = ["femto", "simulate", "--scene", "cube", "--size", "16x8", "--rows", "4..8", "--out", "b1"]

[settings]
scene = "cube"
scene_digest = "0123456789abcdef"
nx = 16
ny = 8
nt = 32
dt_ps = 4.0
t0_ps = 3200.0
spp = 1
seed = 7
max_bounces = 4
formats = ["Png16"]
flaws = "Flaws { noise: false }"
marker_spacing_m = 0.05

[peaks]
clean_max = 0.5
noiseless = 0.25

[render]
paths = 128
rays = 512
seconds = 0.01
cpu_seconds = 0.02
"#;

fn read_band(path: &Path) -> Result<(), String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(path, dir.path().join(femto::simulate::band::BAND_FILE)).unwrap();
    let info = femto::simulate::band::BandInfo::load(dir.path()).map_err(s)?;
    assert!(!info.rows().is_empty() && info.rows().end <= info.settings.ny);
    Ok(())
}

#[test]
fn band_toml() {
    check(
        Target {
            name: "band_toml",
            ext: "toml",
            seeds: vec![BAND_TOML.as_bytes().to_vec()],
            mutation: Mutation::Text,
            read: read_band,
        },
        300,
    );
}

// ---------------------------------------------------------------- kept findings

/// Every file kept under `tests/fuzz/cases/<target>/` (what the targets above found, and
/// the reproducers of issue 45) read by its target's reader: `Ok` or a one-line `Err`,
/// never a panic, and no allocation above the fuzzers' bound.
#[test]
fn regression_files_read_without_panic() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz/cases");
    let mut n = 0;
    for entry in std::fs::read_dir(&root).unwrap() {
        let dir = entry.unwrap().path();
        if !dir.is_dir() {
            continue; // the README and the generator of the issue's files
        }
        let target = dir.file_name().unwrap().to_string_lossy().into_owned();
        let read: fn(&Path) -> Result<(), String> = match target.as_str() {
            "npy" => |p| read_array(p, Format::Npy),
            "mat" => |p| read_array(p, Format::Mat),
            "hspy" => |p| read_array(p, Format::Hspy),
            "hdf5_array" => |p| read_array(p, Format::Hdf5Array),
            "hpd_tiff" | "img" => read_hpd_tiff,
            "exr_frame" => read_exr_frame,
            "band_toml" => read_band,
            other => panic!("tests/fuzz/cases/{other}: no reader for this folder"),
        };
        for file in std::fs::read_dir(&dir).unwrap() {
            let file = file.unwrap().path();
            let len = std::fs::metadata(&file).unwrap().len() as usize;
            let (result, peak) = super::with_peak(|| {
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(&file)))
            });
            let result = result.unwrap_or_else(|_| panic!("{}: panicked", file.display()));
            if let Err(e) = &result {
                assert_eq!(e.lines().count(), 1, "{}: {e}", file.display());
            }
            // The issue's reproducers: each refused naming its file, the valid ones read.
            let name = file.file_name().unwrap().to_string_lossy().into_owned();
            if name.starts_with("issue45-") {
                match (&result, name.contains("-valid")) {
                    (Ok(()), true) => {}
                    // (a band's file is read as band.toml of a folder, which it names)
                    (Err(e), false) => assert!(
                        e.contains(&name) || e.contains(femto::simulate::band::BAND_FILE),
                        "{name}: {e}"
                    ),
                    (r, _) => panic!("{name}: {r:?}"),
                }
            }
            assert!(
                peak <= super::alloc_bound(len),
                "{}: one allocation of {peak} bytes",
                file.display()
            );
            n += 1;
        }
    }
    assert!(n > 0, "no regression files under {}", root.display());
}
