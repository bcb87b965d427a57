//! Fault cases: sizes nothing bounded (issue 16). Every size or count a user can ask for is
//! capped or estimated against the memory available before anything is allocated or walked;
//! each reproducer of the report must be refused with exit 2, one line naming the flag, file
//! or key that fixes it, nothing written, and at once.
//!
//! The runs set `FEMTO_MEMORY_LIMIT_BYTES` to 2 GB so the refusals do not depend on this
//! machine's memory.

use super::{case, cli, render_args};
use cli::FemtoCmd;
use femto::container::{CubeReader, CubeWriter, DataBuf, Provenance};
use std::path::Path;
use std::time::{Duration, Instant};

/// The memory the runs are told this machine has: 2 GB.
const LIMIT: (&str, &str) = ("FEMTO_MEMORY_LIMIT_BYTES", "2000000000");

/// A refusal must not be a slow failure: well under a second of work (the bound leaves room
/// for a loaded test machine starting the binary).
const FAST: Duration = Duration::from_secs(3);

/// [`cli::refused_unchanged`] with the 2 GB limit, also required to be fast.
fn refused_fast(dir: &Path, args: &[&str], names: &[&str]) -> String {
    let started = Instant::now();
    let err = cli::refused_unchanged(dir, args, &[LIMIT], names);
    let took = started.elapsed();
    assert!(
        took < FAST,
        "femto {}: refused after {took:?}",
        args.join(" ")
    );
    eprintln!("femto {}: {took:.2?}: {err}", args[0]);
    err
}

/// A scene file like the built-in cube scene's camera and laser over one floor quad of
/// `side_m` x `side_m`.
fn floor_scene(side_m: f64) -> String {
    format!(
        "name = \"floor\"\n\
         [laser]\n\
         position_m = [-0.13, 0.06, -0.07]\n\
         normal = [0.8, 0.2, 0.55]\n\
         wavelength_nm = 795.0\n\
         pulse_width_fs = 50.0\n\
         energy = 1.0\n\
         [camera]\n\
         position_m = [0.0, 0.22, 0.85]\n\
         look_at_m = [0.0, 0.05, 0.0]\n\
         vfov_deg = 16.0\n\
         nx = 32\n\
         ny = 24\n\
         nt = 64\n\
         dt_ps = 4.0\n\
         t0_ps = 3200.0\n\
         [[mesh]]\n\
         name = \"floor\"\n\
         primitive = \"quad\"\n\
         size = [{side_m}, {side_m}]\n\
         rotate_deg = [-90.0, 0.0, 0.0]\n\
         albedo = 0.7\n"
    )
}

#[test]
fn simulate_marker_spacing_of_a_nanometre_is_refused_at_once() {
    // Exhausted a 23 GB machine: 1.4e17 fiducial candidates on the cube scene's floor.
    let dir = case(&[]);
    let err = refused_fast(
        dir.path(),
        &[
            "simulate",
            "--size",
            "32x24",
            "--marker-spacing-m",
            "1e-9",
            "--out",
            "cap",
        ],
        &["--marker-spacing-m"],
    );
    assert!(err.contains("fiducial"), "{err}");
}

#[test]
fn simulate_of_a_kilometre_quad_is_refused_at_once() {
    // A 1000 x 1000 m quad asked 6.4 GB: its fiducial grid at 8 mm has 1.6e10 nodes.
    let dir = case(&[]);
    std::fs::write(dir.path().join("big.toml"), floor_scene(1000.0)).unwrap();
    refused_fast(
        dir.path(),
        &["simulate", "--scene", "big.toml", "--out", "cap"],
        &["--marker-spacing-m", "fiducial"],
    );
    // The same file with a 1 m floor runs through the same checks (the limit is the quad).
    std::fs::write(dir.path().join("small.toml"), floor_scene(1.0)).unwrap();
    let ok = cli::femto_env(
        Some(dir.path()),
        &[
            "simulate",
            "--scene",
            "small.toml",
            "--spp",
            "1",
            "--out",
            "cap",
        ],
        &[LIMIT],
    );
    assert_eq!(ok.code, Some(0), "{}", ok.stderr);
}

#[test]
fn simulate_size_beyond_the_cap_is_refused_at_once() {
    // Hung: simulate had no size cap.
    let dir = case(&[]);
    let err = refused_fast(
        dir.path(),
        &["simulate", "--size", "100000x100000", "--out", "cap"],
        &["--size", "100000"],
    );
    assert!(err.contains("width"), "{err}");
}

