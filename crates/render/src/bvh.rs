//! Bounding volume hierarchy over all primitives: a binary tree built with the binned
//! surface-area heuristic, collapsed into 4-wide nodes (one ray against four boxes per step),
//! closest-hit and any-hit traversal, and any-hit for packets of up to 16 rays. Exact: the box
//! test is conservative, so the closest hit is the one a brute-force loop over all primitives
//! finds (tests check this).
//!
//! Kept rather than the `obvhs` crate (compressed 8-wide BVH, PLOC build), measured on the
//! camera and shadow rays of cornell-tube, mesh-occluder and two-tubes at 256²: this tree was
//! faster per ray in every case (closest hit 26–41 vs 48–96 ns, any hit 17–69 vs 23–96 ns,
//! minimum of 15 interleaved passes) for about the same instruction count, obvhs reported 6 of
//! 62 066 cornell-tube shadow rays differently (its box test is not made conservative), and it
//! needs glam 0.33–0.34 besides the workspace's 0.30.

use crate::shapes::{intersect_triangle_edges, Aabb, Hit, Primitive, Ray};
use glam::Vec3;

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
/// Cost of one traversal step relative to one primitive test.
const TRAVERSAL_COST: f32 = 1.0;
/// Below this depth the builder stops using SAH and splits at the median, which halves the
/// count: the tree depth stays ≤ SAH_DEPTH + log2(n) ≤ 64 (the recursion depth of the build).
const SAH_DEPTH: u32 = 30;

/// Build-time node: bounds, and either a primitive range (leaf) or the right child (interior).
#[derive(Clone, Copy, Debug)]
struct BuildNode {
    bounds: Aabb,
    /// Leaf: first primitive. Interior: index of the right child (the left one is next).
    offset: u32,
    /// Number of primitives in a leaf; 0 for interior nodes.
    count: u32,
    /// Split axis of an interior node (traversal order).
    axis: u8,
}

/// Traversal node of the 4-wide tree the binary build is collapsed into: the boxes of up to
/// four children side by side, `b[0]` = lower and `b[1]` = upper corners as `[axis][lane]`, so
/// one ray is tested against four boxes with lane-parallel arithmetic. The near and far planes
/// of an axis are `b[s][axis]` and `b[1 − s][axis]` for the ray's direction sign s on that axis.
/// Empty slots have lower = +∞, upper = −∞ and never pass the test.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    b: [[[f32; WIDTH]; 3]; 2],
    /// Interior child: its node index. Leaf child: its first primitive.
    child: [u32; WIDTH],
    /// Leaf child: number of primitives (≥ 1). Interior child or empty slot: 0.
    count: [u32; WIDTH],
}

const WIDTH: usize = 4;

impl Node {
    const EMPTY: Node = Node {
        b: [[[f32::INFINITY; WIDTH]; 3], [[f32::NEG_INFINITY; WIDTH]; 3]],
        child: [u32::MAX; WIDTH],
        count: [0; WIDTH],
    };
}

/// Collapse the binary subtree at `root` into 4-wide nodes appended to `out`; returns the index
/// of its node. Children are opened largest surface area first until four slots are used.
fn collapse(bin: &[BuildNode], root: u32, out: &mut Vec<Node>) -> u32 {
    let index = out.len() as u32;
    out.push(Node::EMPTY);
    let r = &bin[root as usize];
    let mut kids: Vec<u32> = if r.count > 0 {
        vec![root]
    } else {
        vec![root + 1, r.offset]
    };
    while kids.len() < WIDTH {
        let open = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| bin[k as usize].count == 0)
            .max_by(|a, b| {
                let area = |k: u32| bin[k as usize].bounds.half_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(i, _)| i);
        let Some(i) = open else { break };
        let k = kids.swap_remove(i);
        kids.push(k + 1);
        kids.push(bin[k as usize].offset);
    }
    for (lane, &k) in kids.iter().enumerate() {
        let n = &bin[k as usize];
        let (child, count) = if n.count > 0 {
            (n.offset, n.count)
        } else {
            (collapse(bin, k, out), 0)
        };
        let node = &mut out[index as usize];
        for a in 0..3 {
            node.b[0][a][lane] = n.bounds.min[a];
            node.b[1][a][lane] = n.bounds.max[a];
        }
        node.child[lane] = child;
        node.count[lane] = count;
    }
    index
}

