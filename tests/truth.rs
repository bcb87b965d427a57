//! The image-based renderer against the traced truth of a moving camera (`femto simulate
//! --truth-path`, `femto compare`), run as a user runs them: at the capture camera's own
//! position and at rest, the render of the capture's world-time cube and the truth must agree
//! within the noise of both (docs/truth.md).

#[path = "common/cli.rs"]
mod cli;
use cli::{arg, femto_ok, refused_unchanged};
use femto::color;
use femto::container::read_cube;
use femto::video::read_exr;
use std::path::Path;

/// A camera path that holds the built-in cube scene's capture camera still: `frames` frames
/// of `dtau_ps` from world time `t0_ps`, at `w x h` pixels.
fn still_path(w: usize, h: usize, frames: usize, t0_ps: f64, dtau_ps: f64) -> String {
    let pose = "position_m = [0.0, 0.22, 0.85]\nworld_from_camera = [[1.0, 0.0, 0.0], \
                [0.0, -0.9805806756909201, -0.19611613513818402], \
                [0.0, 0.19611613513818402, -0.9805806756909201]]\nvfov_deg = 16.0\n";
    format!(
        "width = {w}\nheight = {h}\nframes = {frames}\ndtau_ps = {dtau_ps}\ntau0_ps = {t0_ps}\n\
         clock = \"world\"\ninterpolation = \"linear\"\n\n[[keyframe]]\ntime_ps = {t0_ps}\n{pose}\n\
         [[keyframe]]\ntime_ps = {}\n{pose}",
        t0_ps + 10_000.0
    )
}

fn luminance_frame(path: &Path) -> Vec<f64> {
    let (_, _, rgb) = read_exr(path).unwrap();
    rgb.iter()
        .map(|p| color::luminance([p[0] as f64, p[1] as f64, p[2] as f64]))
        .collect()
}

/// Mean and variance of the mean of `v`.
fn mean_and_var_of_mean(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, var / n)
}

/// What one side of a comparison gave: `[seed][frame][pixel]` luminances.
type Frames = Vec<Vec<Vec<f64>>>;

/// Group-by-group comparison of `a` and `b` (4 x 4 pixel groups of a `w x h` frame, every
/// frame), each group's difference of the seed means against its standard error from the
/// spread over the seeds of both sides, plus `allowance[frame][pixel]` summed over the group
/// (a bound on a known approximation; zeros for none). Returns the lit groups, those whose
/// difference exceeds 3.5 standard errors plus the allowance, and the pooled z of all
/// groups' differences.
fn group_test(
    a: &Frames,
    b: &Frames,
    allowance: &[Vec<f64>],
    keep: &[bool],
    w: usize,
    h: usize,
) -> (usize, usize, f64) {
    let (mut groups, mut over) = (0usize, 0usize);
    let (mut diff_sum, mut var_sum) = (0.0, 0.0);
    let mut worst = (0.0f64, 0usize, 0usize, 0usize);
    for k in 0..a[0].len() {
        for gy in 0..h / 4 {
            for gx in 0..w / 4 {
                let sum = |f: &Vec<f64>| {
                    let mut s = 0.0;
                    for y in gy * 4..gy * 4 + 4 {
                        for x in gx * 4..gx * 4 + 4 {
                            if keep[y * w + x] {
                                s += f[y * w + x];
                            }
                        }
                    }
                    s
                };
                let va: Vec<f64> = a.iter().map(|s| sum(&s[k])).collect();
                let vb: Vec<f64> = b.iter().map(|s| sum(&s[k])).collect();
                let ((ma, vara), (mb, varb)) =
                    (mean_and_var_of_mean(&va), mean_and_var_of_mean(&vb));
                if ma == 0.0 && mb == 0.0 {
                    continue;
                }
                groups += 1;
                let sigma = (vara + varb).sqrt();
                let z = ((mb - ma).abs() - sum(&allowance[k])).max(0.0) / sigma;
                if z > worst.0 {
                    worst = (z, k, gx, gy);
                }
                over += (z > 3.5) as usize;
                diff_sum += mb - ma;
                var_sum += vara + varb;
            }
        }
    }
    let pooled = diff_sum / var_sum.sqrt();
    eprintln!(
        "{groups} lit groups, {over} beyond 3.5 standard errors (plus allowance); worst {:.2} \
         (frame {}, group {},{}); pooled z {pooled:.2}",
        worst.0, worst.1, worst.2, worst.3
    );
    (groups, over, pooled)
}

