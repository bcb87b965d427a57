//! Physics tests of the transient path tracer. Expectations come from closed forms and from
//! ray casts written here, never from the tracer itself; tolerances follow from the number
//! of samples per pixel.

use femto::camera::Intrinsics;
use femto::cube::{Cube, TimeAxis};
use femto::geometry::bvh::Bvh;
use femto::geometry::Ray;
use femto::scene::{Emission, Scene};
use femto::tracer::{render_steady, trace, TraceOptions, Tracer};
use femto::units::C_M_PER_PS;
use nalgebra::{Point3, Vector3};
use std::f64::consts::PI;
use std::path::Path;

fn no_progress(_: usize) {}

/// A single Lambertian plane (z = 0, 3 m square) lit by the spot, seen by the camera.
const PLANE: &str = r#"
eta = 1.33

[laser]
position_m = [-0.3, 0.2, 0.4]
normal = [0.6, -0.3, -0.7]
emission = "cosine"
wavelength_nm = 532.0
pulse_width_fs = 300.0
energy = 2.0

[camera]
position_m = [0.1, -0.05, 1.0]
look_at_m = [0.0, 0.0, 0.0]
vfov_deg = 40.0
nx = 16
ny = 12
nt = 8
dt_ps = 2.0
t0_ps = 0.0

[[mesh]]
name = "plane"
primitive = "quad"
size = [3.0, 3.0]
albedo = 0.6
"#;

/// Time of flight of a path of `dist_m` metres, ps (written out here on purpose).
fn tof_ps(eta: f64, dist_m: f64) -> f64 {
    eta * dist_m / C_M_PER_PS
}

/// First bin with a non-zero value, if any.
fn first_nonzero(profile: &[f32]) -> Option<usize> {
    profile.iter().position(|&v| v > 0.0)
}

/// Per pixel on the plane, from a G x G grid of sub-pixel rays: mean radiance, its variance
/// over the footprint, and the radiance-weighted means of camera time and world time with
/// the variances of the centroid estimator.
struct PlaneTruth {
    mean: f64,
    var: f64,
    t_cam: f64,
    t_world: f64,
    var_t_cam: f64,
    var_t_world: f64,
}

fn plane_truth(s: &Scene, emission: Emission, x: usize, y: usize, g: usize) -> PlaneTruth {
    let calib = s.calibration();
    let o = s.camera.pose.position_m;
    let l = s.laser.position_m;
    let (mut f, mut tc, mut tw) = (Vec::new(), Vec::new(), Vec::new());
    for a in 0..g {
        for b in 0..g {
            let u = x as f64 + (a as f64 + 0.5) / g as f64;
            let v = y as f64 + (b as f64 + 0.5) / g as f64;
            let d = calib.world_ray(u, v).into_inner();
            let t = -o.z / d.z;
            assert!(t > 0.0);
            let p = o + d * t;
            let to_p = p - l;
            let r = to_p.norm();
            let w = to_p / r;
            let intensity = match emission {
                Emission::Cosine => 2.0 * s.laser.normal.dot(&w).max(0.0) / PI,
                Emission::Isotropic => 2.0 / (4.0 * PI),
            };
            let cos_p = Vector3::z().dot(&(-w));
            let radiance = 0.6 / PI * intensity * cos_p.max(0.0) / (r * r);
            f.push(radiance);
            tc.push(tof_ps(1.33, r + t));
            tw.push(tof_ps(1.33, r));
        }
    }
    let n = f.len() as f64;
    let mean = f.iter().sum::<f64>() / n;
    let var = f.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    let wmean = |t: &[f64]| f.iter().zip(t).map(|(a, b)| a * b).sum::<f64>() / (mean * n);
    let (t_cam, t_world) = (wmean(&tc), wmean(&tw));
    // Delta method for the ratio sum(f t) / sum(f) of spp samples: E[f^2 (t - tbar)^2] / E[f]^2.
    let rvar = |t: &[f64], tbar: f64| {
        f.iter()
            .zip(t)
            .map(|(a, b)| (a * (b - tbar)).powi(2))
            .sum::<f64>()
            / n
            / (mean * mean)
    };
    PlaneTruth {
        mean,
        var,
        t_cam,
        t_world,
        var_t_cam: rvar(&tc, t_cam),
        var_t_world: rvar(&tw, t_world),
    }
}

fn centroid(cube: &Cube, x: usize, y: usize) -> (f64, f64) {
    let p = cube.profile(x, y);
    let sum: f64 = p.iter().map(|&v| v as f64).sum();
    let m: f64 = p
        .iter()
        .enumerate()
        .map(|(i, &v)| v as f64 * cube.axis.bin_centre_ps(i))
        .sum();
    (sum, m / sum)
}

