//! Exact tube lights (`--cylinders exact`): a `cylinder` with an `area` emitter rendered as the
//! cylinder it is, with no R → 0 limit (docs/cylinders.md).
//!
//! The light is Mitsuba's cylinder: the side surface of radius R around p0 → p1, **no caps**,
//! normals outward, emitting radiance L = K/R from the outer side only (the inner side is
//! black) and opaque to shadow rays, as any other shape. With `hide_emitters = false` the
//! camera sees L where its ray meets the outer side first and black where it meets the inner
//! side; with `hide_emitters = true` camera rays pass through tubes, as Mitsuba 3's `direct`
//! integrator ignores emitters for camera rays then (a camera ray aimed at a tube resting on a
//! floor returns the floor's radiance behind it).
//!
//! Per light and iteration at a shading point x with normal n, the estimate of
//! ∫ L·f(v, ω)·max(0, n·ω)·V(ω) dΩ over the directions that meet the tube's outer side first:
//! - an emitter sample ω_e of the cylinder technique, density p_e per steradian over the side
//!   x sees ([`linlight_sampling::cylinder`]), shadow-traced to its point on the tube;
//! - with MIS, a BSDF-side sample ω_b from the cosine-weighted hemisphere of n,
//!   p_b = max(0, n·ω)/π: it counts where it meets the side x sees, shadow-traced to its point
//!   there like the emitter sample. The hit is decided from x in f64 (the emitter techniques'
//!   own geometry), not by a ray from x's pushed-off origin: the two must agree exactly on the
//!   domain they cover, or MIS is biased where the push-off is comparable with R (thin tubes).
//!
//! Both are weighted by the balance heuristic w_e = p_e/(p_e + p_b), w_b = p_b/(p_e + p_b), so
//! each contributes L·f·cos/(p_e + p_b); without MIS the emitter sample has weight 1. The
//! emitter techniques are positive on every direction above the horizon that meets the visible
//! side, and p_b on every direction above the horizon, so both estimators are unbiased for every
//! R > 0 (the integrand is bounded: no R → 0 argument enters).
//!
//! Random numbers per light and iteration: ξ₀, ξ₁ for the emitter sample, then (MIS) ξ₂, ξ₃ for
//! the BSDF-side sample, drawn whether or not the light contributes.
//!
//! Shadow rays toward light j end (1 − `SHADOW_EPSILON`) of the way to their point on the tube
//! and ignore light j's own cylinder: in exact arithmetic the segment from x to a point of the
//! side x faces meets the convex solid cylinder only at that point, but in f32 a ray near the
//! silhouette can graze it before. Every other tube occludes them.

use crate::hooks::EVAL_LANES;
use crate::options::{Cylinders, TubeSampling};
use crate::scene::Scene;
use crate::shapes::{Primitive, Ray, SurfacePoint};
use glam::{DVec3, Mat3, Vec3};
use linlight_sampling::cylinder::{Cylinder, CylinderSampler, CylinderView, PreparedCylinder};
use linlight_sampling::noise::Uniforms;

/// One tube light.
#[derive(Clone, Debug)]
pub struct Tube {
    /// The geometry in f64, for the samplers.
    pub cylinder: Cylinder,
    /// The same cylinder as a ray-traced primitive (`shape` unused).
    pub prim: Primitive,
    /// Radiance L = K/R per channel.
    pub radiance: Vec3,
    pub radius: f32,
}

/// The tubes of a scene's lights: `Some` per light rendered as a tube (exact mode, R > 0),
/// `None` for lights rendered as lines.
#[derive(Clone, Debug, Default)]
pub struct Tubes {
    pub tubes: Vec<Option<Tube>>,
    /// How tubes are sampled (exact mode).
    pub sampling: TubeSampling,
    /// Whether camera rays see the tubes' radiance (`hide_emitters = false`).
    pub camera_sees: bool,
    /// A tree over the tubes' boxes when there are more than [`INDEX_TUBES`]; private, so that
    /// only [`Tubes::indexed`] sets it (after a change of `tubes`, call it again).
    index: Option<TubeIndex>,
}

/// Above this many tubes a ray's tests go through a BVH over the tubes rather than every tube.
pub const INDEX_TUBES: usize = 16;

/// A BVH over the tubes' boxes and the light index of each of its primitives: the tubes a ray
/// may meet without testing every one. Queries are conservative (the boxes padded by 1e-5 of
/// the scene's scale), so they find every tube the exact test would hit.
#[derive(Clone, Debug)]
struct TubeIndex {
    bvh: crate::bvh::Bvh,
    light: Vec<usize>,
    pad: f64,
}

/// Padding of a tube index's boxes relative to the scene's scale: far above f32 rounding.
const BOX_PAD: f64 = 1e-5;

impl Tubes {
    /// The tubes of `scene` under `cylinders`: none under [`Cylinders::Line`]; every light with
    /// a positive finite radius and a usable segment otherwise.
    pub fn new(scene: &Scene, cylinders: Cylinders) -> Self {
        let Cylinders::Exact(sampling) = cylinders else {
            return Self::default();
        };
        let tubes = scene
            .lights
            .iter()
            .map(|l| {
                let r = l.radius;
                if !(r > 0.0 && r.is_finite()) {
                    return None;
                }
                let cylinder = Cylinder::from_f32(l.begin, l.end, r)?;
                let axis = l.end - l.begin;
                let length = axis.length();
                if !(length > 0.0 && length.is_finite()) {
                    return None;
                }
                Some(Tube {
                    cylinder,
                    prim: Primitive::Cylinder {
                        p0: l.begin,
                        axis: axis / length,
                        length,
                        radius: r,
                        shape: u32::MAX,
                    },
                    radiance: Vec3::from_array(l.radiance_times_radius) / r,
                    radius: r,
                })
            })
            .collect();
        Self {
            tubes,
            sampling,
            camera_sees: !scene.integrator.hide_emitters,
            index: None,
        }
        .indexed()
    }

