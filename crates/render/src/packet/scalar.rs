//! The lanes sampled with the scalar code, lane by lane (techniques without a batch kernel;
//! LTC and MIS on non-Lambertian surfaces), their shadow rays traced in packet walks.

use super::lights::LightLanes;
use super::shading::ShadingLanes;
use super::shadow::shadow_rays_along;
use super::{Context, Lanes3};
use crate::hooks::{Ltc, SceneBsdf};
use crate::render_scene::RenderScene;
use crate::shading::{single_contribution, single_sample, TwoTechniqueLight};
use glam::Vec3;
use linlight_simd::{get3, set3, PACKET_LANES};

impl<'a> Context<'a> {
    /// Each lane's light of `lights` at the lanes of `lanes`, sampled lane by lane
    /// with the scalar code — a single technique's sample ([`single_sample`]), or LTC's and
    /// MIS's diffuse and specular samples ([`TwoTechniqueLight::candidates`]) —, each kind of
    /// sample's shadow rays in one packet walk, the lanes' contributions of this light summed
    /// as the scalar path sums them, then added to `total`. Returns the number of non-finite
    /// contributions left out.
    #[inline(always)]
    pub(super) fn scalar_light(
        &self,
        shading: &ShadingLanes,
        lanes: u32,
        lights: &LightLanes,
        total: &mut Lanes3,
    ) -> u64 {
        let samples = self.scalar_samples(shading, lanes, lights);
        let visible = samples
            .each_ref()
            .map(|s| s.visible(self.rs, shading, lights));
        let seen: [(&Lanes3, u32); 2] = std::array::from_fn(|i| (&samples[i].c, visible[i]));
        add_visible(&seen, lanes, total)
    }

    /// The samples of [`Self::scalar_light`] before visibility, lane by lane; ξ of lane k:
    /// `lights.scalar_xi[0][k]` (single techniques) or both (LTC, MIS). Not inlined:
    /// scalar code, compiled once for the target's baseline rather than into every ISA's
    /// packet kernel.
    #[inline(never)]
    fn scalar_samples(
        &self,
        shading: &ShadingLanes,
        lanes: u32,
        lights: &LightLanes,
    ) -> [CandidateLanes; 2] {
        let xi = &lights.scalar_xi;
        let mut samples = [CandidateLanes::default(), CandidateLanes::default()];
        let mut m = lanes;
        match self.combination {
            None => {
                let xi = &xi[0];
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let (light, k_light) = lights.of(self.rs, k);
                    let (p, n) = (get3(&shading.p, k), get3(&shading.n, k));
                    let Some(sampler) = light.sampler(&self.technique, p, n) else {
                        continue;
                    };
                    let Some(s) = single_sample(&sampler, n, xi[k]) else {
                        continue;
                    };
                    // The integrator's contributions: full BSDF, or K·(ρ/π)·(cos θ/p).
                    let c = match &shading.glossy[k] {
                        Some(point) => single_contribution(&SceneBsdf, point, k_light, s.w, s.pdf),
                        None => k_light * get3(&shading.lambert, k) * (s.cos / s.pdf),
                    };
                    samples[0].set(k, s.w, s.dist, c);
                }
            }
            Some(combination) => {
                let [xi_d, xi_s] = xi;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let Some(point) = &shading.glossy[k] else {
                        continue;
                    };
                    let (light, k_light) = lights.of(self.rs, k);
                    let Some(light) = TwoTechniqueLight::prepare(&Ltc, point, light.segment())
                    else {
                        continue;
                    };
                    let eval = |w: Vec3| point.eval(&SceneBsdf, w);
                    let candidates =
                        light.candidates(combination, k_light, (xi_d[k], xi_s[k]), eval);
                    for (lanes, c) in samples.iter_mut().zip(candidates) {
                        if let Some(c) = c {
                            lanes.set(k, c.w, c.dist, c.c);
                        }
                    }
                }
            }
        }
        samples
    }
}

/// Adds to `total`, at each lane of `lanes`, the contributions of the samples whose shadow ray
/// reached the light there (bit k of each mask), in the samples' order and summed from +0 per
/// lane as the scalar path sums them. Returns the number of non-finite contributions left out.
#[inline(always)]
pub(super) fn add_visible(samples: &[(&Lanes3, u32)], lanes: u32, total: &mut Lanes3) -> u64 {
    let mut dropped = 0;
    let mut m = lanes;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        // A lane without a visible sample adds +0, which leaves the total's bits unchanged.
        let mut light = Vec3::ZERO;
        for &(c, visible) in samples {
            if visible >> k & 1 == 1 {
                let c = get3(c, k);
                if c.is_finite() {
                    light += c;
                } else {
                    dropped += 1;
                }
            }
        }
        set3(total, k, get3(total, k) + light);
    }
    dropped
}

/// Samples found lane by lane with the scalar code: lane k (in `mask`) adds `c[k]` when the
/// line point along `dir[k]` at `distance[k]` is visible.
#[derive(Default)]
#[repr(C, align(64))] // the lane arrays first, each on its own cache line(s) ([`Aligned`])
struct CandidateLanes {
    dir: Lanes3,
    c: Lanes3,
    distance: [f32; PACKET_LANES],
    mask: u32,
}

impl CandidateLanes {
    #[inline(always)]
    fn set(&mut self, k: usize, dir: Vec3, distance: f32, c: Vec3) {
        self.mask |= 1 << k;
        set3(&mut self.dir, k, dir);
        self.distance[k] = distance;
        set3(&mut self.c, k, c);
    }

    /// The lanes whose line point is visible: the scalar integrator's shadow rays
    /// (`shadow_ray_to`) toward lane k's light `lights.light[k]`, in one packet walk per
    /// culled shadow BVH the lanes' lights use, plus one of the full BVH for the others
    /// ([`crate::shadow_culling`]).
    #[inline(always)]
    fn visible(&self, rs: &RenderScene, shading: &ShadingLanes, lights: &LightLanes) -> u32 {
        if self.mask == 0 {
            return 0;
        }
        let (rays, mask) = shadow_rays_along(self.mask, &self.dir, &self.distance, shading);
        mask & !rs
            .shadows
            .occluded_lanes(&rs.bvh, &lights.light, lights.uniform, &rays, mask)
    }
}
