//! Bounding volume hierarchy over all primitives: a binary tree built with the binned
//! surface-area heuristic, collapsed into 4-wide nodes (one ray against four boxes per step),
//! closest-hit and any-hit traversal, and any-hit for packets of up to 16 rays. Exact: the box
//! test is conservative, so the closest hit is the one a brute-force loop over all primitives
//! finds (tests check this), up to the rounding of a triangle's t against its box's computed
//! entry: a subtree entered beyond the current closest distance is skipped, which on rare
//! rays skips a hit within rounding of that distance (docs/performance.md, "Large scenes").
//!
//! Kept rather than the `obvhs` crate (compressed 8-wide BVH, PLOC build): on the camera and
//! shadow rays of cornell-tube, mesh-occluder and two-tubes at 256² this tree is faster per
//! ray in every case (closest hit 26–41 vs 48–96 ns, any hit 17–69 vs 23–96 ns, minimum of 15
//! interleaved passes) for about the same instruction count; obvhs reports 6 of 62 066
//! cornell-tube shadow rays differently (its box test is not made conservative), and it needs
//! glam 0.33–0.34 besides the workspace's 0.30.

use crate::shapes::{intersect_triangle_lane, Aabb, Hit, Primitive, Ray};
use kernels::Kernel;

mod kernels;
use glam::{Vec3, Vec3A};
use rayon::prelude::*;

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

/// Most primitives (all triangles) for which the packet walks skip the tree and test every
/// triangle against every ray of the packet. Measured (docs/performance.md): a triangle costs
/// such a walk ~13 instructions per ray (AVX2), the tree walk of cornell-tube's 34 triangles
/// ~170–190, so the crossover is at 12–13 triangles (with AVX-512 too, 34 are slower).
const TINY: usize = 12;

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
    // The (at most WIDTH) children of the node, kids[..len].
    let mut kids = [0u32; WIDTH];
    let mut len = if r.count > 0 {
        kids[0] = root;
        1
    } else {
        kids[..2].copy_from_slice(&[root + 1, r.offset]);
        2
    };
    while len < WIDTH {
        let open = kids[..len]
            .iter()
            .enumerate()
            .filter(|(_, &k)| bin[k as usize].count == 0)
            .max_by(|a, b| {
                let area = |k: u32| bin[k as usize].bounds.half_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(i, _)| i);
        let Some(i) = open else { break };
        // As Vec::swap_remove and two pushes.
        let k = kids[i];
        kids[i] = kids[len - 1];
        kids[len - 1] = k + 1;
        kids[len] = bin[k as usize].offset;
        len += 1;
    }
    for (lane, &k) in kids[..len].iter().enumerate() {
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

/// The 4-wide tree of the binary tree `bin` (empty when `bin` is), allocated once: a 4-wide
/// node holds at least one interior node of the binary tree (or is the root leaf), so there
/// are at most max(1, interior) of them and the pages past the tree's end are never touched.
/// The vector is shrunk to its length after `bin` is freed (a copy: `Node` is over-aligned
/// for `realloc`). Grown by pushes, the old and the new allocation would coexist on every
/// doubling, at the peak memory of a large scene's build.
fn collapsed(bin: Vec<BuildNode>) -> Vec<Node> {
    let interior = bin.iter().filter(|n| n.count == 0).count();
    let mut nodes = Vec::with_capacity(interior.max(1));
    if !bin.is_empty() {
        collapse(&bin, 0, &mut nodes);
    }
    drop(bin);
    nodes.shrink_to_fit();
    nodes
}

/// What traversal needs to intersect a primitive: triangles with their edges precomputed (same
/// arithmetic as [`Primitive::intersect`], so the same results bit for bit), everything else
/// through the primitive itself.
#[derive(Clone, Copy, Debug)]
enum Isect {
    Triangle {
        v0: Vec3,
        e1: Vec3,
        e2: Vec3,
    },
    /// The radius as f32: an f64 r² would make every entry 8 bytes larger, which costs the
    /// triangle walks of cornell-tube ~5 instructions per sample.
    Sphere {
        center: Vec3,
        radius: f32,
    },
    Other,
}

/// Primitives and the tree over them (primitives are reordered at build time).
#[derive(Clone, Debug)]
pub struct Bvh {
    /// The primitives in the caller's order (less those with non-finite bounds): a reordered
    /// copy would be the largest allocation of a large scene, a random-access permutation in
    /// place costs more than the indirection on hits.
    prims: Vec<Primitive>,
    /// BVH position → index into `prims`.
    order: Vec<u32>,
    isect: Vec<Isect>,
    nodes: Vec<Node>,
    /// A tree of at most [`TINY`] primitives, all triangles: (v0, e1, e2) of each, in BVH
    /// order, which the packet walks test against every ray without traversal (see
    /// [`Bvh::intersect_lanes`]); empty otherwise.
    tiny: Vec<[Vec3; 3]>,
    /// The packet walks' kernel, detected once at build (detection per walk costs ~70
    /// instructions per packet): AVX-512 (with BW), AVX2 + FMA, or the target's baseline.
    walk_isa: linlight_simd::Isa,
}

/// 1 + 2γ₃ with γₙ = nε/(1 − nε), ε = 2⁻²⁴: scaling the far slab distance by it makes the
/// rounded box test conservative (PBRT's robust ray–box test), so no hit inside a box is lost.
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Bit i set where child i's interval [t0, t1] is not empty (a NaN bound: empty).
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn hit_mask(t0: &[f32; WIDTH], t1: &[f32; WIDTH]) -> u32 {
    (0..WIDTH).fold(0, |hit, i| hit | ((t0[i] <= t1[i]) as u32) << i)
}

/// Per-ray constants of the box test.
struct RayBoxes {
    o: [f32; 3],
    inv: [f32; 3],
    /// Per axis, the row of the node's planes as `[[f32; WIDTH]; 6]` (lower corners' axes,
    /// then upper corners') holding the near planes: the upper one where the direction
    /// component is negative. The far planes are the other corner's row.
    near: [usize; 3],
    far: [usize; 3],
}

impl RayBoxes {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        Self::with_inv(ray, ray.d.recip().to_array())
    }

    /// [`Self::new`] with `inv` = 1 / `ray.d`, computed by the caller.
    #[inline(always)]
    fn with_inv(ray: &Ray, inv: [f32; 3]) -> Self {
        debug_assert!(
            (0..3).all(|a| inv[a].to_bits() == (1.0 / ray.d[a]).to_bits() || inv[a].is_nan()),
            "inv {inv:?} is not 1 / {}",
            ray.d
        );
        let s = inv.map(|v| v.is_sign_negative() as usize);
        Self {
            o: ray.o.to_array(),
            inv,
            near: std::array::from_fn(|a| s[a] * 3 + a),
            far: std::array::from_fn(|a| (1 - s[a]) * 3 + a),
        }
    }

    /// Entry distances into the four child boxes and which of them the ray's (t_min, t_max)
    /// meets (bit i: child i). A NaN slab distance (0·∞: origin on a slab plane of a parallel
    /// ray) leaves the interval unchanged, which is conservative.
    #[inline(always)]
    fn hits(&self, node: &Node, t_min: f32, t_max: f32) -> ([f32; WIDTH], u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE is part of x86-64. `Node` is 64-byte aligned with its 24 planes
            // first, so rows 0..6 of four floats each are 16-byte aligned; `near` and `far`
            // are rows below 6 (`new`).
            unsafe {
                let b = node.b.as_ptr() as *const f32;
                let mut t0 = _mm_set1_ps(t_min);
                let mut t1 = _mm_set1_ps(t_max);
                for a in 0..3 {
                    let (o, inv) = (_mm_set1_ps(self.o[a]), _mm_set1_ps(self.inv[a]));
                    let nb = _mm_load_ps(b.add(self.near[a] * WIDTH));
                    let fb = _mm_load_ps(b.add(self.far[a] * WIDTH));
                    let near = _mm_mul_ps(_mm_sub_ps(nb, o), inv);
                    let far =
                        _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(fb, o), inv), _mm_set1_ps(FAR_SCALE));
                    // near > t0 ? near : t0 (NaN: no constraint), likewise for t1.
                    t0 = _mm_max_ps(near, t0);
                    t1 = _mm_min_ps(far, t1);
                }
                let hit = _mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32;
                (std::mem::transmute::<__m128, [f32; WIDTH]>(t0), hit)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut t0 = [t_min; WIDTH];
            let mut t1 = [t_max; WIDTH];
            let rows = [
                node.b[0][0],
                node.b[0][1],
                node.b[0][2],
                node.b[1][0],
                node.b[1][1],
                node.b[1][2],
            ];
            for a in 0..3 {
                let (o, inv) = (self.o[a], self.inv[a]);
                let (nb, fb) = (&rows[self.near[a]], &rows[self.far[a]]);
                for i in 0..WIDTH {
                    let near = (nb[i] - o) * inv;
                    let far = (fb[i] - o) * inv * FAR_SCALE;
                    t0[i] = if near > t0[i] { near } else { t0[i] };
                    t1[i] = if far < t1[i] { far } else { t1[i] };
                }
            }
            (t0, hit_mask(&t0, &t1))
        }
    }
}

/// Most rays in one packet ([`Bvh::intersect_lanes`], [`Bvh::occluded_lanes`]).
pub const PACKET: usize = 16;

/// Most 4-wide nodes of a tree whose packet walks test boxes against a coherent packet by
/// intervals. The interval box of shadow rays fanning out from one pixel's points toward a
/// long light covers the whole wedge between them, and that of a pixel's camera rays a whole
/// pixel footprint, which on a large tree holds many triangles: it enters subtrees no ray
/// meets (many-meshes, 2.3 M triangles: ~30× the cost per shadow ray of ray-by-ray box tests;
/// camera rays on ladder-4m: 6.5×), while on a small tree (the committed scenes, at most a few
/// hundred nodes) it is the cheaper test. Larger trees test ray by ray the boxes that the
/// intervals of a coherent packet do not reject (every box of an incoherent one); both tests
/// are conservative, so the hits are those of the ray-by-ray walk (docs/performance.md has the
/// measurements).
const INTERVAL_NODES: usize = 1024;

