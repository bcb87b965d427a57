//! Tests of the BVH: the wide trees against brute force on random meshes and rooms, every
//! lane type against the scalar watertight test, and degenerate rays and meshes.

use super::packets::{intersect_triangle, packet_test};
use super::*;

fn assert_send_sync<T: Send + Sync>() {}

#[test]
fn bvh_is_send_and_sync() {
    assert_send_sync::<Bvh>();
}

#[test]
fn empty_and_degenerate_meshes_never_hit() {
    let ray = Ray::new(Point3::new(0.2, 0.2, -1.0), Vector3::new(0.0, 0.0, 1.0));
    let empty = Bvh::new(TriangleMesh::default());
    assert!(empty.intersect(&ray, 0.0, f32::INFINITY).is_none());
    assert!(!empty.occluded(&ray, 0.0, f32::INFINITY));
    // A point triangle, a collinear one and a repeated-vertex one, all crossing the ray.
    let mesh = TriangleMesh {
        positions: vec![
            Point3::new(0.2, 0.2, 0.0),
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
        ],
        triangles: vec![[0, 0, 0], [1, 0, 2], [1, 2, 2]],
        material: vec![0; 3],
    };
    let bvh = Bvh::new(mesh);
    assert!(bvh.intersect(&ray, 0.0, f32::INFINITY).is_none());
    assert!(!bvh.occluded(&ray, 0.0, f32::INFINITY));
}

/// Rays with a NaN or an infinite component (a camera path or calibration gone wrong,
/// issue 16) meet nothing and never reach an empty child slot's leaf of no packets,
/// whose eight-lane test indexed `first - 1` ("index out of bounds in leaf_by_pairs").
/// Triangles with a non-finite corner are left out of the tree.
#[test]
fn non_finite_rays_and_corners_meet_nothing() {
    let mut rng = Uniforms(7);
    let mut mesh = test_mesh(&mut rng);
    // One triangle with a NaN corner among the others.
    let bad = mesh.positions.len() as u32;
    mesh.positions.push(Point3::new(f32::NAN, 0.0, 0.0));
    mesh.triangles.push([bad, 0, 1]);
    mesh.material.push(0);
    let finite = Ray::new(Point3::new(0.1, 0.2, -5.0), Vector3::new(0.0, 0.0, 1.0));
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let rays = [
        Ray::new(Point3::new(0.0, nan, 0.0), Vector3::new(0.0, 0.0, 1.0)),
        Ray::new(Point3::new(0.0, -inf, 0.0), Vector3::new(0.0, 0.0, 1.0)),
        Ray::new(Point3::new(0.0, 0.0, -5.0), Vector3::new(nan, nan, nan)),
        Ray::new(Point3::new(0.0, 0.0, -5.0), Vector3::new(0.0, inf, 1.0)),
    ];
    for width in [4, 8] {
        let b = Bvh::with_width(mesh.clone(), width);
        if width == 4 || eight_isa().is_some() {
            // The finite ray still works (and never reports the NaN triangle).
            let hit = brute_force(&mesh, &finite, f32::INFINITY);
            let got = b.intersect(&finite, 0.0, f32::INFINITY);
            assert_eq!(got.map(|h| h.triangle), hit.map(|h| h.0));
            assert_ne!(got.map(|h| h.triangle), Some(bad));
        }
        for r in &rays {
            if width == 4 || eight_isa().is_some() {
                assert!(b.intersect(r, 0.0, f32::INFINITY).is_none(), "{r:?}");
                assert!(!b.occluded(r, 0.0, f32::INFINITY), "{r:?}");
            }
            if width == 8 {
                let w = eight(&b);
                assert!(w
                    .intersect::<_, _, PORTABLE_OR_SSE>(
                        Portable::<8>::new(),
                        Portable::<8>::new(),
                        r,
                        0.0,
                        inf
                    )
                    .is_none());
                assert!(!w.occluded::<_, _, PORTABLE_OR_SSE>(
                    Portable::<8>::new(),
                    Portable::<8>::new(),
                    r,
                    0.0,
                    inf
                ));
            }
        }
    }
}

