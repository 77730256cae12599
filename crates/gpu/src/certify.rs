//! The kernels' own certification beside the sampler suite: per-sample agreement with the Rust
//! f32 samplers on the same ξ, the backward-error sweep of the projected-solid-angle inversion
//! on the kernels' samples, and the LTC table lookup and MIS weights against the Rust ones.
//!
//! Units of the agreement:
//! - directions: |ω_kernel − ω_rust| (Euclidean, evaluated in f64) in units of f32's ε = 2⁻²³,
//!   i.e. in ulps of 1, the magnitude of a unit vector's largest component;
//! - densities: the distance of the two f32 values in units in the last place (the count of f32
//!   values between them).

use crate::source::{query, KernelConfig, Technique};
use crate::{CertifyMode, Gpu, GpuError};
use glam::Vec3;
use linlight_kernels::CERTIFY_ANSWER_VEC4S;
use linlight_sampling::backward_error::{sweep_f32_with, SweepConfig, SweepRow};
use linlight_sampling::ltc::LtcLine;
use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
use linlight_sampling::solid_angle::SolidAngle;
use linlight_sampling::{mis, LineSampler, Segment};
use linlight_verify::configs::Config;

/// The configuration of the suite as the kernels take it.
pub fn kernel_config(c: &Config) -> KernelConfig {
    KernelConfig {
        begin: c.begin,
        end: c.end,
        x: c.x,
        n: c.n,
        view: c.view,
        a_rows: c.a_rows,
    }
}

/// The Rust f32 sampler of a technique for a configuration (`None` where it prepares nothing).
pub fn rust_sampler(technique: Technique, c: &Config) -> Option<Box<dyn LineSampler>> {
    let seg = Segment::new(Vec3::from(c.begin), Vec3::from(c.end));
    let (x, n) = (Vec3::from(c.x), Vec3::from(c.n));
    match technique {
        Technique::Clipped => {
            SolidAngle::prepare_clipped(&seg, x, n).map(|s| Box::new(s) as Box<dyn LineSampler>)
        }
        Technique::ProjectedSolidAngle => {
            ProjectedSolidAngle::prepare(&seg, x, n).map(|s| Box::new(s) as Box<dyn LineSampler>)
        }
        Technique::Ltc => LtcLine::prepare(&seg, x, c.shading_frame(), c.a())
            .map(|s| Box::new(s) as Box<dyn LineSampler>),
    }
}

/// Quantiles of a distribution of non-negative differences.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quantiles {
    pub count: usize,
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub p999: f64,
    pub max: f64,
}

impl Quantiles {
    pub fn of(mut v: Vec<f64>) -> Self {
        if v.is_empty() {
            return Self::default();
        }
        v.sort_by(f64::total_cmp);
        let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        Self {
            count: v.len(),
            p50: q(0.5),
            p90: q(0.9),
            p99: q(0.99),
            p999: q(0.999),
            max: v[v.len() - 1],
        }
    }
}

impl std::fmt::Display for Quantiles {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "p50 {:.3} p90 {:.3} p99 {:.3} p99.9 {:.3} max {:.3} (n = {})",
            self.p50, self.p90, self.p99, self.p999, self.max, self.count
        )
    }
}

/// The distance of two f32 values in units in the last place (∞ if either is not finite or
/// their signs differ, 0 for equal values).
pub fn ulp_distance(a: f32, b: f32) -> f64 {
    if a == b {
        return 0.0;
    }
    if !(a.is_finite() && b.is_finite()) || (a < 0.0) != (b < 0.0) {
        return f64::INFINITY;
    }
    (a.abs().to_bits() as i64 - b.abs().to_bits() as i64).unsigned_abs() as f64
}

/// The bound of the per-sample agreement with the Rust f32 samplers.
///
/// Why the two differ at all: the kernels compute in f32 only, the Rust samplers form the line
/// frame (closest point, distance d, clipped ends), Δ and the inversion's n·ω in f64 and round
/// once, and use different sin/cos/atan2 polynomials. The frame's closest point
/// c = p − (u·p)u cancels: its f32 error is ~ε·|p|, so d and ĉ are off by ~ε·|p|/d relative,
/// and that ratio (the nearer endpoint's distance over the distance to the line) reaches ~100
/// among the suite's configurations (long-far, close-spanning). A direction inherits that
/// error; the densities of projected solid angle and LTC (∝ 1/Ω⊥, a product of several such
/// factors, and for LTC |Aω|⁻⁴) a few times it. Measured on lavapipe, 1024 stratified ξ on
/// each of 147 configurations: directions p99 ≤ 4.5, max 169 ulps of 1; densities p99 ≤ 128,
/// max 2515 ulps. The bound leaves a factor ~1.5 on the maxima and ≥ 4 on the percentiles: a
/// kernel that rounds differently passes, one with a wrong formula (errors of 1e-3 and more,
/// i.e. 10⁴ ulps) does not.
pub const AGREEMENT_BOUND: AgreementBound = AgreementBound {
    direction_p99: 16.0,
    direction_max: 256.0,
    density_p99: 512.0,
    density_max: 4096.0,
};

