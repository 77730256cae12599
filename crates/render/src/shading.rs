//! Direct light of one linear light at one shading point: the estimators of every
//! [`Method`], written once as scalar code that the integrator calls per light. Each
//! iteration is split at the shadow ray — [`single_sample`] and [`TwoTechniqueLight::candidates`]
//! return the samples that can contribute before visibility is known — so that the batched
//! renderer (`crate::packet`) runs the same code lane by lane and traces the shadow rays of
//! all lanes in one packet walk, with the same bits.
//!
//! Measure: densities per radius (dΩ_R); a contribution is K·f(v, ω)·cos θ·V(ω)·w(ω)/p(ω) with
//! K = radiance × radius and f·cos from the BSDF model, averaged over `samples` iterations.
//!
//! The two-technique estimator (methods `Ltc` and `Mis`), per light:
//! 1. PSA (the diffuse technique) on the line clipped at the horizon of n; `None` → nothing.
//! 2. LTC (the specular technique) with the table's A for (α, cos θ_v); `None` (no specular
//!    lobe, lobe empty on the line in cosine space, A too ill-conditioned) → diffuse only.
//! 3. Technique weights per channel: W_d = max(ρ_d, 0.01)·Ω⊥_R, W_s = k_s·ρ_s·Ω⊥_o/κ.
//! 4. Per iteration one diffuse sample ω_d (ξ₀) and one specular sample ω_s (ξ₁), each
//!    weighted with its own density and the other technique's cross density
//!    (`ProjectedSolidAngle::density_in_support`, `SpecularSampler::density_on_clipped_line`:
//!    both samples lie on the clipped line, so no support test), both shadow-traced.
//!
//! Random numbers: per light, `samples` numbers (one technique, or diffuse only on a
//! Lambertian surface) or 2·`samples` (the two-technique estimators on other surfaces: ξ₀, ξ₁
//! per iteration), drawn whether or not the light contributes. The integrator calls these
//! estimators once per light with `samples` = `light_samples` (`--lights every`), or once per
//! light sample for the light it chose, with `samples` = 1 and K/p in place of K (`--lights
//! one`; the choice's number ξ_c comes before the light's: [`crate::integrator`],
//! [`crate::light_choice`]).

use crate::hooks::{
    with_resolved, BsdfModel, Hooks, LightSampling, Resolved, SpecularSampling, EVAL_LANES,
};
pub use crate::method::lambert_technique;
use crate::method::Method;
use glam::{DVec3, Mat3, Vec3};
use linlight_brdf::ltc::GgxLtcTable;
use linlight_brdf::{Bsdf, Lobes};
use linlight_sampling::batch::{PreparedBatch, BATCH_LANES};
use linlight_sampling::mis::Heuristic;
use linlight_sampling::noise::Uniforms;
use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
use linlight_sampling::{LineSampler, Segment, SpecularSampler};
use linlight_simd::{get3, set3, splat3, Isa};

/// Smallest diffuse albedo in the diffuse technique weight W_d = max(ρ_d, 0.01)·Ω⊥_R.
pub const MIN_DIFFUSE_WEIGHT: f32 = 0.01;

/// The shading frame of the LTC tables: columns x̂, ŷ, n with x̂ = normalize(v − (n·v)n)
/// (any unit x̂ ⊥ n when v ∥ n) and ŷ = n × x̂; and v in it. `n`, `wi` unit, n·wi > 0.
/// Branch-free (glam's `try_normalize` written out, the fallback selected), so that the
/// packet renderer's loop over its lanes vectorises.
#[inline(always)]
pub fn shading_frame(n: Vec3, wi: Vec3) -> (Mat3, DVec3) {
    let d = wi - n.dot(wi) * n;
    let rcp = d.length_recip();
    let x = if rcp.is_finite() && rcp > 0.0 {
        d * rcp
    } else {
        n.any_orthonormal_vector()
    };
    let frame = Mat3::from_cols(x, n.cross(x), n);
    let v = DVec3::new(wi.dot(x) as f64, 0.0, wi.dot(n) as f64);
    (frame, v)
}