#[test]
fn simulate_size_within_the_cap_but_beyond_the_memory_is_refused() {
    // 30000 x 20000 pixels is inside the cap; its flat field alone is 2.4 GB.
    let dir = case(&[]);
    let err = refused_fast(
        dir.path(),
        &["simulate", "--size", "30000x20000", "--out", "cap"],
        &["--size", "2.0 GB"],
    );
    assert!(err.contains("30000 x 20000"), "{err}");
}

#[test]
fn simulate_bins_of_1e_300_ps_are_refused_at_once() {
    // Hung: the pulse was 1e298 bins wide and the world-time axis 1e303 bins long.
    let dir = case(&[]);
    refused_fast(
        dir.path(),
        &[
            "simulate", "--size", "32x24", "--dt-ps", "1e-300", "--out", "cap",
        ],
        &["--dt-ps"],
    );
}

#[test]
fn simulate_a_pulse_of_4294967296_fs_is_refused_at_once() {
    // Hung: a 4.3 ms pulse measured in bins of 4 ps (1.6e5 sigmas of bins per splat).
    let dir = case(&[]);
    let scene = floor_scene(0.4).replace("pulse_width_fs = 50.0", "pulse_width_fs = 4294967296");
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    refused_fast(
        dir.path(),
        &["simulate", "--scene", "s.toml", "--out", "cap"],
        &["pulse_width_fs", "4294967296"],
    );
}

#[test]
fn unwarp_nt_of_a_billion_is_refused_before_reading() {
    // Asked 64 GB.
    let dir = case(&["cube.h5"]);
    let err = refused_fast(
        dir.path(),
        &[
            "unwarp",
            "cube.h5",
            "--out",
            "w.h5",
            "--t0-ps",
            "0",
            "--nt",
            "1000000000",
        ],
        &["--nt", "cube.h5"],
    );
    assert!(err.contains("GB"), "{err}");
}

/// Copy the cube `from` to `to` with its axis and `registration` group changed by `edit`
/// (the other groups are left out: unwarp reads only the registration).
fn rewrite_cube(
    from: &Path,
    to: &Path,
    edit: impl FnOnce(&mut femto::cube::TimeAxis, &mut femto::container::GroupData),
) {
    let reader = CubeReader::open(from).unwrap();
    let meta = reader.meta().clone();
    let cube = reader.read_cube().unwrap();
    let mut group = reader.read_group("registration").unwrap();
    let mut axis = meta.axis;
    edit(&mut axis, &mut group);
    let mut w = CubeWriter::create(
        to,
        meta.nx,
        meta.ny,
        axis,
        meta.frame,
        &meta.units,
        &Provenance::new("tests/faults/sizes.rs"),
    )
    .unwrap();
    w.write_rows(0, &cube.data).unwrap();
    if let Some(mask) = &cube.mask {
        w.write_mask(mask).unwrap();
    }
    w.write_group("registration", &group).unwrap();
    w.finish().unwrap();
}

#[test]
fn unwarp_of_a_registration_distance_of_1e12_m_is_refused() {
    // Asked 53 PB.
    let dir = case(&["cube.h5"]);
    rewrite_cube(
        &dir.path().join("cube.h5"),
        &dir.path().join("far.h5"),
        |_, group| {
            for (name, _, values) in &mut group.datasets {
                if name == "dist_m" {
                    let DataBuf::F32(d) = values else {
                        panic!("dist_m is f32")
                    };
                    let p = d.iter().position(|v| v.is_finite()).unwrap();
                    d[p] = 1e12;
                }
            }
            for (name, value) in &mut group.attrs {
                if name == "dist_max_m" {
                    *value = femto::container::AttrValue::F64(1e12);
                }
            }
        },
    );
    refused_fast(
        dir.path(),
        &["unwarp", "far.h5", "--out", "w.h5"],
        &["far.h5", "dist_m"],
    );
}