/// The worst backward error allowed of two Halley steps (the Rust f32 path's bound, the
/// paper's 1.6e-5 rounded up), ξ guard included.
pub const BACKWARD_ERROR_BOUND: f64 = 2e-5;

/// Bounds on quantiles of the agreement (directions in ulps of 1, densities in ulps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AgreementBound {
    pub direction_p99: f64,
    pub direction_max: f64,
    pub density_p99: f64,
    pub density_max: f64,
}

impl AgreementBound {
    /// `Err` with the quantity that exceeds its bound.
    pub fn check(&self, a: &Agreement) -> Result<(), String> {
        let checks = [
            ("direction p99", a.direction.p99, self.direction_p99),
            ("direction max", a.direction.max, self.direction_max),
            ("density p99", a.density.p99, self.density_p99),
            ("density max", a.density.max, self.density_max),
        ];
        for (name, value, bound) in checks {
            // NaN fails.
            if value.is_nan() || value > bound {
                return Err(format!(
                    "{name} {value} exceeds {bound} (worst at {})",
                    a.worst_config
                ));
            }
        }
        if !a.prepared_mismatch.is_empty() {
            return Err(format!("prepared differently: {:?}", a.prepared_mismatch));
        }
        Ok(())
    }
}

/// Per-sample agreement of one technique with its Rust f32 sampler.
#[derive(Clone, Debug, Default)]
pub struct Agreement {
    pub technique: &'static str,
    pub configs: usize,
    /// Configurations where exactly one of the two prepared a sampler.
    pub prepared_mismatch: Vec<String>,
    /// Direction differences in ulps of 1.
    pub direction: Quantiles,
    /// Density differences in ulps.
    pub density: Quantiles,
    /// The configuration of the largest direction difference.
    pub worst_config: String,
}

/// ξ of the agreement test: stratified over (0, 1) (cell midpoints), `per_config` values.
pub fn agreement_xi(per_config: usize) -> Vec<f32> {
    (0..per_config)
        .map(|i| ((i as f64 + 0.5) / per_config as f64) as f32)
        .collect()
}

/// Runs `technique` on the kernels and in Rust (f32) for every configuration at the same ξ.
pub fn agreement(
    gpu: &Gpu,
    technique: Technique,
    configs: &[Config],
    per_config: usize,
) -> Result<Agreement, GpuError> {
    let xi = agreement_xi(per_config);
    let mut out = Agreement {
        technique: technique.name(),
        configs: configs.len(),
        ..Default::default()
    };
    let (mut dirs, mut dens) = (Vec::new(), Vec::new());
    let mut worst = 0.0f64;
    // All configurations in one batch: a dispatch per configuration costs more than its work.
    let queries: Vec<[f32; 4]> = configs
        .iter()
        .flat_map(|c| {
            let kc = kernel_config(c);
            xi.iter().flat_map(move |&x| query(&kc, x, [0.0; 3]))
        })
        .collect();
    let answers = gpu.certify(source_mode(technique), 0, &queries)?;
    for (c, block) in configs
        .iter()
        .zip(answers.chunks_exact(per_config * CERTIFY_ANSWER_VEC4S))
    {
        let prepared = block[1][1] == 1.0;
        let rust = rust_sampler(technique, c);
        if prepared != rust.is_some() {
            out.prepared_mismatch.push(c.name.clone());
            continue;
        }
        let Some(rust) = rust else { continue };
        for (k, &x) in xi.iter().enumerate() {
            let a = &block[k * CERTIFY_ANSWER_VEC4S];
            let (d_rust, p_rust) = rust.sample_with_pdf(x);
            let d_gpu = Vec3::new(a[0], a[1], a[2]);
            let e = (d_gpu.as_dvec3() - d_rust.as_dvec3()).length() / f32::EPSILON as f64;
            if e > worst {
                worst = e;
                out.worst_config = c.name.clone();
            }
            dirs.push(e);
            dens.push(ulp_distance(a[3], p_rust));
        }
    }
    out.direction = Quantiles::of(dirs);
    out.density = Quantiles::of(dens);
    Ok(out)
}

fn source_mode(t: Technique) -> CertifyMode {
    match t {
        Technique::Clipped => CertifyMode::Clipped,
        Technique::ProjectedSolidAngle => CertifyMode::ProjectedSolidAngle,
        Technique::Ltc => CertifyMode::Ltc,
    }
}

