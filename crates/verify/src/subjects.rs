//! What the suite certifies: a [`SamplerUnderTest`] is a named way to prepare a [`LineSampler`]
//! for a [`Config`]. Techniques are certified (must pass); negative controls are deliberately
//! wrong wrappers that the suite must reject, each with the check(s) that must reject it
//! ([`Rejection`]). New techniques (LTC, MIS) plug in as further samplers under test.
//!
//! Two kinds of control matter for the power of the χ² test itself: a control whose inverse is
//! the exact CDF while its samples are not is caught by the round trip alone, which a real bug
//! with a *self-consistent* inverse would not be. [`TiltedSamples`] and [`OwnInverse`] build
//! controls whose sample map, inverse, `sample_with_pdf` and pdf agree with each other and whose
//! pdf integrates to 1 — only the distribution of the samples is wrong, so only the χ² tests (and
//! the Monte Carlo integral, where f/p is not constant) can reject them.

use crate::answers::{AnswerSource, SharedSource};
use crate::check::Check;
use crate::configs::Config;
use glam::Vec3;
use linlight_sampling::ltc::LtcLine;
use linlight_sampling::mixture::Mixture;
use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
use linlight_sampling::solid_angle::SolidAngle;
use linlight_sampling::{LineFrame, LineSampler, Technique};
use serde::Serialize;

/// A sampler prepared for one configuration (`None`: the light contributes nothing).
pub type Prepare = dyn Fn(&Config) -> Option<Box<dyn LineSampler>> + Send + Sync;

/// The other technique of the two-technique estimator, prepared for the same configuration:
/// its certified density (`sampler.pdf`, with support test) and its *cross density* — the
/// function the estimator evaluates at the subject's samples without support test
/// (`ProjectedSolidAngle::density_in_support`, `SpecularSampler::density_on_clipped_line`).
pub struct Partner {
    pub name: &'static str,
    pub sampler: Box<dyn LineSampler>,
    pub cross: Box<dyn Fn(Vec3) -> f32>,
}

/// A partner prepared for one configuration (`None`: the estimator has no second technique
/// there, e.g. an empty lobe in cosine space).
pub type PreparePartner = dyn Fn(&Config) -> Option<Partner> + Send + Sync;

/// Which integral the Monte Carlo agreement check estimates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Coverage {
    /// The density is positive wherever (n·ω)⁺ is: the estimate of ∫(n·ω)⁺ dΩ_R must match the
    /// closed form Ω⊥_R of the horizon-clipped line, and `None` is allowed only when Ω⊥_R = 0.
    Lambert,
    /// The density covers only part of the upper hemisphere (LTC): the reference is quadrature
    /// of (n·ω)⁺ over the directions where the pdf is positive; `None` is always allowed.
    OwnSupport,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Role {
    /// Must pass every configuration.
    Certify,
    /// Must be rejected as its [`Rejection`] says.
    NegativeControl,
}

/// When a negative control counts as rejected: at least `min_share` of its tested
/// configurations (and at least one) fail one of the checks `by` (any check when empty).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Rejection {
    pub by: Vec<Check>,
    pub min_share: f64,
}

impl Rejection {
    /// Any failing check on any configuration.
    pub fn any() -> Self {
        Self {
            by: Vec::new(),
            min_share: 0.0,
        }
    }

    /// One of the χ² tests on at least `min_share` of the tested configurations.
    pub fn by_chi2(min_share: f64) -> Self {
        Self {
            by: vec![Check::Chi2, Check::Chi2Coarse],
            min_share,
        }
    }

    /// Whether a failure of `check` counts.
    pub fn counts(&self, check: Check) -> bool {
        self.by.is_empty() || self.by.contains(&check)
    }

    /// Configurations that must be rejected out of `tested`.
    pub fn needed(&self, tested: usize) -> usize {
        ((self.min_share * tested as f64).ceil() as usize).max(1)
    }
}