/// A world direction `w` in the frame with columns `x`, `y`, `n` ([`shading_frame`]), as the
/// BSDF is evaluated with it ([`ShadingPoint::local`], f32: [`Bsdf::eval_f32`]).
#[inline(always)]
pub fn to_local(x: Vec3, y: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    Vec3::new(w.dot(x), w.dot(y), w.dot(n))
}

/// A shading point of a non-Lambertian surface: position, frame, view and what the BSDF
/// model says about its lobes there.
#[derive(Clone, Copy, Debug)]
pub struct ShadingPoint<'a> {
    pub x: Vec3,
    /// Columns x̂, ŷ, n ([`shading_frame`]); n is the normal of the side facing the viewer.
    pub frame: Mat3,
    /// The view direction in shading coordinates (v_y = 0, v_z = cos θ_v > 0).
    pub v: DVec3,
    pub bsdf: &'a Bsdf,
    pub lobes: Lobes,
    /// A (shading → cosine space) and ρ_s of the specular lobe from the GGX LTC table.
    pub ltc: Option<(Mat3, f32)>,
    /// Whether `lobes` and `ltc` were computed ([`ShadingPoint::for_method`] leaves them out
    /// for single techniques, which only evaluate the BSDF).
    summarised: bool,
}

impl<'a> ShadingPoint<'a> {
    /// `n`: unit normal of the reflecting side, `wi`: unit direction toward the viewer.
    pub fn new<B: BsdfModel>(model: &B, bsdf: &'a Bsdf, x: Vec3, n: Vec3, wi: Vec3) -> Self {
        Self::with_summary(model, bsdf, x, n, wi, true)
    }

    /// The shading point `method` needs: [`ShadingPoint::new`] for the two-technique methods,
    /// without the lobe summary and LTC look-up for single techniques (which only call
    /// [`ShadingPoint::eval`]; a third of a glossy sample's work went into them).
    #[inline]
    pub fn for_method<B: BsdfModel>(
        model: &B,
        method: Method,
        bsdf: &'a Bsdf,
        x: Vec3,
        n: Vec3,
        wi: Vec3,
    ) -> Self {
        Self::with_summary(model, bsdf, x, n, wi, Combination::of(method).is_some())
    }

    #[inline]
    fn with_summary<B: BsdfModel>(
        model: &B,
        bsdf: &'a Bsdf,
        x: Vec3,
        n: Vec3,
        wi: Vec3,
        summarised: bool,
    ) -> Self {
        let (frame, v) = shading_frame(n, wi);
        let lobes = if summarised {
            model.lobes(bsdf, v)
        } else {
            Lobes::BLACK
        };
        let ltc = lobes
            .specular
            .map(|s| GgxLtcTable::ggx().lookup(s.alpha as f32, v.z as f32));
        Self {
            x,
            frame,
            v,
            bsdf,
            lobes,
            ltc,
            summarised,
        }
    }

    #[inline]
    pub fn n(&self) -> Vec3 {
        self.frame.z_axis
    }

    /// The shading frame and the GGX LTC table's A of the specular lobe (the look-up of
    /// [`ShadingPoint::new`], made here if this point was built without it); `None` without a
    /// specular lobe. For the tube technique `ltc` (`crate::tube`).
    pub fn ltc_lobe<B: BsdfModel>(&self, model: &B) -> Option<(Mat3, Mat3)> {
        let a = if self.summarised {
            self.ltc.map(|(a, _)| a)
        } else {
            model
                .lobes(self.bsdf, self.v)
                .specular
                .map(|s| GgxLtcTable::ggx().lookup(s.alpha as f32, self.v.z as f32).0)
        };
        a.map(|a| (self.frame, a))
    }

    /// f(v, ω)·cos θ for a unit world direction ω (v and ω in the frame are f32 values, so
    /// [`SceneBsdf`](crate::hooks::SceneBsdf) evaluates exactly what the packet renderer's
    /// f32 lanes do).
    #[inline]
    pub fn eval<B: BsdfModel>(&self, model: &B, w: Vec3) -> Vec3 {
        model.eval(self.bsdf, self.v, self.local(w)).as_vec3()
    }

