//! Deliberately wrong variants of the glossy integrator, for power controls: a certification
//! that cannot reject these proves nothing. They exist for tests only (never a user-facing
//! option) and plug into [`crate::render_scalar`] through [`Hooks`](crate::hooks::Hooks):
//!
//! | control | hook | what is wrong |
//! |---|---|---|
//! | [`LtcWithoutKappa`] | `with_specular` | κ := 1 in p_s (own and cross density); samples right |
//! | [`LtcHemisphereDensity`] | `with_specular` | p_s := the LTC's density per steradian on the hemisphere, (Aω)_z⁺·\|det A\|/(π\|Aω\|⁴), instead of the density normalised on the line |
//! | [`PrincipledWithoutFresnel`] | `with_bsdf` | `principled` evaluated with F_p ≡ 1 (the lobe summary, hence the sampling, unchanged) |
//! | [`AlphaScaledEval`] | `with_bsdf` | GGX α × factor (e.g. 1.05) in the evaluation, not in the lobe summary that selects the table entry |
//!
//! Usage in a certify-level test (`linlight::certify::Subject` renders through a closure):
//!
//! ```
//! use linlight_render::hooks::Hooks;
//! use linlight_render::power_controls::{AlphaScaledEval, LtcHemisphereDensity};
//! let alpha_off = Hooks::new().with_bsdf(AlphaScaledEval(1.05));
//! let hemisphere = Hooks::new().with_specular(LtcHemisphereDensity);
//! // render_scalar(&scene, &RenderOptions { method: Method::Mis(h), .. }, &alpha_off, &progress)
//! # let _ = (alpha_off, hemisphere);
//! ```
//!
//! The unit tests of [`crate::shading`] show each of them biased on a shading-point integral
//! (every method that uses the replaced piece), against quadrature.

use crate::hooks::{BsdfModel, SpecularSampling};
use glam::{DVec3, Mat3, Vec3};
use linlight_brdf::microfacet::ggx_cos_and_cos_vh;
use linlight_brdf::{fresnel, Blend, Bsdf, Lobes, Principled, RoughConductor};
use linlight_sampling::ltc::LtcLine;
use linlight_sampling::{LineFrame, LineSampler, Segment, SpecularSampler};

/// LTC samples with a density scaled by a per-light constant (wrong unless it is 1).
#[derive(Clone, Copy, Debug)]
pub struct ScaledLtc {
    pub inner: LtcLine,
    pub factor: f32,
}

impl LineSampler for ScaledLtc {
    fn sample(&self, xi: f32) -> Vec3 {
        self.inner.sample(xi)
    }
    fn pdf(&self, dir: Vec3) -> f32 {
        self.factor * self.inner.pdf(dir)
    }
    fn support(&self) -> &LineFrame {
        self.inner.support()
    }
    fn inverse(&self, dir: Vec3) -> Option<f32> {
        self.inner.inverse(dir)
    }
}

impl SpecularSampler for ScaledLtc {
    fn density_on_clipped_line(&self, dir: Vec3) -> f32 {
        self.factor * self.inner.density_on_clipped_line(dir)
    }
    fn weight_scale(&self) -> f32 {
        self.inner.weight_scale()
    }
}

/// κ := 1 in the LTC density: p_s/κ (the tube's half-width correction left out).
#[derive(Clone, Copy, Debug, Default)]
pub struct LtcWithoutKappa;

impl SpecularSampling for LtcWithoutKappa {
    type Sampler = ScaledLtc;
    fn prepare(&self, segment: &Segment, x: Vec3, frame: Mat3, a: Mat3) -> Option<ScaledLtc> {
        let inner = LtcLine::prepare(segment, x, frame, a)?;
        Some(ScaledLtc {
            factor: 1.0 / inner.kappa(),
            inner,
        })
    }
    fn name(&self) -> Option<String> {
        Some("ltc-without-kappa".into())
    }
}

/// The hemisphere LTC density D(ω) = (Aω)_z⁺·|det A|/(π|Aω|⁴) (per steradian, normalised over
/// the hemisphere) in place of the line-normalised p_s = κ/Ω⊥_o·π·D.
#[derive(Clone, Copy, Debug, Default)]
pub struct LtcHemisphereDensity;

