//! The triangles under a packet's hit lanes, gathered into lanes (structure of arrays), and
//! their surface points computed on all lanes at once.

use super::Lanes3;
use crate::bvh::PacketHits;
use glam::Vec3;
use linlight_simd::{get3, set3, PACKET_LANES};
use std::mem::MaybeUninit;

/// The triangles hit by the lanes of a packet (structure of arrays): vertices, vertex normals
/// (`normals`: lanes that have them), the sign of `flip_normals`. The lanes of one triangle are
/// written together ([`Triangles::set`]): the first triangle into every lane (so that all lanes
/// are initialised without zeroing the arrays first), the later ones by selects over the
/// lanes (lane by lane when a group has at most [`SMALL_GROUP`] lanes); the normals only once
/// a triangle has them (they are not read otherwise). Lanes outside `mask` (`normals`) hold
/// another triangle's values, computed on and not kept.
#[repr(C, align(64))] // `sign` on its own cache line ([`Aligned`])
pub(super) struct Triangles<'t> {
    sign: [f32; PACKET_LANES],
    pub(super) mask: u32,
    v: &'t mut MaybeUninit<[Lanes3; 3]>,
    n: &'t mut MaybeUninit<[Lanes3; 3]>,
    normals: u32,
}

impl<'t> Triangles<'t> {
    /// No lanes yet, the vertices and normals to be written into `v` and `n`.
    #[inline(always)]
    pub(super) fn new(
        v: &'t mut MaybeUninit<[Lanes3; 3]>,
        n: &'t mut MaybeUninit<[Lanes3; 3]>,
    ) -> Self {
        Self {
            mask: 0,
            v,
            n,
            normals: 0,
            sign: [1.0; PACKET_LANES],
        }
    }
}

/// Groups of at most this many lanes are written lane by lane, larger ones by a select over
/// all sixteen lanes (nine selects cost about as much as the stores of five lanes).
pub(super) const SMALL_GROUP: u32 = 4;

/// `x` in the lanes of `group` (bit k: lane k) of `lanes`. [`write_group`] keeps a loop of
/// its own: one helper shared by both costs more instructions per sample than the two loops.
#[inline(always)]
pub(super) fn select_lanes<T: Copy>(lanes: &mut [T; PACKET_LANES], group: u32, x: T) {
    if group.count_ones() <= SMALL_GROUP {
        let mut g = group;
        while g != 0 {
            lanes[g.trailing_zeros() as usize] = x;
            g &= g - 1;
        }
        return;
    }
    for (k, l) in lanes.iter_mut().enumerate() {
        *l = if group >> k & 1 == 1 { x } else { *l };
    }
}

/// Writes the three vectors `v` into the lanes of `group` (bit k: lane k) of `lanes`, or into
/// every lane when `written` = 0 (`lanes` not yet initialised; afterwards it is).
///
/// The small-group and select loops are written out here rather than calling `select_lanes`
/// per component array, which costs more instructions per sample.
#[inline(always)]
fn write_group(lanes: &mut MaybeUninit<[Lanes3; 3]>, written: u32, group: u32, v: &[Vec3; 3]) {
    if written == 0 {
        // An array literal: `v.map(…)` compiles to an out-of-line `try_map` call whose
        // result comes back through memory (a 576-byte `memcpy`).
        let splat = |x: Vec3| {
            [
                [x.x; PACKET_LANES],
                [x.y; PACKET_LANES],
                [x.z; PACKET_LANES],
            ]
        };
        lanes.write([splat(v[0]), splat(v[1]), splat(v[2])]);
        return;
    }
    // SAFETY: `written` ≠ 0: a first call initialised every lane.
    let lanes = unsafe { lanes.assume_init_mut() };
    if group.count_ones() <= SMALL_GROUP {
        let mut g = group;
        while g != 0 {
            let k = g.trailing_zeros() as usize;
            g &= g - 1;
            for (lj, vj) in lanes.iter_mut().zip(v) {
                set3(lj, k, *vj);
            }
        }
        return;
    }
    // A select by bit masks, which loads and stores every lane in vectors (with `if`, LLVM
    // emits a store per lane behind a branch: ≈ 850 instructions of scalar code).
    let masks: [u32; PACKET_LANES] = std::array::from_fn(|k| 0u32.wrapping_sub(group >> k & 1));
    for (lj, vj) in lanes.iter_mut().zip(v) {
        for (l, c) in lj.iter_mut().zip(vj.to_array()) {
            for (x, m) in l.iter_mut().zip(masks) {
                *x = f32::from_bits(c.to_bits() & m | x.to_bits() & !m);
            }
        }
    }
}

impl Triangles<'_> {
    /// Triangle `v` (vertex normals `n`) in the lanes of `group`.
    #[inline(always)]
    pub(super) fn set(&mut self, group: u32, v: &[Vec3; 3], n: Option<&[Vec3; 3]>, flip: bool) {
        write_group(self.v, self.mask, group, v);
        self.mask |= group;
        if let Some(n) = n {
            write_group(self.n, self.normals, group, n);
            self.normals |= group;
        }
        select_lanes(&mut self.sign, group, if flip { -1.0 } else { 1.0 });
    }

    /// `Primitive::surface_point` of the triangle lanes, the same operations lane by lane (so
    /// the same bits), in one loop over all lanes that the compiler vectorises; other lanes
    /// are left as they are. Only with `mask` ≠ 0.
    #[inline(always)]
    pub(super) fn surface_points(
        &self,
        hits: &PacketHits,
        p: &mut Lanes3,
        ng: &mut Lanes3,
        ns: &mut Lanes3,
    ) {
        debug_assert!(self.mask != 0);
        // SAFETY: `set` initialised every lane (mask ≠ 0).
        let v = unsafe { self.v.assume_init_ref() };
        if self.normals == 0 {
            // Zero normals, as the lanes without them: the shading normal is the geometric.
            self.lanes(v, None, hits, p, ng, ns);
            return;
        }
        // SAFETY: as above (normals ≠ 0).
        let n = unsafe { self.n.assume_init_ref() };
        self.lanes(v, Some(n), hits, p, ng, ns);
    }

    #[inline(always)]
    fn lanes(
        &self,
        v: &[Lanes3; 3],
        n: Option<&[Lanes3; 3]>,
        hits: &PacketHits,
        p: &mut Lanes3,
        ng: &mut Lanes3,
        ns: &mut Lanes3,
    ) {
        for k in 0..PACKET_LANES {
            let (b1, b2) = (hits.b1[k], hits.b2[k]);
            let b0 = 1.0 - b1 - b2;
            let [v0, v1, v2] = v.each_ref().map(|v| get3(v, k));
            let pk = b0 * v0 + b1 * v1 + b2 * v2;
            let ngk = (v1 - v0).cross(v2 - v0).normalize_or_zero();
            let nsk = match n {
                Some(n) => {
                    let [n0, n1, n2] = n.each_ref().map(|n| get3(n, k));
                    let nsk = (b0 * n0 + b1 * n1 + b2 * n2).normalize_or_zero();
                    if (self.normals >> k & 1 == 1) & (nsk != Vec3::ZERO) {
                        nsk
                    } else {
                        ngk
                    }
                }
                None => ngk,
            };
            if self.mask >> k & 1 == 1 {
                let sign = self.sign[k];
                set3(p, k, pk);
                set3(ng, k, sign * ngk);
                set3(ns, k, sign * nsk);
            }
        }
    }
}
