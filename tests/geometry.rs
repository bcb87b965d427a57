//! Geometry tests: analytic ray-plane and ray-box intersections, watertightness at shared edges
//! and vertices, the BVH against brute force, and the mesh readers and writer.
//!
//! Expectations come from formulas written here (plane equation, slab method, Möller-Trumbore
//! in f64, hand-composed node transforms), never from the code under test.

use femto::geometry::bvh::Bvh;
use femto::geometry::glb::write_glb;
use femto::geometry::load::{load_mesh, LoadError};
use femto::geometry::{Ray, TriangleMesh};
use nalgebra::{Point3, Rotation3, Unit, Vector3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::path::PathBuf;

#[path = "common/shared.rs"]
mod shared;

/// The Stanford bunny of `../shared` (skipped when absent; a failure under `CI=true`).
fn bunny_path() -> Option<PathBuf> {
    shared::file("data/stanford-bunny.obj")
}

fn p3(x: f64, y: f64, z: f64) -> Point3<f32> {
    Point3::new(x as f32, y as f32, z as f32)
}

fn to64(p: &Point3<f32>) -> Vector3<f64> {
    Vector3::new(p.x as f64, p.y as f64, p.z as f64)
}

fn unit_vector(rng: &mut Pcg64) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

/// Möller-Trumbore in f64, two-sided: `(t, u, v)` with `p = (1-u-v) a + u b + v c`.
fn moller_trumbore(
    tri: [Vector3<f64>; 3],
    o: Vector3<f64>,
    d: Vector3<f64>,
) -> Option<(f64, f64, f64)> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = d.cross(&e2);
    let det = e1.dot(&p);
    if det == 0.0 {
        return None;
    }
    let s = o - tri[0];
    let u = s.dot(&p) / det;
    let q = s.cross(&e1);
    let v = d.dot(&q) / det;
    if u < 0.0 || v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(&q) / det, u, v))
}

fn brute_force(mesh: &TriangleMesh, ray: &Ray) -> Option<(f64, usize)> {
    let (o, d) = (to64(&ray.origin), ray.dir.cast::<f64>());
    let mut best: Option<(f64, usize)> = None;
    for i in 0..mesh.triangle_count() {
        let c = mesh.corners(i).map(|p| to64(&p));
        if let Some((t, _, _)) = moller_trumbore(c, o, d) {
            if t > 0.0 && best.is_none_or(|(tb, _)| t < tb) {
                best = Some((t, i));
            }
        }
    }
    best
}

/// A unit quad `[-s, s]^2` in the plane through `centre` with normal `rot * z`, wound so
/// that `(v1 - v0) x (v2 - v0)` is that normal.
fn quad(rot: &Rotation3<f64>, centre: Vector3<f64>, s: f64) -> TriangleMesh {
    let corner = |x: f64, y: f64| {
        let p = rot * Vector3::new(x, y, 0.0) + centre;
        p3(p.x, p.y, p.z)
    };
    TriangleMesh {
        positions: vec![corner(-s, -s), corner(s, -s), corner(s, s), corner(-s, s)],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        material: vec![0, 0],
    }
}

