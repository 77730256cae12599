//! The light chosen per light sample by a tree over the lights' segments
//! ([`LightSelection::Tree`](crate::light_choice::LightSelection::Tree)), in the spirit of
//! pbrt-v4's `BVHLightSampler`: each node bounds its segments by a box and holds their power;
//! from the shading point (x, n) the walk goes down from the root, at each node into child c
//! with probability I_c/(I_left + I_right), and the pmf of the light reached is the product of
//! the choices made on its path.
//!
//! Importance of a node seen from (x, n): a bound of the projected solid angle per radius of
//! its segments times their radiance. Interior nodes (box with bounding sphere of centre c and
//! radius r, power Φ = Σ ‖K‖₁·L of their segments, K = radiance × radius, L the length; the
//! emitted power of a tube is 2π²·R·(K/R)·L, proportional): I = 2Φ·cos θ′/d², with
//! d² = max(‖c − x‖², r²), cos θ′ = cos(max(0, θ − θ_b)), θ the angle between n and c − x and
//! θ_b = asin(r/d) the half-angle of the sphere seen from x (θ_b = π inside the sphere). Leaves
//! (one segment): I = ‖K‖₁·Ω_R·cos θ′, Ω_R the segment's exact solid angle per radius (its far
//! limit is the interior nodes' 2L·sin θ/d²). A tube radiates all around its axis, so there is
//! no emission cone to bound (pbrt's θ_o, θ_e).
//!
//! Unbiasedness: every light has p_j > 0 at every shading point (to the resolution of ξ_c,
//! below). cos θ' is floored at
//! [`COS_FLOOR`]: a node wholly below the horizon keeps a tiny probability instead of none, so
//! the walk never stops without a light and every light sample draws the same numbers (the
//! choice ξ_c, then the light's) whatever the shading point. A light below the horizon
//! contributes zero through its estimator (max(0, n·ω)), so choosing it rarely only wastes that
//! sample. The estimator divides light j's K by p_j(x, n) ([`LightTree::sample`]); its
//! expectation is Σ_j p_j·E_j/p_j = Σ_j E_j, the expectation of `every`.
//!
//! ξ_c is one uniform on a lattice of spacing 2⁻²⁴. At a node it goes left when
//! u·I_right < (1 − u)·I_left, and is then rescaled to [0, 1) on the chosen side, in f32 (as
//! pbrt-v4 does): each rescaling rounds to 2⁻²⁴ relative, finer than the spacing of the values
//! u takes there (the lattice stretched by 1/share at every level above), so the selection
//! frequencies equal the pmf to within that lattice. The pmf is the product, in f64, of the
//! shares p = I_left/(I_left + I_right) (f32) and 1 − p on the path: a node's two shares sum to
//! 1 exactly. A side whose importance the f32 sum absorbs (below 2⁻²⁴ of the other's, which no
//! lattice ξ_c could reach either) has share 0 and is never taken. [`LightTree::pmf`]
//! recomputes the same products in the same order, bit for bit.

use crate::light::Light;
use glam::Vec3;
use linlight_sampling::Segment;
use linlight_simd::{Isa, Lanes3};

mod levels;

/// The children (left, right) of L lanes' nodes and their fields, lane by lane.
type Children<const L: usize> = ([u32; L], [u32; L], NodeLanes<L>, NodeLanes<L>);

/// Floor of cos θ' in a node's importance (relative to the node's Φ/d²).
pub const COS_FLOOR: f32 = 1e-4;

/// A node as the walk reads it: what its importance needs that does not depend on the shading
/// point (the sphere around its box, 2Φ or a leaf's ‖K‖₁, a leaf's segment) and its children.
/// A leaf's children are itself, so a walk that has reached it stays there. One cache line.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct Node {
    /// Centre c and squared radius r² of the sphere around the box.
    centre: [f32; 3],
    r2: f32,
    /// 2Φ for an interior node; −‖K‖₁ for a leaf (its sign bit marks the leaves, −0.0 too).
    weight: f32,
    /// A leaf's segment: its begin, unit axis (end − begin)/L, length L and the floor
    /// 10⁻¹²·L·L of h² in Ω_R.
    segment: SegmentBound,
    /// Children (left, right); (self, self) for a leaf.
    children: [u32; 2],
}

/// What Ω_R of a segment needs that does not depend on the shading point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct SegmentBound {
    begin: [f32; 3],
    unit_axis: [f32; 3],
    length: f32,
    h2_floor: f32,
}

impl Node {
    fn is_leaf(&self) -> bool {
        self.weight.is_sign_negative()
    }
}

/// Three coordinates' dot product in glam's order, (a₀b₀ + a₁b₁) + a₂b₂.
#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] * b[0]) + (a[1] * b[1]) + (a[2] * b[2])
}

