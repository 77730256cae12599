//! The shader kernels' certification (docs/kernels.md), shared by `linlight samplers --backend
//! gpu` and `linlight certify`: on the adapter wgpu finds (Mesa's lavapipe without a GPU), the
//! per-sample agreement with the Rust f32 samplers, the backward-error sweep of the kernels'
//! projected-solid-angle inversion, the LTC table lookup and MIS weights, the mutated kernels as
//! negative controls, and the sampler suite on the kernels' answers.
//!
//! Without the `gpu` feature, or without an adapter, the result says so (its field `skipped`):
//! a certification never leaves the kernels out silently.

use serde::{Deserialize, Serialize};

/// Why the kernels were not certified in a build without the backend.
pub const NOT_BUILT: &str = "not built with --features gpu";
/// Why the kernels were not certified on a machine without a Vulkan adapter.
pub const NO_ADAPTER: &str = "no adapter";
/// Why the kernels were not certified when the command line said so.
pub const NOT_REQUESTED: &str = "--no-gpu-kernels";

/// One check of the kernels' certification.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpuCheck {
    pub name: String,
    /// Certified subject: it passed. Negative control: it was rejected.
    pub passed: bool,
    pub detail: String,
}

/// The kernels' certification as `certify` reports it (summary, report.md, report.html, JSON).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpuSummary {
    /// Why the kernels did not run ([`NOT_BUILT`], [`NO_ADAPTER`], [`NOT_REQUESTED`]); `None`:
    /// they ran.
    pub skipped: Option<String>,
    /// The backend's own message about the skip or the failure (e.g. wgpu's "no adapter" error).
    pub note: Option<String>,
    /// The adapter: name, driver, device type, software or hardware.
    pub adapter: Option<String>,
    /// The backend failed while running (device lost, a kernel did not compile): the checks
    /// after it did not run, and the summary has failed.
    pub error: Option<String>,
    /// Ran, and every check passed (every control rejected). False when skipped.
    pub passed: bool,
    pub checks: Vec<GpuCheck>,
    /// Per-sample agreement: ξ per configuration; the answer suite: samples per configuration.
    pub agreement_samples: usize,
    pub suite_samples: usize,
    pub elapsed_seconds: f64,
}

impl GpuSummary {
    /// Not run, for `reason` ([`NOT_BUILT`], [`NO_ADAPTER`]).
    pub fn skipped(reason: &str, note: Option<String>) -> Self {
        Self {
            skipped: Some(reason.to_string()),
            note,
            adapter: None,
            error: None,
            passed: false,
            checks: Vec::new(),
            agreement_samples: 0,
            suite_samples: 0,
            elapsed_seconds: 0.0,
        }
    }

    /// Whether the certification counts it as failed: it ran and a check failed (a skip is
    /// reported, not failed).
    pub fn failed(&self) -> bool {
        self.skipped.is_none() && !self.passed
    }

    /// The rows are consistent with the verdict (`certify --merge` refuses a report whose
    /// summary claims more than its rows).
    pub fn check_consistency(&self) -> Result<(), String> {
        let rows = self.checks.iter().all(|c| c.passed) && self.error.is_none();
        match &self.skipped {
            Some(_) if self.passed || !self.checks.is_empty() => {
                Err("GPU kernels marked skipped but with a verdict or checks".into())
            }
            None if self.passed && (!rows || self.checks.is_empty()) => {
                Err("GPU kernels marked passed but a check failed or none ran".into())
            }
            None if !self.passed && rows && !self.checks.is_empty() => {
                Err("GPU kernels marked failed but every check passed".into())
            }
            _ => Ok(()),
        }
    }

    /// One line: `GPU kernels: PASS on … (n checks, s)`, `… FAIL …; failing: …`, or
    /// `GPU kernels: skipped (reason)`.
    pub fn line(&self) -> String {
        if let Some(reason) = &self.skipped {
            return format!("GPU kernels: skipped ({reason})");
        }
        let failing: Vec<&str> = self
            .checks
            .iter()
            .filter(|c| !c.passed)
            .map(|c| c.name.as_str())
            .collect();
        format!(
            "GPU kernels: {} on {} ({} checks, {:.1} s){}{}",
            if self.passed { "PASS" } else { "FAIL" },
            self.adapter.as_deref().unwrap_or("?"),
            self.checks.len(),
            self.elapsed_seconds,
            if failing.is_empty() {
                String::new()
            } else {
                format!("; failing: {}", failing.join(", "))
            },
            self.error
                .as_ref()
                .map_or_else(String::new, |e| format!("; backend error: {e}"))
        )
    }
}

