//! The sampler certification suite (docs/sampler-suite.md): every sampler under test × every
//! configuration.
//!
//! Per configuration, with N samples from one counter-based stream (seed; sampler, config):
//! - two chi-square tests, expected counts N·∫_cell p_R dΩ_R (adaptive Gauss–Legendre, f64,
//!   the sampler's own `pdf`), pooled to ≥ 5, fail if p < α_c: the *fine* test on M equal
//!   φ-cells of the support (local errors), the *coarse* test on K cells of equal probability
//!   (smooth errors: a 1 % tilt of the density is rejected in most configurations at the
//!   default N); a sample outside the support or in a zero-expected bin fails both;
//! - normalisation |∫ p_R dΩ_R − 1| ≤ 1e-5 (same quadrature, sum over bins);
//! - the pdf is 0 on the line outside the support;
//! - every sample is a unit direction toward the line; `sample_with_pdf` agrees with the `pdf`
//!   of the sample or of a direction on the line that the f32 sample cannot be told from;
//! - inverse round trips ξ → ω → ξ' where `inverse` returns Some;
//! - integral agreement: the Monte Carlo estimate of ∫(n·ω)⁺ dΩ_R lies within z_c standard
//!   errors (plus an f32 floor, below) of the closed form Ω⊥_R.
//!
//! Each check is a function; the samples are tabulated once (`tabulate`: histogram, worst
//! deviations, moments, round trips) and each test then judges its tally. The samples are a Rust
//! sampler's own, or the answers of an [`crate::answers::AnswerSource`] to the same primary
//! samples, judged against its reference technique (and then also `answer`,
//! `reported-inverse` and its pdf at directions it did not sample: `cross-density`).
//!
//! Multiple testing: m = (certified samplers) × (configurations) × 3 statistical tests (fine χ²,
//! coarse χ², integral z-test); suite-wide α = 0.01; Šidák α_c = 1 − (1 − α)^(1/m) for each; the
//! z-test uses z_c = max(4, Φ⁻¹(1 − α_c/2)). Negative controls are judged at the same α_c: a
//! control is *rejected* iff its [`Rejection`] holds — at least the required share of its tested
//! configurations (at least one) fail one of the required checks (any check unless stated; a
//! panic or unprepared API never counts as a rejection).

// `!(x <= tol)` on purpose throughout: a NaN must fail a check, not pass it.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::answers::{SampleAnswers, SharedSource, SourceError};
pub use crate::check::Check;
use crate::chi2::{
    equal_mass_cells, grouped_chi_square, runs, s_resolution, BinLookup, Chi2Outcome, Masses,
    PhiBinning, COUNTING_SUBDIVISION, DIRECTION_TOLERANCE,
};
use crate::configs::{suite_configs, Config, ConfigClass};
use crate::quadrature::Adaptive;
use crate::quiet_panic::catch_quietly;
use crate::subjects::{Coverage, Partner, Rejection, Role, SamplerUnderTest};
use linlight_sampling::philox::CounterRng;
use linlight_sampling::{unit_normal, LineFrame, LineSampler};
use rayon::prelude::*;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal};
use std::collections::BTreeMap;

/// Settings of a suite run.
#[derive(Clone, Debug, Serialize)]
pub struct Settings {
    /// Samples per configuration.
    pub samples: usize,
    /// Equal φ-bins of the fine χ² test (odd); samples are counted in
    /// [`COUNTING_SUBDIVISION`]× finer bins, from which both tests' cells are formed.
    pub bins: usize,
    /// Cells of ≈ equal probability of the coarse χ² test (power against smooth errors).
    pub coarse_cells: usize,
    /// Gauss–Legendre nodes per panel (the first panel of every bin is the bin).
    pub nodes: usize,
    /// Suite-wide significance level.
    pub alpha: f64,
    pub seed: u64,
    pub random_configs: usize,
    /// Bound on |∫ p_R dΩ_R − 1|.
    pub normalisation_tolerance: f64,
    /// Samples per configuration whose inverse round trip is checked.
    pub round_trips: usize,
    /// A negative control stops once the configurations it has run decide its rejection (its
    /// rejections reach what it would need were every remaining configuration tested): its
    /// verdict is the one over every configuration, unless a skipped configuration would have
    /// panicked. `false` runs every configuration (the share rejected, e.g. `--tilt-power`).
    pub controls_until_decided: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            samples: 1_000_000,
            bins: 51,
            coarse_cells: 6,
            nodes: 8,
            alpha: 0.01,
            seed: 0x4c49_4e4c_4947_4854, // "LINLIGHT"
            random_configs: 40,
            normalisation_tolerance: 1e-5,
            round_trips: 2_000,
            controls_until_decided: true,
        }
    }
}

/// Relative error target of the adaptive quadrature (the f32 noise floor 8ε·∫|p| usually
/// decides first).
const QUAD_RELATIVE: f64 = 1e-9;

/// `None` from a Lambert-covering subject is accepted iff Ω⊥_R ≤ this × Ω_R of the whole line.
const ZERO_CONTRIBUTION_TOLERANCE: f64 = 1e-6;

/// Floors of the integral agreement tolerance for f32 arithmetic: relative to the reference
/// (same bound as the normalisation) and relative to Ω_R of the support (rounding of n·ω).
const INTEGRAL_RELATIVE_FLOOR: f64 = 1e-5;
const INTEGRAL_SOLID_ANGLE_FLOOR: f64 = 1e-6;

/// Answer sources only: their geometry (computed from the same f32 configuration in their own
/// arithmetic, e.g. f64) may differ from the reference's f32 frame by the rounding of the
/// endpoints' angles, ≲ ε each; relative to the support's angle Δφ the integral may then
/// differ by this many ε/Δφ (e.g. `short-oblique`, Δφ = 2.7e-3: a numpy sampler's exact
/// Ω⊥_R is 1.4e-5 above the f32 reference).
const INTEGRAL_GEOMETRY_ROUNDING: f64 = 8.0 * f32::EPSILON as f64;

/// `sample_with_pdf` may differ from `pdf(sample)` by this much relative, plus this much of the
/// mean density 1/Ω_R of the support (near-zero densities at the horizon).
const PDF_CONSISTENCY_RELATIVE: f64 = 1e-3;
const PDF_CONSISTENCY_FLOOR: f64 = 1e-5;

/// How far along the line (in φ) an f32 unit direction is uncertain: each component is rounded
/// by up to ε/2 relative, which turns the direction by up to ~ε; 4ε leaves a margin.
const DIRECTION_ANGLE_ROUNDING: f64 = 4.0 * f32::EPSILON as f64;

/// The range of `pdf` over the directions *on the line* within [`DIRECTION_ANGLE_ROUNDING`] of
/// a sample (φ − δ, φ, φ + δ, each built in f64 and rounded once): the pdf's contract covers only
/// directions toward the line, and a sampler's `sample_with_pdf` may return the density of the
/// exact direction it aimed at, which the rounded f32 sample identifies only this well. Where
/// the density is steep on the scale of an ulp the two legitimately differ. Example
/// (random-045, a 3e-3-rad interval clipped at the horizon): n·ω ≈ 2e-5 while an f32 direction
/// fixes n·ω only to ~ε, so (n·ω)/Ω⊥ with Ω⊥ = 4e-6 is determined only to ~0.03 — more than
/// 1e-3 of the density.
fn on_line_range(sampler: &dyn LineSampler, binning: &PhiBinning, dir: glam::Vec3) -> (f64, f64) {
    let phi = binning.phi_of(dir);
    on_line_range_around(sampler, binning, phi, middle_pdf(sampler, binning, phi))
}

/// The pdf at φ, the middle of [`on_line_range`]'s three directions (φ + 0·δ: −0 becomes +0 as
/// there).
fn middle_pdf(sampler: &dyn LineSampler, binning: &PhiBinning, phi: f64) -> f64 {
    sampler.pdf(binning.direction(phi + 0.0 * DIRECTION_ANGLE_ROUNDING)) as f64
}

/// [`on_line_range`] at φ of the sample, given the pdf at φ itself (`middle`). The range starts
/// empty (NaN values are ignored by `min`/`max`, in any order).
fn on_line_range_around(
    sampler: &dyn LineSampler,
    binning: &PhiBinning,
    phi: f64,
    middle: f64,
) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY.min(middle), f64::NEG_INFINITY.max(middle));
    for k in [-1.0, 1.0] {
        let q = sampler.pdf(binning.direction(phi + k * DIRECTION_ANGLE_ROUNDING)) as f64;
        lo = lo.min(q);
        hi = hi.max(q);
    }
    (lo, hi)
}

/// Round-trip tolerance in ξ: absolute, plus the ξ-change of an s-error of this size.
const ROUND_TRIP_XI: f64 = 1e-4;
const ROUND_TRIP_S: f64 = 1e-6;