/// A named way to prepare a [`LineSampler`] for a configuration, with its role in the suite.
pub struct SamplerUnderTest {
    pub name: String,
    pub description: String,
    pub role: Role,
    pub coverage: Coverage,
    /// For negative controls: what must reject them (ignored for certified samplers).
    pub rejection: Rejection,
    pub prepare: Box<Prepare>,
    /// Whether it runs on the suite's configurations (seeded random + edge cases).
    pub suite_configs: bool,
    /// Configurations of its own, after the suite's (e.g. the fitted-table grid).
    pub extra_configs: Vec<Config>,
    /// The other technique whose cross density is checked at this subject's samples
    /// (`cross-density`, `cross-balance`; docs/sampler-suite.md).
    pub partner: Option<Box<PreparePartner>>,
    /// Where the samples come from when not from the prepared sampler: an answer source
    /// ([`crate::answers`]), judged against the prepared sampler as its reference.
    pub answers: Option<SharedSource>,
}

impl SamplerUnderTest {
    pub fn new(
        name: impl Into<String>,
        description: impl Into<String>,
        role: Role,
        coverage: Coverage,
        prepare: impl Fn(&Config) -> Option<Box<dyn LineSampler>> + Send + Sync + 'static,
    ) -> Self {
        Self {
            name: name.into(),
            description: description.into(),
            role,
            coverage,
            rejection: Rejection::any(),
            prepare: Box::new(prepare),
            suite_configs: true,
            extra_configs: Vec::new(),
            partner: None,
            answers: None,
        }
    }

    /// The answers of `source` judged against this subject's sampler (the reference technique
    /// `source` claims to implement), under another name, certified; without a partner (the
    /// source's own pdf is checked instead, at directions it did not sample).
    pub fn answered_by(
        mut self,
        name: impl Into<String>,
        description: impl Into<String>,
        source: Box<dyn AnswerSource>,
    ) -> Self {
        self.name = name.into();
        self.description = description.into();
        self.role = Role::Certify;
        self.partner = None;
        self.answers = Some(SharedSource::new(source));
        self
    }

    /// The same subject on `configs` only.
    pub fn on_configs(mut self, configs: Vec<Config>) -> Self {
        self.suite_configs = false;
        self.extra_configs = configs;
        self
    }

    /// The same subject on the suite's configurations and `configs`.
    pub fn plus_configs(mut self, configs: Vec<Config>) -> Self {
        self.extra_configs.extend(configs);
        self
    }

    /// Its configurations when the suite's are `suite`.
    pub fn configs(&self, suite: &[Config]) -> Vec<Config> {
        let mut v = if self.suite_configs {
            suite.to_vec()
        } else {
            Vec::new()
        };
        v.extend(self.extra_configs.iter().cloned());
        v
    }

    /// The same subject with the cross density of `partner` checked at its samples.
    pub fn with_partner(
        mut self,
        partner: impl Fn(&Config) -> Option<Partner> + Send + Sync + 'static,
    ) -> Self {
        self.partner = Some(Box::new(partner));
        self
    }

    /// The statistical tests it contributes per configuration: fine χ², coarse χ², integral,
    /// and cross-balance with a partner.
    pub fn statistical_tests_per_config(&self) -> usize {
        3 + usize::from(self.partner.is_some())
    }

    /// The same subject under another name and role.
    pub fn renamed(
        mut self,
        name: impl Into<String>,
        description: impl Into<String>,
        role: Role,
    ) -> Self {
        self.name = name.into();
        self.description = description.into();
        self.role = role;
        self
    }

    /// The same control, rejected only as `rejection` says.
    pub fn rejected_by(mut self, rejection: Rejection) -> Self {
        self.rejection = rejection;
        self
    }
}

fn boxed<S: LineSampler + 'static>(s: S) -> Box<dyn LineSampler> {
    Box::new(s)
}

/// A technique of [`Technique`] prepared through `Technique::prepare`.
pub fn technique(t: Technique) -> SamplerUnderTest {
    SamplerUnderTest::new(
        t.name(),
        format!("Technique::{t:?} via Technique::prepare"),
        Role::Certify,
        Coverage::Lambert,
        move |c| t.prepare(&c.segment(), c.x(), c.n()).map(boxed),
    )
}