    /// A world direction in the shading frame, as [`ShadingPoint::eval`] passes it to the
    /// BSDF (f32 values, exactly; the packet renderer's lanes call [`to_local`] too).
    #[inline(always)]
    pub fn local(&self, w: Vec3) -> DVec3 {
        self.local_f32(w).as_dvec3()
    }

    /// [`ShadingPoint::local`] in f32 (the same values).
    #[inline(always)]
    pub fn local_f32(&self, w: Vec3) -> Vec3 {
        to_local(self.frame.x_axis, self.frame.y_axis, self.frame.z_axis, w)
    }
}

/// How the two samples of the two-technique estimator are weighted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Combination {
    /// A MIS heuristic (method `Mis`).
    Heuristic(Heuristic),
    /// w_s = 1\[p_s > 0\], w_d = 1\[p_s = 0\] (method `Ltc`).
    SupportIndicator,
}

impl Combination {
    /// The combination of a two-technique method; `None` for single techniques.
    pub fn of(method: Method) -> Option<Self> {
        match method {
            Method::Technique(_) => None,
            Method::Ltc => Some(Combination::SupportIndicator),
            Method::Mis(h) => Some(Combination::Heuristic(h)),
        }
    }

    /// Weight per channel of a sample of the diffuse (`specular` = false) or specular
    /// technique: p_own its density, p_other the other technique's, w_* the technique weights.
    #[inline]
    pub fn weight(
        self,
        specular: bool,
        p_own: f32,
        p_other: f32,
        w_own: Vec3,
        w_other: Vec3,
    ) -> Vec3 {
        match self {
            // 1[p_s > 0] for the specular technique, 1[p_s = 0] for the diffuse one.
            Combination::SupportIndicator => {
                let p_s = if specular { p_own } else { p_other };
                if (p_s > 0.0) == specular {
                    Vec3::ONE
                } else {
                    Vec3::ZERO
                }
            }
            Combination::Heuristic(h) if h.uses_technique_weights() => Vec3::new(
                h.weight(p_own, p_other, w_own.x, w_other.x),
                h.weight(p_own, p_other, w_own.y, w_other.y),
                h.weight(p_own, p_other, w_own.z, w_other.z),
            ),
            Combination::Heuristic(h) => Vec3::splat(h.weight(p_own, p_other, 0.0, 0.0)),
        }
    }
}

/// Distance along ω (toward the line of `sampler`) to the line; `None` if not finite.
#[inline]
fn distance_to_line<L: LineSampler>(sampler: &L, w: Vec3) -> Option<f32> {
    // The line point seen along ω is at distance d/t, t = √(1 − s²) = ĉ·ω.
    let frame = sampler.support();
    let t = frame.c_hat.dot(w);
    let dist = frame.d / t;
    (t > 0.0 && dist.is_finite()).then_some(dist)
}

/// The contribution K·f(v, ω)·cos θ/p(ω) of one sample ω (density `pdf`) of a single
/// technique at a non-Lambertian shading point, not yet tested for finiteness: the expression
/// of [`estimate_resolved`], which the packet renderer evaluates lane by lane.
#[inline]
pub fn single_contribution<B: BsdfModel>(
    model: &B,
    sp: &ShadingPoint,
    k: Vec3,
    w: Vec3,
    pdf: f32,
) -> Vec3 {
    contribution(k, sp.eval(model, w), pdf)
}

/// K·(f·cos)/p: the last step of [`single_contribution`] (`f_cos` from the BSDF), which the
/// packet renderer applies to its lanes' BSDF values.
#[inline(always)]
pub fn contribution(k: Vec3, f_cos: Vec3, pdf: f32) -> Vec3 {
    k * f_cos / pdf
}

/// A sample of a single technique that can contribute: direction ω, cos θ = n·ω > 0, density
/// p > 0 (finite, per radius) and the finite distance along ω to the line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SingleSample {
    pub w: Vec3,
    pub cos: f32,
    pub pdf: f32,
    pub dist: f32,
}

