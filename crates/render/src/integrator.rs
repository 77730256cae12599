//! Direct lighting from linear lights in the R → 0 limit (Mitsuba's `direct` integrator with
//! emitter sampling only).
//!
//! Per light, the estimator of the reflected radiance is K·f(v, ω)·max(0, n·ω)·V(ω)·w(ω)/p(ω),
//! where p is a technique's density per radius (dΩ_R), K = radiance × radius (the radius cancels
//! between the tube's solid angle R·Ω_R and its radiance K/R), f the surface's full BSDF
//! (`linlight_brdf::Bsdf::eval`, which includes the cosine) in the shading frame of the side
//! facing the viewer, and w the weight of the render's [`Method`] (1 for single techniques; see
//! [`crate::method`] and [`crate::shading`]). Each camera sample takes `light_samples` light
//! samples and their mean (Mitsuba's `emitter_samples`); what one light sample is depends on
//! the [`LightSelection`](crate::light_choice::LightSelection) of the render ([`crate::light_choice`]):
//! - `every` (default): every light, one after the other, each estimated with its own K.
//! - `one` (Mitsuba's estimator): one light j, chosen with probability p_j from an extra number
//!   ξ_c drawn first, estimated with K_j/p_j in place of K_j. A scene with one light draws no ξ_c
//!   (p = 1).
//! - `tree`: as `one`, with p_j(x, n) of the light tree at the shading point
//!   ([`crate::light_tree`]).
//!
//! Numbers of a camera sample that reaches a reflecting surface, after its film position:
//! `every`: light by light, each light's `light_samples` iterations ([`crate::shading`]: one
//! number per iteration, two for the two-technique methods on non-Lambertian surfaces);
//! `one` and `tree`: per light sample ξ_c (scenes with two or more lights), then the chosen light's
//! numbers of one iteration. Lambertian surfaces take the fast path f = ρ/π with one diffuse
//! technique (the single technique, or projected solid angle for the two-technique methods).

use crate::film::Welford;
use crate::frame::{metadata, pixel_entries, render_in_tiles};
use crate::hooks::{
    with_resolved, BsdfModel, Hooks, LightSampling, Resolved, SpecularSampling, EVAL_LANES,
};
use crate::light::Light;
use crate::method::Method;
use crate::options::{check_options, window, RenderError, RenderOptions, Window};
use crate::ray_offset::shadow_ray_to;
use crate::render_scene::{reflecting_normal, RenderScene};
use crate::scene::{Rgb, Scene};
use crate::shading::{estimate_resolved, single_technique, ShadingPoint};
use crate::shapes::{Hit, Ray, SurfacePoint};
use crate::visible_line::PixelLine;
use glam::Vec3;
use linlight_imagefile::{Image, Metadata};
use linlight_sampling::cylinder::CylinderTechnique;
use linlight_sampling::noise::{NoiseSource, SampleStream};
use linlight_simd::{get3, set3, splat3};