/// The importance of `node` (a leaf if `leaf`) at shading point `x` with unit normal `n` (module
/// documentation):
/// cos θ′ (floored at [`COS_FLOOR`]) times 2Φ/d² for an interior node, times ‖K‖₁·Ω_R for a
/// leaf; positive and finite. Written without early exits (the walk runs it over lanes at
/// different nodes, [`NodeLanes`]): the values are those of the branches taken.
#[inline(always)]
fn importance(node: &Node, leaf: bool, x: [f32; 3], n: [f32; 3]) -> f32 {
    let c = node.centre;
    let r2 = node.r2;
    let to = [c[0] - x[0], c[1] - x[1], c[2] - x[2]];
    let dist2 = dot(to, to);
    let nd = dot(n, to);
    // Outside the sphere (d² > r²), with ‖n‖ = 1 and t = n·(c − x): cos θ = t/d, cos θ_b =
    // √(d² − r²)/d and sin θ_b = r/d, so cos(θ − θ_b) = (t·√(d² − r²) + √((d² − t²)·r²))/d²,
    // and θ ≤ θ_b iff t ≥ √(d² − r²): two square roots and one division.
    let s1 = max(dist2 - r2, 0.0).sqrt();
    let s2 = max((dist2 - nd * nd) * r2, 0.0).sqrt();
    let inv = 1.0 / max(max(dist2, r2), 1.0 / LIMIT);
    let reach = if leaf {
        -node.weight * solid_angle_per_radius(&node.segment, x)
    } else {
        node.weight * inv
    };
    // Clamped (NaN and ∞ to the largest) while the cone's roots are computed. With reach and
    // 1/d² at most LIMIT, and t·√(d² − r²) + √((d² − t²)·r²) ≤ 2d² outside the sphere, the
    // importance is positive and at most 2·LIMIT.
    let reach = max(min(reach, LIMIT), f32::MIN_POSITIVE / COS_FLOOR);
    // cos θ′ = 1 when x is inside the bounding sphere (every direction may reach it) or n
    // inside the cone of the sphere; the rest of the product is taken before the last root.
    if dist2 <= r2 || nd >= s1 {
        reach
    } else {
        max((nd * s1 + s2) * (reach * inv), COS_FLOOR * reach)
    }
}

/// The largest reach and 1/d² of an importance, 2⁶⁰ (far beyond a scene's: d below a
/// nanometre, or a power 10¹⁸ times a metre's): products and sums of importances stay finite.
const LIMIT: f32 = (1u64 << 60) as f32;

/// a if a > b, else b (b where a is NaN): one instruction on x86 (`f32::max` takes three).
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// a if a < b, else b (b where a is NaN).
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// Ω_R of a leaf's segment seen from `x`: the solid angle per radius of the thin tube around
/// it, ∫ 2 sin θ/r² dl = (2/h)·(l₂/√(h² + l₂²) − l₁/√(h² + l₁²)), h the distance from `x` to the
/// line and l₁ < l₂ the positions of the ends along it from the foot of the perpendicular,
/// taken over one division: 2·(l₂·√(h² + l₁²) − l₁·√(h² + l₂²))/(h·√(h² + l₂²)·√(h² + l₁²)).
/// (Far away it is 2L·sin θ/d², the interior nodes' 2Φ/d² with sin θ ≤ 1.)
#[inline(always)]
fn solid_angle_per_radius(segment: &SegmentBound, x: [f32; 3]) -> f32 {
    let (b, unit, length) = (segment.begin, segment.unit_axis, segment.length);
    let a = [b[0] - x[0], b[1] - x[1], b[2] - x[2]];
    let l1 = dot(a, unit);
    let l2 = l1 + length;
    let h2 = max(dot(a, a) - l1 * l1, segment.h2_floor);
    let (root2, root1) = ((h2 + l2 * l2).sqrt(), (h2 + l1 * l1).sqrt());
    2.0 * (l2 * root1 - l1 * root2) / (h2.sqrt() * root2 * root1)
}

/// One step of the walk down from a node with children importances `il`, `ir`: whether ξ `u`
/// goes left (u·ir < (1 − u)·il: u·(il + ir) < il but for rounding, with neither the sum's nor
/// a division's latency on the chain from one level's choice to the next), u rescaled to
/// [0, 1) on that side (one division on the chain of u), and [`p_left`]. Never a side of share
/// 0.
#[inline(always)]
fn step(il: f32, ir: f32, u: f32) -> (bool, f32, f32) {
    let sum = il + ir;
    let left = (u * ir < (1.0 - u) * il || sum == il) && sum != ir;
    let (start, width) = if left { (0.0, il) } else { (il, ir) };
    let u_next = min(max((u * sum - start) / width, 0.0), 1.0);
    (left, u_next, p_left(il, ir))
}

/// The probability of the left child, il/(il + ir) in f32: exactly 1 (0) where the sum absorbs
/// ir (il).
#[inline(always)]
fn p_left(il: f32, ir: f32) -> f32 {
    let sum = il + ir;
    if sum == ir {
        0.0
    } else {
        il / sum
    }
}

/// The probability of the side taken, `left` of the left one's `p`, in f64 (p + (1 − p) = 1
/// exactly).
#[inline(always)]
fn share(left: bool, p: f32) -> f64 {
    if left {
        p as f64
    } else {
        1.0 - p as f64
    }
}

/// A binary tree over a scene's light segments (see the module documentation). Empty for no
/// lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// Per node: its light (leaves; unused in interior nodes).
    light: Vec<u32>,
    /// Per light: the choices from the root to its leaf, bit i set = right at depth i, and
    /// the depth.
    trail: Vec<(u64, u32)>,
    /// The deepest and the shallowest leaf's depths.
    depth: u32,
    shallowest: u32,
    /// The nodes are in breadth-first order (each depth's nodes contiguous, a node's children
    /// consecutive). Entry d: depth d's first node and its nodes' fields as tables, for the
    /// depths from the root down to the first with more than [`levels::MAX_NODES`] nodes.
    levels: Vec<levels::Level>,
}