#[test]
fn many_identical_triangles_build_a_bounded_tree() {
    // Coincident centroids force the count split; the stack must hold the depth.
    let mut mesh = TriangleMesh {
        positions: vec![
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(1.0, 0.0, 1.0),
            Point3::new(0.0, 1.0, 1.0),
        ],
        ..Default::default()
    };
    mesh.triangles = vec![[0, 1, 2]; 1000];
    mesh.material = vec![0; 1000];
    for width in [4, 8] {
        let bvh = Bvh::with_width(mesh.clone(), width);
        match &bvh.tree {
            Tree::Four(w, _) => check_leaves(w, 1000),
            Tree::Eight(w, _) => check_leaves(w, 1000),
        }
        if width == 4 || eight_isa().is_some() {
            let ray = Ray::new(Point3::new(0.25, 0.25, 0.0), Vector3::new(0.0, 0.0, 1.0));
            let hit = bvh.intersect(&ray, 0.0, f32::INFINITY).unwrap();
            assert!((hit.t - 1.0).abs() < 1e-6);
        }
    }
}

/// Every leaf holds at most MAX_LEAF triangles, in at most ceil(MAX_LEAF / 4) packets, and
/// the `n` triangles are in the tree exactly once.
fn check_leaves<const N: usize>(w: &Wide<N>, n: u32) {
    let refs = w.nodes.iter().flat_map(|n| n.child).chain([w.root]);
    for r in refs.filter(|r| r & LEAF != 0) {
        let packets = ((r & !LEAF) >> LEAF_COUNT_SHIFT) as usize;
        assert!(packets <= MAX_LEAF.div_ceil(PACKET));
        let first = (r & LEAF_FIRST_MASK) as usize;
        let tris = w.packet_ids[first..first + packets]
            .iter()
            .flatten()
            .filter(|&&id| id != u32::MAX)
            .count();
        assert!(tris <= MAX_LEAF);
    }
    let mut ids: Vec<u32> = w.packet_ids.iter().flatten().copied().collect();
    ids.retain(|&id| id != u32::MAX);
    ids.sort_unstable();
    assert_eq!(ids, (0..n).collect::<Vec<u32>>());
}

/// A splitmix64 stream of uniforms in [0, 1) (no dependence on the code under test).
struct Uniforms(u64);

impl Uniforms {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
}

/// A soup of random triangles of very different sizes, a grid of quads on integer
/// coordinates (rays along the axes through their shared edges and corners make edge
/// functions exactly zero) and a few triangles of zero area.
fn test_mesh(rng: &mut Uniforms) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    let push = |mesh: &mut TriangleMesh, c: [[f32; 3]; 3]| {
        let base = mesh.positions.len() as u32;
        mesh.positions
            .extend(c.iter().map(|p| Point3::new(p[0], p[1], p[2])));
        mesh.triangles.push([base, base + 1, base + 2]);
        mesh.material.push(0);
    };
    for k in 0..300 {
        let size = if k % 10 == 0 { 3.0 } else { 0.2 };
        let o = [0, 1, 2].map(|_| rng.range(-2.0, 2.0));
        let c = [0, 1, 2].map(|_| [0, 1, 2].map(|a| o[a] + rng.range(-size, size)));
        push(&mut mesh, c);
    }
    for i in -2..2 {
        for j in -2..2 {
            let (x, y, z) = (i as f32, j as f32, 0.5);
            push(
                &mut mesh,
                [[x, y, z], [x + 1.0, y, z], [x + 1.0, y + 1.0, z]],
            );
            push(
                &mut mesh,
                [[x, y, z], [x + 1.0, y + 1.0, z], [x, y + 1.0, z]],
            );
        }
    }
    push(&mut mesh, [[0.1, 0.1, 0.0]; 3]);
    push(
        &mut mesh,
        [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]],
    );
    mesh
}

fn test_rays(rng: &mut Uniforms, n: usize) -> Vec<(Ray, f32)> {
    let mut rays = Vec::new();
    for k in 0..n {
        let o = Point3::new(
            rng.range(-4.0, 4.0),
            rng.range(-4.0, 4.0),
            rng.range(-4.0, 4.0),
        );
        let dir = match k % 4 {
            // Axis-aligned (through grid edges and corners when the origin is on one).
            0 => {
                let o = Point3::new(o.x.round() * 0.5, o.y.round() * 0.5, -3.0);
                rays.push((Ray::new(o, Vector3::new(0.0, 0.0, 1.0)), f32::INFINITY));
                continue;
            }
            // Towards a random point of the soup's region.
            _ => {
                let target = Vector3::new(
                    rng.range(-2.0, 2.0),
                    rng.range(-2.0, 2.0),
                    rng.range(-2.0, 2.0),
                );
                (target - o.coords).normalize()
            }
        };
        let t_max = if k % 3 == 0 {
            rng.range(0.5, 6.0)
        } else {
            f32::INFINITY
        };
        rays.push((Ray::new(o, dir), t_max));
    }
    rays
}

