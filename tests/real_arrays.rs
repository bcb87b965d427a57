//! Array files as labs save them (`.npy`, `.mat` v5 and v7.3, `.hspy`, plain HDF5) through
//! `femto ingest`: the real files of `../shared/data/real` against numbers an independent
//! reader gave, synthetic files of every kind written here, and bad input (one line, exit
//! 2, nothing written).

#[path = "common/shared.rs"]
mod shared;

use femto::container::{read_cube, read_meta};
use femto::cube::Cube;
use std::path::Path;
use std::process::{Command, Output};

fn femto(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_femto"))
        .args(args)
        .output()
        .expect("femto runs")
}

/// Run `femto ingest INPUT -o OUT ARGS`, assert success, return the cube.
fn ingest(input: &Path, out: &Path, args: &[&str]) -> Cube {
    // --force: these tests read formats, and several write one output path in turn.
    let mut all = vec![
        "ingest",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--force",
    ];
    all.extend_from_slice(args);
    let o = femto(&all);
    assert!(
        o.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    read_cube(out).unwrap()
}

/// Run an ingest that must fail: exit 2, one line on stderr naming `names`, no output.
fn refused(input: &Path, out: &Path, args: &[&str], names: &str) {
    // --force: these tests read formats, and several write one output path in turn.
    let mut all = vec![
        "ingest",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--force",
    ];
    all.extend_from_slice(args);
    let o = femto(&all);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{all:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{all:?}: {err}");
    assert!(err.contains(names), "{all:?}: {err} (expected {names})");
    assert!(!out.exists(), "{all:?} wrote {}", out.display());
}

fn sum(c: &Cube) -> f64 {
    c.data.iter().map(|&v| f64::from(v)).sum()
}

fn at(c: &Cube, y: usize, x: usize, t: usize) -> f32 {
    c.profile(x, y)[t]
}

fn note<'a>(meta: &'a femto::container::CubeMeta, key: &str) -> Option<&'a str> {
    meta.notes
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1.0)
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn lct_data_s_u_mat_reads_as_scipy_indexes_it_and_records_the_confocal_wall() {
    let Some(mat) = shared::file("data/real/lct/data_s_u.mat") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lct.h5");
    // No time axis in the file: asked for in one line, nothing written.
    refused(&mat, &out, &[], "--dt-ps");
    refused(&mat, &out, &["--dt-ps", "4", "--confocal"], "--wall-size-m");
    refused(
        &mat,
        &out,
        &["--dt-ps", "4", "--wall-size-m", "0.7"],
        "--confocal",
    );
    let c = ingest(
        &mat,
        &out,
        &["--dt-ps", "4", "--confocal", "--wall-size-m", "0.7"],
    );
    assert_eq!((c.ny, c.nx, c.nt()), (64, 64, 2048));
    assert_eq!((c.axis.t0_ps, c.axis.dt_ps), (0.0, 4.0));
    // scipy.io.loadmat(f)['rect_data'].astype(float64): sum 53190216, r[10,20,100] = 34,
    // r[63,0,2047] = 1, r[0,63,5] = 1197, maximum 2017 at (0, 52, 0).
    assert!(close(sum(&c), 53_190_216.0), "{}", sum(&c));
    assert_eq!(at(&c, 10, 20, 100), 34.0);
    assert_eq!(at(&c, 63, 0, 2047), 1.0);
    assert_eq!(at(&c, 0, 63, 5), 1197.0);
    assert_eq!(at(&c, 0, 52, 0), 2017.0);
    let meta = read_meta(&out).unwrap();
    assert_eq!(note(&meta, "wall_size_m"), Some("0.7"));
    // The wall: a 0.7 m square of 64 x 64 points, each pixel its own laser point.
    let group = femto::container::read_group(&out, "tal").unwrap();
    let geo = femto::interop::geometry_from_group(&out, &group, 64, 64).unwrap();
    assert_eq!(geo.laser_spot_m, femto::interop::tal::LaserSpot::Confocal);
    let step = 0.7 / 64.0;
    assert!((geo.sensor_grid_m[0][0] - (step / 2.0 - 0.35)).abs() < 1e-12);
    assert!((geo.sensor_grid_m[64 * 64 - 1][1] - (0.35 - step / 2.0)).abs() < 1e-12);
    // Camera time with no device position: unwarp cannot remove the legs, and says so.
    let world = dir.path().join("lct_world.h5");
    let o = femto(&[
        "unwarp",
        out.to_str().unwrap(),
        "-o",
        world.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--device-m") && err.contains("sensor_m"),
        "{err}"
    );
    assert!(!world.exists());
    assert_eq!(note(&meta, "mat.width"), Some("0.35"));
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn hyperspy_streak_image_and_transient_map_keep_their_axes() {
    let (Some(aln), Some(ingan)) = (
        shared::file("data/real/lumispy/AlN_HR_streak_image.hspy"),
        shared::file("data/real/lumispy/InGaN_transient_map.hspy"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("aln.h5");
    let c = ingest(&aln, &out, &[]);
    // h5py: data (217, 220) uint16, axis-0 Time ps (scale 2.4392644399322356, offset -80),
    // axis-1 Wavelength nm (scale 0.008, offset 204.7); sum 50545, a[0,0] = 1,
    // a[216,219] = 1. Time x wavelength: one scanline of 220 pixels.
    assert_eq!((c.ny, c.nx, c.nt()), (1, 220, 217));
    assert!((c.axis.t0_ps + 80.0).abs() < 0.1 * c.axis.dt_ps);
    assert!((c.axis.dt_ps - 2.439_264_439_932_235_6).abs() < 1e-9);
    assert!(close(sum(&c), 50_545.0));
    assert_eq!(at(&c, 0, 0, 0), 1.0);
    assert_eq!(at(&c, 0, 219, 216), 1.0);
    let meta = read_meta(&out).unwrap();
    assert_eq!(note(&meta, "axis.x.name"), Some("Wavelength"));
    assert_eq!(note(&meta, "axis.x.units"), Some("nm"));
    assert_eq!(note(&meta, "axis.x.scale"), Some("0.008"));
    assert_eq!(note(&meta, "axis.x.offset"), Some("204.7"));
    // The file names its time axis: --transpose and a contradicting --dt-ps are refused.
    refused(&aln, &out_new(&dir), &["--transpose"], "--transpose");
    refused(&aln, &out_new(&dir), &["--dt-ps", "3"], "--dt-ps");

    let out = dir.path().join("ingan.h5");
    let c = ingest(&ingan, &out, &[]);
    // h5py: data (30, 30, 525) uint32; axis-2/axis in ns from 2.4 to 4.496 (4 ps bins);
    // sum 10452156, a[3,7,100] = 98, a[29,0,524] = 0, max 535.
    assert_eq!((c.ny, c.nx, c.nt()), (30, 30, 525));
    assert!((c.axis.t0_ps - 2400.0).abs() < 0.1 * 4.0);
    assert!((c.axis.dt_ps - 4.0).abs() < 1e-6);
    assert!((c.axis.bin_start_ps(524) - 4496.0).abs() < 0.1 * 4.0);
    assert!(close(sum(&c), 10_452_156.0));
    assert_eq!(at(&c, 3, 7, 100), 98.0);
    assert_eq!(c.value_range(), Some((0.0, 535.0)));
    let meta = read_meta(&out).unwrap();
    assert_eq!(note(&meta, "axis.y.name"), Some("Y"));
    assert_eq!(note(&meta, "axis.x.units"), Some("nm"));
}

fn out_new(dir: &tempfile::TempDir) -> std::path::PathBuf {
    dir.path().join("never.h5")
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn spad_histogram_takes_its_bin_width_and_masks_the_clipped_bin() {
    let Some(spad) = shared::file("data/real/spad/spad_data_1.hdf5") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("spad.h5");
    // h5py: counts (901, 1) uint16, timebin_width_ps 0.75, n_timebins 901; sum 3568386,
    // max 65535 at bin 103, counts[0] = counts[900] = 15.
    let c = ingest(&spad, &out, &[]);
    assert_eq!((c.ny, c.nx, c.nt()), (1, 1, 901));
    assert_eq!(c.axis.dt_ps, 0.75);
    assert!(close(sum(&c), 3_568_386.0));
    assert_eq!(c.profile(0, 0)[103], 65535.0);
    assert_eq!((c.profile(0, 0)[0], c.profile(0, 0)[900]), (15.0, 15.0));
    assert!(c.mask.is_none());
    let meta = read_meta(&out).unwrap();
    assert!(note(&meta, "ingest.time_axis")
        .unwrap()
        .contains("timebin_width_ps"));
    // --saturation auto: the uint16 maximum; the clipped pixel is masked, its values kept.
    let c = ingest(&spad, &out, &["--saturation", "auto"]);
    assert_eq!(c.mask.as_deref(), Some(&[0u8][..]));
    assert_eq!(c.profile(0, 0)[103], 65535.0);
    // A level above every count masks nothing.
    let c = ingest(&spad, &out, &["--saturation", "70000"]);
    assert_eq!(c.mask.as_deref(), Some(&[1u8][..]));
    refused(&spad, &out_new(&dir), &["--dt-ps", "1"], "--dt-ps");
}

/// A version-1 `.npy` file: `descr`, order, shape, raw values.
fn npy(shape: &[usize], descr: &str, fortran: bool, raw: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let order = if fortran { "True" } else { "False" };
    let mut h = format!("{{'descr': '{descr}', 'fortran_order': {order}, 'shape': {tuple}, }}");
    while !(10 + h.len() + 1).is_multiple_of(64) {
        h.push(' ');
    }
    h.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(h.as_bytes());
    out.extend_from_slice(raw);
    out
}

/// The value of element (i, j, k) of the synthetic arrays.
fn v(i: usize, j: usize, k: usize) -> u8 {
    (50 * i + 10 * j + k) as u8
}

/// The bytes of the synthetic (2, 3, 4) array in C or column-major order, each value
/// written by `put` in its type.
fn raw_of(fortran: bool, put: &dyn Fn(u8, &mut Vec<u8>)) -> Vec<u8> {
    let mut out = Vec::new();
    let mut idx = Vec::new();
    for i in 0..2 {
        for j in 0..3 {
            for k in 0..4 {
                idx.push((i, j, k));
            }
        }
    }
    if fortran {
        idx.sort_by_key(|&(i, j, k)| (k, j, i));
    }
    for (i, j, k) in idx {
        put(v(i, j, k), &mut out);
    }
    out
}

fn check_cube(c: &Cube) {
    assert_eq!((c.ny, c.nx, c.nt()), (2, 3, 4));
    for i in 0..2 {
        for j in 0..3 {
            for k in 0..4 {
                assert_eq!(at(c, i, j, k), f32::from(v(i, j, k)), "({i}, {j}, {k})");
            }
        }
    }
}

#[test]
fn npy_of_every_dtype_order_and_byte_order_is_row_column_bin() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.npy");
    let out = dir.path().join("a.h5");
    type Put = fn(u8, &mut Vec<u8>, bool);
    let kinds: [(&str, Put); 11] = [
        ("u1", |x, o, _| o.push(x)),
        ("i1", |x, o, _| o.push(x as i8 as u8)),
        ("u2", |x, o, b| {
            o.extend(if b {
                u16::from(x).to_be_bytes()
            } else {
                u16::from(x).to_le_bytes()
            })
        }),
        ("i2", |x, o, b| {
            o.extend(if b {
                i16::from(x).to_be_bytes()
            } else {
                i16::from(x).to_le_bytes()
            })
        }),
        ("u4", |x, o, b| {
            o.extend(if b {
                u32::from(x).to_be_bytes()
            } else {
                u32::from(x).to_le_bytes()
            })
        }),
        ("i4", |x, o, b| {
            o.extend(if b {
                i32::from(x).to_be_bytes()
            } else {
                i32::from(x).to_le_bytes()
            })
        }),
        ("u8", |x, o, b| {
            o.extend(if b {
                u64::from(x).to_be_bytes()
            } else {
                u64::from(x).to_le_bytes()
            })
        }),
        ("i8", |x, o, b| {
            o.extend(if b {
                i64::from(x).to_be_bytes()
            } else {
                i64::from(x).to_le_bytes()
            })
        }),
        ("f2", |x, o, b| {
            let h = half::f16::from_f32(f32::from(x));
            o.extend(if b { h.to_be_bytes() } else { h.to_le_bytes() })
        }),
        ("f4", |x, o, b| {
            o.extend(if b {
                f32::from(x).to_be_bytes()
            } else {
                f32::from(x).to_le_bytes()
            })
        }),
        ("f8", |x, o, b| {
            o.extend(if b {
                f64::from(x).to_be_bytes()
            } else {
                f64::from(x).to_le_bytes()
            })
        }),
    ];
    for (code, put) in kinds {
        for big in [false, true] {
            for fortran in [false, true] {
                let order = match (code.ends_with('1'), big) {
                    (true, _) => '|',
                    (false, true) => '>',
                    (false, false) => '<',
                };
                let raw = raw_of(fortran, &|x, o| put(x, o, big));
                std::fs::write(
                    &p,
                    npy(&[2, 3, 4], &format!("{order}{code}"), fortran, &raw),
                )
                .unwrap();
                check_cube(&ingest(&p, &out, &["--dt-ps", "2"]));
            }
        }
    }
    // 2-D: one scanline (x, t), or (t, x) with --transpose.
    let raw: Vec<u8> = (0..6u8).collect();
    std::fs::write(&p, npy(&[2, 3], "|u1", false, &raw)).unwrap();
    let c = ingest(&p, &out, &["--dt-ps", "2"]);
    assert_eq!((c.ny, c.nx, c.nt()), (1, 2, 3));
    assert_eq!(c.profile(1, 0), [3.0, 4.0, 5.0]);
    let c = ingest(&p, &out, &["--dt-ps", "2", "--transpose"]);
    assert_eq!((c.ny, c.nx, c.nt()), (1, 3, 2));
    assert_eq!(c.profile(1, 0), [1.0, 4.0]);
    // Integers above 2^24 are rounded, recorded and warned about.
    let big: Vec<u8> = [16_777_217u32, 1]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    std::fs::write(&p, npy(&[1, 2], "<u4", false, &big)).unwrap();
    let o = femto(&[
        "ingest",
        p.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--dt-ps",
        "1",
        "--force",
    ]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("2^24"));
    let meta = read_meta(&out).unwrap();
    assert!(note(&meta, "ingest.inexact_values")
        .unwrap()
        .starts_with("1 integer"));
}

#[test]
fn mat_v5_plain_compressed_and_v73_keep_matlab_indexing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.h5");
    let raw = raw_of(true, &|x, o| o.extend(u16::from(x).to_le_bytes()));
    let width = 0.35f64.to_le_bytes();
    for compress in [false, true] {
        let p = dir.path().join(format!("v5_{compress}.mat"));
        let bytes = femto::readers::mat::v5_bytes(
            &[
                ("width", &[1, 1], 6, 9, &width),
                ("rect", &[2, 3, 4], 6, 4, &raw),
            ],
            compress,
        );
        std::fs::write(&p, bytes).unwrap();
        let c = ingest(&p, &out, &["--dt-ps", "4"]);
        check_cube(&c);
        assert_eq!(note(&read_meta(&out).unwrap(), "mat.width"), Some("0.35"));
        refused(
            &p,
            &out_new(&dir),
            &["--dt-ps", "4", "--dataset", "nope"],
            "rect",
        );
    }
    // v7.3: HDF5 after a 512-byte user block; HDF5 dims are MATLAB's reversed.
    let p = dir.path().join("v73.mat");
    {
        let f = rust_hdf5::H5File::options()
            .userblock(512)
            .create(&p)
            .unwrap();
        let ds = f
            .new_dataset::<u16>()
            .shape([4, 3, 2])
            .create("rect")
            .unwrap();
        let vals: Vec<u16> = raw
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        ds.write_raw(&vals).unwrap();
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
    }
    let mut bytes = std::fs::read(&p).unwrap();
    bytes[..19].copy_from_slice(b"MATLAB 7.3 MAT-file");
    std::fs::write(&p, bytes).unwrap();
    check_cube(&ingest(&p, &out, &["--dt-ps", "4"]));
    assert_eq!(note(&read_meta(&out).unwrap(), "mat.width"), Some("0.35"));
}

/// A HyperSpy file of one signal (2, 3, 4) u16 with the time axis `time` (attributes or an
/// explicit array) as axis-2.
fn hspy(p: &Path, scale: f64, values: Option<&[f64]>) {
    let f = rust_hdf5::H5File::create(p).unwrap();
    f.root_group()
        .set_attr_string("file_format", "HyperSpy")
        .unwrap();
    let g = f
        .create_group("Experiments")
        .unwrap()
        .create_group("s")
        .unwrap();
    let raw = raw_of(false, &|x, o| o.extend(u16::from(x).to_le_bytes()));
    let vals: Vec<u16> = raw
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    g.new_dataset::<u16>()
        .shape([2, 3, 4])
        .create("data")
        .unwrap()
        .write_raw(&vals)
        .unwrap();
    for (i, (name, units)) in [("Y", "um"), ("X", "um"), ("Time", "ns")]
        .iter()
        .enumerate()
    {
        let a = g.create_group(&format!("axis-{i}")).unwrap();
        a.set_attr_string("name", name).unwrap();
        a.set_attr_string("units", units).unwrap();
        match (i, values) {
            (2, Some(v)) => {
                let d = a
                    .new_dataset::<f64>()
                    .shape([v.len()])
                    .create("axis")
                    .unwrap();
                d.write_raw(v).unwrap();
            }
            _ => {
                a.set_attr_numeric("scale", &if i == 2 { scale } else { 0.5 })
                    .unwrap();
                a.set_attr_numeric("offset", &1.0f64).unwrap();
            }
        }
    }
    f.close().unwrap();
}

#[test]
fn hspy_axes_uniform_explicit_and_non_uniform_and_absurd_ones() {
    let dir = tempfile::tempdir().unwrap();
    let (p, out) = (dir.path().join("s.hspy"), dir.path().join("s.h5"));
    hspy(&p, 0.004, None);
    let c = ingest(&p, &out, &[]);
    check_cube(&c);
    assert!((c.axis.dt_ps - 4.0).abs() < 1e-9 && (c.axis.t0_ps - 1000.0).abs() < 1e-9);
    // An explicit uniform axis becomes the same axis.
    hspy(&p, 0.0, Some(&[1.0, 1.004, 1.008, 1.012]));
    let c = ingest(&p, &out, &[]);
    check_cube(&c);
    assert!((c.axis.dt_ps - 4.0).abs() < 1e-9);
    // A non-uniform one is resampled onto its span, each pixel's integral kept.
    hspy(&p, 0.0, Some(&[1.0, 1.002, 1.008, 1.012]));
    let c = ingest(&p, &out, &[]);
    assert_eq!(c.nt(), 4);
    let total: f64 = (0..4).map(|k| f64::from(at(&c, 1, 2, k))).sum();
    let want: f64 = (0..4).map(|k| f64::from(v(1, 2, k))).sum();
    assert!((total - want).abs() < 1e-4, "{total} vs {want}");
    assert!(note(&read_meta(&out).unwrap(), "ingest.time_axis")
        .unwrap()
        .contains("resampled"));
    for bad in [f64::NAN, 0.0, -0.004, 1e-300] {
        hspy(&p, bad, None);
        refused(&p, &out_new(&dir), &[], "axis-2");
    }
    hspy(&p, 0.0, Some(&[1.0, f64::NAN, 1.008, 1.012]));
    refused(&p, &out_new(&dir), &[], "axis-2");
}

#[test]
fn truncated_and_corrupt_files_are_one_line_exit_2_and_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = out_new(&dir);
    // .npy: truncated values, bad magic, bad dtype.
    let p = dir.path().join("t.npy");
    let good = npy(&[2, 3, 4], "<u2", false, &[0; 48]);
    std::fs::write(&p, &good[..good.len() - 3]).unwrap();
    refused(&p, &out, &["--dt-ps", "1"], "t.npy");
    std::fs::write(&p, [b"\x93NUMPX".as_slice(), &good[6..]].concat()).unwrap();
    refused(&p, &out, &["--dt-ps", "1"], "npy header");
    std::fs::write(&p, npy(&[2], "<c8", false, &[0; 16])).unwrap();
    refused(&p, &out, &["--dt-ps", "1"], "dtype");
    // .mat: truncated, corrupt header.
    let p = dir.path().join("t.mat");
    let raw = [0u8; 48];
    let m = femto::readers::mat::v5_bytes(&[("a", &[2, 3, 4], 11, 4, &raw)], true);
    std::fs::write(&p, &m[..m.len() - 20]).unwrap();
    refused(&p, &out, &["--dt-ps", "1"], "t.mat");
    std::fs::write(&p, [b"MATLAB 4.0".as_slice(), &m[10..]].concat()).unwrap();
    refused(&p, &out, &["--dt-ps", "1"], "mat header");
    // .hspy: truncated.
    let p = dir.path().join("t.hspy");
    hspy(&p, 0.004, None);
    let b = std::fs::read(&p).unwrap();
    std::fs::write(&p, &b[..b.len() / 2]).unwrap();
    refused(&p, &out, &[], "t.hspy");
    // Plain HDF5: an absurd recorded bin width; a file cut short.
    let p = dir.path().join("t.h5");
    for width in [0.0, f64::NAN, -1.0, 1e-300] {
        let f = rust_hdf5::H5File::create(&p).unwrap();
        f.new_dataset::<u16>()
            .shape([5, 1])
            .create("counts")
            .unwrap()
            .write_raw(&[1u16; 5])
            .unwrap();
        f.new_dataset::<f64>()
            .shape([1usize; 0])
            .create("timebin_width_ps")
            .unwrap()
            .write_raw(&[width])
            .unwrap();
        f.close().unwrap();
        refused(&p, &out, &[], "timebin_width_ps");
    }
    let b = std::fs::read(&p).unwrap();
    std::fs::write(&p, &b[..b.len() - 40]).unwrap();
    refused(&p, &out, &[], "t.h5");
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn info_describes_array_files_and_what_ingest_needs() {
    let (Some(mat), Some(spad)) = (
        shared::file("data/real/lct/data_s_u.mat"),
        shared::file("data/real/spad/spad_data_1.hdf5"),
    ) else {
        return;
    };
    let o = femto(&["info", mat.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("variable rect_data"), "{text}");
    assert!(text.contains("[64, 64, 2048] uint16"), "{text}");
    assert!(text.contains("--dt-ps"), "{text}");
    let o = femto(&["info", spad.to_str().unwrap(), "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["kind"], "array");
    assert_eq!(j["nt"], 901);
    assert_eq!(j["source"], "dataset /counts");
}

/// The real-data jitter check (tools/sparse_jitter_check.py does the same with numpy):
/// the real confocal capture `data_s_u.mat` written as 64 PNG16 scanline files (scanline y =
/// rect_data(y, :, :), 64 columns by 2048 time rows), scanline 20 recorded 3 bins late and
/// scanline 41 two bins late (the rows rolled in are zero), ingested with default flags: both
/// shifts come back within a quarter of a bin, and no other scanline moves by more than its
/// standard error.
#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn lct_capture_as_png16_scanlines_gets_two_trigger_glitches_back() {
    let Some(mat) = shared::file("data/real/lct/data_s_u.mat") else {
        return;
    };
    let c = femto::readers::open(&mat, femto::readers::Format::Mat, &Default::default()).unwrap();
    let (nx, ny, nt) = (c.nx, c.ny, c.nt);
    let glitches = [(20usize, 3usize), (41, 2)];
    let dir = tempfile::tempdir().unwrap();
    for y in 0..ny {
        let shift = glitches.iter().find(|g| g.0 == y).map_or(0, |g| g.1);
        let mut img = vec![0.0f32; nt * nx];
        for x in 0..nx {
            for t in shift..nt {
                img[t * nx + x] = c.samples[(y * nx + x) * nt + t - shift];
            }
        }
        let streak = femto::formats::StreakImage::new(nx, nt, img);
        let path = dir.path().join(format!("scan_{y:03}.png"));
        femto::formats::raster::write_png16(&path, &streak, 1.0).unwrap();
    }
    let out = dir.path().join("cube.h5");
    let pattern = dir.path().join("scan_*.png");
    let o = femto(&[
        "ingest",
        pattern.to_str().unwrap(),
        "--dt-ps",
        "4",
        "--t0-ps",
        "0",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.contains("jitter: 2 of 64 scanlines shifted"),
        "{stdout}"
    );
    let meta = read_meta(&out).unwrap();
    let shifts: Vec<f64> =
        serde_json::from_str(note(&meta, "ingest.jitter_shifts_ps").unwrap()).unwrap();
    let errors: Vec<Option<f64>> =
        serde_json::from_str(note(&meta, "ingest.jitter_std_errors_ps").unwrap()).unwrap();
    for y in 0..ny {
        match glitches.iter().find(|g| g.0 == y) {
            Some(&(_, k)) => {
                let want = 4.0 * k as f64;
                assert!(
                    (shifts[y] - want).abs() < 0.25 * 4.0,
                    "scanline {y}: {} ps, want {want}",
                    shifts[y]
                );
            }
            None => {
                let se = errors[y].expect("every scanline estimated");
                assert!(shifts[y].abs() <= se, "scanline {y}: {} +- {se}", shifts[y]);
            }
        }
    }
}

/// The real confocal capture rendered with render's default flags (the capture's own view):
/// ingested with its wall (`--confocal --wall-size-m 0.7`) on the world clock (its time
/// starts at the wall), the frames after the direct return show the hidden objects' echoes:
/// light that arrives 0.3 to 3 ns after the wall's own return, well above the black level.
#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn lct_capture_renders_its_echoes_with_default_flags() {
    let Some(mat) = shared::file("data/real/lct/data_s_u.mat") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let cube = dir.path().join("lct.h5");
    ingest(
        &mat,
        &cube,
        &[
            "--dt-ps",
            "4",
            "--confocal",
            "--wall-size-m",
            "0.7",
            "--clock",
            "world",
        ],
    );
    let frames = dir.path().join("frames");
    let o = femto(&[
        "render",
        "--cube",
        cube.to_str().unwrap(),
        "--capture-view",
        "--out",
        frames.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("entirely black"), "{stderr}");
    // Mean display level of each frame (the brightest channel: 670 nm light is red); the
    // default sweep runs over the cube's 8192 ps.
    let levels: Vec<f64> = (0..100)
        .map(|k| {
            let png = image::open(frames.join(format!("frame_{k:05}.png")))
                .unwrap()
                .to_rgb8();
            let n = png.pixels().len() as f64;
            png.pixels()
                .map(|p| f64::from(*p.0.iter().max().unwrap()))
                .sum::<f64>()
                / n
        })
        .collect();
    eprintln!("mean level per frame: {levels:.1?}");
    // The direct return, then a dark gap, then the echoes: the level falls below a quarter of
    // the direct return's and rises again to a visible second peak.
    let (peak_k, peak) = levels
        .iter()
        .copied()
        .enumerate()
        .fold((0, 0.0), |a, (k, l)| if l > a.1 { (k, l) } else { a });
    let gap = (peak_k..100)
        .find(|&k| levels[k] < 0.25 * peak)
        .expect("the direct return fades");
    let (echo_k, echo) =
        (gap..100).fold(
            (gap, 0.0),
            |a, k| {
                if levels[k] > a.1 {
                    (k, levels[k])
                } else {
                    a
                }
            },
        );
    let floor = levels[gap..echo_k]
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    assert!(
        echo > 12.0 && echo > 2.0 * floor,
        "no echo after frame {gap}: {levels:.1?}"
    );
}

/// A plain HDF5 file whose only dataset is 3-D and records no time axis could be streak
/// images `(ny, nt, nx)` or an x-y-t cube `(ny, nx, nt)`: ingest asks which in one line and
/// writes nothing, `femto info` says so, and each flag reads it its own way.
#[test]
fn a_bare_3d_hdf5_dataset_asks_for_its_layout() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("stack.h5");
    let f = rust_hdf5::H5File::create(&p).unwrap();
    let values: Vec<f32> = (0..3 * 5 * 4).map(|v| v as f32).collect();
    let ds = f
        .new_dataset::<f32>()
        .shape([3, 5, 4])
        .create("images")
        .unwrap();
    ds.write_raw(&values).unwrap();
    f.close().unwrap();
    let out = dir.path().join("c.h5");
    refused(&p, &out, &["--dt-ps", "1"], "--dataset images");
    let o = femto(&["info", p.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("--from array"));
    // Streak images: 3 scanlines of 4 columns by 5 bins.
    let c = ingest(
        &p,
        &out,
        &["--dataset", "images", "--dt-ps", "1", "--t0-ps", "0"],
    );
    assert_eq!((c.ny, c.nx, c.nt()), (3, 4, 5));
    assert_eq!(at(&c, 1, 2, 3), (20 + 3 * 4 + 2) as f32);
    std::fs::remove_file(&out).unwrap();
    // An x-y-t cube: 3 rows of 5 columns by 4 bins.
    let c = ingest(&p, &out, &["--from", "array", "--dt-ps", "1"]);
    assert_eq!((c.ny, c.nx, c.nt()), (3, 5, 4));
    assert_eq!(at(&c, 1, 2, 3), (20 + 2 * 4 + 3) as f32);
}