    /// With an index over the tubes where there are more than [`INDEX_TUBES`] and every one has
    /// finite bounds; without one otherwise.
    pub fn indexed(mut self) -> Self {
        let tubes: Vec<(usize, &Tube)> = self
            .tubes
            .iter()
            .enumerate()
            .filter_map(|(j, t)| Some((j, t.as_ref()?)))
            .collect();
        self.index = None;
        if tubes.len() <= INDEX_TUBES {
            return self;
        }
        let scale = tubes.iter().fold(0.0f64, |m, (_, t)| {
            let b = t.prim.bounds();
            m.max(b.min.abs().max_element() as f64)
                .max(b.max.abs().max_element() as f64)
        });
        let light: Vec<usize> = tubes.iter().map(|&(j, _)| j).collect();
        let bvh = crate::bvh::Bvh::build(tubes.iter().map(|(_, t)| t.prim.clone()).collect());
        if bvh.len() == light.len() && scale.is_finite() {
            self.index = Some(TubeIndex {
                bvh,
                light,
                pad: BOX_PAD * (scale + 1.0),
            });
        }
        self
    }

    /// Calls `visit(j, tube)` for the tubes `ray` may meet in (t_min, t_max): every tube
    /// without an index, in light order; with one, a superset of those it meets, in no order,
    /// until `visit` returns true.
    #[inline]
    fn visit(&self, ray: &Ray, mut visit: impl FnMut(usize, &Tube) -> bool) {
        debug_assert!(
            self.index
                .as_ref()
                .is_none_or(|i| i.light.iter().all(|&j| j < self.tubes.len())),
            "a tube index of other tubes: call `indexed` after changing `tubes`"
        );
        let Some(index) = &self.index else {
            for (j, t) in self.tubes.iter().enumerate() {
                if let Some(t) = t {
                    if visit(j, t) {
                        return;
                    }
                }
            }
            return;
        };
        let done = std::cell::Cell::new(false);
        let segment = PaddedSegment::new(ray, index.pad);
        index.bvh.visit_overlapping(
            |lo, hi| !done.get() && segment.meets(lo, hi),
            |k, _| {
                let j = index.light[k as usize];
                if !done.get() {
                    if let Some(t) = &self.tubes[j] {
                        done.set(visit(j, t));
                    }
                }
            },
        );
    }

    /// Whether any light is a tube.
    pub fn any(&self) -> bool {
        self.tubes.iter().any(Option::is_some)
    }

    pub fn get(&self, j: usize) -> Option<&Tube> {
        self.tubes.get(j).and_then(Option::as_ref)
    }

    /// The closest tube `ray` meets in (t_min, t_max): its distance, light index and whether
    /// the ray meets its outer (emitting) side. Of tubes at the same distance, the first
    /// light's (as a test of every tube in light order gives, each shortening the ray to its
    /// hit).
    pub fn closest(&self, ray: &Ray) -> Option<(f32, usize, bool)> {
        let mut best: Option<(f32, usize, bool)> = None;
        self.visit(ray, |j, tube| {
            // Up to and including the best distance so far, for the tie rule.
            let mut r = *ray;
            if let Some((t, _, _)) = best {
                r.t_max = t.next_up();
            }
            if let Some((t, _, _)) = tube.prim.intersect(&r) {
                if best.is_none_or(|(b, k, _)| t < b || (t == b && j < k)) {
                    best = Some((t, j, outside(&tube.prim, &r, t)));
                }
            }
            false
        });
        best
    }

    /// Whether a tube other than light `except`'s meets `ray` in (t_min, t_max).
    pub fn occluded(&self, ray: &Ray, except: usize) -> bool {
        let mut hit = false;
        self.visit(ray, |j, t| {
            hit = j != except && t.prim.intersect(ray).is_some();
            hit
        });
        hit
    }
}

/// A ray's interval (t_min, t_max), widened by a spatial padding, for conservative box tests.
struct PaddedSegment {
    o: DVec3,
    inv_d: DVec3,
    t_min: f64,
    t_max: f64,
    pad: f64,
}

impl PaddedSegment {
    fn new(ray: &Ray, pad: f64) -> Self {
        let d = ray.d.as_dvec3();
        // The spatial padding as a distance along the ray.
        let t_pad = pad / d.length();
        Self {
            o: ray.o.as_dvec3(),
            inv_d: d.recip(),
            t_min: ray.t_min as f64 - t_pad,
            t_max: ray.t_max as f64 + t_pad,
            pad,
        }
    }

    /// Whether the widened interval of the ray meets the box [lo, hi] grown by the padding
    /// (slabs; an axis the ray runs along constrains nothing unless the origin lies outside).
    fn meets(&self, lo: Vec3, hi: Vec3) -> bool {
        let (lo, hi) = (lo.as_dvec3() - self.pad, hi.as_dvec3() + self.pad);
        let (mut near, mut far) = (self.t_min, self.t_max);
        for a in 0..3 {
            let inv = self.inv_d[a];
            if inv.is_infinite() || inv.is_nan() {
                if self.o[a] < lo[a] || self.o[a] > hi[a] {
                    return false;
                }
                continue;
            }
            let (t0, t1) = ((lo[a] - self.o[a]) * inv, (hi[a] - self.o[a]) * inv);
            near = near.max(t0.min(t1));
            far = far.min(t0.max(t1));
        }
        near <= far
    }
}