/// LTC line sampling with the configuration's shading frame and matrix A.
pub fn ltc() -> SamplerUnderTest {
    use linlight_sampling::ltc::LtcLine;
    SamplerUnderTest::new(
        "ltc",
        "LtcLine::prepare(segment, x, shading frame, A)",
        Role::Certify,
        Coverage::OwnSupport,
        |c| LtcLine::prepare(&c.segment(), c.x(), c.shading_frame(), c.a()).map(boxed),
    )
}

/// LTC line sampling with A from the fitted GGX table on the (α, θ_o) grid of
/// [`crate::configs::ltc_table_configs`] (the renderer's lookup and frame).
pub fn ltc_fitted_table() -> SamplerUnderTest {
    let mut s = ltc();
    s.name = "ltc-fitted-table".into();
    s.description =
        "LtcLine::prepare with A = GgxLtcTable::ggx().lookup(α, cos θ_o), (α, θ_o) grid".into();
    s.on_configs(crate::configs::ltc_table_configs())
}

/// The projected solid angle (the estimator's diffuse technique) on the horizon-clipped line.
fn prepare_diffuse(c: &Config) -> Option<ProjectedSolidAngle> {
    ProjectedSolidAngle::prepare(&c.segment(), c.x(), c.n())
}

/// LTC (the estimator's specular technique) with the configuration's frame and A.
fn prepare_specular(c: &Config) -> Option<LtcLine> {
    LtcLine::prepare(&c.segment(), c.x(), c.shading_frame(), c.a())
}

/// The diffuse technique as the partner of LTC samples: p_d at a specular sample.
pub fn diffuse_partner(c: &Config) -> Option<Partner> {
    let d = prepare_diffuse(c)?;
    Some(Partner {
        name: "projected-solid-angle",
        sampler: boxed(d),
        cross: Box::new(move |w| d.density_in_support(w)),
    })
}

/// LTC as the partner of diffuse samples: p_s at a diffuse sample.
pub fn specular_partner(c: &Config) -> Option<Partner> {
    let s = prepare_specular(c)?;
    Some(Partner {
        name: "ltc",
        sampler: boxed(s),
        cross: Box::new(move |w| s.density_on_clipped_line(w)),
    })
}

/// Probability of the diffuse technique in the mixture subject.
pub const MIXTURE_DIFFUSE_PROBABILITY: f32 = 0.5;

/// The one-sample MIS mixture of the estimator's two techniques
/// ([`linlight_sampling::mixture::Mixture`], c = [`MIXTURE_DIFFUSE_PROBABILITY`]): density
/// c·p_d + (1 − c)·p_s from the cross densities; the diffuse technique alone where the lobe is
/// empty (the estimator's diffuse-only fallback). On the suite's configurations and the
/// fitted-table grid.
pub fn mixture() -> SamplerUnderTest {
    let c = MIXTURE_DIFFUSE_PROBABILITY;
    SamplerUnderTest::new(
        format!("mis-mixture-c{c}"),
        format!(
            "Mixture::new(projected solid angle, LTC, {c}): one-sample MIS, mixture pdf from the \
             cross densities"
        ),
        Role::Certify,
        Coverage::Lambert,
        move |cfg| {
            let d = prepare_diffuse(cfg)?;
            Some(match prepare_specular(cfg) {
                Some(s) => boxed(Mixture::new(d, s, c)),
                None => boxed(d),
            })
        },
    )
    .plus_configs(crate::configs::ltc_table_configs())
}

/// Every subject the suite certifies: each entry of `Technique::UNBIASED` (the projected solid
/// angle with the LTC cross density checked at its samples), LTC with random A and with the
/// fitted table (both with the diffuse cross density checked), and the one-sample mixture.
pub fn certified() -> Vec<SamplerUnderTest> {
    let mut v: Vec<SamplerUnderTest> = Technique::UNBIASED
        .into_iter()
        .map(|t| match t {
            Technique::ProjectedSolidAngle => technique(t).with_partner(specular_partner),
            t => technique(t),
        })
        .collect();
    v.push(ltc().with_partner(diffuse_partner));
    v.push(ltc_fitted_table().with_partner(diffuse_partner));
    v.push(mixture());
    v
}

