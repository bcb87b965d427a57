//! Fault cases of issue 45: the decoders added since issue 16 (MATLAB v5 and v7.3, `.npy`,
//! HPD-TA `.img` and TIFF tables, EXR frames) and the side paths (`compare`, MP4 sizes,
//! registration ranges, y-tal, `merge`, `encode`). Each reproducer of the report is built
//! here by a small generator and run through the binary as a user would; each must give
//! exit 2 (not an abort, 134, nor a panic, 101), one line on stderr naming the file and the
//! value, and leave its folder as it was. The memory cases run under `ulimit -v 4000000`,
//! as the report's runs did, so the refusal comes from the address-space limit itself.
//! (`femto view`'s lying client is in `tests/view/lying_client.rs`.)

use super::{case, cli, render_args};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant, SystemTime};

/// The address-space limit of the report's runs, kB (`ulimit -v`).
const ULIMIT_KB: u64 = 4_000_000;

/// Each file under `dir` with its length and modification time: what a refused command
/// must leave as it was, without reading the 3 GB sparse file's contents.
fn listing(dir: &Path) -> BTreeMap<PathBuf, (u64, SystemTime)> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let entry = entry.unwrap();
            let meta = entry.metadata().unwrap();
            if meta.is_dir() {
                stack.push(entry.path());
            } else {
                let rel = entry.path().strip_prefix(dir).unwrap().to_path_buf();
                out.insert(rel, (meta.len(), meta.modified().unwrap()));
            }
        }
    }
    out
}

