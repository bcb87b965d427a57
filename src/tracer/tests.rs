//! Unit tests of the tracer's row loop and path kernel: the undistorted pixel matrix, the
//! wide-ISA rows against the baseline rows, the triangle bases and the path window.

use super::path::*;
use super::sampling::*;
use super::*;
use nalgebra::Vector3;

#[test]
fn pixel_matrix_gives_the_camera_rays() {
    // The undistorted fast path agrees with Intrinsics::camera_ray rotated to the world,
    // at corners, centre and interior points of the image.
    let scene = Scene::builtin("cornell", None).unwrap();
    let cam = &scene.camera;
    let m = world_from_pixel(cam).expect("the built-in camera has no distortion");
    let (w, h) = (cam.intrinsics.width as f64, cam.intrinsics.height as f64);
    for (u, v) in [
        (0.0, 0.0),
        (w, h),
        (0.5 * w, 0.5 * h),
        (3.25, 40.5),
        (w, 0.0),
    ] {
        let expected = cam.pose.world_from_camera * cam.intrinsics.camera_ray(u, v).into_inner();
        let got = (m * Vector3::new(u as f32, v as f32, 1.0)).normalize();
        assert!((got.cast::<f64>() - expected).norm() < 1e-6, "({u}, {v})");
    }
    let mut distorted = *cam;
    distorted.intrinsics.k1 = 0.1;
    assert!(world_from_pixel(&distorted).is_none());
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(
    not(femto_host_avx2),
    ignore = "needs AVX2, BMI1/2, LZCNT and POPCNT (not on this CPU)"
)]
fn wide_isa_rows_are_bit_identical_to_baseline_rows() {
    // The x86-64-v3 builds of the row renderer (with GFNI where the CPU has it) compute the
    // same operations in the same order as the baseline one: every cube (camera, split,
    // world time) agrees bit for bit, and the counters agree.
    let scene = Scene::builtin("cornell", None)
        .unwrap()
        .with_resolution(8, 6, 120, 4.0);
    let bvh = Bvh::new(scene.mesh.clone());
    let opts = TraceOptions {
        spp: 16,
        ..TraceOptions::default()
    };
    let mut tracer = Tracer::new(&scene, &bvh, &opts);
    assert!(
        SimdLevel::Avx2.is_supported(),
        "built on a CPU with AVX2 and BMI, run on one without"
    );
    // The CPU runs the v3 rows (its features are those of the `avx2` level), whatever
    // FEMTO_SIMD made `Tracer::new` choose; and the GFNI rows where it has GFNI.
    tracer.row_isa = RowIsa::Baseline;
    let base = tracer.render_rows(0..6, &|_| {});
    let mut builds = vec![RowIsa::V3];
    if is_x86_feature_detected!("gfni") {
        builds.push(RowIsa::V3Gfni);
    } else {
        eprintln!("skipped the GFNI rows: this CPU has no GFNI");
    }
    for build in builds {
        tracer.row_isa = build;
        let wide = tracer.render_rows(0..6, &|_| {});
        let bits = |c: &Cube| c.data.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
        let cubes = |r: &TransientRender| {
            [
                Some(r.camera_time.clone()),
                r.direct.clone(),
                r.multi.clone(),
                r.world_time.clone(),
            ]
        };
        for (a, b) in cubes(&wide).iter().zip(cubes(&base).iter()) {
            let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
            assert!(a.data.iter().any(|&v| v > 0.0));
            assert_eq!(bits(a), bits(b));
        }
        let (mut sw, mut sb) = (wide.stats, base.stats);
        (sw.seconds, sb.seconds) = (0.0, 0.0);
        (sw.cpu_seconds, sb.cpu_seconds) = (0.0, 0.0);
        assert_eq!(sw, sb);
    }
}