/// A run of the kernels' certification: the summary, and the sampler suite on the kernels'
/// answers for a caller that prints its tables.
pub struct KernelRun {
    pub summary: GpuSummary,
    pub suite: Option<linlight_verify::suite::SuiteReport>,
}

/// The sizes `certify` runs the kernels at: ξ per configuration of the agreement (as `linlight
/// samplers --backend gpu`), and samples per configuration of the answer suite (as
/// `samplers --backend gpu --samples 10000`, a tenth of its default: the suite on the kernels
/// is most of the run's time on lavapipe).
pub const AGREEMENT_SAMPLES: usize = 1024;
pub const SUITE_SAMPLES: usize = 10_000;

/// Without the backend: skipped, and why.
#[cfg(not(feature = "gpu"))]
pub fn run(
    _agreement_samples: usize,
    _suite_samples: usize,
    _say: &mut dyn FnMut(&str),
) -> KernelRun {
    KernelRun {
        summary: GpuSummary::skipped(NOT_BUILT, None),
        suite: None,
    }
}

/// The certification on the adapter wgpu finds; each step's result line goes to `say` as it
/// is known. Deterministic: fixed configurations, ξ and seeds.
#[cfg(feature = "gpu")]
pub fn run(agreement_samples: usize, suite_samples: usize, say: &mut dyn FnMut(&str)) -> KernelRun {
    use linlight_gpu::{Gpu, GpuError};
    let start = std::time::Instant::now();
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(GpuError::NoAdapter(e)) => {
            return KernelRun {
                summary: GpuSummary::skipped(NO_ADAPTER, Some(e)),
                suite: None,
            }
        }
        Err(e) => {
            return KernelRun {
                summary: GpuSummary {
                    error: Some(e.to_string()),
                    ..GpuSummary::skipped("", None)
                }
                .ran(),
                suite: None,
            }
        }
    };
    let per_config = agreement_samples.clamp(16, 1024);
    let mut summary = GpuSummary {
        adapter: Some(gpu.adapter().to_string()),
        agreement_samples: per_config,
        suite_samples,
        ..GpuSummary::skipped("", None)
    }
    .ran();
    say(&format!("adapter: {}", gpu.adapter()));
    let mut suite = None;
    if let Err(e) = steps(
        gpu,
        per_config,
        suite_samples,
        say,
        &mut summary,
        &mut suite,
    ) {
        summary.error = Some(e.to_string());
    }
    summary.passed = summary.error.is_none()
        && !summary.checks.is_empty()
        && summary.checks.iter().all(|c| c.passed);
    summary.elapsed_seconds = start.elapsed().as_secs_f64();
    KernelRun { summary, suite }
}

#[cfg(feature = "gpu")]
impl GpuSummary {
    /// The same summary as one that ran (not skipped).
    fn ran(mut self) -> Self {
        self.skipped = None;
        self
    }
}

/// Where the checks' results go: each check's row of the summary, and its line for the caller
/// as soon as it is known.
#[cfg(feature = "gpu")]
struct Recorder<'a> {
    say: &'a mut dyn FnMut(&str),
    checks: &'a mut Vec<GpuCheck>,
}

#[cfg(feature = "gpu")]
impl Recorder<'_> {
    fn say(&mut self, line: &str) {
        (self.say)(line)
    }

    fn check(&mut self, name: String, passed: bool, detail: String) {
        self.checks.push(GpuCheck {
            name,
            passed,
            detail,
        })
    }
}