impl SpecularSampling for LtcHemisphereDensity {
    type Sampler = ScaledLtc;
    fn prepare(&self, segment: &Segment, x: Vec3, frame: Mat3, a: Mat3) -> Option<ScaledLtc> {
        let inner = LtcLine::prepare(segment, x, frame, a)?;
        Some(ScaledLtc {
            factor: inner.weight_scale() * std::f32::consts::FRAC_1_PI,
            inner,
        })
    }
    fn name(&self) -> Option<String> {
        Some("ltc-hemisphere-density".into())
    }
}

/// Evaluates `bsdf` as `Bsdf::eval` does, with `leaf` overriding the leaves it returns `Some`
/// for (blends and `twosided` are walked as Mitsuba evaluates them).
fn eval_with(
    bsdf: &Bsdf,
    v: DVec3,
    l: DVec3,
    leaf: &impl Fn(&Bsdf, DVec3, DVec3) -> Option<DVec3>,
) -> DVec3 {
    match bsdf {
        Bsdf::Blend(Blend { bsdfs, .. }) => {
            let w = match bsdf {
                Bsdf::Blend(b) => b.weight(),
                _ => unreachable!(),
            };
            eval_with(&bsdfs[0], v, l, leaf) * (1.0 - w) + eval_with(&bsdfs[1], v, l, leaf) * w
        }
        Bsdf::TwoSided(inner) => {
            let (v, l) = if v.z.is_sign_negative() {
                (DVec3::new(v.x, v.y, -v.z), DVec3::new(l.x, l.y, -l.z))
            } else {
                (v, l)
            };
            eval_with(inner, v, l, leaf)
        }
        b => leaf(b, v, l).unwrap_or_else(|| b.eval(v, l)),
    }
}

/// `principled` with the Fresnel factor F_p of its specular lobe replaced by 1 (the diffuse
/// part unchanged); every other BSDF as loaded.
#[derive(Clone, Copy, Debug, Default)]
pub struct PrincipledWithoutFresnel;

impl BsdfModel for PrincipledWithoutFresnel {
    fn eval(&self, bsdf: &Bsdf, v: DVec3, l: DVec3) -> DVec3 {
        eval_with(bsdf, v, l, &|b, v, l| match b {
            Bsdf::Principled(p) => Some(principled_without_fresnel(p, v, l)),
            _ => None,
        })
    }
    fn lobes(&self, bsdf: &Bsdf, v: DVec3) -> Lobes {
        bsdf.lobes(v)
    }
    fn name(&self) -> Option<String> {
        Some("principled-without-fresnel".into())
    }
}

/// Principled::eval − F_p·lobe + lobe, where `Principled::eval` adds the specular term.
fn principled_without_fresnel(p: &Principled, v: DVec3, l: DVec3) -> DVec3 {
    let value = p.eval(v, l);
    if !(v.z > 0.0 && l.z > 0.0) {
        return value;
    }
    let (lobe, cos_vh) = ggx_cos_and_cos_vh(p.alpha(), v, l);
    if lobe != 0.0 && fresnel::dielectric(cos_vh, p.eta as f64) > 0.0 {
        value - p.fresnel(cos_vh) * lobe + DVec3::splat(lobe)
    } else {
        value
    }
}

/// GGX α multiplied by the factor in the evaluation (`roughconductor` α, `principled`
/// roughness × √factor), while the lobe summary — and so the LTC table entry and the MIS
/// weights — keeps the scene's α.
#[derive(Clone, Copy, Debug)]
pub struct AlphaScaledEval(pub f32);

impl BsdfModel for AlphaScaledEval {
    fn eval(&self, bsdf: &Bsdf, v: DVec3, l: DVec3) -> DVec3 {
        let factor = self.0;
        eval_with(bsdf, v, l, &|b, v, l| match b {
            Bsdf::RoughConductor(c) => Some(
                RoughConductor {
                    alpha: c.alpha * factor,
                    ..c.clone()
                }
                .eval(v, l),
            ),
            Bsdf::Principled(p) => Some(
                Principled {
                    roughness: p.roughness * factor.sqrt(),
                    ..p.clone()
                }
                .eval(v, l),
            ),
            _ => None,
        })
    }
    fn lobes(&self, bsdf: &Bsdf, v: DVec3) -> Lobes {
        bsdf.lobes(v)
    }
    fn name(&self) -> Option<String> {
        Some(format!("alpha-x{}-in-eval", self.0))
    }
}