#[derive(Clone, Debug, Serialize)]
pub struct Failure {
    pub check: Check,
    pub message: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Outcome {
    /// A sampler was prepared and tested.
    Tested,
    /// Preparation returned `None` (zero contribution).
    ZeroContribution,
    /// Preparation or sampling panicked (e.g. an unimplemented technique).
    Panicked,
    /// Not run because the subject panicked on an earlier configuration.
    NotRun,
    /// Not run because earlier configurations decided the negative control's rejection
    /// ([`Settings::controls_until_decided`]).
    Decided,
    /// The subject's answer source could not answer (crash, hang, not the protocol): nothing
    /// was judged. `linlight samplers` exits 2.
    SourceFailed,
}

#[derive(Clone, Debug, Serialize)]
pub struct IntegralCheck {
    pub estimate: f64,
    pub reference: f64,
    pub std_error: f64,
    /// Allowed |estimate − reference|.
    pub tolerance: f64,
    /// Standard deviation of one sample's estimate over the reference (0 when reference is 0).
    pub relative_std: f64,
}

/// The partner technique's cross density at this subject's samples (docs/sampler-suite.md).
#[derive(Clone, Debug, Serialize)]
pub struct CrossCheck {
    pub partner: String,
    /// Worst |cross density − partner pdf| over the samples in units of the tolerance (≤ 1
    /// passes).
    pub worst_deviation: f64,
    /// Mean of the balance weight q/(p + q) over the samples (q: the cross density).
    pub balance_estimate: f64,
    /// ∫ p·q/(p + q) dΩ_R by quadrature with both certified pdfs.
    pub balance_reference: f64,
    pub std_error: f64,
    pub tolerance: f64,
}

/// An answer source's own pdf at directions it did not sample, against the reference pdf.
#[derive(Clone, Debug, Serialize)]
pub struct PdfQueryCheck {
    pub queried: usize,
    /// Worst deviation in units of the pdf-consistency tolerance (≤ 1 passes).
    pub worst_deviation: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct RoundTripCheck {
    pub checked: usize,
    pub max_error: f64,
}

/// Result of one subject on one configuration.
#[derive(Clone, Debug, Serialize)]
pub struct ConfigResult {
    pub config: String,
    pub class: ConfigClass,
    pub outcome: Outcome,
    /// Fine χ² (equal φ-cells).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2: Option<Chi2Outcome>,
    /// Coarse χ² (cells of equal probability).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2_coarse: Option<Chi2Outcome>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normalisation_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integral: Option<IntegralCheck>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub round_trip: Option<RoundTripCheck>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cross: Option<CrossCheck>,
    /// Answer sources that report their inverse: ξ' of every sample against its ξ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reported_inverse: Option<RoundTripCheck>,
    /// Answer sources: their pdf at directions they did not sample.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pdf_queries: Option<PdfQueryCheck>,
    pub failures: Vec<Failure>,
}

impl ConfigResult {
    fn new(config: &Config, outcome: Outcome) -> Self {
        Self {
            config: config.name.clone(),
            class: config.class,
            outcome,
            chi2: None,
            chi2_coarse: None,
            normalisation_error: None,
            integral: None,
            round_trip: None,
            cross: None,
            reported_inverse: None,
            pdf_queries: None,
            failures: Vec::new(),
        }
    }

    fn fail(&mut self, check: Check, message: String) {
        self.failures.push(Failure { check, message });
    }

    /// The smaller p-value of the two χ² tests.
    pub fn worst_p_value(&self) -> Option<f64> {
        [&self.chi2, &self.chi2_coarse]
            .into_iter()
            .flatten()
            .map(|c| c.p_value)
            .reduce(f64::min)
    }

    /// Failed one of the checks that `rejection` counts.
    pub fn rejected_as(&self, rejection: &Rejection) -> bool {
        self.rejected() && self.failures.iter().any(|f| rejection.counts(f.check))
    }

    pub fn passed(&self) -> bool {
        self.failures.is_empty()
            && matches!(self.outcome, Outcome::Tested | Outcome::ZeroContribution)
    }

    /// Ran and did not pass (a configuration skipped as [`Outcome::Decided`] neither passed nor
    /// failed).
    pub fn failed(&self) -> bool {
        !self.passed() && self.outcome != Outcome::Decided
    }

    /// Failed a check of the suite (a panic is not a statistical rejection).
    pub fn rejected(&self) -> bool {
        self.outcome == Outcome::Tested && !self.failures.is_empty()
            || self.outcome == Outcome::ZeroContribution && !self.failures.is_empty()
    }
}

/// Per class summary of one subject (one row of the `linlight samplers` table).
#[derive(Clone, Debug, Serialize)]
pub struct ClassSummary {
    pub class: ConfigClass,
    pub configs: usize,
    pub tested: usize,
    pub zero_contribution: usize,
    pub failing: usize,
    pub worst_p_value: Option<f64>,
    pub max_normalisation_error: Option<f64>,
    pub passed: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct SubjectReport {
    pub name: String,
    pub description: String,
    pub role: Role,
    /// Certified subject: all configurations passed. Negative control: rejected.
    pub passed: bool,
    /// "pass" / "FAIL" / "rejected as expected" / "NOT REJECTED" / "panicked".
    pub verdict: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub panic: Option<String>,
    pub failing_configs: usize,
    /// Configurations failing each check (a configuration counts once per check).
    pub failures_by_check: BTreeMap<Check, usize>,
    /// Configurations with a prepared sampler (outcome `tested`).
    pub tested: usize,
    /// Negative controls: what must reject them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rejection: Option<Rejection>,
    /// Negative controls: configurations failing a check that `rejection` counts, and how many
    /// are needed.
    pub rejected_as_required: usize,
    pub needed: usize,
    pub worst_p_value: Option<f64>,
    pub max_normalisation_error: Option<f64>,
    pub classes: Vec<ClassSummary>,
    pub configs: Vec<ConfigResult>,
    /// Wall-clock time of this subject.
    pub elapsed_seconds: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct SuiteReport {
    pub settings: Settings,
    /// m: statistical tests the Šidák correction is taken over.
    pub statistical_tests: usize,
    pub alpha_per_test: f64,
    pub z_threshold: f64,
    pub configurations: Vec<Config>,
    /// Configurations some subjects run on besides the suite's (the fitted-table grid), once
    /// each.
    pub extra_configurations: Vec<Config>,
    pub techniques: Vec<SubjectReport>,
    pub negative_controls: Vec<SubjectReport>,
    /// Every technique passed and every negative control was rejected.
    pub passed: bool,
    pub elapsed_seconds: f64,
}

impl SubjectReport {
    /// The configurations run when some were skipped as [`Outcome::Decided`] (a negative
    /// control decided early); `None` when every configuration ran.
    pub fn decided_after(&self) -> Option<usize> {
        let skipped = self
            .configs
            .iter()
            .filter(|r| r.outcome == Outcome::Decided)
            .count();
        (skipped > 0).then(|| self.configs.len() - skipped)
    }
}

/// Šidák level and z threshold for m tests at suite-wide α.
pub fn corrected_levels(alpha: f64, m: usize) -> (f64, f64) {
    let m = m.max(1) as f64;
    // 1 − (1 − α)^(1/m) without cancellation.
    let alpha_c = -((-alpha).ln_1p() / m).exp_m1();
    let normal = Normal::new(0.0, 1.0).expect("standard normal");
    let z = normal.inverse_cdf(1.0 - alpha_c / 2.0).max(4.0);
    (alpha_c, z)
}

/// Ω⊥_R of the horizon-clipped line and Ω_R of the whole line, both evaluated in f64 by the
/// sampling crate from the frame's l-interval ([`LineFrame::projected_solid_angle`],
/// [`LineFrame::solid_angle`]; rounded once to f32, 6e-8 relative, far below the integral
/// check's 1e-5 floor). (0, Ω_R) when nothing is above the horizon; (0, 0) when the line is
/// degenerate.
pub fn lambert_reference(config: &Config) -> (f64, f64) {
    let Some(n) = unit_normal(config.n()) else {
        return (0.0, 0.0);
    };
    let Some(frame) = LineFrame::new(&config.segment(), config.x()) else {
        return (0.0, 0.0);
    };
    let omega = frame.solid_angle() as f64;
    let psa = frame
        .clip_to_horizon(n)
        .map_or(0.0, |c| c.projected_solid_angle(n) as f64);
    (psa.max(0.0), omega)
}

/// Ω_R of a sampler's support (2/d)(sin φ_end − sin φ_begin), in f64.
fn support_solid_angle(frame: &LineFrame) -> f64 {
    let (phi_b, phi_e) = PhiBinning::new(frame, 1).phi_range();
    2.0 / frame.d as f64 * (phi_e.sin() - phi_b.sin())
}

/// What the checks of one prepared sampler on one configuration share: the sampler (for an
/// answer source, the reference technique), the φ-binning of its support at the counting
/// resolution, the quadrature, and the measure of the support.
struct Bench<'a> {
    sampler: &'a dyn LineSampler,
    binning: PhiBinning,
    quad: Adaptive,
    /// dΩ_R/ds = 2/d of the support's frame.
    two_over_d: f64,
    /// Ω_R of the support.
    support_omega: f64,
    /// The absolute part of the pdf-consistency tolerance of the sampler's own densities.
    own_floor: f64,
    /// The unit normal in f64 (+z if the configuration's is degenerate).
    n: glam::DVec3,
}

impl<'a> Bench<'a> {
    fn new(sampler: &'a dyn LineSampler, config: &Config, settings: &Settings) -> Self {
        let frame = *sampler.support();
        let binning = PhiBinning::new(&frame, settings.bins * COUNTING_SUBDIVISION);
        let two_over_d = 2.0 / frame.d as f64;
        let support_omega = {
            let (phi_b, phi_e) = binning.phi_range();
            two_over_d * (phi_e.sin() - phi_b.sin())
        };
        Self {
            sampler,
            binning,
            quad: Adaptive::new(settings.nodes, QUAD_RELATIVE),
            two_over_d,
            support_omega,
            own_floor: PDF_CONSISTENCY_FLOOR / support_omega,
            n: unit_normal(config.n()).unwrap_or(glam::Vec3::Z).as_dvec3(),
        }
    }