/// The checks in order: agreement, support ends, backward-error sweep, lookup and MIS, the
/// mutated kernels,
/// the sampler suite on the kernels' answers (its report kept for the caller's tables).
#[cfg(feature = "gpu")]
fn steps(
    gpu: linlight_gpu::Gpu,
    per_config: usize,
    suite_samples: usize,
    say: &mut dyn FnMut(&str),
    summary: &mut GpuSummary,
    suite: &mut Option<linlight_verify::suite::SuiteReport>,
) -> Result<(), linlight_gpu::GpuError> {
    use linlight_verify::configs::{edge_configs, ltc_table_configs, random_configs};
    let mut configs = random_configs(1, 64);
    configs.extend(edge_configs());
    configs.extend(ltc_table_configs());
    let mut out = Recorder {
        say,
        checks: &mut summary.checks,
    };
    check_agreement(&gpu, &configs, per_config, &mut out)?;
    check_support_ends(&gpu, &configs, &mut out)?;
    check_backward_error(&gpu, &mut out)?;
    check_lookup_and_mis(&gpu, &mut out)?;
    check_controls(&configs, per_config, &mut out)?;
    out.say(&format!(
        "\nsampler suite on the kernels' answers (N = {suite_samples} samples per configuration)"
    ));
    let report = answer_suite(gpu, suite_samples)?;
    for r in report.techniques.iter().chain(&report.negative_controls) {
        let detail = match &r.panic {
            Some(p) => format!("panicked: {p}"),
            None => r.verdict.clone(),
        };
        out.check(format!("suite {}", r.name), r.passed, detail);
    }
    *suite = Some(report);
    Ok(())
}

/// The agreement's quantiles as one line.
#[cfg(feature = "gpu")]
fn quantiles(a: &linlight_gpu::certify::Agreement) -> String {
    format!(
        "direction p50 {:>6.2} p99 {:>7.2} max {:>9.2}  density p50 {:>5.0} p99 {:>7.0} max {:>9.0}",
        a.direction.p50, a.direction.p99, a.direction.max, a.density.p50, a.density.p99,
        a.density.max
    )
}

/// Per-sample agreement of each kernel with its Rust f32 sampler, within
/// [`linlight_gpu::certify::AGREEMENT_BOUND`].
#[cfg(feature = "gpu")]
fn check_agreement(
    gpu: &linlight_gpu::Gpu,
    configs: &[linlight_verify::configs::Config],
    per_config: usize,
    out: &mut Recorder,
) -> Result<(), linlight_gpu::GpuError> {
    use linlight_gpu::certify::{agreement, AGREEMENT_BOUND};
    out.say(&format!(
        "\nper-sample agreement with the Rust f32 samplers ({} configurations × {per_config} ξ); \
         directions in ulps of 1, densities in ulps",
        configs.len()
    ));
    for t in linlight_gpu::Technique::ALL {
        let a = agreement(gpu, t, configs, per_config)?;
        let verdict = AGREEMENT_BOUND.check(&a);
        out.say(&format!(
            "  {:<22} {}  {}",
            a.technique,
            quantiles(&a),
            match &verdict {
                Ok(()) => "pass".to_string(),
                Err(e) => format!("FAIL: {e}"),
            }
        ));
        let detail = match verdict {
            Ok(()) => quantiles(&a),
            Err(ref e) => e.clone(),
        };
        out.check(
            format!("agreement {}", a.technique),
            verdict.is_ok(),
            detail,
        );
    }
    let b = AGREEMENT_BOUND;
    out.say(&format!(
        "  bound: direction p99 ≤ {}, max ≤ {}; density p99 ≤ {}, max ≤ {} (docs/kernels.md)",
        b.direction_p99, b.direction_max, b.density_p99, b.density_max
    ));
    Ok(())
}

/// The kernels' pdf at every direction near each support end against the reference's
/// (precision contract: ends within [`linlight_gpu::certify::SUPPORT_END_BOUND`]).
#[cfg(feature = "gpu")]
fn check_support_ends(
    gpu: &linlight_gpu::Gpu,
    configs: &[linlight_verify::configs::Config],
    out: &mut Recorder,
) -> Result<(), linlight_gpu::GpuError> {
    use linlight_gpu::certify::{support_ends, SUPPORT_END_BOUND};
    out.say(&format!(
        "\nsupport ends: the kernels' pdf near each end against the reference's within \
         {SUPPORT_END_BOUND:.2e} rad (docs/kernels.md)"
    ));
    for t in linlight_gpu::Technique::ALL {
        let e = support_ends(gpu, t, configs)?;
        let ok = e.mismatches == 0;
        let detail = match e.examples.first() {
            None => format!("{} directions probed, none off", e.probes),
            Some(first) => format!(
                "{} of {} directions probed off, e.g. {first}",
                e.mismatches, e.probes
            ),
        };
        out.say(&format!(
            "  {:<22} {detail}  {}",
            e.technique,
            if ok { "pass" } else { "FAIL" }
        ));
        out.check(format!("support ends {}", e.technique), ok, detail);
    }
    Ok(())
}

