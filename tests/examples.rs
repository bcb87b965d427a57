//! The example files and the walkthrough (issue 15, item 7), checked as a user would use them:
//! every camera path in `examples/paths/` loads, keeps below the speed of light and renders
//! light in every frame on a simulated capture of the built-in `cube` scene; every
//! correspondences file in `examples/points/` loads (the TOML and CSV forms alike) and
//! calibrates that capture; and the practice run of `docs/walkthrough.md` (its `sh` blocks)
//! runs command by command as written.

#[path = "common/cli.rs"]
mod cli;

use cli::{arg, femto_in, femto_ok};
use femto::calibrate::load_points;
use femto::camera::Calibration;
use femto::camera_path::CameraPath;
use femto::relativity::RotationAxis;
use nalgebra::Vector2;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The files of `examples/<sub>` with extension `ext`, sorted.
fn example_files(sub: &str, ext: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("examples").join(sub))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    files
}

fn stem(p: &Path) -> String {
    p.file_stem().unwrap().to_string_lossy().into_owned()
}

#[test]
fn every_example_path_loads_with_frames_and_speeds_below_c() {
    let files = example_files("paths", "toml");
    let names: Vec<String> = files.iter().map(|p| stem(p)).collect();
    for want in ["dolly", "keyframes", "orbit", "roll"] {
        assert!(names.iter().any(|n| n == want), "{want}.toml in {names:?}");
    }
    for file in &files {
        let path = CameraPath::load(file).unwrap_or_else(|e| panic!("{e}"));
        let spec = path.spec();
        assert!(spec.frames > 0 && spec.width > 0 && spec.height > 0);
        let half = Vector2::new(0.5 * spec.width as f64, 0.5 * spec.height as f64);
        let mut fastest: f64 = 0.0;
        for k in 0..spec.frames {
            let f = path.frame(k);
            // The camera, and with a rotating sensor every corner of it.
            for offset in [
                Vector2::zeros(),
                half,
                -half,
                Vector2::new(half.x, -half.y),
                Vector2::new(-half.x, half.y),
            ] {
                fastest = fastest.max(f.pixel_beta(&offset, &half).norm());
            }
        }
        assert!(fastest < 1.0, "{}: |beta| {fastest}", file.display());
        println!(
            "{}: {} frames of {}x{}, fastest |beta| {fastest:.3}",
            stem(file),
            spec.frames,
            spec.width,
            spec.height
        );
        match stem(file).as_str() {
            // The seed's Fig. 8: a sensor rolling about the optical axis.
            "roll" => assert_eq!(path.rotation().map(|r| r.axis), Some(RotationAxis::Roll)),
            // The others move: the fastest point is the camera itself.
            _ => assert!(path.rotation().is_none() && fastest > 0.1, "{fastest}"),
        }
    }
}

#[test]
fn every_example_points_file_loads_and_each_toml_matches_its_csv() {
    let toml = example_files("points", "toml");
    let csv = example_files("points", "csv");
    assert!(!toml.is_empty() && !csv.is_empty(), "{toml:?} {csv:?}");
    for file in toml.iter().chain(csv.iter()) {
        let points = load_points(file).unwrap_or_else(|e| panic!("{e}"));
        // Enough for a fit of unknown intrinsics.
        assert!(
            points.len() >= 6,
            "{}: {} points",
            file.display(),
            points.len()
        );
    }
    for t in &toml {
        let c = t.with_extension("csv");
        assert!(c.exists(), "{} has no CSV twin", t.display());
        assert_eq!(load_points(t).unwrap(), load_points(&c).unwrap());
    }
}

/// Share of the pixels of an 8-bit RGB PNG with a channel above 8 (of 255).
fn lit_fraction(png: &Path) -> f64 {
    let img = image::open(png)
        .unwrap_or_else(|e| panic!("{}: {e}", png.display()))
        .to_rgb8();
    let lit = img.pixels().filter(|p| p.0.iter().any(|&v| v > 8)).count();
    lit as f64 / (img.width() * img.height()) as f64
}