/// A sampler whose density is scaled by a constant (not a density any more unless factor = 1).
pub struct ScaledPdf {
    pub inner: Box<dyn LineSampler>,
    pub factor: f32,
}

impl LineSampler for ScaledPdf {
    fn sample(&self, xi: f32) -> Vec3 {
        self.inner.sample(xi)
    }
    fn pdf(&self, dir: Vec3) -> f32 {
        self.inner.pdf(dir) * self.factor
    }
    fn support(&self) -> &LineFrame {
        self.inner.support()
    }
    fn inverse(&self, dir: Vec3) -> Option<f32> {
        self.inner.inverse(dir)
    }
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let (d, p) = self.inner.sample_with_pdf(xi);
        (d, p * self.factor)
    }
}

/// Samples from one sampler, density (and support, inverse) of another.
pub struct Mismatched {
    pub sampler: Box<dyn LineSampler>,
    pub density: Box<dyn LineSampler>,
}

impl LineSampler for Mismatched {
    fn sample(&self, xi: f32) -> Vec3 {
        self.sampler.sample(xi)
    }
    fn pdf(&self, dir: Vec3) -> f32 {
        self.density.pdf(dir)
    }
    fn support(&self) -> &LineFrame {
        self.density.support()
    }
    fn inverse(&self, dir: Vec3) -> Option<f32> {
        self.density.inverse(dir)
    }
}

/// pdf × 1.01 of a correct technique.
pub fn control_scaled_pdf(t: Technique) -> SamplerUnderTest {
    SamplerUnderTest::new(
        format!("{}-pdf-x1.01", t.name()),
        format!(
            "{} with its pdf (and sample_with_pdf) multiplied by 1.01",
            t.name()
        ),
        Role::NegativeControl,
        Coverage::Lambert,
        move |c| {
            let inner = boxed(t.prepare(&c.segment(), c.x(), c.n())?);
            Some(boxed(ScaledPdf {
                inner,
                factor: 1.01,
            }))
        },
    )
}

/// Clipped solid angle samples against the unclipped solid angle density.
pub fn control_clipped_samples_unclipped_pdf() -> SamplerUnderTest {
    SamplerUnderTest::new(
        "clipped-samples-unclipped-pdf",
        "ClippedSolidAngle samples, SolidAngle (unclipped) pdf and support",
        Role::NegativeControl,
        Coverage::Lambert,
        |c| {
            let (seg, x, n) = (c.segment(), c.x(), c.n());
            let sampler = boxed(SolidAngle::prepare_clipped(&seg, x, n)?);
            let density = boxed(SolidAngle::prepare(&seg, x, n)?);
            Some(boxed(Mismatched { sampler, density }))
        },
    )
}

/// Peters' sampler with one Halley iteration, judged against the exact density.
pub fn control_one_halley_iteration() -> SamplerUnderTest {
    use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
    SamplerUnderTest::new(
        "projected-solid-angle-1-iteration",
        "ProjectedSolidAngle::prepare_with_iterations(.., 1) samples, exact pdf and inverse",
        Role::NegativeControl,
        Coverage::Lambert,
        |c| {
            let (seg, x, n) = (c.segment(), c.x(), c.n());
            let sampler = boxed(ProjectedSolidAngle::prepare_with_iterations(&seg, x, n, 1)?);
            let density = boxed(ProjectedSolidAngle::prepare(&seg, x, n)?);
            Some(boxed(Mismatched { sampler, density }))
        },
    )
}

/// Li et al. 2018 stopped after two Newton iterations.
pub fn control_li2018_two_iterations() -> SamplerUnderTest {
    use linlight_sampling::li2018::Li2018;
    SamplerUnderTest::new(
        "li2018-2-iterations",
        "Li2018::prepare(..).with_max_iterations(2)",
        Role::NegativeControl,
        Coverage::Lambert,
        |c| {
            let s = Li2018::prepare(&c.segment(), c.x(), c.n())?.with_max_iterations(2);
            Some(boxed(s))
        },
    )
}