/// Whether the ray meets the cylinder's outer side at distance t (the radial normal faces it).
fn outside(prim: &Primitive, ray: &Ray, t: f32) -> bool {
    let Primitive::Cylinder { p0, axis, .. } = *prim else {
        return false;
    };
    let p = (ray.o + t * ray.d - p0).as_dvec3();
    let a = axis.as_dvec3();
    let radial = p - p.dot(a) * a;
    radial.dot(ray.d.as_dvec3()) < 0.0
}

/// A unit direction from the cosine-weighted hemisphere of unit `n` for (u1, u2), and its
/// density max(0, n·ω)/π per steradian ([`CosineFrame::sample`] in the frame of `n`).
#[inline]
pub fn cosine_hemisphere(n: Vec3, u1: f32, u2: f32) -> (DVec3, f32) {
    CosineFrame::new(n).sample(u1, u2)
}

/// The frame of the cosine-weighted hemisphere of a unit normal n: n in f64 and glam's
/// orthonormal pair completing it, formed once per shading point.
#[derive(Clone, Copy, Debug)]
pub struct CosineFrame {
    n: DVec3,
    t: DVec3,
    bt: DVec3,
}

impl CosineFrame {
    /// The frame of unit `n`.
    #[inline]
    pub fn new(n: Vec3) -> Self {
        let n = n.as_dvec3();
        let (t, bt) = n.any_orthonormal_pair();
        Self { n, t, bt }
    }

    /// A unit direction from the cosine-weighted hemisphere of n for (u1, u2), and its density
    /// max(0, n·ω)/π per steradian. Shirley and Chiu's concentric map of the square onto the
    /// disk (area-preserving), lifted to the hemisphere, in f64: near n the directions keep the
    /// resolution of u (≈ 1e-7 rad), where the polar map's rings √u1 are 2.4e-4 rad wide at the
    /// first step of an f32 u1, wider than a thin tube seen along n.
    #[inline]
    pub fn sample(&self, u1: f32, u2: f32) -> (DVec3, f32) {
        let (a, b) = (
            2.0 * u1.clamp(0.0, 1.0) as f64 - 1.0,
            2.0 * u2.clamp(0.0, 1.0) as f64 - 1.0,
        );
        let (r, phi) = if a == 0.0 && b == 0.0 {
            (0.0, 0.0)
        } else if a.abs() > b.abs() {
            (a, std::f64::consts::FRAC_PI_4 * (b / a))
        } else {
            (
                b,
                std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / b),
            )
        };
        let (s, c) = phi.sin_cos();
        let (x, y) = (r * c, r * s);
        let z = (1.0 - x * x - y * y).max(0.0).sqrt();
        let (n, t, bt) = (self.n, self.t, self.bt);
        let w = (x * t + y * bt + z * n).normalize();
        (w, (n.dot(w).max(0.0) * std::f64::consts::FRAC_1_PI) as f32)
    }
}

/// A light sample of one iteration of the tube estimator before visibility: the unit world
/// direction toward the tube, the distance to its point on the visible side, and the
/// contribution L·f·cos/p (balance heuristic: p = p_e + p_b) it adds when that point is visible.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TubeCandidate {
    pub w: Vec3,
    pub dist: f32,
    pub c: Vec3,
}

/// The cylinder technique prepared at a shading point: `None` where the point sees no front
/// face or the technique has nothing to sample (no candidates then).
pub struct PreparedTube {
    /// The technique, which holds the view of the tube from the point.
    technique: PreparedCylinder,
    /// The reflecting normal.
    n: Vec3,
    /// With MIS: what the BSDF-side samples need of the point, formed once for its iterations.
    bsdf_side: Option<(CosineFrame, AzimuthPretest)>,
}

impl PreparedTube {
    /// The technique of `sampling` prepared for `tube` at point `p` with reflecting normal `n`
    /// (the normal of the candidates); `lobe`: the shading frame and LTC matrix of the
    /// surface's glossy lobe ([`ShadingPoint::ltc_lobe`](crate::shading::ShadingPoint::ltc_lobe);
    /// only the technique `ltc` uses it, which is `projected` without it).
    #[inline]
    pub fn new(
        tube: &Tube,
        sampling: TubeSampling,
        p: Vec3,
        n: Vec3,
        lobe: Option<(Mat3, Mat3)>,
    ) -> Option<Self> {
        let view = CylinderView::from_f32(&tube.cylinder, p, n)?;
        let lobe = lobe.map(|(f, a)| (f.as_dmat3(), a.as_dmat3()));
        let technique = sampling.technique.prepare_with_lobe(&view, lobe)?;
        let bsdf_side = sampling
            .mis
            .then(|| (CosineFrame::new(n), AzimuthPretest::new(technique.view())));
        Some(Self {
            technique,
            n,
            bsdf_side,
        })
    }

    /// One iteration's candidates (module documentation) for the numbers `xi` (emitter sample)
    /// and `xi_b` (the BSDF-side sample, with MIS): the emitter sample's, then the BSDF-side
    /// sample's. `eval(ω)`: f·max(0, n·ω); `radiance`: L (or L/p_j). The arithmetic of
    /// [`estimate`], which sums the visible ones.
    #[inline]
    pub fn candidates(
        &self,
        radiance: Vec3,
        xi: [f32; 2],
        xi_b: Option<(f32, f32)>,
        eval: &impl Fn(Vec3) -> Vec3,
    ) -> [Option<TubeCandidate>; 2] {
        self.weighted(xi, xi_b)
            .map(|s| s.and_then(|s| s.candidate(radiance, eval(s.w))))
    }