/// Brute force with the scalar watertight test: the nearest hit `(triangle, t, u, v)`
/// over all triangles of non-zero area (the first triangle on a tie of `t`).
fn brute_force(mesh: &TriangleMesh, ray: &Ray, t_max: f32) -> Option<(u32, f32, f32, f32)> {
    let consts = RayConsts::new(ray);
    let mut best: Option<(u32, f32, f32, f32)> = None;
    for i in 0..mesh.triangle_count() {
        let c = mesh.corners(i).map(|p| [p.x, p.y, p.z]);
        if cross_f64(&c).norm_squared() <= 0.0 {
            continue;
        }
        if let Some(h) = intersect_triangle(&c, &consts, 0.0, t_max) {
            if best.is_none_or(|b| h.t < b.1) {
                best = Some((i as u32, h.t, h.u, h.v));
            }
        }
    }
    best
}

/// A tree walk under test: nearest hit `(triangle, t, u, v)` and occlusion.
type Cast = dyn Fn(&Bvh, &Ray, f32) -> (Option<(u32, f32, f32, f32)>, bool);

/// The walk `cast` of a tree of `width` finds what brute force finds: the same distance bit
/// for bit, the same triangle (or, on a tie of distance, one at the same distance) and
/// barycentrics; `occluded` agrees; the public API gives the same hit with its normal.
/// Both on the soup of [`test_mesh`] and inside the room of [`room_mesh`].
fn agrees_with_brute_force(width: usize, cast: &Cast) {
    let mut rng = Uniforms(11);
    let mesh = test_mesh(&mut rng);
    let rays = test_rays(&mut rng, 3000);
    agrees_on(&mesh, &rays, width, cast);
    let mesh = room_mesh(&mut rng);
    let rays = room_rays(&mut rng, 2000);
    agrees_on(&mesh, &rays, width, cast);
}

fn agrees_on(mesh: &TriangleMesh, rays: &[(Ray, f32)], width: usize, cast: &Cast) {
    let bvh = Bvh::with_width(mesh.clone(), width);
    let public = width == 4 || eight_isa().is_some();
    let mut hits = 0;
    for (k, (ray, t_max)) in rays.iter().enumerate() {
        let expected = brute_force(mesh, ray, *t_max);
        let (got, occluded) = cast(&bvh, ray, *t_max);
        assert_eq!(occluded, expected.is_some(), "ray {k}");
        match (expected, got) {
            (None, None) => {}
            (Some((tri, t, u, v)), Some((h_tri, h_t, h_u, h_v))) => {
                hits += 1;
                assert_eq!(h_t.to_bits(), t.to_bits(), "ray {k}");
                if h_tri == tri {
                    assert_eq!((h_u, h_v), (u, v), "ray {k}");
                } else {
                    // A tie: the other triangle must hit at exactly the same distance.
                    let c = mesh.corners(h_tri as usize).map(|p| [p.x, p.y, p.z]);
                    let other = intersect_triangle(&c, &RayConsts::new(ray), 0.0, f32::INFINITY);
                    assert_eq!(other.unwrap().t.to_bits(), t.to_bits(), "ray {k}");
                }
            }
            (e, g) => panic!("ray {k}: brute force {e:?}, BVH {g:?}"),
        }
        if public {
            let h = bvh.intersect(ray, 0.0, *t_max);
            assert_eq!(h.map(|h| (h.triangle, h.t, h.u, h.v)), got, "ray {k}");
            if let Some(h) = h {
                let c = mesh.corners(h.triangle as usize).map(|p| [p.x, p.y, p.z]);
                assert_eq!(h.normal, geometric_normal(&c));
            }
            assert_eq!(bvh.occluded(ray, 0.0, *t_max), occluded);
        }
    }
    assert!(hits > 1000, "only {hits} rays hit");
}