#[test]
fn ray_plane_distance_normal_and_barycentrics() {
    let mut rng = Pcg64::seed_from_u64(1);
    let rot = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(0.3, -0.5, 0.8)), 0.7);
    let centre = Vector3::new(0.2, -0.1, 3.0);
    let normal = rot * Vector3::z();
    let mesh = quad(&rot, centre, 2.0);
    let bvh = Bvh::new(mesh.clone());
    let mut hits = 0;
    for _ in 0..2000 {
        // Origins on both sides of the plane (both faces must be hit).
        let o = centre + unit_vector(&mut rng) * rng.random_range(1.0..4.0);
        let target = centre
            + rot
                * Vector3::new(
                    rng.random_range(-1.9..1.9),
                    rng.random_range(-1.9..1.9),
                    0.0,
                );
        let d = (target - o).normalize();
        let ray = Ray::new(p3(o.x, o.y, o.z), d.cast::<f32>());
        // Plane n . x = n . centre: t = n . (centre - o) / (n . d).
        let t_expected = normal.dot(&(centre - o)) / normal.dot(&d);
        if normal.dot(&d).abs() < 0.05 {
            continue; // grazing: t is ill-conditioned in f32
        }
        let hit = bvh
            .intersect(&ray, 0.0, f32::INFINITY)
            .unwrap_or_else(|| panic!("ray {o:?} -> {target:?} missed the quad"));
        hits += 1;
        assert!(
            (hit.t as f64 - t_expected).abs() < 1e-5 * t_expected.max(1.0),
            "t {} vs {t_expected}",
            hit.t
        );
        assert!((hit.normal.cast::<f64>() - normal).norm() < 1e-5, "normal");
        // Barycentrics of the analytic hit point, from the 2x2 normal equations.
        let p = o + d * t_expected;
        let c = mesh.corners(hit.triangle as usize).map(|q| to64(&q));
        let (e1, e2, r) = (c[1] - c[0], c[2] - c[0], p - c[0]);
        let (a11, a12, a22) = (e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
        let (b1, b2) = (e1.dot(&r), e2.dot(&r));
        let det = a11 * a22 - a12 * a12;
        let u = (b1 * a22 - b2 * a12) / det;
        let v = (a11 * b2 - a12 * b1) / det;
        assert!((hit.u as f64 - u).abs() < 1e-5 && (hit.v as f64 - v).abs() < 1e-5);
        assert!(u >= -1e-6 && v >= -1e-6 && u + v <= 1.0 + 1e-6);
        // Shadow rays agree, and the hit is excluded when t_max stops short of it.
        assert!(bvh.occluded(&ray, 0.0, f32::INFINITY));
        assert!(!bvh.occluded(&ray, 0.0, 0.99 * t_expected as f32));
        assert!(bvh
            .intersect(&ray, 1.01 * t_expected as f32, 100.0)
            .is_none());
    }
    assert!(hits > 1500);
}

/// An axis-aligned box as 12 triangles wound outwards.
fn box_mesh(lo: [f64; 3], hi: [f64; 3]) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    for i in 0..8 {
        let pick = |a: usize| if i >> a & 1 == 1 { hi[a] } else { lo[a] };
        mesh.positions.push(p3(pick(0), pick(1), pick(2)));
    }
    // Faces as (corner bits) quads, counter-clockwise seen from outside.
    let faces = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    for f in faces {
        mesh.triangles.push([f[0], f[1], f[2]]);
        mesh.triangles.push([f[0], f[2], f[3]]);
    }
    mesh.material = vec![0; 12];
    mesh
}

#[test]
fn ray_box_entry_distance_matches_slab_formula() {
    let mut rng = Pcg64::seed_from_u64(2);
    let (lo, hi) = ([-0.3, 0.1, 1.0], [0.5, 0.4, 2.2]);
    let bvh = Bvh::new(box_mesh(lo, hi));
    let centre = Vector3::new(0.1, 0.25, 1.6);
    let (mut hits, mut misses) = (0, 0);
    for k in 0..4000 {
        let o = centre + unit_vector(&mut rng) * 3.0;
        let d = if k % 2 == 0 {
            // Aimed into the box.
            let target = Vector3::new(
                rng.random_range(lo[0]..hi[0]),
                rng.random_range(lo[1]..hi[1]),
                rng.random_range(lo[2]..hi[2]),
            );
            (target - o).normalize()
        } else {
            unit_vector(&mut rng)
        };
        let (o32, d32) = (p3(o.x, o.y, o.z), d.cast::<f32>());
        let (o, d) = (to64(&o32), d32.cast::<f64>());
        // Slab method in f64.
        let (mut t_near, mut t_far, mut entry_axis) = (f64::NEG_INFINITY, f64::INFINITY, 0);
        for a in 0..3 {
            let t1 = (lo[a] - o[a]) / d[a];
            let t2 = (hi[a] - o[a]) / d[a];
            if t1.min(t2) > t_near {
                t_near = t1.min(t2);
                entry_axis = a;
            }
            t_far = t_far.min(t1.max(t2));
        }
        let gap = t_far - t_near;
        if gap.abs() < 1e-4 {
            continue; // grazes an edge or corner: hit or miss is a matter of rounding
        }
        let hit = bvh.intersect(&Ray::new(o32, d32), 0.0, f32::INFINITY);
        if gap > 0.0 && t_far > 0.0 {
            let hit = hit.unwrap_or_else(|| panic!("ray {o:?} {d:?} missed the box"));
            hits += 1;
            assert!(
                (hit.t as f64 - t_near).abs() < 1e-5,
                "t {} vs {t_near}",
                hit.t
            );
            // Entry face: outward normal -sign(d) along the entry axis (unless near an edge).
            let mut second = f64::NEG_INFINITY;
            for a in (0..3).filter(|&a| a != entry_axis) {
                second = second.max(((lo[a] - o[a]) / d[a]).min((hi[a] - o[a]) / d[a]));
            }
            if t_near - second > 1e-4 {
                let mut n = Vector3::zeros();
                n[entry_axis] = -d[entry_axis].signum();
                assert!((hit.normal.cast::<f64>() - n).norm() < 1e-6, "normal");
            }
        } else {
            assert!(hit.is_none(), "ray {o:?} {d:?} should miss, got {hit:?}");
            misses += 1;
        }
    }
    assert!(hits > 2000 && misses > 500, "hits {hits}, misses {misses}");
}

