//! Every SIMD path this CPU runs, forced at run time and compared with the scalar one
//! (issue 20, "every code path tested"): through the library ([`Bvh::with_simd`], which the
//! tracer's rows follow) and through the `femto` binary with `FEMTO_SIMD`, as a user runs it.
//!
//! What is compared, and why bit for bit: `scalar` and `sse` share the four-wide tree and
//! `avx2` and `avx512` the eight-wide one; every lane computes the scalar watertight
//! triangle test and slab test with the same IEEE operations (no fused multiply-add), and
//! the tracer's two row builds compute the same operations in the same order, so the cubes
//! agree bit for bit. Across the two trees the hits have the same distance bit for bit and
//! may differ only in which of two triangles at exactly the same distance is reported
//! (`src/geometry/bvh/tests.rs` checks that on random rays); on these scenes no such tie
//! changes a cube, so the tests ask for identical cubes and files there too. A level this
//! CPU lacks is `#[ignore]`d with the reason (`cfg(femto_host_*)` from `build.rs`).

#[path = "common/cli.rs"]
mod cli;

use cli::{files_under, FemtoCmd};
use femto::cube::Cube;
use femto::geometry::bvh::Bvh;
use femto::geometry::simd_level::{SimdError, SimdLevel};
use femto::scene::Scene;
use femto::tracer::{trace, TraceOptions, TransientRender};
use std::path::Path;

/// The cornell scene at 12 x 8 pixels, 96 bins, 16 paths per pixel, every output cube, with
/// the BVH (and so the tracer's rows) forced to `level`.
fn render(level: SimdLevel) -> TransientRender {
    let scene = Scene::builtin("cornell", None)
        .unwrap()
        .with_resolution(12, 8, 96, 8.0);
    let bvh =
        Bvh::with_simd(scene.mesh.clone(), Some(level)).unwrap_or_else(|e| panic!("{level}: {e}"));
    let opts = TraceOptions {
        spp: 16,
        ..TraceOptions::default()
    };
    trace(&scene, &bvh, &opts, &|_| {})
}

/// `level`'s cubes (camera time, one-bounce, multi-bounce, world time) and counters are the
/// scalar level's, bit for bit.
fn renders_the_scalar_cubes(level: SimdLevel) {
    let (got, want) = (render(level), render(SimdLevel::Scalar));
    fn cubes(r: &TransientRender) -> [&Cube; 4] {
        [
            Some(&r.camera_time),
            r.direct.as_ref(),
            r.multi.as_ref(),
            r.world_time.as_ref(),
        ]
        .map(|c| c.expect("every cube asked for"))
    }
    for (name, (a, b)) in ["camera", "direct", "multi", "world"]
        .iter()
        .zip(cubes(&got).into_iter().zip(cubes(&want)))
    {
        assert!(b.data.iter().any(|&v| v > 0.0), "{name} is empty");
        let differ = a
            .data
            .iter()
            .zip(&b.data)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(
            differ, 0,
            "{level}: {differ} values of the {name} cube differ"
        );
    }
    let (mut sa, mut sb) = (got.stats, want.stats);
    (sa.seconds, sb.seconds) = (0.0, 0.0);
    (sa.cpu_seconds, sb.cpu_seconds) = (0.0, 0.0);
    assert_eq!(sa, sb, "{level}: counters");
}

#[test]
fn scalar_render_is_deterministic() {
    renders_the_scalar_cubes(SimdLevel::Scalar);
}

#[cfg(target_arch = "x86_64")]
#[test]
fn sse_renders_the_scalar_cubes_bit_for_bit() {
    renders_the_scalar_cubes(SimdLevel::Sse);
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(
    not(femto_host_avx2),
    ignore = "needs AVX2, BMI1/2, LZCNT and POPCNT (not on this CPU)"
)]
fn avx2_renders_the_scalar_cubes_bit_for_bit() {
    renders_the_scalar_cubes(SimdLevel::Avx2);
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(
    not(femto_host_avx512),
    ignore = "needs AVX-512 F and VL with AVX2 and BMI (not on this CPU)"
)]
fn avx512_renders_the_scalar_cubes_bit_for_bit() {
    renders_the_scalar_cubes(SimdLevel::Avx512);
}