/// A room (the unit cube without its front face z = 1: five walls of two triangles each,
/// triangles 0..10, wall `i / 2`), an open box standing on its floor (its bottom face is
/// coplanar with the floor) and a cluster of 200 small triangles in the air.
fn room_mesh(rng: &mut Uniforms) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    let mut quad = |c: [[f32; 3]; 4]| {
        let base = mesh.positions.len() as u32;
        mesh.positions
            .extend(c.iter().map(|p| Point3::new(p[0], p[1], p[2])));
        mesh.triangles.push([base, base + 1, base + 2]);
        mesh.triangles.push([base, base + 2, base + 3]);
        mesh.material.extend([0, 0]);
    };
    // Walls: floor, ceiling, back, left, right.
    quad([[0., 0., 0.], [1., 0., 0.], [1., 0., 1.], [0., 0., 1.]]);
    quad([[0., 1., 0.], [1., 1., 0.], [1., 1., 1.], [0., 1., 1.]]);
    quad([[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]);
    quad([[0., 0., 0.], [0., 1., 0.], [0., 1., 1.], [0., 0., 1.]]);
    quad([[1., 0., 0.], [1., 1., 0.], [1., 1., 1.], [1., 0., 1.]]);
    // An open box (no lid) [0.3, 0.5] x [0, 0.2] x [0.3, 0.5]: bottom and four sides.
    let (l, h, top) = (0.3, 0.5, 0.2);
    quad([[l, 0., l], [h, 0., l], [h, 0., h], [l, 0., h]]);
    quad([[l, 0., l], [h, 0., l], [h, top, l], [l, top, l]]);
    quad([[l, 0., h], [h, 0., h], [h, top, h], [l, top, h]]);
    quad([[l, 0., l], [l, top, l], [l, top, h], [l, 0., h]]);
    quad([[h, 0., l], [h, top, l], [h, top, h], [h, 0., h]]);
    for _ in 0..200 {
        let o = [0.6, 0.5, 0.6].map(|x| x + rng.range(-0.15, 0.15));
        let c = [0, 1, 2].map(|_| [0, 1, 2].map(|a| o[a] + rng.range(-0.03, 0.03)));
        let base = mesh.positions.len() as u32;
        mesh.positions
            .extend(c.iter().map(|p| Point3::new(p[0], p[1], p[2])));
        mesh.triangles.push([base, base + 1, base + 2]);
        mesh.material.push(0);
    }
    mesh
}

/// Rays from inside the room of [`room_mesh`]: every third towards a point of the box's
/// bottom face, which lies on the floor, so the floor and the box's bottom are hit at
/// distances a few ulps apart; the others in random directions.
fn room_rays(rng: &mut Uniforms, n: usize) -> Vec<(Ray, f32)> {
    (0..n)
        .map(|k| {
            let o = Point3::new(
                rng.range(0.05, 0.95),
                rng.range(0.25, 0.95),
                rng.range(0.05, 0.95),
            );
            let target = if k % 3 == 0 {
                Point3::new(rng.range(0.3, 0.5), 0.0, rng.range(0.3, 0.5))
            } else {
                Point3::new(
                    rng.range(-1.0, 2.0),
                    rng.range(-1.0, 2.0),
                    rng.range(-1.0, 2.0),
                )
            };
            let t_max = if k % 5 == 0 {
                rng.range(0.1, 1.0)
            } else {
                f32::INFINITY
            };
            (Ray::new(o, (target - o).normalize()), t_max)
        })
        .collect()
}

/// Triangle ids of each leaf of `w`.
fn leaf_triangles<const N: usize>(w: &Wide<N>) -> Vec<Vec<u32>> {
    let refs = w.nodes.iter().flat_map(|n| n.child).chain([w.root]);
    refs.filter(|&r| r & LEAF != 0 && r != EMPTY_CHILD)
        .map(|r| {
            let packets = ((r & !LEAF) >> LEAF_COUNT_SHIFT) as usize;
            let first = (r & LEAF_FIRST_MASK) as usize;
            w.packet_ids[first..first + packets]
                .iter()
                .flatten()
                .copied()
                .filter(|&id| id != u32::MAX)
                .collect()
        })
        .collect()
}

#[test]
fn walls_of_a_room_are_leaves_of_their_own() {
    // A leaf holding a wall and anything else would be entered by nearly every ray from
    // inside the room; each wall's two triangles must be alone in their leaf.
    let mesh = room_mesh(&mut Uniforms(5));
    for width in [4, 8] {
        let bvh = Bvh::with_width(mesh.clone(), width);
        let leaves = match &bvh.tree {
            Tree::Four(w, _) => leaf_triangles(w),
            Tree::Eight(w, _) => leaf_triangles(w),
        };
        for leaf in leaves {
            if let Some(wall) = leaf.iter().find(|&&id| id < 10).map(|id| id / 2) {
                assert!(
                    leaf.iter().all(|&id| id / 2 == wall && id < 10),
                    "width {width}: leaf {leaf:?} mixes wall {wall} with other triangles"
                );
            }
        }
    }
}