    /// How far a density `q` claimed for `dir` is from `reference`'s pdf there (`q_ref`), in units of
    /// the pdf-consistency tolerance (relative, plus `floor`); where more than 1, the distance to
    /// the range of the pdf over the on-line directions the f32 `dir` cannot be told from
    /// ([`on_line_range`]). NaN where `q` is NaN.
    fn deviation(
        &self,
        reference: &dyn LineSampler,
        dir: glam::Vec3,
        q: f32,
        q_ref: f32,
        floor: f64,
    ) -> f64 {
        let scale = PDF_CONSISTENCY_RELATIVE * (q as f64).abs().max((q_ref as f64).abs()) + floor;
        let dev = (q as f64 - q_ref as f64).abs() / scale;
        if dev > 1.0 {
            // Only then (three pdf calls).
            let (lo, hi) = on_line_range(reference, &self.binning, dir);
            (lo - q as f64).max(q as f64 - hi).max(0.0) / scale
        } else {
            dev
        }
    }

    /// [`Self::deviation`] where it may exceed `worst` (what [`Worst::add`] keeps); `None` where
    /// it is certainly ≤ `worst`, decided without its division and, where it would take the
    /// on-line range, with one pdf call of the three where that suffices. NaN and a scale that is
    /// not positive and finite take the full computation.
    fn deviation_above(
        &self,
        reference: &dyn LineSampler,
        dir: glam::Vec3,
        (q, q_ref): (f32, f32),
        floor: f64,
        worst: f64,
    ) -> Option<f64> {
        let (q, q_ref) = (q as f64, q_ref as f64);
        let scale = PDF_CONSISTENCY_RELATIVE * q.abs().max(q_ref.abs()) + floor;
        let diff = (q - q_ref).abs();
        // diff/scale ≤ ½·min(worst, 1)·(1 + 2ε) ≤ min(worst, 1): not above worst, no range.
        if scale > 0.0 && scale.is_finite() && diff <= 0.5 * worst.min(1.0) * scale {
            return None;
        }
        let dev = diff / scale;
        if !(dev > 1.0) {
            return Some(dev);
        }
        // The on-line range [lo, hi] holds its middle value v, so max(lo − q, q − hi, 0) ≤
        // |q − v| (each difference rounded monotonically): |q − v|/scale ≤ worst settles it.
        let binning = &self.binning;
        let phi = binning.phi_of(dir);
        let middle = middle_pdf(reference, binning, phi);
        if (q - middle).abs() / scale <= worst {
            return None;
        }
        let (lo, hi) = on_line_range_around(reference, binning, phi, middle);
        Some((lo - q).max(q - hi).max(0.0) / scale)
    }
}

/// Normalisation: |∫ p_R dΩ_R − 1| of the masses (the sampler's pdf by quadrature).
fn check_normalisation(masses: &Masses, settings: &Settings, out: &mut ConfigResult) {
    let total = masses.total();
    let norm_err = (total - 1.0).abs();
    out.normalisation_error = Some(norm_err);
    if !(norm_err <= settings.normalisation_tolerance) {
        out.fail(
            Check::Normalisation,
            format!(
                "∫ p_R dΩ_R = {total:.9} (|err| {norm_err:.2e} > {:.0e})",
                settings.normalisation_tolerance
            ),
        );
    }
}

/// The pdf vanishes on the line outside the support: points spread over the rest of the line
/// in s (beyond a margin in s), and points beyond each end at φ-distances growing by 10× from
/// 1e-6 + 1e-5·Δφ rad (4× the rounding of an f32 direction's φ, 10× the relative rounding of
/// Δφ). The latter stay distinguishable from the ends where the s-grid near ±1 has no room
/// beyond them (for ℓ/d ≳ 3000 s_end rounds to 1 in f32).
fn check_pdf_vanishes_outside(bench: &Bench, out: &mut ConfigResult) {
    let binning = &bench.binning;
    let (phi_b, phi_e) = binning.phi_range();
    let (sb, se) = (phi_b.sin(), phi_e.sin());
    let margin = (1e-4 * (se - sb)).max(1e-5);
    let mut outside = Vec::new();
    for k in 0..8 {
        let t = (k as f64 + 0.5) / 8.0;
        if sb - margin > -1.0 {
            outside.push((-1.0 + t * (sb - margin + 1.0)).asin());
        }
        if se + margin < 1.0 {
            outside.push((se + margin + t * (1.0 - se - margin)).asin());
        }
    }
    let frame = bench.sampler.support();
    let (lb, le, d) = (frame.l_begin as f64, frame.l_end as f64, frame.d as f64);
    let half_pi = std::f64::consts::FRAC_PI_2;
    let mut delta = 1e-6 + 1e-5 * (phi_e - phi_b);
    while delta < std::f64::consts::PI {
        outside.extend([phi_b - delta, phi_e + delta]);
        delta *= 10.0;
    }
    outside.retain(|&phi| phi > -half_pi && phi < half_pi && (phi < phi_b || phi > phi_e));
    if let Some(&phi) = outside
        .iter()
        .find(|&&phi| bench.sampler.pdf(binning.direction(phi)) != 0.0)
    {
        out.fail(
            Check::Support,
            format!(
                "pdf ≠ 0 at φ = {phi:.9} outside the support [{phi_b:.9}, {phi_e:.9}] (l ∈ [{lb:e}, {le:e}], d = {d:e})"
            ),
        );
    }
}

/// One sample as the checks see it: its primary sample, direction and density, and the inverse
/// the implementation reports for it (answer sources only).
#[derive(Clone, Copy, Debug)]
struct Drawn {
    xi: f32,
    dir: glam::Vec3,
    p: f32,
    reported_inverse: Option<f32>,
}

/// The sampler's own samples: N primary samples of the counter-based stream, in order.
fn own_samples<'a>(
    sampler: &'a dyn LineSampler,
    settings: &Settings,
    stream: [u32; 3],
) -> impl Iterator<Item = Drawn> + 'a {
    let mut rng = CounterRng::new(settings.seed, stream);
    (0..settings.samples).map(move |_| {
        let xi = rng.next_f32();
        let (dir, p) = sampler.sample_with_pdf(xi);
        Drawn {
            xi,
            dir,
            p,
            reported_inverse: None,
        }
    })
}

/// The primary samples of [`own_samples`] (the batch an answer source is asked for).
fn primary_samples(settings: &Settings, stream: [u32; 3]) -> Vec<f32> {
    let mut rng = CounterRng::new(settings.seed, stream);
    (0..settings.samples).map(|_| rng.next_f32()).collect()
}

/// The answers of a source to the batch `xi`.
fn answered_samples<'a>(
    xi: &'a [f32],
    answers: &'a SampleAnswers,
) -> impl Iterator<Item = Drawn> + 'a {
    (0..xi.len()).map(move |i| Drawn {
        xi: xi[i],
        dir: answers.directions[i],
        p: answers.densities[i],
        reported_inverse: answers.inverse.as_ref().map(|v| v[i]),
    })
}

/// Counts of the samples per counting bin, and of those outside the support or not toward the
/// line.
struct Histogram {
    observed: Vec<u64>,
    outside_support: u64,
    not_toward_line: u64,
}

impl Histogram {
    fn new(bins: usize) -> Self {
        Self {
            observed: vec![0; bins],
            outside_support: 0,
            not_toward_line: 0,
        }
    }