/// `femto simulate` of a small capture with `FEMTO_SIMD=value`, in its own folder under
/// `tmp` (the same relative `--out` for every value, so the recorded command lines agree).
fn simulate(tmp: &Path, value: &str) -> cli::Run {
    let dir = tmp.join(value);
    std::fs::create_dir_all(&dir).unwrap();
    FemtoCmd::new()
        .current_dir(&dir)
        .env("FEMTO_SIMD", value)
        .args([
            "simulate",
            "--out",
            "cap",
            "--size",
            "16x12",
            "--nt",
            "48",
            "--dt-ps",
            "20",
            "--spp",
            "4",
            "--bounces",
            "3",
        ])
        .run()
}

#[test]
fn femto_simd_forces_each_path_of_the_binary_and_the_files_are_identical() {
    let tmp = tempfile::tempdir().unwrap();
    let scalar = simulate(tmp.path(), "scalar");
    assert_eq!(scalar.code, Some(0), "{}", scalar.stderr);
    let want = files_under(&tmp.path().join("scalar/cap"));
    assert!(want.len() > 5, "{:?}", want.keys());
    let mut ran = vec!["scalar"];
    for level in SimdLevel::ALL.into_iter().skip(1) {
        if !level.is_supported() {
            // Refused (see `a_level_this_cpu_lacks_is_refused`); the others still compare.
            continue;
        }
        let run = simulate(tmp.path(), level.name());
        assert_eq!(run.code, Some(0), "{level}: {}", run.stderr);
        let got = files_under(&tmp.path().join(level.name()).join("cap"));
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            want.keys().collect::<Vec<_>>()
        );
        for (path, bytes) in &want {
            assert!(
                bytes == &got[path],
                "FEMTO_SIMD={level}: {} differs from scalar",
                path.display()
            );
        }
        ran.push(level.name());
    }
    // `auto` too: whatever it picks is one of the above.
    let auto = simulate(tmp.path(), "auto");
    assert_eq!(auto.code, Some(0), "{}", auto.stderr);
    assert_eq!(files_under(&tmp.path().join("auto/cap")), want);
    println!("compared with scalar: {} and auto", ran.join(", "));
}

#[test]
fn an_unknown_femto_simd_is_refused_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    for bad in ["neon", "avx", "sse4"] {
        let run = simulate(tmp.path(), bad);
        assert_eq!(run.code, Some(2), "{bad}: {}", run.stderr);
        let line = run.stderr.trim();
        assert_eq!(line.lines().count(), 1, "{line}");
        assert!(line.contains("FEMTO_SIMD") && line.contains(bad), "{line}");
        assert!(!tmp.path().join(bad).join("cap").exists());
    }
}

#[test]
#[cfg_attr(
    femto_host_avx512,
    ignore = "this CPU runs every level, so none can be refused here"
)]
fn a_level_this_cpu_lacks_is_refused() {
    let lacking: Vec<SimdLevel> = SimdLevel::ALL
        .into_iter()
        .filter(|l| !l.is_supported())
        .collect();
    assert!(
        !lacking.is_empty(),
        "built where a level was missing, run where none is"
    );
    let tmp = tempfile::tempdir().unwrap();
    for level in lacking {
        let err = Bvh::with_simd(Default::default(), Some(level)).unwrap_err();
        assert!(matches!(err, SimdError::Unsupported { .. }), "{err}");
        let run = simulate(tmp.path(), level.name());
        assert_eq!(run.code, Some(2), "{level}: {}", run.stderr);
        let line = run.stderr.trim();
        assert_eq!(line.lines().count(), 1, "{line}");
        assert!(
            line.contains("lacks") && line.contains(level.name()),
            "{line}"
        );
        assert!(!tmp.path().join(level.name()).join("cap").exists());
    }
}

/// The library's own constructor reads `FEMTO_SIMD` (once per process: no other test of
/// this file calls `Bvh::new`, and the `femto` runs above set it for their own process).
#[test]
fn bvh_new_follows_femto_simd() {
    std::env::set_var("FEMTO_SIMD", "scalar");
    let bvh = Bvh::new(Scene::builtin("cornell", None).unwrap().mesh);
    assert_eq!(bvh.simd(), Some(SimdLevel::Scalar));
}