#[test]
fn axis_aligned_rays_hit_faces_and_edges_of_a_box() {
    // Rays parallel to the axes through face centres, along edges' planes and at corners.
    let bvh = Bvh::new(box_mesh([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]));
    for &(x, y) in &[
        (0.5, 0.5),
        (0.0, 0.5),
        (0.5, 1.0),
        (0.0, 0.0),
        (1.0, 1.0),
        (0.25, 0.0),
    ] {
        let ray = Ray::new(p3(x, y, -2.0), Vector3::z());
        let hit = bvh
            .intersect(&ray, 0.0, f32::INFINITY)
            .unwrap_or_else(|| panic!("axis ray at ({x}, {y}) missed"));
        assert!((hit.t - 2.0).abs() < 1e-6, "t {}", hit.t);
    }
}

#[test]
fn rays_through_shared_edges_and_vertices_never_slip_through() {
    let mut rng = Pcg64::seed_from_u64(3);
    // A jittered 24 x 24 vertex grid in the tilted plane z = (x + 2 y) / 4, built from dyadic
    // numbers so that every vertex, every point `pa + (pb - pa) k / 8` of an edge, every ray
    // origin (a multiple of 1/64) and every direction `target - origin` is exact in f32: the
    // rays pass *exactly* through shared edges and vertices, the case where a test that is not
    // watertight lets rays slip between triangles. The jitter (at most 0.19 of the spacing)
    // flips no triangle, so the surface covers the plane around every interior edge.
    let n = 24usize;
    let spacing = 1.0 / 16.0;
    let mut mesh = TriangleMesh::default();
    for j in 0..n {
        for i in 0..n {
            let jitter = |rng: &mut Pcg64| rng.random_range(-12i32..=12) as f64 / 1024.0;
            let x = i as f64 * spacing + jitter(&mut rng) - 0.75;
            let y = j as f64 * spacing + jitter(&mut rng) - 0.75;
            mesh.positions.push(p3(x, y, (x + 2.0 * y) / 4.0));
        }
    }
    let id = |i: usize, j: usize| (j * n + i) as u32;
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            // Alternate the diagonal so vertices have different valences.
            if (i + j) % 2 == 0 {
                mesh.triangles
                    .push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                mesh.triangles
                    .push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                mesh.triangles.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                mesh.triangles
                    .push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    mesh.material = vec![0; mesh.triangles.len()];
    // Interior edges: both endpoints off the grid border.
    let interior = |v: u32| {
        let (i, j) = (v as usize % n, v as usize / n);
        i > 0 && j > 0 && i < n - 1 && j < n - 1
    };
    let mut edges = Vec::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if interior(a) && interior(b) {
                edges.push((a, b));
            }
        }
    }
    let bvh = Bvh::new(mesh.clone());
    let plane_normal = Vector3::new(1.0, 2.0, -4.0).normalize();
    let mut misses = 0;
    let mut k = 0;
    while k < 100_000 {
        let (a, b) = edges[rng.random_range(0..edges.len())];
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        // Every fourth ray aims at a vertex, the others at a point of an edge.
        let target = if k % 4 == 0 {
            pa
        } else {
            pa + (pb - pa) * (rng.random_range(1..8) as f32 / 8.0)
        };
        let o = Point3::from(Vector3::from_fn(|_, _| {
            rng.random_range(-128i32..=128) as f32 / 64.0
        }));
        let dir = target - o;
        // Rays at grazing incidence carry no information about cracks.
        if plane_normal.dot(&dir.cast::<f64>().normalize()).abs() < 0.05 {
            continue;
        }
        k += 1;
        if bvh
            .intersect(&Ray::new(o, dir), 0.0, f32::INFINITY)
            .is_none()
        {
            misses += 1;
        }
    }
    assert_eq!(
        misses, 0,
        "{misses} of 100000 rays slipped through the mesh"
    );
}