/// What traversal needs to intersect a primitive: triangles with their edges precomputed (same
/// arithmetic as [`Primitive::intersect`], so the same results bit for bit), everything else
/// through the primitive itself.
#[derive(Clone, Copy, Debug)]
enum Isect {
    Triangle { v0: Vec3, e1: Vec3, e2: Vec3 },
    Other,
}

/// Primitives and the tree over them (primitives are reordered at build time).
#[derive(Clone, Debug)]
pub struct Bvh {
    prims: Vec<Primitive>,
    isect: Vec<Isect>,
    nodes: Vec<Node>,
}

struct BuildItem {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

/// 1 + 2γ₃ with γₙ = nε/(1 − nε), ε = 2⁻²⁴: scaling the far slab distance by it makes the
/// rounded box test conservative (PBRT's robust ray–box test), so no hit inside a box is lost.
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Per-ray constants of the box test.
struct RayBoxes {
    o: [f32; 3],
    inv: [f32; 3],
    /// 1 where the direction component is negative (its near plane is the box's max).
    sign: [usize; 3],
}

impl RayBoxes {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let inv = ray.d.recip();
        Self {
            o: ray.o.to_array(),
            inv: inv.to_array(),
            sign: [
                inv.x.is_sign_negative() as usize,
                inv.y.is_sign_negative() as usize,
                inv.z.is_sign_negative() as usize,
            ],
        }
    }

    /// Entry distances into the four child boxes and which of them the ray's (t_min, t_max)
    /// meets. A NaN slab distance (0·∞: origin on a slab plane of a parallel ray) leaves the
    /// interval unchanged, which is conservative.
    #[inline(always)]
    fn hits(&self, node: &Node, t_min: f32, t_max: f32) -> ([f32; WIDTH], [bool; WIDTH]) {
        let mut t0 = [t_min; WIDTH];
        let mut t1 = [t_max; WIDTH];
        for a in 0..3 {
            let s = self.sign[a] & 1;
            let (o, inv) = (self.o[a], self.inv[a]);
            let (nb, fb) = (&node.b[s][a], &node.b[s ^ 1][a]);
            for i in 0..WIDTH {
                let near = (nb[i] - o) * inv;
                let far = (fb[i] - o) * inv * FAR_SCALE;
                t0[i] = if near > t0[i] { near } else { t0[i] };
                t1[i] = if far < t1[i] { far } else { t1[i] };
            }
        }
        let mut hit = [false; WIDTH];
        for i in 0..WIDTH {
            hit[i] = t0[i] <= t1[i];
        }
        (t0, hit)
    }
}

/// Most rays in one [`Bvh::occluded_packet`].
pub const PACKET: usize = 16;

/// A packet of rays as structure of arrays, for box tests of all rays at once. Lanes beyond the
/// packet have an empty interval and never hit.
struct RayPacket<const N: usize> {
    o: [[f32; N]; 3],
    inv: [[f32; N]; 3],
    /// Direction component negative (its near plane is the box's max).
    neg: [[bool; N]; 3],
    t_min: [f32; N],
    t_max: [f32; N],
}

impl<const N: usize> RayPacket<N> {
    #[inline(always)]
    fn new(rays: &[Ray]) -> Self {
        let mut p = RayPacket {
            o: [[0.0; N]; 3],
            inv: [[0.0; N]; 3],
            neg: [[false; N]; 3],
            t_min: [f32::INFINITY; N],
            t_max: [f32::NEG_INFINITY; N],
        };
        for (i, ray) in rays.iter().enumerate() {
            let inv = ray.d.recip();
            for a in 0..3 {
                p.o[a][i] = ray.o[a];
                p.inv[a][i] = inv[a];
                p.neg[a][i] = inv[a].is_sign_negative();
            }
            (p.t_min[i], p.t_max[i]) = (ray.t_min, ray.t_max);
        }
        p
    }

