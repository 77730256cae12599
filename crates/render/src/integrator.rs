//! Direct lighting from linear lights in the R → 0 limit (Mitsuba's `direct` integrator with
//! emitter sampling only, one sample per light and camera sample).
//!
//! Per light, the estimator of the reflected radiance is K·f·max(0, n·ω)·V(ω)/p(ω), where p is
//! the technique's density per radius (dΩ_R) and K = radiance × radius: the radius cancels
//! between the tube's solid angle R·Ω_R and its radiance K/R.

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::scene::{Bsdf, Rgb};
use crate::shapes::{Ray, SurfacePoint};
use glam::Vec3;
use linlight_sampling::philox::CounterRng;
use linlight_sampling::{LineSampler, Prepared, Segment, Technique};

/// Mitsuba's ray epsilon for f32 variants: 1500 ulp(1) = 1500·2⁻²⁴.
pub const RAY_EPSILON: f32 = 1500.0 / 16_777_216.0;
/// Shadow rays stop this fraction of their length short of the target.
pub const SHADOW_EPSILON: f32 = 10.0 * RAY_EPSILON;

/// How the integrator samples a light at a shading point. [`Technique`] is the production
/// implementation; tests substitute deliberately wrong samplers (power controls) through
/// [`crate::render::render_with`]. Generic, so the production path stays monomorphic.
pub trait LightSampling: Sync {
    type Sampler: LineSampler;
    /// The sampler for `segment` seen from `x` with normal `n`; `None`: no contribution.
    fn prepare(&self, segment: &Segment, x: Vec3, n: Vec3) -> Option<Self::Sampler>;
    /// Name recorded in the image metadata (`technique`).
    fn name(&self) -> String;
}

impl LightSampling for Technique {
    type Sampler = Prepared;
    #[inline]
    fn prepare(&self, segment: &Segment, x: Vec3, n: Vec3) -> Option<Prepared> {
        Technique::prepare(*self, segment, x, n)
    }
    fn name(&self) -> String {
        Technique::name(*self).to_string()
    }
}

/// Everything the integrator needs, prepared from a [`crate::scene::Scene`].
#[derive(Clone, Debug)]
pub struct RenderScene {
    pub camera: Camera,
    pub bvh: Bvh,
    /// Per `Scene::shapes` entry: its BSDF and flip_normals.
    pub surfaces: Vec<(Bsdf, bool)>,
    /// Segment and K = radiance × radius per light.
    pub lights: Vec<(Segment, Vec3)>,
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

/// The Lambertian lobe seen from direction `wi` (unit, pointing away from the surface): its
/// albedo and the normal of the side that reflects, or `None` when the viewer is behind a
/// one-sided BSDF. `twosided` flips the frame toward the viewer.
pub fn diffuse_lobe(bsdf: &Bsdf, ns: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    match bsdf {
        Bsdf::Diffuse { reflectance } => {
            (ns.dot(wi) > 0.0).then(|| (ns, Vec3::from_array(*reflectance)))
        }
        Bsdf::TwoSided(inner) => {
            let n = if ns.dot(wi) < 0.0 { -ns } else { ns };
            diffuse_lobe(inner, n, wi)
        }
    }
}

#[inline]
fn finite_rgb(v: Vec3) -> bool {
    v.is_finite()
}

/// One camera sample through film position (px, py) in pixels: direct lighting from every
/// light with one sample of `technique` each. Consumes exactly `lights.len()` numbers of `rng`
/// (the camera sample's own stream) after the caller's pixel-position numbers (0 for misses and
/// black surfaces).
pub fn radiance<S: LightSampling>(
    scene: &RenderScene,
    technique: &S,
    ray: &Ray,
    rng: &mut CounterRng,
) -> Rgb {
    let mut total = Vec3::ZERO;
    let Some(hit) = scene.bvh.intersect(ray) else {
        return [0.0; 3];
    };
    let prim = scene.bvh.primitive(hit.prim);
    let (bsdf, flip) = &scene.surfaces[prim.shape() as usize];
    let sp = prim.surface_point(ray, &hit, *flip);
    let wi = -ray.d;
    let Some((n, albedo)) = diffuse_lobe(bsdf, sp.ns, wi) else {
        return [0.0; 3];
    };
    let f = albedo * std::f32::consts::FRAC_1_PI;
    for (segment, k) in &scene.lights {
        let xi = rng.next_f32();
        let Some(sampler) = technique.prepare(segment, sp.p, n) else {
            continue;
        };
        let (w, pdf) = sampler.sample_with_pdf(xi);
        let cos = n.dot(w);
        if !(pdf > 0.0 && pdf.is_finite() && cos > 0.0) {
            continue;
        }
        // The line point seen along ω is at distance d/t, t = √(1 − s²) = ĉ·ω.
        let frame = sampler.support();
        let t = frame.c_hat.dot(w);
        let dist = frame.d / t;
        if !(t > 0.0 && dist.is_finite()) {
            continue;
        }
        let Some(shadow) = shadow_ray_to(&sp, sp.p + dist * w) else {
            continue;
        };
        if scene.bvh.occluded(&shadow) {
            continue;
        }
        let c = *k * f * (cos / pdf);
        if finite_rgb(c) {
            total += c;
        }
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