/// Σ estimate(j, light, K, iterations, rng) over the lights of the light samples: every light
/// with its K and `opts.light_samples` iterations, or ([`RenderScene::chooses_one`])
/// `opts.light_samples` times the light chosen by ξ_c (from shading point x with normal n),
/// with K/p and one iteration. This is the order of a camera sample's light numbers
/// ([`RenderScene::light_dimension`]).
#[inline(always)]
fn sum_over_light_samples(
    scene: &RenderScene,
    opts: &RenderOptions,
    (x, n): (Vec3, Vec3),
    rng: &mut SampleStream,
    mut estimate: impl FnMut(usize, &Light, Vec3, u32, &mut SampleStream) -> Vec3,
) -> Vec3 {
    let mut total = Vec3::ZERO;
    if scene.chooses_one(opts.lights) {
        for _ in 0..opts.light_samples {
            let xi = rng.next_f32_unstratified();
            let (j, k) = scene.choose_light(opts.lights, x, n, xi);
            total += estimate(j, &scene.lights[j], k, 1, rng);
        }
    } else {
        for (j, light) in scene.lights.iter().enumerate() {
            total += estimate(j, light, light.k(), opts.light_samples, rng);
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
    let hit = scene.bvh.intersect(ray);
    if scene.tubes.camera_sees {
        if let Some(rgb) = tube_in_front(scene, ray, hit.as_ref()) {
            return rgb;
        }
    }
    let Some(hit) = hit else {
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
    if scene.tubes.any() {
        return tube_radiance(scene, opts, pieces, bsdf, shape, &sp, n, wi, rng).to_array();
    }
    let mut dropped = 0u32;
    let total = match scene.lambert[shape] {
        Some(f) => lambertian_radiance(scene, opts, pieces.technique, f, &sp, n, rng, &mut dropped),
        None => {
            let point = ShadingPoint::for_method(pieces.bsdf, opts.method, bsdf, sp.p, n, wi);
            glossy_radiance(scene, opts, pieces, &point, &sp, n, rng, &mut dropped)
        }
    };
    if dropped > 0 {
        scene.dropped.add_many(dropped as u64);
    }
    total.to_array()
}

/// The radiance of a tube the camera ray meets in front of the first surface `hit`: its
/// radiance seen from outside, black inside; None when the ray meets no tube first. With
/// `hide_emitters` camera rays pass through tubes, as in Mitsuba's `direct`.
#[inline(always)]
fn tube_in_front(scene: &RenderScene, ray: &Ray, hit: Option<&Hit>) -> Option<Rgb> {
    let mut front = *ray;
    if let Some(h) = hit {
        front.t_max = h.t;
    }
    let (_, j, outside) = scene.tubes.closest(&front)?;
    Some(match scene.tubes.get(j) {
        Some(t) if outside && scene.tubes.camera_sees => t.radiance.to_array(),
        _ => [0.0; 3],
    })
}

/// Whether the point at distance `dist` along `w` from `sp` is visible: the shadow ray toward
/// light j walks its culled shadow BVH (same answers as `scene.bvh`).
#[inline(always)]
fn visible_toward<'a>(
    scene: &'a RenderScene,
    sp: &'a SurfacePoint,
    j: usize,
) -> impl FnMut(Vec3, f32) -> bool + 'a {
    move |w: Vec3, dist: f32| {
        shadow_ray_to(sp, sp.p + dist * w)
            .is_some_and(|shadow| !scene.shadows.occluded(&scene.bvh, j, &shadow))
    }
}

/// The fast path of a Lambertian surface (f = ρ/π): K·f·cos θ/p(ω) by one technique, p per
/// radius (dΩ_R); the mean over the light samples.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn lambertian_radiance<T: LightSampling>(
    scene: &RenderScene,
    opts: &RenderOptions,
    technique: &T,
    f: Vec3,
    sp: &SurfacePoint,
    n: Vec3,
    rng: &mut SampleStream,
    dropped: &mut u32,
) -> Vec3 {
    let mut total =
        sum_over_light_samples(scene, opts, (sp.p, n), rng, |j, light, k, samples, rng| {
            single_technique(
                light.sampler(technique, sp.p, n).as_ref(),
                n,
                samples,
                rng,
                &mut visible_toward(scene, sp, j),
                |_: Vec3, cos: f32, pdf: f32| k * f * (cos / pdf),
                dropped,
            )
        });
    if opts.light_samples > 1 {
        total /= opts.light_samples as f32;
    }
    total
}

/// A surface of any other BSDF, by the render's method at `point`. `every`: each light's
/// estimate is its iterations' mean; `one`: the mean of the light samples is taken here.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn glossy_radiance<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &RenderScene,
    opts: &RenderOptions,
    pieces: Resolved<T, S, B>,
    point: &ShadingPoint,
    sp: &SurfacePoint,
    n: Vec3,
    rng: &mut SampleStream,
    dropped: &mut u32,
) -> Vec3 {
    let mut total =
        sum_over_light_samples(scene, opts, (sp.p, n), rng, |j, light, k, samples, rng| {
            estimate_resolved(
                pieces,
                opts.method,
                point,
                light.segment(),
                k,
                samples,
                rng,
                &mut visible_toward(scene, sp, j),
                dropped,
            )
        });
    if scene.chooses_one(opts.lights) && opts.light_samples > 1 {
        total /= opts.light_samples as f32;
    }
    total
}