    fn add(&mut self, binning: &PhiBinning, dir: glam::Vec3) {
        match binning.lookup(dir) {
            BinLookup::Bin(b) => self.observed[b] += 1,
            BinLookup::OutsideSupport => self.outside_support += 1,
            BinLookup::NotTowardLine => self.not_toward_line += 1,
        }
    }
}

/// The largest deviation seen (NaN counts as infinite) and the pair of densities there.
struct Worst {
    deviation: f64,
    at: (f32, f32),
}

impl Worst {
    fn new() -> Self {
        Self {
            deviation: 0.0,
            at: (0.0, 0.0),
        }
    }

    fn add(&mut self, dev: f64, at: (f32, f32)) {
        if !(dev <= self.deviation) {
            self.deviation = if dev.is_nan() { f64::INFINITY } else { dev };
            self.at = at;
        }
    }
}

/// Sums of a Monte Carlo estimate's per-sample values and their squares.
#[derive(Default)]
struct Moments {
    sum: f64,
    sum_sq: f64,
}

impl Moments {
    fn add(&mut self, w: f64) {
        self.sum += w;
        self.sum_sq += w * w;
    }

    /// (mean, unbiased variance of one sample, standard error of the mean) over `n` samples.
    fn estimate(&self, n: f64) -> (f64, f64, f64) {
        let mean = self.sum / n;
        let var = (self.sum_sq / n - mean * mean).max(0.0) * n / (n - 1.0).max(1.0);
        (mean, var, (var / n).sqrt())
    }
}

/// The partner's cross density at the samples: agreement with its certified pdf, and the
/// balance weight q/(p + q) (bounded: its mean has finite variance for the z-test).
struct CrossTally {
    floor: f64,
    worst: Worst,
    balance: Moments,
}

/// Round trips ξ → ω → ξ' with the tolerance 1e-4 + 1e-6·(2/d)·p (an s-error of 1e-6).
struct RoundTrips {
    check: RoundTripCheck,
    failure: Option<String>,
}

impl RoundTrips {
    fn new() -> Self {
        Self {
            check: RoundTripCheck {
                checked: 0,
                max_error: 0.0,
            },
            failure: None,
        }
    }

    fn add(&mut self, bench: &Bench, xi: f32, xi2: f32, p: f32) {
        let err = (xi2 as f64 - xi as f64).abs();
        let tol = ROUND_TRIP_XI + ROUND_TRIP_S * bench.two_over_d * p as f64;
        self.check.checked += 1;
        self.check.max_error = self.check.max_error.max(err);
        if !(err <= tol) && self.failure.is_none() {
            self.failure = Some(format!(
                "ξ = {xi} → ω → ξ' = {xi2} (|Δξ| {err:.2e} > {tol:.2e})"
            ));
        }
    }

    /// Fail `check` on the first violation; the summary, if anything was checked.
    fn test(&self, check: Check, out: &mut ConfigResult) -> Option<RoundTripCheck> {
        if let Some(m) = &self.failure {
            out.fail(check, m.clone());
        }
        (self.check.checked > 0).then(|| self.check.clone())
    }
}

/// Answers that are not numbers of the right kind (answer sources; Rust samplers are held to
/// the same by the other checks).
#[derive(Default)]
struct BadAnswers {
    non_finite_density: u64,
    negative_density: u64,
    non_unit_direction: u64,
}

impl BadAnswers {
    fn add(&mut self, s: &Drawn) {
        if !s.p.is_finite() {
            self.non_finite_density += 1;
        } else if s.p < 0.0 {
            self.negative_density += 1;
        }
        let w = s.dir.as_dvec3();
        if !w.is_finite() || !((w.length() - 1.0).abs() <= DIRECTION_TOLERANCE) {
            self.non_unit_direction += 1;
        }
    }

    fn test(&self, out: &mut ConfigResult) {
        if self.non_finite_density + self.negative_density + self.non_unit_direction > 0 {
            out.fail(
                Check::Answer,
                format!(
                    "{} densities NaN or infinite, {} negative; {} directions not finite unit \
                     vectors (| |ω| − 1 | > {DIRECTION_TOLERANCE:.0e})",
                    self.non_finite_density, self.negative_density, self.non_unit_direction
                ),
            );
        }
    }
}

/// Everything tabulated in one pass over the samples.
struct Tallies {
    histogram: Histogram,
    consistency: Worst,
    cross: Option<CrossTally>,
    integral: Moments,
    /// Samples with (n·ω)⁺ > 0 but density 0 or non-finite where the density on the line is not.
    zero_density_hits: u64,
    round_trips: RoundTrips,
    reported_inverse: RoundTrips,
    bad: BadAnswers,
}

/// Samples per pass of [`tabulate`]: a chunk is drawn, then binned, then judged sample by
/// sample, three tight loops instead of one; every tally sees the samples in the same order.
const CHUNK: usize = 256;

/// Tabulate the samples (in order: the first `round_trips` are round-tripped); `answered`:
/// the samples are an answer source's (only then are its answers checked as numbers).
fn tabulate(
    bench: &Bench,
    partner: Option<&Partner>,
    settings: &Settings,
    mut samples: impl Iterator<Item = Drawn>,
    answered: bool,
) -> Tallies {
    let mut t = Tallies {
        histogram: Histogram::new(bench.binning.bins()),
        consistency: Worst::new(),
        cross: partner.map(|pt| CrossTally {
            floor: PDF_CONSISTENCY_FLOOR / support_solid_angle(pt.sampler.support()),
            worst: Worst::new(),
            balance: Moments::default(),
        }),
        integral: Moments::default(),
        zero_density_hits: 0,
        round_trips: RoundTrips::new(),
        reported_inverse: RoundTrips::new(),
        bad: BadAnswers::default(),
    };
    let mut chunk: Vec<Drawn> = Vec::with_capacity(CHUNK);
    let mut first = 0;
    loop {
        chunk.clear();
        chunk.extend(samples.by_ref().take(CHUNK));
        if chunk.is_empty() {
            return t;
        }
        for s in &chunk {
            t.histogram.add(&bench.binning, s.dir);
        }
        for (j, s) in chunk.iter().enumerate() {
            if answered {
                t.bad.add(s);
            }
            judge(bench, partner, settings, &mut t, first + j, s);
        }
        first += chunk.len();
    }
}

/// Sample `i` (`s`) into the tallies other than the histogram.
fn judge(
    bench: &Bench,
    partner: Option<&Partner>,
    settings: &Settings,
    t: &mut Tallies,
    i: usize,
    s: &Drawn,
) {
    let (sampler, own_floor) = (bench.sampler, bench.own_floor);
    let Drawn { xi, dir, p, .. } = *s;
    // p must be the density of a direction on the line that the f32 sample cannot be told
    // apart from.
    let p_eval = sampler.pdf(dir);
    let worst = t.consistency.deviation;
    if let Some(dev) = bench.deviation_above(sampler, dir, (p, p_eval), own_floor, worst) {
        t.consistency.add(dev, (p, p_eval));
    }
    if let (Some(pt), Some(c)) = (partner, t.cross.as_mut()) {
        let (q, q_pdf) = ((pt.cross)(dir), pt.sampler.pdf(dir));
        let (reference, worst) = (pt.sampler.as_ref(), c.worst.deviation);
        if let Some(dev) = bench.deviation_above(reference, dir, (q, q_pdf), c.floor, worst) {
            c.worst.add(dev, (q, q_pdf));
        }
        if p > 0.0 && p.is_finite() {
            let w = (q as f64 / (p as f64 + q as f64)).max(0.0);
            c.balance.add(if w.is_finite() { w } else { 1.0 });
        }
    }
    let f = bench.n.dot(dir.as_dvec3()).max(0.0);
    if p > 0.0 && p.is_finite() {
        t.integral.add(f / p as f64);
    } else if f > 0.0 && on_line_range(sampler, &bench.binning, dir).0 > own_floor {
        // A density-0 sample loses its contribution to the estimate. Legitimate only where
        // the density is 0 at a direction on the line that the f32 sample cannot be told
        // from (the end of a density that vanishes at a horizon — in cosine space for LTC —
        // met at ξ within ~1e-5 of 0 or 1, which N = 10⁶ samples reach).
        t.zero_density_hits += 1;
    }
    if i < settings.round_trips {
        if let Some(xi2) = sampler.inverse(dir) {
            t.round_trips.add(bench, xi, xi2, p_eval);
        }
    }
    if let Some(xi2) = s.reported_inverse {
        t.reported_inverse.add(bench, xi, xi2, p_eval);
    }
}

/// Every sample is a unit direction toward the line, inside the support.
fn test_samples_on_support(h: &Histogram, out: &mut ConfigResult) {
    if h.not_toward_line > 0 {
        out.fail(
            Check::Direction,
            format!(
                "{} samples are not unit directions toward the line",
                h.not_toward_line
            ),
        );
    }
    if h.outside_support > 0 {
        out.fail(
            Check::Support,
            format!("{} samples outside the support", h.outside_support),
        );
    }
}