fn check_plane(emission: Emission) {
    let mut s = Scene::from_toml(PLANE, "plane", Path::new(".")).unwrap();
    let spp = 256u32;
    let g = 12;
    let (nx, ny) = (16, 12);
    let truths: Vec<PlaneTruth> = (0..ny)
        .flat_map(|y| (0..nx).map(move |x| (x, y)))
        .map(|(x, y)| plane_truth(&s, emission, x, y, g))
        .collect();
    // A window that holds all the direct light (camera-time bounds from corner rays).
    let calib = s.calibration();
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for j in 0..=ny {
        for i in 0..=nx {
            let d = calib.world_ray(i as f64, j as f64).into_inner();
            let p = s.camera.pose.position_m + d * (-s.camera.pose.position_m.z / d.z);
            let t = tof_ps(
                1.33,
                (p - s.laser.position_m).norm() + (p - s.camera.pose.position_m).norm(),
            );
            lo = lo.min(t);
            hi = hi.max(t);
        }
    }
    s.camera.axis = TimeAxis {
        t0_ps: lo - 20.0,
        dt_ps: 2.0,
        nt: ((hi - lo + 40.0) / 2.0).ceil() as usize,
    };
    let bvh = Bvh::new(s.mesh.clone());
    let opts = TraceOptions {
        spp,
        max_bounces: 3,
        seed: 11,
        emission: Some(emission),
        ..TraceOptions::default()
    };
    let r = trace(&s, &bvh, &opts, &no_progress);
    assert_eq!(r.stats.samples_outside_window, 0);
    assert_eq!(r.stats.energy_outside_window, 0.0);
    // A plane cannot light itself: every sample is one-bounce light.
    assert!(r.multi.as_ref().unwrap().data.iter().all(|&v| v == 0.0));
    let world = r.world_time.as_ref().unwrap();
    let mut lit = 0;
    for y in 0..ny {
        for x in 0..nx {
            let t = &truths[y * nx + x];
            let (sum, c_cam) = centroid(&r.camera_time, x, y);
            // Radiance: Monte Carlo error sd = sqrt(var / spp); grid quadrature within 0.2 %.
            let tol = 5.0 * (t.var / spp as f64).sqrt() + 2e-3 * t.mean + 1e-12;
            assert!(
                (sum - t.mean).abs() <= tol,
                "{emission:?} pixel ({x},{y}): {sum} vs {} (tol {tol})",
                t.mean
            );
            if t.mean <= 0.0 {
                continue;
            }
            lit += 1;
            let tol_t = 5.0 * (t.var_t_cam / spp as f64).sqrt() + 0.05;
            assert!(
                (c_cam - t.t_cam).abs() <= tol_t,
                "pixel ({x},{y}): camera-time centroid {c_cam} vs {} (tol {tol_t})",
                t.t_cam
            );
            let (wsum, c_world) = centroid(world, x, y);
            assert!((wsum - sum).abs() <= 1e-5 * sum);
            let tol_w = 5.0 * (t.var_t_world / spp as f64).sqrt() + 0.05;
            assert!(
                (c_world - t.t_world).abs() <= tol_w,
                "pixel ({x},{y}): world-time centroid {c_world} vs {} (tol {tol_w})",
                t.t_world
            );
        }
    }
    assert!(lit > nx * ny / 2, "only {lit} lit pixels");
}

#[test]
fn single_plane_matches_closed_form_irradiance_and_arrival_time_cosine() {
    check_plane(Emission::Cosine);
}

#[test]
fn single_plane_matches_closed_form_irradiance_and_arrival_time_isotropic() {
    check_plane(Emission::Isotropic);
}

/// Hit point, its side's normal, and whether the spot lights it directly (independent ray
/// cast with the scene's BVH).
fn direct_hit(s: &Scene, bvh: &Bvh, u: f64, v: f64) -> Option<(Point3<f64>, u32, bool)> {
    let o = s.camera.pose.position_m;
    let d = s.calibration().world_ray(u, v).into_inner();
    let h = bvh.intersect(
        &Ray::new(o.cast::<f32>(), d.cast::<f32>()),
        0.0,
        f32::INFINITY,
    )?;
    let p = o + d * h.t as f64;
    let mut n = h.normal.cast::<f64>();
    if n.dot(&d) > 0.0 {
        n = -n;
    }
    let to_l = s.laser.position_m - p;
    let r = to_l.norm();
    let w = to_l / r;
    let facing = n.dot(&w) > 1e-3 && s.laser.normal.dot(&-w) > 1e-3;
    let shadow = Ray::new((p + n * 1e-4).cast::<f32>(), w.cast::<f32>());
    let lit = facing && !bvh.occluded(&shadow, 0.0, (r - 1e-3) as f32);
    Some((p, bvh.mesh().material[h.triangle as usize], lit))
}