/// The light reflected at `sp` (reflecting normal `n`, toward `wi`) when some lights are exact
/// tubes ([`crate::tube`]): tube lights by the tube estimator, line lights as in [`radiance`]
/// (their shadow rays also stopped by tubes). The same numbers as [`radiance`] per line light;
/// per tube light those of [`crate::tube::estimate`].
#[allow(clippy::too_many_arguments)]
fn tube_radiance<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &RenderScene,
    opts: &RenderOptions,
    pieces: Resolved<T, S, B>,
    bsdf: &crate::scene::Bsdf,
    shape: usize,
    sp: &SurfacePoint,
    n: Vec3,
    wi: Vec3,
    rng: &mut SampleStream,
) -> Vec3 {
    let mut dropped = 0u32;
    let lambert = scene.lambert[shape];
    let point = ShadingPoint::for_method(pieces.bsdf, opts.method, bsdf, sp.p, n, wi);
    let eval = |w: Vec3| match lambert {
        Some(f) => f * n.dot(w).max(0.0),
        None => point.eval(pieces.bsdf, w),
    };
    // f·cos of the glossy BSDF for up to EVAL_LANES directions at once, each lane `eval`'s.
    let eval_lanes = |w: &[Vec3; EVAL_LANES], len: usize| {
        let mut l = splat3::<EVAL_LANES>(Vec3::Z);
        for (k, &w) in w.iter().enumerate().take(len) {
            set3(&mut l, k, point.local_f32(w));
        }
        let f = pieces.bsdf.eval_lanes(bsdf, point.v, &l, len);
        std::array::from_fn(|k| get3(&f, k))
    };
    let tubes = &scene.tubes;
    // The glossy lobe, looked up only for the technique that uses it.
    let lobe = match lambert {
        None if tubes.sampling.technique == CylinderTechnique::Ltc => point.ltc_lobe(pieces.bsdf),
        _ => None,
    };
    // The scene's full BVH: the shadow culling assumes targets on the light's segment.
    let bvh: &crate::bvh::Bvh = &scene.bvh;
    let visible = |j: usize| {
        move |w: Vec3, dist: f32| {
            shadow_ray_to(sp, sp.p + dist * w)
                .is_some_and(|shadow| !bvh.occluded(&shadow) && !tubes.occluded(&shadow, j))
        }
    };
    let light_samples = opts.light_samples;
    let one = scene.chooses_one(opts.lights);
    let total = sum_over_light_samples(scene, opts, (sp.p, n), rng, |j, light, k, samples, rng| {
        let Some(tube) = tubes.get(j) else {
            // A line light among tubes (a light of zero radius).
            let mut sum = match lambert {
                Some(f) => single_technique(
                    light.sampler(pieces.technique, sp.p, n).as_ref(),
                    n,
                    samples,
                    rng,
                    &mut visible(j),
                    |_: Vec3, cos: f32, pdf: f32| k * f * (cos / pdf),
                    &mut dropped,
                ),
                None => {
                    estimate_resolved(
                        pieces,
                        opts.method,
                        &point,
                        light.segment(),
                        k,
                        samples,
                        rng,
                        &mut visible(j),
                        &mut dropped,
                    ) * samples as f32
                }
            };
            if samples > 1 {
                sum /= samples as f32;
            }
            return sum;
        };
        // k is K (or K/p_j): L = k/R.
        let sum = if lambert.is_none() && samples > 1 {
            crate::tube::estimate_lanes(
                tube,
                tubes.sampling,
                sp,
                n,
                lobe,
                k / tube.radius,
                samples,
                rng,
                &eval_lanes,
                &mut visible(j),
                &mut dropped,
            )
        } else {
            crate::tube::estimate(
                tube,
                tubes.sampling,
                sp,
                n,
                lobe,
                k / tube.radius,
                samples,
                rng,
                &eval,
                &mut visible(j),
                &mut dropped,
            )
        };
        if samples > 1 {
            sum / samples as f32
        } else {
            sum
        }
    });
    if dropped > 0 {
        scene.dropped.add_many(dropped as u64);
    }
    if one && light_samples > 1 {
        total / light_samples as f32
    } else {
        total
    }
}