/// `sample_with_pdf` agrees with `pdf` at every sample.
fn test_pdf_consistency(worst: &Worst, out: &mut ConfigResult) {
    if worst.deviation > 1.0 {
        let (p, q) = worst.at;
        out.fail(
            Check::PdfConsistency,
            format!("sample_with_pdf {p:e} vs pdf(sample) {q:e}"),
        );
    }
}

/// Two χ² tests on cells of the counting bins, both merged to the s-resolution of N samples
/// (`chi2::s_resolution`): the fine test on the `bins` equal φ-cells (local errors), the coarse
/// test on `coarse_cells` cells of equal probability (smooth errors: a tilt of the density
/// spreads its noncentrality over few degrees of freedom there). A sample outside the support
/// or in a bin of zero expected count is an immediate failure of both (p = 0).
fn test_chi2(
    bench: &Bench,
    h: &Histogram,
    masses: &Masses,
    settings: &Settings,
    alpha_c: f64,
    out: &mut ConfigResult,
) {
    let binning = &bench.binning;
    let big_n = settings.samples as f64;
    let zero_bin_samples: u64 = h
        .observed
        .iter()
        .zip(&masses.mass)
        .filter(|(_, &m)| !(m > 0.0))
        .map(|(&o, _)| o)
        .sum();
    let resolution = s_resolution(settings.samples);
    let fine = binning.at_resolution(&runs(binning.bins(), COUNTING_SUBDIVISION), resolution);
    let coarse = equal_mass_cells(
        &binning.resolution_groups(resolution),
        &masses.mass,
        settings.coarse_cells,
    );
    let immediate = h.outside_support + h.not_toward_line + zero_bin_samples > 0;
    for (check, cells) in [(Check::Chi2, &fine), (Check::Chi2Coarse, &coarse)] {
        let mut chi2 = grouped_chi_square(&h.observed, &masses.mass, big_n, cells);
        chi2.zero_bin_samples = zero_bin_samples;
        if immediate {
            chi2.p_value = 0.0;
        }
        if !(chi2.p_value >= alpha_c) {
            out.fail(
                check,
                format!(
                    "χ² = {:.1} on {} dof, p = {:.3e} < α_c = {alpha_c:.2e}{}",
                    chi2.statistic,
                    chi2.dof,
                    chi2.p_value,
                    if chi2.zero_bin_samples > 0 {
                        format!(" ({} samples in zero-expected bins)", chi2.zero_bin_samples)
                    } else {
                        String::new()
                    }
                ),
            );
        }
        match check {
            Check::Chi2 => out.chi2 = Some(chi2),
            _ => out.chi2_coarse = Some(chi2),
        }
    }
}

/// Integral agreement: the Monte Carlo estimate of ∫(n·ω)⁺ dΩ_R lies within z_c standard errors
/// (plus the f32 floors; for answer sources, the geometry's rounding) of the reference, and no
/// sample lost its contribution to a density 0.
#[allow(clippy::too_many_arguments)]
fn test_integral(
    bench: &Bench,
    coverage: Coverage,
    answered: bool,
    config: &Config,
    t: &Tallies,
    settings: &Settings,
    z_c: f64,
    out: &mut ConfigResult,
) {
    let binning = &bench.binning;
    let reference = match coverage {
        Coverage::Lambert => lambert_reference(config).0,
        Coverage::OwnSupport => {
            let mut g = |phi: f64| {
                let dir = binning.direction(phi);
                if bench.sampler.pdf(dir) > 0.0 {
                    bench.n.dot(dir.as_dvec3()).max(0.0) * binning.jacobian(phi)
                } else {
                    0.0
                }
            };
            bench
                .quad
                .integrate_partition(&binning.edges(), &mut g)
                .value
        }
    };
    let (mean, var, std_error) = t.integral.estimate(settings.samples as f64);
    let mut tolerance = z_c * std_error
        + INTEGRAL_RELATIVE_FLOOR * reference.abs()
        + INTEGRAL_SOLID_ANGLE_FLOOR * bench.support_omega;
    if answered {
        let (phi_b, phi_e) = binning.phi_range();
        tolerance += INTEGRAL_GEOMETRY_ROUNDING / (phi_e - phi_b) * reference.abs();
    }
    let relative_std = if reference > 0.0 {
        var.sqrt() / reference
    } else {
        0.0
    };
    if !((mean - reference).abs() <= tolerance) {
        out.fail(
            Check::Integral,
            format!(
                "∫(n·ω)⁺ estimate {mean:.7e} ± {std_error:.2e} vs reference {reference:.7e} (tolerance {tolerance:.2e})"
            ),
        );
    }
    if t.zero_density_hits > 0 {
        out.fail(
            Check::Integral,
            format!(
                "{} samples with (n·ω)⁺ > 0 but density 0 or non-finite",
                t.zero_density_hits
            ),
        );
    }
    out.integral = Some(IntegralCheck {
        estimate: mean,
        reference,
        std_error,
        tolerance,
        relative_std,
    });
}

/// Cross density: the partner's cross density agrees with its pdf at every sample, and
/// E_p[q/(p + q)] = ∫ p·q/(p + q) dΩ_R (both pdfs certified on their own).
fn test_cross(
    bench: &Bench,
    pt: &Partner,
    c: &CrossTally,
    settings: &Settings,
    z_c: f64,
    out: &mut ConfigResult,
) {
    if c.worst.deviation > 1.0 {
        let (q, q_pdf) = c.worst.at;
        out.fail(
            Check::CrossDensity,
            format!(
                "{} cross density {q:e} vs its pdf {q_pdf:e} at a sample",
                pt.name
            ),
        );
    }
    let binning = &bench.binning;
    let mut g = |phi: f64| {
        let dir = binning.direction(phi);
        let (p, q) = (bench.sampler.pdf(dir) as f64, pt.sampler.pdf(dir) as f64);
        if p + q > 0.0 {
            p * q / (p + q) * binning.jacobian(phi)
        } else {
            0.0
        }
    };
    let reference = bench
        .quad
        .integrate_partition(&binning.edges(), &mut g)
        .value;
    let (mean, _, std_error) = c.balance.estimate(settings.samples as f64);
    let tolerance =
        z_c * std_error + INTEGRAL_RELATIVE_FLOOR * reference.abs() + INTEGRAL_SOLID_ANGLE_FLOOR;
    if !((mean - reference).abs() <= tolerance) {
        out.fail(
            Check::CrossBalance,
            format!(
                "E[q/(p+q)] estimate {mean:.7e} ± {std_error:.2e} vs reference \
                 {reference:.7e} (tolerance {tolerance:.2e}; q: {})",
                pt.name
            ),
        );
    }
    out.cross = Some(CrossCheck {
        partner: pt.name.to_string(),
        worst_deviation: c.worst.deviation,
        balance_estimate: mean,
        balance_reference: reference,
        std_error,
        tolerance,
    });
}

/// Directions at which an answer source's own pdf is queried per configuration (or N, if
/// fewer).
pub const PDF_QUERIES: usize = 65_536;

/// An answer source's pdf at directions it did not sample: uniform in solid angle over the
/// whole, unclipped line (so below the horizon and outside the support too, where it must be 0),
/// from the configuration's stream with third word 1; each against the reference pdf with the
/// pdf-consistency tolerance.
fn check_pdf_queries(
    bench: &Bench,
    source: &SharedSource,
    config: &Config,
    settings: &Settings,
    stream: [u32; 3],
    out: &mut ConfigResult,
) -> Result<(), SourceError> {
    let Some(whole) = LineFrame::new(&config.segment(), config.x()) else {
        return Ok(());
    };
    let line = PhiBinning::new(&whole, 1);
    let (phi_b, phi_e) = line.phi_range();
    let (sb, se) = (phi_b.sin(), phi_e.sin());
    let mut rng = CounterRng::new(settings.seed, [stream[0], stream[1], 1]);
    let directions: Vec<glam::Vec3> = (0..PDF_QUERIES.min(settings.samples))
        .map(|_| {
            let s = sb + rng.next_f32() as f64 * (se - sb);
            line.direction(s.clamp(-1.0, 1.0).asin())
        })
        .collect();
    let answers = source.pdf(config, &directions)?;
    let floor = PDF_CONSISTENCY_FLOOR / bench.support_omega;
    let mut worst = Worst::new();
    let mut worst_dir = glam::Vec3::ZERO;
    for (&dir, &q) in directions.iter().zip(&answers) {
        let p = bench.sampler.pdf(dir);
        let dev = bench.deviation(bench.sampler, dir, q, p, floor);
        if !(dev <= worst.deviation) {
            worst_dir = dir;
        }
        worst.add(dev, (q, p));
    }
    if worst.deviation > 1.0 {
        let (q, p) = worst.at;
        out.fail(
            Check::CrossDensity,
            format!(
                "its pdf {q:e} vs the reference pdf {p:e} at ω = {worst_dir:?} (φ = {:.9}, \
                 support [{:.9}, {:.9}]), a direction it did not sample",
                bench.binning.phi_of(worst_dir),
                bench.binning.phi_range().0,
                bench.binning.phi_range().1
            ),
        );
    }
    out.pdf_queries = Some(PdfQueryCheck {
        queried: directions.len(),
        worst_deviation: worst.deviation,
    });
    Ok(())
}