fn four(b: &Bvh) -> &Wide<4> {
    match &b.tree {
        Tree::Four(w, _) => w,
        Tree::Eight(..) => unreachable!("built with width 4"),
    }
}

fn eight(b: &Bvh) -> &Wide<8> {
    match &b.tree {
        Tree::Eight(w, _) => w,
        Tree::Four(..) => unreachable!("built with width 8"),
    }
}

#[test]
fn four_wide_tree_agrees_with_brute_force_native() {
    agrees_with_brute_force(4, &|b, r, t| {
        let w = four(b);
        (
            w.intersect::<_, _, PORTABLE_OR_SSE>(NATIVE, NATIVE, r, 0.0, t),
            w.occluded::<_, _, PORTABLE_OR_SSE>(NATIVE, NATIVE, r, 0.0, t),
        )
    });
}

#[test]
fn four_wide_tree_agrees_with_brute_force_portable() {
    agrees_with_brute_force(4, &|b, r, t| {
        let w = four(b);
        (
            w.intersect::<_, _, PORTABLE_OR_SSE>(
                Portable::<4>::new(),
                Portable::<4>::new(),
                r,
                0.0,
                t,
            ),
            w.occluded::<_, _, PORTABLE_OR_SSE>(
                Portable::<4>::new(),
                Portable::<4>::new(),
                r,
                0.0,
                t,
            ),
        )
    });
}

#[test]
fn eight_wide_tree_agrees_with_brute_force_portable() {
    agrees_with_brute_force(8, &|b, r, t| {
        let w = eight(b);
        (
            w.intersect::<_, _, PORTABLE_OR_SSE>(
                Portable::<8>::new(),
                Portable::<8>::new(),
                r,
                0.0,
                t,
            ),
            w.occluded::<_, _, PORTABLE_OR_SSE>(
                Portable::<8>::new(),
                Portable::<8>::new(),
                r,
                0.0,
                t,
            ),
        )
    });
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(not(femto_host_avx), ignore = "needs AVX (not on this CPU)")]
fn eight_wide_tree_agrees_with_brute_force_avx() {
    let avx = Avx::new().expect("built on a CPU with AVX, run on one without");
    let isa = Some(Isa::Avx(avx));
    agrees_with_brute_force(8, &move |b, r, t| {
        let w = eight(b);
        (
            intersect_eight(w, isa, r, 0.0, t),
            occluded_eight(w, isa, r, 0.0, t),
        )
    });
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(
    not(femto_host_avx512),
    ignore = "needs AVX-512 F and VL (not on this CPU)"
)]
fn eight_wide_tree_agrees_with_brute_force_avx512() {
    let proof = Avx512::new().expect("built on a CPU with AVX-512, run on one without");
    let isa = Some(Isa::Avx512(proof));
    agrees_with_brute_force(8, &move |b, r, t| {
        let w = eight(b);
        (
            intersect_eight(w, isa, r, 0.0, t),
            occluded_eight(w, isa, r, 0.0, t),
        )
    });
}

#[test]
fn eight_wide_trees_without_an_instruction_set_use_plain_arrays() {
    agrees_with_brute_force(8, &|b, r, t| {
        let w = eight(b);
        (
            intersect_eight(w, None, r, 0.0, t),
            occluded_eight(w, None, r, 0.0, t),
        )
    });
}

/// Each lane of the packet test is the scalar test, bit for bit, including lanes that
/// take the double-precision fallback (rays through shared edges and corners).
fn packet_lanes_are_the_scalar_test<S: Simd<PACKET>>(lanes: S) {
    let mut rng = Uniforms(12);
    let mesh = test_mesh(&mut rng);
    let bvh = Bvh::with_width(mesh, 4);
    let w = four(&bvh);
    let mut compared = 0;
    for (ray, t_max) in test_rays(&mut rng, 400) {
        let consts = RayConsts::new(&ray);
        let tri_ray = TriRay::new(lanes, &consts);
        for (p, ids) in w.packets.iter().zip(&w.packet_ids) {
            let h = packet_test(lanes, p, &tri_ray, 0.0, t_max);
            for (j, &id) in ids.iter().enumerate() {
                let scalar = if id == u32::MAX {
                    None
                } else {
                    intersect_triangle(&p.corners(j), &consts, 0.0, t_max)
                };
                match scalar {
                    None => assert_eq!(h.mask & (1 << j), 0),
                    Some(s) => {
                        compared += 1;
                        assert_ne!(h.mask & (1 << j), 0);
                        assert_eq!(
                            (h.t[j].to_bits(), h.u[j].to_bits(), h.v[j].to_bits()),
                            (s.t.to_bits(), s.u.to_bits(), s.v.to_bits())
                        );
                    }
                }
            }
        }
    }
    assert!(compared > 400, "{compared}");
}

