//! Direct lighting from linear lights in the R → 0 limit (Mitsuba's `direct` integrator with
//! emitter sampling only, one sample per light and camera sample).
//!
//! Per light, the estimator of the reflected radiance is K·f(v, ω)·max(0, n·ω)·V(ω)/p(ω), where p
//! is the technique's density per radius (dΩ_R), K = radiance × radius (the radius cancels
//! between the tube's solid angle R·Ω_R and its radiance K/R) and f the surface's full BSDF
//! (`linlight_brdf::Bsdf::eval`, which includes the cosine) in the shading frame of the side
//! facing the viewer. The techniques sample the line's part above that side's horizon, which is
//! where f·cos is nonzero, so every technique is unbiased for every BSDF; only Lambertian surfaces
//! take the fast path f = ρ/π.

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::scene::{Bsdf, Rgb};
use crate::shapes::{Ray, SurfacePoint};
use crate::visible_line::VisibleLines;
use glam::{DVec3, Vec3};
use linlight_sampling::noise::SampleStream;
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
    /// Per `Scene::shapes` entry: f = ρ/π when its BSDF is Lambertian (`Bsdf::lambertian`), the
    /// integrator's fast path; `None` for glossy BSDFs.
    pub lambert: Vec<Option<Vec3>>,
    /// Segment and K = radiance × radius per light.
    pub lights: Vec<(Segment, Vec3)>,
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
    fn add(&self) {
        self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
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

/// How the shading point reflects light arriving from ω.
enum Reflection<'a> {
    /// f = albedo/π (the fast path: `diffuse` and blends of it).
    Lambert(Vec3),
    /// The full BSDF.
    Bsdf(Glossy<'a>),
}

/// A BSDF in the shading frame (t, b, n) of the side that faces the viewer (so a `twosided`
/// BSDF sees v_z > 0), v = `wi` in it. Out of line, so that the Lambertian loop stays as tight
/// as before.
struct Glossy<'a> {
    bsdf: &'a Bsdf,
    t: Vec3,
    b: Vec3,
    n: Vec3,
    v: DVec3,
}

impl<'a> Glossy<'a> {
    #[inline(never)]
    fn new(bsdf: &'a Bsdf, n: Vec3, wi: Vec3) -> Self {
        let (t, b) = n.any_orthonormal_pair();
        let v = DVec3::new(wi.dot(t) as f64, wi.dot(b) as f64, wi.dot(n) as f64);
        Glossy { bsdf, t, b, n, v }
    }

    /// f(v, ω)·cos θ for the world direction ω (unit).
    #[inline(never)]
    fn eval(&self, w: Vec3) -> Vec3 {
        let l = DVec3::new(
            w.dot(self.t) as f64,
            w.dot(self.b) as f64,
            w.dot(self.n) as f64,
        );
        self.bsdf.eval(self.v, l).as_vec3()
    }
}

#[inline]
fn finite_rgb(v: Vec3) -> bool {
    v.is_finite()
}

/// One camera sample through film position (px, py) in pixels: direct lighting from every
/// light with one sample of `technique` each. Takes exactly `lights.len()` dimensions of `rng`
/// (the camera sample's stream, [`SampleStream::next_f32`]: one light sample each) after the
/// caller's film position (none for misses and black surfaces).
pub fn radiance<S: LightSampling>(
    scene: &RenderScene,
    technique: &S,
    ray: &Ray,
    rng: &mut SampleStream,
) -> Rgb {
    let mut total = Vec3::ZERO;
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
    let reflection = match scene.lambert[shape] {
        Some(f) => Reflection::Lambert(f),
        None => Reflection::Bsdf(Glossy::new(bsdf, n, wi)),
    };
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
        // K·f(v, ω)·cos θ/p(ω), p per radius (dΩ_R).
        let c = match &reflection {
            Reflection::Lambert(f) => *k * *f * (cos / pdf),
            Reflection::Bsdf(g) => *k * g.eval(w) / pdf,
        };
        if finite_rgb(c) {
            total += c;
        } else {
            scene.dropped.add();
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