impl LightTree {
    /// The tree over `lights`. A light's power is ‖K‖₁·length (positive lengths
    /// and K assumed; a zero power is raised to the smallest positive f32 so every light can be
    /// chosen).
    pub fn new(lights: &[Light]) -> Self {
        let mut tree = Self {
            nodes: Vec::with_capacity(2 * lights.len()),
            light: Vec::with_capacity(2 * lights.len()),
            trail: vec![(0, 0); lights.len()],
            depth: 0,
            shallowest: 0,
            levels: Vec::new(),
        };
        if lights.is_empty() {
            return tree;
        }
        let mut order: Vec<u32> = (0..lights.len() as u32).collect();
        tree.build(lights, &mut order, 0, 0);
        tree.depth = tree.trail.iter().map(|&(_, d)| d).max().unwrap_or(0);
        tree.shallowest = tree.trail.iter().map(|&(_, d)| d).min().unwrap_or(0);
        tree.breadth_first();
        tree
    }

    /// Renumbers the nodes (built depth first) in breadth-first order, so that each depth's
    /// nodes are contiguous and a node's children consecutive, and tabulates the small levels.
    fn breadth_first(&mut self) {
        let mut order = vec![0u32];
        let mut starts = Vec::new();
        let mut begin = 0;
        while begin < order.len() {
            starts.push(begin as u32);
            let end = order.len();
            for i in begin..end {
                let node = &self.nodes[order[i] as usize];
                if !node.is_leaf() {
                    order.extend(node.children);
                }
            }
            begin = end;
        }
        let mut new_index = vec![0u32; self.nodes.len()];
        for (new, &old) in order.iter().enumerate() {
            new_index[old as usize] = new as u32;
        }
        let nodes: Vec<Node> = order
            .iter()
            .map(|&old| {
                let mut node = self.nodes[old as usize];
                node.children = node.children.map(|c| new_index[c as usize]);
                node
            })
            .collect();
        self.light = order.iter().map(|&old| self.light[old as usize]).collect();
        self.nodes = nodes;
        starts.push(self.nodes.len() as u32);
        self.levels = starts
            .windows(2)
            .map_while(|w| levels::Level::new(&self.nodes[w[0] as usize..w[1] as usize], w[0]))
            .collect();
    }

    /// Builds the subtree of `lights[order]` at depth `depth` with trail `bits`; returns its
    /// node index. Splits at the median of the segments' midpoints along the axis where they
    /// spread most.
    fn build(&mut self, lights: &[Light], order: &mut [u32], depth: u32, bits: u64) -> u32 {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        let mut power = 0.0f32;
        for &j in order.iter() {
            let Light { segment: s, k } = &lights[j as usize];
            lo = lo.min(s.begin).min(s.end);
            hi = hi.max(s.begin).max(s.end);
            let mid = 0.5 * (s.begin + s.end);
            clo = clo.min(mid);
            chi = chi.max(mid);
            power += light_power(s, *k);
        }
        let index = self.nodes.len() as u32;
        let Light { segment, k } = lights[order[0] as usize];
        self.nodes.push(leaf(lo, hi, &segment, k, index));
        self.light.push(order[0]);
        // Median splits: depth ≤ ⌈log₂ N⌉ < 64, the bits of a trail.
        debug_assert!(depth < 64);
        if order.len() == 1 {
            self.trail[order[0] as usize] = (bits, depth);
            return index;
        }
        let axis = (chi - clo).max_position();
        let key = |j: &u32| {
            let s = &lights[*j as usize].segment;
            (0.5 * (s.begin + s.end))[axis]
        };
        order.sort_by(|a, b| key(a).total_cmp(&key(b)).then(a.cmp(b)));
        let half = order.len() / 2;
        let (left, right) = order.split_at_mut(half);
        let l = self.build(lights, left, depth + 1, bits);
        let r = self.build(lights, right, depth + 1, bits | (1 << depth));
        let node = &mut self.nodes[index as usize];
        node.children = [l, r];
        node.weight = 2.0 * power.max(f32::MIN_POSITIVE);
        index
    }

    /// Number of lights.
    pub fn len(&self) -> usize {
        self.trail.len()
    }

    pub fn is_empty(&self) -> bool {
        self.trail.is_empty()
    }

    /// The probability of going left at interior node `node` from (x, n).
    #[inline]
    fn node_p_left(&self, node: &Node, x: Vec3, n: Vec3) -> f32 {
        let [il, ir] = node.children.map(|c| {
            let child = &self.nodes[c as usize];
            importance(child, child.is_leaf(), x.into(), n.into())
        });
        p_left(il, ir)
    }

    /// The light chosen by ξ_c ∈ [0, 1) at shading point `x` with unit normal `n`, and its
    /// probability p_j(x, n) > 0 (equal to [`Self::pmf`]): [`Self::sample_lanes`] on one lane.
    #[inline]
    pub fn sample(&self, x: Vec3, n: Vec3, xi: f32) -> (usize, f64) {
        let lane = |v: Vec3| v.to_array().map(|c| [c]);
        let (j, pmf) = self.sample_lanes(Isa::Baseline, &lane(x), &lane(n), &[xi]);
        (j[0] as usize, pmf[0])
    }

    /// [`Self::sample`] for each lane k of (`x`, `n`, `xi`): the lanes walk down together, one
    /// level per step, each from its own node, the importances of their children computed over
    /// the lanes (vector operations; the leaves' segments only at levels that hold leaves); a
    /// lane at its leaf stays there. The nodes' fields are gathered lane by lane, or, for 16
    /// lanes under [`Isa::Avx512`] and levels of at most 64 nodes, looked up
    /// in the level's tables by vector permutes. The operations of each lane are those of one
    /// lane alone: the same lights and pmfs, bit for bit, whatever `isa`.
    #[inline(always)]
    pub fn sample_lanes<const L: usize>(
        &self,
        isa: Isa,
        x: &Lanes3<f32, L>,
        n: &Lanes3<f32, L>,
        xi: &[f32; L],
    ) -> ([u32; L], [f64; L]) {
        debug_assert!(!self.nodes.is_empty(), "no light to choose");
        #[cfg(target_arch = "x86_64")]
        if L == levels::LANES && isa == Isa::Avx512 && self.levels.len() > 1 && isa.supported() {
            // SAFETY: L = LANES, so the casts are between identical types; the CPU runs
            // AVX-512 (just checked).
            unsafe {
                let cast =
                    |v: &Lanes3<f32, L>| &*(v as *const _ as *const Lanes3<f32, { levels::LANES }>);
                let xi = &*(xi as *const [f32; L] as *const [f32; levels::LANES]);
                let out = levels::sample(self, cast(x), cast(n), xi);
                return std::mem::transmute_copy(&out);
            }
        }
        let _ = isa;
        self.walk(x, n, xi, |_, node, leaves| {
            self.gather_children(node, leaves)
        })
    }