/// The sample of `sampler` for ξ = `xi` seen from a point with normal `n`, where it can
/// contribute (before visibility): one iteration of [`single_technique`], which the batched
/// renderer runs lane by lane for techniques without a batch kernel.
#[inline(always)]
pub fn single_sample<L: LineSampler>(sampler: &L, n: Vec3, xi: f32) -> Option<SingleSample> {
    let (w, pdf) = sampler.sample_with_pdf(xi);
    let cos = n.dot(w);
    if !(pdf > 0.0 && pdf.is_finite() && cos > 0.0) {
        return None;
    }
    let dist = distance_to_line(sampler, w)?;
    Some(SingleSample { w, cos, pdf, dist })
}

/// One technique, `samples` iterations: Σ contribution(ω, cos θ, p) over the visible samples
/// with p > 0 and cos θ > 0 (not divided by `samples`). `contribution` returns
/// K·f·cos/p; non-finite ones are counted in `dropped` and left out.
#[inline(always)]
pub fn single_technique<L: LineSampler>(
    sampler: Option<&L>,
    n: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    contribution: impl Fn(Vec3, f32, f32) -> Vec3,
    dropped: &mut u32,
) -> Vec3 {
    let mut total = Vec3::ZERO;
    let Some(sampler) = sampler else {
        skip_numbers(rng, samples);
        return total;
    };
    for _ in 0..samples {
        let Some(SingleSample { w, cos, pdf, dist }) = single_sample(sampler, n, rng.next_f32())
        else {
            continue;
        };
        if !visible(w, dist) {
            continue;
        }
        let c = contribution(w, cos, pdf);
        add_finite(&mut total, dropped, c);
    }
    total
}

/// Adds a visible sample's contribution `c` to `total`, or counts it in `dropped` when it is
/// not finite.
#[inline(always)]
pub(crate) fn add_finite(total: &mut Vec3, dropped: &mut u32, c: Vec3) {
    if c.is_finite() {
        *total += c;
    } else {
        *dropped += 1;
    }
}

/// Draws and discards `count` numbers: an estimate that finds nothing to sample consumes the
/// numbers its iterations would have drawn, so the stream stays aligned.
#[inline]
fn skip_numbers(rng: &mut impl Uniforms, count: u32) {
    for _ in 0..count {
        rng.next_f32();
    }
}

/// [`single_technique`] at a non-Lambertian shading point with the contribution of
/// [`single_contribution`], the BSDF evaluated for up to [`EVAL_LANES`] samples in one
/// [`BsdfModel::eval_lanes`] call: per chunk of iterations, each draws its number and is
/// shadow-tested in turn, then the visible ones are evaluated together and added in the order
/// of their iterations. The same numbers, shadow rays, sums and bits as [`single_technique`].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn single_technique_lanes<L: LineSampler, B: BsdfModel>(
    sampler: Option<&L>,
    model: &B,
    sp: &ShadingPoint,
    k: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    dropped: &mut u32,
) -> Vec3 {
    let mut total = Vec3::ZERO;
    let Some(sampler) = sampler else {
        skip_numbers(rng, samples);
        return total;
    };
    let n = sp.n();
    let mut left = samples as usize;
    while left > 0 {
        let chunk = left.min(EVAL_LANES);
        left -= chunk;
        // The chunk's samples, then its visible ones in order: directions in the shading
        // frame, densities.
        let mut drawn = [None; EVAL_LANES];
        for s in drawn.iter_mut().take(chunk) {
            *s = single_sample(sampler, n, rng.next_f32());
        }
        let mut l = splat3::<EVAL_LANES>(Vec3::Z);
        let mut pdf = [1.0f32; EVAL_LANES];
        let mut len = 0;
        for SingleSample {
            w, pdf: p, dist, ..
        } in drawn.into_iter().take(chunk).flatten()
        {
            if visible(w, dist) {
                set3(&mut l, len, sp.local_f32(w));
                pdf[len] = p;
                len += 1;
            }
        }
        if len == 0 {
            continue;
        }
        let f_cos = model.eval_lanes(sp.bsdf, sp.v, &l, len);
        for (i, &p) in pdf.iter().enumerate().take(len) {
            let c = contribution(k, get3(&f_cos, i), p);
            add_finite(&mut total, dropped, c);
        }
    }
    total
}