/// A clean capture of the cube scene (64 x 48 pixels, direct and one-bounce light), ingested
/// and unwarped with the simulator's true calibration: `(world cube, calibration, mesh)`.
fn cube_scene_world(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let cap = dir.join("cap");
    femto_ok(&[
        "simulate",
        "--scene",
        "cube",
        "--size",
        "64x48",
        "--spp",
        "16",
        "--bounces",
        "2",
        "--out",
        arg(&cap),
    ]);
    let camera = dir.join("camera.h5");
    femto_ok(&["ingest", arg(&cap), "-o", arg(&camera)]);
    let (cal, mesh) = (cap.join("calibration.toml"), cap.join("scene.glb"));
    let world = dir.join("world.h5");
    // Every pixel kept: these tests are about the paths' timing against the scene's light.
    // At 64 x 48 the default mask takes out the floor (its footprints span 9 bins of path
    // and more, docs/truth.md), whose light comes first and last.
    femto_ok(&[
        "unwarp",
        arg(&camera),
        "--calibration",
        arg(&cal),
        "--mesh",
        arg(&mesh),
        "--mask-spread-bins",
        "inf",
        "-o",
        arg(&world),
    ]);
    (world, cal, mesh)
}

#[test]
fn every_example_path_shows_light_in_every_frame_of_a_cube_scene_capture() {
    let dir = tempfile::tempdir().unwrap();
    let (world, cal, mesh) = cube_scene_world(dir.path());
    for file in example_files("paths", "toml") {
        let name = stem(&file);
        let frames = CameraPath::load(&file).unwrap().spec().frames;
        let out = dir.path().join(&name);
        // Every frame of the path, at the capture's size.
        let run = femto_ok(&[
            "render",
            "--cube",
            arg(&world),
            "--calibration",
            arg(&cal),
            "--mesh",
            arg(&mesh),
            "--path",
            arg(&file),
            "--size",
            "64x48",
            "--laser-nm",
            "795",
            "--format",
            "png",
            "--out",
            arg(&out),
        ]);
        assert!(!run.stderr.contains("entirely black"), "{}", run.stderr);
        let lit: Vec<f64> = (0..frames)
            .map(|k| lit_fraction(&out.join(format!("frame_{k:05}.png"))))
            .collect();
        let dark: Vec<usize> = (0..frames).filter(|&k| lit[k] < 0.002).collect();
        println!(
            "{name}: lit share per frame {:.3} (first) .. {:.3} (last), least {:.3}",
            lit[0],
            lit[frames - 1],
            lit.iter().cloned().fold(f64::INFINITY, f64::min)
        );
        assert!(
            dark.is_empty(),
            "{name}: frames {dark:?} show (almost) no light: {lit:?}"
        );
    }
}

#[test]
fn example_points_calibrate_the_cube_scene() {
    let dir = tempfile::tempdir().unwrap();
    let cap = dir.path().join("cap");
    femto_ok(&[
        "simulate",
        "--scene",
        "cube",
        "--spp",
        "16",
        "--bounces",
        "2",
        "--out",
        arg(&cap),
    ]);
    let cube = dir.path().join("cube.h5");
    femto_ok(&["ingest", arg(&cap), "-o", arg(&cube)]);
    let truth = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let dt_ps = femto::container::read_meta(&cube).unwrap().axis.dt_ps;
    for points in example_files("points", "toml")
        .into_iter()
        .chain(example_files("points", "csv"))
    {
        let out = dir.path().join(format!(
            "{}.calibration.toml",
            points.file_name().unwrap().to_string_lossy()
        ));
        // The command given in the example's header.
        femto_ok(&[
            "calibrate",
            arg(&cube),
            "--mesh",
            arg(&cap.join("scene.glb")),
            "--points",
            arg(&points),
            "--laser",
            "-0.13,0.06,-0.07",
            "--square-pixels",
            "--centred-principal-point",
            "--out",
            arg(&out),
        ]);
        let fit = Calibration::load(&out).unwrap();
        let centre_mm = 1e3 * (fit.pose.position_m - truth.pose.position_m).norm();
        let t0_ps = fit.t0_ps - truth.t0_ps;
        println!(
            "{}: camera centre {centre_mm:.3} mm from the truth, t0 {t0_ps:+.3} ps",
            points.display()
        );
        assert!(centre_mm < 1.0, "{centre_mm} mm");
        assert!(t0_ps.abs() < 0.25 * dt_ps, "{t0_ps} ps");
    }
}