    /// The children (left, right) of each lane's node, and their fields: gathered lane by lane.
    #[inline(always)]
    fn gather_children<const L: usize>(&self, node: &[u32; L], leaves: bool) -> Children<L> {
        let mut left = [0u32; L];
        let mut right = [0u32; L];
        for k in 0..L {
            [left[k], right[k]] = self.nodes[node[k] as usize].children;
        }
        let l = NodeLanes::gather(&self.nodes, &left, leaves);
        let r = NodeLanes::gather(&self.nodes, &right, leaves);
        (left, right, l, r)
    }

    /// The walk of [`Self::sample_lanes`], with `children(level, node, leaves)` the children of
    /// each lane's node at depth `level` and their fields (with the leaves' segments when
    /// `leaves`). Lanes at a leaf keep their numbers, whatever `children` gives for them.
    #[inline(always)]
    fn walk<const L: usize>(
        &self,
        x: &Lanes3<f32, L>,
        n: &Lanes3<f32, L>,
        xi: &[f32; L],
        children: impl Fn(usize, &[u32; L], bool) -> Children<L>,
    ) -> ([u32; L], [f64; L]) {
        let mut walk = Walk::start(self, xi);
        for level in 0..self.depth {
            // Children at depth level + 1: leaves among them from the shallowest leaf's depth.
            let leaves = level + 1 >= self.shallowest;
            let c = children(level as usize, &walk.node, leaves);
            walk.level(c, x, n);
        }
        walk.end(self)
    }

    /// p_j(x, n): the probability that [`Self::sample`] chooses light `j` at (x, n).
    pub fn pmf(&self, x: Vec3, n: Vec3, j: usize) -> f64 {
        let (bits, depth) = self.trail[j];
        let mut pmf = 1.0f64;
        let mut node = 0;
        for d in 0..depth {
            let p = self.node_p_left(&self.nodes[node], x, n);
            let [l, r] = self.nodes[node].children;
            let left = bits >> d & 1 == 0;
            pmf *= share(left, p);
            node = if left { l } else { r } as usize;
        }
        debug_assert!(self.nodes[node].is_leaf() && self.light[node] as usize == j);
        pmf
    }
}

/// The state of L lanes' walk down the tree.
struct Walk<const L: usize> {
    node: [u32; L],
    u: [f32; L],
    pmf: [f64; L],
    /// All ones in the lanes at a leaf.
    done: [u32; L],
}

impl<const L: usize> Walk<L> {
    #[inline(always)]
    fn start(tree: &LightTree, xi: &[f32; L]) -> Self {
        Self {
            node: [0; L],
            u: xi.map(|v| v.clamp(0.0, 1.0)),
            pmf: [1.0; L],
            done: [(tree.nodes[0].is_leaf() as u32).wrapping_neg(); L],
        }
    }

    /// One level down, from the children of the lanes' nodes.
    #[inline(always)]
    fn level(&mut self, (left, right, l, r): Children<L>, x: &Lanes3<f32, L>, n: &Lanes3<f32, L>) {
        let il = l.importance(x, n);
        let ir = r.importance(x, n);
        // Per lane: the probability of the side taken is p (left) or 1 − p; 1 (p = 1, left)
        // for lanes that stay.
        let mut p = [0.0f32; L];
        let mut lefts = [0u32; L];
        for k in 0..L {
            let (go_left, u_next, p_left) = step(il[k], ir[k], self.u[k]);
            let walks = self.done[k] == 0;
            p[k] = if walks { p_left } else { 1.0 };
            lefts[k] = (go_left || !walks) as u32;
            // Bitwise selects: written with `if`, the compiler stores u with a mask, and
            // selects the arrays' addresses and gathers from them.
            self.u[k] = f32::from_bits(
                u_next.to_bits() & !self.done[k] | self.u[k].to_bits() & self.done[k],
            );
            let m = (go_left as u32).wrapping_neg();
            let next = left[k] & m | right[k] & !m;
            let weight = l.weight[k].to_bits() & m | r.weight[k].to_bits() & !m;
            self.node[k] = next & !self.done[k] | self.node[k] & self.done[k];
            self.done[k] |= ((weight as i32) >> 31) as u32;
        }
        // Apart from the f32 step: f64 lanes are half as many per vector.
        for k in 0..L {
            self.pmf[k] *= share(lefts[k] != 0, p[k]);
        }
    }

    #[inline(always)]
    fn end(self, tree: &LightTree) -> ([u32; L], [f64; L]) {
        (self.node.map(|i| tree.light[i as usize]), self.pmf)
    }
}

/// The nodes of L lanes, field by field (what [`importance`] reads), so that it runs over the
/// lanes as vector operations. Each array on its own cache line(s): 16 lanes are one
/// register, which a misaligned spill or reload would split.
#[repr(C, align(64))]
struct NodeLanes<const L: usize> {
    centre: Lanes3<f32, L>,
    r2: [f32; L],
    weight: [f32; L],
    /// The leaves' segments, when a lane's node may be a leaf.
    segment: Option<SegmentLanes<L>>,
}