/// Run `femto args...` in `dir` under `ulimit -v` [`ULIMIT_KB`] and require a refusal:
/// exit 2, one line containing each of `names`, no file added, removed or changed, and
/// within `within`. Returns the line.
fn refused_under_ulimit(dir: &Path, args: &[&str], names: &[&str], within: Duration) -> String {
    let before = listing(dir);
    let started = Instant::now();
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {ULIMIT_KB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_femto"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("sh runs femto");
    let took = started.elapsed();
    let shown = format!("femto {}", args.join(" "));
    let err = String::from_utf8_lossy(&out.stderr).trim_end().to_string();
    assert_eq!(
        out.status.code(),
        Some(2),
        "{shown}: {:?}: {err}",
        out.status
    );
    assert_eq!(err.lines().count(), 1, "{shown}: one line: {err}");
    for name in names {
        assert!(
            err.contains(name),
            "{shown}: the message names {name}: {err}"
        );
    }
    assert_eq!(
        listing(dir),
        before,
        "{shown}: refused but changed the folder"
    );
    assert!(took < within, "{shown}: refused after {took:?}");
    eprintln!("{shown}: {took:.2?}: {err}");
    err
}

/// Case 1: a compressed MATLAB v5 variable of `dims` uint8 values, all zero, declared
/// truthfully (the zlib stream inflates to exactly the element it declares). The file is
/// about a thousandth of the values' size.
fn mat_v5_bomb(path: &Path, name: &str, dims: [usize; 3]) {
    let n: usize = dims.iter().product();
    let element = |ty: u32, len: usize| [ty.to_le_bytes(), (len as u32).to_le_bytes()].concat();
    let mut body = Vec::new();
    body.extend(element(6, 8)); // miUINT32 array flags: class 9, uint8
    body.extend([9, 0, 0, 0, 0, 0, 0, 0]);
    body.extend(element(5, 12)); // miINT32 dimensions
    for d in dims {
        body.extend((d as i32).to_le_bytes());
    }
    body.extend([0; 4]);
    let mut padded_name = name.as_bytes().to_vec();
    padded_name.resize(name.len().next_multiple_of(8), 0);
    body.extend(element(1, name.len())); // miINT8 name
    body.extend(padded_name);
    body.extend(element(2, n)); // miUINT8 values
    let matrix_len = body.len() + n;
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(&element(14, matrix_len)).unwrap();
    z.write_all(&body).unwrap();
    let zeros = vec![0u8; 1 << 20];
    let mut left = n;
    while left > 0 {
        let k = left.min(zeros.len());
        z.write_all(&zeros[..k]).unwrap();
        left -= k;
    }
    let compressed = z.finish().unwrap();
    let mut header = b"MATLAB 5.0 MAT-file, written by femto's fault tests".to_vec();
    header.resize(116, b' ');
    header.extend([0; 8]);
    header.extend(0x0100u16.to_le_bytes());
    header.extend(b"IM");
    let mut f = std::fs::File::create(path).unwrap();
    f.write_all(&header).unwrap();
    f.write_all(&element(15, compressed.len())).unwrap();
    f.write_all(&compressed).unwrap();
}

#[test]
fn a_compressed_matlab_bomb_is_refused_before_it_is_inflated() {
    // 1.2 GB of uint8 declared truthfully: decoded to float32 it asked for 4.8 GB and
    // aborted (SIGABRT) under ulimit -v 4000000.
    let dir = case(&[]);
    let p = dir.path().join("bomb.mat");
    mat_v5_bomb(&p, "bomb", [1000, 1000, 1200]);
    let size = std::fs::metadata(&p).unwrap().len();
    assert!(size < 2_000_000, "the bomb is small on disk: {size} bytes");
    let names = ["bomb.mat", "1000 x 1000 x 1200 uint8"];
    let fast = Duration::from_secs(10);
    refused_under_ulimit(
        dir.path(),
        &["ingest", "bomb.mat", "-o", "c.h5"],
        &names,
        fast,
    );
    refused_under_ulimit(dir.path(), &["info", "bomb.mat"], &names, fast);
}

/// A `.npy` file of `shape` and `descr` whose values are a hole of the file system (a
/// sparse file of the right length).
fn sparse_npy(path: &Path, shape: &str, descr: &str, data_bytes: u64) {
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    while !(10 + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    let mut f = std::fs::File::create(path).unwrap();
    f.write_all(b"\x93NUMPY\x01\x00").unwrap();
    f.write_all(&(header.len() as u16).to_le_bytes()).unwrap();
    f.write_all(header.as_bytes()).unwrap();
    f.set_len(10 + header.len() as u64 + data_bytes).unwrap();
}

#[test]
fn a_3_gb_npy_is_refused_before_it_is_read() {
    // Read whole before any check: "memory allocation of 3000000000 bytes failed", SIGABRT.
    let dir = case(&[]);
    sparse_npy(
        &dir.path().join("big.npy"),
        "(3000000000,)",
        "|u1",
        3_000_000_000,
    );
    sparse_npy(
        &dir.path().join("big3d.npy"),
        "(1000, 1000, 750)",
        "<f4",
        3_000_000_000,
    );
    let fast = Duration::from_secs(10);
    for (file, value) in [
        ("big.npy", "3000000000 uint8"),
        ("big3d.npy", "1000 x 1000 x 750 float32"),
    ] {
        let names = [file, value];
        refused_under_ulimit(dir.path(), &["ingest", file, "-o", "c.h5"], &names, fast);
        refused_under_ulimit(dir.path(), &["info", file], &names, fast);
    }
}

/// An HPD-TA `.img` file of `w` x `h` 16-bit pixels, with `comment`, its pixels, then
/// `table` float32 values.
fn hpd_img(comment: &str, w: usize, h: usize, table: &[f32]) -> Vec<u8> {
    let mut out = b"IM".to_vec();
    for v in [comment.len() as i16, w as i16, h as i16, 0, 0, 2] {
        out.extend(v.to_le_bytes());
    }
    out.extend(0i32.to_le_bytes()); // number of images
    out.extend([0u8; 4]); // additional channels, channel number
    out.resize(64, 0);
    out.extend(comment.as_bytes());
    for i in 0..w * h {
        out.extend(((i % 4000) as u16).to_le_bytes());
    }
    for t in table {
        out.extend(t.to_le_bytes());
    }
    out
}

/// The comment of an HPD-TA image whose Y (time) axis is the table of `count` entries at
/// `offset` (written with 12 digits, so that the comment's length does not depend on it),
/// of which `areSource` says the image holds `y..y + h`.
fn hpd_comment(offset: u64, count: &str, y: &str, w: usize, h: usize) -> String {
    format!(
        "[Application],Software=\"HPD-TA\"\r\n[Acquisition],areSource=\"0,{y},{w},{h}\"\r\n\
         [Streak camera],Mode=\"Operate\"\r\n[Scaling],ScalingXType=1,ScalingXScale=1,\
         ScalingXUnit=\"px\",ScalingYType=2,ScalingYUnit=\"ps\",\
         ScalingYScalingFile=\"#{offset:012},{count}\"\r\n"
    )
}

/// The same image as a one-page 16-bit TIFF with the comment in its ImageDescription.
fn hpd_tiff(comment: &str, w: usize, h: usize) -> Vec<u8> {
    use tiff::encoder::{colortype::Gray16, TiffEncoder};
    let mut out = std::io::Cursor::new(Vec::new());
    let mut enc = TiffEncoder::new(&mut out).unwrap();
    let mut image = enc.new_image::<Gray16>(w as u32, h as u32).unwrap();
    image
        .encoder()
        .write_tag(tiff::tags::Tag::ImageDescription, comment)
        .unwrap();
    let pixels: Vec<u16> = (0..w * h).map(|i| (i % 4000) as u16).collect();
    image.write_data(&pixels).unwrap();
    out.into_inner()
}

#[test]
fn hpd_ta_table_offsets_and_counts_near_2_pow_64_are_refused() {
    // areSource's y offset of 2^64 - 1 wrapped `offset + size` and panicked (exit 101) in
    // ingest and info; a table count of 2^62 wrapped past the end-of-file check.
    let (w, h) = (16usize, 8usize);
    let table: Vec<f32> = (0..h + 8).map(|i| 100.0 + 2.0 * i as f32).collect();
    let table_at = |comment: &str| (64 + comment.len() + 2 * w * h) as u64;
    let dir = case(&[]);
    let d = dir.path();
    let fast = Duration::from_secs(10);
    // (table count, areSource y offset, the value the message must name)
    let cases = [
        ("16", "18446744073709551615", "18446744073709551615"),
        ("4611686018427387904", "0", "4611686018427387904"),
        ("18446744073709551615", "0", "18446744073709551615"),
    ];
    for (count, y, value) in cases {
        let comment = hpd_comment(table_at(&hpd_comment(0, count, y, w, h)), count, y, w, h);
        std::fs::write(d.join("scan.img"), hpd_img(&comment, w, h, &table)).unwrap();
        std::fs::write(d.join("scan.tif"), hpd_tiff(&comment, w, h)).unwrap();
        for file in ["scan.img", "scan.tif"] {
            let names = [file, value];
            refused_under_ulimit(d, &["ingest", file, "-o", "c.h5"], &names, fast);
            refused_under_ulimit(d, &["info", file], &names, fast);
        }
    }
    // The same image with a table the file holds reads (the generator makes a valid file).
    let comment = hpd_comment(table_at(&hpd_comment(0, "16", "4", w, h)), "16", "4", w, h);
    std::fs::write(d.join("good.img"), hpd_img(&comment, w, h, &table)).unwrap();
    let img = femto::formats::read_streak(&d.join("good.img"), false).unwrap();
    let t = img.time_axis_ps.expect("a time axis from the table");
    assert_eq!(
        (t[0], t[h - 1]),
        (108.0, 122.0),
        "entries 4..12 of the table"
    );
}

#[test]
fn a_matlab_matrix_of_2_pow_62_values_without_values_is_refused() {
    // 2^62 x 4 bytes wrapped to 0 = the 0 bytes stored: ingest failed naming its own
    // temporary file, info exited 0 describing the impossible cube.
    let dir = case(&[]);
    let dims = [2097152usize, 2097152, 1048576];
    let bytes = femto::readers::mat::v5_bytes(&[("huge", &dims, 7, 7, &[])], false);
    std::fs::write(dir.path().join("huge.mat"), bytes).unwrap();
    let names = ["huge.mat", "2097152, 2097152, 1048576"];
    let fast = Duration::from_secs(10);
    let err = refused_under_ulimit(
        dir.path(),
        &["ingest", "huge.mat", "-o", "c.h5"],
        &names,
        fast,
    );
    assert!(
        !err.contains(".tmp"),
        "names the input, not a temporary file: {err}"
    );
    refused_under_ulimit(dir.path(), &["info", "huge.mat"], &names, fast);
    // Compressed, the same.
    let bytes = femto::readers::mat::v5_bytes(&[("huge", &dims, 7, 7, &[])], true);
    std::fs::write(dir.path().join("huge.mat"), bytes).unwrap();
    refused_under_ulimit(dir.path(), &["info", "huge.mat"], &names, fast);
}

/// An EXR frame of `w` x `h` RGB pixels whose data window then claims `claim_w` x
/// `claim_h` (its header edited; the blocks are left as written).
fn exr_claiming(w: usize, h: usize, claim: Option<(i32, i32)>) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("f.exr");
    let rgb = vec![0.25f32; w * h * 3];
    femto::video::write_exr(&p, &rgb, w, h).unwrap();
    let mut bytes = std::fs::read(&p).unwrap();
    if let Some((cw, ch)) = claim {
        let key = b"dataWindow\0box2i\0";
        let at = bytes
            .windows(key.len())
            .position(|k| k == key)
            .expect("a data window")
            + key.len()
            + 4; // the attribute's size
        for (k, v) in [0i32, 0, cw - 1, ch - 1].into_iter().enumerate() {
            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    bytes
}

#[test]
fn compare_refuses_a_damaged_exr_frame_as_a_read_in_one_line() {
    let dir = case(&[]);
    let d = dir.path();
    for sub in ["t", "r"] {
        std::fs::create_dir(d.join(sub)).unwrap();
    }
    std::fs::write(d.join("r/frame_00000.exr"), exr_claiming(8, 6, None)).unwrap();
    // Case 6: a data window of 16777216 x 1048576 pixels asked 211 TB and aborted.
    std::fs::write(
        d.join("t/frame_00000.exr"),
        exr_claiming(8, 6, Some((16_777_216, 1_048_576))),
    )
    .unwrap();
    let args = ["compare", "--truth", "t", "--render", "r"];
    let fast = Duration::from_secs(10);
    refused_under_ulimit(d, &args, &["t/frame_00000.exr", "16777216 x 1048576"], fast);
    // Case 7: a truth frame that is not an EXR was reported as "cannot write".
    std::fs::write(d.join("t/frame_00000.exr"), b"not an EXR file").unwrap();
    let err = refused_under_ulimit(d, &args, &["cannot read t/frame_00000.exr"], fast);
    assert!(!err.contains("write"), "{err}");
}

#[test]
fn an_mp4_under_16_pixels_is_refused_naming_the_size_and_the_limit() {
    // OpenH264's raw "Native:5 ... Backtraces enabled." before.
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    let d = dir.path();
    let args = render_args(
        "cube.calibration.toml",
        &[
            "--capture-view",
            "--frames",
            "0..2",
            "--size",
            "16x12",
            "--out",
            "v.mp4",
        ],
    );
    let names = ["16x12", "16x16"];
    refused_under_ulimit(d, &args, &names, Duration::from_secs(20));
    std::fs::create_dir(d.join("frames")).unwrap();
    for k in 0..2 {
        let name = femto::video::sequence_file_name(k, femto::video::VideoFormat::PngSequence);
        femto::video::write_png(&d.join("frames").join(name), &[90u8; 16 * 12 * 3], 16, 12)
            .unwrap();
    }
    refused_under_ulimit(
        d,
        &["encode", "frames", "--out", "v.mp4"],
        &names,
        Duration::from_secs(10),
    );
}

#[test]
fn encode_refuses_a_frame_name_it_cannot_order() {
    // A frame named with a 23-digit number was silently skipped.
    let dir = case(&[]);
    let d = dir.path();
    std::fs::create_dir(d.join("frames")).unwrap();
    for name in [
        "frame_00000.png",
        "frame_00001.png",
        "frame_12345678901234567890123.png",
    ] {
        femto::video::write_png(&d.join("frames").join(name), &[90u8; 16 * 16 * 3], 16, 16)
            .unwrap();
    }
    refused_under_ulimit(
        d,
        &["encode", "frames", "--out", "v.gif"],
        &[
            "frame_12345678901234567890123.png",
            "12345678901234567890123",
        ],
        Duration::from_secs(10),
    );
}

#[test]
fn a_registration_distance_out_of_range_is_refused_by_unwarp() {
    // dist_m of 1e12 m was accepted: unwarp exited 0 and quietly masked the pixel.
    let dir = case(&["cube.h5"]);
    let cube = dir.path().join("cube.h5");
    let mut group = femto::container::read_group(&cube, "registration").unwrap();
    let (_, shape, data) = group
        .datasets
        .iter_mut()
        .find(|(n, _, _)| n == "dist_m")
        .expect("a dist_m dataset");
    let femto::container::DataBuf::F32(v) = data else {
        panic!("dist_m is f32")
    };
    let nx = shape[1];
    v[3 * nx + 5] = 1e12;
    femto::container::write_groups(&cube, &[("registration", group)]).unwrap();
    refused_under_ulimit(
        dir.path(),
        &["unwarp", "cube.h5", "--out", "world.h5"],
        &["cube.h5", "dist_m", "pixel (5, 3)", "999999995904"],
        Duration::from_secs(20),
    );
}

#[test]
fn a_ytal_capture_with_no_known_sensor_point_is_refused() {
    // A sensor grid of NaN at every point was ingested (exit 0) and exported again.
    let dir = case(&["cube.h5"]);
    let d = dir.path();
    let run = cli::femto_in(
        Some(d),
        &["export", "--to", "tal", "cube.h5", "-o", "t.hdf5"],
    );
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let mut cap = femto::interop::read_tal(&d.join("t.hdf5")).unwrap();
    std::fs::remove_file(d.join("t.hdf5")).unwrap();
    for p in &mut cap.sensor_grid_xyz_m {
        *p = [f64::NAN; 3];
    }
    femto::interop::write_tal(&d.join("blind.hdf5"), &cap).unwrap();
    let names = ["blind.hdf5", "sensor_grid_xyz", "known sensor point"];
    let fast = Duration::from_secs(10);
    refused_under_ulimit(d, &["ingest", "blind.hdf5", "-o", "c.h5"], &names, fast);
    refused_under_ulimit(d, &["info", "blind.hdf5"], &names, fast);
}

#[test]
fn merge_refuses_a_truth_file_swapped_between_bands() {
    // A truth file swapped between two bands of as many rows was merged: duplicated rows.
    let dir = case(&[]);
    let d = dir.path();
    for (rows, out) in [("0..4", "b0"), ("4..8", "b1")] {
        cli::FemtoCmd::new()
            .current_dir(d)
            .args([
                "simulate", "--scene", "cube", "--size", "16x8", "--nt", "32", "--spp", "1",
                "--rows", rows, "--out", out,
            ])
            .ok();
    }
    let (a, b) = (d.join("b0/truth_camera.h5"), d.join("b1/truth_camera.h5"));
    let tmp = d.join("swap.h5");
    std::fs::rename(&a, &tmp).unwrap();
    std::fs::rename(&b, &a).unwrap();
    std::fs::rename(&tmp, &b).unwrap();
    refused_under_ulimit(
        d,
        &["merge", "b0", "b1", "--out", "cap"],
        &["b0/truth_camera.h5", "rows 4..8", "rows 0..4"],
        Duration::from_secs(20),
    );
}