/// At the capture camera's position and at rest the truth is what the capture itself
/// records, and the renderer gives it back through the chain's world-time cube: 8
/// independent captures and truths (seeds 1-8) of a 64 x 48 capture, three frames of 100 ps
/// while the light crosses the scene, compared in 4 x 4 pixel groups.
///
/// - The truth against the camera-time capture's own window sums (frames on its bin edges):
///   equal within the noise of both.
/// - The render of `femto unwarp`'s world-time cube against the truth, on the pixels the
///   unwarp shifts (those it masks as mixed, spanning more than 4 bins of path, are black in
///   the render): equal within the noise of both plus the bound of the renderer's time
///   interpolation. The cube goes to world time
///   and back through two linear interpolations of each pixel's prefix sum between bin
///   edges (the unwarp's fractional shift, `crate::unwarp`'s "Resampling error", and the
///   renderer's read at `t_e`); both reproduce straight lines, so at each end of the window
///   the read value lies within half the largest change between neighbouring bins (of the
///   three bins about it) of the exact one. Without that allowance the pulse's sharp edges
///   differ by up to a few per cent (docs/truth.md).
#[test]
fn truth_and_render_agree_at_the_capture_position_within_noise() {
    let dir = tempfile::tempdir().unwrap();
    let path_file = dir.path().join("still.toml");
    let (w, h, frames) = (64usize, 48usize, 3usize);
    let (t0_ps, dtau_ps) = (3500.0, 100.0);
    std::fs::write(&path_file, still_path(w, h, frames, t0_ps, dtau_ps)).unwrap();
    const SEEDS: u64 = 8;
    let (mut truth, mut ibr, mut capture): (Frames, Frames, Frames) = Default::default();
    let mut allowance = vec![vec![0.0f64; w * h]; frames];
    let mut shifted = Vec::new();
    for seed in 1..=SEEDS {
        let cap = dir.path().join(format!("cap{seed}"));
        let seed_text = seed.to_string();
        let run = femto_ok(&[
            "simulate",
            "--size",
            "64x48",
            "--spp",
            "64",
            "--seed",
            &seed_text,
            "--truth-path",
            arg(&path_file),
            "--out",
            arg(&cap),
        ]);
        assert!(
            run.stdout.contains("truth: frames 0..3 of 64x48 at 64 spp"),
            "{}",
            run.stdout
        );
        let world = dir.path().join(format!("world{seed}.h5"));
        let (cal, mesh, camera) = (
            cap.join("calibration.toml"),
            cap.join("scene.glb"),
            cap.join("truth_camera.h5"),
        );
        let geometry = ["--calibration", arg(&cal), "--mesh", arg(&mesh)];
        let mut unwarp = vec!["unwarp", arg(&camera), "--out", arg(&world)];
        unwarp.extend_from_slice(&geometry);
        femto_ok(&unwarp);
        if seed == 1 {
            let cube = read_cube(&world).unwrap();
            shifted = (0..w * h).map(|p| cube.is_valid(p % w, p / w)).collect();
        }
        let out = dir.path().join(format!("ibr{seed}"));
        let mut render = vec!["render", "--cube", arg(&world), "--path", arg(&path_file)];
        render.extend_from_slice(&geometry);
        render.extend_from_slice(&["--format", "exr", "--out", arg(&out)]);
        femto_ok(&render);
        let frame = |d: &Path, k: usize| luminance_frame(&d.join(format!("frame_{k:05}.exr")));
        truth.push((0..frames).map(|k| frame(&cap.join("truth"), k)).collect());
        ibr.push((0..frames).map(|k| frame(&out, k)).collect());
        // The camera-time cube's window sums (the truth's colour has luminance 1).
        let cube = read_cube(&cap.join("truth_camera.h5")).unwrap();
        let (a, nt) = (cube.axis, cube.axis.nt);
        let edge = |t: f64| {
            let i = (t - a.t0_ps) / a.dt_ps;
            assert!((i - i.round()).abs() < 1e-9 && i >= 1.0 && i < nt as f64 - 2.0);
            i.round() as usize
        };
        let mut sums = Vec::new();
        for (k, allowance) in allowance.iter_mut().enumerate() {
            let t = t0_ps + k as f64 * dtau_ps;
            let (i0, i1) = (edge(t), edge(t + dtau_ps));
            let mut f = vec![0.0; w * h];
            for (p, v) in f.iter_mut().enumerate() {
                let bins = &cube.data[p * nt..(p + 1) * nt];
                *v = bins[i0..i1].iter().map(|&b| b as f64).sum::<f64>() / dtau_ps;
                let step = |i: usize| {
                    (i - 1..=i + 1)
                        .map(|j| (bins[j + 1] as f64 - bins[j] as f64).abs())
                        .fold(0.0, f64::max)
                };
                allowance[p] += 0.5 * (step(i0) + step(i1)) / dtau_ps / SEEDS as f64;
            }
            sums.push(f);
        }
        capture.push(sums);
    }
    let none = vec![vec![0.0; w * h]; frames];
    let all = vec![true; w * h];
    let (groups, over, pooled) = group_test(&capture, &truth, &none, &all, w, h);
    assert!(groups >= 150, "{groups} lit groups");
    // Student's t with 7 degrees of freedom per side exceeds 3.5 in about 1 % of groups.
    assert!(
        over * 20 <= groups,
        "truth against the capture: {over} of {groups} groups"
    );
    assert!(
        pooled.abs() < 4.0,
        "truth against the capture: pooled z {pooled:.2}"
    );
    // The pixels the unwarp masked as mixed (footprints spanning more than 4 bins of path)
    // are black in the render: they are the holes docs/truth.md counts, not compared here.
    let kept = shifted.iter().filter(|k| **k).count();
    assert!(kept * 2 > w * h, "{kept} of {} pixels shifted", w * h);
    let (groups, over, pooled) = group_test(&truth, &ibr, &allowance, &shifted, w, h);
    assert!(
        over * 20 <= groups,
        "render against the truth: {over} of {groups} groups"
    );
    assert!(
        pooled.abs() < 4.0,
        "render against the truth: pooled z {pooled:.2}"
    );
}

