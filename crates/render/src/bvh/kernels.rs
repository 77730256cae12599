//! The lane arithmetic of the packet walks, once per vector extension: the packet set-up
//! (reciprocal directions, direction-sign masks, the fourteen bounds of the packet's intervals),
//! the ray-by-ray box test of one child box (planes per lane, or a coherent packet's common
//! planes), the triangle test of all 16 lanes and the closest-hit update. [`Portable`] is plain
//! Rust the compiler vectorises (the target's baseline); [`Avx2`] (two 8-lane registers) and
//! [`Avx512`] (one 16-lane register, mask registers for the lane masks) are written with
//! `std::arch` intrinsics, because the compiler packed the portable code's independent
//! reductions into SSE insert/shuffle chains and zeroed the packet with a `memset`
//! (docs/performance.md, "Packet walks in intrinsics").
//!
//! Every kernel computes each lane's triangle test with the scalar test's operations in the
//! scalar test's order (`shapes::intersect_triangle_lane`: no FMA, a true division), so the
//! hits are the scalar path's bit for bit; box tests only decide which subtrees a packet
//! enters and are conservative in every kernel (the bvh tests compare all kernels).

use super::{replaces, AxisBounds, Node, PacketHits, RayLanes, RayPacket, FAR_SCALE, PACKET};
use crate::shapes::{intersect_sphere_lane, intersect_triangle_lane};
use glam::Vec3;

/// A triangle against the 16 lanes: t, b1, b2 per lane (meaningless where it misses) and bit
/// i set where ray i meets it within (t_min, t_max) of lane i.
pub(super) type LaneHits = ([f32; PACKET], [f32; PACKET], [f32; PACKET], u32);

/// The lane arithmetic of the packet walks for one vector extension. Implementations for an
/// extension the CPU may lack are only called from functions compiled for it after run-time
/// detection (`Bvh::occluded_lanes`, `Bvh::intersect_lanes`).
pub(super) trait Kernel {
    /// The rays of `lanes` in `active` (not 0) as a packet.
    fn packet(lanes: &RayLanes, active: u32) -> RayPacket<'_>;
    /// Bit i: ray i meets child `lane`'s box of `node` within its (t_min, t_max) of the packet
    /// — the conservative slab test of `RayBoxes::hits` (a NaN slab distance leaves the
    /// interval unchanged); and the smallest entry distance of the rays that hit (+∞ if none).
    fn box_hits(p: &RayPacket, node: &Node, lane: usize) -> (u32, f32);
    /// [`Kernel::box_hits`]' bits on the packet's rays for a coherent packet (`p.coherent`):
    /// the near and far planes by the packet's common direction signs, one pair per axis for
    /// all lanes instead of a pick per lane; the same arithmetic, so the same bits.
    fn box_mask_coherent(p: &RayPacket, node: &Node, lane: usize) -> u32;
    /// The triangle (v0, e1, e2) against every lane with the intervals (t_min, t_max).
    fn triangle(
        lanes: &RayLanes,
        t_min: &[f32; PACKET],
        t_max: &[f32; PACKET],
        tri: &[Vec3; 3],
    ) -> LaneHits;
    /// The sphere (center, r² in f64) against every lane with the intervals (t_min, t_max):
    /// t per lane (b1 = b2 = 0, as [`crate::shapes::Primitive::intersect`] returns) and the hit
    /// bits ([`sphere_lanes`] compiled for the kernel's extension).
    fn sphere(
        lanes: &RayLanes,
        t_min: &[f32; PACKET],
        t_max: &[f32; PACKET],
        center: Vec3,
        r2: f64,
    ) -> LaneHits;
    /// The hits of primitive `prim` on the rays of `mask` that replace the best ones so far
    /// (`replaces`: closer, or as close with a smaller index); their t_max becomes next_up(t).
    /// Returns the rays whose best hit changed.
    fn take_closest(
        best: &mut PacketHits,
        t_max: &mut [f32; PACKET],
        hits: &LaneHits,
        mask: u32,
        prim: u32,
    ) -> u32;
    /// The lanes of `hits` (bit i: ray i hits primitive `prim` closer than `best.t[i]`) take
    /// that hit: t, prim, b1, b2 (the tiny-tree walk, whose t_max is `best.t`).
    fn take_nearer(best: &mut PacketHits, hits: &LaneHits, prim: u32);
    /// Largest element (no NaN).
    fn max(a: &[f32; PACKET]) -> f32;
}

/// [`Kernel::sphere`] in plain Rust on the lanes (`shapes::intersect_sphere_lane`), which the
/// compiler vectorises for the extension of the function it is inlined into (f64: four lanes
/// per AVX2 register, eight per AVX-512 one). The intrinsics kernels call it through functions
/// compiled for their extension (`avx2::sphere`, `avx512::sphere`): the walks test spheres out
/// of line (`Bvh::occluded_other`, `Bvh::intersect_other`, baseline code).
#[inline(always)]
fn sphere_lanes(
    lanes: &RayLanes,
    t_min: &[f32; PACKET],
    t_max: &[f32; PACKET],
    center: Vec3,
    r2: f64,
) -> LaneHits {
    let mut t = [0.0f32; PACKET];
    let mut hits = 0u32;
    for k in 0..PACKET {
        let o = Vec3::new(lanes.o[0][k], lanes.o[1][k], lanes.o[2][k]);
        let d = Vec3::new(lanes.d[0][k], lanes.d[1][k], lanes.d[2][k]);
        let (tk, hit) = intersect_sphere_lane(o, d, t_min[k], t_max[k], center, r2);
        t[k] = tk;
        hits |= (hit as u32) << k;
    }
    (t, [0.0; PACKET], [0.0; PACKET], hits)
}

/// Plain Rust, vectorised by the compiler for whatever the target has (SSE2 on x86-64).
pub(super) struct Portable;

/// Smallest (`MAX` = false) or largest element of a, by halving (elementwise operations the
/// compiler vectorises; a reduction loop would stay scalar). NaN-free inputs.
#[inline(always)]
fn reduce<const MAX: bool>(mut a: [f32; PACKET]) -> f32 {
    let mut w = PACKET;
    while w > 1 {
        w /= 2;
        for i in 0..w {
            let (x, y) = (a[i], a[i + w]);
            a[i] = if (x < y) ^ MAX { x } else { y };
        }
    }
    a[0]
}