/// The [`SegmentBound`]s of L lanes, field by field, aligned as [`NodeLanes`].
#[repr(C, align(64))]
struct SegmentLanes<const L: usize> {
    begin: Lanes3<f32, L>,
    unit_axis: Lanes3<f32, L>,
    length: [f32; L],
    h2_floor: [f32; L],
}

impl<const L: usize> NodeLanes<L> {
    /// Node `index[k]` of `nodes` in lane k (one node for all when the lanes share it), with
    /// the leaves' segments when `leaves` (a lane's node may be a leaf).
    #[inline(always)]
    fn gather(nodes: &[Node], index: &[u32; L], leaves: bool) -> Self {
        let mut lanes = Self {
            centre: [[0.0; L]; 3],
            r2: [0.0; L],
            weight: [0.0; L],
            segment: None,
        };
        // One node for all lanes: tested without a branch per lane (an OR of XORs).
        if index.iter().fold(0, |any, &i| any | (i ^ index[0])) == 0 {
            let node = &nodes[index[0] as usize];
            lanes.centre = node.centre.map(|c| [c; L]);
            lanes.r2 = [node.r2; L];
            lanes.weight = [node.weight; L];
        } else {
            for (k, &i) in index.iter().enumerate() {
                let node = &nodes[i as usize];
                for c in 0..3 {
                    lanes.centre[c][k] = node.centre[c];
                }
                lanes.r2[k] = node.r2;
                lanes.weight[k] = node.weight;
            }
        }
        if leaves {
            let mut segment = SegmentLanes {
                begin: [[0.0; L]; 3],
                unit_axis: [[0.0; L]; 3],
                length: [0.0; L],
                h2_floor: [0.0; L],
            };
            for (k, &i) in index.iter().enumerate() {
                let s = &nodes[i as usize].segment;
                for c in 0..3 {
                    segment.begin[c][k] = s.begin[c];
                    segment.unit_axis[c][k] = s.unit_axis[c];
                }
                segment.length[k] = s.length;
                segment.h2_floor[k] = s.h2_floor;
            }
            lanes.segment = Some(segment);
        }
        lanes
    }

    /// Lane k's node (its fields; not its children), with `segment` (zero when None).
    #[inline(always)]
    fn node(&self, k: usize, segment: Option<&SegmentLanes<L>>) -> Node {
        let lane = |v: &Lanes3<f32, L>| [v[0][k], v[1][k], v[2][k]];
        Node {
            centre: lane(&self.centre),
            r2: self.r2[k],
            weight: self.weight[k],
            segment: segment.map_or(SegmentBound::default(), |s| SegmentBound {
                begin: lane(&s.begin),
                unit_axis: lane(&s.unit_axis),
                length: s.length[k],
                h2_floor: s.h2_floor[k],
            }),
            children: [0, 0],
        }
    }

    /// [`importance`] of each lane's node from the lane's (`x`, `n`); Ω_R only when a lane's
    /// node may be a leaf.
    #[inline(always)]
    fn importance(&self, x: &Lanes3<f32, L>, n: &Lanes3<f32, L>) -> [f32; L] {
        let mut out = [0.0; L];
        let lane = |v: &Lanes3<f32, L>, k: usize| [v[0][k], v[1][k], v[2][k]];
        match &self.segment {
            None => {
                for (k, out) in out.iter_mut().enumerate() {
                    *out = importance(&self.node(k, None), false, lane(x, k), lane(n, k));
                }
            }
            Some(s) => {
                for (k, out) in out.iter_mut().enumerate() {
                    let leaf = self.weight[k].is_sign_negative();
                    *out = importance(&self.node(k, Some(s)), leaf, lane(x, k), lane(n, k));
                }
            }
        }
        out
    }
}

/// The leaf of box [`lo`, `hi`], `segment` and K `k` at index `index` (children (index,
/// index)); the builder makes it interior by setting its children and weight.
fn leaf(lo: Vec3, hi: Vec3, segment: &Segment, k: Vec3, index: u32) -> Node {
    let centre = 0.5 * (lo + hi);
    let axis = segment.end - segment.begin;
    let length = axis.length();
    // A point light (zero length) has Ω_R = 0 whatever the axis.
    let unit_axis = if length > 0.0 {
        axis / length
    } else {
        Vec3::ZERO
    };
    Node {
        centre: centre.to_array(),
        r2: 0.25 * (hi - lo).length_squared(),
        weight: -k.abs().element_sum(),
        segment: SegmentBound {
            begin: segment.begin.to_array(),
            unit_axis: unit_axis.to_array(),
            length,
            h2_floor: 1e-12 * length * length,
        },
        children: [index, index],
    }
}