/// LTC without the density correction κ (pdf / κ).
pub fn control_ltc_without_kappa() -> SamplerUnderTest {
    use linlight_sampling::ltc::LtcLine;
    SamplerUnderTest::new(
        "ltc-without-kappa",
        "LtcLine with pdf / kappa() (the tube half-width correction left out)",
        Role::NegativeControl,
        Coverage::OwnSupport,
        |c| {
            let s = LtcLine::prepare(&c.segment(), c.x(), c.shading_frame(), c.a())?;
            let factor = 1.0 / s.kappa();
            Some(boxed(ScaledPdf {
                inner: boxed(s),
                factor,
            }))
        },
    )
}

/// The projected solid angle with the LTC cross density divided by κ (the κ := 1 power control
/// of the renderer, in the cross density only: `pdf` and samples are correct).
pub fn control_cross_density_without_kappa() -> SamplerUnderTest {
    technique(Technique::ProjectedSolidAngle)
        .with_partner(|c| {
            let s = prepare_specular(c)?;
            let k = s.kappa();
            Some(Partner {
                name: "ltc",
                sampler: boxed(s),
                cross: Box::new(move |w| s.density_on_clipped_line(w) / k),
            })
        })
        .renamed(
            "cross-density-without-kappa",
            "ProjectedSolidAngle samples; LTC cross density density_on_clipped_line / κ",
            Role::NegativeControl,
        )
        .rejected_by(Rejection {
            by: vec![Check::CrossDensity, Check::CrossBalance],
            min_share: 0.0,
        })
}

/// Samples whose density is the claimed one tilted by 1 + ε·(2u − 1), u = F(ω) the claimed CDF
/// of the sample: a smooth, self-consistent density error of relative size ε (±ε at the ends).
/// With S(u) = ε(u² − u) the tilted CDF is G(u) = u + S(u); sampling draws u = G⁻¹(ξ) and then
/// the inner sampler at u; the inverse is G(F(ω)) from the inner inverse; `pdf` and
/// `sample_with_pdf` stay the inner (claimed, untilted) density, which integrates to 1.
pub struct TiltedSamples {
    pub inner: Box<dyn LineSampler>,
    pub epsilon: f64,
}

impl TiltedSamples {
    /// G⁻¹(ξ) = 2ξ / ((1 − ε) + √((1 − ε)² + 4εξ)) (the cancellation-free root), |ε| < 1.
    fn tilted_u(&self, xi: f32) -> f32 {
        let (e, xi) = (self.epsilon, (xi as f64).clamp(0.0, 1.0));
        (2.0 * xi / ((1.0 - e) + ((1.0 - e) * (1.0 - e) + 4.0 * e * xi).sqrt())) as f32
    }
}

impl LineSampler for TiltedSamples {
    fn sample(&self, xi: f32) -> Vec3 {
        self.inner.sample(self.tilted_u(xi))
    }
    fn pdf(&self, dir: Vec3) -> f32 {
        self.inner.pdf(dir)
    }
    fn support(&self) -> &LineFrame {
        self.inner.support()
    }
    fn inverse(&self, dir: Vec3) -> Option<f32> {
        let u = self.inner.inverse(dir)? as f64;
        Some((u + self.epsilon * (u * u - u)) as f32)
    }
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        self.inner.sample_with_pdf(self.tilted_u(xi))
    }
}

/// A sampler whose inverse is the numerical inverse of its *own* sample map (bisection on ξ over
/// the directions' angle along the line), not of the exact CDF: the round trip passes however
/// wrong the sample map is. For monotone sample maps (every technique here).
pub struct OwnInverse {
    pub inner: Box<dyn LineSampler>,
}