impl Kernel for Portable {
    #[inline(always)]
    fn packet(lanes: &RayLanes, active: u32) -> RayPacket<'_> {
        let on: [bool; PACKET] = std::array::from_fn(|i| active >> i & 1 == 1);
        let (inf, ninf) = (f32::INFINITY, f32::NEG_INFINITY);
        let mut inv = [[0.0f32; PACKET]; 3];
        let mut axes = [(0.0, 0.0, 0.0, 0.0, 0u32); 3];
        let mut ordered = true;
        for a in 0..3 {
            let mut neg_bits = 0u32;
            let (mut o_lo, mut o_hi) = ([inf; PACKET], [ninf; PACKET]);
            let (mut i_lo, mut i_hi) = ([inf; PACKET], [ninf; PACKET]);
            for i in 0..PACKET {
                let o = lanes.o[a][i];
                let r = 1.0 / lanes.d[a][i];
                inv[a][i] = r;
                neg_bits |= ((on[i] & r.is_sign_negative()) as u32) << i;
                ordered &= !on[i] | !(o.is_nan() | r.is_nan());
                o_lo[i] = if on[i] { o } else { inf };
                o_hi[i] = if on[i] { o } else { ninf };
                i_lo[i] = if on[i] { r } else { inf };
                i_hi[i] = if on[i] { r } else { ninf };
            }
            axes[a] = (
                reduce::<false>(o_lo),
                reduce::<true>(o_hi),
                reduce::<false>(i_lo),
                reduce::<true>(i_hi),
                neg_bits,
            );
        }
        let mut t_min = [inf; PACKET];
        let mut t_max = [ninf; PACKET];
        for i in 0..PACKET {
            t_min[i] = if on[i] { lanes.t_min[i] } else { inf };
            t_max[i] = if on[i] { lanes.t_max[i] } else { ninf };
            ordered &= !on[i] | !(t_min[i].is_nan() | t_max[i].is_nan());
        }
        let t = (reduce::<false>(t_min), reduce::<true>(t_max));
        RayPacket::from_bounds(lanes, active, inv, t_min, t_max, axes, t, ordered)
    }

    #[inline(always)]
    fn box_hits(p: &RayPacket, node: &Node, lane: usize) -> (u32, f32) {
        let mut t0 = p.t_min;
        let mut t1 = p.t_max;
        for a in 0..3 {
            let (lo, hi) = (node.b[0][a][lane], node.b[1][a][lane]);
            for i in 0..PACKET {
                let (o, inv) = (p.lanes.o[a][i], p.inv[a][i]);
                let (nb, fb) = if inv.is_sign_negative() {
                    (hi, lo)
                } else {
                    (lo, hi)
                };
                let near = (nb - o) * inv;
                let far = (fb - o) * inv * FAR_SCALE;
                t0[i] = if near > t0[i] { near } else { t0[i] };
                t1[i] = if far < t1[i] { far } else { t1[i] };
            }
        }
        let mut mask = 0u32;
        let mut entries = [f32::INFINITY; PACKET];
        for i in 0..PACKET {
            let hit = t0[i] <= t1[i];
            mask |= (hit as u32) << i;
            // t0 is never NaN (it only takes values that compared greater).
            entries[i] = if hit { t0[i] } else { f32::INFINITY };
        }
        (mask, reduce::<false>(entries))
    }

    #[inline(always)]
    fn box_mask_coherent(p: &RayPacket, node: &Node, lane: usize) -> u32 {
        Self::box_hits(p, node, lane).0
    }

    #[inline(always)]
    fn triangle(
        lanes: &RayLanes,
        t_min: &[f32; PACKET],
        t_max: &[f32; PACKET],
        &[v0, e1, e2]: &[Vec3; 3],
    ) -> LaneHits {
        let (mut t, mut b1, mut b2) = ([0.0f32; PACKET], [0.0f32; PACKET], [0.0f32; PACKET]);
        let mut hits = 0u32;
        for k in 0..PACKET {
            let o = Vec3::new(lanes.o[0][k], lanes.o[1][k], lanes.o[2][k]);
            let d = Vec3::new(lanes.d[0][k], lanes.d[1][k], lanes.d[2][k]);
            let (tk, u, v, hit) = intersect_triangle_lane(o, d, t_min[k], t_max[k], v0, e1, e2);
            (t[k], b1[k], b2[k]) = (tk, u, v);
            hits |= (hit as u32) << k;
        }
        (t, b1, b2, hits)
    }

    #[inline(always)]
    fn sphere(
        lanes: &RayLanes,
        t_min: &[f32; PACKET],
        t_max: &[f32; PACKET],
        center: Vec3,
        r2: f64,
    ) -> LaneHits {
        sphere_lanes(lanes, t_min, t_max, center, r2)
    }

    #[inline(always)]
    fn take_closest(
        best: &mut PacketHits,
        t_max: &mut [f32; PACKET],
        (t, b1, b2, hits): &LaneHits,
        mask: u32,
        prim: u32,
    ) -> u32 {
        let hits = hits & mask;
        let mut took = 0u32;
        for k in 0..PACKET {
            let take = (hits >> k & 1 == 1) & replaces(t[k], prim, best.t[k], best.prim[k]);
            best.t[k] = if take { t[k] } else { best.t[k] };
            best.prim[k] = if take { prim } else { best.prim[k] };
            best.b1[k] = if take { b1[k] } else { best.b1[k] };
            best.b2[k] = if take { b2[k] } else { best.b2[k] };
            t_max[k] = if take { t[k].next_up() } else { t_max[k] };
            took |= (take as u32) << k;
        }
        took
    }

    #[inline(always)]
    fn take_nearer(best: &mut PacketHits, (t, b1, b2, hits): &LaneHits, prim: u32) {
        for k in 0..PACKET {
            let hit = hits >> k & 1 == 1;
            best.t[k] = if hit { t[k] } else { best.t[k] };
            best.prim[k] = if hit { prim } else { best.prim[k] };
            best.b1[k] = if hit { b1[k] } else { best.b1[k] };
            best.b2[k] = if hit { b2[k] } else { best.b2[k] };
        }
    }

    #[inline(always)]
    fn max(a: &[f32; PACKET]) -> f32 {
        reduce::<true>(*a)
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx2, Avx512};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    /// Slot of the fourteen packet bounds in the vectors the set-up reduces: per axis the
    /// smallest origin, −(largest origin), smallest 1/d, −(largest 1/d); then the smallest
    /// t_min and −(largest t_max). (Largest values as the negated smallest of the negated: one
    /// kind of reduction for all.)
    const T_SLOT: usize = 12;

    /// The packet's interval part from the fourteen minima `m` (by slot, see [`T_SLOT`]).
    #[inline(always)]
    fn bounds(m: impl Fn(usize) -> f32, neg: [u32; 3]) -> ([AxisBounds; 3], (f32, f32)) {
        let axes =
            std::array::from_fn(|a| (m(4 * a), -m(4 * a + 1), m(4 * a + 2), -m(4 * a + 3), neg[a]));
        (axes, (m(T_SLOT), -m(T_SLOT + 1)))
    }

    /// Intel AVX-512 (F, VL, DQ, BW): a packet is one register per component.
    pub(in crate::bvh) struct Avx512;

    /// AVX2 + FMA (FMA unused: the lane arithmetic must round like the scalar code): a packet
    /// is two 8-lane registers per component.
    pub(in crate::bvh) struct Avx2;

    /// `impl Kernel for $kernel`: `inline(always)` wrappers of the functions of module `$m`,
    /// compiled for the kernel's extension: once inlined into `Bvh::*_lanes`' instantiation for
    /// that extension the intrinsics inline too.
    macro_rules! forward_kernel {
        ($kernel:ident, $m:ident) => {
            impl Kernel for $kernel {
                #[inline(always)]
                fn packet(lanes: &RayLanes, active: u32) -> RayPacket<'_> {
                    // SAFETY (every method): called only from the walks compiled for the
                    // kernel's extension after detection (`Bvh::occluded_lanes`,
                    // `Bvh::intersect_lanes`).
                    unsafe { $m::packet(lanes, active) }
                }
                #[inline(always)]
                fn box_hits(p: &RayPacket, node: &Node, lane: usize) -> (u32, f32) {
                    unsafe { $m::box_hits(p, node, lane) }
                }
                #[inline(always)]
                fn box_mask_coherent(p: &RayPacket, node: &Node, lane: usize) -> u32 {
                    unsafe { $m::box_mask_coherent(p, node, lane) }
                }
                #[inline(always)]
                fn triangle(
                    lanes: &RayLanes,
                    t_min: &[f32; PACKET],
                    t_max: &[f32; PACKET],
                    tri: &[Vec3; 3],
                ) -> LaneHits {
                    unsafe { $m::triangle(lanes, t_min, t_max, tri) }
                }
                #[inline(always)]
                fn sphere(
                    lanes: &RayLanes,
                    t_min: &[f32; PACKET],
                    t_max: &[f32; PACKET],
                    center: Vec3,
                    r2: f64,
                ) -> LaneHits {
                    unsafe { $m::sphere(lanes, t_min, t_max, center, r2) }
                }
                #[inline(always)]
                fn take_closest(
                    best: &mut PacketHits,
                    t_max: &mut [f32; PACKET],
                    hits: &LaneHits,
                    mask: u32,
                    prim: u32,
                ) -> u32 {
                    unsafe { $m::take_closest(best, t_max, hits, mask, prim) }
                }
                #[inline(always)]
                fn take_nearer(best: &mut PacketHits, hits: &LaneHits, prim: u32) {
                    unsafe { $m::take_nearer(best, hits, prim) }
                }
                #[inline(always)]
                fn max(a: &[f32; PACKET]) -> f32 {
                    unsafe { $m::max(a) }
                }
            }
        };
    }

    forward_kernel!(Avx512, avx512);
    forward_kernel!(Avx2, avx2);

    mod avx512 {
        use super::*;

        type V = __m512;

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        fn ld(a: &[f32; PACKET]) -> V {
            // SAFETY: 16 floats.
            unsafe { _mm512_loadu_ps(a.as_ptr()) }
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        fn arr(v: V) -> [f32; PACKET] {
            // SAFETY: same size, every bit pattern valid.
            unsafe { std::mem::transmute::<V, [f32; PACKET]>(v) }
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        fn splat(x: f32) -> V {
            _mm512_set1_ps(x)
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        fn negate(x: V) -> V {
            _mm512_xor_ps(x, splat(-0.0))
        }

        /// a·b + c·d + e·f summed left to right, as `Vec3::dot` (no FMA).
        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        #[allow(clippy::too_many_arguments)]
        fn dot(a: V, b: V, c: V, d: V, e: V, f: V) -> V {
            _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(a, b), _mm512_mul_ps(c, d)),
                _mm512_mul_ps(e, f),
            )
        }

        /// a·b − c·d, one component of `Vec3::cross`.
        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        fn cross1(a: V, b: V, c: V, d: V) -> V {
            _mm512_sub_ps(_mm512_mul_ps(a, b), _mm512_mul_ps(c, d))
        }

        /// Smallest element of each of 16 vectors at once (a transposing butterfly: 15
        /// minima, 30 shuffles): element 4(s mod 4) + s/4 of the result is the minimum of v[s].
        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        fn min16(v: [V; 16]) -> [f32; PACKET] {
            // v[2j] in 128-bit blocks 0–1, v[2j+1] in 2–3, each folded in half.
            let c: [V; 8] = std::array::from_fn(|j| {
                let (a, b) = (v[2 * j], v[2 * j + 1]);
                _mm512_min_ps(
                    _mm512_shuffle_f32x4::<0b01_00_01_00>(a, b),
                    _mm512_shuffle_f32x4::<0b11_10_11_10>(a, b),
                )
            });
            // Block q of e[j]: v[4j + q], four partial minima.
            let e: [V; 4] = std::array::from_fn(|j| {
                let (a, b) = (c[2 * j], c[2 * j + 1]);
                _mm512_min_ps(
                    _mm512_shuffle_f32x4::<0b10_00_10_00>(a, b),
                    _mm512_shuffle_f32x4::<0b11_01_11_01>(a, b),
                )
            });
            // Block q of g[j]: two partial minima of v[8j + q], then two of v[8j + 4 + q].
            let g: [V; 2] = std::array::from_fn(|j| {
                let (a, b) = (e[2 * j], e[2 * j + 1]);
                _mm512_min_ps(
                    _mm512_shuffle_ps::<0b01_00_01_00>(a, b),
                    _mm512_shuffle_ps::<0b11_10_11_10>(a, b),
                )
            });
            // Block q: the minima of v[q], v[4 + q], v[8 + q], v[12 + q].
            arr(_mm512_min_ps(
                _mm512_shuffle_ps::<0b10_00_10_00>(g[0], g[1]),
                _mm512_shuffle_ps::<0b11_01_11_01>(g[0], g[1]),
            ))
        }

        /// Smallest element of v.
        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        fn hmin(v: V) -> f32 {
            let m = _mm256_min_ps(_mm512_castps512_ps256(v), _mm512_extractf32x8_ps::<1>(v));
            let m = _mm_min_ps(_mm256_castps256_ps128(m), _mm256_extractf128_ps::<1>(m));
            let m = _mm_min_ps(m, _mm_movehl_ps(m, m));
            _mm_cvtss_f32(_mm_min_ss(m, _mm_movehdup_ps(m)))
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn packet(lanes: &RayLanes, active: u32) -> RayPacket<'_> {
            let on = active as __mmask16;
            let inf = splat(f32::INFINITY);
            let mut ordered = on;
            let mut inv = [inf; 3];
            let mut neg = [0u32; 3];
            for a in 0..3 {
                let o = ld(&lanes.o[a]);
                let r = _mm512_div_ps(splat(1.0), ld(&lanes.d[a]));
                inv[a] = r;
                neg[a] = (_mm512_movepi32_mask(_mm512_castps_si512(r)) & on) as u32;
                ordered &= _mm512_cmp_ps_mask::<_CMP_ORD_Q>(o, r);
            }
            let t_min = _mm512_mask_mov_ps(inf, on, ld(&lanes.t_min));
            let t_max = _mm512_mask_mov_ps(negate(inf), on, ld(&lanes.t_max));
            ordered &= _mm512_cmp_ps_mask::<_CMP_ORD_Q>(t_min, t_max);
            // SAFETY: same size, every bit pattern valid.
            let inv_lanes = unsafe { std::mem::transmute::<[V; 3], [[f32; PACKET]; 3]>(inv) };
            if (ordered != on) | !RayPacket::one_sign_per_axis(neg, active) {
                // Tested ray by ray: the bounds are not needed.
                return RayPacket::incoherent(lanes, inv_lanes, arr(t_min), arr(t_max));
            }
            let mut red = [inf; 16];
            for a in 0..3 {
                let (o, r) = (ld(&lanes.o[a]), inv[a]);
                red[4 * a] = _mm512_mask_mov_ps(inf, on, o);
                red[4 * a + 1] = _mm512_mask_mov_ps(inf, on, negate(o));
                red[4 * a + 2] = _mm512_mask_mov_ps(inf, on, r);
                red[4 * a + 3] = _mm512_mask_mov_ps(inf, on, negate(r));
            }
            red[T_SLOT] = t_min;
            red[T_SLOT + 1] = negate(t_max);
            let m = min16(red);
            let (axes, t) = bounds(|s| m[4 * (s % 4) + s / 4], neg);
            let inv = inv_lanes;
            RayPacket::from_bounds(lanes, active, inv, arr(t_min), arr(t_max), axes, t, true)
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn box_hits(p: &RayPacket, node: &Node, lane: usize) -> (u32, f32) {
            let mut t0 = ld(&p.t_min);
            let mut t1 = ld(&p.t_max);
            for a in 0..3 {
                let (lo, hi) = (splat(node.b[0][a][lane]), splat(node.b[1][a][lane]));
                let (o, inv) = (ld(&p.lanes.o[a]), ld(&p.inv[a]));
                let neg = _mm512_movepi32_mask(_mm512_castps_si512(inv));
                let near_plane = _mm512_mask_blend_ps(neg, lo, hi);
                let far_plane = _mm512_mask_blend_ps(neg, hi, lo);
                let near = _mm512_mul_ps(_mm512_sub_ps(near_plane, o), inv);
                let far = _mm512_mul_ps(
                    _mm512_mul_ps(_mm512_sub_ps(far_plane, o), inv),
                    splat(FAR_SCALE),
                );
                // near > t0 ? near : t0 (a NaN near leaves t0), and likewise for t1.
                t0 = _mm512_max_ps(near, t0);
                t1 = _mm512_min_ps(far, t1);
            }
            let hit = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(t0, t1);
            let entry = hmin(_mm512_mask_mov_ps(splat(f32::INFINITY), hit, t0));
            (hit as u32, entry)
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn box_mask_coherent(p: &RayPacket, node: &Node, lane: usize) -> u32 {
            let mut t0 = ld(&p.t_min);
            let mut t1 = ld(&p.t_max);
            for a in 0..3 {
                let s = p.sign[a] & 1;
                let near_plane = splat(node.b[s][a][lane]);
                let far_plane = splat(node.b[s ^ 1][a][lane]);
                let (o, inv) = (ld(&p.lanes.o[a]), ld(&p.inv[a]));
                let near = _mm512_mul_ps(_mm512_sub_ps(near_plane, o), inv);
                let far = _mm512_mul_ps(
                    _mm512_mul_ps(_mm512_sub_ps(far_plane, o), inv),
                    splat(FAR_SCALE),
                );
                t0 = _mm512_max_ps(near, t0);
                t1 = _mm512_min_ps(far, t1);
            }
            _mm512_cmp_ps_mask::<_CMP_LE_OQ>(t0, t1) as u32
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn triangle(
            lanes: &RayLanes,
            t_min: &[f32; PACKET],
            t_max: &[f32; PACKET],
            &[v0, e1, e2]: &[Vec3; 3],
        ) -> LaneHits {
            let (ox, oy, oz) = (ld(&lanes.o[0]), ld(&lanes.o[1]), ld(&lanes.o[2]));
            let (dx, dy, dz) = (ld(&lanes.d[0]), ld(&lanes.d[1]), ld(&lanes.d[2]));
            let (e1x, e1y, e1z) = (splat(e1.x), splat(e1.y), splat(e1.z));
            let (e2x, e2y, e2z) = (splat(e2.x), splat(e2.y), splat(e2.z));
            // The operations of `intersect_triangle_lane` (glam's cross and dot), in order.
            let (px, py, pz) = (
                cross1(dy, e2z, e2y, dz),
                cross1(dz, e2x, e2z, dx),
                cross1(dx, e2y, e2x, dy),
            );
            let det = dot(e1x, px, e1y, py, e1z, pz);
            let inv = _mm512_div_ps(splat(1.0), det);
            let (tx, ty, tz) = (
                _mm512_sub_ps(ox, splat(v0.x)),
                _mm512_sub_ps(oy, splat(v0.y)),
                _mm512_sub_ps(oz, splat(v0.z)),
            );
            let b1 = _mm512_mul_ps(dot(tx, px, ty, py, tz, pz), inv);
            let (qx, qy, qz) = (
                cross1(ty, e1z, e1y, tz),
                cross1(tz, e1x, e1z, tx),
                cross1(tx, e1y, e1x, ty),
            );
            let b2 = _mm512_mul_ps(dot(dx, qx, dy, qy, dz, qz), inv);
            let t = _mm512_mul_ps(dot(e2x, qx, e2y, qy, e2z, qz), inv);
            let (zero, one) = (_mm512_setzero_ps(), splat(1.0));
            // det ≠ 0 and finite, b1 ∈ [0, 1], b2 ≥ 0, b1 + b2 ≤ 1, t_min < t < t_max.
            let abs_det = _mm512_andnot_ps(splat(-0.0), det);
            let m = _mm512_cmp_ps_mask::<_CMP_NEQ_OQ>(det, zero);
            let m = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(m, abs_det, splat(f32::INFINITY));
            let m = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(m, b1, zero);
            let m = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(m, b1, one);
            let m = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(m, b2, zero);
            let m = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(m, _mm512_add_ps(b1, b2), one);
            let m = _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(m, t, ld(t_min));
            let m = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(m, t, ld(t_max));
            (arr(t), arr(b1), arr(b2), m as u32)
        }

        /// Out of line, compiled for this extension (see [`sphere_lanes`]).
        #[inline(never)]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn sphere(
            lanes: &RayLanes,
            t_min: &[f32; PACKET],
            t_max: &[f32; PACKET],
            center: Vec3,
            r2: f64,
        ) -> LaneHits {
            sphere_lanes(lanes, t_min, t_max, center, r2)
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn take_closest(
            best: &mut PacketHits,
            t_max: &mut [f32; PACKET],
            (t, b1, b2, hits): &LaneHits,
            mask: u32,
            prim: u32,
        ) -> u32 {
            let hits = (hits & mask) as __mmask16;
            if hits == 0 {
                return 0;
            }
            let t = ld(t);
            let best_t = ld(&best.t);
            // SAFETY: 16 u32 in each.
            let best_prim = unsafe { _mm512_loadu_si512(best.prim.as_ptr().cast()) };
            let i = _mm512_set1_epi32(prim as i32);
            // `replaces`: closer, or as close with a smaller index (u32::MAX, no hit yet, is
            // larger than every index).
            let take = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(hits, t, best_t)
                | _mm512_mask_cmplt_epu32_mask(hits, i, best_prim);
            // next_up(t) of a finite t: ±0 → the smallest subnormal, else one ulp up.
            let bits = _mm512_castps_si512(t);
            let up = _mm512_mask_blend_epi32(
                _mm512_cmpgt_epi32_mask(bits, _mm512_setzero_si512()),
                _mm512_sub_epi32(bits, _mm512_set1_epi32(1)),
                _mm512_add_epi32(bits, _mm512_set1_epi32(1)),
            );
            let zero = _mm512_testn_epi32_mask(bits, _mm512_set1_epi32(i32::MAX));
            let up = _mm512_mask_mov_epi32(up, zero, _mm512_set1_epi32(1));
            // Whole-register stores (blends), not masked ones: a masked store does not forward
            // to the next triangle's whole-register load of t_max (a stall per update).
            // SAFETY: 16 lanes in each array.
            unsafe {
                _mm512_storeu_ps(best.t.as_mut_ptr(), _mm512_mask_mov_ps(best_t, take, t));
                let p = _mm512_mask_mov_epi32(best_prim, take, i);
                _mm512_storeu_si512(best.prim.as_mut_ptr().cast(), p);
                let b = _mm512_mask_mov_ps(ld(&best.b1), take, ld(b1));
                _mm512_storeu_ps(best.b1.as_mut_ptr(), b);
                let b = _mm512_mask_mov_ps(ld(&best.b2), take, ld(b2));
                _mm512_storeu_ps(best.b2.as_mut_ptr(), b);
                let up = _mm512_mask_mov_ps(ld(t_max), take, _mm512_castsi512_ps(up));
                _mm512_storeu_ps(t_max.as_mut_ptr(), up);
            }
            take as u32
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn take_nearer(best: &mut PacketHits, (t, b1, b2, hits): &LaneHits, prim: u32) {
            let take = *hits as __mmask16;
            // SAFETY: 16 lanes in each array.
            unsafe {
                _mm512_storeu_ps(
                    best.t.as_mut_ptr(),
                    _mm512_mask_mov_ps(ld(&best.t), take, ld(t)),
                );
                let old = _mm512_loadu_si512(best.prim.as_ptr().cast());
                let p = _mm512_mask_mov_epi32(old, take, _mm512_set1_epi32(prim as i32));
                _mm512_storeu_si512(best.prim.as_mut_ptr().cast(), p);
                let b = _mm512_mask_mov_ps(ld(&best.b1), take, ld(b1));
                _mm512_storeu_ps(best.b1.as_mut_ptr(), b);
                let b = _mm512_mask_mov_ps(ld(&best.b2), take, ld(b2));
                _mm512_storeu_ps(best.b2.as_mut_ptr(), b);
            }
        }

        #[inline]
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        pub(super) fn max(a: &[f32; PACKET]) -> f32 {
            -hmin(negate(ld(a)))
        }
    }

    mod avx2 {
        use super::*;

        type V = __m256;

        /// Lanes h·8 .. h·8 + 8 of a.
        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn ld(a: &[f32; PACKET], h: usize) -> V {
            // SAFETY: h ∈ {0, 1}, 8 floats from 8h.
            unsafe { _mm256_loadu_ps(a.as_ptr().add(8 * h)) }
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn arr(v: [V; 2]) -> [f32; PACKET] {
            // SAFETY: same size, every bit pattern valid.
            unsafe { std::mem::transmute::<[V; 2], [f32; PACKET]>(v) }
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn splat(x: f32) -> V {
            _mm256_set1_ps(x)
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn negate(x: V) -> V {
            _mm256_xor_ps(x, splat(-0.0))
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn flip_all() -> __m256i {
            _mm256_set1_epi32(-1)
        }

        /// Bits of the sign of every lane.
        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn bits(m: V) -> u32 {
            _mm256_movemask_ps(m) as u32
        }

        /// Lane k of half h: all ones iff bit 8h + k of `mask` is set.
        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn lane_mask(mask: u32, h: usize) -> V {
            let b = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let m = _mm256_and_si256(_mm256_set1_epi32((mask >> (8 * h)) as i32), b);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(m, b))
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        #[allow(clippy::too_many_arguments)]
        fn dot(a: V, b: V, c: V, d: V, e: V, f: V) -> V {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(a, b), _mm256_mul_ps(c, d)),
                _mm256_mul_ps(e, f),
            )
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn cross1(a: V, b: V, c: V, d: V) -> V {
            _mm256_sub_ps(_mm256_mul_ps(a, b), _mm256_mul_ps(c, d))
        }

        /// Smallest element of each of 16 vectors at once (a transposing butterfly, 15
        /// minima): element 8(s / 8) + 4(s mod 2) + (s mod 8) / 2 of the result is the
        /// minimum of v[s].
        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn min16(v: [V; 16]) -> [f32; PACKET] {
            // Half h of c[j]: v[2j + h], four partial minima.
            let c: [V; 8] = std::array::from_fn(|j| {
                let (a, b) = (v[2 * j], v[2 * j + 1]);
                _mm256_min_ps(
                    _mm256_permute2f128_ps::<0x20>(a, b),
                    _mm256_permute2f128_ps::<0x31>(a, b),
                )
            });
            // Half h of e[j]: two partial minima of v[4j + h], then two of v[4j + 2 + h].
            let e: [V; 4] = std::array::from_fn(|j| {
                let (a, b) = (c[2 * j], c[2 * j + 1]);
                _mm256_min_ps(
                    _mm256_shuffle_ps::<0b01_00_01_00>(a, b),
                    _mm256_shuffle_ps::<0b11_10_11_10>(a, b),
                )
            });
            // Half h of g[m]: the minima of v[8m + h], v[8m + 2 + h], v[8m + 4 + h],
            // v[8m + 6 + h].
            let g: [V; 2] = std::array::from_fn(|m| {
                let (a, b) = (e[2 * m], e[2 * m + 1]);
                _mm256_min_ps(
                    _mm256_shuffle_ps::<0b10_00_10_00>(a, b),
                    _mm256_shuffle_ps::<0b11_01_11_01>(a, b),
                )
            });
            arr(g)
        }

        /// Smallest element of v.
        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn hmin(v: V) -> f32 {
            let m = _mm_min_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
            let m = _mm_min_ps(m, _mm_movehl_ps(m, m));
            _mm_cvtss_f32(_mm_min_ss(m, _mm_movehdup_ps(m)))
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn packet(lanes: &RayLanes, active: u32) -> RayPacket<'_> {
            let inf = splat(f32::INFINITY);
            let on = [lane_mask(active, 0), lane_mask(active, 1)];
            let mut unordered = 0u32;
            let mut inv = [[inf; 2]; 3];
            let mut neg = [0u32; 3];
            for a in 0..3 {
                for (h, inv) in inv[a].iter_mut().enumerate() {
                    let o = ld(&lanes.o[a], h);
                    let r = _mm256_div_ps(splat(1.0), ld(&lanes.d[a], h));
                    *inv = r;
                    neg[a] |= bits(r) << (8 * h);
                    unordered |= bits(_mm256_cmp_ps::<_CMP_UNORD_Q>(o, r)) << (8 * h);
                }
                neg[a] &= active;
            }
            let mut t_min = [inf; 2];
            let mut t_max = [inf; 2];
            for h in 0..2 {
                t_min[h] = _mm256_blendv_ps(inf, ld(&lanes.t_min, h), on[h]);
                t_max[h] = _mm256_blendv_ps(negate(inf), ld(&lanes.t_max, h), on[h]);
                unordered |= bits(_mm256_cmp_ps::<_CMP_UNORD_Q>(t_min[h], t_max[h])) << (8 * h);
            }
            // SAFETY: same size, every bit pattern valid.
            let inv_lanes = unsafe { std::mem::transmute::<[[V; 2]; 3], [[f32; PACKET]; 3]>(inv) };
            if (unordered & active != 0) | !RayPacket::one_sign_per_axis(neg, active) {
                // Tested ray by ray: the bounds are not needed.
                return RayPacket::incoherent(lanes, inv_lanes, arr(t_min), arr(t_max));
            }
            let mut red = [inf; 16];
            for a in 0..3 {
                let mut lo = [inf; 4];
                for h in 0..2 {
                    let (o, r) = (ld(&lanes.o[a], h), inv[a][h]);
                    // Outside the packet: +∞ (blendv takes the second operand where the
                    // mask's sign bit is set).
                    let v = [o, negate(o), r, negate(r)];
                    for (l, x) in lo.iter_mut().zip(v) {
                        let x = _mm256_blendv_ps(inf, x, on[h]);
                        *l = if h == 0 { x } else { _mm256_min_ps(*l, x) };
                    }
                }
                red[4 * a..4 * a + 4].copy_from_slice(&lo);
            }
            red[T_SLOT] = _mm256_min_ps(t_min[0], t_min[1]);
            red[T_SLOT + 1] = _mm256_min_ps(negate(t_max[0]), negate(t_max[1]));
            let m = min16(red);
            let (axes, t) = bounds(|s| m[8 * (s / 8) + 4 * (s % 2) + (s % 8) / 2], neg);
            let inv = inv_lanes;
            RayPacket::from_bounds(lanes, active, inv, arr(t_min), arr(t_max), axes, t, true)
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn box_hits(p: &RayPacket, node: &Node, lane: usize) -> (u32, f32) {
            let mut mask = 0u32;
            let mut entry = splat(f32::INFINITY);
            for h in 0..2 {
                let mut t0 = ld(&p.t_min, h);
                let mut t1 = ld(&p.t_max, h);
                for a in 0..3 {
                    let (lo, hi) = (splat(node.b[0][a][lane]), splat(node.b[1][a][lane]));
                    let (o, inv) = (ld(&p.lanes.o[a], h), ld(&p.inv[a], h));
                    // The sign bit of 1/d picks the planes.
                    let near_plane = _mm256_blendv_ps(lo, hi, inv);
                    let far_plane = _mm256_blendv_ps(hi, lo, inv);
                    let near = _mm256_mul_ps(_mm256_sub_ps(near_plane, o), inv);
                    let far = _mm256_mul_ps(
                        _mm256_mul_ps(_mm256_sub_ps(far_plane, o), inv),
                        splat(FAR_SCALE),
                    );
                    // near > t0 ? near : t0 (a NaN near leaves t0), and likewise for t1.
                    t0 = _mm256_max_ps(near, t0);
                    t1 = _mm256_min_ps(far, t1);
                }
                let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1);
                mask |= bits(hit) << (8 * h);
                entry = _mm256_min_ps(entry, _mm256_blendv_ps(splat(f32::INFINITY), t0, hit));
            }
            (mask, hmin(entry))
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn box_mask_coherent(p: &RayPacket, node: &Node, lane: usize) -> u32 {
            let mut mask = 0u32;
            for h in 0..2 {
                let mut t0 = ld(&p.t_min, h);
                let mut t1 = ld(&p.t_max, h);
                for a in 0..3 {
                    let s = p.sign[a] & 1;
                    let near_plane = splat(node.b[s][a][lane]);
                    let far_plane = splat(node.b[s ^ 1][a][lane]);
                    let (o, inv) = (ld(&p.lanes.o[a], h), ld(&p.inv[a], h));
                    let near = _mm256_mul_ps(_mm256_sub_ps(near_plane, o), inv);
                    let far = _mm256_mul_ps(
                        _mm256_mul_ps(_mm256_sub_ps(far_plane, o), inv),
                        splat(FAR_SCALE),
                    );
                    t0 = _mm256_max_ps(near, t0);
                    t1 = _mm256_min_ps(far, t1);
                }
                mask |= bits(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) << (8 * h);
            }
            mask
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn triangle(
            lanes: &RayLanes,
            t_min: &[f32; PACKET],
            t_max: &[f32; PACKET],
            &[v0, e1, e2]: &[Vec3; 3],
        ) -> LaneHits {
            let (e1x, e1y, e1z) = (splat(e1.x), splat(e1.y), splat(e1.z));
            let (e2x, e2y, e2z) = (splat(e2.x), splat(e2.y), splat(e2.z));
            let (zero, one) = (_mm256_setzero_ps(), splat(1.0));
            let (mut t, mut b1, mut b2) = ([zero; 2], [zero; 2], [zero; 2]);
            let mut hits = 0u32;
            for h in 0..2 {
                let (ox, oy, oz) = (ld(&lanes.o[0], h), ld(&lanes.o[1], h), ld(&lanes.o[2], h));
                let (dx, dy, dz) = (ld(&lanes.d[0], h), ld(&lanes.d[1], h), ld(&lanes.d[2], h));
                // The operations of `intersect_triangle_lane` (glam's cross and dot), in order.
                let (px, py, pz) = (
                    cross1(dy, e2z, e2y, dz),
                    cross1(dz, e2x, e2z, dx),
                    cross1(dx, e2y, e2x, dy),
                );
                let det = dot(e1x, px, e1y, py, e1z, pz);
                let inv = _mm256_div_ps(one, det);
                let (tx, ty, tz) = (
                    _mm256_sub_ps(ox, splat(v0.x)),
                    _mm256_sub_ps(oy, splat(v0.y)),
                    _mm256_sub_ps(oz, splat(v0.z)),
                );
                let u = _mm256_mul_ps(dot(tx, px, ty, py, tz, pz), inv);
                let (qx, qy, qz) = (
                    cross1(ty, e1z, e1y, tz),
                    cross1(tz, e1x, e1z, tx),
                    cross1(tx, e1y, e1x, ty),
                );
                let v = _mm256_mul_ps(dot(dx, qx, dy, qy, dz, qz), inv);
                let d = _mm256_mul_ps(dot(e2x, qx, e2y, qy, e2z, qz), inv);
                // det ≠ 0 and finite, b1 ∈ [0, 1], b2 ≥ 0, b1 + b2 ≤ 1, t_min < t < t_max.
                let abs_det = _mm256_andnot_ps(splat(-0.0), det);
                let c = [
                    _mm256_cmp_ps::<_CMP_NEQ_OQ>(det, zero),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(abs_det, splat(f32::INFINITY)),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero),
                    _mm256_cmp_ps::<_CMP_LE_OQ>(u, one),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero),
                    _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_add_ps(u, v), one),
                    _mm256_cmp_ps::<_CMP_GT_OQ>(d, ld(t_min, h)),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(d, ld(t_max, h)),
                ];
                let all = c.into_iter().reduce(|x, y| _mm256_and_ps(x, y));
                hits |= bits(all.unwrap_or(zero)) << (8 * h);
                (t[h], b1[h], b2[h]) = (d, u, v);
            }
            (arr(t), arr(b1), arr(b2), hits)
        }

        /// Out of line, compiled for this extension (see [`sphere_lanes`]).
        #[inline(never)]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn sphere(
            lanes: &RayLanes,
            t_min: &[f32; PACKET],
            t_max: &[f32; PACKET],
            center: Vec3,
            r2: f64,
        ) -> LaneHits {
            sphere_lanes(lanes, t_min, t_max, center, r2)
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn take_closest(
            best: &mut PacketHits,
            t_max: &mut [f32; PACKET],
            (t, b1, b2, hits): &LaneHits,
            mask: u32,
            prim: u32,
        ) -> u32 {
            let hits = hits & mask;
            if hits == 0 {
                return 0;
            }
            let mut took = 0u32;
            let flip = _mm256_set1_epi32(i32::MIN);
            let i = _mm256_set1_epi32(prim as i32);
            for h in 0..2 {
                let ti = ld(t, h);
                let best_t = ld(&best.t, h);
                // SAFETY: 8 u32 from 8h.
                let best_prim = unsafe { _mm256_loadu_si256(best.prim.as_ptr().add(8 * h).cast()) };
                // `replaces`: closer, or as close with a smaller index (u32::MAX, no hit yet,
                // is larger than every index; unsigned comparison as signed with the sign
                // bits flipped).
                let smaller = _mm256_cmpgt_epi32(
                    _mm256_xor_si256(best_prim, flip),
                    _mm256_xor_si256(i, flip),
                );
                let closer = _mm256_cmp_ps::<_CMP_LT_OQ>(ti, best_t);
                let take = _mm256_and_ps(
                    _mm256_or_ps(closer, _mm256_castsi256_ps(smaller)),
                    lane_mask(hits, h),
                );
                // next_up(t) of a finite t: ±0 → the smallest subnormal, else one ulp up.
                let bits_t = _mm256_castps_si256(ti);
                let pos = _mm256_cmpgt_epi32(bits_t, _mm256_setzero_si256());
                // bits + 1 where positive, bits − 1 elsewhere: pos is −1 or 0, !pos | 1 is 1 or −1.
                let step = _mm256_or_si256(_mm256_set1_epi32(1), _mm256_xor_si256(pos, flip_all()));
                let up = _mm256_add_epi32(bits_t, step);
                let zero = _mm256_cmpeq_epi32(
                    _mm256_and_si256(bits_t, _mm256_set1_epi32(i32::MAX)),
                    _mm256_setzero_si256(),
                );
                let up = _mm256_blendv_epi8(up, _mm256_set1_epi32(1), zero);
                let take_i = _mm256_castps_si256(take);
                // SAFETY: 8 lanes from 8h in each array.
                unsafe {
                    let at = |a: &mut [f32; PACKET]| a.as_mut_ptr().add(8 * h);
                    _mm256_storeu_ps(at(&mut best.t), _mm256_blendv_ps(best_t, ti, take));
                    let p = _mm256_blendv_epi8(best_prim, i, take_i);
                    _mm256_storeu_si256(best.prim.as_mut_ptr().add(8 * h).cast(), p);
                    let old = ld(&best.b1, h);
                    _mm256_storeu_ps(at(&mut best.b1), _mm256_blendv_ps(old, ld(b1, h), take));
                    let old = ld(&best.b2, h);
                    _mm256_storeu_ps(at(&mut best.b2), _mm256_blendv_ps(old, ld(b2, h), take));
                    let old = ld(t_max, h);
                    let new = _mm256_blendv_ps(old, _mm256_castsi256_ps(up), take);
                    _mm256_storeu_ps(at(t_max), new);
                }
                took |= bits(take) << (8 * h);
            }
            took
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn take_nearer(best: &mut PacketHits, (t, b1, b2, hits): &LaneHits, prim: u32) {
            let i = _mm256_set1_ps(f32::from_bits(prim));
            for h in 0..2 {
                let take = lane_mask(*hits, h);
                let pick = |old: &[f32; PACKET], new: V| _mm256_blendv_ps(ld(old, h), new, take);
                let (nt, n1, n2) = (
                    pick(&best.t, ld(t, h)),
                    pick(&best.b1, ld(b1, h)),
                    pick(&best.b2, ld(b2, h)),
                );
                // SAFETY: 8 u32 from 8h.
                let old_prim = unsafe { _mm256_loadu_ps(best.prim.as_ptr().add(8 * h).cast()) };
                let np = _mm256_blendv_ps(old_prim, i, take);
                // SAFETY: 8 lanes from 8h in each array.
                unsafe {
                    _mm256_storeu_ps(best.t.as_mut_ptr().add(8 * h), nt);
                    _mm256_storeu_ps(best.b1.as_mut_ptr().add(8 * h), n1);
                    _mm256_storeu_ps(best.b2.as_mut_ptr().add(8 * h), n2);
                    _mm256_storeu_ps(best.prim.as_mut_ptr().add(8 * h).cast(), np);
                }
            }
        }

        #[inline]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        pub(super) fn max(a: &[f32; PACKET]) -> f32 {
            -hmin(_mm256_min_ps(negate(ld(a, 0)), negate(ld(a, 1))))
        }
    }
}

#[cfg(test)]
mod tests {
    /// `$check::<K>()` for each vector kernel this CPU runs (AVX-512, AVX2 + FMA), each call
    /// compiled with its kernel's target features.
    macro_rules! on_every_vector_kernel {
        ($check:ident) => {
            #[cfg(target_arch = "x86_64")]
            {
                use linlight_simd::Isa;
                if Isa::Avx512.supported() {
                    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                    unsafe fn run() {
                        $check::<Avx512>();
                    }
                    // SAFETY: detected above.
                    unsafe { run() };
                }
                if Isa::Avx2.supported() {
                    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                    unsafe fn run() {
                        $check::<Avx2>();
                    }
                    // SAFETY: detected above.
                    unsafe { run() };
                }
            }
        };
    }
    use super::*;
    use crate::shapes::{intersect_triangle_edges, Ray};
    use linlight_sampling::rng::Pcg32;

    /// Packets with every kind of lane: masked off, zero and negative direction components,
    /// one common origin or scattered origins, NaN origins and directions.
    fn packets(rng: &mut Pcg32, count: usize) -> Vec<(RayLanes, u32)> {
        let mut f = move || rng.next_f32();
        (0..count)
            .map(|k| {
                let mut lanes = RayLanes::default();
                let origin = [f(), f(), f()];
                for i in 0..PACKET {
                    #[allow(clippy::needless_range_loop)] // lane i of every component
                    for a in 0..3 {
                        lanes.o[a][i] = if k % 2 == 0 {
                            origin[a]
                        } else {
                            f() * 4.0 - 2.0
                        };
                        // Coherent signs on even packets, mixed on odd ones.
                        let d = if k % 2 == 0 { f() + 0.1 } else { f() - 0.5 };
                        lanes.d[a][i] = match (k + i + a) % 23 {
                            0 => 0.0,
                            1 => -0.0,
                            _ => d,
                        };
                    }
                    lanes.t_min[i] = 0.01 * f();
                    lanes.t_max[i] = 1.0 + 4.0 * f();
                }
                if k % 17 == 5 {
                    lanes.o[k % 3][k % PACKET] = f32::NAN;
                }
                if k % 19 == 7 {
                    lanes.d[k % 3][(k + 3) % PACKET] = f32::NAN;
                }
                let active = match k % 4 {
                    0 => 0xffff,
                    1 => 1 << (k % PACKET),
                    _ => ((f() * 65535.0) as u32).max(1),
                };
                (lanes, active)
            })
            .collect()
    }

    /// Every kernel this CPU runs gives the portable kernel's packets (bounds, signs,
    /// coherence), box hits, triangle hits (t, b1, b2 bit for bit) and closest-hit updates.
    #[test]
    fn kernels_agree_with_portable() {
        on_every_vector_kernel!(compare);
        // The portable kernel against the scalar single-ray tests (triangles; every other
        // comparison is of the portable kernel with itself).
        compare::<Portable>();
    }

    /// Every kernel's sphere lanes are the scalar single-ray test (`Primitive::intersect`, what
    /// `Bvh::intersect` and `Bvh::occluded` call): the same hit or miss, and where it hits the
    /// same t bit for bit — rays from outside and inside (near or far root), zero and NaN
    /// directions, empty intervals.
    #[test]
    fn sphere_lanes_match_single_rays() {
        on_every_vector_kernel!(compare_spheres);
        compare_spheres::<Portable>();
    }

    #[inline(always)]
    fn compare_spheres<K: Kernel>() {
        use crate::shapes::Primitive;
        let mut rng = Pcg32::new(5, 12);
        let spheres: Vec<(Vec3, f32)> = (0..24)
            .map(|i| {
                let mut f = || rng.next_f32();
                let center = Vec3::new(f(), f(), f()) * 2.0 - 1.0;
                // Radii from tiny (rays graze or miss) to large (origins inside).
                let radius = if i % 6 == 0 { 1e-3 } else { 0.1 + 1.5 * f() };
                (center, radius)
            })
            .collect();
        let (mut near, mut far, mut lanes_tested) = (0u32, 0u32, 0u32);
        for (k, (mut lanes, _)) in packets(&mut rng, 200).into_iter().enumerate() {
            // A zero direction (a = 0: no root) and an empty interval in some packets.
            if k % 5 == 0 {
                for a in 0..3 {
                    lanes.d[a][k % PACKET] = 0.0;
                }
            }
            if k % 7 == 0 {
                lanes.t_min[(k + 1) % PACKET] = f32::INFINITY;
                lanes.t_max[(k + 1) % PACKET] = f32::NEG_INFINITY;
            }
            for &(center, radius) in &spheres {
                let prim = Primitive::Sphere {
                    center,
                    radius,
                    shape: 0,
                };
                let r2 = (radius as f64).powi(2);
                let (t, b1, b2, hits) = K::sphere(&lanes, &lanes.t_min, &lanes.t_max, center, r2);
                for i in 0..PACKET {
                    let ray = lanes.get(i);
                    let scalar = prim.intersect(&ray).map(|(t, ..)| t.to_bits());
                    let lane = (hits >> i & 1 == 1).then(|| t[i].to_bits());
                    assert_eq!(
                        scalar, lane,
                        "lane {i}, sphere {center} {radius}, ray {ray:?}"
                    );
                    assert_eq!((b1[i], b2[i]), (0.0, 0.0));
                    if hits >> i & 1 == 1 {
                        // Which root: the origin inside the sphere gives the far one.
                        if (ray.o - center).length() < radius {
                            far += 1;
                        } else {
                            near += 1;
                        }
                    }
                    lanes_tested += 1;
                }
            }
        }
        assert!(near > 1000 && far > 1000, "{near} near and {far} far roots");
        assert!(lanes_tested > 50_000);
    }

    #[inline(always)]
    fn compare<K: Kernel>() {
        let mut rng = Pcg32::new(21, 8);
        let node = {
            let mut n = Node::EMPTY;
            for lane in 0..3 {
                for a in 0..3 {
                    let lo = rng.next_f32() * 2.0 - 1.0;
                    n.b[0][a][lane] = lo;
                    n.b[1][a][lane] = lo + rng.next_f32();
                }
            }
            n
        };
        let tris: Vec<[Vec3; 3]> = (0..40)
            .map(|i| {
                let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let v0 = r3() * 3.0 - 1.0;
                let e1 = (r3() - 0.5) * 4.0;
                // Every eighth triangle degenerate (det = 0 for every ray).
                let e2 = if i % 8 == 0 {
                    e1 * 2.0
                } else {
                    (r3() - 0.5) * 4.0
                };
                [v0, e1, e2]
            })
            .collect();
        let (mut coherent, mut hits) = (0, 0);
        for (lanes, active) in packets(&mut rng, 400) {
            let (p, q) = (Portable::packet(&lanes, active), K::packet(&lanes, active));
            assert_eq!(p.coherent, q.coherent);
            coherent += p.coherent as u32;
            if p.coherent {
                assert_eq!(p.sign, q.sign);
                assert_eq!((p.o_near, p.o_far), (q.o_near, q.o_far));
                assert_eq!((p.inv_lo, p.inv_hi), (q.inv_lo, q.inv_hi));
                assert_eq!((p.t_lo, p.t_hi), (q.t_lo, q.t_hi));
            }
            let bits = |a: &[f32; PACKET]| a.map(f32::to_bits);
            for a in 0..3 {
                assert_eq!(bits(&p.inv[a]), bits(&q.inv[a]));
            }
            assert_eq!(bits(&p.t_min), bits(&q.t_min));
            assert_eq!(bits(&p.t_max), bits(&q.t_max));
            for lane in 0..4 {
                let (pm, pe) = Portable::box_hits(&p, &node, lane);
                let (qm, qe) = K::box_hits(&q, &node, lane);
                assert_eq!((pm & active, pe), (qm & active, qe), "lane {lane}");
                if p.coherent {
                    let (pc, qc) = (
                        Portable::box_mask_coherent(&p, &node, lane),
                        K::box_mask_coherent(&q, &node, lane),
                    );
                    assert_eq!((pc & active, qc & active), (pm & active, pm & active));
                }
            }
            let mut best = [PacketHits {
                t: [0.0; PACKET],
                prim: [u32::MAX; PACKET],
                b1: [0.0; PACKET],
                b2: [0.0; PACKET],
                mask: 0,
            }; 2];
            let mut t_max = [p.t_max; 2];
            for (i, tri) in tris.iter().enumerate() {
                let h = Portable::triangle(&lanes, &p.t_min, &t_max[0], tri);
                let g = K::triangle(&lanes, &q.t_min, &t_max[1], tri);
                assert_eq!(h.3, g.3);
                #[allow(clippy::needless_range_loop)] // lane k of every array
                for k in 0..PACKET {
                    // Kernel K's lane is the scalar single-ray test (`Bvh::intersect`'s):
                    // the same hit or miss, and where it hits the same t, b1, b2 bit for bit.
                    let ray = Ray {
                        t_min: q.t_min[k],
                        t_max: t_max[1][k],
                        ..lanes.get(k)
                    };
                    let scalar = intersect_triangle_edges(&ray, tri[0], tri[1], tri[2]);
                    let lane = (g.3 >> k & 1 == 1).then(|| (g.0[k], g.1[k], g.2[k]));
                    let bits3 = |x: Option<(f32, f32, f32)>| {
                        x.map(|(t, b1, b2)| (t.to_bits(), b1.to_bits(), b2.to_bits()))
                    };
                    assert_eq!(bits3(scalar), bits3(lane), "lane {k}");
                    if h.3 >> k & 1 == 1 {
                        assert_eq!(
                            (h.0[k].to_bits(), h.1[k].to_bits(), h.2[k].to_bits()),
                            (g.0[k].to_bits(), g.1[k].to_bits(), g.2[k].to_bits())
                        );
                    }
                }
                hits += h.3.count_ones();
                // The same hits under index 2i + 1, then again under 2i: every hit is then a
                // tie that the smaller index wins.
                for prim in [2 * i as u32 + 1, 2 * i as u32] {
                    let [tp, tq] = &mut t_max;
                    let [bp, bq] = &mut best;
                    let took = Portable::take_closest(bp, tp, &h, active, prim);
                    assert_eq!(took, K::take_closest(bq, tq, &g, active, prim));
                    assert_eq!(bits(tp), bits(tq));
                    assert_eq!(bits(&bp.t), bits(&bq.t));
                    assert_eq!(bp.prim, bq.prim);
                    assert_eq!(bits(&bp.b1), bits(&bq.b1));
                    assert_eq!(bits(&bp.b2), bits(&bq.b2));
                }
            }
            // The tiny-tree update: best.t is the rays' t_max.
            let mut near = [PacketHits {
                t: p.t_max,
                prim: [u32::MAX; PACKET],
                b1: [0.0; PACKET],
                b2: [0.0; PACKET],
                mask: 0,
            }; 2];
            for (i, tri) in tris.iter().enumerate() {
                let [np, nq] = &mut near;
                let h = Portable::triangle(&lanes, &p.t_min, &np.t, tri);
                let g = K::triangle(&lanes, &q.t_min, &nq.t, tri);
                assert_eq!(h.3, g.3);
                Portable::take_nearer(np, &h, i as u32);
                K::take_nearer(nq, &g, i as u32);
                assert_eq!(bits(&np.t), bits(&nq.t));
                assert_eq!(np.prim, nq.prim);
                assert_eq!(bits(&np.b1), bits(&nq.b1));
                assert_eq!(bits(&np.b2), bits(&nq.b2));
            }
            let finite = p.t_max.map(|t| if t.is_finite() { t } else { 0.0 });
            assert_eq!(Portable::max(&finite), K::max(&finite));
        }
        assert!(
            coherent > 50 && coherent < 350,
            "{coherent} coherent packets"
        );
        assert!(hits > 1000, "{hits} triangle hits");
    }
}
