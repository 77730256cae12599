//! Direct lighting from linear lights in the R → 0 limit (Mitsuba's `direct` integrator with
//! emitter sampling only).
//!
//! Per light, the estimator of the reflected radiance is K·f(v, ω)·max(0, n·ω)·V(ω)·w(ω)/p(ω),
//! where p is a technique's density per radius (dΩ_R), K = radiance × radius (the radius cancels
//! between the tube's solid angle R·Ω_R and its radiance K/R), f the surface's full BSDF
//! (`linlight_brdf::Bsdf::eval`, which includes the cosine) in the shading frame of the side
//! facing the viewer, and w the weight of the render's [`Method`](crate::method::Method) (1 for single techniques; see
//! [`crate::method`] and [`crate::shading`]). Each camera sample takes `light_samples` light
//! samples and their mean (Mitsuba's `emitter_samples`); what one light sample is depends on
//! the [`LightSelection`] of the render ([`crate::light_choice`]):
//! - `every` (default): every light, one after the other, each estimated with its own K.
//! - `one` (Mitsuba's estimator): one light j, chosen with probability p_j from an extra number
//!   ξ_c drawn first, estimated with K_j/p_j in place of K_j. A scene with one light draws no ξ_c
//!   (p = 1).
//!
//! Numbers of a camera sample that reaches a reflecting surface, after its film position:
//! `every`: light by light, each light's `light_samples` iterations ([`crate::shading`]: one
//! number per iteration, two for the two-technique methods on non-Lambertian surfaces);
//! `one`: per light sample ξ_c (scenes with two or more lights), then the chosen light's
//! numbers of one iteration. Lambertian surfaces take the fast path f = ρ/π with one diffuse
//! technique (the single technique, or projected solid angle for the two-technique methods).

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::hooks::{BsdfModel, LightSampling, Resolved, SpecularSampling};
use crate::light_choice::{LightChoice, LightSelection};
use crate::render::RenderOptions;
use crate::scene::{Bsdf, Rgb};
use crate::shading::{estimate_resolved, single_technique, ShadingPoint};
use crate::shadow_culling::ShadowCulling;
use crate::shapes::{Ray, SurfacePoint};
use crate::visible_line::VisibleLines;
use glam::Vec3;
use linlight_sampling::noise::SampleStream;
use linlight_sampling::Segment;

/// Mitsuba's ray epsilon for f32 variants: 1500 ulp(1) = 1500·2⁻²⁴.
pub const RAY_EPSILON: f32 = 1500.0 / 16_777_216.0;
/// Shadow rays stop this fraction of their length short of the target.
pub const SHADOW_EPSILON: f32 = 10.0 * RAY_EPSILON;

/// Everything the integrator needs, prepared from a [`crate::scene::Scene`].
#[derive(Clone, Debug)]
pub struct RenderScene {
    pub camera: Camera,
    pub bvh: Bvh,
    /// The shadow BVH of each light ([`crate::shadow_culling`]): shadow rays toward light j
    /// walk `shadows` with `bvh` as the fallback; same answers as `bvh`.
    pub shadows: ShadowCulling,
    /// Per `Scene::shapes` entry: its BSDF and flip_normals.
    pub surfaces: Vec<(Bsdf, bool)>,
    /// Per `Scene::shapes` entry: f = ρ/π when its BSDF is Lambertian (`Bsdf::lambertian`), the
    /// integrator's fast path; `None` for glossy BSDFs.
    pub lambert: Vec<Option<Vec3>>,
    /// Segment and K = radiance × radius per light.
    pub lights: Vec<(Segment, Vec3)>,
    /// The distribution of the light chosen per light sample under [`LightSelection::One`].
    pub choice: LightChoice,
    /// The lights as the camera sees them (empty when the scene hides emitters).
    pub visible: VisibleLines,
    /// Light contributions dropped because they were not finite (reported by the renderer).
    pub dropped: DroppedSamples,
}

/// A count shared by the threads of a render (relaxed: only the total is read, at the end).
#[derive(Debug, Default)]
pub struct DroppedSamples(pub std::sync::atomic::AtomicU64);

impl Clone for DroppedSamples {
    fn clone(&self) -> Self {
        Self(std::sync::atomic::AtomicU64::new(self.get()))
    }
}