/// The backward-error sweep of the kernels' projected-solid-angle inversion (two Halley steps),
/// ξ guard included, within [`linlight_gpu::certify::BACKWARD_ERROR_BOUND`].
#[cfg(feature = "gpu")]
fn check_backward_error(
    gpu: &linlight_gpu::Gpu,
    out: &mut Recorder,
) -> Result<(), linlight_gpu::GpuError> {
    use linlight_gpu::certify::{backward_error_sweep, BACKWARD_ERROR_BOUND};
    let row = backward_error_sweep(gpu, &Default::default(), 2)?;
    let ok = row.worst_including_guard <= BACKWARD_ERROR_BOUND;
    let detail = format!(
        "{} problems: worst {:.3e} outside the ξ guard, {:.3e} with it, {:.3e} near the ends \
         (bound {:.0e})",
        row.samples,
        row.worst_outside_guard,
        row.worst_including_guard,
        row.worst_near_ends,
        BACKWARD_ERROR_BOUND
    );
    out.say(&format!(
        "\nbackward-error sweep of the kernels' projected-solid-angle inversion ({detail})  {}",
        if ok { "pass" } else { "FAIL" }
    ));
    out.check("backward-error sweep".into(), ok, detail);
    Ok(())
}

/// The LTC table lookup and the four MIS weights within 1e-6 of the Rust ones.
#[cfg(feature = "gpu")]
fn check_lookup_and_mis(
    gpu: &linlight_gpu::Gpu,
    out: &mut Recorder,
) -> Result<(), linlight_gpu::GpuError> {
    use linlight_gpu::certify::{lookup_difference, mis_difference};
    let (lookup, mis) = (lookup_difference(gpu, 40)?, mis_difference(gpu)?);
    let ok = lookup <= 1e-6 && mis <= 1e-6;
    let detail = format!(
        "LTC table lookup within {lookup:.2e} of the Rust one, MIS weights within {mis:.2e} \
         (bound 1e-6)"
    );
    out.say(&format!("{detail}  {}", if ok { "pass" } else { "FAIL" }));
    out.check("ltc lookup and mis weights".into(), ok, detail);
    Ok(())
}

/// Each mutated kernel through the same backend: rejected iff the agreement (and for one
/// Halley step, the backward-error sweep) finds it.
#[cfg(feature = "gpu")]
fn check_controls(
    configs: &[linlight_verify::configs::Config],
    per_config: usize,
    out: &mut Recorder,
) -> Result<(), linlight_gpu::GpuError> {
    use linlight_gpu::certify::{
        agreement, backward_error_sweep, AGREEMENT_BOUND, BACKWARD_ERROR_BOUND,
    };
    use linlight_gpu::mutate::{mutated, Mutation};
    use linlight_gpu::{Gpu, Technique};
    out.say("\nnegative controls (mutated kernels, same backend): must be rejected");
    for m in Mutation::ALL {
        let mutant = Gpu::with_source(&mutated(linlight_kernels::WGSL, m))?;
        let mut reasons = Vec::new();
        let techniques: &[Technique] = match m {
            Mutation::LtcWrongInverse => &[Technique::Ltc],
            _ => &[Technique::ProjectedSolidAngle, Technique::Ltc],
        };
        for &t in techniques {
            let a = agreement(&mutant, t, configs, per_config)?;
            if let Err(e) = AGREEMENT_BOUND.check(&a) {
                reasons.push(format!("{} agreement: {e}", a.technique));
            }
        }
        if m == Mutation::OneHalleyStep {
            let r = backward_error_sweep(&mutant, &Default::default(), 1)?;
            if r.worst_outside_guard > BACKWARD_ERROR_BOUND {
                reasons.push(format!(
                    "backward error {:.3e} > {:.0e}",
                    r.worst_outside_guard, BACKWARD_ERROR_BOUND
                ));
            }
        }
        let rejected = !reasons.is_empty();
        let detail = if rejected {
            format!("rejected: {}", reasons.join("; "))
        } else {
            "NOT REJECTED".to_string()
        };
        out.say(&format!("  {:<20} {detail}", m.name()));
        out.check(format!("control {}", m.name()), rejected, detail);
    }
    Ok(())
}