/// A sample of the two-technique estimator before visibility: it adds `c` (K·f·w/p, not yet
/// tested for finiteness) when the line point along `w`, at distance `dist`, is visible.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    pub w: Vec3,
    pub dist: f32,
    pub c: Vec3,
}

/// The samplers of the two-technique estimator for one light at one shading point: the
/// diffuse technique (projected solid angle on the line clipped at the horizon), the
/// specular one with its technique weight W_s (`None`: diffuse only), the diffuse technique
/// weight W_d.
pub struct TwoTechniqueLight<S> {
    pub diffuse: ProjectedSolidAngle,
    pub specular: Option<(S, Vec3)>,
    pub w_d: Vec3,
}

impl<S: SpecularSampler> TwoTechniqueLight<S> {
    /// Steps 1–3 of the module documentation for `segment` at `sp`; `None` when the diffuse
    /// technique cannot sample (no contribution; the estimator still draws its numbers).
    #[inline]
    pub fn prepare<P: SpecularSampling<Sampler = S>>(
        specular: &P,
        sp: &ShadingPoint,
        segment: &Segment,
    ) -> Option<Self> {
        debug_assert!(sp.summarised, "a shading point without its lobe summary");
        let (diffuse, line) = ProjectedSolidAngle::prepare_with_whole_frame(segment, sp.x, sp.n())?;
        let k_s = sp
            .lobes
            .specular
            .map_or(DVec3::ZERO, |l| l.weight)
            .as_vec3();
        let specular = sp.ltc.and_then(|(a, rho)| {
            let s = specular.prepare_on_line(segment, sp.x, &line?, sp.frame, a)?;
            let w_s = k_s * (rho * s.weight_scale());
            Some((s, w_s))
        });
        let w_d = sp
            .lobes
            .diffuse
            .as_vec3()
            .max(Vec3::splat(MIN_DIFFUSE_WEIGHT))
            * diffuse.projected_solid_angle();
        Some(Self {
            diffuse,
            specular,
            w_d,
        })
    }

    /// Step 4 before visibility: the diffuse sample of ξ_d, then the specular sample of ξ_s,
    /// each `None` where it cannot contribute (zero density, weight or f·cos, no finite
    /// distance to the line). `eval`: f·cos of a world direction. [`two_techniques`] traces
    /// them one after the other; the packet renderer traces each in a packet walk.
    #[inline]
    pub fn candidates(
        &self,
        combination: Combination,
        k: Vec3,
        xi: (f32, f32),
        eval: impl Fn(Vec3) -> Vec3,
    ) -> [Option<Candidate>; 2] {
        self.weighted(combination, xi)
            .map(|s| s.and_then(|s| s.candidate(k, eval(s.w))))
    }

    /// [`Self::candidates`] before the BSDF: the diffuse sample of ξ_d and the specular one of
    /// ξ_s with their weights and densities, `None` where density, weight or distance rule
    /// them out.
    #[inline]
    pub fn weighted(
        &self,
        combination: Combination,
        (xi_d, xi_s): (f32, f32),
    ) -> [Option<WeightedSample>; 2] {
        self.weighted_with(combination, self.diffuse.sample_with_pdf(xi_d), xi_s)
    }

    /// [`Self::weighted`] with the diffuse sample (ω_d, p_d) of ξ_d given (bit for bit
    /// `self.diffuse.sample_with_pdf(ξ_d)`, e.g. from a batch kernel).
    #[inline]
    pub fn weighted_with(
        &self,
        combination: Combination,
        (w, p_d): (Vec3, f32),
        xi_s: f32,
    ) -> [Option<WeightedSample>; 2] {
        let mut out = [None, None];
        let diffuse = &self.diffuse;
        // The diffuse sample.
        if p_d > 0.0 && p_d.is_finite() {
            let weight = match &self.specular {
                None => Vec3::ONE,
                Some((s, w_s)) => {
                    let p_s = s.density_on_clipped_line(w);
                    combination.weight(false, p_d, p_s, self.w_d, *w_s)
                }
            };
            if weight != Vec3::ZERO {
                if let Some(dist) = distance_to_line(diffuse, w) {
                    out[0] = Some(WeightedSample {
                        w,
                        dist,
                        weight,
                        pdf: p_d,
                    });
                }
            }
        }
        // The specular sample.
        let Some((s, w_s)) = &self.specular else {
            return out;
        };
        let (w, p_s) = s.sample_with_pdf(xi_s);
        if !(p_s > 0.0 && p_s.is_finite()) {
            return out;
        }
        let p_d = diffuse.density_in_support(w);
        let weight = combination.weight(true, p_s, p_d, *w_s, self.w_d);
        if weight == Vec3::ZERO {
            return out;
        }
        if let Some(dist) = distance_to_line(s, w) {
            out[1] = Some(WeightedSample {
                w,
                dist,
                weight,
                pdf: p_s,
            });
        }
        out
    }
}

