//! Shadow rays toward the light samples of a packet's lanes (the scalar integrator's
//! `shadow_ray_to`, without branches).

use super::lights::SampleLanes;
use super::shading::ShadingLanes;
use crate::bvh::RayLanes;
use crate::ray_offset::{offset_origin, SHADOW_EPSILON};
use crate::shapes::Ray;
use glam::Vec3;
use linlight_simd::{get3, PACKET_LANES};

/// Shadow rays of the lanes whose sample can contribute (the scalar integrator's tests:
/// positive finite density, n·ω > 0, a finite positive distance, a usable shadow ray), and
/// their mask.
#[inline(always)]
pub(super) fn shadow_rays(shading: &ShadingLanes, samples: &SampleLanes) -> (RayLanes, u32) {
    let mut rays = RayLanes::default();
    let mut mask = 0u32;
    for k in 0..PACKET_LANES {
        let (p, ng, n) = (
            get3(&shading.p, k),
            get3(&shading.ng, k),
            get3(&shading.n, k),
        );
        let (dir, pdf, distance) = (get3(&samples.dir, k), samples.pdf[k], samples.distance[k]);
        let cos = n.dot(dir);
        // distance = d/t with d > 0: the scalar test "t > 0 and d/t finite".
        let usable =
            (pdf > 0.0) & pdf.is_finite() & (cos > 0.0) & (distance > 0.0) & distance.is_finite();
        let (ray, ok) = shadow_ray_lane(p, ng, p + distance * dir);
        rays.set(k, &ray);
        mask |= ((usable & ok & (samples.mask >> k & 1 == 1)) as u32) << k;
    }
    (rays, mask)
}

/// [`shadow_ray_to`] without branches: the ray, and whether `shadow_ray_to` returns it.
#[inline(always)]
pub(super) fn shadow_ray_lane(p: Vec3, ng: Vec3, target: Vec3) -> (Ray, bool) {
    let o = offset_origin(p, ng, target - p);
    let d = target - o;
    let dist = d.length();
    let ok = (dist > 0.0) & dist.is_finite();
    let ray = Ray {
        o,
        d: d / dist,
        t_min: 0.0,
        t_max: dist * (1.0 - SHADOW_EPSILON),
    };
    (ray, ok)
}

/// The shadow rays of the lanes of `mask` from their shading points toward the points at
/// `distance[k]` along `dir[k]` ([`shadow_ray_lane`]), and the lanes whose ray is valid.
#[inline(always)]
pub(super) fn shadow_rays_along(
    mask: u32,
    dir: &super::Lanes3,
    distance: &[f32; PACKET_LANES],
    shading: &ShadingLanes,
) -> (RayLanes, u32) {
    let mut rays = RayLanes::default();
    let mut valid = 0u32;
    let mut m = mask;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        let p = get3(&shading.p, k);
        let target = p + distance[k] * get3(dir, k);
        let (ray, ok) = shadow_ray_lane(p, get3(&shading.ng, k), target);
        rays.set(k, &ray);
        valid |= (ok as u32) << k;
    }
    (rays, valid)
}