/// How far (radians along the line) the kernels' support ends may lie from the reference's:
/// 3ε. The sampler suite's cross-density check lets a pdf query's answer match the reference pdf
/// anywhere within 4ε of the query direction (the rounding of an f32 direction), so kernels
/// within this bound pass it at every sample count, with a margin of ε for the probes' own
/// spacing. Measured on lavapipe: 1.75e-7 (1.5ε), at the far end of arcs wider than 1 rad.
pub const SUPPORT_END_BOUND: f64 = 3.0 * f32::EPSILON as f64;

/// Spacing of the directions probed around each support end (radians; below an f32
/// direction's resolution of ~ε/2, so that every distinct direction there is probed).
const SUPPORT_END_STEP: f64 = 1e-8;

/// The kernels' support ends against the reference technique's (the certified Rust sampler,
/// whose frame is formed in f64): the result of [`support_ends`].
#[derive(Clone, Debug, Default)]
pub struct SupportEnds {
    pub technique: &'static str,
    /// Directions probed.
    pub probes: usize,
    /// Probes where the kernel's pdf matches the reference pdf at no direction within
    /// [`SUPPORT_END_BOUND`].
    pub mismatches: usize,
    /// The first 10 mismatches, one line each.
    pub examples: Vec<String>,
}

/// Probes the kernels' `pdf` at directions spaced `SUPPORT_END_STEP` (1e-8 rad) apart across each end of
/// every configuration's support (from [`SUPPORT_END_BOUND`] + 2e-7 inside the reference's end
/// to as far outside its widened support, docs/kernels.md): each answer must lie within the
/// sampler suite's pdf-consistency tolerance (1e-3 relative plus 1e-5 of the mean density) of
/// the range of the reference pdf over the directions within [`SUPPORT_END_BOUND`] of the probe.
/// This is the suite's cross-density rule with 3ε for its 4ε, on every direction near the ends
/// instead of the few that random queries reach.
pub fn support_ends(
    gpu: &Gpu,
    technique: Technique,
    configs: &[Config],
) -> Result<SupportEnds, GpuError> {
    use linlight_sampling::geometry::arc_tolerance;
    use linlight_verify::chi2::PhiBinning;
    let margin = SUPPORT_END_BOUND + 2e-7;
    // Per prepared configuration: the reference, its binning and its probes' φ.
    let mut cases = Vec::new();
    let mut queries: Vec<[f32; 4]> = Vec::new();
    for c in configs {
        let Some(reference) = rust_sampler(technique, c) else {
            continue;
        };
        let binning = PhiBinning::new(reference.support(), 1);
        let (phi_b, phi_e) = binning.phi_range();
        let count = ((arc_tolerance(phi_e - phi_b) + 2.0 * margin) / SUPPORT_END_STEP) as usize;
        let kc = kernel_config(c);
        let mut probes = Vec::with_capacity(2 * count + 2);
        for (end, outward) in [(phi_b, -1.0), (phi_e, 1.0)] {
            for k in 0..=count {
                let phi = end + outward * (k as f64 * SUPPORT_END_STEP - margin);
                queries.extend(query(&kc, 0.5, binning.direction(phi).to_array()));
                probes.push(phi);
            }
        }
        cases.push((c, reference, binning, probes));
    }
    // All configurations in one batch, as the agreement.
    let answers = gpu.certify(source_mode(technique), 0, &queries)?;
    let mut answers = answers.chunks_exact(CERTIFY_ANSWER_VEC4S);
    let mut out = SupportEnds {
        technique: technique.name(),
        ..Default::default()
    };
    for (c, reference, binning, probes) in &cases {
        let (phi_b, phi_e) = binning.phi_range();
        let omega = 2.0 / reference.support().d as f64 * (phi_e.sin() - phi_b.sin());
        let floor = 1e-5 / omega;
        let pdf = |phi: f64| reference.pdf(binning.direction(phi)) as f64;
        for (&phi, a) in probes.iter().zip(&mut answers) {
            let q = a[1][2] as f64;
            let near = [
                pdf(phi - SUPPORT_END_BOUND),
                pdf(phi),
                pdf(phi + SUPPORT_END_BOUND),
            ];
            let lo = near.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = near.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let scale = 1e-3 * q.abs().max(near[1].abs()) + floor;
            out.probes += 1;
            if !q.is_finite() || (lo - q).max(q - hi) > scale {
                out.mismatches += 1;
                if out.examples.len() < 10 {
                    out.examples.push(format!(
                        "{}: pdf {q:e} vs the reference's {:e} at φ = {phi:.9} (support \
                         [{phi_b:.9}, {phi_e:.9}])",
                        c.name, near[1]
                    ));
                }
            }
        }
    }
    Ok(out)
}