/// Most 4-wide nodes of a tree whose walks do not prefetch ([`Bvh::prefetch`]): 512 KiB of
/// nodes, which stay in the cache, where a prefetch adds only its instructions (ladder-10k's
/// tree is below, ladder-100k's above; docs/performance.md).
const PREFETCH_NODES: usize = 4096;

/// A subtree that at most this many rays of a packet walk on a large tree enter is walked ray
/// by ray (the walk of [`Bvh::occluded`] or [`Bvh::intersect`] from that node): the packet's
/// box and triangle tests cost all sixteen lanes whatever the number of rays.
const FEW_RAYS: u32 = 2;

/// Up to [`PACKET`] rays as structure of arrays (the rays of a packet renderer); which lanes
/// hold rays is a separate bit mask.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))] // one cache line per component: whole-register loads never split
pub struct RayLanes {
    pub o: [[f32; PACKET]; 3],
    pub d: [[f32; PACKET]; 3],
    pub t_min: [f32; PACKET],
    pub t_max: [f32; PACKET],
}

impl Default for RayLanes {
    fn default() -> Self {
        Self {
            o: [[0.0; PACKET]; 3],
            d: [[0.0; PACKET]; 3],
            t_min: [0.0; PACKET],
            t_max: [0.0; PACKET],
        }
    }
}

impl RayLanes {
    /// Lanes 0..rays.len() from `rays` (at most [`PACKET`]).
    pub fn from_rays(rays: &[Ray]) -> Self {
        assert!(rays.len() <= PACKET, "at most {PACKET} rays per packet");
        let mut lanes = Self::default();
        for (i, r) in rays.iter().enumerate() {
            lanes.set(i, r);
        }
        lanes
    }

    #[inline(always)]
    pub fn get(&self, i: usize) -> Ray {
        Ray {
            o: Vec3::new(self.o[0][i], self.o[1][i], self.o[2][i]),
            d: Vec3::new(self.d[0][i], self.d[1][i], self.d[2][i]),
            t_min: self.t_min[i],
            t_max: self.t_max[i],
        }
    }

    #[inline(always)]
    pub fn set(&mut self, i: usize, r: &Ray) {
        for a in 0..3 {
            self.o[a][i] = r.o[a];
            self.d[a][i] = r.d[a];
        }
        self.t_min[i] = r.t_min;
        self.t_max[i] = r.t_max;
    }
}

/// A packet of rays prepared for box tests. Lanes outside the packet's mask have an empty
/// interval and never hit. Built by a [`Kernel`] (`Kernel::packet`); origins and directions are
/// read from the caller's [`RayLanes`], not copied.
///
/// When every ray has the same direction sign on each axis (the camera rays of a pixel or a
/// row of pixels, shadow rays from a pixel's points toward a light that does not straddle
/// them), the packet is also kept as intervals: per axis, the bounds of the origins and of the
/// reciprocal directions. A node's four boxes are then tested against the whole packet at once
/// by interval arithmetic — the slab distance (plane − o)·inv is bilinear in (o, inv), so its
/// extremes over the packet are at corners of the bounds — which gives an entry distance no ray
/// undercuts and an exit no ray exceeds (the exit scaled by the same 1 + 2γ₃ as the ray-by-ray
/// test; a NaN corner, 0·∞, leaves the axis unconstrained). Conservative like that test, it
/// only decides which subtrees the packet enters: every ray still meets the primitives with its
/// own exact test. Other packets are tested ray by ray.
#[repr(C, align(64))] // the lane arrays first, one cache line each
struct RayPacket<'a> {
    /// 1 / d per axis and lane; its sign bit says that the near plane is the box's max.
    inv: [[f32; PACKET]; 3],
    /// The rays' intervals: +∞ and −∞ outside the packet (t_max kept up to date by the
    /// closest-hit walk).
    t_min: [f32; PACKET],
    t_max: [f32; PACKET],
    lanes: &'a RayLanes,
    /// Every ray has the same direction signs (and nothing is NaN): box tests by intervals.
    coherent: bool,
    /// A coherent packet's boxes that pass the interval test are tested ray by ray too (large
    /// trees, see [`INTERVAL_NODES`]): the interval test rejects a node's other children for
    /// the whole packet at once, the ray test keeps exact per-ray masks.
    rays_too: bool,
    /// 1 where the common direction sign is negative.
    sign: [usize; 3],
    /// Origin bound giving the smallest entry (the upper bound for positive directions, the
    /// lower for negative ones) and the one giving the largest exit distance.
    o_near: [f32; 3],
    o_far: [f32; 3],
    /// Bounds of the reciprocal directions.
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    /// Smallest t_min and largest t_max of the rays. `t_hi` is read only when `coherent`
    /// (interval tests), so the closest-hit walk keeps it up to date only then.
    t_lo: f32,
    t_hi: f32,
}

/// Bounds of a packet on one axis: smallest and largest origin, smallest and largest 1/d, and
/// the direction-sign bits of the active rays.
type AxisBounds = (f32, f32, f32, f32, u32);

impl<'a> RayPacket<'a> {
    /// The interval part of the packet from the bounds of its rays, per axis
    /// ([`AxisBounds`]), and the smallest t_min and largest t_max. `ordered`: no active lane has a NaN origin,
    /// reciprocal or interval end (a NaN makes the packet incoherent).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn from_bounds(
        lanes: &'a RayLanes,
        active: u32,
        inv: [[f32; PACKET]; 3],
        t_min: [f32; PACKET],
        t_max: [f32; PACKET],
        axes: [AxisBounds; 3],
        (t_lo, t_hi): (f32, f32),
        ordered: bool,
    ) -> Self {
        let mut p = RayPacket {
            lanes,
            inv,
            t_min,
            t_max,
            coherent: ordered && t_lo <= t_hi,
            rays_too: false,
            sign: [0; 3],
            o_near: [0.0; 3],
            o_far: [0.0; 3],
            inv_lo: [0.0; 3],
            inv_hi: [0.0; 3],
            t_lo,
            t_hi,
        };
        for (a, &(o_lo, o_hi, inv_lo, inv_hi, neg_bits)) in axes.iter().enumerate() {
            // `&`, not `&&`, and selects: no branch per axis.
            let negative = neg_bits == active;
            p.coherent &= (neg_bits == 0) | negative;
            p.coherent &= (o_lo <= o_hi) & (inv_lo <= inv_hi);
            p.sign[a] = negative as usize;
            p.o_near[a] = if negative { o_lo } else { o_hi };
            p.o_far[a] = if negative { o_hi } else { o_lo };
            (p.inv_lo[a], p.inv_hi[a]) = (inv_lo, inv_hi);
        }
        p
    }

    /// A packet tested ray by ray (`coherent` false): the rays' reciprocals and intervals
    /// only, no bounds (they are read only by the interval tests). The kernels build it
    /// without reducing the bounds once the direction signs are mixed or a lane is NaN.
    #[inline(always)]
    fn incoherent(
        lanes: &'a RayLanes,
        inv: [[f32; PACKET]; 3],
        t_min: [f32; PACKET],
        t_max: [f32; PACKET],
    ) -> Self {
        RayPacket {
            lanes,
            inv,
            t_min,
            t_max,
            coherent: false,
            rays_too: false,
            sign: [0; 3],
            o_near: [0.0; 3],
            o_far: [0.0; 3],
            inv_lo: [0.0; 3],
            inv_hi: [0.0; 3],
            t_lo: 0.0,
            t_hi: 0.0,
        }
    }

    /// Whether a packet with these direction-sign bits per axis (of the `active` rays) and
    /// none of them NaN may be coherent: every axis has one sign.
    #[inline(always)]
    fn one_sign_per_axis(neg: [u32; 3], active: u32) -> bool {
        neg.iter().all(|&n| (n == 0) | (n == active))
    }

    /// The four boxes of `node` against the packet as intervals (valid when `coherent`), with
    /// the rays' distances limited to [t_lo, t_hi]: whether some ray may meet each box, and a
    /// lower bound of the rays' entry distances.
    #[inline(always)]
    fn interval_hits(&self, node: &Node) -> ([f32; WIDTH], u32) {
        #[cfg(target_arch = "x86_64")]
        {
            // The same arithmetic in SSE registers (the compiler kept parts of it scalar).
            use std::arch::x86_64::*;
            // SAFETY: SSE and SSE2 are part of x86-64; the loads read four floats each.
            unsafe {
                let mut t0 = _mm_set1_ps(self.t_lo);
                let mut t1 = _mm_set1_ps(self.t_hi);
                let zero = _mm_setzero_ps();
                // c ? x : y for a comparison mask c (SSE2 has no blend).
                let select = |c: __m128, x: __m128, y: __m128| {
                    _mm_or_ps(_mm_and_ps(c, x), _mm_andnot_ps(c, y))
                };
                for a in 0..3 {
                    let s = self.sign[a] & 1;
                    let (nb, fb) = (
                        _mm_loadu_ps(node.b[s][a].as_ptr()),
                        _mm_loadu_ps(node.b[s ^ 1][a].as_ptr()),
                    );
                    let (lo, hi) = (_mm_set1_ps(self.inv_lo[a]), _mm_set1_ps(self.inv_hi[a]));
                    let g = _mm_sub_ps(nb, _mm_set1_ps(self.o_near[a]));
                    let near = _mm_mul_ps(g, select(_mm_cmpge_ps(g, zero), lo, hi));
                    let h = _mm_sub_ps(fb, _mm_set1_ps(self.o_far[a]));
                    let far = _mm_mul_ps(
                        _mm_mul_ps(h, select(_mm_cmpge_ps(h, zero), hi, lo)),
                        _mm_set1_ps(FAR_SCALE),
                    );
                    // near > t0 ? near : t0 (NaN: no constraint), likewise for t1.
                    t0 = _mm_max_ps(near, t0);
                    t1 = _mm_min_ps(far, t1);
                }
                let hit = _mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32;
                (std::mem::transmute::<__m128, [f32; WIDTH]>(t0), hit)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut t0 = [self.t_lo; WIDTH];
            let mut t1 = [self.t_hi; WIDTH];
            for a in 0..3 {
                let s = self.sign[a] & 1;
                let (nb, fb) = (&node.b[s][a], &node.b[s ^ 1][a]);
                let (on, of) = (self.o_near[a], self.o_far[a]);
                let (lo, hi) = (self.inv_lo[a], self.inv_hi[a]);
                for i in 0..WIDTH {
                    // Smallest (nb − o)·inv and largest (fb − o)·inv over the packet's bounds
                    // (a NaN, 0·∞, compares false below: no constraint).
                    let g = nb[i] - on;
                    let near = g * if g >= 0.0 { lo } else { hi };
                    let h = fb[i] - of;
                    let far = h * if h >= 0.0 { hi } else { lo } * FAR_SCALE;
                    t0[i] = if near > t0[i] { near } else { t0[i] };
                    t1[i] = if far < t1[i] { far } else { t1[i] };
                }
            }
            (t0, hit_mask(&t0, &t1))
        }
    }

    /// Per child of `node`: the rays of `mask` that may meet its box and a lower bound of
    /// their entry distances (for the whole packet by intervals, ray by ray, or ray by ray for
    /// the boxes the intervals do not reject: both tests are conservative, so is their
    /// conjunction).
    #[inline(always)]
    fn children<K: Kernel>(&self, node: &Node, mask: u32) -> [(u32, f32); WIDTH] {
        let mut out = [(0u32, f32::INFINITY); WIDTH];
        if self.coherent {
            let (t0, hit) = self.interval_hits(node);
            if self.rays_too {
                // The interval entry t0 bounds every ray's entry from below: it orders the
                // children and culls pending ones (`still_hit`) as the rays' own minimum
                // would, a little less tightly, without its horizontal minimum per box.
                for (lane, o) in out.iter_mut().enumerate() {
                    if hit >> lane & 1 == 1 {
                        *o = (K::box_mask_coherent(self, node, lane) & mask, t0[lane]);
                    }
                }
            } else {
                for lane in 0..WIDTH {
                    out[lane] = (if hit >> lane & 1 == 1 { mask } else { 0 }, t0[lane]);
                }
            }
        } else {
            for (lane, o) in out.iter_mut().enumerate() {
                let (hits, entry) = K::box_hits(self, node, lane);
                *o = (hits & mask, entry);
            }
        }
        out
    }

    /// The rays of `mask` that may still meet the box of `node`'s child `lane`, entered at
    /// `entry` (from [`Self::children`]), now that some have found closer hits.
    #[inline(always)]
    fn still_hit<K: Kernel>(&self, node: &Node, lane: usize, mask: u32, entry: f32) -> u32 {
        if self.coherent && entry > self.t_hi {
            0
        } else if self.coherent && !self.rays_too {
            mask
        } else if self.coherent {
            mask & K::box_mask_coherent(self, node, lane)
        } else {
            mask & K::box_hits(self, node, lane).0
        }
    }
}