    /// [`Self::candidates`] before the BSDF: the emitter sample and the BSDF-side sample with
    /// the denominators of their contributions, `None` where density, cosine, azimuth or
    /// distance rule them out. `xi_b` is given exactly when the sampling combines by MIS.
    #[inline]
    pub fn weighted(&self, xi: [f32; 2], xi_b: Option<(f32, f32)>) -> [Option<TubeSample>; 2] {
        let (technique, n) = (&self.technique, self.n);
        let mis = self.bsdf_side.is_some();
        debug_assert_eq!(xi_b.is_some(), mis, "BSDF-side numbers exactly with MIS");
        let mut out = [None, None];
        // The emitter sample.
        if let Some(sample) = technique.sample_toward(xi) {
            let (p_e, w) = (sample.pdf, sample.dir.as_vec3());
            let cos = n.dot(w);
            if p_e > 0.0 && p_e.is_finite() && cos > 0.0 {
                if let Some(dist) = distance_f32(sample.distance) {
                    let denominator = if mis {
                        p_e as f32 + cos * std::f32::consts::FRAC_1_PI
                    } else {
                        p_e as f32
                    };
                    out[0] = Some(TubeSample {
                        w,
                        dist,
                        denominator,
                    });
                }
            }
        }
        // The BSDF-side sample.
        let (Some((u1, u2)), Some((frame, pretest))) = (xi_b, self.bsdf_side) else {
            return out;
        };
        let (dir, p_b) = frame.sample(u1, u2);
        if !(p_b > 0.0) {
            return out;
        }
        if pretest.misses(technique.view(), dir) {
            return out;
        }
        let w = dir.as_vec3();
        let Some((p_e, dist)) = technique.pdf_toward(dir) else {
            return out;
        };
        let Some(dist) = distance_f32(dist) else {
            return out;
        };
        out[1] = Some(TubeSample {
            w,
            dist,
            denominator: p_e as f32 + p_b,
        });
        out
    }
}

/// A light sample of the tube estimator before the BSDF: direction, distance, and the
/// denominator of its contribution L·f·cos/denominator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TubeSample {
    pub w: Vec3,
    pub dist: f32,
    pub denominator: f32,
}

impl TubeSample {
    /// The candidate with f·cos = `f` (L·f/denominator), `None` where f·cos is zero.
    #[inline(always)]
    pub fn candidate(&self, radiance: Vec3, f: Vec3) -> Option<TubeCandidate> {
        (f != Vec3::ZERO).then(|| TubeCandidate {
            w: self.w,
            dist: self.dist,
            c: radiance * f / self.denominator,
        })
    }
}

/// Σ over `samples` iterations (not divided) of the tube estimate of light j (module
/// documentation) at `sp` with reflecting normal `n`; `radiance` is L (or L/p_j when the light
/// was chosen with probability p_j). `eval(ω)`: f·max(0, n·ω) of a unit world direction.
/// `visible(ω, dist)`: the tube point along ω at distance `dist` is not occluded (by the scene
/// or another tube).
/// Non-finite contributions are counted in `dropped` and left out.
/// `lobe`: as for [`PreparedTube::new`].
#[allow(clippy::too_many_arguments)]
pub fn estimate(
    tube: &Tube,
    sampling: TubeSampling,
    sp: &SurfacePoint,
    n: Vec3,
    lobe: Option<(Mat3, Mat3)>,
    radiance: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    eval: &impl Fn(Vec3) -> Vec3,
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    dropped: &mut u32,
) -> Vec3 {
    let prepared = PreparedTube::new(tube, sampling, sp.p, n, lobe);
    let mut total = Vec3::ZERO;
    for _ in 0..samples {
        let (xi, xi_b) = iteration_numbers(sampling.mis, rng);
        let Some(prepared) = &prepared else {
            continue;
        };
        for c in prepared
            .candidates(radiance, xi, xi_b, eval)
            .into_iter()
            .flatten()
        {
            if visible(c.w, c.dist) {
                crate::shading::add_finite(&mut total, dropped, c.c);
            }
        }
    }
    total
}

/// [`estimate`] with f·cos of up to [`EVAL_LANES`] directions at once: `eval_lanes(ω, len)`
/// returns f·max(0, n·ω) of the first `len` unit world directions of ω, each bit for bit
/// `eval` of [`estimate`]. Per chunk of iterations, each draws its numbers and weighs its
/// samples ([`PreparedTube::weighted`]), then f·cos is evaluated on all of them, then the
/// candidates are shadow-tested and added in the order of [`estimate`]: the same numbers,
/// shadow rays, sums and bits.
#[allow(clippy::too_many_arguments)]
pub fn estimate_lanes(
    tube: &Tube,
    sampling: TubeSampling,
    sp: &SurfacePoint,
    n: Vec3,
    lobe: Option<(Mat3, Mat3)>,
    radiance: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    eval_lanes: &impl Fn(&[Vec3; EVAL_LANES], usize) -> [Vec3; EVAL_LANES],
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    dropped: &mut u32,
) -> Vec3 {
    let prepared = PreparedTube::new(tube, sampling, sp.p, n, lobe);
    let iterations = if sampling.mis {
        EVAL_LANES / 2
    } else {
        EVAL_LANES
    };
    let mut total = Vec3::ZERO;
    let mut left = samples as usize;
    while left > 0 {
        let chunk = left.min(iterations);
        left -= chunk;
        let mut weighted = [None; EVAL_LANES];
        let mut w = [Vec3::Z; EVAL_LANES];
        let mut len = 0;
        for _ in 0..chunk {
            let (xi, xi_b) = iteration_numbers(sampling.mis, rng);
            let Some(prepared) = &prepared else {
                continue;
            };
            for s in prepared.weighted(xi, xi_b).into_iter().flatten() {
                (w[len], weighted[len]) = (s.w, Some(s));
                len += 1;
            }
        }
        if len == 0 {
            continue;
        }
        let f = eval_lanes(&w, len);
        for (s, f) in weighted.iter().zip(f).take(len) {
            let Some(c) = s.and_then(|s| s.candidate(radiance, f)) else {
                continue;
            };
            if visible(c.w, c.dist) {
                crate::shading::add_finite(&mut total, dropped, c.c);
            }
        }
    }
    total
}