/// A sample of the two-technique estimator before the BSDF: direction, distance to the line,
/// MIS weight per channel and its technique's density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedSample {
    pub w: Vec3,
    pub dist: f32,
    pub weight: Vec3,
    pub pdf: f32,
}

impl WeightedSample {
    /// The candidate with f·cos = `f` (K·f·w/p), `None` where f·cos is zero.
    #[inline(always)]
    pub fn candidate(&self, k: Vec3, f: Vec3) -> Option<Candidate> {
        (f != Vec3::ZERO).then(|| Candidate {
            w: self.w,
            dist: self.dist,
            c: k * f * self.weight / self.pdf,
        })
    }
}

/// The two-technique estimator (module documentation), `samples` iterations, not divided by
/// `samples`: per iteration ξ_d, ξ_s, the [`TwoTechniqueLight::candidates`], each added
/// when visible (non-finite ones counted in `dropped`).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn two_techniques<S: SpecularSampler>(
    light: &TwoTechniqueLight<S>,
    combination: Combination,
    k: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    eval: impl Fn(Vec3) -> Vec3,
    dropped: &mut u32,
) -> Vec3 {
    let mut total = Vec3::ZERO;
    for _ in 0..samples {
        let xi = (rng.next_f32(), rng.next_f32());
        for candidate in light
            .candidates(combination, k, xi, &eval)
            .into_iter()
            .flatten()
        {
            if visible(candidate.w, candidate.dist) {
                add_finite(&mut total, dropped, candidate.c);
            }
        }
    }
    total
}

/// f·cos at `sp` (`model`) of each of the (at most 2·[`BATCH_LANES`]) `weighted` samples,
/// [`EVAL_LANES`] at a time ([`BsdfModel::eval_lanes`]); zero past them.
#[inline(always)]
fn eval_weighted<B: BsdfModel>(
    model: &B,
    sp: &ShadingPoint,
    weighted: &[Option<WeightedSample>],
) -> [Vec3; 2 * BATCH_LANES] {
    let mut f_cos = [Vec3::ZERO; 2 * BATCH_LANES];
    for (chunk, out) in weighted
        .chunks(EVAL_LANES)
        .zip(f_cos.chunks_mut(EVAL_LANES))
    {
        let mut l = splat3::<EVAL_LANES>(Vec3::Z);
        for (i, s) in chunk.iter().enumerate() {
            if let Some(s) = s {
                set3(&mut l, i, sp.local_f32(s.w));
            }
        }
        let f = model.eval_lanes(sp.bsdf, sp.v, &l, chunk.len());
        for (i, out) in out.iter_mut().enumerate().take(chunk.len()) {
            *out = get3(&f, i);
        }
    }
    f_cos
}