#[test]
fn a_manifest_ny_of_2_to_the_64_is_refused() {
    // "capacity overflow" in the manifest check.
    let dir = case(&["cap/manifest.toml"]);
    let path = dir.path().join("cap/manifest.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let edited = text.replacen("ny = 24", "ny = 18446744073709551615", 1);
    assert_ne!(edited, text, "the fixture manifest has ny = 24");
    std::fs::write(&path, edited).unwrap();
    refused_fast(
        dir.path(),
        &["ingest", "cap", "-o", "c.h5"],
        &["manifest.toml", "capture.ny"],
    );
}

#[test]
fn ingest_rows_of_1e11_are_refused_before_listing() {
    // Asked 2.4 TB for the file list.
    let dir = case(&["cap/scanlines/scanline_0000.png"]);
    refused_fast(
        dir.path(),
        &[
            "ingest",
            "cap/scanlines/scanline_%04d.png",
            "--rows",
            "100000000000",
            "--allow-missing",
            "-o",
            "c.h5",
        ],
        &["--rows", "100000000000"],
    );
}

#[test]
fn render_size_inside_its_cap_but_beyond_the_memory_is_refused() {
    // 16384 x 16384 is inside the renderer's cap and needed 6.4 GB per frame for its rays.
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    let err = refused_fast(
        dir.path(),
        &render_args(
            "cube.calibration.toml",
            &[
                "--capture-view",
                "--size",
                "16384x16384",
                "--frame-count",
                "2",
                "--out",
                "r.gif",
            ],
        ),
        &["--size", "16384x16384"],
    );
    assert!(err.contains("GB"), "{err}");
}

/// Run `femto args...` in `dir` with the 2 GB limit and return its exit code and the peak
/// resident memory it reached (VmHWM of /proc/PID/status, polled every millisecond until it
/// exits; the high-water mark only grows, so the last reading is the peak but for the last
/// millisecond, when the stage's buffers are already freed).
fn peak_memory_bytes(dir: &Path, args: &[&str]) -> (Option<i32>, u64) {
    let mut child = FemtoCmd::new()
        .args(args)
        .env(LIMIT.0, LIMIT.1)
        .current_dir(dir)
        .command()
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("femto starts");
    let status_file = format!("/proc/{}/status", child.id());
    let mut peak_kb = 0u64;
    loop {
        if let Ok(text) = std::fs::read_to_string(&status_file) {
            if let Some(kb) = text
                .lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<u64>().ok())
            {
                peak_kb = peak_kb.max(kb);
            }
        }
        if let Some(status) = child.try_wait().expect("wait") {
            return (status.code(), peak_kb * 1024);
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// The estimate a stage refuses by is within a factor of two of what it really holds, on a
/// case whose buffers dominate the process (the output axis of 60000 bins makes one slab of
/// rows 64 MB).
#[test]
fn unwarp_memory_estimate_is_within_a_factor_two_of_the_peak() {
    let dir = case(&["cube.h5"]);
    let meta = femto::container::read_meta(&dir.path().join("cube.h5")).unwrap();
    let nt_out = 60_000;
    let est = femto::pipeline::unwarp::memory_estimate(meta.nx, meta.ny, meta.axis.nt, nt_out);
    let (code, peak) = peak_memory_bytes(
        dir.path(),
        &[
            "unwarp",
            "cube.h5",
            "--out",
            "w.h5",
            "--t0-ps",
            "0",
            "--nt",
            &nt_out.to_string(),
        ],
    );
    assert_eq!(code, Some(0));
    eprintln!("unwarp: estimate {est:.3e} B, peak {peak} B");
    assert!(
        est >= peak as f64 && est <= 2.0 * peak as f64,
        "estimate {est:.3e} B, peak {peak} B"
    );
}

#[test]
fn render_memory_estimate_is_within_a_factor_two_of_the_peak() {
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    let meta = femto::container::read_meta(&dir.path().join("world.h5")).unwrap();
    let (w, h) = (1024, 1024);
    let est = femto::pipeline::render::memory_estimate(
        (meta.nx, meta.ny, meta.axis.nt),
        (w, h, 1),
        femto::video::VideoFormat::Gif,
    );
    let (code, peak) = peak_memory_bytes(
        dir.path(),
        &render_args(
            "cube.calibration.toml",
            &[
                "--capture-view",
                "--size",
                &format!("{w}x{h}"),
                "--frame-count",
                "1",
                "--out",
                "r.gif",
            ],
        ),
    );
    assert_eq!(code, Some(0));
    eprintln!("render: estimate {est:.3e} B, peak {peak} B");
    assert!(
        est >= peak as f64 && est <= 2.0 * peak as f64,
        "estimate {est:.3e} B, peak {peak} B"
    );
}

#[test]
fn pyramid_slabs_beyond_the_memory_are_refused_before_writing() {
    // The pyramid stage sized its slabs from the cube's attributes unchecked; with 20 MB
    // available not even the process fits, and the cube is left as it was.
    let dir = case(&["world.h5"]);
    let err = cli::refused_unchanged(
        dir.path(),
        &["pyramid", "world.h5"],
        &[("FEMTO_MEMORY_LIMIT_BYTES", "20000000")],
        &["world.h5", "20.0 MB"],
    );
    assert!(err.contains("pyramid"), "{err}");
}

#[test]
fn render_threads_beyond_any_machine_are_refused() {
    // A million threads would each reserve a stack before the first frame.
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    for threads in ["0", "1000000"] {
        refused_fast(
            dir.path(),
            &render_args(
                "cube.calibration.toml",
                &["--capture-view", "--threads", threads, "--out", "r.gif"],
            ),
            &["--threads", threads, "1024"],
        );
    }
}

#[test]
fn an_hdf5_stack_beyond_the_memory_is_refused_before_reading() {
    // Ingest read a whole HDF5 stack before checking what it would hold; a 1 MB limit makes
    // a stack of 24 streak images of 32 x 256 (no time axis recorded: streak images) such a
    // stack. (A femto cube's own /cube records its axis, so it is read as an x-y-t array.)
    let dir = case(&[]);
    let f = rust_hdf5::H5File::create(dir.path().join("stack_in.h5")).unwrap();
    let ds = f
        .new_dataset::<f32>()
        .shape([24, 256, 32])
        .create("cube")
        .unwrap();
    ds.write_raw(&vec![1.0f32; 24 * 256 * 32]).unwrap();
    f.close().unwrap();
    let before = cli::Snapshot::of(dir.path());
    let run = cli::femto_env(
        Some(dir.path()),
        &[
            "ingest",
            "stack_in.h5",
            "--dataset",
            "cube",
            "-o",
            "stack.h5",
            "--dt-ps",
            "2",
            "--t0-ps",
            "0",
        ],
        &[("FEMTO_MEMORY_LIMIT_BYTES", "1000000")],
    );
    let err = run.stderr.trim_end();
    assert_eq!(run.code, Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    for name in ["stack_in.h5", "/cube", "split the stack"] {
        assert!(err.contains(name), "names {name}: {err}");
    }
    assert!(before.changes(&cli::Snapshot::of(dir.path())).is_empty());
}

/// An MP4 or GIF is held in memory until it is written whole: its frames count in the
/// render's memory estimate (they did not). With a limit that one frame fits, 4000 frames of
/// 320 x 240 (77 MB as H.264 at the estimate's 1 byte a pixel) are refused for MP4, naming
/// `--frame-count` and the frame sequence that streams instead; a PNG sequence of the same
/// frames passes the memory check (it is then refused for its folder, which is not a folder).
#[test]
fn render_counts_the_frames_an_mp4_holds_in_memory() {
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    let meta = femto::container::read_meta(&dir.path().join("world.h5")).unwrap();
    let one = femto::pipeline::render::memory_estimate(
        (meta.nx, meta.ny, meta.axis.nt),
        (320, 240, 1),
        femto::video::VideoFormat::Mp4,
    );
    let limit = format!("{}", (one + 20e6) as u64);
    let env = [("FEMTO_MEMORY_LIMIT_BYTES", limit.as_str())];
    let flags = |out: &'static str| {
        let mut a = render_args(
            "cube.calibration.toml",
            &[
                "--dolly",
                "0.5",
                "--size",
                "320x240",
                "--frame-count",
                "4000",
            ],
        );
        a.extend_from_slice(&["--out", out]);
        a
    };
    let err = cli::refused_unchanged(
        dir.path(),
        &flags("long.mp4"),
        &env,
        &["--frame-count", "--format png", "MP4 held in memory"],
    );
    assert!(err.contains("4000 frames of 320x240"), "{err}");
    std::fs::write(dir.path().join("file"), b"not a folder").unwrap();
    let err = cli::refused_unchanged(dir.path(), &flags("file"), &env, &["file"]);
    assert!(!err.contains("memory"), "a frame sequence streams: {err}");
}

/// A render's options are refused before its inputs are opened: with no cube at all, a
/// `--size` beyond the cap is what the message names (the inputs, gigabytes at times, were
/// read first, 0.4 s on this fixture).
#[test]
fn render_options_are_refused_before_the_inputs_are_opened() {
    let dir = case(&[]);
    let err = cli::refused_unchanged(
        dir.path(),
        &render_args(
            "absent.toml",
            &["--capture-view", "--size", "99999x10", "--out", "r.gif"],
        ),
        &[],
        &["--size", "99999x10", "16384"],
    );
    assert!(!err.contains("world.h5"), "{err}");
}