/// Φ of one light: ‖K‖₁ × its length (proportional to the tube's emitted power).
fn light_power(s: &Segment, k: Vec3) -> f32 {
    let p = k.abs().element_sum() * (s.end - s.begin).length();
    if p.is_finite() {
        p
    } else {
        f32::MAX
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_verify::chi2::pooled_chi_square;

    /// A fixed 64-bit generator (SplitMix64) for the tests' ξ and scenes.
    struct Mix(u64);
    impl Mix {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }
        /// A lattice uniform k·2⁻²⁴, as the renderer's.
        fn xi(&mut self) -> f32 {
            (self.next() >> 40) as f32 * (1.0 / 16_777_216.0)
        }
        fn unit(&mut self) -> f32 {
            self.xi()
        }
    }

    /// The many-tubes ceiling: 8 × 8 tubes along x at height 3.9, K of a few sizes.
    fn ceiling() -> Vec<Light> {
        (0..64)
            .map(|i| {
                let (a, b) = ((i % 8) as f32, (i / 8) as f32);
                let (x, y) = (-7.0 + 2.0 * a, -5.0 + 1.4 * b);
                let k = Vec3::splat(1.0 + (i % 3) as f32);
                Light::new(
                    Segment::new(Vec3::new(x - 0.6, y, 3.9), Vec3::new(x + 0.6, y, 3.9)),
                    k,
                )
            })
            .collect()
    }

    /// Random segments in a box (some crossing, some long), random K.
    fn random_lights(rng: &mut Mix, n: usize) -> Vec<Light> {
        (0..n)
            .map(|_| {
                let p = |rng: &mut Mix| {
                    Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 10.0 - Vec3::splat(5.0)
                };
                let a = p(rng);
                let b = a + (p(rng) * 0.3);
                Light::new(Segment::new(a, b), Vec3::splat(0.1 + rng.unit()))
            })
            .collect()
    }

    /// Shading points: floor and desk points facing up, a wall point, points on the ceiling
    /// facing down (every light on its horizon), random points and normals.
    fn shading_points(rng: &mut Mix) -> Vec<(Vec3, Vec3)> {
        let mut v = vec![
            (Vec3::new(0.0, 0.0, 0.0), Vec3::Z),
            (Vec3::new(-6.5, -4.0, 0.75), Vec3::Z),
            (Vec3::new(8.0, 0.0, 2.0), -Vec3::X),
            (Vec3::new(0.3, 0.2, 4.0), -Vec3::Z),
            (Vec3::new(0.0, 0.0, 3.9), Vec3::Z), // on the lights' plane, facing away below
        ];
        for _ in 0..5 {
            let x = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 12.0 - Vec3::splat(6.0);
            let n = (Vec3::new(rng.unit(), rng.unit(), rng.unit()) - Vec3::splat(0.5))
                .try_normalize()
                .unwrap_or(Vec3::Z);
            v.push((x, n));
        }
        v
    }

    /// Pearson's χ² of `counts` against `n`·`pmf` (the verify crate's pooling: cells below 5
    /// expected pooled); its p-value.
    fn chi2_p(counts: &[u64], pmf: &[f64], n: u64) -> f64 {
        let expected: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
        pooled_chi_square(counts, &expected).p_value
    }

    /// Counts of the lights chosen by `samples` lattice ξ at (x, n).
    fn frequencies(tree: &LightTree, x: Vec3, n: Vec3, rng: &mut Mix, samples: u64) -> Vec<u64> {
        let mut counts = vec![0u64; tree.len()];
        for _ in 0..samples {
            let (j, p) = tree.sample(x, n, rng.xi());
            assert_eq!(p, tree.pmf(x, n, j), "sample and pmf disagree");
            counts[j] += 1;
        }
        counts
    }

    /// Scenes × shading points of the selection tests: (tree, x, n).
    fn cases() -> Vec<(LightTree, Vec3, Vec3)> {
        let mut rng = Mix(0x5eed_0022);
        let mut scenes = vec![
            ceiling(),
            random_lights(&mut rng, 37),
            random_lights(&mut rng, 2),
        ];
        scenes.push(random_lights(&mut rng, 1));
        let mut out = Vec::new();
        for lights in scenes {
            let tree = LightTree::new(&lights);
            for (x, n) in shading_points(&mut rng) {
                out.push((tree.clone(), x, n));
            }
        }
        out
    }

    /// Significance level of the whole family of χ² tests below; each case is tested at
    /// ALPHA / cases (Bonferroni).
    const ALPHA: f64 = 0.01;
    /// Choices drawn per case.
    const SAMPLES: u64 = 200_000;

    /// The probabilities of every light sum to 1 (to f64 rounding) and are positive at every
    /// shading point, and the frequencies of the lights chosen by SAMPLES lattice ξ match them:
    /// Pearson's χ² per case (cells below 5 expected pooled) at α = 0.01 over the family
    /// (Bonferroni over the cases); `sample` returns the `pmf` of its light bit for bit.
    #[test]
    fn selection_frequencies_match_the_pmf() {
        let cases = cases();
        let level = ALPHA / cases.len() as f64;
        let mut rng = Mix(7);
        for (c, (tree, x, n)) in cases.iter().enumerate() {
            let pmf: Vec<f64> = (0..tree.len()).map(|j| tree.pmf(*x, *n, j)).collect();
            assert!(pmf.iter().all(|&p| p > 0.0 && p.is_finite()), "case {c}");
            let sum: f64 = pmf.iter().sum();
            assert!((sum - 1.0).abs() < 1e-12, "case {c}: Σ pmf = {sum}");
            if tree.len() < 2 {
                assert_eq!(tree.sample(*x, *n, 0.3), (0, 1.0));
                continue;
            }
            let counts = frequencies(tree, *x, *n, &mut rng, SAMPLES);
            let p = chi2_p(&counts, &pmf, SAMPLES);
            assert!(
                p > level,
                "case {c} ({x}, {n}): χ² p = {p:.3e} ≤ {level:.1e}"
            );
        }
    }

    /// Negative control: the same frequencies tested against a pmf off by a factor 1.1 on its
    /// most probable light (the others rescaled to sum to 1) are rejected at the same level in
    /// every case with a light of probability ≥ 0.1.
    #[test]
    fn a_pmf_off_by_a_factor_is_rejected() {
        let cases = cases();
        let level = ALPHA / cases.len() as f64;
        let mut rng = Mix(7);
        let mut rejected = 0;
        for (tree, x, n) in cases.iter().filter(|(t, _, _)| t.len() >= 2) {
            let mut pmf: Vec<f64> = (0..tree.len()).map(|j| tree.pmf(*x, *n, j)).collect();
            let top = (0..pmf.len())
                .max_by(|&a, &b| pmf[a].total_cmp(&pmf[b]))
                .unwrap();
            if pmf[top] < 0.1 {
                continue;
            }
            let rest = 1.0 - pmf[top];
            let wrong = (pmf[top] * 1.1).min(0.999);
            for (j, p) in pmf.iter_mut().enumerate() {
                *p = if j == top {
                    wrong
                } else {
                    *p * (1.0 - wrong) / rest
                };
            }
            let counts = frequencies(tree, *x, *n, &mut rng, SAMPLES);
            let p = chi2_p(&counts, &pmf, SAMPLES);
            assert!(
                p <= level,
                "({x}, {n}): wrong pmf not rejected, p = {p:.3e}"
            );
            rejected += 1;
        }
        assert!(rejected >= 10, "only {rejected} cases tested");
    }

    /// The lanes' walk chooses, lane by lane, the light and pmf of the one-lane walk bit for
    /// bit (16 lanes of different shading points and ξ, among them lanes without a shading
    /// point: zero normal and position), with every instruction set the CPU runs (AVX-512:
    /// the level tables; 150 lights also have levels too large for them).
    #[test]
    fn lanes_choose_as_one_lane() {
        let mut rng = Mix(0x1a7e5);
        let mut cases = cases();
        let large = LightTree::new(&random_lights(&mut rng, 150));
        assert!(large.levels.len() > 1 && large.levels.len() <= large.depth as usize);
        cases.extend(
            shading_points(&mut rng)
                .into_iter()
                .map(|(x, n)| (large.clone(), x, n)),
        );
        for ((tree, x0, n0), isa) in cases
            .into_iter()
            .flat_map(|c| Isa::ALL.map(|isa| (c.clone(), isa)))
            .filter(|(_, isa)| isa.supported())
        {
            let mut x = [[0.0f32; 16]; 3];
            let mut n = [[0.0f32; 16]; 3];
            let xi: [f32; 16] = std::array::from_fn(|_| rng.xi());
            for k in 1..16 {
                let (xk, nk) = if k % 2 == 0 {
                    (x0, n0)
                } else {
                    let v = Vec3::new(rng.unit(), rng.unit(), rng.unit());
                    let d = Vec3::new(rng.unit(), rng.unit(), rng.unit()) - Vec3::splat(0.5);
                    (
                        v * 12.0 - Vec3::splat(6.0),
                        d.try_normalize().unwrap_or(Vec3::Z),
                    )
                };
                for c in 0..3 {
                    x[c][k] = xk[c];
                    n[c][k] = nk[c];
                }
            }
            let (light, pmf) = tree.sample_lanes(isa, &x, &n, &xi);
            for k in 0..16 {
                let xk = Vec3::new(x[0][k], x[1][k], x[2][k]);
                let nk = Vec3::new(n[0][k], n[1][k], n[2][k]);
                let (j, p) = tree.sample(xk, nk, xi[k]);
                assert_eq!(
                    (light[k] as usize, pmf[k].to_bits()),
                    (j, p.to_bits()),
                    "lane {k}, {isa:?}"
                );
            }
        }
    }

    /// The importance is its definition (module documentation) evaluated in f64 with the
    /// trigonometric functions: cos θ′ = cos(max(0, θ − θ_b)) from acos and asin, Ω_R from its
    /// closed form; to 10⁻³ relative (f32 cancels to ~2·10⁻⁴ where cos θ′ nears its floor
    /// and in Ω_R) on random nodes, leaves and shading points, points inside the bounding
    /// spheres, inside the cones and below the horizon (the floor) among them.
    #[test]
    fn importance_is_its_definition() {
        let mut rng = Mix(17);
        let v = |rng: &mut Mix, s: f32| {
            Vec3::new(rng.unit(), rng.unit(), rng.unit()) * (2.0 * s) - Vec3::splat(s)
        };
        let (mut worst, mut cases, mut floors, mut inside) = (0.0f64, 0, 0, 0);
        for _ in 0..20_000 {
            let (a, b) = (v(&mut rng, 4.0), v(&mut rng, 4.0));
            let leaf = rng.unit() < 0.5;
            let node = node_over(a, b, leaf, &mut rng);
            let x = v(&mut rng, 6.0);
            let n = v(&mut rng, 1.0).try_normalize().unwrap_or(Vec3::Z);
            let got = importance(&node, leaf, x.into(), n.into()) as f64;
            let to = Vec3::from(node.centre).as_dvec3() - x.as_dvec3();
            let (d, r) = (to.length(), (node.r2 as f64).sqrt());
            let theta = (n.as_dvec3().dot(to) / d).clamp(-1.0, 1.0).acos();
            let theta_b = if d <= r {
                std::f64::consts::PI
            } else {
                (r / d).asin()
            };
            let cos = (theta - theta_b).max(0.0).cos().max(COS_FLOOR as f64);
            let reach = if leaf {
                let s = &node.segment;
                let u = Vec3::from(s.unit_axis).as_dvec3();
                let a = Vec3::from(s.begin).as_dvec3() - x.as_dvec3();
                let l1 = a.dot(u);
                let l2 = l1 + s.length as f64;
                let h = (a.length_squared() - l1 * l1).max(s.h2_floor as f64).sqrt();
                let omega = 2.0 / h * (l2 / h.hypot(l2) - l1 / h.hypot(l1));
                -node.weight as f64 * omega
            } else {
                node.weight as f64 / (d * d).max(r * r)
            };
            let want = reach * cos;
            // Ω_R far along the line's extension cancels in f32; the bound is for the rest.
            if leaf && reach < 1e-3 * -node.weight as f64 {
                continue;
            }
            worst = worst.max((got / want - 1.0).abs());
            cases += 1;
            floors += (cos == COS_FLOOR as f64) as u32;
            inside += (d <= r) as u32;
        }
        assert!(worst < 1e-3, "worst relative error {worst:e}");
        assert!(
            cases > 15_000 && floors > 1000 && inside > 100,
            "{cases} {floors} {inside}"
        );
    }

    /// A node over segment a → b: a leaf (K of 0.1–1.1), or an interior node with the box
    /// of the segment grown by up to 1 on each side and weight 2Φ of 1–11.
    fn node_over(a: Vec3, b: Vec3, leaf: bool, rng: &mut Mix) -> Node {
        let k = Vec3::splat(0.1 + rng.unit());
        let grow = Vec3::splat(rng.unit());
        let mut node = super::leaf(a.min(b) - grow, a.max(b) + grow, &Segment::new(a, b), k, 0);
        if !leaf {
            node.weight = 1.0 + 10.0 * rng.unit();
        }
        node
    }

    /// Extreme nodes and shading points (a 10⁻¹³-long segment of huge K next to x, an interior
    /// node of weight 10³⁰ at x, points 10³⁰ away, a zero normal): every importance is positive
    /// and at most 2⁶¹, so that two children's p is a probability.
    #[test]
    fn importance_is_positive_and_bounded_on_extremes() {
        let tiny = Segment::new(Vec3::ZERO, Vec3::new(1e-13, 0.0, 0.0));
        let leaf = super::leaf(tiny.begin, tiny.end, &tiny, Vec3::splat(1e30), 0);
        let mut heavy = node_over(Vec3::ZERO, Vec3::X, false, &mut Mix(3));
        heavy.weight = 1e30;
        let points = [
            Vec3::new(5e-14, 1e-14, 0.0),
            Vec3::ZERO,
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::splat(1e30),
            Vec3::splat(-1e30),
        ];
        for (node, is_leaf) in [(leaf, true), (heavy, false)] {
            for x in points {
                for n in [Vec3::Z, -Vec3::Z, Vec3::ZERO] {
                    let i = importance(&node, is_leaf, x.into(), n.into());
                    assert!(i > 0.0 && i <= 2.0 * LIMIT, "{i} at {x}, {n}");
                    let p = p_left(i, i);
                    assert!((0.0..=1.0).contains(&p), "p = {p}");
                }
            }
        }
    }

    /// The step's choice splits [0, 1) at p: on a lattice of 2¹⁶ values u, the number going
    /// left is p·2¹⁶ to within one lattice point (the f32 rounding of the test), for importance
    /// ratios from 1 to 10⁻⁷ each way; every u is rescaled into [0, 1] and takes a side of
    /// positive share; a side absorbed by the sum has share exactly 0 and is never taken.
    #[test]
    fn a_step_splits_at_p() {
        const N: u32 = 1 << 16;
        let mut rng = Mix(23);
        for case in 0..200 {
            let il = 10f32.powf(7.0 * rng.unit() - 3.5) * (0.5 + rng.unit());
            let ir = 10f32.powf(7.0 * rng.unit() - 3.5) * (0.5 + rng.unit());
            let p = p_left(il, ir);
            let mut left = 0u32;
            for k in 0..N {
                let (go_left, u, q) = step(il, ir, k as f32 / N as f32);
                assert_eq!(q.to_bits(), p.to_bits());
                assert!((0.0..=1.0).contains(&u), "case {case}: u = {u}");
                assert!(share(go_left, p) > 0.0, "case {case}: a side of share 0");
                left += go_left as u32;
            }
            let want = p as f64 * N as f64;
            assert!(
                (left as f64 - want).abs() <= 1.0 + 1e-3,
                "case {case} ({il}, {ir}): {left} left, p·N = {want}"
            );
        }
        for (il, ir, goes_left) in [(1.0, 1e-9, true), (1e-9, 1.0, false)] {
            let p = p_left(il, ir);
            assert_eq!(p, if goes_left { 1.0 } else { 0.0 });
            for k in 0..N {
                assert_eq!(step(il, ir, k as f32 / N as f32).0, goes_left);
            }
        }
    }

    /// Near lights are preferred: on the floor under one of 64 equal tubes, that tube is the
    /// likeliest; above the ceiling facing up (every tube below the horizon), the floor keeps
    /// every light possible.
    #[test]
    fn importance_prefers_near_lights_above_the_horizon() {
        let lights: Vec<_> = ceiling()
            .into_iter()
            .map(|l| Light::new(l.segment, Vec3::ONE))
            .collect();
        let tree = LightTree::new(&lights);
        let x = Vec3::new(-7.0, -5.0, 0.0);
        let pmf: Vec<f64> = (0..64).map(|j| tree.pmf(x, Vec3::Z, j)).collect();
        let best = (0..64).max_by(|&a, &b| pmf[a].total_cmp(&pmf[b])).unwrap();
        assert_eq!(best, 0, "{pmf:?}");
        let up = Vec3::new(0.0, 0.0, 4.5);
        assert!((0..64).all(|j| tree.pmf(up, Vec3::Z, j) > 0.0));
        // Every leaf's trail leads to it, and the depth is ⌈log₂ 64⌉.
        assert!(tree.trail.iter().all(|&(_, d)| d == 6));
    }
}