impl DroppedSamples {
    pub fn get(&self) -> u64 {
        self.0.load(std::sync::atomic::Ordering::Relaxed)
    }
    #[cold]
    fn add_many(&self, count: u64) {
        self.0
            .fetch_add(count, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Origin of a ray leaving surface point `p` (geometric normal `ng`) in direction `d`: pushed
/// off the surface to the side `d` points to, by (1 + max|p_i|)·RAY_EPSILON, as Mitsuba does.
#[inline]
pub fn offset_origin(p: Vec3, ng: Vec3, d: Vec3) -> Vec3 {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPSILON;
    let mag = if ng.dot(d) < 0.0 { -mag } else { mag };
    p + mag * ng
}

/// Shadow ray from a surface point to `target`, ending (1 − SHADOW_EPSILON)·distance along.
#[inline]
pub fn shadow_ray_to(sp: &SurfacePoint, target: Vec3) -> Option<Ray> {
    let o = offset_origin(sp.p, sp.ng, target - sp.p);
    let d = target - o;
    let dist = d.length();
    if !(dist > 0.0 && dist.is_finite()) {
        return None;
    }
    Some(Ray {
        o,
        d: d / dist,
        t_min: 0.0,
        t_max: dist * (1.0 - SHADOW_EPSILON),
    })
}

/// The normal of the side of a surface that reflects toward the viewer (`wi`: unit, pointing
/// away from the surface): the shading normal `ns`, its negation for a `twosided` BSDF seen from
/// below, or `None` when the viewer is behind a one-sided BSDF (or exactly in the tangent plane),
/// where Mitsuba's eval is zero.
#[inline]
pub fn reflecting_normal(bsdf: &Bsdf, ns: Vec3, wi: Vec3) -> Option<Vec3> {
    let c = ns.dot(wi);
    if c > 0.0 {
        Some(ns)
    } else if c < 0.0 && bsdf.is_two_sided() {
        Some(-ns)
    } else {
        None
    }
}

/// The Lambertian lobe seen from direction `wi`: the normal of the side that reflects and the
/// albedo, or `None` when nothing reflects toward the viewer or the BSDF is not Lambertian.
pub fn diffuse_lobe(bsdf: &Bsdf, ns: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    let n = reflecting_normal(bsdf, ns, wi)?;
    Some((n, bsdf.lambertian()?.as_vec3()))
}

impl RenderScene {
    /// Whether light samples choose one light ([`LightSelection::One`] with two or more
    /// lights); otherwise every light is sampled (with one light the two are the same).
    #[inline]
    pub fn chooses_one(&self, selection: LightSelection) -> bool {
        selection == LightSelection::One && self.lights.len() > 1
    }

    /// Numbers a camera sample that reaches a reflecting surface draws for its lights, with
    /// `numbers` per iteration of one light (1 on Lambertian surfaces).
    pub fn light_numbers(
        &self,
        selection: LightSelection,
        light_samples: u32,
        numbers: usize,
    ) -> usize {
        let samples = light_samples as usize;
        if self.chooses_one(selection) {
            samples * (1 + numbers)
        } else {
            samples * self.lights.len() * numbers
        }
    }
}

/// The light chosen by ξ_c under [`LightSelection::One`]: its index, and its K/p.
#[inline]
pub fn chosen_light(lights: &[(Segment, Vec3)], choice: &LightChoice, xi: f32) -> (usize, Vec3) {
    let (j, _) = choice.pick(xi);
    (j, k_over_probability(lights, choice, j))
}

/// K_j/p_j of light j (the same operation on both render paths).
#[inline(always)]
pub fn k_over_probability(lights: &[(Segment, Vec3)], choice: &LightChoice, j: usize) -> Vec3 {
    lights[j].1 * choice.inverse_probability(j)
}

/// Σ estimate(segment, K, iterations, rng) over the lights of the light samples: every light
/// with `opts.light_samples` iterations, or ([`RenderScene::chooses_one`]) `opts.light_samples`
/// times the light chosen by ξ_c, with K/p and one iteration.
#[inline(always)]
fn sum_over_light_samples(
    scene: &RenderScene,
    opts: &RenderOptions,
    rng: &mut SampleStream,
    mut estimate: impl FnMut(usize, &Segment, Vec3, u32, &mut SampleStream) -> Vec3,
) -> Vec3 {
    let mut total = Vec3::ZERO;
    if scene.chooses_one(opts.lights) {
        for _ in 0..opts.light_samples {
            let xi = rng.next_f32_unstratified();
            let (j, k) = chosen_light(&scene.lights, &scene.choice, xi);
            total += estimate(j, &scene.lights[j].0, k, 1, rng);
        }
    } else {
        for (j, (segment, k)) in scene.lights.iter().enumerate() {
            total += estimate(j, segment, *k, opts.light_samples, rng);
        }
    }
    total
}

/// One camera sample along `ray`: direct lighting by `opts.method` with `opts.light_samples`
/// light samples of the lights `opts.lights` selects (module documentation). Draws from `rng`
/// (the camera sample's own stream, after the caller's pixel-position numbers) the numbers
/// documented above and in [`crate::shading`] (none for misses and black surfaces).
pub fn radiance<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &RenderScene,
    opts: &RenderOptions,
    pieces: Resolved<T, S, B>,
    ray: &Ray,
    rng: &mut SampleStream,
) -> Rgb {
    let Some(hit) = scene.bvh.intersect(ray) else {
        return [0.0; 3];
    };
    let prim = scene.bvh.primitive(hit.prim);
    let shape = prim.shape() as usize;
    let (bsdf, flip) = &scene.surfaces[shape];
    let sp = prim.surface_point(ray, &hit, *flip);
    let wi = -ray.d;
    let Some(n) = reflecting_normal(bsdf, sp.ns, wi) else {
        return [0.0; 3];
    };
    let mut dropped = 0u32;
    let mut total;
    // Shadow rays toward light j walk its culled shadow BVH (same answers as `scene.bvh`).
    let sp = &sp;
    let visible = |j: usize| {
        move |w: Vec3, dist: f32| {
            shadow_ray_to(sp, sp.p + dist * w)
                .is_some_and(|shadow| !scene.shadows.occluded(&scene.bvh, j, &shadow))
        }
    };
    let light_samples = opts.light_samples;
    let one = scene.chooses_one(opts.lights);
    match scene.lambert[shape] {
        Some(f) => {
            // K·(ρ/π)·cos θ/p(ω), p per radius (dΩ_R).
            total = sum_over_light_samples(scene, opts, rng, |j, segment, k, samples, rng| {
                single_technique(
                    pieces.technique.prepare(segment, sp.p, n).as_ref(),
                    n,
                    samples,
                    rng,
                    &mut visible(j),
                    |_: Vec3, cos: f32, pdf: f32| k * f * (cos / pdf),
                    &mut dropped,
                )
            });
            if light_samples > 1 {
                total /= light_samples as f32;
            }
        }
        None => {
            let point = ShadingPoint::for_method(pieces.bsdf, opts.method, bsdf, sp.p, n, wi);
            // `every`: each light's estimate is its iterations' mean; `one`: the mean of the
            // light samples is taken here.
            total = sum_over_light_samples(scene, opts, rng, |j, segment, k, samples, rng| {
                estimate_resolved(
                    pieces,
                    opts.method,
                    &point,
                    segment,
                    k,
                    samples,
                    rng,
                    &mut visible(j),
                    &mut dropped,
                )
            });
            if one && light_samples > 1 {
                total /= light_samples as f32;
            }
        }
    }
    if dropped > 0 {
        scene.dropped.add_many(dropped as u64);
    }
    total.to_array()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epsilons_match_mitsuba() {
        assert!((RAY_EPSILON - 8.940697e-5).abs() < 1e-10);
        assert!((1.0 - SHADOW_EPSILON - (1.0 - 8.94e-4)).abs() < 1e-6);
    }

    #[test]
    fn one_and_two_sided_lobes() {
        let d = Bsdf::Diffuse {
            reflectance: [0.5; 3],
        };
        assert!(diffuse_lobe(&d, Vec3::Z, Vec3::Z).is_some());
        assert!(diffuse_lobe(&d, Vec3::Z, -Vec3::Z).is_none());
        let t = Bsdf::TwoSided(Box::new(d));
        assert_eq!(diffuse_lobe(&t, Vec3::Z, -Vec3::Z).unwrap().0, -Vec3::Z);
    }

    #[test]
    fn offset_moves_to_the_side_of_the_direction() {
        let p = Vec3::new(3.0, 0.0, 0.0);
        let o = offset_origin(p, Vec3::Z, Vec3::new(1.0, 0.0, -1.0));
        assert!((o - p + Vec3::Z * 4.0 * RAY_EPSILON).length() < 1e-9);
    }
}