/// One iteration's numbers, in the order every estimator of a tube draws them: ξ of the
/// light-side sample, then with MIS the BSDF-side pair.
#[inline(always)]
fn iteration_numbers(mis: bool, rng: &mut impl Uniforms) -> ([f32; 2], Option<(f32, f32)>) {
    let xi = [rng.next_f32(), rng.next_f32()];
    let xi_b = mis.then(|| (rng.next_f32(), rng.next_f32()));
    (xi, xi_b)
}

/// Whether `dir` misses the visible side by its azimuth α for certain ([`AzimuthPretest`]).
#[cfg(test)]
fn misses_in_azimuth(view: &CylinderView, dir: DVec3) -> bool {
    AzimuthPretest::new(view).misses(view, dir)
}

/// The azimuth pre-test of the BSDF-side samples at one shading point: whether a direction
/// misses the visible side by its azimuth α for certain, without the arctangents of
/// [`CylinderView::hit`] (most BSDF-side samples miss a tube): where the side spans at most
/// ±45° (R ≤ √(ρ² − R²), so tan α_max ≤ 1), a direction with n·ĉ < 0, or with |tan α| more
/// than twice tan α_max, has |α| ≥ atan(2 tan α_max) > 1.3 α_max, beyond any rounding of the
/// angles `hit` compares: `hit` returns `None` for it too.
#[derive(Clone, Copy, Debug)]
struct AzimuthPretest {
    /// √(ρ² − R²) where the side spans at most ±45°, NaN (no test) otherwise.
    tangent: f64,
}

impl AzimuthPretest {
    #[inline]
    fn new(view: &CylinderView) -> Self {
        let (r, rho) = (view.radius, view.rho);
        let tangent = ((rho - r) * (rho + r)).sqrt();
        Self {
            tangent: if r <= tangent { tangent } else { f64::NAN },
        }
    }

    /// Whether `dir` misses the side of `view` (the view of [`Self::new`]) by its azimuth;
    /// `false` where the test does not apply (also for NaN).
    #[inline]
    fn misses(&self, view: &CylinderView, dir: DVec3) -> bool {
        let tangent = self.tangent;
        if tangent.is_nan() {
            return false;
        }
        let (dc, dw) = (dir.dot(view.c), dir.dot(view.w));
        dc < 0.0 || (dc == 0.0 && dw != 0.0) || dw.abs() * tangent > 2.0 * view.radius * dc
    }
}