/// Run one prepared sampler (for an answer source: the reference technique, with the source's
/// answers as the samples) through every check: tabulate, then test.
#[allow(clippy::too_many_arguments)]
fn check_sampler(
    sampler: &dyn LineSampler,
    partner: Option<&Partner>,
    subject: &SamplerUnderTest,
    config: &Config,
    settings: &Settings,
    levels: (f64, f64),
    stream: [u32; 3],
    out: &mut ConfigResult,
) -> Result<(), SourceError> {
    let (alpha_c, z_c) = levels;
    let bench = Bench::new(sampler, config, settings);
    let masses = bench.binning.masses(sampler, &bench.quad);
    check_normalisation(&masses, settings, out);
    check_pdf_vanishes_outside(&bench, out);
    let t = match &subject.answers {
        None => tabulate(
            &bench,
            partner,
            settings,
            own_samples(sampler, settings, stream),
            false,
        ),
        Some(source) => {
            let xi = primary_samples(settings, stream);
            let answers = source.sample(config, &xi)?;
            let samples = answered_samples(&xi, &answers);
            tabulate(&bench, partner, settings, samples, true)
        }
    };
    let round_trip = t.round_trips.test(Check::RoundTrip, out);
    out.round_trip = round_trip;
    test_samples_on_support(&t.histogram, out);
    test_pdf_consistency(&t.consistency, out);
    test_chi2(&bench, &t.histogram, &masses, settings, alpha_c, out);
    let answered = subject.answers.is_some();
    test_integral(
        &bench,
        subject.coverage,
        answered,
        config,
        &t,
        settings,
        z_c,
        out,
    );
    if let (Some(pt), Some(c)) = (partner, &t.cross) {
        test_cross(&bench, pt, c, settings, z_c, out);
    }
    if let Some(source) = &subject.answers {
        t.bad.test(out);
        let reported = t.reported_inverse.test(Check::ReportedInverse, out);
        out.reported_inverse = reported;
        check_pdf_queries(&bench, source, config, settings, stream, out)?;
    }
    Ok(())
}

/// One subject on one configuration (never panics: panics become `Outcome::Panicked`, and
/// print nothing: [`catch_quietly`]).
pub fn certify_config(
    subject: &SamplerUnderTest,
    config: &Config,
    settings: &Settings,
    levels: (f64, f64),
    stream: [u32; 3],
) -> ConfigResult {
    let run = catch_quietly(|| {
        let prepared = (subject.prepare)(config);
        match prepared {
            None => {
                let mut r = ConfigResult::new(config, Outcome::ZeroContribution);
                if subject.coverage == Coverage::Lambert {
                    let (psa, omega) = lambert_reference(config);
                    if psa > ZERO_CONTRIBUTION_TOLERANCE * omega {
                        r.fail(
                            Check::ZeroContribution,
                            format!("prepare returned None but Ω⊥_R = {psa:.6e} > 0"),
                        );
                    }
                }
                r
            }
            Some(s) => {
                let mut r = ConfigResult::new(config, Outcome::Tested);
                let partner = subject.partner.as_ref().and_then(|p| p(config));
                let checked = check_sampler(
                    s.as_ref(),
                    partner.as_ref(),
                    subject,
                    config,
                    settings,
                    levels,
                    stream,
                    &mut r,
                );
                if let Err(e) = checked {
                    r = ConfigResult::new(config, Outcome::SourceFailed);
                    r.fail(Check::Source, e.0);
                }
                r
            }
        }
    });
    run.unwrap_or_else(|message| {
        let mut r = ConfigResult::new(config, Outcome::Panicked);
        r.fail(Check::Panic, message);
        r
    })
}

fn summarise(
    subject: &SamplerUnderTest,
    configs: Vec<ConfigResult>,
    panic: Option<String>,
) -> SubjectReport {
    let mut classes = Vec::new();
    for class in ConfigClass::ALL {
        let rows: Vec<&ConfigResult> = configs.iter().filter(|r| r.class == class).collect();
        if rows.is_empty() {
            continue;
        }
        classes.push(ClassSummary {
            class,
            configs: rows.len(),
            tested: rows.iter().filter(|r| r.outcome == Outcome::Tested).count(),
            zero_contribution: rows
                .iter()
                .filter(|r| r.outcome == Outcome::ZeroContribution)
                .count(),
            failing: rows.iter().filter(|r| r.failed()).count(),
            worst_p_value: rows
                .iter()
                .filter_map(|r| r.worst_p_value())
                .reduce(f64::min),
            max_normalisation_error: rows
                .iter()
                .filter_map(|r| r.normalisation_error)
                .reduce(f64::max),
            passed: !rows.iter().any(|r| r.failed()),
        });
    }
    let mut failures_by_check = BTreeMap::new();
    for r in &configs {
        let mut seen: Vec<Check> = r.failures.iter().map(|f| f.check).collect();
        seen.sort();
        seen.dedup();
        for c in seen {
            *failures_by_check.entry(c).or_insert(0) += 1;
        }
    }
    let failing_configs = configs.iter().filter(|r| r.failed()).count();
    let tested = configs
        .iter()
        .filter(|r| r.outcome == Outcome::Tested)
        .count();
    let rejected_as_required = configs
        .iter()
        .filter(|r| r.rejected_as(&subject.rejection))
        .count();
    let needed = subject.rejection.needed(tested);
    let runnable = panic.is_none()
        && configs.iter().all(|r| {
            matches!(
                r.outcome,
                Outcome::Tested | Outcome::ZeroContribution | Outcome::Decided
            )
        });
    let source_failed = configs.iter().any(|r| r.outcome == Outcome::SourceFailed);
    let (passed, verdict) = match subject.role {
        _ if source_failed => (false, "source failed".to_string()),
        _ if !runnable => (false, "panicked".to_string()),
        Role::Certify if failing_configs == 0 => (true, "pass".to_string()),
        Role::Certify => (false, "FAIL".to_string()),
        Role::NegativeControl if rejected_as_required >= needed => {
            (true, "rejected as expected".to_string())
        }
        Role::NegativeControl => (false, "NOT REJECTED".to_string()),
    };
    SubjectReport {
        name: subject.name.clone(),
        description: subject.description.clone(),
        role: subject.role,
        passed,
        verdict,
        panic,
        failing_configs,
        failures_by_check,
        tested,
        rejection: (subject.role == Role::NegativeControl).then(|| subject.rejection.clone()),
        rejected_as_required,
        needed,
        worst_p_value: classes
            .iter()
            .filter_map(|c| c.worst_p_value)
            .reduce(f64::min),
        max_normalisation_error: classes
            .iter()
            .filter_map(|c| c.max_normalisation_error)
            .reduce(f64::max),
        classes,
        configs,
        elapsed_seconds: 0.0,
    }
}

/// Run one subject over all configurations (in parallel). Configuration 0 runs first on its
/// own: if the subject panics there (unimplemented), the rest are not run. A negative control
/// runs in chunks until its rejection is decided ([`Settings::controls_until_decided`]).
pub fn run_subject(
    subject: &SamplerUnderTest,
    subject_index: usize,
    configs: &[Config],
    settings: &Settings,
    levels: (f64, f64),
) -> SubjectReport {
    let started = std::time::Instant::now();
    let mut report = run_subject_inner(subject, subject_index, configs, settings, levels);
    report.elapsed_seconds = started.elapsed().as_secs_f64();
    report
}

fn run_subject_inner(
    subject: &SamplerUnderTest,
    subject_index: usize,
    configs: &[Config],
    settings: &Settings,
    levels: (f64, f64),
) -> SubjectReport {
    let stream = |i: usize| [subject_index as u32, i as u32, 0];
    let Some(first_config) = configs.first() else {
        return summarise(subject, Vec::new(), None);
    };
    let first = certify_config(subject, first_config, settings, levels, stream(0));
    if first.outcome == Outcome::Panicked {
        let msg = first.failures.first().map(|f| f.message.clone());
        let mut results = vec![first];
        results.extend(
            configs[1..]
                .iter()
                .map(|c| ConfigResult::new(c, Outcome::NotRun)),
        );
        return summarise(subject, results, msg);
    }
    let mut results = vec![first];
    let run = |range: std::ops::Range<usize>| -> Vec<ConfigResult> {
        configs[range.clone()]
            .par_iter()
            .zip(range)
            .map(|(c, i)| certify_config(subject, c, settings, levels, stream(i)))
            .collect()
    };
    if subject.role == Role::NegativeControl && settings.controls_until_decided {
        let mut next = 1;
        while next < configs.len() && !rejection_decided(subject, &results, configs.len()) {
            let end = (next + CONTROL_CHUNK).min(configs.len());
            results.extend(run(next..end));
            next = end;
        }
        results.extend(
            configs[next..]
                .iter()
                .map(|c| ConfigResult::new(c, Outcome::Decided)),
        );
    } else {
        results.extend(run(1..configs.len()));
    }
    summarise(subject, results, None)
}