#[test]
fn first_arrival_of_direct_light_in_camera_and_world_time() {
    // The built-in cube scene through a narrow lens, so that most pixels' footprints span
    // less than one 20 ps bin of path time.
    let mut s = Scene::builtin("cube", None).unwrap();
    let (nx, ny) = (32, 24);
    s.camera.intrinsics = Intrinsics::from_vfov(nx, ny, 4.0);
    s.camera.vfov_deg = 4.0;
    let bvh = Bvh::new(s.mesh.clone());
    let eta = s.eta;
    let o = s.camera.pose.position_m;
    let l = s.laser.position_m;
    // Per pixel: the range of direct arrival times over its footprint (boundary and interior
    // grid), when the whole footprint is one lit surface.
    let g = 6;
    let mut ranges = vec![None; nx * ny];
    let (mut lo_all, mut hi_all) = (f64::INFINITY, 0.0f64);
    for y in 0..ny {
        for x in 0..nx {
            let mut cam = (f64::INFINITY, 0.0f64);
            let mut wld = (f64::INFINITY, 0.0f64);
            let mut ok = true;
            let mut material = None;
            for a in 0..=g {
                for b in 0..=g {
                    let u = x as f64 + a as f64 / g as f64;
                    let v = y as f64 + b as f64 / g as f64;
                    match direct_hit(&s, &bvh, u, v) {
                        Some((p, m, true)) if material.is_none_or(|mm| mm == m) => {
                            material = Some(m);
                            let tc = tof_ps(eta, (l - p).norm() + (p - o).norm());
                            let tw = tof_ps(eta, (l - p).norm());
                            cam = (cam.0.min(tc), cam.1.max(tc));
                            wld = (wld.0.min(tw), wld.1.max(tw));
                        }
                        _ => ok = false,
                    }
                }
            }
            if ok {
                lo_all = lo_all.min(cam.0);
                hi_all = hi_all.max(cam.1);
                ranges[y * nx + x] = Some((cam, wld));
            }
        }
    }
    s.camera.axis = TimeAxis {
        t0_ps: (lo_all - 100.0).floor(),
        dt_ps: 20.0,
        nt: ((hi_all - lo_all + 400.0) / 20.0).ceil() as usize,
    };
    let opts = TraceOptions {
        spp: 32,
        max_bounces: 2,
        seed: 3,
        ..TraceOptions::default()
    };
    let r = trace(&s, &bvh, &opts, &no_progress);
    let direct = r.direct.as_ref().unwrap();
    let world = r.world_time.as_ref().unwrap();
    // With tent splatting, a sample at time t reaches first the bin floor(coord(t) - 1/2).
    let first_bin = |axis: &TimeAxis, t: f64| (axis.bin_coord(t) - 0.5).floor() as i64;
    let pad = 0.5; // ps: grid estimate of the footprint's extremes
    let (mut checked, mut sharp) = (0, 0);
    for y in 0..ny {
        for x in 0..nx {
            let Some((cam, wld)) = ranges[y * nx + x] else {
                continue;
            };
            checked += 1;
            if cam.1 - cam.0 <= s.camera.axis.dt_ps {
                sharp += 1;
            }
            let got = first_nonzero(direct.profile(x, y)).expect("lit pixel has light") as i64;
            let (a, b) = (
                first_bin(&direct.axis, cam.0 - pad),
                first_bin(&direct.axis, cam.1 + pad),
            );
            assert!(
                (a..=b).contains(&got),
                "pixel ({x},{y}): first camera bin {got}, expected {a}..={b}"
            );
            // Total light arrives first with the direct light (more bounces are longer).
            assert_eq!(
                first_nonzero(r.camera_time.profile(x, y)),
                Some(got as usize)
            );
            let got_w = first_nonzero(world.profile(x, y)).expect("world light") as i64;
            let (a, b) = (
                first_bin(&world.axis, wld.0 - pad),
                first_bin(&world.axis, wld.1 + pad),
            );
            assert!(
                (a..=b).contains(&got_w),
                "pixel ({x},{y}): first world bin {got_w}, expected {a}..={b}"
            );
        }
    }
    assert!(checked >= nx * ny / 3, "only {checked} pixels checked");
    assert!(
        sharp * 2 >= checked,
        "{sharp} of {checked} footprints within one bin"
    );
}