    /// Bit i: ray i meets child `lane`'s box within its (t_min, t_max) — the same conservative
    /// slab test as [`RayBoxes::hits`] (a NaN slab distance leaves the interval unchanged).
    #[inline(always)]
    fn hits(&self, node: &Node, lane: usize) -> u32 {
        let mut t0 = self.t_min;
        let mut t1 = self.t_max;
        for a in 0..3 {
            let (lo, hi) = (node.b[0][a][lane], node.b[1][a][lane]);
            for i in 0..N {
                let (nb, fb) = if self.neg[a][i] { (hi, lo) } else { (lo, hi) };
                let near = (nb - self.o[a][i]) * self.inv[a][i];
                let far = (fb - self.o[a][i]) * self.inv[a][i] * FAR_SCALE;
                t0[i] = if near > t0[i] { near } else { t0[i] };
                t1[i] = if far < t1[i] { far } else { t1[i] };
            }
        }
        let mut mask = 0u32;
        for i in 0..N {
            mask |= ((t0[i] <= t1[i]) as u32) << i;
        }
        mask
    }
}

/// A pending subtree: (child, count, entry distance) as in [`Node`].
type Entry = (u32, u32, f32);
/// Entries of the traversal stack held on the call stack (zeroing it is a per-ray cost, so it
/// is small); more pending subtrees spill into a Vec, which stays exact, only slower. A 4-wide
/// level adds at most 3 entries net, so spilling needs a deep tree and an unlucky ray.
const STACK: usize = 16;