/// Configurations a negative control runs between two checks of [`rejection_decided`].
const CONTROL_CHUNK: usize = 4;

/// Whether `done` (the first of `total` configurations, in order) decide that `control` is
/// rejected: its required rejections reach what it would need if every configuration not yet
/// run were tested. The verdict over all `total` is then the same (`needed` grows with
/// `tested`, and rejections only add up), a panic in a later configuration aside.
fn rejection_decided(control: &SamplerUnderTest, done: &[ConfigResult], total: usize) -> bool {
    let tested = done.iter().filter(|r| r.outcome == Outcome::Tested).count();
    let rejected = done
        .iter()
        .filter(|r| r.rejected_as(&control.rejection))
        .count();
    rejected >= control.rejection.needed(tested + (total - done.len()))
}

/// Statistical tests per (certified sampler, configuration) without a partner: fine χ², coarse
/// χ², integral (a partner adds the cross-balance test).
pub const STATISTICAL_TESTS_PER_CONFIG: usize = 3;

/// m of the Šidák correction: the statistical tests of `certified` over their configurations
/// (`suite`: the suite's).
pub fn statistical_tests(certified: &[SamplerUnderTest], suite: &[Config]) -> usize {
    certified
        .iter()
        .map(|s| s.statistical_tests_per_config() * s.configs(suite).len())
        .sum()
}

/// Run certified subjects and negative controls over the suite's configurations.
pub fn run_suite(
    certified: &[SamplerUnderTest],
    controls: &[SamplerUnderTest],
    settings: &Settings,
) -> SuiteReport {
    run_suite_at(certified, controls, settings, certified)
}

/// [`run_suite`] with the Šidák correction taken over the subjects `levels_of` (e.g. to run
/// extra controls alone at the level the full suite would judge them: the tilt power table).
pub fn run_suite_at(
    certified: &[SamplerUnderTest],
    controls: &[SamplerUnderTest],
    settings: &Settings,
    levels_of: &[SamplerUnderTest],
) -> SuiteReport {
    let started = std::time::Instant::now();
    let configs = suite_configs(settings.seed, settings.random_configs);
    let m = statistical_tests(levels_of, &configs).max(1);
    let (alpha_c, z) = corrected_levels(settings.alpha, m);
    // Subjects run concurrently as well as their configurations (a subject's first
    // configuration runs alone, and a few slow configurations end each subject): every
    // (subject, configuration) draws from its own counter-based stream and the reports are
    // collected in order, so the verdicts and p-values do not depend on the thread count.
    let techniques: Vec<SubjectReport> = certified
        .par_iter()
        .enumerate()
        .map(|(i, s)| run_subject(s, i, &s.configs(&configs), settings, (alpha_c, z)))
        .collect();
    let negative_controls: Vec<SubjectReport> = controls
        .par_iter()
        .enumerate()
        .map(|(i, s)| run_subject(s, 1000 + i, &s.configs(&configs), settings, (alpha_c, z)))
        .collect();
    let passed = techniques
        .iter()
        .chain(&negative_controls)
        .all(|r| r.passed);
    let mut extra_configurations: Vec<Config> = Vec::new();
    for s in certified.iter().chain(controls) {
        for c in &s.extra_configs {
            if !extra_configurations.iter().any(|e| e.name == c.name) {
                extra_configurations.push(c.clone());
            }
        }
    }
    SuiteReport {
        settings: settings.clone(),
        statistical_tests: m,
        alpha_per_test: alpha_c,
        z_threshold: z,
        configurations: configs,
        extra_configurations,
        techniques,
        negative_controls,
        passed,
        elapsed_seconds: started.elapsed().as_secs_f64(),
    }
}

