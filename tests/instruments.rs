//! Files as instruments write them, through `femto ingest` and `femto info` (issue 44):
//! PicoQuant PTU records, Delmic SPARC HDF5, time-first MATLAB scans, `.npz` archives, and
//! the refusals (an ambiguous layout, a picture, a format femto does not read: one line,
//! exit 2, nothing written).
//!
//! Synthetic PTU files are written here from PicoQuant's record layouts (the expected
//! histogram is the one the records were made from, not femto's); the real files of
//! `../shared/data/real` are checked against the numbers `ptufile` 2026.2.6, rosettasciio
//! 0.15.0 and h5py 3.16 gave for them (skipped when the folder is absent, a failure under
//! `CI=true`). `tools/interop/instruments.py` makes the same comparisons live.

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

fn ingest(input: &Path, out: &Path, args: &[&str]) -> Cube {
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

/// An ingest that must fail: exit 2, one line naming `names`, nothing written.
fn refused(input: &Path, out: &Path, args: &[&str], names: &[&str]) -> String {
    let mut all = vec![
        "ingest",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    let o = femto(&all);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{all:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{all:?}: {err}");
    for n in names {
        assert!(err.contains(n), "{all:?}: {err} (expected {n})");
    }
    assert!(!out.exists(), "{all:?} wrote {}", out.display());
    err
}

fn info(args: &[&str]) -> String {
    let mut all = vec!["info"];
    all.extend_from_slice(args);
    let o = femto(&all);
    assert!(
        o.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).to_string()
}

fn note(out: &Path, key: &str) -> Option<String> {
    read_meta(out)
        .unwrap()
        .notes
        .into_iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v)
}

fn sum(c: &Cube) -> f64 {
    c.data.iter().map(|&v| f64::from(v)).sum()
}

fn at(c: &Cube, y: usize, x: usize, t: usize) -> f32 {
    c.profile(x, y)[t]
}

/// The time profile summed over pixels, and its peak bin.
fn peak(c: &Cube) -> (usize, f64) {
    let mut p = vec![0f64; c.nt()];
    for px in c.data.chunks(c.nt()) {
        p.iter_mut().zip(px).for_each(|(a, &v)| *a += f64::from(v));
    }
    let (i, v) = p
        .iter()
        .enumerate()
        .fold((0, f64::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
    (i, v)
}

// ---- PTU files written from PicoQuant's record layouts ----

const TY_INT8: u32 = 0x1000_0008;
const TY_FLOAT8: u32 = 0x2000_0008;
const TY_EMPTY8: u32 = 0xFFFF_0008;

/// A PTU header: magic, version, the tags, `Header_End`.
fn ptu_header(ints: &[(&str, i64)], floats: &[(&str, f64)]) -> Vec<u8> {
    let mut out = b"PQTTTR\0\0".to_vec();
    out.extend_from_slice(b"1.0.00\0\0");
    let mut tag = |name: &str, ty: u32, raw: [u8; 8]| {
        let mut n = [0u8; 32];
        n[..name.len()].copy_from_slice(name.as_bytes());
        out.extend_from_slice(&n);
        out.extend_from_slice(&(-1i32).to_le_bytes());
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(&raw);
    };
    for (k, v) in ints {
        tag(k, TY_INT8, v.to_le_bytes());
    }
    for (k, v) in floats {
        tag(k, TY_FLOAT8, v.to_le_bytes());
    }
    tag("Header_End", TY_EMPTY8, [0; 8]);
    out
}

/// An event of a synthetic measurement, at an absolute time (sync periods).
#[derive(Clone, Copy)]
enum Ev {
    Photon { t: u64, dtime: u32, channel: u32 },
    Marker { t: u64, bits: u32 },
}

/// The records of `events` (in time order) as PicoHarp T3 (`pico`) or HydraHarp 2 /
/// generic T3 records, with overflow records wherever the clock wraps (65536 or 1024 sync
/// periods).
fn encode(events: &[Ev], pico: bool) -> Vec<u32> {
    let wrap: u64 = if pico { 65536 } else { 1024 };
    let mut out = Vec::new();
    let mut base = 0u64;
    for e in events {
        let t = match *e {
            Ev::Photon { t, .. } | Ev::Marker { t, .. } => t,
        };
        let wraps = (t - base) / wrap;
        if wraps > 0 {
            if pico {
                out.extend(std::iter::repeat_n(0xF000_0000u32, wraps as usize));
            } else {
                out.push((1 << 31) | (0x3F << 25) | wraps as u32);
            }
            base += wraps * wrap;
        }
        let nsync = (t - base) as u32;
        out.push(match (*e, pico) {
            (Ev::Photon { dtime, channel, .. }, true) => {
                ((channel + 1) << 28) | (dtime << 16) | nsync
            }
            (Ev::Marker { bits, .. }, true) => (0xF << 28) | (bits << 16) | nsync,
            (Ev::Photon { dtime, channel, .. }, false) => (channel << 25) | (dtime << 10) | nsync,
            (Ev::Marker { bits, .. }, false) => (1 << 31) | (bits << 25) | nsync,
        });
    }
    out
}

const NX: usize = 4;
const NY: usize = 3;
const NT: usize = 6;

/// The start-stop bin of the photon of frame `f`, pixel `(y, x)`, channel `c`.
fn dtime_of(f: usize, y: usize, x: usize, c: u32) -> u32 {
    ((f + 2 * y + x + 3 * c as usize) % NT) as u32
}

/// A scan of an incomplete first frame (one line), two complete frames of NY lines of NX
/// pixels (100 sync periods each; line start marker 1, stop marker 2, frame marker 3), one
/// photon per pixel and channel (0 and 1) plus stray photons between lines, and a frame
/// marker after each frame. Returns the events and the expected `[y][x][t]` counts of
/// channel `channel` (both when `None`) and frame `frame` (both when `None`).
fn scan(frame: Option<usize>, channel: Option<u32>) -> (Vec<Ev>, Vec<f32>) {
    let mut ev = Vec::new();
    let mut want = vec![0f32; NY * NX * NT];
    let mut t = 60_000u64; // the second frame crosses PicoHarp's 65536 wrap
                           // The incomplete first frame: its photons are left out.
    ev.push(Ev::Marker { t, bits: 1 });
    ev.push(Ev::Photon {
        t: t + 50,
        dtime: 1,
        channel: 0,
    });
    ev.push(Ev::Marker {
        t: t + 400,
        bits: 2,
    });
    ev.push(Ev::Marker {
        t: t + 500,
        bits: 4,
    });
    t += 1000;
    for f in 0..2 {
        for y in 0..NY {
            ev.push(Ev::Marker { t, bits: 1 });
            for x in 0..NX {
                for c in 0..2u32 {
                    let d = dtime_of(f, y, x, c);
                    ev.push(Ev::Photon {
                        t: t + 100 * x as u64 + 10 + 40 * u64::from(c),
                        dtime: d,
                        channel: c,
                    });
                    if frame.is_none_or(|k| k == f) && channel.is_none_or(|k| k == c) {
                        want[(y * NX + x) * NT + d as usize] += 1.0;
                    }
                }
            }
            ev.push(Ev::Marker {
                t: t + 400,
                bits: 2,
            });
            // A stray photon between the line's stop and the next start.
            ev.push(Ev::Photon {
                t: t + 450,
                dtime: 5,
                channel: 0,
            });
            t += 1000;
        }
        ev.push(Ev::Marker { t, bits: 4 });
        t += 700;
    }
    (ev, want)
}

fn write_scan(path: &Path, pico: bool, events: &[Ev]) {
    let records = encode(events, pico);
    let code = if pico { 0x0001_0303 } else { 0x0001_0307 };
    let mut bytes = ptu_header(
        &[
            ("TTResultFormat_TTTRRecType", code),
            ("TTResultFormat_BitsPerRecord", 32),
            ("TTResult_NumberOfRecords", records.len() as i64),
            ("Measurement_Mode", 3),
            ("Measurement_SubMode", 3),
            ("ImgHdr_Dimensions", 3),
            ("ImgHdr_PixX", NX as i64),
            ("ImgHdr_PixY", NY as i64),
            ("ImgHdr_LineStart", 1),
            ("ImgHdr_LineStop", 2),
            ("ImgHdr_Frame", 3),
            ("TTResult_SyncRate", 80_000_000),
        ],
        &[
            ("MeasDesc_Resolution", 25e-12),
            ("MeasDesc_GlobalResolution", 12.5e-9),
        ],
    );
    for r in records {
        bytes.extend_from_slice(&r.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn ptu_image_scans_of_both_record_families_histogram_as_their_records_say() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scan.h5");
    for pico in [true, false] {
        let p = dir.path().join(format!("scan_{pico}.ptu"));
        let (events, want) = scan(None, None);
        write_scan(&p, pico, &events);
        let c = ingest(&p, &out, &[]);
        assert_eq!((c.ny, c.nx, c.nt()), (NY, NX, NT), "pico {pico}");
        assert_eq!((c.axis.t0_ps, c.axis.dt_ps), (0.0, 25.0));
        assert_eq!(c.data, want, "pico {pico}: frames and channels summed");
        assert_eq!(note(&out, "ptu.photons_in_cube").as_deref(), Some("48"));
        let layout = note(&out, "ingest.layout").unwrap();
        assert!(
            layout.contains("2 frame(s) summed") && layout.contains("2 channel(s) summed"),
            "{layout}"
        );
        for (sel, frame, channel) in [
            ("frame=1", Some(1), None),
            ("channel=1", None, Some(1)),
            ("frame=0", Some(0), None),
        ] {
            let c = ingest(&p, &out, &["--select", sel]);
            assert_eq!(c.data, scan(frame, channel).1, "pico {pico} --select {sel}");
        }
        let c = ingest(&p, &out, &["--select", "frame=0", "--select", "C=0"]);
        assert_eq!(c.data, scan(Some(0), Some(0)).1);
        refused(
            &p,
            &dir.path().join("no.h5"),
            &["--select", "frame=2"],
            &["--select", "frame=2", "2 complete frame"],
        );
        refused(
            &p,
            &dir.path().join("no.h5"),
            &["--time-axis", "0"],
            &["--time-axis"],
        );
        refused(
            &p,
            &dir.path().join("no.h5"),
            &["--select", "wavelength=0"],
            &["--select", "frame and channel"],
        );
        let text = info(&[p.to_str().unwrap()]);
        assert!(
            text.contains("PicoQuant PTU") && text.contains("3 x 4 x 6"),
            "{text}"
        );
    }
}

#[test]
fn ptu_point_measurement_and_t2_files() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("point.ptu");
    let out = dir.path().join("point.h5");
    // Photons of channels 1 and 2 (none in 0): the cube's channel axis starts at 1.
    let mut events = vec![];
    let mut want = vec![0f32; 9];
    for i in 0..50u64 {
        let d = (i * 7 % 9) as u32;
        let c = 1 + (i % 2) as u32;
        events.push(Ev::Photon {
            t: 3000 * i,
            dtime: d,
            channel: c,
        });
        want[d as usize] += 1.0;
    }
    let records = encode(&events, false);
    let mut bytes = ptu_header(
        &[
            ("TTResultFormat_TTTRRecType", 0x0101_0304),
            ("TTResult_NumberOfRecords", records.len() as i64),
            ("Measurement_Mode", 3),
            ("Measurement_SubMode", 1),
        ],
        &[
            ("MeasDesc_Resolution", 1e-12),
            ("MeasDesc_GlobalResolution", 25e-9),
        ],
    );
    bytes.extend(records.iter().flat_map(|r| r.to_le_bytes()));
    std::fs::write(&p, &bytes).unwrap();
    let c = ingest(&p, &out, &[]);
    assert_eq!((c.ny, c.nx, c.nt()), (1, 1, 9));
    assert_eq!(c.axis.dt_ps, 1.0);
    assert_eq!(c.data, want);
    let c = ingest(&p, &out, &["--select", "channel=1"]);
    let odd: f32 = (0..50).filter(|i| i % 2 == 1).count() as f32;
    assert_eq!(sum(&c), f64::from(odd));
    refused(
        &p,
        &dir.path().join("no.h5"),
        &["--select", "frame=0"],
        &["--select", "channel"],
    );
    // The same records said to be T2: refused, naming the record type.
    let t2 = dir.path().join("t2.ptu");
    let mut b2 = ptu_header(
        &[
            ("TTResultFormat_TTTRRecType", 0x0001_0203),
            ("Measurement_Mode", 2),
            ("Measurement_SubMode", 1),
        ],
        &[
            ("MeasDesc_Resolution", 4e-12),
            ("MeasDesc_GlobalResolution", 4e-12),
        ],
    );
    b2.extend(records.iter().flat_map(|r| r.to_le_bytes()));
    std::fs::write(&t2, &b2).unwrap();
    refused(&t2, &dir.path().join("no.h5"), &[], &["PicoHarp T2", "T3"]);
    // A header whose string claims more bytes than the file has: one line, nothing written.
    let mut lying = bytes[..16].to_vec();
    let mut n = [0u8; 32];
    n[..7].copy_from_slice(b"Comment");
    lying.extend_from_slice(&n);
    lying.extend_from_slice(&(-1i32).to_le_bytes());
    lying.extend_from_slice(&0x4001_FFFFu32.to_le_bytes());
    lying.extend_from_slice(&(1u64 << 40).to_le_bytes());
    let bad = dir.path().join("lying.ptu");
    std::fs::write(&bad, &lying).unwrap();
    refused(&bad, &dir.path().join("no.h5"), &[], &["Comment"]);
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn real_ptu_scan_equals_ptufile() {
    let Some(p) = shared::file("data/real/ptu/ptu_stack_FLIM_z1.ptu") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("flim.h5");
    let c = ingest(&p, &out, &[]);
    // ptufile 2026.2.6: decode_image(frame=-1, channel=-1, dtype='uint32') is (1, 256, 256,
    // 1, 133), sum 150363 (every photon of the file), peak bin 12 (13544 photons), largest
    // voxel 7 at (y 175, x 146, bin 15); pixel (100, 100) holds 3, (10, 200) 1;
    // MeasDesc_Resolution 9.696969697e-11 s.
    assert_eq!((c.ny, c.nx, c.nt()), (256, 256, 133));
    assert!(
        (c.axis.dt_ps - 96.969_696_97).abs() < 1e-6,
        "{}",
        c.axis.dt_ps
    );
    assert_eq!(sum(&c), 150_363.0);
    assert_eq!(peak(&c), (12, 13_544.0));
    assert_eq!(at(&c, 175, 146, 15), 7.0);
    assert_eq!(c.value_range(), Some((0.0, 7.0)));
    assert_eq!(c.profile(100, 100).iter().sum::<f32>(), 3.0);
    assert_eq!(c.profile(200, 10).iter().sum::<f32>(), 1.0);
    // Each frame alone: ptufile's decode_image(frame=k, channel=-1) sums.
    for (k, n) in [(0, 30_479.0), (2, 29_996.0), (4, 29_743.0)] {
        let c = ingest(&p, &out, &["--select", &format!("frame={k}")]);
        assert_eq!(sum(&c), n, "frame {k}");
    }
    let text = info(&[p.to_str().unwrap()]);
    assert!(text.contains("(5, 256, 256, 1, 133)"), "{text}");
}

// ---- Delmic SPARC HDF5 ----

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn delmic_spots_read_their_acquisition_never_the_preview() {
    let (Some(tc), Some(streak)) = (
        shared::file("data/real/delmic/sparc-time-correlator-spot.h5"),
        shared::file("data/real/delmic/sparc-streak-camera-spot.h5"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.h5");
    // rosettasciio 0.15.0 delmic.file_reader: (65536,) uint32, sum 1072445930, peak 32768 at
    // bin 54582, Time from -99.999 ns in 16 ps steps.
    let c = ingest(&tc, &out, &[]);
    assert_eq!((c.ny, c.nx, c.nt()), (1, 1, 65536));
    assert!((c.axis.t0_ps + 99_999.0).abs() < 1e-3, "{}", c.axis.t0_ps);
    assert!((c.axis.dt_ps - 16.0).abs() < 1e-6, "{}", c.axis.dt_ps);
    assert_eq!(sum(&c), 1_072_445_930.0);
    assert_eq!(peak(&c), (54_582, 32_768.0));
    assert_eq!(
        note(&out, "delmic.acquisition").as_deref(),
        Some("Acquisition2")
    );
    // The streak camera: (Time 256, Wavelength 256), 0 to 5 ns; sum 34088317; summed over
    // wavelength the peak is bin 201 (133228); wavelength 100 alone peaks at bin 58 (525).
    let c = ingest(&streak, &out, &[]);
    assert_eq!((c.ny, c.nx, c.nt()), (1, 1, 256));
    assert!((c.axis.dt_ps - 5000.0 / 255.0).abs() < 1e-6);
    assert_eq!(sum(&c), 34_088_317.0);
    assert_eq!(peak(&c), (201, 133_228.0));
    assert!(note(&out, "ingest.layout").unwrap().contains("summed"));
    let c = ingest(&streak, &out, &["--select", "C=100"]);
    assert_eq!(peak(&c), (58, 525.0));
    assert_eq!(at(&c, 0, 0, 50), 523.0);
    // The preview is a picture: never a candidate, refused when named.
    let text = info(&[streak.to_str().unwrap()]);
    assert!(!text.contains("Preview"), "{text}");
    refused(
        &streak,
        &dir.path().join("no.h5"),
        &["--dataset", "Acquisition0"],
        &["Acquisition0", "one bin"],
    );
    let plain = dir.path().join("no.h5");
    refused(
        &streak,
        &plain,
        &["--from", "array", "--dataset", "/Preview/Image"],
        &["Preview/Image"],
    );
}

// ---- MATLAB v7.3 scans stored time first ----

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn a_time_first_matlab_scan_is_refused_then_read_with_time_axis_0() {
    let (Some(s), Some(direct)) = (
        shared::file("data/real/cdt/letter_s.mat"),
        shared::file("data/real/cdt/capture_direct.mat"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.h5");
    let no = dir.path().join("no.h5");
    let err = refused(
        &s,
        &no,
        &["--dt-ps", "16"],
        &["--time-axis", "[512, 32, 32]"],
    );
    assert!(err.contains("meas"), "{err}");
    refused(
        &s,
        &no,
        &["--dt-ps", "16", "--confocal", "--wall-size-m", "0.6"],
        &["--time-axis"],
    );
    refused(&s, &no, &["--dt-ps", "16", "--transpose"], &["--time-axis"]);
    // h5py: meas (32, 32, 512) float32 = MATLAB (512, 32, 32); sum 20103188; MATLAB
    // meas(t, i, j) is h5py m[j, i, t]: cube[i][j][t]; cube[0][31][511] = 4, max 578 at
    // (21, 17, 257), summed profile peak at bin 262.
    let c = ingest(
        &s,
        &out,
        &[
            "--dt-ps",
            "16",
            "--time-axis",
            "0",
            "--confocal",
            "--wall-size-m",
            "0.6",
        ],
    );
    assert_eq!((c.ny, c.nx, c.nt()), (32, 32, 512));
    assert_eq!(sum(&c), 20_103_188.0);
    assert_eq!(at(&c, 0, 31, 511), 4.0);
    assert_eq!(at(&c, 21, 17, 257), 578.0);
    assert_eq!(peak(&c).0, 262);
    let layout = note(&out, "ingest.layout").unwrap();
    assert!(layout.contains("--time-axis 0"), "{layout}");
    let text = info(&[out.to_str().unwrap()]);
    assert!(
        text.contains("--time-axis 0"),
        "femto info shows the choice: {text}"
    );
    let text = info(&[s.to_str().unwrap()]);
    assert!(
        text.contains("[512, 32, 32]") && text.contains("--time-axis"),
        "{text}"
    );
    // capture_direct.mat: `out` 1 x 65536 double (one pixel's histogram) beside a cell
    // array and two scalars: read with no --dataset; h5py: sum 18181571, peak 1593790 at 3881.
    let c = ingest(&direct, &out, &["--dt-ps", "8"]);
    assert_eq!((c.ny, c.nx, c.nt()), (1, 1, 65536));
    assert_eq!(sum(&c), 18_181_571.0);
    assert_eq!(peak(&c), (3881, 1_593_790.0));
    let text = info(&[direct.to_str().unwrap(), "--dataset", "out"]);
    assert!(text.contains("[1, 65536]"), "{text}");
}

// ---- .npz, pictures, unknown files ----

fn npy(shape: &[usize], values: &[f32]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut h = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {tuple}, }}");
    while !(10 + h.len() + 1).is_multiple_of(64) {
        h.push(' ');
    }
    h.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(h.as_bytes());
    out.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    out
}

#[test]
fn npz_members_are_datasets() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.npz");
    let cube: Vec<f32> = (0..2 * 3 * 8).map(|i| i as f32).collect();
    let axis: Vec<f32> = (0..8).map(|i| 4.0 * i as f32).collect();
    let mut z = zip::ZipWriter::new(std::fs::File::create(&p).unwrap());
    let deflated = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    z.start_file("data.npy", deflated).unwrap();
    z.write_all(&npy(&[2, 3, 8], &cube)).unwrap();
    z.start_file(
        "t_ps.npy",
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored),
    )
    .unwrap();
    z.write_all(&npy(&[8], &axis)).unwrap();
    z.finish().unwrap();
    let out = dir.path().join("a.h5");
    let err = refused(
        &p,
        &out,
        &["--dt-ps", "4"],
        &["--dataset", "data [2, 3, 8]", "t_ps [8]"],
    );
    assert!(err.contains("2 arrays"), "{err}");
    let c = ingest(&p, &out, &["--dataset", "data", "--dt-ps", "4"]);
    assert_eq!((c.ny, c.nx, c.nt()), (2, 3, 8));
    assert_eq!(c.data, cube);
    let text = info(&[p.to_str().unwrap(), "--dataset", "data"]);
    assert!(text.contains("2 x 3 x 8"), "{text}");
    refused(
        &p,
        &dir.path().join("no.h5"),
        &["--dataset", "nope", "--dt-ps", "4"],
        &["nope", "data [2, 3, 8]"],
    );
}

#[test]
fn unknown_and_unread_formats_say_what_femto_reads() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.h5");
    let sdt = dir.path().join("scan.sdt");
    std::fs::write(&sdt, b"\x00\x01 not really").unwrap();
    refused(&sdt, &out, &[], &["Becker & Hickl", ".npy"]);
    let odd = dir.path().join("capture.xyz");
    std::fs::write(&odd, b"whatever").unwrap();
    refused(&odd, &out, &[], &[".ptu", ".npz", "Delmic", ".mat"]);
    let o = femto(&["info", odd.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(".ptu") && err.contains(".npz"), "{err}");
    // A four-axis array names --sum and --select.
    let p = dir.path().join("four.npy");
    std::fs::write(&p, npy(&[2, 3, 4, 9], &vec![1.0; 216])).unwrap();
    refused(&p, &out, &["--dt-ps", "1"], &["--sum", "--select"]);
    let c = ingest(&p, &out, &["--dt-ps", "1", "--sum", "0"]);
    assert_eq!((c.ny, c.nx, c.nt()), (3, 4, 9));
    assert!(c.data.iter().all(|&v| v == 2.0));
}

/// A Delmic SPARC map as Odemis writes it: a survey SEM image (T = 1), the streak-camera map
/// `Image` (C = 2, T = 5, Z = 1, Y = 3, X = 4) with its dimension scales, and an RGB preview.
fn delmic_map(p: &Path) -> Vec<f32> {
    let f = rust_hdf5::H5File::create(p).unwrap();
    let labels = ["C", "T", "Z", "Y", "X"];
    let image = |group: &str, shape: [usize; 5], values: &[u16]| {
        let g = f
            .create_group(group)
            .unwrap()
            .create_group("ImageData")
            .unwrap();
        let d = g.new_dataset::<u16>().shape(shape).create("Image").unwrap();
        d.write_raw(values).unwrap();
        d.new_attr::<rust_hdf5::VarLenUnicode>()
            .shape([5])
            .create("DIMENSION_LABELS")
            .unwrap()
            .write_string_array(&labels)
            .unwrap();
        g
    };
    image("Acquisition0", [1, 1, 1, 6, 6], &[7; 36]);
    // value(c, t, y, x) = 1000 c + 100 t + 10 y + x
    let mut values = Vec::new();
    for c in 0..2u16 {
        for t in 0..5u16 {
            for y in 0..3u16 {
                for x in 0..4u16 {
                    values.push(1000 * c + 100 * t + 10 * y + x);
                }
            }
        }
    }
    let g = image("Acquisition1", [2, 5, 1, 3, 4], &values);
    let scalar = |name: &str, v: f64| {
        g.new_dataset::<f64>()
            .shape([0usize; 0])
            .create(name)
            .unwrap()
            .write_raw(&[v])
            .unwrap();
    };
    scalar("DimensionScaleX", 2e-6);
    scalar("DimensionScaleY", 2e-6);
    scalar("XOffset", 1e-5);
    scalar("YOffset", -3e-6);
    let t: Vec<f64> = (0..5).map(|i| 1e-9 + 20e-12 * f64::from(i)).collect();
    g.new_dataset::<f64>()
        .shape([5])
        .create("DimensionScaleT")
        .unwrap()
        .write_raw(&t)
        .unwrap();
    g.new_dataset::<f64>()
        .shape([2])
        .create("DimensionScaleC")
        .unwrap()
        .write_raw(&[5.5e-7, 5.6e-7])
        .unwrap();
    let preview = f.create_group("Preview").unwrap();
    preview
        .new_dataset::<u8>()
        .shape([8, 8, 3])
        .create("Image")
        .unwrap()
        .write_raw(&[9u8; 192])
        .unwrap();
    f.close().unwrap();
    // The cube: [y][x][t] with C summed.
    let mut want = Vec::new();
    for y in 0..3 {
        for x in 0..4 {
            for t in 0..5 {
                want.push(
                    (0..2)
                        .map(|c| (1000 * c + 100 * t + 10 * y + x) as f32)
                        .sum(),
                );
            }
        }
    }
    want
}

#[test]
fn a_delmic_map_reads_with_no_flags() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("map.h5");
    let want = delmic_map(&p);
    let out = dir.path().join("cube.h5");
    let c = ingest(&p, &out, &[]);
    assert_eq!((c.ny, c.nx, c.nt()), (3, 4, 5));
    assert_eq!(c.data, want);
    assert!((c.axis.t0_ps - 1000.0).abs() < 1e-6 && (c.axis.dt_ps - 20.0).abs() < 1e-6);
    assert_eq!(
        note(&out, "delmic.acquisition").as_deref(),
        Some("Acquisition1")
    );
    assert_eq!(
        note(&out, "delmic.wavelengths_nm").as_deref(),
        Some("[550.0,560.0]")
    );
    // As rosettasciio: Y goes up, the first row at the top; offsets are the first pixel's.
    assert_eq!(note(&out, "axis.y.scale").as_deref(), Some("-0.000002"));
    assert_eq!(
        note(&out, "axis.x.offset").as_deref(),
        Some(&*(1e-5 - 3e-6f64).to_string())
    );
    let c = ingest(&p, &out, &["--select", "C=1"]);
    assert_eq!(at(&c, 2, 3, 4), 1423.0);
    let text = info(&[p.to_str().unwrap()]);
    assert!(
        text.contains("Acquisition1 [2, 5, 1, 3, 4]") && !text.contains("Preview"),
        "{text}"
    );
}
