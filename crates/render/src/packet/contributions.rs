//! The contributions K·f·cos θ/p of a packet's lit lanes: Lambertian lanes on the lanes'
//! arrays, glossy lanes with their BSDFs evaluated on all lanes at once.

use super::lights::SampleLanes;
use super::shading::ShadingLanes;
use super::Lanes3;
use crate::scene::Bsdf;
use crate::shading::{contribution, to_local};
use linlight_simd::{get3, PACKET_LANES};

/// Adds the contributions of the lit lanes (`lit`) on Lambertian surfaces for their light
/// (lane k's K = `k_light[·][k]`) to `total`: K·f(v, ω)·cos θ/p(ω), p per radius (dΩ_R), glam's
/// k·f·(n·ω/p) written on the lanes (the same operations in the same order, the dot product
/// adding x, y, then z: the same bits), finite ones only (adding +0 elsewhere leaves a sum
/// that starts at +0 bitwise unchanged); returns how many were dropped.
#[inline(always)]
pub(super) fn lambert_contributions(
    shading: &ShadingLanes,
    samples: &SampleLanes,
    lit: u32,
    k_light: &Lanes3,
    total: &mut Lanes3,
) -> u64 {
    let lambert_lit = lit & !shading.glossy_mask;
    let mut dropped = 0u32;
    #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
    for k in 0..PACKET_LANES {
        let (n, dir, f) = (&shading.n, &samples.dir, &shading.lambert);
        let cos = n[0][k] * dir[0][k] + n[1][k] * dir[1][k] + n[2][k] * dir[2][k];
        let s = cos / samples.pdf[k];
        let c: [f32; 3] = std::array::from_fn(|a| k_light[a][k] * f[a][k] * s);
        let finite = c.iter().all(|x| x.is_finite());
        let lambert = lambert_lit >> k & 1 == 1;
        let add = lambert & finite;
        dropped |= ((lambert & !finite) as u32) << k;
        for a in 0..3 {
            total[a][k] += if add { c[a] } else { 0.0 };
        }
    }
    dropped.count_ones() as u64
}

/// Adds the contributions of the lit lanes (`lit`) on non-Lambertian surfaces for their light
/// (lane k's K = `k_light[·][k]`) to `total`: the scalar single-technique contribution
/// ([`single_contribution`]), finite ones only; returns how many were dropped. The lanes that
/// share a BSDF are evaluated together, on all sixteen lanes of the packet
/// ([`Bsdf::eval_lanes`]: the scalar path's arithmetic per lane, the same bits, in f32 SIMD
/// lanes of the kernel's instruction set, into which this is inlined), then K·f·cos/p on all
/// lanes at once.
#[inline(always)]
pub(super) fn glossy_contributions(
    shading: &ShadingLanes,
    samples: &SampleLanes,
    lit: u32,
    k_light: &Lanes3,
    total: &mut Lanes3,
) -> u64 {
    let glossy = lit & shading.glossy_mask;
    if glossy == 0 {
        return 0;
    }
    // ω in the shading frames (ShadingPoint::local), all lanes at once.
    let mut l = [[0.0f32; PACKET_LANES]; 3];
    #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
    for k in 0..PACKET_LANES {
        let (x, y, n) = (
            get3(&shading.frame_x, k),
            get3(&shading.frame_y, k),
            get3(&shading.n, k),
        );
        let lk = to_local(x, y, n, get3(&samples.dir, k));
        (l[0][k], l[1][k], l[2][k]) = (lk.x, lk.y, lk.z);
    }
    // f·cos of the lanes in `todo`, BSDF by BSDF, each on all sixteen lanes at once (f32: one
    // 512-bit register; the lanes outside its group are computed and not kept).
    let v = [shading.v[0], [0.0; PACKET_LANES], shading.v[1]];
    let mut f_cos = [[0.0f32; PACKET_LANES]; 3];
    let mut todo = glossy;
    while todo != 0 {
        let (bsdf, group) = if let Some(bsdf) = shading.one_bsdf {
            // Every glossy lane on one shape: one evaluation, no grouping.
            (bsdf, todo)
        } else {
            let Some(bsdf) = shading.bsdf[todo.trailing_zeros() as usize] else {
                todo &= todo - 1;
                continue;
            };
            // The lanes of `todo` whose surface has this BSDF (pointers compared on all lanes
            // at once).
            let mut group = 0u32;
            #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
            for k in 0..PACKET_LANES {
                let same = shading.bsdf[k].map_or(std::ptr::null(), |b| b as *const Bsdf);
                group |= (std::ptr::eq(same, bsdf) as u32) << k;
            }
            (bsdf, group & todo)
        };
        todo &= !group;
        let f = bsdf.eval_lanes(&v, &l);
        if group == glossy {
            // One BSDF on every glossy lit lane (the loop below reads no other lane).
            f_cos = f;
            break;
        }
        #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
        for k in 0..PACKET_LANES {
            let keep = group >> k & 1 == 1;
            for a in 0..3 {
                f_cos[a][k] = if keep { f[a][k] } else { f_cos[a][k] };
            }
        }
    }
    // K·(f·cos)/p (single_contribution's arithmetic) on all lanes, the finite ones of the lit
    // glossy lanes added (+0 elsewhere leaves the sums, which start at +0, bitwise unchanged).
    let mut dropped = 0u32;
    #[allow(clippy::needless_range_loop)] // lane k of every array: the loop that vectorises
    for k in 0..PACKET_LANES {
        let c = contribution(get3(k_light, k), get3(&f_cos, k), samples.pdf[k]);
        let finite = c.is_finite();
        let on = glossy >> k & 1 == 1;
        dropped |= ((on & !finite) as u32) << k;
        for (a, t) in total.iter_mut().enumerate() {
            t[k] += if on & finite { c[a] } else { 0.0 };
        }
    }
    dropped.count_ones() as u64
}