#[test]
fn time_integrated_cube_equals_the_steady_state_render() {
    check_time_integral_against_steady(false, 256);
}

#[test]
fn light_vertices_keep_the_time_integral_of_the_steady_state_render() {
    // Light of two and three bounces estimated by both strategies, weighted by multiple
    // importance sampling, against steady renders of the camera's strategy alone.
    // More paths than the plain test, so that a 50 % error in the light strategy's
    // share of three-bounce light alone shows.
    check_time_integral_against_steady(true, 1024);
}

/// A transient render (with or without light vertices), integrated over time, against
/// eight independent steady-state renders without them: per-pixel z-scores and the image
/// sums agree within noise.
fn check_time_integral_against_steady(light_vertex: bool, spp: u32) {
    let mut s = Scene::builtin("cube", None)
        .unwrap()
        .with_resolution(16, 12, 1, 20.0);
    // Three bounces in this scene stay below 7 m of path: 1200 bins of 20 ps hold it all.
    s.camera.axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 20.0,
        nt: 1200,
    };
    let bvh = Bvh::new(s.mesh.clone());
    let opts = TraceOptions {
        spp,
        max_bounces: 3,
        rr_start_bounce: 2,
        seed: 5,
        world_time: false,
        light_vertex: false,
        ..TraceOptions::default()
    };
    let r = trace(
        &s,
        &bvh,
        &TraceOptions {
            light_vertex,
            ..opts
        },
        &no_progress,
    );
    assert_eq!(r.stats.energy_outside_window, 0.0);
    assert!(r.stats.samples > 0);
    let a = r.camera_time.time_integral();
    // direct + multi = total, bin by bin.
    let (d, m) = (r.direct.as_ref().unwrap(), r.multi.as_ref().unwrap());
    for ((t, dv), mv) in r.camera_time.data.iter().zip(&d.data).zip(&m.data) {
        assert!((t - (dv + mv)).abs() <= 1e-5 * t.abs() + 1e-12);
    }
    assert!(m.data.iter().any(|&v| v > 0.0));
    // K independent steady renders give a per-pixel mean and variance.
    let k = 8;
    let steady: Vec<Vec<f64>> = (0..k)
        .map(|i| {
            render_steady(
                &s,
                &bvh,
                &TraceOptions {
                    seed: 100 + i,
                    ..opts
                },
                &no_progress,
            )
        })
        .collect();
    let npx = a.len();
    let (mut z2, mut n, mut diff_sum, mut var_sum) = (0.0, 0, 0.0, 0.0);
    for p in 0..npx {
        let mean = steady.iter().map(|v| v[p]).sum::<f64>() / k as f64;
        let var = steady.iter().map(|v| (v[p] - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
        let var_diff = var * (1.0 + 1.0 / k as f64);
        diff_sum += a[p] - mean;
        var_sum += var_diff;
        if var > 0.0 {
            z2 += (a[p] - mean).powi(2) / var_diff;
            n += 1;
        } else {
            assert!(a[p] == 0.0 && mean == 0.0, "pixel {p}");
        }
    }
    // Student t with k - 1 = 7 degrees of freedom: E[t^2] = 7/5, and the mean over ~190
    // pixels has a standard deviation near 0.2.
    let mean_z2 = z2 / n as f64;
    println!(
        "light vertex {light_vertex}: mean z^2 {mean_z2:.3}, image sum {:.5e}, difference {diff_sum:.3e}, sd {:.3e}",
        a.iter().sum::<f64>(),
        var_sum.sqrt()
    );
    assert!(
        n > npx / 2 && mean_z2 < 2.4,
        "mean z^2 = {mean_z2} over {n} pixels"
    );
    assert!(
        diff_sum.abs() < 5.0 * var_sum.sqrt(),
        "image sums differ by {diff_sum} (sd {})",
        var_sum.sqrt()
    );
}

#[test]
fn same_seed_gives_bit_identical_cubes_with_one_and_two_threads() {
    let s = Scene::builtin("cube", None)
        .unwrap()
        .with_resolution(12, 9, 64, 8.0);
    let bvh = Bvh::new(s.mesh.clone());
    let opts = TraceOptions {
        spp: 4,
        max_bounces: 3,
        seed: 9,
        ..TraceOptions::default()
    };
    let run = |threads: usize, seed: u64| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| trace(&s, &bvh, &TraceOptions { seed, ..opts }, &no_progress))
    };
    let bits = |c: &Cube| c.data.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
    let (a, b) = (run(1, 9), run(2, 9));
    assert_eq!(bits(&a.camera_time), bits(&b.camera_time));
    assert_eq!(
        bits(a.direct.as_ref().unwrap()),
        bits(b.direct.as_ref().unwrap())
    );
    assert_eq!(
        bits(a.multi.as_ref().unwrap()),
        bits(b.multi.as_ref().unwrap())
    );
    assert_eq!(
        bits(a.world_time.as_ref().unwrap()),
        bits(b.world_time.as_ref().unwrap())
    );
    assert_eq!(a.stats.rays, b.stats.rays);
    assert!(a.camera_time.data.iter().any(|&v| v > 0.0));
    let c = run(2, 10);
    assert_ne!(bits(&a.camera_time), bits(&c.camera_time));
}