#[test]
fn packet_lanes_are_the_scalar_test_native() {
    packet_lanes_are_the_scalar_test(NATIVE);
}

#[test]
fn packet_lanes_are_the_scalar_test_portable() {
    packet_lanes_are_the_scalar_test(Portable::<4>::new());
}

/// Each lane of the eight-lane leaf test (two packets side by side, or one packet whose
/// upper half is masked off) is the scalar test of its triangle, bit for bit.
fn pair_lanes_are_the_scalar_test<T: LeafLanes>(lanes: T) {
    let mut rng = Uniforms(13);
    let mesh = test_mesh(&mut rng);
    let bvh = Bvh::with_width(mesh, 4);
    let w = four(&bvh);
    let mut compared = 0;
    for (ray, t_max) in test_rays(&mut rng, 300) {
        let consts = RayConsts::new(&ray);
        let tri_ray = lanes.ray(&consts);
        for first in 0..w.packets.len() {
            for count in 1..=2.min(w.packets.len() - first) {
                let h = lanes.test_leaf(&w.packets, first, count, &tri_ray, 0.0, t_max, false);
                for lane in 0..8 {
                    let (pk, j) = (first + lane / PACKET, lane % PACKET);
                    let id = if lane < PACKET * count {
                        w.packet_ids[pk][j]
                    } else {
                        u32::MAX
                    };
                    let scalar = if id == u32::MAX {
                        None
                    } else {
                        intersect_triangle(&w.packets[pk].corners(j), &consts, 0.0, t_max)
                    };
                    match scalar {
                        None => assert_eq!(h.mask & (1 << lane), 0),
                        Some(s) => {
                            compared += 1;
                            assert_ne!(h.mask & (1 << lane), 0);
                            assert_eq!(
                                (h.t[lane].to_bits(), h.u[lane].to_bits()),
                                (s.t.to_bits(), s.u.to_bits())
                            );
                            assert_eq!(h.v[lane].to_bits(), s.v.to_bits());
                        }
                    }
                }
            }
        }
    }
    assert!(compared > 300, "{compared}");
}