/// The bunny if present, else a random triangle soup of similar extent.
fn bunny_or_soup() -> TriangleMesh {
    if let Some(p) = bunny_path() {
        return load_mesh(&p).unwrap();
    }
    println!("using a random triangle soup instead of the bunny");
    let mut rng = Pcg64::seed_from_u64(4);
    let mut mesh = TriangleMesh::default();
    for t in 0..3000u32 {
        let c = Vector3::new(
            rng.random_range(-0.1..0.1),
            rng.random_range(0.0..0.2),
            rng.random_range(-0.1..0.1),
        );
        for _ in 0..3 {
            let p = c + unit_vector(&mut rng) * 0.01;
            mesh.positions.push(p3(p.x, p.y, p.z));
        }
        mesh.triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
        mesh.material.push(0);
    }
    mesh
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn bunny_loads_with_all_triangles() {
    let Some(path) = bunny_path() else {
        return;
    };
    let mesh = load_mesh(&path).unwrap();
    assert_eq!(mesh.triangle_count(), 69_451);
    assert_eq!(mesh.material.len(), 69_451);
    // The file header says "about 0.15 m wide": metres, not millimetres.
    let b = mesh.bounds();
    let width = b.max - b.min;
    assert!(width.max() > 0.1 && width.max() < 0.3, "extent {width:?}");
}

#[test]
fn bvh_agrees_with_brute_force() {
    let mesh = bunny_or_soup();
    let bvh = Bvh::new(mesh.clone());
    let b = mesh.bounds();
    let centre = nalgebra::center(&b.min, &b.max).coords.cast::<f64>();
    let radius = (b.max - b.min).norm() as f64;
    let mut rng = Pcg64::seed_from_u64(5);
    let mut hits = 0;
    for k in 0..300 {
        let o = centre + unit_vector(&mut rng) * radius;
        let target = Vector3::new(
            rng.random_range(b.min.x..b.max.x) as f64,
            rng.random_range(b.min.y..b.max.y) as f64,
            rng.random_range(b.min.z..b.max.z) as f64,
        );
        // Half the rays start inside the bounds, to exercise origins within boxes.
        let o = if k % 2 == 0 { o } else { (o + target) * 0.5 };
        let ray = Ray::new(p3(o.x, o.y, o.z), (target - o).normalize().cast::<f32>());
        let expected = brute_force(&mesh, &ray);
        let got = bvh.intersect(&ray, 0.0, f32::INFINITY);
        match (expected, got) {
            (None, None) => {
                assert!(!bvh.occluded(&ray, 0.0, f32::INFINITY));
            }
            (Some((t, tri)), Some(h)) => {
                hits += 1;
                assert!(
                    (h.t as f64 - t).abs() < 1e-5 * t.max(0.01),
                    "ray {k}: t {} vs {t} (triangle {} vs {tri})",
                    h.t,
                    h.triangle
                );
                assert!(bvh.occluded(&ray, 0.0, f32::INFINITY));
                assert!(!bvh.occluded(&ray, 0.0, (0.999 * t) as f32));
            }
            (e, g) => panic!("ray {k}: brute force {e:?}, BVH {g:?}"),
        }
    }
    assert!(hits > 30, "only {hits} rays hit");
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A .gltf with one triangle `(0,0,0), (1,0,0), (0,1,0)` as mesh 0 (material 1) and this
/// `nodes`/`scenes` JSON.
fn triangle_gltf(nodes_and_scenes: &str, mode: u32) -> String {
    let mut bin = Vec::new();
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  {nodes_and_scenes},
  "meshes": [{{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 0}}, "material": 1, "mode": {mode}}}]}}],
  "materials": [{{"name": "a"}}, {{"name": "b"}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0, 0, 0], "max": [1, 1, 0]}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}],
  "buffers": [{{"byteLength": 36, "uri": "data:application/octet-stream;base64,{}"}}]
}}"#,
        base64(&bin)
    )
}