// ---------------------------------------------------------------------------------------------
// The walkthrough's practice run.

/// The command lines of the `sh` code blocks of a Markdown text, `\` continuations joined.
fn sh_commands(markdown: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_sh = false;
    let mut pending = String::new();
    for line in markdown.lines() {
        let t = line.trim();
        if t.starts_with("```") {
            in_sh = t == "```sh";
            continue;
        }
        if !in_sh || t.is_empty() || t.starts_with('#') {
            continue;
        }
        match t.strip_suffix('\\') {
            Some(head) => {
                pending.push_str(head);
                pending.push(' ');
            }
            None => {
                pending.push_str(t);
                out.push(std::mem::take(&mut pending));
            }
        }
    }
    out
}

/// Shell words: blanks separate, single or double quotes group (no escapes, no expansion;
/// the walkthrough uses no more).
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word: Option<String> = None;
    let mut quote: Option<char> = None;
    for ch in line.chars() {
        match quote {
            Some(q) if ch == q => quote = None,
            Some(_) => word.get_or_insert_with(String::new).push(ch),
            None if ch == '\'' || ch == '"' => {
                quote = Some(ch);
                word.get_or_insert_with(String::new);
            }
            None if ch.is_whitespace() => words.extend(word.take()),
            None => word.get_or_insert_with(String::new).push(ch),
        }
    }
    assert!(quote.is_none(), "unbalanced quote in: {line}");
    words.extend(word);
    words
}

/// Set `flag`'s value in `args` (replacing it, or appending the pair).
fn set_flag(args: &mut Vec<String>, flag: &str, value: &str) {
    match args.iter().position(|a| a == flag) {
        Some(i) => args[i + 1] = value.to_string(),
        None => args.extend([flag.to_string(), value.to_string()]),
    }
}

#[test]
fn walkthrough_practice_run_runs_as_written() {
    let text = std::fs::read_to_string(repo().join("docs/walkthrough.md")).unwrap();
    let commands = sh_commands(&text);
    let verbs: Vec<String> = commands
        .iter()
        .map(|c| shell_words(c).get(1).cloned().unwrap_or_default())
        .collect();
    for verb in [
        "simulate",
        "info",
        "ingest",
        "calibrate",
        "unwarp",
        "pyramid",
        "render",
    ] {
        assert!(
            verbs.iter().any(|v| v == verb),
            "no femto {verb} in {verbs:?}"
        );
    }
    let dolly_path = commands
        .iter()
        .filter(|c| c.contains("--path examples/paths/dolly.toml"))
        .count();
    assert_eq!(dolly_path, 1, "one render of the dolly example path");

    let dir = tempfile::tempdir().unwrap();
    let examples = repo().join("examples");
    for line in &commands {
        let mut args = shell_words(line);
        assert_eq!(
            args[0], "femto",
            "a sh block line that is not a femto command: {line}"
        );
        args.remove(0);
        for a in args.iter_mut() {
            if let Some(rest) = a.strip_prefix("examples/") {
                *a = examples.join(rest).to_string_lossy().into_owned();
            }
        }
        if args[0] == "render" {
            // Small and short: the commands are checked, not the pictures.
            set_flag(&mut args, "--size", "64x48");
            set_flag(&mut args, "--frame-count", "8");
        }
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let run = femto_in(Some(dir.path()), &refs);
        assert_eq!(
            run.code,
            Some(0),
            "femto {line}\n{}{}",
            run.stdout,
            run.stderr
        );
        if args[0] == "render" {
            // The wavelength given to ingest reaches the renderer through the cube.
            assert!(run.stderr.contains("795 nm"), "{line}: {}", run.stderr);
        }
        if args[0] == "ingest" {
            // The --value-scale the walkthrough gives is the capture's own (its manifest's
            // png_value_per_count), so that the dark frame's signal values match.
            let manifest =
                std::fs::read_to_string(dir.path().join("out/capture/manifest.toml")).unwrap();
            let scale: f64 = manifest
                .lines()
                .find_map(|l| l.strip_prefix("png_value_per_count = "))
                .unwrap()
                .parse()
                .unwrap();
            let i = args.iter().position(|a| a == "--value-scale").unwrap();
            let given: f64 = args[i + 1].parse().unwrap();
            assert!((given / scale - 1.0).abs() < 1e-12, "{given} vs {scale}");
        }
    }
    // What the walkthrough says each step writes.
    let out = dir.path().join("out");
    for file in [
        "cube.h5",
        "cube.calibration.toml",
        "world.h5",
        "capture_view.mp4",
        "dolly_shortcut.mp4",
        "dolly.mp4",
    ] {
        let len = std::fs::metadata(out.join(file))
            .unwrap_or_else(|e| panic!("out/{file}: {e}"))
            .len();
        assert!(len > 0, "out/{file} is empty");
    }
    // "the fit lands within 1 ps of" the truth, t0 = 0.
    let fit = Calibration::load(&out.join("cube.calibration.toml")).unwrap();
    let truth = Calibration::load(&out.join("capture/calibration.toml")).unwrap();
    println!(
        "walkthrough: t0 {:+.3} ps (truth {})",
        fit.t0_ps, truth.t0_ps
    );
    assert!((fit.t0_ps - truth.t0_ps).abs() < 1.0, "{}", fit.t0_ps);
}

