//! What the suite certifies: a *subject* is a named way to prepare a [`LineSampler`] for a
//! [`Config`]. Techniques are certified (must pass); negative controls are deliberately wrong
//! wrappers that the suite must reject. New techniques (LTC, MIS) plug in as further subjects.

use crate::configs::Config;
use glam::Vec3;
use linlight_sampling::solid_angle::SolidAngle;
use linlight_sampling::{LineFrame, LineSampler, Technique};
use serde::Serialize;

/// A sampler prepared for one configuration (`None`: the light contributes nothing).
pub type Prepare = dyn Fn(&Config) -> Option<Box<dyn LineSampler>> + Send + Sync;

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
    /// Must be rejected: at least one configuration fails.
    NegativeControl,
}

pub struct Subject {
    pub name: String,
    pub description: String,
    pub role: Role,
    pub coverage: Coverage,
    pub prepare: Box<Prepare>,
}

impl Subject {
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
            prepare: Box::new(prepare),
        }
    }
}

fn boxed<S: LineSampler + 'static>(s: S) -> Box<dyn LineSampler> {
    Box::new(s)
}

/// A technique of [`Technique`] prepared through `Technique::prepare`.
pub fn technique(t: Technique) -> Subject {
    Subject::new(
        t.name(),
        format!("Technique::{t:?} via Technique::prepare"),
        Role::Certify,
        Coverage::Lambert,
        move |c| t.prepare(&c.segment(), c.x(), c.n()).map(boxed),
    )
}

/// LTC line sampling with the configuration's shading frame and matrix A.
pub fn ltc() -> Subject {
    use linlight_sampling::ltc::LtcLine;
    Subject::new(
        "ltc",
        "LtcLine::prepare(segment, x, shading frame, A)",
        Role::Certify,
        Coverage::OwnSupport,
        |c| LtcLine::prepare(&c.segment(), c.x(), c.shading_frame(), c.a()).map(boxed),
    )
}

/// Every subject the suite certifies: each entry of `Technique::UNBIASED`, then LTC.
pub fn certified() -> Vec<Subject> {
    #[allow(unused_mut)]
    let mut v: Vec<Subject> = Technique::UNBIASED.into_iter().map(technique).collect();
    v.push(ltc());
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
pub fn control_scaled_pdf(t: Technique) -> Subject {
    Subject::new(
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
pub fn control_clipped_samples_unclipped_pdf() -> Subject {
    Subject::new(
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
pub fn control_one_halley_iteration() -> Subject {
    use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
    Subject::new(
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
pub fn control_li2018_two_iterations() -> Subject {
    use linlight_sampling::li2018::Li2018;
    Subject::new(
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
pub fn control_ltc_without_kappa() -> Subject {
    use linlight_sampling::ltc::LtcLine;
    Subject::new(
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

/// The negative controls of docs/statistics.md §1.
pub fn negative_controls() -> Vec<Subject> {
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
    v
}