impl Bvh {
    pub fn build(prims: Vec<Primitive>) -> Self {
        let mut items: Vec<BuildItem> = prims
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                let b = p.bounds();
                // Primitives with non-finite bounds can never be hit reliably: drop them.
                (b.min.is_finite() && b.max.is_finite()).then(|| BuildItem {
                    bounds: b,
                    centroid: b.centroid(),
                    index: i as u32,
                })
            })
            .collect();
        let mut bin = Vec::with_capacity(2 * items.len().max(1));
        let mut nodes = Vec::new();
        if !items.is_empty() {
            let n = items.len();
            build_node(&mut items, 0, n, 0, &mut bin);
            collapse(&bin, 0, &mut nodes);
        }
        let ordered: Vec<Primitive> = items
            .iter()
            .map(|it| prims[it.index as usize].clone())
            .collect();
        let isect = ordered
            .iter()
            .map(|p| match *p {
                Primitive::Triangle { v, .. } => Isect::Triangle {
                    v0: v[0],
                    e1: v[1] - v[0],
                    e2: v[2] - v[0],
                },
                _ => Isect::Other,
            })
            .collect();
        Self {
            prims: ordered,
            isect,
            nodes,
        }
    }

    pub fn primitive(&self, i: u32) -> &Primitive {
        &self.prims[i as usize]
    }

    pub fn len(&self) -> usize {
        self.prims.len()
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Intersection of primitive `i` (in BVH order) with `ray`, as [`Primitive::intersect`].
    #[inline(always)]
    fn intersect_prim(&self, i: usize, ray: &Ray) -> Option<(f32, f32, f32)> {
        match self.isect[i] {
            Isect::Triangle { v0, e1, e2 } => intersect_triangle_edges(ray, v0, e1, e2),
            Isect::Other => self.prims[i].intersect(ray),
        }
    }

    /// Closest hit in (t_min, t_max).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_with::<STACK>(ray)
    }

    /// Whether anything lies in (t_min, t_max).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with::<STACK>(ray)
    }

    /// [`Self::intersect`] with an N-entry stack (tests force spilling with N = 1).
    #[inline(always)]
    fn intersect_with<const N: usize>(&self, ray: &Ray) -> Option<Hit> {
        let mut ray = *ray;
        let mut best: Option<Hit> = None;
        self.traverse::<N>(&mut ray, |bvh, i, ray| {
            if let Some((t, b1, b2)) = bvh.intersect_prim(i as usize, ray) {
                ray.t_max = t;
                best = Some(Hit { t, prim: i, b1, b2 });
            }
            false
        });
        best
    }

    #[inline(always)]
    fn occluded_with<const N: usize>(&self, ray: &Ray) -> bool {
        let mut ray = *ray;
        let mut hit = false;
        self.traverse::<N>(&mut ray, |bvh, i, ray| {
            hit = bvh.intersect_prim(i as usize, ray).is_some();
            hit
        });
        hit
    }

    /// [`Self::occluded`] for a packet of up to [`PACKET`] rays (shadow rays of a batched
    /// renderer: 8–16 rays from nearby shading points or toward one light). Bit i of the result
    /// is set iff `rays[i]` is occluded, exactly as `occluded(&rays[i])` says.
    ///
    /// The packet walks the tree once: each node's four boxes are tested against every ray
    /// still unresolved (one loop over the rays per box, which the compiler vectorises), and a
    /// subtree is entered with the mask of the rays that hit its box; a leaf tests its
    /// primitives for those rays only; the walk ends when every ray is occluded. Coherent rays
    /// share their node visits; incoherent ones cost about what they cost one by one.
    pub fn occluded_packet(&self, rays: &[Ray]) -> u32 {
        assert!(rays.len() <= PACKET, "at most {PACKET} rays per packet");
        if self.nodes.is_empty() || rays.is_empty() {
            0
        } else if rays.len() <= 8 {
            self.occluded_packet_isa::<8>(rays)
        } else {
            self.occluded_packet_isa::<PACKET>(rays)
        }
    }

    /// The packet walk compiled for the best vector extension this CPU has (chosen at run
    /// time, as `linlight_sampling::batch` does): the box tests of 8–16 rays are one or two
    /// AVX-512/AVX2 instructions per operation instead of four SSE2 ones.
    #[inline(always)]
    fn occluded_packet_isa<const N: usize>(&self, rays: &[Ray]) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use linlight_sampling::batch::Isa;
            #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
            unsafe fn avx512<const N: usize>(bvh: &Bvh, rays: &[Ray]) -> u32 {
                bvh.occluded_packet_n::<N>(rays)
            }
            #[target_feature(enable = "avx2,fma")]
            unsafe fn avx2<const N: usize>(bvh: &Bvh, rays: &[Ray]) -> u32 {
                bvh.occluded_packet_n::<N>(rays)
            }
            match Isa::detect() {
                // SAFETY: the features the functions are compiled for were detected.
                Isa::Avx512 if std::arch::is_x86_feature_detected!("avx512bw") => unsafe {
                    return avx512::<N>(self, rays);
                },
                Isa::Avx512 | Isa::Avx2 => unsafe { return avx2::<N>(self, rays) },
                Isa::Baseline => {}
            }
        }
        self.occluded_packet_n::<N>(rays)
    }

    /// [`Self::occluded_packet`] with N lanes (N ≥ `rays.len()`).
    #[inline(always)]
    fn occluded_packet_n<const N: usize>(&self, rays: &[Ray]) -> u32 {
        let packet = RayPacket::<N>::new(rays);
        let all = (1u32 << rays.len()) - 1;
        let mut occluded = 0u32;
        // (child, count, ray mask) as in `Node`; on the call stack, spilling into a Vec.
        let mut stack = [(0u32, 0u32, 0u32); 64];
        let mut spill: Vec<(u32, u32, u32)> = Vec::new();
        let mut sp = 1;
        stack[0] = (0, 0, all);
        loop {
            let (child, count, mask) = if let Some(e) = spill.pop() {
                e
            } else if sp > 0 {
                sp -= 1;
                stack[sp]
            } else {
                return occluded;
            };
            let mask = mask & !occluded;
            if mask == 0 {
                continue;
            }
            if count > 0 {
                for i in child..child + count {
                    let mut m = mask & !occluded;
                    while m != 0 {
                        let r = m.trailing_zeros() as usize;
                        m &= m - 1;
                        if self.intersect_prim(i as usize, &rays[r]).is_some() {
                            occluded |= 1 << r;
                        }
                    }
                }
                if occluded == all {
                    return occluded;
                }
                continue;
            }
            let node = &self.nodes[child as usize];
            for lane in 0..WIDTH {
                let hits = packet.hits(node, lane) & mask;
                if hits != 0 {
                    let e = (node.child[lane], node.count[lane], hits);
                    if sp < stack.len() && spill.is_empty() {
                        stack[sp] = e;
                        sp += 1;
                    } else {
                        spill.push(e);
                    }
                }
            }
        }
    }

    /// Visit leaves front to back (nearest box entry first, subtrees entered beyond the
    /// current t_max skipped); `visit` returns true to stop.
    #[inline(always)]
    fn traverse<const N: usize>(
        &self,
        ray: &mut Ray,
        mut visit: impl FnMut(&Self, u32, &mut Ray) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let rb = RayBoxes::new(ray);
        let mut stack: [Entry; N] = [(0, 0, 0.0); N];
        let mut spill: Vec<Entry> = Vec::new();
        let mut sp = 0usize;
        // The nearest child of the last node, entered without a trip through the stack.
        let mut next: Option<Entry> = Some((0, 0, ray.t_min));
        loop {
            let (child, count, t_enter) = if let Some(e) = next.take() {
                e
            } else if let Some(e) = spill.pop() {
                e
            } else if sp > 0 {
                sp -= 1;
                stack[sp]
            } else {
                return;
            };
            if t_enter > ray.t_max {
                continue;
            }
            if count > 0 {
                for i in child..child + count {
                    if visit(self, i, ray) {
                        return;
                    }
                }
                continue;
            }
            let node = &self.nodes[child as usize];
            let (t0, hit) = rb.hits(node, ray.t_min, ray.t_max);
            // Hit lanes sorted by entry distance, farthest first: the nearest is entered next,
            // the others are pushed so that the nearer ones are popped first.
            let mut order = [0usize; WIDTH];
            let mut n = 0;
            for lane in 0..WIDTH {
                if hit[lane] {
                    let mut j = n;
                    while j > 0 && t0[order[j - 1]] < t0[lane] {
                        order[j] = order[j - 1];
                        j -= 1;
                    }
                    order[j] = lane;
                    n += 1;
                }
            }
            if n == 0 {
                continue;
            }
            let entry = |lane: usize| (node.child[lane], node.count[lane], t0[lane]);
            next = Some(entry(order[n - 1]));
            for &lane in &order[..n - 1] {
                let e = entry(lane);
                if sp < N && spill.is_empty() {
                    stack[sp] = e;
                    sp += 1;
                } else {
                    spill.push(e);
                }
            }
        }
    }
}