impl OwnInverse {
    /// Angle φ = atan2(u·ω, ĉ·ω) along the line, in f64.
    fn phi(&self, dir: Vec3) -> f64 {
        let f = self.inner.support();
        let w = dir.as_dvec3();
        w.dot(f.u.as_dvec3()).atan2(w.dot(f.c_hat.as_dvec3()))
    }
}

impl LineSampler for OwnInverse {
    fn sample(&self, xi: f32) -> Vec3 {
        self.inner.sample(xi)
    }
    fn pdf(&self, dir: Vec3) -> f32 {
        self.inner.pdf(dir)
    }
    fn support(&self) -> &LineFrame {
        self.inner.support()
    }
    fn inverse(&self, dir: Vec3) -> Option<f32> {
        let p = self.inner.pdf(dir);
        if p.is_nan() || p <= 0.0 {
            return None;
        }
        let target = self.phi(dir);
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        // 24 halvings reach the f32 resolution of ξ near 1.
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if self.phi(self.inner.sample(mid)) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(0.5 * (lo + hi))
    }
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let dir = self.inner.sample(xi);
        (dir, self.inner.pdf(dir))
    }
}

/// A technique whose samples are tilted by 1 + ε(2u − 1) ([`TiltedSamples`]): a
/// self-consistent control that only the distribution tests can see.
pub fn control_tilted(t: Technique, epsilon: f64) -> SamplerUnderTest {
    SamplerUnderTest::new(
        format!("{}-tilt-{}%", t.name(), epsilon * 100.0),
        format!(
            "{} with samples tilted by 1 + {epsilon}·(2F − 1) and a self-consistent inverse; \
             pdf unchanged",
            t.name()
        ),
        Role::NegativeControl,
        Coverage::Lambert,
        move |c| {
            let inner = boxed(t.prepare(&c.segment(), c.x(), c.n())?);
            Some(boxed(TiltedSamples { inner, epsilon }))
        },
    )
}

/// Peters' sampler with one Halley iteration, its inverse the inverse of that sample map (not
/// the exact CDF), the exact density.
pub fn control_one_halley_iteration_own_inverse() -> SamplerUnderTest {
    use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
    SamplerUnderTest::new(
        "projected-solid-angle-1-iteration-own-inverse",
        "ProjectedSolidAngle with 1 Halley iteration; inverse = bisection of that sample map; exact pdf",
        Role::NegativeControl,
        Coverage::Lambert,
        |c| {
            let (seg, x, n) = (c.segment(), c.x(), c.n());
            let sampler = boxed(ProjectedSolidAngle::prepare_with_iterations(&seg, x, n, 1)?);
            let density = boxed(ProjectedSolidAngle::prepare(&seg, x, n)?);
            Some(boxed(OwnInverse {
                inner: boxed(Mismatched { sampler, density }),
            }))
        },
    )
}

/// Relative size of the smooth tilt the suite must detect ([`tilt_control`]).
pub const DETECTABLE_TILT: f64 = 0.01;

/// Share of the tested configurations in which the χ² tests must reject the tilt.
pub const DETECTABLE_TILT_SHARE: f64 = 0.5;

/// The suite's power requirement as a control: Peters' sampler tilted by
/// [`DETECTABLE_TILT`] must be rejected by χ² in most configurations (its f/p is constant, so
/// the integral check cannot see it).
pub fn tilt_control() -> SamplerUnderTest {
    control_tilted(Technique::ProjectedSolidAngle, DETECTABLE_TILT)
        .rejected_by(Rejection::by_chi2(DETECTABLE_TILT_SHARE))
}

/// The tilt sizes of the power table (`linlight samplers --tilt-power`).
pub const TILT_POWER_EPSILONS: [f64; 4] = [0.005, 0.01, 0.02, 0.05];

/// The techniques the power table tilts: the paper's (f/p constant: χ² alone can see a tilt) and
/// the clipped solid angle (a smooth density of its own).
pub const TILT_POWER_TECHNIQUES: [Technique; 2] =
    [Technique::ProjectedSolidAngle, Technique::ClippedSolidAngle];