/// Truth frames depend only on their index and the seed: frames 1..3 of a split run equal
/// the same frames of a whole run, bit for bit; and a bad truth path is refused before
/// anything is traced or written.
#[test]
fn truth_frames_split_alike_and_bad_paths_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path_file = dir.path().join("still.toml");
    std::fs::write(&path_file, still_path(16, 12, 4, 3600.0, 60.0)).unwrap();
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--size",
            "16x12",
            "--spp",
            "8",
            "--truth-path",
            arg(&path_file),
            "--out",
        ];
        let out = dir.path().join(out);
        args.push(arg(&out));
        args.extend_from_slice(extra);
        femto_ok(&args);
        out.join("truth")
    };
    let whole = run("whole", &[]);
    let part = run("part", &["--frames", "1..3"]);
    let names: Vec<String> = std::fs::read_dir(&part)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
    for k in 1..3 {
        for ext in ["exr", "png"] {
            let name = format!("frame_{k:05}.{ext}");
            assert_eq!(
                std::fs::read(whole.join(&name)).unwrap(),
                std::fs::read(part.join(&name)).unwrap(),
                "{name}"
            );
        }
    }
    // A path through the cube, a frame range beyond the path, a missing file, and with
    // --transient-only: refused naming the flag, nothing written.
    let through = dir.path().join("through.toml");
    // The second keyframe, at the last frame's time, is under the floor.
    let still = still_path(16, 12, 2, 3600.0, 60.0).replace("13600", "3660");
    let last = still.rfind("[0.0, 0.22, 0.85]").unwrap();
    std::fs::write(
        &through,
        format!("{}[0.0, -0.2, 0.0]{}", &still[..last], &still[last + 17..]),
    )
    .unwrap();
    let cases: [(&[&str], &str); 4] = [
        (&["--truth-path", arg(&through)], "--truth-path"),
        (
            &["--truth-path", arg(&path_file), "--frames", "2..9"],
            "--frames",
        ),
        (&["--truth-path", "no/such/path.toml"], "--truth-path"),
        (
            &["--truth-path", arg(&path_file), "--transient-only"],
            "--truth-path",
        ),
    ];
    for (extra, flag) in cases {
        let mut args = vec!["simulate", "--size", "16x12", "--spp", "4", "--out", "new"];
        args.extend_from_slice(extra);
        refused_unchanged(dir.path(), &args, &[], &[flag]);
    }
}

/// `femto compare` of a render with itself finds no error; of a truth with a render, the
/// table it prints has a line per frame and the pooled line, and error images are written.
#[test]
fn compare_measures_frames_and_writes_error_images() {
    let dir = tempfile::tempdir().unwrap();
    let path_file = dir.path().join("still.toml");
    std::fs::write(&path_file, still_path(16, 12, 3, 3500.0, 100.0)).unwrap();
    let cap = dir.path().join("cap");
    femto_ok(&[
        "simulate",
        "--size",
        "16x12",
        "--spp",
        "16",
        "--truth-path",
        arg(&path_file),
        "--out",
        arg(&cap),
    ]);
    let truth = cap.join("truth");
    let same = femto_ok(&["compare", "--truth", arg(&truth), "--render", arg(&truth)]);
    let all = same.stdout.lines().last().unwrap().to_string();
    assert!(all.starts_with("all"), "{}", same.stdout);
    let fields: Vec<&str> = all.split_whitespace().collect();
    assert_eq!(&fields[3..6], &["0.0000", "0.0000", "0.0000"], "{all}");
    let errors = dir.path().join("errors");
    let with_out = |out: &Path| {
        let truth = arg(&truth);
        vec!["compare", "--truth", truth, "--render", truth, "--out"]
            .into_iter()
            .map(String::from)
            .chain([arg(out).to_string()])
            .collect::<Vec<String>>()
    };
    let args = with_out(&errors);
    let run = femto_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(run.stdout.lines().count(), 2 + 3 + 1, "{}", run.stdout);
    for k in 0..3 {
        assert!(errors.join(format!("frame_{k:05}.png")).is_file());
    }
    // The output may not be an input, nor replace frames without --force.
    for out in [&truth, &errors] {
        let args = with_out(out);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused_unchanged(dir.path(), &args, &[], &["--out"]);
    }
}