#[test]
fn pair_lanes_are_the_scalar_test_portable() {
    pair_lanes_are_the_scalar_test(Portable::<8>::new());
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(not(femto_host_avx), ignore = "needs AVX (not on this CPU)")]
fn pair_lanes_are_the_scalar_test_avx() {
    let avx = Avx::new().expect("built on a CPU with AVX, run on one without");
    // SAFETY: the proof `avx` says that the CPU runs AVX.
    unsafe { pair_lanes_avx(avx) }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn pair_lanes_avx(avx: Avx) {
    pair_lanes_are_the_scalar_test(avx);
}

#[test]
fn leaf_lanes_native_are_the_scalar_test() {
    pair_lanes_are_the_scalar_test(NATIVE);
}

#[test]
fn nan_and_zero_rays_do_not_hit_or_panic() {
    let mesh = TriangleMesh {
        positions: vec![
            Point3::new(-1.0, -1.0, 1.0),
            Point3::new(1.0, -1.0, 1.0),
            Point3::new(0.0, 1.0, 1.0),
        ],
        triangles: vec![[0, 1, 2]],
        material: vec![0],
    };
    let bvh = Bvh::new(mesh);
    let o = Point3::origin();
    for dir in [Vector3::zeros(), Vector3::new(f32::NAN, 0.0, 1.0)] {
        assert!(bvh
            .intersect(&Ray::new(o, dir), 0.0, f32::INFINITY)
            .is_none());
    }
    let ray = Ray::new(o, Vector3::z());
    assert!(bvh.intersect(&ray, f32::NAN, 10.0).is_none());
    assert!(
        bvh.intersect(&ray, 0.0, 1.0).is_none(),
        "t_max is exclusive"
    );
    assert!(
        bvh.intersect(&ray, 1.0, 2.0).is_none(),
        "t_min is exclusive"
    );
    assert!(bvh.intersect(&ray, 0.5, 2.0).is_some());
}

/// A hit as bits, so that two paths are compared bit for bit (`-0.0 != 0.0`, NaN == NaN).
fn hit_bits(h: Option<Hit>) -> Option<(u32, [u32; 6])> {
    h.map(|h| {
        (
            h.triangle,
            [h.t, h.u, h.v, h.normal.x, h.normal.y, h.normal.z].map(f32::to_bits),
        )
    })
}

/// `level` forced with [`Bvh::with_simd`] builds its tree and lanes and gives the scalar
/// level's hits through the public API, on the random soup and inside the room:
/// - bit for bit (triangle, distance, barycentrics, normal) and the same occlusion against
///   the scalar path of its own tree (the four-wide tree with plain arrays for `sse`, the
///   eight-wide tree with plain arrays for `avx2` and `avx512`): the same lane operations
///   visit the same nodes in the same order;
/// - against `scalar` itself (the four-wide tree): the same distance bit for bit and the
///   same triangle, or on a tie of distance one that hits at exactly that distance.
fn forced_level_gives_the_scalar_hits(level: SimdLevel) {
    let mut rng = Uniforms(21);
    let soup = test_mesh(&mut rng);
    let soup_rays = test_rays(&mut rng, 2000);
    let room = room_mesh(&mut rng);
    let room_rays = room_rays(&mut rng, 1500);
    let mut hits = 0;
    for (mesh, rays) in [(soup, soup_rays), (room, room_rays)] {
        let forced =
            Bvh::with_simd(mesh.clone(), Some(level)).unwrap_or_else(|e| panic!("{level}: {e}"));
        assert_eq!(forced.simd(), Some(level));
        let scalar = Bvh::with_simd(mesh.clone(), Some(SimdLevel::Scalar)).unwrap();
        assert!(matches!(scalar.tree, Tree::Four(_, FourLanes::Portable)));
        let same_tree = match (level, &forced.tree) {
            (SimdLevel::Scalar, Tree::Four(_, FourLanes::Portable)) => scalar.clone(),
            (SimdLevel::Sse, Tree::Four(_, FourLanes::Native)) => {
                Bvh::build_with(mesh.clone(), Layout::Four(FourLanes::Portable), None)
            }
            #[cfg(target_arch = "x86_64")]
            (SimdLevel::Avx2, Tree::Eight(_, Some(Isa::Avx(_))))
            | (SimdLevel::Avx512, Tree::Eight(_, Some(Isa::Avx512(_)))) => {
                Bvh::build_with(mesh.clone(), Layout::Eight(None), None)
            }
            (l, t) => panic!("{l} built {}", describe(t)),
        };
        for (k, (ray, t_max)) in rays.iter().enumerate() {
            let got = forced.intersect(ray, 0.0, *t_max);
            let occluded = forced.occluded(ray, 0.0, *t_max);
            let reference = same_tree.intersect(ray, 0.0, *t_max);
            assert_eq!(hit_bits(got), hit_bits(reference), "{level} ray {k}");
            assert_eq!(occluded, same_tree.occluded(ray, 0.0, *t_max), "ray {k}");
            let s = scalar.intersect(ray, 0.0, *t_max);
            assert_eq!(occluded, scalar.occluded(ray, 0.0, *t_max), "ray {k}");
            match (got, s) {
                (None, None) => {}
                (Some(g), Some(s)) => {
                    hits += 1;
                    assert_eq!(g.t.to_bits(), s.t.to_bits(), "{level} ray {k}");
                    if g.triangle != s.triangle {
                        let c = mesh.corners(g.triangle as usize).map(|p| [p.x, p.y, p.z]);
                        let other = intersect_triangle(&c, &RayConsts::new(ray), 0.0, *t_max);
                        assert_eq!(other.map(|h| h.t.to_bits()), Some(s.t.to_bits()));
                    }
                }
                (g, s) => panic!("{level} ray {k}: {g:?}, scalar {s:?}"),
            }
        }
    }
    assert!(hits > 1000, "only {hits} hits");
}

fn describe(t: &Tree) -> String {
    match t {
        Tree::Four(_, lanes) => format!("a four-wide tree with {lanes:?} lanes"),
        Tree::Eight(_, isa) => format!("an eight-wide tree with {isa:?}"),
    }
}

#[test]
fn forced_scalar_is_the_four_wide_tree_with_plain_arrays() {
    forced_level_gives_the_scalar_hits(SimdLevel::Scalar);
}

#[cfg(target_arch = "x86_64")]
#[test]
fn forced_sse_gives_the_scalar_hits_bit_for_bit() {
    forced_level_gives_the_scalar_hits(SimdLevel::Sse);
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(
    not(femto_host_avx2),
    ignore = "needs AVX2, BMI1/2, LZCNT and POPCNT (not on this CPU)"
)]
fn forced_avx2_gives_the_scalar_hits() {
    forced_level_gives_the_scalar_hits(SimdLevel::Avx2);
}

#[cfg(target_arch = "x86_64")]
#[test]
#[cfg_attr(
    not(femto_host_avx512),
    ignore = "needs AVX-512 F and VL with AVX2 and BMI (not on this CPU)"
)]
fn forced_avx512_gives_the_scalar_hits() {
    forced_level_gives_the_scalar_hits(SimdLevel::Avx512);
}

