//! Exact tube lights (`--cylinders exact`, [`crate::tube`]) in packets: the camera rays and
//! their closest hits, the shading points and the shadow rays of a packet's sixteen lanes as
//! for line lights, the tube samples lane by lane with the scalar code
//! ([`PreparedTube::candidates`], the scalar path's estimator and arithmetic), each kind of
//! sample's shadow rays (emitter, BSDF side) in one packet walk of the full BVH — the shadow
//! culling assumes targets on the light's segment — and the other tubes tested ray by ray
//! ([`Tubes::occluded`](crate::tube::Tubes::occluded)).
//!
//! Same numbers and sums as [`crate::integrator`]'s `tube_radiance`: lane k draws, per light
//! (`every`, light after light) or after its choice ξ_c (`one`, `tree`), ξ₀ ξ₁ of the emitter
//! sample and with MIS ξ₂ ξ₃ of the BSDF-side sample, whether or not the light contributes; a
//! light's visible candidates are summed from +0 in the scalar order (emitter, then BSDF side)
//! and that sum is added to the lane's total. A camera ray that meets a tube before the first
//! surface (`hide_emitters = false`) returns the tube's radiance (black inside) and draws no
//! light numbers. So the images equal the scalar path's bit for bit (tests in the parent
//! module).

use super::scalar::add_visible;
use super::shading::ShadingLanes;
use super::shadow::shadow_rays_along;
use super::{Context, Lanes3};
use crate::bvh::{PacketHits, RayLanes};
use crate::hooks::SceneBsdf;
use crate::tube::PreparedTube;
use glam::Vec3;
use linlight_sampling::cylinder::CylinderTechnique;
use linlight_simd::{get3, set3, PACKET_LANES};

impl Context<'_> {
    /// The tube lights' estimates of the packet's lanes (`active`: the packet's camera samples)
    /// added to `total`, `number(d)` being dimension d of the lanes' streams. Returns the lanes
    /// shaded (they drew the lights' numbers) and the number of non-finite contributions left
    /// out. Not inlined: scalar code per lane, compiled once rather than into every ISA's
    /// packet kernel.
    #[inline(never)]
    pub(super) fn tube_lights(
        &self,
        active: u32,
        number: &dyn Fn(usize) -> [f32; PACKET_LANES],
        (rays, hits): (&RayLanes, &PacketHits),
        shading: &ShadingLanes,
        total: &mut Lanes3,
    ) -> (u32, u64) {
        let rs = self.rs;
        let tubes = &rs.tubes;
        let sampling = tubes.sampling;
        let mut shaded = shading.active;
        if tubes.camera_sees {
            // The scalar path's test: the tube closest along the camera ray up to its hit.
            let mut m = active;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let mut front = rays.get(k);
                if let Some(h) = hits.get(k) {
                    front.t_max = h.t;
                }
                if let Some((_, j, outside)) = tubes.closest(&front) {
                    let l = match tubes.get(j) {
                        Some(t) if outside => t.radiance,
                        _ => Vec3::ZERO,
                    };
                    set3(total, k, l);
                    shaded &= !(1 << k);
                }
            }
        }
        if shaded == 0 {
            return (0, 0);
        }
        let one = rs.chooses_one(self.opts.lights);
        let per_light = if sampling.mis { 4 } else { 2 };
        let mut dropped = 0u64;
        for walk in 0..if one { 1 } else { rs.lights.len() } {
            let lights = self.light_lanes(walk, one, &number, shading, false, false);
            let first = if one { 3 } else { 2 + per_light * walk };
            let zero = [0.0; PACKET_LANES];
            let xi: [[f32; PACKET_LANES]; 4] = std::array::from_fn(|i| {
                if i < per_light {
                    number(first + i)
                } else {
                    zero
                }
            });
            // The emitter and the BSDF-side candidates of each lane.
            let mut samples = [TubeLanes::default(), TubeLanes::default()];
            let mut m = shaded;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let j = lights.light[k] as usize;
                let Some(tube) = tubes.get(j) else { continue };
                let (p, n) = (get3(&shading.p, k), get3(&shading.n, k));
                let glossy = shading.glossy[k].as_ref();
                let lobe = match glossy {
                    Some(point) if sampling.technique == CylinderTechnique::Ltc => {
                        point.ltc_lobe(&SceneBsdf)
                    }
                    _ => None,
                };
                let Some(prepared) = PreparedTube::new(tube, sampling, p, n, lobe) else {
                    continue;
                };
                // k is K (or K/p_j): L = k/R.
                let radiance = get3(lights.k(), k) / tube.radius;
                let f = get3(&shading.lambert, k);
                let eval = |w: Vec3| match glossy {
                    Some(point) => point.eval(&SceneBsdf, w),
                    None => f * n.dot(w).max(0.0),
                };
                let xi_b = sampling.mis.then_some((xi[2][k], xi[3][k]));
                let candidates = prepared.candidates(radiance, [xi[0][k], xi[1][k]], xi_b, &eval);
                for (lanes, c) in samples.iter_mut().zip(candidates) {
                    if let Some(c) = c {
                        lanes.set(k, c.w, c.dist, c.c);
                    }
                }
            }
            let visible = samples
                .each_ref()
                .map(|s| s.visible_past_tubes(self, shading, &lights.light));
            let seen = [(&samples[0].c, visible[0]), (&samples[1].c, visible[1])];
            dropped += add_visible(&seen, shaded, total);
        }
        (shaded, dropped)
    }
}

/// One kind of tube sample of a packet's lanes: lane k (in `mask`) adds `c[k]` when the tube
/// point along `dir[k]` at `distance[k]` is visible.
#[derive(Default)]
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s)
struct TubeLanes {
    dir: Lanes3,
    c: Lanes3,
    distance: [f32; PACKET_LANES],
    mask: u32,
}

impl TubeLanes {
    #[inline(always)]
    fn set(&mut self, k: usize, dir: Vec3, distance: f32, c: Vec3) {
        self.mask |= 1 << k;
        set3(&mut self.dir, k, dir);
        self.distance[k] = distance;
        set3(&mut self.c, k, c);
    }

    /// The lanes whose tube point is visible: the scalar path's shadow rays (`shadow_ray_to`)
    /// in one packet walk of the full BVH, then every tube but the lane's own light
    /// (`light[k]`) ray by ray.
    fn visible_past_tubes(
        &self,
        ctx: &Context,
        shading: &ShadingLanes,
        light: &[u32; PACKET_LANES],
    ) -> u32 {
        if self.mask == 0 {
            return 0;
        }
        let (rays, mask) = shadow_rays_along(self.mask, &self.dir, &self.distance, shading);
        let mut visible = mask & !ctx.rs.bvh.occluded_lanes(&rays, mask);
        let mut m = visible;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            if ctx.rs.tubes.occluded(&rays.get(k), light[k] as usize) {
                visible &= !(1 << k);
            }
        }
        visible
    }
}