/// [`two_techniques`] in chunks of [`BATCH_LANES`] iterations: each chunk draws its ξ_d, ξ_s
/// in order, samples the diffuse technique for its ξ_d on the lanes of a batch kernel (the
/// prepared `light.diffuse` in every lane, [`PreparedBatch::splat`]: not prepared again),
/// weighs the samples ([`TwoTechniqueLight::weighted_with`]), evaluates the BSDF (`model` at
/// `sp`) on them [`EVAL_LANES`] at a time ([`BsdfModel::eval_lanes`]), then shadow-tests and
/// adds the candidates in the order of [`two_techniques`]. The same numbers, shadow rays, sums
/// and bits.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn two_techniques_lanes<S: SpecularSampler, B: BsdfModel>(
    light: &TwoTechniqueLight<S>,
    combination: Combination,
    k: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    (model, sp): (&B, &ShadingPoint),
    dropped: &mut u32,
) -> Vec3 {
    let isa = Isa::detect();
    let batch = PreparedBatch::<BATCH_LANES>::splat(&light.diffuse);
    let mut total = Vec3::ZERO;
    let mut left = samples as usize;
    while left > 0 {
        let chunk = left.min(BATCH_LANES);
        left -= chunk;
        let (mut xi_d, mut xi_s) = ([0.0f32; BATCH_LANES], [0.0f32; BATCH_LANES]);
        for i in 0..chunk {
            (xi_d[i], xi_s[i]) = (rng.next_f32(), rng.next_f32());
        }
        let s = batch.sample_projected_solid_angle(isa, &xi_d);
        let diffuse: [(Vec3, f32); BATCH_LANES] =
            std::array::from_fn(|i| (get3(&s.dir, i), s.pdf[i]));
        let mut weighted = [None; 2 * BATCH_LANES];
        let mut len = 0;
        for i in 0..chunk {
            for s in light
                .weighted_with(combination, diffuse[i], xi_s[i])
                .into_iter()
                .flatten()
            {
                weighted[len] = Some(s);
                len += 1;
            }
        }
        let f_cos = eval_weighted(model, sp, &weighted[..len]);
        for (s, &f) in weighted.iter().zip(&f_cos).take(len) {
            let Some(candidate) = s.and_then(|s| s.candidate(k, f)) else {
                continue;
            };
            if visible(candidate.w, candidate.dist) {
                add_finite(&mut total, dropped, candidate.c);
            }
        }
    }
    total
}

/// The light of one linear light (`segment`, K = `k`) at a non-Lambertian shading point by
/// `method` with `samples` iterations, divided by `samples` (0 when `samples` = 0), with the
/// pieces of `hooks`. `rng` supplies the uniform numbers, `visible(ω, distance)` says whether the line
/// point along ω is visible; non-finite contributions are counted in `dropped`.
#[allow(clippy::too_many_arguments)]
pub fn estimate_light<D: LightSampling, S: SpecularSampling, B: BsdfModel>(
    hooks: &Hooks<D, S, B>,
    method: Method,
    sp: &ShadingPoint,
    segment: &Segment,
    k: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    dropped: &mut u32,
) -> Vec3 {
    with_resolved!(hooks, method, |r| estimate_resolved(
        r, method, sp, segment, k, samples, rng, visible, dropped
    ))
}

/// [`estimate_light`] with the pieces resolved (what the integrator calls).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn estimate_resolved<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    pieces: Resolved<T, S, B>,
    method: Method,
    sp: &ShadingPoint,
    segment: &Segment,
    k: Vec3,
    samples: u32,
    rng: &mut impl Uniforms,
    visible: &mut impl FnMut(Vec3, f32) -> bool,
    dropped: &mut u32,
) -> Vec3 {
    if samples == 0 {
        return Vec3::ZERO;
    }
    let n = sp.n();
    let eval = |w: Vec3| sp.eval(pieces.bsdf, w);
    let total = match Combination::of(method) {
        None if samples == 1 => single_technique(
            pieces.technique.prepare(segment, sp.x, n).as_ref(),
            n,
            samples,
            rng,
            visible,
            |w: Vec3, _cos: f32, pdf: f32| single_contribution(pieces.bsdf, sp, k, w, pdf),
            dropped,
        ),
        None => single_technique_lanes(
            pieces.technique.prepare(segment, sp.x, n).as_ref(),
            pieces.bsdf,
            sp,
            k,
            samples,
            rng,
            visible,
            dropped,
        ),
        Some(combination) => {
            let Some(light) = TwoTechniqueLight::prepare(pieces.specular, sp, segment) else {
                skip_numbers(rng, 2 * samples);
                return Vec3::ZERO;
            };
            if samples == 1 {
                two_techniques(&light, combination, k, samples, rng, visible, eval, dropped)
            } else {
                let eval = (pieces.bsdf, sp);
                two_techniques_lanes(&light, combination, k, samples, rng, visible, eval, dropped)
            }
        }
    };
    total / samples as f32
}