#[test]
fn a_level_is_built_exactly_where_the_cpu_runs_it() {
    let mesh = test_mesh(&mut Uniforms(5));
    for level in SimdLevel::ALL {
        match Bvh::with_simd(mesh.clone(), Some(level)) {
            Ok(b) => {
                assert!(level.is_supported(), "{level}");
                assert_eq!(b.simd(), Some(level));
            }
            Err(e) => {
                assert!(!level.is_supported(), "{level}: {e}");
                assert!(
                    matches!(e, SimdError::Unsupported { level: l, .. } if l == level),
                    "{e}"
                );
            }
        }
    }
    // `auto` is what `Bvh::new` builds without FEMTO_SIMD: the widest tree the CPU runs.
    let auto = Bvh::with_simd(mesh, None).unwrap();
    assert_eq!(auto.simd(), None);
    #[cfg(target_arch = "x86_64")]
    assert_eq!(
        matches!(auto.tree, Tree::Eight(_, Some(_))),
        std::arch::is_x86_feature_detected!("avx")
    );
    #[cfg(not(target_arch = "x86_64"))]
    assert!(matches!(auto.tree, Tree::Four(_, FourLanes::Native)));
}

/// `Bvh::intersect_distances` gives `Bvh::intersect`'s distances bit for bit, for rays from
/// one origin outside the mesh's box (most miss it), on its face planes and inside a room, in
/// random, axis-parallel and degenerate directions, at every SIMD level this CPU runs.
#[test]
fn batch_distances_are_the_single_ray_distances() {
    let mut rng = Uniforms(7);
    let meshes = [
        test_mesh(&mut rng),
        room_mesh(&mut rng),
        TriangleMesh::default(),
    ];
    let mut levels = vec![None, Some(SimdLevel::Scalar), Some(SimdLevel::Sse)];
    levels.extend(
        [SimdLevel::Avx2, SimdLevel::Avx512]
            .into_iter()
            .filter(|l| l.is_supported())
            .map(Some),
    );
    let (mut hits, mut misses) = (0, 0);
    for mesh in &meshes {
        for &level in &levels {
            let bvh = Bvh::with_simd(mesh.clone(), level).unwrap();
            let origins = [
                Point3::new(0.5, 0.6, 0.4),
                Point3::new(3.0, -5.0, 7.0),
                Point3::new(-2.0, 0.5, 0.5),
                Point3::new(1.0, 0.0, 0.5),
            ];
            for o in origins {
                let mut dirs: Vec<Vector3<f32>> = (0..203)
                    .map(|_| {
                        let t = Point3::new(
                            rng.range(-3.0, 3.0),
                            rng.range(-3.0, 3.0),
                            rng.range(-3.0, 3.0),
                        );
                        t - o
                    })
                    .collect();
                dirs.extend([
                    Vector3::x(),
                    -Vector3::x(),
                    Vector3::y(),
                    -Vector3::z(),
                    Vector3::zeros(),
                    Vector3::new(0.0, -0.0, 1.0),
                    Vector3::new(f32::NAN, 0.0, 1.0),
                    Vector3::new(f32::INFINITY, 1.0, 0.0),
                ]);
                for (t_min, t_max) in [(0.0, f32::INFINITY), (0.5, 2.0), (1.0, 1.0)] {
                    let mut got = vec![Some(f32::NAN); dirs.len()];
                    bvh.intersect_distances(o, &dirs, t_min, t_max, &mut got);
                    for (d, got) in dirs.iter().zip(&got) {
                        let want = bvh.intersect(&Ray::new(o, *d), t_min, t_max).map(|h| h.t);
                        assert_eq!(
                            got.map(f32::to_bits),
                            want.map(f32::to_bits),
                            "{level:?} origin {o:?} dir {d:?} t {t_min}..{t_max}"
                        );
                        if want.is_some() {
                            hits += 1;
                        } else {
                            misses += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
}