/// A distance along a direction to the visible side in f32; `None` unless positive and finite.
#[inline]
fn distance_f32(distance: f64) -> Option<f32> {
    let dist = distance as f32;
    (dist > 0.0 && dist.is_finite()).then_some(dist)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene_builder::{floor, light, scene, sensor};
    use linlight_sampling::cylinder::CylinderTechnique;
    use linlight_sampling::philox::CounterRng;
    use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
    use linlight_sampling::Segment;
    use linlight_verify::z_score::{normal_two_sided_quantile, sidak};

    /// Ground truth ∫ max(0, n·ω) dΩ over the side x sees: Gauss–Legendre in the surface angle
    /// (16 panels × 24 nodes), the elevation in closed form.
    fn projected_solid_angle(cyl: &Cylinder, x: Vec3, n: Vec3) -> f64 {
        let view = CylinderView::from_f32(cyl, x, n).unwrap();
        let nodes: Vec<(f64, f64)> = linlight_quadrature::GaussLegendre::new(24)
            .points()
            .collect();
        view.projected_solid_angle_quadrature(16, &nodes)
    }

    fn surface_point(p: Vec3, n: Vec3) -> SurfacePoint {
        SurfacePoint {
            p,
            ng: n,
            ns: n,
            shape: 0,
        }
    }

    fn tube(p0: Vec3, p1: Vec3, r: f32, l: f32) -> Tube {
        let axis = p1 - p0;
        Tube {
            cylinder: Cylinder::from_f32(p0, p1, r).unwrap(),
            prim: Primitive::Cylinder {
                p0,
                axis: axis.normalize(),
                length: axis.length(),
                radius: r,
                shape: u32::MAX,
            },
            radiance: Vec3::splat(l),
            radius: r,
        }
    }

    /// (mean, standard error) of `n` one-iteration estimates with a white stream of `seed`,
    /// f·cos = ρ/π (n·ω)⁺ with ρ = 0.5.
    fn mean_and_error(
        t: &Tube,
        sampling: TubeSampling,
        x: Vec3,
        nrm: Vec3,
        n: u32,
        seed: u64,
    ) -> (f64, f64) {
        let f = 0.5 * std::f32::consts::FRAC_1_PI;
        let eval = |w: Vec3| Vec3::splat(f * nrm.dot(w).max(0.0));
        mean_and_error_of(t, sampling, (x, nrm, None), &eval, n, seed)
    }

    /// [`mean_and_error`] with a glossy lobe (frame, A) and f·cos = `eval`.
    fn mean_and_error_of(
        t: &Tube,
        sampling: TubeSampling,
        (x, nrm, lobe): (Vec3, Vec3, Option<(Mat3, Mat3)>),
        eval: &dyn Fn(Vec3) -> Vec3,
        n: u32,
        seed: u64,
    ) -> (f64, f64) {
        let sp = surface_point(x, nrm);
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        let mut dropped = 0;
        for i in 0..n {
            let mut rng = CounterRng::camera_sample(seed, 0, i, 0);
            let e = estimate(
                t,
                sampling,
                &sp,
                nrm,
                lobe,
                t.radiance,
                1,
                &mut rng,
                &eval,
                &mut |_, _| true,
                &mut dropped,
            )
            .x as f64;
            sum += e;
            sum2 += e * e;
        }
        assert_eq!(dropped, 0);
        let mean = sum / n as f64;
        let var = (sum2 / n as f64 - mean * mean).max(0.0) * n as f64 / (n - 1) as f64;
        (mean, (var / n as f64).sqrt())
    }

    /// The configurations of the unbiasedness test: (tube, shading point, normal). Fat
    /// (R = 0.3 × the distance), thin (R = 1e-4 × the distance), close beside the tube
    /// (ρ = 1.05 R), and a tube crossing the tangent plane.
    fn configs() -> Vec<(Tube, Vec3, Vec3)> {
        let v = Vec3::new;
        vec![
            (
                tube(v(-1.0, 0.2, 1.0), v(1.5, -0.3, 1.2), 0.3, 2.0),
                Vec3::ZERO,
                v(0.3, -0.2, 1.0).normalize(),
            ),
            (
                tube(v(-1.0, 0.0, 1.0), v(1.0, 0.0, 1.0), 1e-4, 1e4),
                Vec3::ZERO,
                Vec3::Z,
            ),
            (
                tube(v(-1.0, 0.0, 0.42), v(1.0, 0.0, 0.42), 0.4, 1.0),
                Vec3::ZERO,
                Vec3::Z,
            ),
            (
                tube(v(-1.0, 0.5, -0.6), v(1.0, 0.3, 0.9), 0.2, 1.0),
                Vec3::ZERO,
                Vec3::Z,
            ),
        ]
    }

    fn samplings() -> Vec<TubeSampling> {
        let mut v = Vec::new();
        for technique in CylinderTechnique::ALL {
            for mis in [false, true] {
                v.push(TubeSampling { technique, mis });
            }
        }
        v
    }

    /// The index finds what testing every tube finds: the same closest tube (distance, light,
    /// side) and the same occlusion, on rays from random origins through a field of 40
    /// crossing tubes (shadow segments and rays to infinity), many aimed near their axes.
    #[test]
    fn the_index_answers_as_every_tube_does() {
        let mut rng = CounterRng::camera_sample(9, 0, 0, 0);
        let mut u = || rng.next_f32();
        let tubes: Vec<Option<Tube>> = (0..40)
            .map(|_| {
                let p0 = Vec3::new(4.0 * u() - 2.0, 4.0 * u() - 2.0, 1.0 + u());
                let p1 = p0 + Vec3::new(2.0 * u() - 1.0, 2.0 * u() - 1.0, 0.5 * u() - 0.25);
                Some(tube(p0, p1, 0.2 * u() * u() + 1e-4, 1.0))
            })
            .collect();
        let all = Tubes {
            tubes,
            sampling: TubeSampling::default(),
            camera_sees: true,
            index: None,
        };
        let indexed = all.clone().indexed();
        assert!(indexed.index.is_some());
        let (mut hits, mut blocked) = (0, 0);
        for i in 0..20_000u32 {
            let mut rng = CounterRng::camera_sample(11, 0, i, 0);
            let mut u = || rng.next_f32();
            let o = Vec3::new(6.0 * u() - 3.0, 6.0 * u() - 3.0, 3.0 * u() - 0.5);
            // Toward a point on some tube's axis (a hit or a near miss), or anywhere.
            let target = match all.tubes[i as usize % 40].as_ref() {
                Some(t) if i % 3 != 0 => {
                    let (a, b) = (t.cylinder.p0().as_vec3(), t.cylinder.p1().as_vec3());
                    a + u() * (b - a) + 0.3 * (Vec3::new(u(), u(), u()) - 0.5)
                }
                _ => Vec3::new(6.0 * u() - 3.0, 6.0 * u() - 3.0, 3.0 * u()),
            };
            let d = target - o;
            let t_max = if i % 2 == 0 { 1.0 } else { f32::INFINITY };
            let ray = Ray {
                o,
                d,
                t_min: 1e-4,
                t_max,
            };
            let closest = all.closest(&ray);
            assert_eq!(indexed.closest(&ray), closest, "ray {i}");
            let except = i as usize % 41; // 40: no tube excepted
            let occluded = all.occluded(&ray, except);
            assert_eq!(indexed.occluded(&ray, except), occluded, "ray {i}");
            hits += usize::from(closest.is_some());
            blocked += usize::from(occluded);
        }
        assert!(hits > 5_000 && blocked > 5_000, "{hits} {blocked}");
    }

    /// A glossy lobe at x: the GGX LTC table's A for α = 0.25 seen from a view mirrored about
    /// n from the tube's middle (raised to n·v ≥ 0.3), in its shading frame.
    fn glossy_lobe(t: &Tube, x: Vec3, n: Vec3) -> (Mat3, Mat3) {
        let mid = (0.5 * (t.cylinder.p0() + t.cylinder.p1())).as_vec3();
        let d = (mid - x).normalize();
        let mirror = 2.0 * n.dot(d) * n - d;
        let tangent = mirror - n.dot(mirror) * n;
        let wi = (tangent + n.dot(mirror).max(0.3) * n).normalize();
        let (frame, v) = crate::shading::shading_frame(n, wi);
        let (a, _) = linlight_brdf::ltc::GgxLtcTable::ggx().lookup(0.25, v.z as f32);
        (frame, a)
    }

    /// Unbiased against the quadrature of L·(ρ/π)·Ω⊥ for every technique with and without MIS
    /// (so MIS and no MIS agree), at R = 0.3 × and 1e-4 × the distance, beside the tube and
    /// with the tube crossing the tangent plane; and `ltc` with a glossy lobe (GGX LTC table,
    /// α = 0.25) against L·∫ (0.05 (n·ω)⁺/π + D(ω)) dΩ, D the LTC lobe (closed-form slice
    /// masses; the diffuse part is where the defensive branch matters). |z| of 40 000
    /// estimates within the two-sided normal quantile at α = 0.01, Šidák over the 48 tests
    /// (5 techniques × MIS on/off × 4 configurations, and `ltc` glossy × MIS on/off × 4:
    /// |z| ≤ 3.71). A pdf 1 % too large in the estimate (the negative control, the thin tube,
    /// where the variance is smallest) is rejected.
    #[test]
    fn the_estimate_is_unbiased_for_every_technique_and_radius() {
        let cases = configs();
        let tests = cases.len() * (samplings().len() + 2);
        let z_max = normal_two_sided_quantile(sidak(0.01, tests));
        assert!((z_max - 3.71).abs() < 0.01, "{z_max}");
        for (k, (t, x, n)) in cases.iter().enumerate() {
            let truth = t.radiance.x as f64
                * 0.5
                * std::f64::consts::FRAC_1_PI
                * projected_solid_angle(&t.cylinder, *x, *n);
            for (m, s) in samplings().into_iter().enumerate() {
                let (mean, se) = mean_and_error(t, s, *x, *n, 40_000, 100 * k as u64 + m as u64);
                // The floor of the standard error: f32 rounding of one estimate (1e-6 relative).
                let z = (mean - truth) / se.max(1e-6 * truth);
                assert!(
                    z.abs() <= z_max,
                    "case {k}, {s:?}: mean {mean} ± {se}, truth {truth}, z = {z}"
                );
                if k == 1 && s == TubeSampling::default() {
                    let z_control = (mean / 1.01 - truth) / (se / 1.01).max(1e-6 * truth);
                    assert!(
                        z_control.abs() > z_max,
                        "control not rejected: z = {z_control}"
                    );
                }
            }
            glossy_case(k, (t, *x, *n), z_max);
        }
    }

    /// The glossy rows of [`the_estimate_is_unbiased_for_every_technique_and_radius`].
    fn glossy_case(k: usize, (t, x, n): (&Tube, Vec3, Vec3), z_max: f64) {
        let lobe = glossy_lobe(t, x, n);
        let view = CylinderView::from_f32(&t.cylinder, x, n).unwrap();
        let (frame, a) = (lobe.0.as_dmat3(), lobe.1.as_dmat3());
        let ltc = linlight_sampling::cylinder::CylinderLtc::new(&view, frame, a).unwrap();
        let kd = 0.05 * std::f64::consts::FRAC_1_PI;
        let eval = |w: Vec3| {
            let d = w.as_dvec3();
            Vec3::splat((kd * n.as_dvec3().dot(d).max(0.0) + ltc.lobe_density(d)) as f32)
        };
        let nodes: Vec<(f64, f64)> = linlight_quadrature::GaussLegendre::new(24)
            .points()
            .collect();
        let panels = 64;
        let width = 2.0 * view.theta_max / panels as f64;
        let mut lobe_mass = 0.0;
        for p in 0..panels {
            for &(y, wt) in &nodes {
                let theta = -view.theta_max + width * (p as f64 + 0.5 * (y + 1.0));
                let (alpha, jac) = view.alpha_of_theta(theta);
                lobe_mass += 0.5 * width * wt * jac * ltc.slice_lobe_mass(alpha);
            }
        }
        let truth =
            t.radiance.x as f64 * (kd * projected_solid_angle(&t.cylinder, x, n) + lobe_mass);
        for mis in [false, true] {
            let s = TubeSampling {
                technique: CylinderTechnique::Ltc,
                mis,
            };
            let seed = 7000 + 10 * k as u64 + mis as u64;
            let (mean, se) = mean_and_error_of(t, s, (x, n, Some(lobe)), &eval, 40_000, seed);
            let z = (mean - truth) / se.max(1e-6 * truth);
            assert!(
                z.abs() <= z_max,
                "case {k}, glossy {s:?}: mean {mean} ± {se}, truth {truth}, z = {z}"
            );
        }
    }

    /// As R → 0 with K = L·R fixed the tube's unshadowed light approaches the line limit's,
    /// K·Ω⊥_R (ProjectedSolidAngle's projected solid angle per radius), at first order in R:
    /// the relative difference divided by R stays of order 1 and changes little from
    /// R = 1e-2 to 1e-4 (a slope of 1 on a log–log plot).
    #[test]
    fn exact_tubes_approach_the_line_at_first_order() {
        let (p0, p1) = (Vec3::new(-1.0, 0.2, 1.0), Vec3::new(1.2, -0.3, 1.1));
        let (x, n) = (
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.2, 0.1, 1.0).normalize(),
        );
        let line = ProjectedSolidAngle::prepare(&Segment::new(p0, p1), x, n)
            .unwrap()
            .projected_solid_angle() as f64;
        let mut coefficient = Vec::new();
        for r in [1e-2f32, 1e-3, 1e-4] {
            let cyl = Cylinder::from_f32(p0, p1, r).unwrap();
            // L = K/R with K = 1: L·Ω⊥ = Ω⊥/R.
            let exact = projected_solid_angle(&cyl, x, n) / r as f64;
            coefficient.push((exact - line) / line / r as f64);
        }
        for c in &coefficient {
            assert!(c.abs() > 1e-3 && c.abs() < 10.0, "{coefficient:?}");
        }
        let drift = (coefficient[0] - coefficient[2]).abs() / coefficient[2].abs();
        assert!(drift < 0.1, "{coefficient:?}");
    }

    /// Shadow rays toward points of the side x sees (area samples 0.05 R from the tube) are
    /// not blocked by the light's own cylinder, though in f32 some of them graze it near the
    /// silhouette; [`Tubes::occluded`] ignores the light it is asked about but not the others.
    #[test]
    fn shadow_rays_are_not_blocked_by_their_own_tube() {
        let (t, x, n) = configs().swap_remove(2);
        let sp = surface_point(x, n);
        let view = CylinderView::from_f32(&t.cylinder, x, n).unwrap();
        let technique = CylinderTechnique::Area.prepare(&view).unwrap();
        let other = tube(
            Vec3::new(-1.0, 0.0, 2.0),
            Vec3::new(1.0, 0.0, 2.0),
            0.1,
            1.0,
        );
        let tubes = Tubes {
            tubes: vec![Some(t.clone()), Some(other)],
            sampling: TubeSampling::default(),
            camera_sees: false,
            index: None,
        };
        let (mut checked, mut grazing) = (0, 0);
        for i in 0..2000u32 {
            let mut rng = CounterRng::camera_sample(5, 0, i, 0);
            let xi = [rng.next_f32(), rng.next_f32()];
            let Some(sample) = technique.sample_toward(xi) else {
                continue;
            };
            let (dir, dist) = (sample.dir, sample.distance as f32);
            let ray = crate::ray_offset::shadow_ray_to(&sp, x + dist * dir.as_vec3()).unwrap();
            grazing += t.prim.intersect(&ray).is_some() as u32;
            assert!(!tubes.occluded(&ray, 0), "sample {i} blocked");
            checked += 1;
        }
        assert!(checked > 1500, "{checked}");
        // In f32 some rays near the silhouette graze the own cylinder: the exclusion matters.
        assert!(grazing > 0, "no grazing ray among {checked}");
        let up = Ray {
            o: Vec3::ZERO,
            d: Vec3::Z,
            t_min: 0.0,
            t_max: 10.0,
        };
        assert!(!tubes.occluded(&up, 0) || tubes.occluded(&up, 1));
        assert!(tubes.occluded(&up, 0), "the other tube blocks");
        let short = Ray { t_max: 1.0, ..up };
        assert!(!tubes.occluded(&short, 0) && tubes.occluded(&short, 1));
        let (_, j, outside) = tubes.closest(&up).unwrap();
        assert!(j == 0 && outside);
    }

    /// The azimuth pre-test of the BSDF-side samples never rejects a direction `hit` accepts,
    /// and rejects most cosine-weighted directions toward a thin and a fat tube (where the side
    /// spans at most ±45°).
    #[test]
    fn the_azimuth_pretest_agrees_with_hit() {
        for (t, x, n) in configs() {
            let view = CylinderView::from_f32(&t.cylinder, x, n).unwrap();
            let (mut rejected, mut hits) = (0, 0);
            // Cosine-weighted directions, and directions near the silhouette azimuths.
            for i in 0..20_000u32 {
                let mut rng = CounterRng::camera_sample(9, 0, i, 0);
                let (u1, u2) = (rng.next_f32(), rng.next_f32());
                let dir = if i % 2 == 0 {
                    cosine_hemisphere(n, u1, u2).0
                } else {
                    let alpha = view.alpha_max * (2.0 * u1 as f64 - 1.0) * 2.5;
                    let phi = (2.0 * u2 as f64 - 1.0) * 1.5;
                    view.direction(alpha, phi)
                };
                let hit = view.hit(dir).is_some();
                let miss = misses_in_azimuth(&view, dir);
                assert!(!(hit && miss), "{dir:?}");
                rejected += miss as u32;
                hits += hit as u32;
            }
            let spans_45 = view.radius <= view.rho * std::f64::consts::FRAC_1_SQRT_2;
            assert!(!spans_45 || rejected > 5000, "{rejected} {hits}");
            assert!(hits > 0);
        }
    }

    /// A scene with a floor and one fat tube: the lights become tubes only under
    /// `--cylinders exact`, with L = K/R.
    #[test]
    fn tubes_follow_the_choice() {
        let v = Vec3::new;
        let mut l = light(v(-1.0, 0.0, 1.0), v(1.0, 0.0, 1.0), [0.2; 3]);
        l.radius = 0.1;
        let s = scene(
            sensor(v(0.0, -3.0, 1.0), Vec3::ZERO, Vec3::Z, 40.0, 8, 8),
            vec![floor(2.0, [0.5; 3])],
            vec![l],
        );
        assert!(!Tubes::new(&s, Cylinders::Line).any());
        let tubes = Tubes::new(&s, Cylinders::EXACT);
        assert!((tubes.get(0).unwrap().radiance.x - 2.0).abs() < 1e-6);
        assert!(!tubes.camera_sees);
    }
}
