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
    let mut all = vec![
        "ingest",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
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
    let mut all = vec![
        "ingest",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
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
    assert_eq!(note(&meta, "confocal"), Some("true"));
    assert_eq!(note(&meta, "wall_size_m"), Some("0.7"));
    assert_eq!(note(&meta, "mat.width"), Some("0.35"));
}

#[test]
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