/// The sampler suite (docs/sampler-suite.md) on the kernels' answers: each technique against
/// its certified Rust reference (χ², pdf consistency, round trip, the kernels' own inverse, the
/// integral, cross densities), and each mutated kernel as a negative control that must fail a
/// check.
#[cfg(feature = "gpu")]
fn answer_suite(
    gpu: linlight_gpu::Gpu,
    samples: usize,
) -> Result<linlight_verify::suite::SuiteReport, linlight_gpu::GpuError> {
    use linlight_gpu::answers::GpuAnswers;
    use linlight_gpu::mutate::{mutated, Mutation};
    use linlight_gpu::{Gpu, GpuError, Technique};
    use linlight_verify::subjects::{ltc, technique, Rejection, Role, SamplerUnderTest};
    use linlight_verify::{run_suite, Settings};
    use std::sync::Arc;

    let reference = |t: Technique| -> SamplerUnderTest {
        match t {
            Technique::Clipped => technique(linlight_sampling::Technique::ClippedSolidAngle),
            Technique::ProjectedSolidAngle => {
                technique(linlight_sampling::Technique::ProjectedSolidAngle)
            }
            Technique::Ltc => ltc(),
        }
    };
    let gpu = Arc::new(gpu);
    let subjects: Vec<SamplerUnderTest> = Technique::ALL
        .iter()
        .map(|&t| {
            reference(t).answered_by(
                format!("gpu-{}", t.name()),
                format!("the {} kernel on {}", t.name(), gpu.adapter()),
                Box::new(GpuAnswers {
                    gpu: gpu.clone(),
                    technique: t,
                }),
            )
        })
        .collect();
    let mut controls = Vec::new();
    for m in Mutation::ALL {
        let mutant = Arc::new(Gpu::with_source(&mutated(linlight_kernels::WGSL, m))?);
        let t = match m {
            Mutation::LtcWrongInverse => Technique::Ltc,
            _ => Technique::ProjectedSolidAngle,
        };
        let mut c = reference(t).answered_by(
            format!("gpu-{}-{}", t.name(), m.name()),
            format!("the {} kernel mutated: {}", t.name(), m.name()),
            Box::new(GpuAnswers {
                gpu: mutant,
                technique: t,
            }),
        );
        c.role = Role::NegativeControl;
        c.rejection = Rejection::any();
        controls.push(c);
    }
    let settings = Settings {
        samples,
        ..Settings::default()
    };
    let report = run_suite(&subjects, &controls, &settings);
    for s in subjects.iter().chain(&controls) {
        if let Some(e) = s.answers.as_ref().and_then(|a| a.failure()) {
            return Err(GpuError::Device(e.to_string()));
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ran(checks: &[bool]) -> GpuSummary {
        GpuSummary {
            skipped: None,
            adapter: Some("llvmpipe".into()),
            passed: checks.iter().all(|&c| c),
            checks: checks
                .iter()
                .enumerate()
                .map(|(i, &passed)| GpuCheck {
                    name: format!("check {i}"),
                    passed,
                    detail: String::new(),
                })
                .collect(),
            ..GpuSummary::skipped("", None)
        }
    }

    /// A skip names its reason; a failure names its failing checks; a summary that claims more
    /// than its rows is refused.
    #[test]
    fn lines_and_consistency() {
        let s = GpuSummary::skipped(NO_ADAPTER, Some("no Vulkan driver".into()));
        assert_eq!(s.line(), "GPU kernels: skipped (no adapter)");
        assert!(!s.failed());
        assert_eq!(s.check_consistency(), Ok(()));
        assert_eq!(
            GpuSummary::skipped(NOT_BUILT, None).line(),
            "GPU kernels: skipped (not built with --features gpu)"
        );

        let ok = ran(&[true, true]);
        assert!(ok
            .line()
            .starts_with("GPU kernels: PASS on llvmpipe (2 checks"));
        assert!(!ok.failed());
        assert_eq!(ok.check_consistency(), Ok(()));

        let bad = ran(&[true, false]);
        assert!(bad.failed());
        assert!(bad.line().ends_with("; failing: check 1"), "{}", bad.line());
        assert_eq!(bad.check_consistency(), Ok(()));

        let forged = GpuSummary {
            passed: true,
            ..bad.clone()
        };
        assert!(forged.check_consistency().is_err());
        let empty = GpuSummary {
            passed: true,
            ..ran(&[])
        };
        assert!(empty.check_consistency().is_err());
        let skipped_with_rows = GpuSummary {
            skipped: Some(NO_ADAPTER.into()),
            passed: false,
            ..bad
        };
        assert!(skipped_with_rows.check_consistency().is_err());
    }
}
