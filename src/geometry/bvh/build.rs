//! Building the BVH: the binary tree by the binned surface area heuristic (with the rules for
//! rays that start inside a room, see the module doc of [`super`]), and its collapse into a
//! wide tree of `N` children per node with leaves of packets of four triangles.

use super::*;

impl<const N: usize> Wide<N> {
    /// Collapse the binary tree `binary` (leaves index the build `order`) into a wide one.
    pub(super) fn collapse(
        binary: &[BuildNode],
        order: &[u32],
        corners: &dyn Fn(u32) -> [[f32; 3]; 3],
    ) -> Wide<N> {
        let mut wide = Wide {
            root: EMPTY_CHILD,
            nodes: Vec::with_capacity(binary.len() / (N - 1) + 1),
            packets: Vec::with_capacity(order.len() / 2 + 1),
            packet_ids: Vec::with_capacity(order.len() / 2 + 1),
        };
        if !binary.is_empty() {
            wide.root = wide.emit(binary, order, corners, 0);
        }
        wide
    }

    /// Emit binary node `ni` and its subtree; returns its child reference.
    pub(super) fn emit(
        &mut self,
        binary: &[BuildNode],
        order: &[u32],
        corners: &dyn Fn(u32) -> [[f32; 3]; 3],
        ni: usize,
    ) -> u32 {
        let n = &binary[ni];
        if n.count > 0 {
            return self.leaf(order, corners, n.first as usize, n.count as usize);
        }
        // Open the interior child of largest area until there are N.
        let mut kids = vec![n.first as usize, n.first as usize + 1];
        while kids.len() < N {
            let widest = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| binary[k].count == 0)
                .max_by(|a, b| half_area(&binary[*a.1]).total_cmp(&half_area(&binary[*b.1])));
            let Some((i, &k)) = widest else {
                break;
            };
            let first = binary[k].first as usize;
            kids[i] = first;
            kids.push(first + 1);
        }
        let index = self.nodes.len();
        self.nodes.push(Node::EMPTY);
        for (lane, &k) in kids.iter().enumerate() {
            let b = binary[k].bounds;
            let child = self.emit(binary, order, corners, k);
            let node = &mut self.nodes[index];
            for (plane, &x) in b.iter().enumerate() {
                node.bounds[plane][lane] = x;
            }
            node.child[lane] = child;
        }
        index as u32
    }

    /// Pack leaf slots `first .. first + count` of the build order into packets.
    pub(super) fn leaf(
        &mut self,
        order: &[u32],
        corners: &dyn Fn(u32) -> [[f32; 3]; 3],
        first: usize,
        count: usize,
    ) -> u32 {
        let first_packet = self.packets.len();
        for chunk in order[first..first + count].chunks(PACKET) {
            let mut p = TriPacket {
                v: [[[f32::NAN; PACKET]; 3]; 3],
            };
            let mut ids = [u32::MAX; PACKET];
            for (j, &tri) in chunk.iter().enumerate() {
                for (k, corner) in corners(tri).iter().enumerate() {
                    for (a, &x) in corner.iter().enumerate() {
                        p.v[k][a][j] = x;
                    }
                }
                ids[j] = tri;
            }
            self.packets.push(p);
            self.packet_ids.push(ids);
        }
        let n_packets = self.packets.len() - first_packet;
        assert!(
            first_packet <= LEAF_FIRST_MASK as usize && n_packets < 8,
            "BVH leaf reference overflow: {first_packet} packets"
        );
        LEAF | ((n_packets as u32) << LEAF_COUNT_SHIFT) | first_packet as u32
    }
}