/// The backward-error sweep of `linlight backward-error` (its f32 cases and ξ) with τ from the
/// kernels' inversion (`steps` Halley steps).
pub fn backward_error_sweep(
    gpu: &Gpu,
    cfg: &SweepConfig,
    steps: u32,
) -> Result<SweepRow, GpuError> {
    let mut failure = None;
    let row = sweep_f32_with(cfg, steps, |problems| {
        let queries: Vec<[f32; 4]> = problems
            .iter()
            .flat_map(|p| {
                let mut q = [[0.0f32; 4]; 9];
                q[0] = [p.ns, p.nt, p.s_b, p.xi];
                q[1] = [p.c_b, p.width, 0.0, 0.0];
                q
            })
            .collect();
        match gpu.certify(CertifyMode::PsaCore, steps, &queries) {
            Ok(a) => a
                .chunks_exact(CERTIFY_ANSWER_VEC4S)
                .map(|a| a[0][0])
                .collect(),
            Err(e) => {
                failure = Some(e);
                Vec::new()
            }
        }
    });
    if let Some(e) = failure {
        return Err(e);
    }
    row.ok_or_else(|| GpuError::Device("the kernels answered the wrong count".into()))
}

/// Largest differences of the kernels' table lookup from `GgxLtcTable::lookup` over a grid of
/// (α, cos θ_o) (absolute, of the entries a..e and ρ_s).
pub fn lookup_difference(gpu: &Gpu, grid: usize) -> Result<f64, GpuError> {
    let table = linlight_brdf::ltc::GgxLtcTable::ggx();
    let mut points = Vec::new();
    let mut queries = Vec::new();
    for i in 0..=grid {
        for j in 0..=grid {
            let alpha = (i as f32 / grid as f32).powi(2);
            let cos = j as f32 / grid as f32;
            points.push((alpha, cos));
            let mut q = [[0.0f32; 4]; 9];
            q[1][3] = alpha;
            q[2][3] = cos;
            queries.extend(q);
        }
    }
    let answers = gpu.certify(CertifyMode::LtcLookup, 0, &queries)?;
    let mut worst = 0.0f64;
    for ((alpha, cos), a) in points
        .iter()
        .zip(answers.chunks_exact(CERTIFY_ANSWER_VEC4S))
    {
        let (m, rho) = table.lookup(*alpha, *cos);
        // Rows [[a, 0, b], [0, c, 0], [d, 0, e]].
        let rust = [
            m.x_axis.x, m.z_axis.x, m.y_axis.y, m.x_axis.z, m.z_axis.z, rho,
        ];
        let gpu = [a[0][0], a[0][1], a[0][2], a[0][3], a[1][0], a[1][1]];
        for (r, g) in rust.iter().zip(gpu) {
            worst = worst.max((r - g).abs() as f64);
        }
    }
    Ok(worst)
}

/// Largest difference of the kernels' four MIS weights from the Rust ones over a grid of
/// densities (including 0 and extreme ratios) and technique weights.
pub fn mis_difference(gpu: &Gpu) -> Result<f64, GpuError> {
    let values = [0.0f32, 1e-30, 1e-6, 0.3, 1.0, 7.5, 1e6, 1e30];
    let weights = [0.0f32, 0.01, 1.0, 40.0];
    let vs = [0.0f32, 0.5, 1.0];
    let mut inputs = Vec::new();
    for &ps in &values {
        for &po in &values {
            for &ws in &weights {
                for &wo in &weights {
                    for &v in &vs {
                        inputs.push((ps, po, ws, wo, v));
                    }
                }
            }
        }
    }
    let queries: Vec<[f32; 4]> = inputs
        .iter()
        .flat_map(|&(ps, po, ws, wo, v)| {
            let mut q = [[0.0f32; 4]; 9];
            q[0] = [ps, po, ws, wo];
            q[1][0] = v;
            q
        })
        .collect();
    let answers = gpu.certify(CertifyMode::Mis, 0, &queries)?;
    let mut worst = 0.0f64;
    for (&(ps, po, ws, wo, v), a) in inputs
        .iter()
        .zip(answers.chunks_exact(CERTIFY_ANSWER_VEC4S))
    {
        let rust = [
            mis::balance(ps, po),
            mis::power(ps, po),
            mis::weighted_balance(ps, po, ws, wo),
            mis::clamped_optimal(ps, po, ws, wo, v),
        ];
        for (r, g) in rust.iter().zip(a[0]) {
            let d = if g.is_finite() {
                (r - g).abs() as f64
            } else {
                f64::INFINITY
            };
            worst = worst.max(d);
        }
    }
    Ok(worst)
}