#[test]
fn cube_assembled_from_bands_of_rows_is_bit_identical_to_the_whole_render() {
    let s = Scene::builtin("cube", None)
        .unwrap()
        .with_resolution(10, 9, 48, 8.0);
    let bvh = Bvh::new(s.mesh.clone());
    let opts = TraceOptions {
        spp: 3,
        max_bounces: 3,
        seed: 5,
        ..TraceOptions::default()
    };
    let whole = trace(&s, &bvh, &opts, &no_progress);
    let tracer = Tracer::new(&s, &bvh, &opts);
    assert_eq!(
        tracer.world_axis(),
        whole.world_time.as_ref().map(|c| c.axis)
    );
    let bits = |c: &Cube| c.data.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
    let mut joined: [Vec<u32>; 4] = Default::default();
    let mut paths = 0;
    // Uneven bands, the last one asking for rows beyond the image.
    for rows in [0..2, 2..7, 7..20] {
        let r = tracer.render_rows(rows.clone(), &no_progress);
        assert_eq!(r.camera_time.ny, rows.end.min(9) - rows.start);
        paths += r.stats.paths;
        for (j, c) in [
            Some(&r.camera_time),
            r.direct.as_ref(),
            r.multi.as_ref(),
            r.world_time.as_ref(),
        ]
        .into_iter()
        .enumerate()
        {
            joined[j].extend(bits(c.unwrap()));
        }
    }
    assert_eq!(paths, whole.stats.paths);
    assert_eq!(joined[0], bits(&whole.camera_time));
    assert_eq!(joined[1], bits(whole.direct.as_ref().unwrap()));
    assert_eq!(joined[2], bits(whole.multi.as_ref().unwrap()));
    assert_eq!(joined[3], bits(whole.world_time.as_ref().unwrap()));
    assert!(joined[0].iter().any(|&b| f32::from_bits(b) > 0.0));
}

#[test]
fn cornell_box_renders_finite_light_from_the_start_of_its_window() {
    let s = Scene::builtin("cornell", None)
        .unwrap()
        .with_resolution(16, 12, 256, 4.0);
    let bvh = Bvh::new(s.mesh.clone());
    let opts = TraceOptions {
        spp: 4,
        ..TraceOptions::default()
    };
    let rows = std::sync::atomic::AtomicUsize::new(0);
    let r = trace(&s, &bvh, &opts, &|n| {
        rows.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
    });
    assert_eq!(rows.into_inner(), 12);
    assert_eq!(r.stats.paths, 16 * 12 * 4);
    for c in [
        &r.camera_time,
        r.direct.as_ref().unwrap(),
        r.multi.as_ref().unwrap(),
    ] {
        assert!(c.data.iter().all(|v| v.is_finite() && *v >= 0.0));
    }
    // The window starts just before the first direct light: some arrives in its first tenth.
    let direct = r.direct.as_ref().unwrap();
    let early: f64 = (0..12)
        .flat_map(|y| (0..16).map(move |x| (x, y)))
        .map(|(x, y)| {
            direct.profile(x, y)[..25]
                .iter()
                .map(|&v| v as f64)
                .sum::<f64>()
        })
        .sum();
    assert!(early > 0.0);
    assert!(r.multi.as_ref().unwrap().data.iter().any(|&v| v > 0.0));
    // The world-time axis covers the camera window shifted by the camera distances.
    let w = r.world_time.as_ref().unwrap();
    assert!(w.axis.t0_ps < s.camera.axis.t0_ps && w.axis.nt > s.camera.axis.nt);
}