fn build_node(
    items: &mut [BuildItem],
    start: usize,
    end: usize,
    depth: u32,
    nodes: &mut Vec<BuildNode>,
) -> u32 {
    let index = nodes.len() as u32;
    let mut bounds = Aabb::EMPTY;
    let mut cbounds = Aabb::EMPTY;
    for it in &items[start..end] {
        bounds = bounds.union(&it.bounds);
        cbounds.grow(it.centroid);
    }
    nodes.push(BuildNode {
        bounds,
        offset: start as u32,
        count: (end - start) as u32,
        axis: 0,
    });
    let n = end - start;
    if n <= 1 {
        return index;
    }
    let split = if depth < SAH_DEPTH {
        best_split(&items[start..end], &bounds, &cbounds)
    } else {
        None
    };
    let mid = match split {
        Some((axis, bin, _cost)) => {
            let lo = cbounds.min[axis];
            let scale = BINS as f32 / (cbounds.max[axis] - lo);
            let bin_of = |c: Vec3| (((c[axis] - lo) * scale) as usize).min(BINS - 1);
            let slice = &mut items[start..end];
            let mut m = 0;
            for i in 0..slice.len() {
                if bin_of(slice[i].centroid) <= bin {
                    slice.swap(i, m);
                    m += 1;
                }
            }
            nodes[index as usize].axis = axis as u8;
            start + m
        }
        None if n <= MAX_LEAF => return index,
        None => {
            // No useful SAH split (coincident centroids, or too deep): median split on the
            // widest centroid axis.
            let axis = (cbounds.max - cbounds.min).max_position();
            items[start..end].sort_by(|a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
            nodes[index as usize].axis = axis as u8;
            start + n / 2
        }
    };
    if mid == start || mid == end {
        return index; // keep as leaf (cannot happen with the binning above, kept for safety)
    }
    build_node(items, start, mid, depth + 1, nodes);
    let right = build_node(items, mid, end, depth + 1, nodes);
    let node = &mut nodes[index as usize];
    node.offset = right;
    node.count = 0;
    index
}

/// Best (axis, last bin of the left side, cost) by binned SAH, if it beats a leaf.
fn best_split(items: &[BuildItem], bounds: &Aabb, cbounds: &Aabb) -> Option<(usize, usize, f32)> {
    let leaf_cost = items.len() as f32;
    let mut best: Option<(usize, usize, f32)> = None;
    let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
    for axis in 0..3 {
        let lo = cbounds.min[axis];
        let extent = cbounds.max[axis] - lo;
        if !(extent > 0.0) {
            continue;
        }
        let scale = BINS as f32 / extent;
        let mut bin_bounds = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for it in items {
            let b = (((it.centroid[axis] - lo) * scale) as usize).min(BINS - 1);
            bin_bounds[b] = bin_bounds[b].union(&it.bounds);
            bin_count[b] += 1;
        }
        // Sweep from the right to get suffix areas and counts.
        let mut right_area = [0f32; BINS];
        let mut right_count = [0usize; BINS];
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for b in (1..BINS).rev() {
            acc = acc.union(&bin_bounds[b]);
            cnt += bin_count[b];
            right_area[b] = acc.half_area();
            right_count[b] = cnt;
        }
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for b in 0..BINS - 1 {
            acc = acc.union(&bin_bounds[b]);
            cnt += bin_count[b];
            if cnt == 0 || right_count[b + 1] == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST
                + (acc.half_area() * cnt as f32 + right_area[b + 1] * right_count[b + 1] as f32)
                    / parent_area;
            if best.is_none_or(|(_, _, c)| cost < c) {
                best = Some((axis, b, cost));
            }
        }
    }
    match best {
        Some((_, _, cost)) if cost < leaf_cost || items.len() > MAX_LEAF => best,
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_sampling::rng::Pcg32;

    /// The BVH must agree with brute force on closest hits and any-hits.
    #[test]
    fn matches_brute_force() {
        let mut rng = Pcg32::new(7, 0);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = Vec::new();
        for i in 0..300 {
            let c = r3() * 10.0;
            let v = [c, c + 3.0 * (r3() - 0.5), c + 3.0 * (r3() - 0.5)];
            prims.push(Primitive::Triangle {
                v,
                n: None,
                shape: i,
            });
        }
        for i in 0..20 {
            prims.push(Primitive::Sphere {
                center: r3() * 10.0,
                radius: 0.3,
                shape: 300 + i,
            });
        }
        for i in 0..5 {
            let to_world = glam::Mat4::from_scale_rotation_translation(
                Vec3::splat(0.8),
                glam::Quat::from_axis_angle((r3() - 0.5).normalize_or(Vec3::X), 1.0),
                r3() * 10.0,
            );
            let to_local = to_world.inverse();
            let normal = crate::shapes::transformed_normal(&to_local);
            prims.push(Primitive::Disk {
                to_local,
                normal,
                shape: 500 + i,
            });
        }
        prims.push(Primitive::Cylinder {
            p0: Vec3::splat(1.0),
            axis: Vec3::new(1.0, 1.0, 0.0).normalize(),
            length: 6.0,
            radius: 0.2,
            shape: 400,
        });
        let bvh = Bvh::build(prims.clone());
        assert_eq!(bvh.len(), prims.len());
        let mut hits = 0;
        for _ in 0..2000 {
            let o = r3() * 14.0 - 2.0;
            let d = (r3() - 0.5).normalize_or(Vec3::X);
            let ray = Ray {
                o,
                d,
                t_min: 0.0,
                t_max: 8.0,
            };
            let brute = prims
                .iter()
                .filter_map(|p| p.intersect(&ray).map(|(t, ..)| (t, p.shape())))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let fast = bvh
                .intersect(&ray)
                .map(|h| (h.t, bvh.primitive(h.prim).shape()));
            assert_eq!(brute, fast);
            assert_eq!(brute.is_some(), bvh.occluded(&ray));
            // A one-entry stack spills on almost every node: same answers.
            let spilled = bvh
                .intersect_with::<1>(&ray)
                .map(|h| (h.t, bvh.primitive(h.prim).shape()));
            assert_eq!(brute, spilled);
            assert_eq!(brute.is_some(), bvh.occluded_with::<1>(&ray));
            hits += brute.is_some() as usize;
        }
        assert!(hits > 200, "too few hits to test anything: {hits}");
    }

    /// Packets of 1–16 rays (coherent: one origin; and incoherent) give the occlusion of each
    /// ray exactly as `occluded` does.
    #[test]
    fn packets_match_single_rays() {
        let mut rng = Pcg32::new(3, 9);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = Vec::new();
        for i in 0..400 {
            let c = r3() * 10.0;
            let v = [c, c + 2.0 * (r3() - 0.5), c + 2.0 * (r3() - 0.5)];
            prims.push(Primitive::Triangle {
                v,
                n: None,
                shape: i,
            });
        }
        prims.push(Primitive::Sphere {
            center: Vec3::splat(5.0),
            radius: 1.0,
            shape: 400,
        });
        let bvh = Bvh::build(prims);
        let (mut occluded, mut total) = (0, 0);
        for k in 0..600 {
            let size = 1 + k % PACKET;
            let origin = r3() * 12.0 - 1.0;
            let rays: Vec<Ray> = (0..size)
                .map(|_| {
                    let o = if k % 2 == 0 {
                        origin
                    } else {
                        r3() * 12.0 - 1.0
                    };
                    let target = r3() * 12.0 - 1.0;
                    Ray {
                        o,
                        d: (target - o).normalize_or(Vec3::X),
                        t_min: 0.0,
                        t_max: (target - o).length(),
                    }
                })
                .collect();
            let mask = bvh.occluded_packet(&rays);
            for (i, ray) in rays.iter().enumerate() {
                assert_eq!(mask >> i & 1 == 1, bvh.occluded(ray), "packet {k}, ray {i}");
                occluded += bvh.occluded(ray) as usize;
                total += 1;
            }
            assert_eq!(mask >> size, 0);
        }
        assert!(
            occluded > total / 5 && occluded < total * 4 / 5,
            "{occluded}/{total}"
        );
        assert_eq!(Bvh::build(Vec::new()).occluded_packet(&[]), 0);
    }

    /// Trees whose root is a leaf, or that are empty, collapse and traverse like any other.
    #[test]
    fn single_primitive_and_empty() {
        let tri = Primitive::Triangle {
            v: [Vec3::ZERO, Vec3::X, Vec3::Y],
            n: None,
            shape: 0,
        };
        let bvh = Bvh::build(vec![tri]);
        let ray = |x: f32| Ray {
            o: Vec3::new(x, 0.25, 1.0),
            d: Vec3::NEG_Z,
            t_min: 0.0,
            t_max: 2.0,
        };
        assert_eq!(bvh.intersect(&ray(0.25)).map(|h| h.t), Some(1.0));
        assert!(bvh.occluded(&ray(0.25)));
        assert!(bvh.intersect(&ray(0.9)).is_none() && !bvh.occluded(&ray(0.9)));
        let empty = Bvh::build(Vec::new());
        assert!(empty.intersect(&ray(0.25)).is_none() && !empty.occluded(&ray(0.25)));
    }

    /// Geometrically spaced and coincident primitives: bounded depth, still exact.
    #[test]
    fn pathological_distributions() {
        let mut prims = Vec::new();
        for i in 0..3000 {
            let x = 0.99f32.powi(i);
            let v = [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            ];
            prims.push(Primitive::Triangle {
                v,
                n: None,
                shape: i as u32,
            });
            // Many copies of one triangle (identical centroids).
            let w = [
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(2.0, 1.0, 0.0),
                Vec3::new(2.0, 0.0, 1.0),
            ];
            prims.push(Primitive::Triangle {
                v: w,
                n: None,
                shape: 5000,
            });
        }
        let bvh = Bvh::build(prims.clone());
        for k in 0..200 {
            let y = 0.101 + 0.004 * k as f32; // never on the edge y + z = 1
            let ray = Ray {
                o: Vec3::new(-1.0, y, 0.2),
                d: Vec3::X,
                t_min: 0.0,
                t_max: 10.0,
            };
            let brute = prims
                .iter()
                .filter_map(|p| p.intersect(&ray).map(|(t, ..)| t))
                .min_by(f32::total_cmp);
            assert_eq!(brute, bvh.intersect(&ray).map(|h| h.t));
            let far = Ray {
                o: Vec3::new(1.5, y, 0.2),
                ..ray
            };
            assert_eq!(bvh.occluded(&far), y + 0.2 <= 1.0, "y = {y}");
        }
    }
}