#[test]
fn gltf_node_hierarchy_places_mesh_in_world() {
    let dir = tempfile::tempdir().unwrap();
    // Scene 1 is the default: parent translates by (1, 2, 3); its child rotates 90 degrees
    // about z and scales by 2; a second child mirrors x. Scene 0 (not default) would put the
    // triangle at the origin.
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let json = triangle_gltf(
        &format!(
            r#""scene": 1,
  "scenes": [{{"nodes": [3]}}, {{"nodes": [0]}}],
  "nodes": [
    {{"translation": [1, 2, 3], "children": [1, 2]}},
    {{"rotation": [0, 0, {s}, {s}], "scale": [2, 2, 2], "mesh": 0}},
    {{"matrix": [-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "mesh": 0}},
    {{"mesh": 0}}
  ]"#
        ),
        4,
    );
    let path = write(dir.path(), "scene.gltf", &json);
    let mesh = load_mesh(&path).unwrap();
    assert_eq!(mesh.triangle_count(), 2);
    assert_eq!(mesh.material, vec![1, 1]);
    // Child 1: p -> (1,2,3) + Rz(90)(2 p), with Rz(90)(x, y, z) = (-y, x, z).
    let child1 = [[1.0, 2.0, 3.0], [1.0, 4.0, 3.0], [-1.0, 2.0, 3.0]];
    // Child 2: p -> (1,2,3) + (-x, y, z); mirrored, so two corners swap to keep the front face.
    let child2 = [[1.0, 2.0, 3.0], [1.0, 3.0, 3.0], [0.0, 2.0, 3.0]];
    for (k, expected) in [child1, child2].iter().enumerate() {
        let got = mesh.corners(k);
        for (g, e) in got.iter().zip(expected) {
            let e = p3(e[0], e[1], e[2]);
            assert!(
                (g - e).norm() < 1e-6,
                "triangle {k}: {got:?} vs {expected:?}"
            );
        }
    }
    // Both front faces point along +z, as the untransformed triangle's does.
    for k in 0..2 {
        let [a, b, c] = mesh.corners(k);
        assert!((b - a).cross(&(c - a)).z > 0.0);
    }
}

#[test]
fn gltf_without_default_scene_uses_the_first() {
    let dir = tempfile::tempdir().unwrap();
    let json = triangle_gltf(
        r#""scenes": [{"nodes": [0]}, {"nodes": [1]}],
  "nodes": [{"translation": [0, 0, 5], "mesh": 0}, {"mesh": 0}]"#,
        4,
    );
    let mesh = load_mesh(&write(dir.path(), "a.gltf", &json)).unwrap();
    assert_eq!(mesh.triangle_count(), 1);
    assert!(mesh.corners(0).iter().all(|p| p.z == 5.0));
}

#[test]
fn gltf_lines_are_rejected_naming_mesh_and_primitive() {
    let dir = tempfile::tempdir().unwrap();
    let json = triangle_gltf(r#""scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}]"#, 1);
    let path = write(dir.path(), "lines.gltf", &json);
    let err = load_mesh(&path).unwrap_err();
    assert!(matches!(err, LoadError::NotTriangles { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.contains("lines.gltf") && msg.contains("\"tri\"") && msg.contains("primitive 0"),
        "{msg}"
    );
}

#[test]
fn obj_faces_are_triangulated_with_material_ids() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "m.mtl",
        "newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\n",
    );
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
               usemtl green\nf 1 2 3 4\nusemtl red\nf 1 2 5\n";
    let mesh = load_mesh(&write(dir.path(), "quad.obj", obj)).unwrap();
    assert_eq!(mesh.triangle_count(), 3);
    let green = mesh.material.iter().filter(|&&m| m == 1).count();
    let red = mesh.material.iter().filter(|&&m| m == 0).count();
    assert_eq!((green, red), (2, 1));
    // The quad's two triangles cover area 1; the red triangle 0.5.
    let area = |m: u32| -> f32 {
        (0..3)
            .filter(|&i| mesh.material[i] == m)
            .map(|i| mesh.area(i))
            .sum()
    };
    assert!((area(1) - 1.0).abs() < 1e-6 && (area(0) - 0.5).abs() < 1e-6);
}

#[test]
fn load_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.obj");
    let msg = load_mesh(&missing).unwrap_err().to_string();
    assert!(msg.contains("nope.obj"), "{msg}");
    assert!(matches!(
        load_mesh(&missing).unwrap_err(),
        LoadError::Io { ref source, .. } if source.kind() == std::io::ErrorKind::NotFound
    ));
    let stl = write(dir.path(), "x.stl", "solid");
    let err = load_mesh(&stl).unwrap_err();
    assert!(matches!(err, LoadError::UnsupportedFormat { .. }));
    assert!(err.to_string().contains("x.stl"));
    let bad = write(dir.path(), "bad.gltf", "{ not json");
    let msg = load_mesh(&bad).unwrap_err().to_string();
    assert!(msg.contains("bad.gltf"), "{msg}");
    let out_of_range = write(dir.path(), "oor.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
    let msg = load_mesh(&out_of_range).unwrap_err().to_string();
    assert!(msg.contains("oor.obj"), "{msg}");
}

#[test]
fn glb_round_trip_keeps_triangles_per_material() {
    let mut rng = Pcg64::seed_from_u64(6);
    let mut mesh = TriangleMesh::default();
    for _ in 0..40 {
        mesh.positions.push(p3(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ));
    }
    // Shared vertices, materials interleaved and with a gap (no material 1).
    for k in 0..60u32 {
        mesh.triangles
            .push([k % 40, (k * 7 + 1) % 40, (k * 13 + 5) % 40]);
        mesh.material.push([2, 0, 3, 0, 2][k as usize % 5]);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.glb");
    write_glb(&mesh, &path).unwrap();
    let back = load_mesh(&path).unwrap();
    assert_eq!(back.triangle_count(), mesh.triangle_count());
    let per_material = |m: &TriangleMesh, mat: u32| -> Vec<[Point3<f32>; 3]> {
        (0..m.triangle_count())
            .filter(|&i| m.material[i] == mat)
            .map(|i| m.corners(i))
            .collect()
    };
    for mat in 0..4 {
        assert_eq!(
            per_material(&back, mat),
            per_material(&mesh, mat),
            "material {mat}"
        );
    }
    // Only the .glb is left in the folder (the write went through a temporary file).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

    // Invalid meshes are refused without leaving a file behind.
    let bad = dir.path().join("bad.glb");
    let mut broken = mesh.clone();
    broken.triangles[3][1] = 40;
    assert!(write_glb(&broken, &bad)
        .unwrap_err()
        .to_string()
        .contains("bad.glb"));
    let mut huge = mesh.clone();
    huge.material[0] = u32::MAX;
    assert!(write_glb(&huge, &bad).is_err());
    assert!(!bad.exists());

    let empty = dir.path().join("empty.glb");
    write_glb(&TriangleMesh::default(), &empty).unwrap();
    assert_eq!(load_mesh(&empty).unwrap().triangle_count(), 0);
}