/// Closest hits of a packet of up to [`PACKET`] rays ([`Bvh::intersect_lanes`]); lanes of
/// rays that hit nothing (or outside the packet) hold meaningless values.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))] // one cache line per array: whole-register loads never split
pub struct PacketHits {
    pub t: [f32; PACKET],
    /// BVH primitive index ([`Bvh::primitive`]).
    pub prim: [u32; PACKET],
    pub b1: [f32; PACKET],
    pub b2: [f32; PACKET],
    /// Bit i: ray i hits something.
    pub mask: u32,
}

impl PacketHits {
    /// What [`Bvh::intersect`] returns for ray i.
    #[inline]
    pub fn get(&self, i: usize) -> Option<Hit> {
        (self.mask >> i & 1 == 1).then(|| Hit {
            t: self.t[i],
            prim: self.prim[i],
            b1: self.b1[i],
            b2: self.b2[i],
        })
    }
}

/// Whether a hit at t of primitive i replaces the best hit so far (`best_prim` = u32::MAX:
/// none): the closest hit, and among hits at the same t the smallest primitive index, so that
/// the answer does not depend on the order in which the tree is walked. The caller has already
/// checked t < t_max, where t_max = next_up(best t) once a hit is known. No primitive index is
/// u32::MAX ([`Bvh::build`]), so i < best_prim also covers "no hit yet".
#[inline(always)]
fn replaces(t: f32, i: u32, best_t: f32, best_prim: u32) -> bool {
    (t < best_t) | (i < best_prim)
}

/// The rays' t_max on the lanes of `active`, −∞ elsewhere: rays outside the packet never hit
/// (t < −∞ is false).
#[inline(always)]
fn active_t_max(lanes: &RayLanes, active: u32) -> [f32; PACKET] {
    std::array::from_fn(|k| {
        if active >> k & 1 == 1 {
            lanes.t_max[k]
        } else {
            f32::NEG_INFINITY
        }
    })
}

/// 1 / d per axis and lane of a packet's rays.
type Inv = [[f32; PACKET]; 3];

/// A pending subtree of a packet walk: parent node, slot, rays, entry distance.
type PacketEntry = (u32, u32, u32, f32);

/// A fixed stack of `S` entries on the call stack, not initialised (zeroing it would cost a
/// 1 KiB `memset` per packet walk); only entries below the stack pointer are read.
#[inline(always)]
fn stack<T: Copy, const S: usize>() -> [std::mem::MaybeUninit<T>; S] {
    [const { std::mem::MaybeUninit::uninit() }; S]
}

/// Push onto a fixed stack, spilling into a Vec when it is full (exact, only slower).
#[inline(always)]
fn push<T: Copy, const S: usize>(
    stack: &mut [std::mem::MaybeUninit<T>; S],
    sp: &mut usize,
    spill: &mut Vec<T>,
    e: T,
) {
    if *sp < S && spill.is_empty() {
        stack[*sp] = std::mem::MaybeUninit::new(e);
        *sp += 1;
    } else {
        spill.push(e);
    }
}

#[inline(always)]
fn pop<T: Copy, const S: usize>(
    stack: &[std::mem::MaybeUninit<T>; S],
    sp: &mut usize,
    spill: &mut Vec<T>,
) -> Option<T> {
    if let Some(e) = spill.pop() {
        Some(e)
    } else if *sp > 0 {
        *sp -= 1;
        // SAFETY: entries below the stack pointer were written by `push`.
        Some(unsafe { stack[*sp].assume_init() })
    } else {
        None
    }
}
/// A pending subtree: (child, count, entry distance) as in [`Node`].
type Entry = (u32, u32, f32);
/// Entries of the traversal stack held on the call stack (small, to stay in the L1 cache);
/// more pending subtrees spill into a Vec, which stays exact, only slower. A 4-wide level adds
/// at most 3 entries net, so spilling needs a deep tree and an unlucky ray.
const STACK: usize = 16;