/// Half the surface area of a binary node's box.
pub(super) fn half_area(n: &BuildNode) -> f32 {
    let d = [0, 1, 2].map(|a| (n.bounds[3 + a] - n.bounds[a]).max(0.0));
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// One node of the binary build tree.
#[derive(Clone, Copy, Debug)]
pub(super) struct BuildNode {
    /// Box corners: `min` x, y, z then `max` x, y, z.
    pub(super) bounds: [f32; 6],
    /// Leaf: first entry of the build order. Interior: index of its first child (the second
    /// follows it).
    pub(super) first: u32,
    /// Number of triangles of a leaf; 0 for an interior node.
    pub(super) count: u32,
}

/// Build record of one triangle.
pub(super) struct Prim {
    pub(super) lo: [f32; 3],
    pub(super) hi: [f32; 3],
    pub(super) centroid: [f32; 3],
}

impl Prim {
    /// Half the surface area of the triangle's box.
    pub(super) fn half_area(&self) -> f32 {
        let d = [0, 1, 2].map(|a| (self.hi[a] - self.lo[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

#[derive(Clone, Copy)]
pub(super) struct Bin {
    pub(super) count: u32,
    pub(super) lo: [f32; 3],
    pub(super) hi: [f32; 3],
}

impl Bin {
    const EMPTY: Bin = Bin {
        count: 0,
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };

    pub(super) fn add(&mut self, p: &Prim) {
        self.count += 1;
        self.grow(&p.lo, &p.hi);
    }

    pub(super) fn grow(&mut self, lo: &[f32; 3], hi: &[f32; 3]) {
        for a in 0..3 {
            self.lo[a] = self.lo[a].min(lo[a]);
            self.hi[a] = self.hi[a].max(hi[a]);
        }
    }

    pub(super) fn merge(&mut self, o: &Bin) {
        self.count += o.count;
        self.grow(&o.lo, &o.hi);
    }

    /// Half the surface area (0 for an empty bin).
    pub(super) fn half_area(&self) -> f32 {
        if self.count == 0 {
            return 0.0;
        }
        let d = [0, 1, 2].map(|a| (self.hi[a] - self.lo[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// Build the flattened tree; returns the nodes and the mesh triangle index of each leaf slot.
pub(super) fn build(mesh: &TriangleMesh) -> (Vec<BuildNode>, Vec<u32>) {
    let mut prims = Vec::with_capacity(mesh.triangle_count());
    let mut order = Vec::with_capacity(mesh.triangle_count());
    for i in 0..mesh.triangle_count() {
        let c = mesh.corners(i).map(|p: Point3<f32>| [p.x, p.y, p.z]);
        // Zero area (coincident or collinear corners, or non-finite ones): never hit, so leave out.
        let n = cross_f64(&c);
        if !(n.norm_squared() > 0.0 && n.norm_squared().is_finite()) {
            continue;
        }
        let lo = [0, 1, 2].map(|a| c[0][a].min(c[1][a]).min(c[2][a]));
        let hi = [0, 1, 2].map(|a| c[0][a].max(c[1][a]).max(c[2][a]));
        let centroid = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
        prims.push(Prim { lo, hi, centroid });
        order.push(i as u32);
    }
    let mut scene = Bin::EMPTY;
    for p in &prims {
        scene.add(p);
    }
    let scene_area = scene.half_area();
    let mut nodes = Vec::new();
    if prims.is_empty() {
        return (nodes, order);
    }
    let mut idx: Vec<u32> = (0..prims.len() as u32).collect();
    nodes.reserve(2 * prims.len());
    nodes.push(BuildNode {
        bounds: [0.0; 6],
        first: 0,
        count: 0,
    });
    // (node, start, end, depth)
    let mut work = vec![(0usize, 0usize, prims.len(), 0u32)];
    while let Some((ni, s, e, depth)) = work.pop() {
        let mut bounds = Bin::EMPTY;
        let mut cbounds = Bin::EMPTY;
        for &i in &idx[s..e] {
            let p = &prims[i as usize];
            bounds.add(p);
            cbounds.grow(&p.centroid, &p.centroid);
        }
        nodes[ni].bounds = [
            bounds.lo[0],
            bounds.lo[1],
            bounds.lo[2],
            bounds.hi[0],
            bounds.hi[1],
            bounds.hi[2],
        ];
        let count = e - s;
        let mid = if count <= 1 {
            None
        } else {
            split(&prims, &mut idx[s..e], &bounds, &cbounds, depth, scene_area).map(|m| s + m)
        };
        match mid {
            None => {
                nodes[ni].first = s as u32;
                nodes[ni].count = count as u32;
            }
            Some(mid) => {
                let l = nodes.len();
                let child = BuildNode {
                    bounds: [0.0; 6],
                    first: 0,
                    count: 0,
                };
                nodes.push(child);
                nodes.push(child);
                nodes[ni].first = l as u32;
                nodes[ni].count = 0;
                // Left popped first, so its subtree is laid out next to this node.
                work.push((l + 1, mid, e, depth + 1));
                work.push((l, s, mid, depth + 1));
            }
        }
    }
    let order = idx.iter().map(|&i| order[i as usize]).collect();
    (nodes, order)
}

/// Choose how to split `idx` (at least two triangles; `scene_area`: half area of the box of
/// all triangles): partitions it in place and returns the size of the left part, or `None` to
/// make a leaf.
pub(super) fn split(
    prims: &[Prim],
    idx: &mut [u32],
    bounds: &Bin,
    cbounds: &Bin,
    depth: u32,
    scene_area: f32,
) -> Option<usize> {
    let count = idx.len();
    let extent = [0, 1, 2].map(|a| cbounds.hi[a] - cbounds.lo[a]);
    let axis = (0..3)
        .max_by(|&a, &b| extent[a].total_cmp(&extent[b]))
        .unwrap_or(0);
    let median = |idx: &mut [u32]| {
        let m = idx.len() / 2;
        idx.select_nth_unstable_by(m, |&i, &j| {
            prims[i as usize].centroid[axis].total_cmp(&prims[j as usize].centroid[axis])
        });
        Some(m)
    };
    // Coincident centroids cannot be binned: any partition is as good as another. (Extents
    // are finite: triangles with non-finite corners were left out.)
    if extent[axis] <= 0.0 {
        return if count <= MAX_LEAF {
            None
        } else {
            Some(count / 2)
        };
    }
    if depth >= SAH_DEPTH {
        return median(idx);
    }
    let room = bounds.half_area() > ROOM_FRACTION * scene_area;
    if room {
        // Large triangles first, the others after.
        let large = LARGE_FRACTION * scene_area;
        let mut left = 0;
        for j in 0..count {
            if prims[idx[j] as usize].half_area() > large {
                idx.swap(j, left);
                left += 1;
            }
        }
        if left > 0 && left < count {
            return Some(left);
        }
    }

    // Binned SAH over every axis with non-zero centroid extent.
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, last left bin)
    for a in 0..3 {
        if extent[a] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent[a];
        let mut bins = [Bin::EMPTY; BINS];
        for &i in idx.iter() {
            let p = &prims[i as usize];
            bins[bin_of(p.centroid[a], cbounds.lo[a], scale)].add(p);
        }
        // Sweep from the right: area and count of bins (k+1)..BINS.
        let mut right_area = [0f32; BINS];
        let mut right_count = [0u32; BINS];
        let mut acc = Bin::EMPTY;
        for k in (1..BINS).rev() {
            acc.merge(&bins[k]);
            right_area[k - 1] = acc.half_area();
            right_count[k - 1] = acc.count;
        }
        let mut acc = Bin::EMPTY;
        for k in 0..BINS - 1 {
            acc.merge(&bins[k]);
            if acc.count == 0 || right_count[k] == 0 {
                continue;
            }
            let cost = acc.half_area() * blocks(acc.count as usize)
                + right_area[k] * blocks(right_count[k] as usize);
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, a, k));
            }
        }
    }
    let Some((cost, a, k)) = best else {
        return median(idx);
    };
    let parent_area = bounds.half_area();
    let split_cost = COST_TRAVERSAL + cost / parent_area;
    if split_cost >= blocks(count) && count <= MAX_LEAF && !room {
        return None;
    }
    let scale = BINS as f32 / extent[a];
    let lo = cbounds.lo[a];
    let mut left = 0;
    for j in 0..count {
        if bin_of(prims[idx[j] as usize].centroid[a], lo, scale) <= k {
            idx.swap(j, left);
            left += 1;
        }
    }
    if left == 0 || left == count {
        return median(idx);
    }
    Some(left)
}

/// SAH cost of testing `n` triangles: the number of packets they fill.
pub(super) fn blocks(n: usize) -> f32 {
    n.div_ceil(PACKET) as f32
}

#[inline]
pub(super) fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    // `as usize` saturates (negative and NaN give 0).
    (((c - lo) * scale) as usize).min(BINS - 1)
}