#[test]
fn triangle_bases_are_those_of_the_hit_normals() {
    // The per-triangle basis the kernel precomputes is, bit for bit, the basis of the
    // normal the BVH reports for hits on that triangle (so shading with it is the same
    // as computing it per hit), for rays in all directions from inside the room.
    let scene = Scene::builtin("cornell", None).unwrap();
    let bvh = Bvh::new(scene.mesh.clone());
    let k = kernel(&scene, &bvh, &TraceOptions::default());
    let mut rng = pixel_rng(3, Stream::Steady, 0);
    let mut seen = std::collections::HashSet::new();
    for _ in 0..4000 {
        let (u1, u2) = uniform_pair(&mut rng);
        let z = 1.0 - 2.0 * u1;
        let phi = 2.0 * std::f32::consts::PI * u2;
        let rxy = (1.0 - z * z).max(0.0).sqrt();
        let dir = Vector3::new(rxy * phi.cos(), rxy * phi.sin(), z);
        let Some(hit) = bvh.intersect(&Ray::new(k.laser_m, dir), 0.0, f32::INFINITY) else {
            continue;
        };
        let s = &k.shading[hit.triangle as usize];
        let (t, b) = orthonormal_basis(&hit.normal);
        assert_eq!(
            (s.tangent, s.bitangent),
            (t, b),
            "triangle {}",
            hit.triangle
        );
        seen.insert(hit.triangle);
    }
    assert!(seen.len() > 20, "{}", seen.len());
}

/// Every contribution of 256 paths of one pixel, each path's random stream started
/// afresh: `(path, bounce, first_m, path_m, value)`.
fn contributions(k: &PathKernel, window: &PathWindow) -> Vec<(u32, u32, f64, f64, f64)> {
    let mut out = Vec::new();
    let ld = PixelSampler::new(1, Stream::Transient, 7, 256);
    for i in 0..256 {
        let mut rng = pixel_rng(1, Stream::Transient, 1000 + i as u64);
        let (du, dv) = ld.sample(i, 0);
        let (u, v) = (20.0 + du as f64, 30.0 + dv as f64);
        k.trace_path(&mut rng, &ld, i, (u, v), window, &mut |c: Contribution| {
            out.push((i, c.bounce, c.first_m, c.path_m, c.value))
        });
    }
    out
}

#[test]
fn a_window_drops_exactly_the_contributions_outside_it() {
    // The same paths traced without a window and with one (camera time, and camera plus
    // world time) give exactly the unwindowed contributions that land inside it: ending
    // a path whose length plus the straight line to the spot is already past the window
    // loses nothing that could land in it.
    let scene = Scene::builtin("cornell", None).unwrap();
    let bvh = Bvh::new(scene.mesh.clone());
    let opts = TraceOptions {
        max_bounces: 8,
        rr_start_bounce: 8,
        ..TraceOptions::default()
    };
    let k = kernel(&scene, &bvh, &opts);
    let all = contributions(&k, &PathWindow::UNBOUNDED);
    assert!(all.iter().any(|c| c.1 >= 5), "long paths are sampled");
    let lo = all.iter().map(|c| c.3).fold(f64::INFINITY, f64::min);
    let hi = all.iter().map(|c| c.3).fold(0.0, f64::max);
    let narrow = (lo + 0.2 * (hi - lo), lo + 0.4 * (hi - lo));
    for window in [
        PathWindow {
            camera_m: narrow,
            world_m: None,
        },
        PathWindow {
            camera_m: narrow,
            world_m: Some((narrow.0 - 0.5, narrow.1 - 0.3)),
        },
    ] {
        let kept = contributions(&k, &window);
        let expected: Vec<_> = all
            .iter()
            .filter(|c| {
                let (a, b) = window.bounds_m(c.2);
                a <= c.3 && c.3 <= b
            })
            .cloned()
            .collect();
        assert_eq!(kept, expected);
        assert!(
            kept.len() > 50 && kept.len() + 50 < all.len(),
            "{}",
            kept.len()
        );
    }
}