impl Bvh {
    pub fn build(mut prims: Vec<Primitive>) -> Self {
        // Primitive indices are u32 below u32::MAX, the packets' "no hit" (see `replaces`).
        assert!(
            prims.len() < u32::MAX as usize,
            "a BVH holds fewer than 2^32 - 1 primitives"
        );
        // Primitives with non-finite bounds can never be hit reliably: drop them.
        prims.retain(|p| {
            let b = p.bounds();
            b.min.is_finite() && b.max.is_finite()
        });
        let mut items: Vec<Box3> = prims
            .iter()
            .map(|p| {
                let b = p.bounds();
                Box3 {
                    min: b.min.into(),
                    max: b.max.into(),
                }
            })
            .collect();
        let mut order: Vec<u32> = (0..items.len() as u32).collect();
        let mut bin = Vec::with_capacity(2 * items.len().max(1));
        if !items.is_empty() {
            let extent = Extent::of(&items);
            build_node(&mut items, &mut order, 0, 0, extent, &mut bin);
        }
        // The builder's boxes go before the collapse, which holds the binary and the 4-wide
        // tree at once (with the primitives, the peak memory of a large scene's build).
        drop(items);
        let nodes = collapsed(bin);
        let isect: Vec<Isect> = order
            .iter()
            .map(|&i| match prims[i as usize] {
                Primitive::Triangle { v, .. } => Isect::Triangle {
                    v0: v[0],
                    e1: v[1] - v[0],
                    e2: v[2] - v[0],
                },
                Primitive::Sphere { center, radius, .. } => Isect::Sphere { center, radius },
                _ => Isect::Other,
            })
            .collect();
        let tiny = if order.len() <= TINY {
            isect
                .iter()
                .map(|t| match *t {
                    Isect::Triangle { v0, e1, e2 } => Some([v0, e1, e2]),
                    Isect::Sphere { .. } | Isect::Other => None,
                })
                .collect::<Option<Vec<_>>>()
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        Self {
            prims,
            order,
            isect,
            nodes,
            tiny,
            walk_isa: linlight_simd::Isa::detect(),
        }
    }

    /// Whether the tree has more than `INTERVAL_NODES` (1024) nodes: its packet walks test
    /// boxes ray by ray and leave the subtrees that few rays enter to one-ray walks, so
    /// packets whose rays lie close together cost less.
    pub fn is_large(&self) -> bool {
        self.nodes.len() > INTERVAL_NODES
    }

    pub fn primitive(&self, i: u32) -> &Primitive {
        &self.prims[self.order[i as usize] as usize]
    }

    pub fn len(&self) -> usize {
        self.prims.len()
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Calls `visit(k, primitive)` for every primitive whose box lies in a node box that
    /// `overlaps(lower, upper)` accepts down the tree (and whose own box it accepts), `k` its
    /// position among the primitives in the order given to [`Bvh::build`] (less those of
    /// non-finite bounds), in no particular order. A query by region, not a ray walk.
    pub fn visit_overlapping(
        &self,
        overlaps: impl Fn(Vec3, Vec3) -> bool,
        mut visit: impl FnMut(u32, &Primitive),
    ) {
        let mut stack: Vec<u32> = Vec::new();
        if !self.nodes.is_empty() {
            stack.push(0);
        }
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            for lane in 0..WIDTH {
                let lo = Vec3::from_array(std::array::from_fn(|a| node.b[0][a][lane]));
                let hi = Vec3::from_array(std::array::from_fn(|a| node.b[1][a][lane]));
                if !lo.cmple(hi).all() || !overlaps(lo, hi) {
                    continue; // an empty slot, or outside the region
                }
                let (child, count) = (node.child[lane], node.count[lane]);
                if count == 0 {
                    stack.push(child);
                    continue;
                }
                for pos in child..child + count {
                    let k = self.order[pos as usize];
                    let p = &self.prims[k as usize];
                    let b = p.bounds();
                    if overlaps(b.min, b.max) {
                        visit(k, p);
                    }
                }
            }
        }
    }

    /// Intersection of primitive `i` (in BVH order) with `ray`, as [`Primitive::intersect`].
    /// Triangles take the branch-free test: which of a leaf's conditions fails varies from
    /// ray to ray, so the early outs of [`crate::shapes::intersect_triangle_edges`] are
    /// mispredicted.
    #[inline(always)]
    fn intersect_prim(&self, i: usize, ray: &Ray) -> Option<(f32, f32, f32)> {
        match self.isect[i] {
            Isect::Triangle { v0, e1, e2 } => {
                let (o, d) = (ray.o, ray.d);
                let (t, b1, b2, hit) =
                    intersect_triangle_lane(o, d, ray.t_min, ray.t_max, v0, e1, e2);
                hit.then_some((t, b1, b2))
            }
            Isect::Sphere { .. } | Isect::Other => self.primitive(i as u32).intersect(ray),
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
                let (best_t, best_prim) = best.map_or((0.0, u32::MAX), |b| (b.t, b.prim));
                if replaces(t, i, best_t, best_prim) {
                    // Later hits at the same t still pass `t < t_max` (ties: smallest index).
                    ray.t_max = t.next_up();
                    best = Some(Hit { t, prim: i, b1, b2 });
                }
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

    /// The rays of `mask` occluded within the subtree of node `node`, walked ray by ray; `inv`
    /// holds their 1 / d (the packet's, computed once).
    #[inline(never)]
    fn occluded_rays(&self, lanes: &RayLanes, inv: &Inv, mask: u32, node: u32) -> u32 {
        let mut occluded = 0u32;
        let mut m = mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let mut ray = lanes.get(k);
            let rb = RayBoxes::with_inv(&ray, std::array::from_fn(|a| inv[a][k]));
            let mut hit = false;
            let start = (node, 0, ray.t_min);
            self.traverse_from::<STACK>(&mut ray, &rb, start, |bvh, i, ray| {
                hit = bvh.intersect_prim(i as usize, ray).is_some();
                hit
            });
            occluded |= (hit as u32) << k;
        }
        occluded
    }

    /// [`Self::occluded`] for a packet of up to [`PACKET`] rays: bit i of the result is set
    /// iff `rays[i]` is occluded, exactly as `occluded(&rays[i])` says.
    pub fn occluded_packet(&self, rays: &[Ray]) -> u32 {
        let all = ((1u64 << rays.len()) - 1) as u32;
        self.occluded_lanes(&RayLanes::from_rays(rays), all)
    }

    /// [`Self::intersect`] for a packet of up to [`PACKET`] rays: lane i of the result is
    /// exactly what `intersect(&rays[i])` returns.
    pub fn intersect_packet(&self, rays: &[Ray]) -> PacketHits {
        let all = ((1u64 << rays.len()) - 1) as u32;
        self.intersect_lanes(&RayLanes::from_rays(rays), all)
    }

    /// Any-hit for the rays of `lanes` in `active` (shadow rays of a packet renderer): bit i of
    /// the result is set iff ray i is occluded, exactly as [`Self::occluded`] says.
    ///
    /// The packet walks the tree once: each node's four boxes are tested against the rays still
    /// unresolved (as intervals when the packet is coherent, else ray by ray, see
    /// `RayPacket`), a subtree is entered with the rays that may meet its box, a leaf tests
    /// its triangles and spheres against all of them at once (vectorised) and other primitives
    /// ray by ray, and the walk ends when every ray is occluded. A tree of at most `TINY` (12) triangles is
    /// not walked: each triangle is tested against all rays not yet occluded. The lane
    /// arithmetic is written per vector extension (`kernels`: AVX-512, AVX2, portable), the
    /// best the CPU has chosen at run time, as `linlight_sampling::batch` does.
    pub fn occluded_lanes(&self, lanes: &RayLanes, active: u32) -> u32 {
        let active = active & ((1u64 << PACKET) - 1) as u32;
        if self.nodes.is_empty() || active == 0 {
            return 0;
        }
        #[cfg(target_arch = "x86_64")]
        {
            use linlight_simd::Isa;
            #[target_feature(
                enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
            )]
            unsafe fn avx512(bvh: &Bvh, lanes: &RayLanes, active: u32) -> u32 {
                bvh.occluded_walk::<kernels::Avx512>(lanes, active)
            }
            #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
            unsafe fn avx2(bvh: &Bvh, lanes: &RayLanes, active: u32) -> u32 {
                bvh.occluded_walk::<kernels::Avx2>(lanes, active)
            }
            match self.walk_isa {
                // SAFETY: `walk_isa` is a variant `Isa::supported` on this CPU (`Isa::detect`
                // at build; tests set only supported ones), and that checks every feature the
                // functions are compiled for.
                Isa::Avx512 => unsafe { return avx512(self, lanes, active) },
                Isa::Avx2 => unsafe { return avx2(self, lanes, active) },
                Isa::Baseline => {}
            }
        }
        self.occluded_walk::<kernels::Portable>(lanes, active)
    }

    #[inline(always)]
    fn occluded_walk<K: Kernel>(&self, lanes: &RayLanes, active: u32) -> u32 {
        if !self.tiny.is_empty() {
            return self.occluded_tiny::<K>(lanes, active);
        }
        // Small trees: interval tests for coherent packets, never ray by ray; larger ones:
        // interval tests, then ray by ray for the boxes they pass.
        let small = self.nodes.len() <= INTERVAL_NODES;
        let few = if small { 0 } else { FEW_RAYS };
        let mut packet = K::packet(lanes, active);
        packet.rays_too = !small;
        if active.count_ones() <= few {
            return self.occluded_rays(lanes, &packet.inv, active, 0);
        }
        let mut occluded = 0u32;
        let mut stack = stack::<PacketEntry, 64>();
        let mut spill: Vec<PacketEntry> = Vec::new();
        let mut sp = 0;
        let mut expand = Some((0u32, active));
        // A child of the last node entered without a trip through the stack (an entry
        // written and read back at once stalls the load: store forwarding fails).
        let mut next: Option<PacketEntry> = None;
        loop {
            if let Some((index, mask)) = expand.take() {
                let node = &self.nodes[index as usize];
                let children = packet.children::<K>(node, mask);
                // Any hit: no order, the entry distances are not needed (and, unused, not
                // computed: the kernels' horizontal minima are dropped).
                for (lane, (hits, _)) in children.into_iter().enumerate() {
                    if hits != 0 {
                        self.prefetch(node.child[lane], node.count[lane]);
                        if let Some(e) = next.replace((index, lane as u32, hits, 0.0)) {
                            push(&mut stack, &mut sp, &mut spill, e);
                        }
                    }
                }
            }
            let Some((parent, lane, mask, _)) =
                next.take().or_else(|| pop(&stack, &mut sp, &mut spill))
            else {
                return occluded;
            };
            let mask = mask & !occluded;
            if mask == 0 {
                continue;
            }
            let node = &self.nodes[parent as usize];
            let (child, count) = (node.child[lane as usize], node.count[lane as usize]);
            if count == 0 {
                if mask.count_ones() <= few {
                    occluded |= self.occluded_rays(lanes, &packet.inv, mask, child);
                } else {
                    expand = Some((child, mask));
                }
                continue;
            }
            let mut mask = mask;
            for i in child..child + count {
                if let Isect::Triangle { v0, e1, e2 } = self.isect[i as usize] {
                    let tri = [v0, e1, e2];
                    occluded |= mask & K::triangle(lanes, &packet.t_min, &packet.t_max, &tri).3;
                } else {
                    occluded |= self.occluded_other::<K>(i, lanes, &packet, mask);
                }
                mask &= !occluded;
                if mask == 0 {
                    break;
                }
            }
            if occluded == active {
                return occluded;
            }
        }
    }