#[test]
fn the_walkthrough_reader_splits_commands_as_a_shell_would() {
    let md = "text\n```sh\nfemto ingest 'a b/*.img' -o x.h5\nfemto render --cube w.h5 \\\n    --out v.mp4\n```\n```text\nfemto not this one\n```\n";
    let cmds = sh_commands(md);
    assert_eq!(
        cmds,
        vec![
            "femto ingest 'a b/*.img' -o x.h5",
            "femto render --cube w.h5  --out v.mp4"
        ]
    );
    assert_eq!(
        shell_words(&cmds[0]),
        vec!["femto", "ingest", "a b/*.img", "-o", "x.h5"]
    );
    assert_eq!(
        shell_words(&cmds[1]),
        vec!["femto", "render", "--cube", "w.h5", "--out", "v.mp4"]
    );
    let mut args: Vec<String> = vec!["render".into(), "--size".into(), "320x240".into()];
    set_flag(&mut args, "--size", "64x48");
    set_flag(&mut args, "--frame-count", "8");
    assert_eq!(args, ["render", "--size", "64x48", "--frame-count", "8"]);
}

/// The body of the first code block of `markdown` fenced as ```` ```lang ````.
fn first_block(markdown: &str, lang: &str) -> String {
    let fence = format!("```{lang}");
    let start = markdown
        .lines()
        .position(|l| l.trim() == fence)
        .unwrap_or_else(|| panic!("no {fence} block"));
    markdown
        .lines()
        .skip(start + 1)
        .take_while(|l| l.trim() != "```")
        .map(|l| format!("{l}\n"))
        .collect()
}

#[test]
fn the_format_pages_examples_parse() {
    let doc = |name: &str| std::fs::read_to_string(repo().join("docs").join(name)).unwrap();
    let paths = doc("camera-path.md");
    let path = CameraPath::from_toml(&first_block(&paths, "toml"), "camera-path.md")
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(path.rotation().is_some() && path.spec().frames > 0);
    let points = doc("correspondences.md");
    let from_toml = femto::calibrate::points::parse_points_toml(
        &first_block(&points, "toml"),
        "correspondences.md",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let from_csv = femto::calibrate::points::parse_points_csv(
        &first_block(&points, "csv"),
        "correspondences.md",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(from_toml.len(), 2);
    // The CSV block shows the same two points, named.
    assert_eq!(
        from_csv
            .iter()
            .map(|p| (p.pixel, p.point_m))
            .collect::<Vec<_>>(),
        from_toml
            .iter()
            .map(|p| (p.pixel, p.point_m))
            .collect::<Vec<_>>()
    );
}