/// [`render`](crate::render::render) with replaced pieces ([`Hooks`]): the hook through which tests render with
/// deliberately wrong techniques, specular samplers or BSDF evaluations (power controls, see
/// `power_controls`, with the `test-support` feature). `opts.method` still chooses the estimator; the header records
/// the hooks (`technique` of a replaced technique, `specular_hook`, `bsdf_hook`). Always the
/// scalar path (the packet renderer's images equal it bit for bit where it applies).
pub fn render_scalar<D: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &Scene,
    opts: &RenderOptions,
    hooks: &Hooks<D, S, B>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    check_options(opts)?;
    let window = window(scene)?;
    let rs = RenderScene::with_cylinders(scene, opts.cylinders)?;
    render_scalar_window(scene, &rs, window, opts, hooks, progress)
}

/// [`render_scalar`] of the pixels `window` = (x0, y0, w, h) of `scene`'s film (a valid window)
/// with `rs`, its render scene with `opts.cylinders` ([`RenderScene::sharing`]).
pub(crate) fn render_scalar_window<D: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &Scene,
    rs: &RenderScene,
    window: Window,
    opts: &RenderOptions,
    hooks: &Hooks<D, S, B>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    check_options(opts)?;
    let mut image = with_resolved!(hooks, opts.method, |r| render_tiles(
        scene, rs, window, opts, r, progress
    ));
    let mut entries = Vec::new();
    if let (Some(t), Method::Technique(_)) = (&hooks.technique, opts.method) {
        entries.push(("technique", t.name()));
    }
    entries.extend(hooks.header());
    image.meta = metadata(opts, scene, std::mem::take(&mut image.meta.extra), entries);
    Ok(image)
}

/// The image of [`render_scalar_window`] with the pieces resolved; its header holds only the
/// pixels' entries ([`pixel_entries`]).
fn render_tiles<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &Scene,
    rs: &RenderScene,
    (x0, y0, w, h): Window,
    opts: &RenderOptions,
    pieces: Resolved<T, S, B>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Image {
    let full_width = scene.sensor.film.width;
    let noise = NoiseSource::new(opts.noise, opts.seed, opts.spp);
    let mut image = render_in_tiles(
        rs,
        opts,
        (x0, y0, w, h),
        progress,
        |pixels, seen, pass, single| {
            for (i, &(fx, fy)) in pixels.iter().enumerate() {
                // < 2^32: checked by `window`.
                let index = fy.wrapping_mul(full_width).wrapping_add(fx);
                single[i] =
                    render_pixel_pass(rs, opts, &noise, pieces, fx, fy, index, pass, &seen[i]);
            }
        },
    );
    image.meta = Metadata {
        extra: pixel_entries(scene, rs, (x0, y0, w, h)),
        ..Default::default()
    };
    image
}

/// The camera samples of one pixel (full-film coordinates) in one pass; `seen`: the lines the
/// camera sees in this pixel ([`VisibleLines::pixel`]).
#[allow(clippy::too_many_arguments)]
fn render_pixel_pass<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    rs: &RenderScene,
    opts: &RenderOptions,
    noise: &NoiseSource,
    pieces: Resolved<T, S, B>,
    fx: u32,
    fy: u32,
    index: u32,
    pass: u32,
    seen: &[PixelLine],
) -> Welford {
    let mut acc = Welford::default();
    for sample in 0..opts.spp {
        let mut rng = noise.stream(fx, fy, index, pass, sample);
        let (u, v) = rng.film_position();
        let ray = rs.camera.ray(fx as f32 + u, fy as f32 + v);
        let l = radiance(rs, opts, pieces, &ray, &mut rng);
        let l = if seen.is_empty() {
            l
        } else {
            let mut t = Vec3::from_array(l);
            rs.visible
                .add_estimate(seen, &rs.bvh, || rng.next_f64(), &mut t);
            t.to_array()
        };
        acc.push(l.map(|c| c as f64));
    }
    acc
}