/// [`run_suite`] of one certified subject that draws the primary samples of the subject at
/// `index` of a [`run_suite`] run (a (subject, configuration) stream is keyed by the subject's
/// position and the configuration's): run at the index of technique T in
/// [`crate::subjects::certified`], it is given, configuration by configuration, the ξ that
/// `linlight samplers` gives T's own sampler, so that an answer source claiming T can be
/// compared with T statistic for statistic. The Šidák correction is over this subject's tests.
pub fn run_suite_as(subject: &SamplerUnderTest, index: usize, settings: &Settings) -> SuiteReport {
    let started = std::time::Instant::now();
    let configs = suite_configs(settings.seed, settings.random_configs);
    let m = statistical_tests(std::slice::from_ref(subject), &configs).max(1);
    let (alpha_c, z) = corrected_levels(settings.alpha, m);
    let report = run_subject(
        subject,
        index,
        &subject.configs(&configs),
        settings,
        (alpha_c, z),
    );
    SuiteReport {
        settings: settings.clone(),
        statistical_tests: m,
        alpha_per_test: alpha_c,
        z_threshold: z,
        configurations: configs,
        extra_configurations: subject.extra_configs.clone(),
        passed: report.passed,
        techniques: vec![report],
        negative_controls: Vec::new(),
        elapsed_seconds: started.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::subjects::{self, technique};
    use linlight_sampling::Technique;

    /// A subject run alone at the index of a technique in a run draws that technique's primary
    /// samples (the same statistics, configuration by configuration); at another index, others.
    #[test]
    fn a_subject_run_alone_at_an_index_draws_the_samples_of_that_index() {
        let settings = Settings {
            samples: 4_000,
            random_configs: 2,
            ..Settings::default()
        };
        let psa = || technique(Technique::ProjectedSolidAngle);
        let run = run_suite(&[technique(Technique::Area), psa()], &[], &settings);
        let stats = |c: &ConfigResult| {
            let i = c.integral.as_ref().map(|i| (i.estimate, i.std_error));
            format!("{:?} {:?} {i:?}", c.chi2, c.chi2_coarse)
        };
        let same = |alone: &SuiteReport| {
            let (a, b) = (&run.techniques[1].configs, &alone.techniques[0].configs);
            assert_eq!(a.len(), b.len());
            a.iter().zip(b).all(|(x, y)| stats(x) == stats(y))
        };
        assert!(same(&run_suite_as(&psa(), 1, &settings)));
        assert!(!same(&run_suite_as(&psa(), 0, &settings)));
    }

    /// `deviation_above` is `None` only where the deviation is ≤ `worst`, and otherwise the
    /// deviation bit for bit: claimed densities off by 0 to 100 % (and NaN, 0, ∞) at samples and
    /// at the support's ends, against every kind of running worst.
    #[test]
    fn deviation_above_agrees_with_the_deviation() {
        let config = crate::configs::paper_sanity();
        let sampler = (technique(Technique::ClippedSolidAngle).prepare)(&config).unwrap();
        let bench = Bench::new(sampler.as_ref(), &config, &Settings::default());
        let (phi_b, phi_e) = bench.binning.phi_range();
        let mut dirs: Vec<glam::Vec3> =
            (0..200).map(|i| sampler.sample(i as f32 / 199.0)).collect();
        for k in 0..12 {
            let delta = 10f64.powi(-k);
            dirs.push(bench.binning.direction(phi_b + delta * (phi_e - phi_b)));
            dirs.push(bench.binning.direction(phi_e - delta * (phi_e - phi_b)));
        }
        let factors = [0.0, 1e-7, 1e-4, 9e-4, 1.1e-3, 0.01, 1.0, -1.0, f64::NAN];
        let worsts = [0.0, 1e-3, 0.5, 1.0, 1.5, 1e3, f64::INFINITY];
        let mut some = 0;
        for &dir in &dirs {
            let q_ref = sampler.pdf(dir);
            for f in factors {
                let q = (q_ref as f64 * (1.0 + f)) as f32;
                for q in [q, 0.0, f32::INFINITY] {
                    for floor in [bench.own_floor, 0.0] {
                        let d = bench.deviation(sampler.as_ref(), dir, q, q_ref, floor);
                        for worst in worsts {
                            match bench.deviation_above(
                                sampler.as_ref(),
                                dir,
                                (q, q_ref),
                                floor,
                                worst,
                            ) {
                                None => assert!(d <= worst, "{dir} {q} {q_ref} {worst}: {d}"),
                                Some(x) => {
                                    some += 1;
                                    assert_eq!(x.to_bits(), d.to_bits(), "{dir} {q} {q_ref}");
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(some > 1000, "{some}");
    }

    #[test]
    fn sidak_levels() {
        let (a, z) = corrected_levels(0.01, 1);
        assert!((a - 0.01).abs() < 1e-15);
        assert_eq!(z, 4.0);
        let (a, z) = corrected_levels(0.01, 1000);
        assert!((1.0 - (1.0 - a).powf(1000.0) - 0.01).abs() < 1e-12);
        assert!(z > 4.0 && z < 5.0, "{z}");
    }

    /// Subjects and configurations run concurrently: every verdict, p-value and failure
    /// message is the same on one thread as on three.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let settings = Settings {
            samples: 4_000,
            random_configs: 6,
            ..Settings::default()
        };
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool");
            let r = pool.install(|| {
                run_suite(
                    &[
                        technique(Technique::ClippedSolidAngle),
                        technique(Technique::ProjectedSolidAngle),
                    ],
                    &[
                        subjects::control_one_halley_iteration(),
                        subjects::control_scaled_pdf(Technique::ClippedSolidAngle),
                    ],
                    &settings,
                )
            });
            let rows: Vec<String> = r
                .techniques
                .iter()
                .chain(&r.negative_controls)
                .flat_map(|s| {
                    s.configs.iter().map(move |c| {
                        format!(
                            "{} {} {:?} {:?} {:?} {:?}",
                            s.name,
                            c.config,
                            c.outcome,
                            c.chi2.as_ref().map(|x| x.p_value.to_bits()),
                            c.chi2_coarse.as_ref().map(|x| x.p_value.to_bits()),
                            c.failures.iter().map(|f| &f.message).collect::<Vec<_>>()
                        )
                    })
                })
                .collect();
            (r.passed, rows)
        };
        let one = run(1);
        assert!(one.1.len() > 40, "{}", one.1.len());
        assert_eq!(one, run(3));
    }

    #[test]
    fn lambert_reference_sanity_value() {
        let (psa, omega) = lambert_reference(&crate::configs::paper_sanity());
        assert!((psa - (1.0 + std::f64::consts::FRAC_PI_2)).abs() < 1e-6);
        assert!((omega - 2.0 * 2f64.sqrt()).abs() < 1e-6);
    }

    /// The machinery at a small N (the full suite at its defaults is `linlight samplers`, run
    /// end to end by tests/samplers_cli.rs, which must exit 0): the solid angle techniques pass
    /// and every control that the deterministic checks catch is rejected, each by the check
    /// that its design targets.
    #[test]
    fn solid_angle_techniques_pass_and_controls_are_rejected() {
        let settings = Settings {
            samples: 40_000,
            random_configs: 20,
            ..Settings::default()
        };
        let certified = [
            technique(Technique::SolidAngle),
            technique(Technique::ClippedSolidAngle),
        ];
        let controls = [
            subjects::control_scaled_pdf(Technique::ClippedSolidAngle),
            subjects::control_clipped_samples_unclipped_pdf(),
            subjects::control_one_halley_iteration(),
            subjects::control_ltc_without_kappa(),
        ];
        let r = run_suite(&certified, &controls, &settings);
        for t in &r.techniques {
            let bad: Vec<_> = t.configs.iter().filter(|c| !c.passed()).collect();
            assert!(t.passed, "{}: {:#?}", t.name, bad);
        }
        let expect = [
            Check::Normalisation,
            Check::Chi2,
            Check::RoundTrip,
            Check::Normalisation,
        ];
        for (c, check) in r.negative_controls.iter().zip(expect) {
            eprintln!(
                "{}: {} ({} failing, {:?})",
                c.name, c.verdict, c.failing_configs, c.failures_by_check
            );
            assert!(c.passed, "{} not rejected", c.name);
            assert!(
                c.failures_by_check.get(&check).is_some_and(|&k| k > 0),
                "{}",
                c.name
            );
        }
    }

    /// The LTC of the fitted table, the one-sample mixture and the cross densities pass at a
    /// small N; the cross density without κ is rejected by the cross checks (and only by them:
    /// its samples and pdf are the projected solid angle's).
    #[test]
    fn mixture_table_and_cross_densities() {
        let settings = Settings {
            samples: 20_000,
            random_configs: 5,
            ..Settings::default()
        };
        let certified = [
            subjects::ltc_fitted_table().with_partner(subjects::diffuse_partner),
            technique(Technique::ProjectedSolidAngle).with_partner(subjects::specular_partner),
            subjects::mixture(),
        ];
        let controls = [subjects::control_cross_density_without_kappa()];
        let r = run_suite(&certified, &controls, &settings);
        let grid = crate::configs::ltc_table_configs().len();
        assert_eq!(r.techniques[0].configs.len(), grid);
        assert_eq!(r.techniques[2].configs.len(), r.configurations.len() + grid);
        assert_eq!(r.extra_configurations.len(), grid);
        // m counts the cross-balance test of the subjects with a partner.
        assert_eq!(
            r.statistical_tests,
            4 * grid + 4 * r.configurations.len() + 3 * (r.configurations.len() + grid)
        );
        for t in &r.techniques {
            let bad: Vec<_> = t.configs.iter().filter(|c| !c.passed()).collect();
            assert!(t.passed, "{}: {:#?}", t.name, bad);
        }
        let with_cross = r.techniques[0].configs.iter().filter(|c| c.cross.is_some());
        assert_eq!(with_cross.count(), grid);
        let c = &r.negative_controls[0];
        assert!(c.passed, "{}: {:?}", c.verdict, c.failures_by_check);
        assert!(c
            .failures_by_check
            .keys()
            .all(|k| matches!(k, Check::CrossDensity | Check::CrossBalance)));
    }

    /// A control counts as rejected only by the checks its `Rejection` names, on the required
    /// share of configurations.
    #[test]
    fn controls_are_judged_by_their_required_checks() {
        let settings = Settings {
            samples: 20_000,
            random_configs: 10,
            ..Settings::default()
        };
        // pdf × 1.01 fails the normalisation, never χ² alone at this N on most configurations.
        let by_norm = subjects::control_scaled_pdf(Technique::ClippedSolidAngle);
        let by_chi2_everywhere = subjects::control_scaled_pdf(Technique::ClippedSolidAngle)
            .rejected_by(Rejection::by_chi2(1.0));
        let r = run_suite(&[], &[by_norm, by_chi2_everywhere], &settings);
        assert!(r.negative_controls[0].passed);
        assert!(!r.negative_controls[1].passed);
        assert_eq!(r.negative_controls[1].verdict, "NOT REJECTED");
        assert_eq!(r.negative_controls[1].needed, r.negative_controls[1].tested);
    }
    /// A negative control stops once the configurations run decide its rejection, with the
    /// verdict and, configuration by configuration, the results of a run over every
    /// configuration; a control that is not rejected runs every configuration.
    #[test]
    fn controls_stop_once_decided_with_the_full_verdict() {
        let full = Settings {
            samples: 20_000,
            random_configs: 10,
            controls_until_decided: false,
            ..Settings::default()
        };
        let early = Settings {
            controls_until_decided: true,
            ..full.clone()
        };
        let scaled = || subjects::control_scaled_pdf(Technique::ClippedSolidAngle);
        let controls = || {
            [
                scaled(),
                scaled().rejected_by(Rejection {
                    by: Vec::new(),
                    min_share: 0.5,
                }),
                scaled().rejected_by(Rejection::by_chi2(1.0)),
            ]
        };
        let all = run_suite(&[], &controls(), &full);
        let decided = run_suite(&[], &controls(), &early);
        let json = |r: &ConfigResult| serde_json::to_value(r).unwrap();
        let mut ran = Vec::new();
        for (a, b) in all.negative_controls.iter().zip(&decided.negative_controls) {
            assert_eq!((a.passed, &a.verdict), (b.passed, &b.verdict), "{}", a.name);
            let n = b
                .configs
                .iter()
                .take_while(|r| r.outcome != Outcome::Decided)
                .count();
            assert!(b.configs[n..].iter().all(|r| r.outcome == Outcome::Decided));
            assert_eq!(b.decided_after(), (n < b.configs.len()).then_some(n));
            assert_eq!(a.decided_after(), None);
            assert!(a.configs.iter().all(|r| r.outcome != Outcome::Decided));
            for (x, y) in a.configs.iter().zip(&b.configs[..n]) {
                assert_eq!(json(x), json(y), "{}", a.name);
            }
            ran.push(n);
        }
        let total = all.configurations.len();
        assert!(all.negative_controls[0].passed && ran[0] < total, "{ran:?}");
        // Half of the configurations rejected: more than half of them run.
        assert!(
            all.negative_controls[1].passed && 2 * ran[1] > total,
            "{ran:?}"
        );
        assert!(ran[1] < total, "{ran:?}");
        assert!(
            !all.negative_controls[2].passed && ran[2] == total,
            "{ran:?}"
        );
    }
}