    /// Closest hits for the rays of `lanes` in `active` (camera rays of a packet renderer):
    /// lane i of the result is exactly what [`Self::intersect`] returns for ray i, ties
    /// included (see [`Self::intersect`]).
    ///
    /// The packet walks the tree once, nearest box first (by the smallest entry distance of its
    /// rays), boxes tested as in [`Self::occluded_lanes`]; a pending subtree is checked again
    /// against the rays' current closest distances when it is popped; a leaf's triangles and
    /// spheres are tested against all its rays at once (vectorised), other primitives ray by
    /// ray. A tree of
    /// at most `TINY` (12) triangles is not walked: each triangle is tested against all rays.
    // `inline`: the 320-byte result is built where the caller keeps it (1–2 instructions per
    // sample fewer on every scene than a copy, ~4 fewer than an out parameter).
    #[inline]
    pub fn intersect_lanes(&self, lanes: &RayLanes, active: u32) -> PacketHits {
        let active = active & ((1u64 << PACKET) - 1) as u32;
        let mut out = PacketHits {
            t: [0.0; PACKET],
            prim: [u32::MAX; PACKET],
            b1: [0.0; PACKET],
            b2: [0.0; PACKET],
            mask: 0,
        };
        if self.nodes.is_empty() || active == 0 {
            return out;
        }
        #[cfg(target_arch = "x86_64")]
        {
            use linlight_simd::Isa;
            #[target_feature(
                enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
            )]
            unsafe fn avx512(bvh: &Bvh, lanes: &RayLanes, active: u32, out: &mut PacketHits) {
                bvh.intersect_walk::<kernels::Avx512>(lanes, active, out)
            }
            #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
            unsafe fn avx2(bvh: &Bvh, lanes: &RayLanes, active: u32, out: &mut PacketHits) {
                bvh.intersect_walk::<kernels::Avx2>(lanes, active, out)
            }
            match self.walk_isa {
                // SAFETY: `walk_isa` is a variant `Isa::supported` on this CPU (`Isa::detect`
                // at build; tests set only supported ones), and that checks every feature the
                // functions are compiled for.
                Isa::Avx512 => unsafe {
                    avx512(self, lanes, active, &mut out);
                    return out;
                },
                Isa::Avx2 => unsafe {
                    avx2(self, lanes, active, &mut out);
                    return out;
                },
                Isa::Baseline => {}
            }
        }
        self.intersect_walk::<kernels::Portable>(lanes, active, &mut out);
        out
    }

    /// The walk of [`Self::intersect_lanes`]; `out` holds "no hit" in every lane on entry.
    #[inline(always)]
    fn intersect_walk<K: Kernel>(&self, lanes: &RayLanes, active: u32, out: &mut PacketHits) {
        if self.tiny.is_empty() {
            self.intersect_tree::<K>(lanes, active, out);
        } else {
            self.intersect_tiny::<K>(lanes, active, out);
        }
        for (k, &prim) in out.prim.iter().enumerate() {
            out.mask |= ((prim != u32::MAX) as u32) << k;
        }
    }

    /// [`Self::intersect_walk`] through the tree: `out`'s hits, not its mask.
    #[inline(always)]
    fn intersect_tree<K: Kernel>(&self, lanes: &RayLanes, active: u32, out: &mut PacketHits) {
        // As the any-hit walk: small trees test coherent packets by intervals, larger ones
        // test boxes ray by ray (after the intervals) and walk the subtrees that few rays
        // enter ray by ray.
        let small = self.nodes.len() <= INTERVAL_NODES;
        let few = if small { 0 } else { FEW_RAYS };
        let mut packet = K::packet(lanes, active);
        packet.rays_too = !small;
        if active.count_ones() <= few {
            self.intersect_rays(lanes, &packet.inv, active, 0, &mut packet.t_max, out);
            return;
        }
        let mut stack = stack::<PacketEntry, 64>();
        let mut spill: Vec<PacketEntry> = Vec::new();
        let mut sp = 0;
        let mut expand = Some((0u32, active));
        // The nearest child of the last node, entered without a trip through the stack (an
        // entry written and read back at once stalls the load: store forwarding fails).
        let mut next: Option<PacketEntry> = None;
        loop {
            if let Some((index, mask)) = expand.take() {
                let node = &self.nodes[index as usize];
                let children = packet.children::<K>(node, mask);
                // Hit slots sorted by entry distance, farthest first: the nearest is entered
                // next, the others pushed so that the nearer ones are popped first.
                let mut order = [0usize; WIDTH];
                let mut n = 0;
                for (lane, &(hits, entry)) in children.iter().enumerate() {
                    if hits != 0 {
                        let mut j = n;
                        while j > 0 && children[order[j - 1]].1 < entry {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = lane;
                        n += 1;
                    }
                }
                for (k, &lane) in order[..n].iter().enumerate() {
                    self.prefetch(node.child[lane], node.count[lane]);
                    let (hits, entry) = children[lane];
                    let e = (index, lane as u32, hits, entry);
                    if k + 1 == n {
                        next = Some(e);
                    } else {
                        push(&mut stack, &mut sp, &mut spill, e);
                    }
                }
            }
            let (parent, lane, mask) = if let Some((parent, lane, mask, _)) = next.take() {
                (parent, lane as usize, mask)
            } else {
                let Some((parent, lane, mask, entry)) = pop(&stack, &mut sp, &mut spill) else {
                    break;
                };
                // Rays that found a closer hit since the push may no longer reach the box.
                let node = &self.nodes[parent as usize];
                let mask = packet.still_hit::<K>(node, lane as usize, mask, entry);
                if mask == 0 {
                    continue;
                }
                (parent, lane as usize, mask)
            };
            let node = &self.nodes[parent as usize];
            let (child, count) = (node.child[lane], node.count[lane]);
            if count == 0 {
                if mask.count_ones() <= few {
                    self.intersect_rays(lanes, &packet.inv, mask, child, &mut packet.t_max, out);
                } else {
                    expand = Some((child, mask));
                }
                continue;
            }
            let mut took = 0u32;
            for i in child..child + count {
                if let Isect::Triangle { v0, e1, e2 } = self.isect[i as usize] {
                    let tri = [v0, e1, e2];
                    let lane_hits = K::triangle(lanes, &packet.t_min, &packet.t_max, &tri);
                    took |= K::take_closest(out, &mut packet.t_max, &lane_hits, mask, i);
                } else {
                    took |= self.intersect_other::<K>(i, lanes, &mut packet, out, mask);
                }
            }
            if packet.coherent & (took != 0) {
                // The rays' intervals shrank: so does the packet's (read only by the
                // interval tests of a coherent packet).
                packet.t_hi = K::max(&packet.t_max);
            }
        }
    }

    /// The closest hits of the rays of `mask` within the subtree of node `node`, walked ray by
    /// ray from their current best hits in `out` and intervals up to `t_max` (both updated);
    /// `inv` holds their 1 / d.
    #[inline(never)]
    fn intersect_rays(
        &self,
        lanes: &RayLanes,
        inv: &Inv,
        mask: u32,
        node: u32,
        t_max: &mut [f32; PACKET],
        out: &mut PacketHits,
    ) {
        let mut m = mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let mut ray = Ray {
                t_max: t_max[k],
                ..lanes.get(k)
            };
            let rb = RayBoxes::with_inv(&ray, std::array::from_fn(|a| inv[a][k]));
            let mut best = (out.t[k], out.prim[k], out.b1[k], out.b2[k]);
            let start = (node, 0, ray.t_min);
            self.traverse_from::<STACK>(&mut ray, &rb, start, |bvh, i, ray| {
                if let Some((t, b1, b2)) = bvh.intersect_prim(i as usize, ray) {
                    if replaces(t, i, best.0, best.1) {
                        ray.t_max = t.next_up();
                        best = (t, i, b1, b2);
                    }
                }
                false
            });
            (out.t[k], out.prim[k], out.b1[k], out.b2[k]) = best;
            t_max[k] = ray.t_max;
        }
    }

    /// Primitive `i`, not a triangle, against the rays of `mask` of a packet walk (any hit):
    /// the rays it occludes. Spheres in lanes ([`Kernel::sphere`]), other shapes ray by ray.
    /// Out of line, as [`Self::intersect_other`].
    #[inline(never)]
    fn occluded_other<K: Kernel>(
        &self,
        i: u32,
        lanes: &RayLanes,
        packet: &RayPacket,
        mask: u32,
    ) -> u32 {
        if let Isect::Sphere { center, radius } = self.isect[i as usize] {
            let r2 = (radius as f64).powi(2);
            return mask & K::sphere(lanes, &packet.t_min, &packet.t_max, center, r2).3;
        }
        let mut occluded = 0u32;
        let mut m = mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            if self.primitive(i).intersect(&lanes.get(k)).is_some() {
                occluded |= 1 << k;
            }
        }
        occluded
    }

    /// Primitive `i`, not a triangle, against the rays of `mask` of a closest-hit packet walk:
    /// its hits that replace the best ones so far (as `Kernel::take_closest`), and the rays
    /// whose best hit changed. Spheres in lanes ([`Kernel::sphere`]), other shapes ray by ray.
    /// Out of line: inlined, the sphere test and the ray-by-ray loop cost the triangle-only
    /// walks (cornell-tube, mesh-occluder) 3–6 instructions per sample.
    #[inline(never)]
    fn intersect_other<K: Kernel>(
        &self,
        i: u32,
        lanes: &RayLanes,
        packet: &mut RayPacket,
        out: &mut PacketHits,
        mask: u32,
    ) -> u32 {
        if let Isect::Sphere { center, radius } = self.isect[i as usize] {
            let r2 = (radius as f64).powi(2);
            let lane_hits = K::sphere(lanes, &packet.t_min, &packet.t_max, center, r2);
            return K::take_closest(out, &mut packet.t_max, &lane_hits, mask, i);
        }
        let mut took = 0u32;
        let mut m = mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let ray = Ray {
                t_max: packet.t_max[k],
                ..lanes.get(k)
            };
            if let Some((t, b1, b2)) = self.primitive(i).intersect(&ray) {
                if replaces(t, i, out.t[k], out.prim[k]) {
                    (out.t[k], out.prim[k]) = (t, i);
                    (out.b1[k], out.b2[k]) = (b1, b2);
                    packet.t_max[k] = t.next_up();
                    took |= 1 << k;
                }
            }
        }
        took
    }

    /// [`Self::occluded_lanes`] of a tiny tree ([`Bvh::tiny`]): every triangle against all
    /// active rays at once, until every ray is occluded.
    #[inline(always)]
    fn occluded_tiny<K: Kernel>(&self, lanes: &RayLanes, active: u32) -> u32 {
        let t_max = active_t_max(lanes, active);
        let mut occluded = 0u32;
        for tri in &self.tiny {
            occluded |= K::triangle(lanes, &lanes.t_min, &t_max, tri).3;
            if occluded == active {
                break;
            }
        }
        occluded
    }

    /// [`Self::intersect_lanes`] of a tiny tree ([`Bvh::tiny`]): every triangle against all
    /// active rays at once. In increasing primitive index, a hit replaces the best one only if
    /// it is strictly closer, so a ray ends with its smallest t and, among hits at that t, the
    /// smallest index: what [`Self::intersect`] returns.
    #[inline(always)]
    fn intersect_tiny<K: Kernel>(&self, lanes: &RayLanes, active: u32, out: &mut PacketHits) {
        // `out.t`: the current closest distance of each ray.
        out.t = active_t_max(lanes, active);
        for (i, tri) in self.tiny.iter().enumerate() {
            let hits = K::triangle(lanes, &lanes.t_min, &out.t, tri);
            K::take_nearer(out, &hits, i as u32);
        }
    }

    /// Ask the cache for what entering a child takes: an interior child's node (both cache
    /// lines) or a leaf child's primitives (`count` ≥ 1 from `child`). The walks of large
    /// trees are bound by the latency of these loads: started when a node's hit children are
    /// known, they overlap with each other and with the walk of the nearer children. Trees of
    /// at most [`PREFETCH_NODES`] nodes stay in the cache: no prefetch, whose instructions
    /// would be all it adds.
    #[inline(always)]
    fn prefetch(&self, child: u32, count: u32) {
        if self.nodes.len() <= PREFETCH_NODES {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (start, end) = if count == 0 {
                let p = self.nodes.as_ptr().wrapping_add(child as usize) as *const i8;
                (p, p.wrapping_add(std::mem::size_of::<Node>()))
            } else {
                let p = self.isect.as_ptr().wrapping_add(child as usize);
                (p as *const i8, p.wrapping_add(count as usize) as *const i8)
            };
            let mut line = start.wrapping_sub(start as usize % 64);
            while line < end {
                // SAFETY: a prefetch is a hint: it never faults, whatever the address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(line) };
                line = line.wrapping_add(64);
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (child, count);
    }

    /// Visit leaves front to back (nearest box entry first, subtrees entered beyond the
    /// current t_max skipped); `visit` returns true to stop.
    #[inline(always)]
    fn traverse<const N: usize>(
        &self,
        ray: &mut Ray,
        visit: impl FnMut(&Self, u32, &mut Ray) -> bool,
    ) {
        let start = (0, 0, ray.t_min);
        self.traverse_from::<N>(ray, &RayBoxes::new(ray), start, visit)
    }

    /// [`Self::traverse`] of the subtree `start` (a pending entry: node or leaf range).
    #[inline(always)]
    fn traverse_from<const N: usize>(
        &self,
        ray: &mut Ray,
        rb: &RayBoxes,
        start: Entry,
        mut visit: impl FnMut(&Self, u32, &mut Ray) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = stack::<Entry, N>();
        let mut spill: Vec<Entry> = Vec::new();
        let mut sp = 0usize;
        // The nearest child of the last node, entered without a trip through the stack.
        let mut next: Option<Entry> = Some(start);
        loop {
            let (child, count, t_enter) = if let Some(e) = next.take() {
                e
            } else if let Some(e) = spill.pop() {
                e
            } else if sp > 0 {
                sp -= 1;
                // SAFETY: entries below the stack pointer were written below.
                unsafe { stack[sp].assume_init() }
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
            if hit == 0 {
                continue;
            }
            let entry = |lane: usize| (node.child[lane], node.count[lane], t0[lane]);
            if hit & (hit - 1) == 0 {
                // One child: entered next, nothing pushed.
                let lane = hit.trailing_zeros() as usize;
                self.prefetch(node.child[lane], node.count[lane]);
                next = Some(entry(lane));
                continue;
            }
            // Hit lanes sorted by entry distance, farthest first: the nearest is entered next,
            // the others are pushed so that the nearer ones are popped first.
            let mut order = [0usize; WIDTH];
            let mut n = 0;
            let mut bits = hit;
            while bits != 0 {
                let lane = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                self.prefetch(node.child[lane], node.count[lane]);
                let mut j = n;
                while j > 0 && t0[order[j - 1]] < t0[lane] {
                    order[j] = order[j - 1];
                    j -= 1;
                }
                order[j] = lane;
                n += 1;
            }
            next = Some(entry(order[n - 1]));
            for &lane in &order[..n - 1] {
                let e = entry(lane);
                if sp < N && spill.is_empty() {
                    stack[sp] = std::mem::MaybeUninit::new(e);
                    sp += 1;
                } else {
                    spill.push(e);
                }
            }
        }
    }
}

/// Subtrees of at least this many primitives build their two halves in parallel (rayon, with
/// more than one thread).
const PARALLEL_BUILD: usize = 4096;

/// Items of at least this many are binned in parallel chunks (with more than one thread); the
/// bins' boxes and counts do not depend on the order of the merge.
const PARALLEL_BINNING: usize = 1 << 16;

/// Box of the builder: min and max as 16-byte vectors, so a union is two vector operations.
/// The same f32 arithmetic as [`Aabb`] lane by lane, so the tree is the one [`Aabb`] would give.
#[derive(Clone, Copy, Debug)]
struct Box3 {
    min: Vec3A,
    max: Vec3A,
}

impl Box3 {
    const EMPTY: Box3 = Box3 {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    #[inline(always)]
    fn union(self, o: Box3) -> Box3 {
        Box3 {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline(always)]
    fn grow(&mut self, p: Vec3A) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    #[inline(always)]
    fn centroid(&self) -> Vec3A {
        0.5 * (self.min + self.max)
    }

    /// As [`Aabb::half_area`].
    #[inline(always)]
    fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    fn aabb(&self) -> Aabb {
        Aabb {
            min: self.min.into(),
            max: self.max.into(),
        }
    }
}

/// The boxes of a range of items and of their centroids.
#[derive(Clone, Copy, Debug)]
struct Extent {
    bounds: Box3,
    centroids: Box3,
}

impl Extent {
    const EMPTY: Extent = Extent {
        bounds: Box3::EMPTY,
        centroids: Box3::EMPTY,
    };

    #[inline(always)]
    fn add(&mut self, b: &Box3) {
        self.bounds = self.bounds.union(*b);
        self.centroids.grow(b.centroid());
    }

    fn of(items: &[Box3]) -> Extent {
        let merge = |a: Extent, b: Extent| Extent {
            bounds: a.bounds.union(b.bounds),
            centroids: a.centroids.union(b.centroids),
        };
        let fold = |c: &[Box3]| {
            let mut e = Extent::EMPTY;
            for b in c {
                e.add(b);
            }
            e
        };
        if items.len() >= PARALLEL_BINNING && rayon::current_num_threads() > 1 {
            items
                .par_chunks(PARALLEL_BINNING / 4)
                .map(fold)
                .reduce(|| Extent::EMPTY, merge)
        } else {
            fold(items)
        }
    }
}

/// Build the subtree over `items` (the boxes of the primitives `start ..` of the whole build,
/// `index` their primitives, permuted alongside; `extent` their boxes) into `nodes`, in
/// depth-first order (the left child follows its parent; `offset` of an interior node is the
/// index of its right child), and return the index of its root.
fn build_node(
    items: &mut [Box3],
    index: &mut [u32],
    start: usize,
    depth: u32,
    extent: Extent,
    nodes: &mut Vec<BuildNode>,
) -> u32 {
    debug_assert_eq!(items.len(), index.len());
    let node_index = nodes.len() as u32;
    let Extent {
        bounds,
        centroids: cbounds,
    } = extent;
    let n = items.len();
    nodes.push(BuildNode {
        bounds: bounds.aabb(),
        offset: start as u32,
        count: n as u32,
        axis: 0,
    });
    if n <= 1 {
        return node_index;
    }
    let split = if depth < SAH_DEPTH {
        best_split(items, &bounds, &cbounds)
    } else {
        None
    };
    let (mid, left_extent, right_extent) = match split {
        Some((axis, bin, _cost)) => {
            let lo = cbounds.min[axis];
            let scale = BINS as f32 / (cbounds.max[axis] - lo);
            let bin_of = |c: Vec3A| (((c[axis] - lo) * scale) as usize).min(BINS - 1);
            // The partition's swaps, and the two sides' extents on the way.
            let (mut left, mut right) = (Extent::EMPTY, Extent::EMPTY);
            let mut m = 0;
            for i in 0..n {
                let b = items[i];
                if bin_of(b.centroid()) <= bin {
                    items.swap(i, m);
                    index.swap(i, m);
                    m += 1;
                    left.add(&b);
                } else {
                    right.add(&b);
                }
            }
            nodes[node_index as usize].axis = axis as u8;
            (m, left, right)
        }
        None if n <= MAX_LEAF => return node_index,
        None => {
            // No useful SAH split (coincident centroids, or too deep): median split on the
            // widest centroid axis (a stable sort by centroid).
            let axis = (cbounds.max - cbounds.min).max_position();
            let mut perm: Vec<u32> = (0..n as u32).collect();
            perm.sort_by(|&a, &b| {
                items[a as usize].centroid()[axis].total_cmp(&items[b as usize].centroid()[axis])
            });
            let sorted_items: Vec<Box3> = perm.iter().map(|&p| items[p as usize]).collect();
            let sorted_index: Vec<u32> = perm.iter().map(|&p| index[p as usize]).collect();
            items.copy_from_slice(&sorted_items);
            index.copy_from_slice(&sorted_index);
            nodes[node_index as usize].axis = axis as u8;
            let mid = n / 2;
            (mid, Extent::of(&items[..mid]), Extent::of(&items[mid..]))
        }
    };
    if mid == 0 || mid == n {
        return node_index; // keep as leaf (cannot happen with the binning above, kept for safety)
    }
    let (left, right) = items.split_at_mut(mid);
    let (left_index, right_index) = index.split_at_mut(mid);
    let right_root = if n >= PARALLEL_BUILD && rayon::current_num_threads() > 1 {
        // The right subtree goes to its own vector (indices from 0), appended after the left
        // one and shifted: the same layout as the sequential build.
        let ((), mut rnodes) = rayon::join(
            || {
                build_node(left, left_index, start, depth + 1, left_extent, nodes);
            },
            || {
                let mut r = Vec::with_capacity(2 * right.len());
                build_node(
                    right,
                    right_index,
                    start + mid,
                    depth + 1,
                    right_extent,
                    &mut r,
                );
                r
            },
        );
        let base = nodes.len() as u32;
        for node in &mut rnodes {
            if node.count == 0 {
                node.offset += base;
            }
        }
        nodes.append(&mut rnodes);
        base
    } else {
        build_node(left, left_index, start, depth + 1, left_extent, nodes);
        build_node(
            right,
            right_index,
            start + mid,
            depth + 1,
            right_extent,
            nodes,
        )
    };
    let node = &mut nodes[node_index as usize];
    node.offset = right_root;
    node.count = 0;
    node_index
}

/// The bins of all three axes: per axis and bin, the union of the items' boxes and their count.
#[derive(Clone, Copy)]
struct Bins {
    bounds: [[Box3; BINS]; 3],
    count: [[u32; BINS]; 3],
}

impl Bins {
    const EMPTY: Bins = Bins {
        bounds: [[Box3::EMPTY; BINS]; 3],
        count: [[0; BINS]; 3],
    };

    /// One pass over the items fills the bins of all three axes.
    fn fill(&mut self, items: &[Box3], lo: Vec3A, scale: Vec3A) {
        for it in items {
            let f = (it.centroid() - lo) * scale;
            for axis in 0..3 {
                let b = (f[axis] as usize).min(BINS - 1);
                self.bounds[axis][b] = self.bounds[axis][b].union(*it);
                self.count[axis][b] += 1;
            }
        }
    }

    fn merge(mut self, o: &Bins) -> Bins {
        for axis in 0..3 {
            for b in 0..BINS {
                self.bounds[axis][b] = self.bounds[axis][b].union(o.bounds[axis][b]);
                self.count[axis][b] += o.count[axis][b];
            }
        }
        self
    }
}

/// Best (axis, last bin of the left side, cost) by binned SAH, if it beats a leaf.
fn best_split(items: &[Box3], bounds: &Box3, cbounds: &Box3) -> Option<(usize, usize, f32)> {
    let leaf_cost = items.len() as f32;
    let mut best: Option<(usize, usize, f32)> = None;
    let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
    let lo = cbounds.min;
    let extent = cbounds.max - lo;
    // An axis without extent gets scale 0 (every item in bin 0) and is skipped below.
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(BINS as f32) / extent,
        Vec3A::ZERO,
    );
    let bins = if items.len() >= PARALLEL_BINNING && rayon::current_num_threads() > 1 {
        items
            .par_chunks(PARALLEL_BINNING / 4)
            .map(|c| {
                let mut b = Bins::EMPTY;
                b.fill(c, lo, scale);
                b
            })
            .reduce(|| Bins::EMPTY, |a, b| a.merge(&b))
    } else {
        let mut b = Bins::EMPTY;
        b.fill(items, lo, scale);
        b
    };
    for axis in 0..3 {
        if !(extent[axis] > 0.0) {
            continue;
        }
        let (bin_bounds, bin_count) = (&bins.bounds[axis], &bins.count[axis]);
        // Sweep from the right to get suffix areas and counts.
        let mut right_area = [0f32; BINS];
        let mut right_count = [0u32; BINS];
        let mut acc = Box3::EMPTY;
        let mut cnt = 0;
        for b in (1..BINS).rev() {
            acc = acc.union(bin_bounds[b]);
            cnt += bin_count[b];
            right_area[b] = acc.half_area();
            right_count[b] = cnt;
        }
        let mut acc = Box3::EMPTY;
        let mut cnt = 0;
        for b in 0..BINS - 1 {
            acc = acc.union(bin_bounds[b]);
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
pub(crate) mod tests {
    use super::*;
    use linlight_sampling::rng::Pcg32;

    /// The BVH once per packet-walk kernel this CPU runs (the baseline always).
    fn walk_variants(bvh: &Bvh) -> Vec<Bvh> {
        use linlight_simd::Isa;
        Isa::ALL
            .into_iter()
            .filter(|isa| isa.supported())
            .map(|walk_isa| Bvh {
                walk_isa,
                ..bvh.clone()
            })
            .collect()
    }

    /// `count` triangles in the cube [0, 10]³, each spanning about `size`, shape i.
    fn triangle_soup(r3: &mut impl FnMut() -> Vec3, count: u32, size: f32) -> Vec<Primitive> {
        (0..count)
            .map(|i| {
                let c = r3() * 10.0;
                let v = [c, c + size * (r3() - 0.5), c + size * (r3() - 0.5)];
                Primitive::Triangle {
                    v,
                    n: None,
                    shape: i,
                }
            })
            .collect()
    }

    /// The parallel build (subtrees of ≥ PARALLEL_BUILD primitives split across threads) lays
    /// out the same nodes and primitive order as the build on one thread.
    #[test]
    fn parallel_build_equals_sequential() {
        let mut rng = Pcg32::new(11, 0);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = triangle_soup(&mut r3, 6 * PARALLEL_BUILD as u32, 0.4);
        // Long thin triangles across the soup as well.
        prims.extend(
            triangle_soup(&mut r3, 2000, 0.0)
                .into_iter()
                .map(|p| match p {
                    Primitive::Triangle { v, shape, .. } => Primitive::Triangle {
                        v: [
                            v[0],
                            v[0] + Vec3::new(8.0, 0.01, 0.0),
                            v[0] + Vec3::new(0.0, 0.02, 0.01),
                        ],
                        n: None,
                        shape: shape + 6 * PARALLEL_BUILD as u32,
                    },
                    other => other,
                }),
        );
        let pool = |t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
        };
        let one = pool(1).install(|| Bvh::build(prims.clone()));
        let four = pool(4).install(|| Bvh::build(prims.clone()));
        assert!(one.nodes.len() > 1000);
        assert_eq!(one.nodes.len(), four.nodes.len());
        for (a, b) in one.nodes.iter().zip(&four.nodes) {
            assert_eq!((a.child, a.count), (b.child, b.count));
            assert_eq!(
                a.b.map(|c| c.map(|l| l.map(f32::to_bits))),
                b.b.map(|c| c.map(|l| l.map(f32::to_bits)))
            );
        }
        let shapes = |b: &Bvh| {
            (0..b.len() as u32)
                .map(|i| b.primitive(i).shape())
                .collect::<Vec<_>>()
        };
        assert!(shapes(&one) == shapes(&four));
        let mut seen = shapes(&one);
        seen.sort_unstable();
        assert!(seen == (0..prims.len() as u32).collect::<Vec<_>>());
    }

    /// The BVH must agree with brute force on closest hits and any-hits.
    #[test]
    fn matches_brute_force() {
        let mut rng = Pcg32::new(7, 0);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = triangle_soup(&mut r3, 300, 3.0);
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
            prims.push(Primitive::disk(to_world.inverse(), 500 + i));
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
    /// ray exactly as `occluded` does, on a small tree (interval box tests) and on one of more
    /// than `INTERVAL_NODES` nodes (ray-by-ray box tests, subtrees of few rays walked ray by
    /// ray).
    #[test]
    fn packets_match_single_rays() {
        // (triangles, size): about the same fraction of occluded rays.
        for (count, size) in [(400, 2.0), (16_000, 0.32)] {
            let bvh = occlusion_soup(count, size);
            assert_eq!(bvh.nodes.len() > INTERVAL_NODES, count > 400, "{count}");
            packets_match_single_rays_on(&bvh);
        }
        assert_eq!(Bvh::build(Vec::new()).occluded_packet(&[]), 0);
    }

    /// A triangle soup of `count` triangles with a sphere in its middle.
    /// Closest hits on a tree of more than `INTERVAL_NODES` nodes (ray-by-ray box tests, the
    /// subtrees of few rays walked ray by ray) equal the single-ray walk's, ties included.
    #[test]
    fn closest_hit_packets_match_single_rays_on_large_trees() {
        let mut rng = Pcg32::new(8, 4);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = triangle_soup(&mut r3, 16_000, 0.6);
        // Every fifth triangle twice: every hit on it is a tie.
        let twins: Vec<Primitive> = prims
            .iter()
            .step_by(5)
            .map(|p| match p {
                Primitive::Triangle { v, n, shape } => Primitive::Triangle {
                    v: *v,
                    n: *n,
                    shape: 100_000 + shape,
                },
                _ => unreachable!("the soup holds triangles"),
            })
            .collect();
        prims.extend(twins);
        prims.push(Primitive::Sphere {
            center: Vec3::splat(5.0),
            radius: 1.0,
            shape: 200_000,
        });
        let bvh = Bvh::build(prims);
        assert!(bvh.nodes.len() > INTERVAL_NODES, "{}", bvh.nodes.len());
        let variants = walk_variants(&bvh);
        let (mut hits, mut total) = (0, 0);
        for k in 0..600 {
            let size = 1 + k % PACKET;
            let origin = r3() * 12.0 - 1.0;
            let aim = r3() * 12.0 - 1.0;
            let rays: Vec<Ray> = (0..size)
                .map(|_| {
                    // A pixel's camera rays (one origin, close directions), rays fanning out
                    // from one origin, or anything.
                    let (o, target) = match k % 3 {
                        0 => (origin, aim + 0.02 * (r3() - 0.5)),
                        1 => (origin, aim + 2.0 * (r3() - 0.5)),
                        _ => (r3() * 12.0 - 1.0, r3() * 12.0 - 1.0),
                    };
                    Ray {
                        o,
                        d: (target - o).normalize_or(Vec3::X),
                        t_min: 0.01,
                        t_max: 20.0,
                    }
                })
                .collect();
            for b in std::iter::once(&bvh).chain(&variants) {
                let packet = b.intersect_packet(&rays);
                assert_eq!(packet.mask >> size, 0);
                for (i, ray) in rays.iter().enumerate() {
                    let single = bvh.intersect(ray).map(|h| (h.t, h.prim, h.b1, h.b2));
                    let got = packet.get(i).map(|h| (h.t, h.prim, h.b1, h.b2));
                    assert_eq!(got, single, "packet {k}, ray {i}, {:?}", b.walk_isa);
                    hits += single.is_some() as usize;
                    total += 1;
                }
            }
        }
        // Both outcomes occur.
        assert!(hits > total / 5 && hits < total, "{hits}/{total}");
    }

    /// `count` random triangles of edge up to `size` in the unit cube and a sphere beside it.
    pub(crate) fn occlusion_soup(count: u32, size: f32) -> Bvh {
        let mut rng = Pcg32::new(3, 9);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = triangle_soup(&mut r3, count, size);
        prims.push(Primitive::Sphere {
            center: Vec3::splat(5.0),
            radius: 1.0,
            shape: count,
        });
        Bvh::build(prims)
    }

    fn packets_match_single_rays_on(bvh: &Bvh) {
        let mut rng = Pcg32::new(4, 9);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        assert!(bvh.tiny.is_empty());
        let variants = walk_variants(bvh);
        let (mut occluded, mut total) = (0, 0);
        for k in 0..900 {
            let size = 1 + k % PACKET;
            let origin = r3() * 12.0 - 1.0;
            let aim = r3() * 12.0 - 1.0;
            let rays: Vec<Ray> = (0..size)
                .map(|_| {
                    let (o, target) = match k % 3 {
                        0 => (origin, r3() * 12.0 - 1.0),
                        1 => (origin + 0.3 * (r3() - 0.5), aim + 2.0 * (r3() - 0.5)),
                        _ => (r3() * 12.0 - 1.0, r3() * 12.0 - 1.0),
                    };
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
            for b in &variants {
                assert_eq!(b.occluded_packet(&rays), mask, "{:?}", b.walk_isa);
            }
        }
        assert!(
            occluded > total / 5 && occluded < total * 4 / 5,
            "{occluded}/{total}"
        );
    }

    /// Packets of 1–16 rays (coherent: one origin, nearby directions; and incoherent) find
    /// exactly the closest hit `intersect` finds, ties included: the scene has coincident
    /// duplicate triangles (every hit on them is a tie) and spheres and disks.
    #[test]
    fn closest_hit_packets_match_single_rays() {
        let mut rng = Pcg32::new(5, 2);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = triangle_soup(&mut r3, 300, 2.0);
        // Every third triangle twice: every hit on it is a tie.
        let twins: Vec<Primitive> = prims
            .iter()
            .step_by(3)
            .map(|p| match p {
                Primitive::Triangle { v, n, shape } => Primitive::Triangle {
                    v: *v,
                    n: *n,
                    shape: 1000 + shape,
                },
                _ => unreachable!("the soup holds triangles"),
            })
            .collect();
        prims.extend(twins);
        for i in 0..10 {
            prims.push(Primitive::Sphere {
                center: r3() * 10.0,
                radius: 0.5,
                shape: 2000 + i,
            });
            let to_world = glam::Mat4::from_translation(r3() * 10.0);
            prims.push(Primitive::disk(to_world.inverse(), 3000 + i));
        }
        let bvh = Bvh::build(prims);
        assert!(bvh.tiny.is_empty());
        let variants = walk_variants(&bvh);
        let (mut hits, mut total, mut coherent) = (0, 0, 0);
        for k in 0..1200 {
            let size = 1 + k % PACKET;
            let origin = r3() * 12.0 - 1.0;
            let aim = r3() * 12.0 - 1.0;
            let rays: Vec<Ray> = (0..size)
                .map(|_| {
                    // One origin (camera rays), nearby origins and targets (shadow rays of a
                    // pixel toward a light), or anything.
                    let (o, target) = match k % 3 {
                        0 => (origin, aim + 0.5 * (r3() - 0.5)),
                        1 => (origin + 0.3 * (r3() - 0.5), aim + 2.0 * (r3() - 0.5)),
                        _ => (r3() * 12.0 - 1.0, r3() * 12.0 - 1.0),
                    };
                    Ray {
                        o,
                        d: (target - o).normalize_or(Vec3::X),
                        t_min: 0.01,
                        t_max: 20.0,
                    }
                })
                .collect();
            let packet = bvh.intersect_packet(&rays);
            let all = (1u32 << size) - 1;
            coherent += kernels::Portable::packet(&RayLanes::from_rays(&rays), all).coherent as u32;
            for (i, ray) in rays.iter().enumerate() {
                let single = bvh.intersect(ray).map(|h| (h.t, h.prim, h.b1, h.b2));
                let got = packet.get(i).map(|h| (h.t, h.prim, h.b1, h.b2));
                assert_eq!(got, single, "packet {k}, ray {i}");
                hits += single.is_some() as usize;
                total += 1;
            }
            assert_eq!(packet.mask >> size, 0);
            for b in &variants {
                let other = b.intersect_packet(&rays);
                assert_eq!(other.mask, packet.mask, "{:?}", b.walk_isa);
                for i in 0..size {
                    let same = |p: &PacketHits| p.get(i).map(|h| (h.t, h.prim, h.b1, h.b2));
                    assert_eq!(same(&other), same(&packet), "{:?}", b.walk_isa);
                }
            }
        }
        assert!(hits > total / 5 && hits < total * 9 / 10, "{hits}/{total}");
        // Both box tests ran: intervals (coherent packets) and ray by ray.
        assert!(
            coherent > 400 && coherent < 1000,
            "{coherent} coherent packets"
        );
        assert_eq!(Bvh::build(Vec::new()).intersect_packet(&[]).mask, 0);
    }

    /// Trees of at most `TINY` triangles (walked without the tree, every triangle against every
    /// ray): packets of 1–16 rays, with every kernel, give exactly what `intersect` and
    /// `occluded` give ray by ray, ties included (every triangle has a coincident twin), and
    /// rays outside the packet's mask neither hit nor count as occluded.
    #[test]
    fn tiny_trees_match_single_rays() {
        let mut rng = Pcg32::new(11, 4);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut prims = triangle_soup(&mut r3, (TINY / 2) as u32, 6.0);
        let twins: Vec<Primitive> = prims
            .iter()
            .map(|p| match p {
                Primitive::Triangle { v, n, shape } => Primitive::Triangle {
                    v: *v,
                    n: *n,
                    shape: 100 + shape,
                },
                _ => unreachable!("the soup holds triangles"),
            })
            .collect();
        prims.extend(twins);
        let bvh = Bvh::build(prims.clone());
        assert_eq!(bvh.tiny.len(), TINY);
        // A sphere among the triangles: the tree is walked.
        prims.push(Primitive::Sphere {
            center: Vec3::splat(5.0),
            radius: 1.0,
            shape: 999,
        });
        assert!(Bvh::build(prims).tiny.is_empty());
        let (mut hits, mut occluded, mut total) = (0, 0, 0);
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
                    // Toward a point of a triangle, stopping short of it or beyond it.
                    let [v0, e1, e2] = bvh.tiny[k % TINY];
                    let w = r3() * 0.5;
                    let target = v0 + e1 * w.x + e2 * w.y;
                    Ray {
                        o,
                        d: (target - o).normalize_or(Vec3::X),
                        t_min: 0.01,
                        t_max: (target - o).length() * (0.6 + 1.6 * w.z),
                    }
                })
                .collect();
            // Every other ray of the packet switched off.
            let lanes = RayLanes::from_rays(&rays);
            let half = 0x5555 & ((1u32 << size) - 1);
            // The single-ray answers, once per ray.
            let singles: Vec<_> = rays
                .iter()
                .map(|ray| {
                    let hit = bvh.intersect(ray).map(|h| (h.t, h.prim, h.b1, h.b2));
                    (hit, bvh.occluded(ray))
                })
                .collect();
            for &(hit, shadowed) in &singles {
                hits += hit.is_some() as usize;
                occluded += shadowed as usize;
                total += 1;
            }
            for b in walk_variants(&bvh) {
                let packet = b.intersect_packet(&rays);
                let shadows = b.occluded_packet(&rays);
                for (i, &(single, shadowed)) in singles.iter().enumerate() {
                    let got = packet.get(i).map(|h| (h.t, h.prim, h.b1, h.b2));
                    assert_eq!(got, single, "{:?}, packet {k}, ray {i}", b.walk_isa);
                    assert_eq!(
                        shadows >> i & 1 == 1,
                        shadowed,
                        "{:?}, packet {k}, ray {i}",
                        b.walk_isa
                    );
                }
                assert_eq!(packet.mask >> size, 0);
                assert_eq!(shadows >> size, 0);
                assert_eq!(b.intersect_lanes(&lanes, half).mask, packet.mask & half);
                assert_eq!(b.occluded_lanes(&lanes, half), shadows & half);
            }
        }
        assert!(hits > total / 5 && hits < total * 9 / 10, "{hits}/{total}");
        assert!(
            occluded > total / 5 && occluded < total * 9 / 10,
            "{occluded}/{total}"
        );
    }

    /// Coincident triangles: the closest hit is the one with the smallest primitive index,
    /// whatever the order of the walk.
    #[test]
    fn ties_go_to_the_smallest_index() {
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let prims: Vec<Primitive> = (0..9)
            .map(|shape| Primitive::Triangle { v, n: None, shape })
            .collect();
        let bvh = Bvh::build(prims);
        let ray = Ray {
            o: Vec3::new(0.2, 0.2, 1.0),
            d: Vec3::NEG_Z,
            t_min: 0.0,
            t_max: 2.0,
        };
        assert_eq!(bvh.intersect(&ray).unwrap().prim, 0);
        assert_eq!(bvh.intersect_packet(&[ray; 3]).get(2).unwrap().prim, 0);
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