/// Controls of the power table: every technique of [`TILT_POWER_TECHNIQUES`] tilted by every
/// ε of [`TILT_POWER_EPSILONS`], judged by χ² alone.
pub fn tilt_power_controls() -> Vec<SamplerUnderTest> {
    TILT_POWER_TECHNIQUES
        .into_iter()
        .flat_map(|t| {
            TILT_POWER_EPSILONS.map(|e| control_tilted(t, e).rejected_by(Rejection::by_chi2(0.0)))
        })
        .collect()
}

/// The negative controls of the suite (docs/sampler-suite.md), each with what must reject it.
pub fn negative_controls() -> Vec<SamplerUnderTest> {
    #[allow(unused_mut)]
    let mut v = vec![
        control_scaled_pdf(Technique::ClippedSolidAngle),
        control_clipped_samples_unclipped_pdf(),
    ];
    {
        v.push(control_one_halley_iteration());
        v.push(control_li2018_two_iterations());
    }
    v.push(control_ltc_without_kappa());
    v.push(control_one_halley_iteration_own_inverse().rejected_by(Rejection::by_chi2(0.0)));
    v.push(tilt_control());
    v.push(control_cross_density_without_kappa());
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::configs::paper_sanity;

    fn prepared(t: Technique) -> Box<dyn LineSampler> {
        let c = paper_sanity();
        boxed(t.prepare(&c.segment(), c.x(), c.n()).unwrap())
    }

    /// The tilt is self-consistent: sample ∘ inverse is the identity on ξ, and the share of
    /// samples below the inner sampler's median is G(½) = ½ − ε/4 (the tilt moves mass to the
    /// end where 2u − 1 > 0).
    #[test]
    fn tilted_samples_are_self_consistent_and_tilted() {
        let epsilon = 0.2;
        let t = TiltedSamples {
            inner: prepared(Technique::ClippedSolidAngle),
            epsilon,
        };
        let inner = prepared(Technique::ClippedSolidAngle);
        let median = inner.sample(0.5);
        let frame = *inner.support();
        let s_of = |d: Vec3| d.dot(frame.u);
        let m = 4000;
        let mut below = 0;
        for i in 0..m {
            let xi = (i as f32 + 0.5) / m as f32;
            let (dir, p) = t.sample_with_pdf(xi);
            assert_eq!(p, inner.pdf(dir));
            let back = t.inverse(dir).unwrap();
            assert!((back - xi).abs() < 1e-5, "ξ {xi} → {back}");
            below += usize::from(s_of(dir) < s_of(median));
        }
        let share = below as f64 / m as f64;
        assert!((share - (0.5 - epsilon / 4.0)).abs() < 1e-3, "{share}");
    }

    /// The own inverse undoes the (wrong) sample map, where the exact CDF's inverse does not.
    #[test]
    fn own_inverse_round_trips_a_wrong_sample_map() {
        let subject = control_one_halley_iteration_own_inverse();
        let c = crate::configs::edge_configs()
            .into_iter()
            .find(|c| c.name == "crossing-oblique")
            .unwrap();
        let s = (subject.prepare)(&c).unwrap();
        let exact = ProjectedSolidAngleExact::of(&c);
        let (mut worst_own, mut worst_exact) = (0.0f32, 0.0f32);
        for i in 1..200 {
            let xi = i as f32 / 200.0;
            let dir = s.sample(xi);
            worst_own = worst_own.max((s.inverse(dir).unwrap() - xi).abs());
            worst_exact = worst_exact.max((exact.inverse(dir).unwrap() - xi).abs());
        }
        assert!(worst_own < 1e-5, "{worst_own}");
        assert!(
            worst_exact > 1e-4,
            "the one-iteration map is not wrong here: {worst_exact}"
        );
    }

    struct ProjectedSolidAngleExact;
    impl ProjectedSolidAngleExact {
        fn of(c: &Config) -> Box<dyn LineSampler> {
            boxed(
                Technique::ProjectedSolidAngle
                    .prepare(&c.segment(), c.x(), c.n())
                    .unwrap(),
            )
        }
    }
}
