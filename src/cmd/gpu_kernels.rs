//! `linlight samplers --backend gpu`: the shader kernels (crates/kernels) certified on the
//! adapter wgpu finds (Mesa's lavapipe without a GPU): per-sample agreement with the Rust f32
//! samplers, the backward-error sweep of the projected-solid-angle inversion, the LTC table
//! lookup and the MIS weights, and the negative controls (mutated kernels) through the same
//! backend. Built only with the `gpu` feature (`cargo build --release --features gpu`).

use std::process::ExitCode;

#[cfg(not(feature = "gpu"))]
pub fn run(_samples_per_config: usize, _suite_samples: usize) -> ExitCode {
    eprintln!(
        "error: this linlight was built without the GPU backend; build it with \
         `cargo build --release --features gpu` (docs/kernels.md)"
    );
    ExitCode::from(2)
}

/// The sampler suite (docs/sampler-suite.md) on the kernels' answers: each technique against
/// its certified Rust reference (χ², pdf consistency, round trip, the kernels' own inverse, the
/// integral, cross densities), and each mutated kernel as a negative control that must fail a
/// check. `Ok(passed)`, or the exit code of a backend failure.
#[cfg(feature = "gpu")]
fn run_answer_suite(gpu: linlight_gpu::Gpu, samples: usize) -> Result<bool, ExitCode> {
    use linlight_gpu::answers::GpuAnswers;
    use linlight_gpu::mutate::{mutated, Mutation};
    use linlight_gpu::{Gpu, Technique};
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
        let mutant = match Gpu::with_source(&mutated(linlight_kernels::WGSL, m)) {
            Ok(g) => Arc::new(g),
            Err(e) => {
                eprintln!("error: {e}");
                return Err(ExitCode::from(2));
            }
        };
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
    println!("\nsampler suite on the kernels' answers (N = {samples} samples per configuration)");
    let report = run_suite(&subjects, &controls, &settings);
    for s in subjects.iter().chain(&controls) {
        if let Some(e) = s.answers.as_ref().and_then(|a| a.failure()) {
            eprintln!("error: {e}");
            return Err(ExitCode::from(2));
        }
    }
    super::suite_tables::print_techniques(&report.techniques);
    super::suite_tables::print_failures(&report.techniques);
    super::suite_tables::print_controls(&report.negative_controls);
    Ok(report.passed)
}

#[cfg(feature = "gpu")]
pub fn run(samples_per_config: usize, suite_samples: usize) -> ExitCode {
    use linlight_gpu::certify::{
        agreement, backward_error_sweep, lookup_difference, mis_difference, Agreement,
        AGREEMENT_BOUND, BACKWARD_ERROR_BOUND,
    };
    use linlight_gpu::mutate::{mutated, Mutation};
    use linlight_gpu::{Gpu, GpuError, Technique};
    use linlight_sampling::backward_error::SweepConfig;
    use linlight_verify::configs::{edge_configs, ltc_table_configs, random_configs};
    use std::time::Instant;

    let start = Instant::now();
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            println!("GPU kernels: skipped (no adapter): {e}");
            eprintln!("error: no adapter for the GPU kernels (run scripts/setup-gpu): {e}");
            return ExitCode::from(2);
        }
    };
    println!("adapter: {}", gpu.adapter());
    let mut configs = random_configs(1, 64);
    configs.extend(edge_configs());
    configs.extend(ltc_table_configs());
    let per_config = samples_per_config.clamp(16, 1024);
    let fail = |e: GpuError| {
        eprintln!("error: {e}");
        ExitCode::from(2)
    };
    let mut passed = true;

    println!(
        "\nper-sample agreement with the Rust f32 samplers ({} configurations × {per_config} ξ); \
         directions in ulps of 1, densities in ulps",
        configs.len()
    );
    let print = |a: &Agreement, verdict: &str| {
        println!(
            "  {:<22} direction p50 {:>6.2} p99 {:>7.2} max {:>9.2}  density p50 {:>5.0} p99 {:>7.0} max {:>9.0}  {verdict}",
            a.technique, a.direction.p50, a.direction.p99, a.direction.max, a.density.p50,
            a.density.p99, a.density.max
        )
    };
    for t in Technique::ALL {
        let a = match agreement(&gpu, t, &configs, per_config) {
            Ok(a) => a,
            Err(e) => return fail(e),
        };
        let verdict = match AGREEMENT_BOUND.check(&a) {
            Ok(()) => "pass".to_string(),
            Err(e) => {
                passed = false;
                format!("FAIL: {e}")
            }
        };
        print(&a, &verdict);
    }
    println!(
        "  bound: direction p99 ≤ {}, max ≤ {}; density p99 ≤ {}, max ≤ {} (docs/kernels.md)",
        AGREEMENT_BOUND.direction_p99,
        AGREEMENT_BOUND.direction_max,
        AGREEMENT_BOUND.density_p99,
        AGREEMENT_BOUND.density_max
    );

    let sweep = SweepConfig::default();
    let row = match backward_error_sweep(&gpu, &sweep, 2) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    let ok = row.worst_including_guard <= BACKWARD_ERROR_BOUND;
    passed &= ok;
    println!(
        "\nbackward-error sweep of the kernels' projected-solid-angle inversion ({} problems): \
         worst {:.3e} outside the ξ guard, {:.3e} with it, {:.3e} near the ends (bound {:.0e})  {}",
        row.samples,
        row.worst_outside_guard,
        row.worst_including_guard,
        row.worst_near_ends,
        BACKWARD_ERROR_BOUND,
        if ok { "pass" } else { "FAIL" }
    );

    let (lookup, mis) = match (lookup_difference(&gpu, 40), mis_difference(&gpu)) {
        (Ok(l), Ok(m)) => (l, m),
        (Err(e), _) | (_, Err(e)) => return fail(e),
    };
    let ok = lookup <= 1e-6 && mis <= 1e-6;
    passed &= ok;
    println!(
        "LTC table lookup within {lookup:.2e} of the Rust one, MIS weights within {mis:.2e} \
         (bound 1e-6)  {}",
        if ok { "pass" } else { "FAIL" }
    );

    println!("\nnegative controls (mutated kernels, same backend): must be rejected");
    for m in Mutation::ALL {
        let mutant = match Gpu::with_source(&mutated(linlight_kernels::WGSL, m)) {
            Ok(g) => g,
            Err(e) => return fail(e),
        };
        let mut reasons = Vec::new();
        let techniques: &[Technique] = match m {
            Mutation::LtcWrongInverse => &[Technique::Ltc],
            _ => &[Technique::ProjectedSolidAngle, Technique::Ltc],
        };
        for &t in techniques {
            match agreement(&mutant, t, &configs, per_config) {
                Ok(a) => {
                    if let Err(e) = AGREEMENT_BOUND.check(&a) {
                        reasons.push(format!("{} agreement: {e}", a.technique));
                    }
                }
                Err(e) => return fail(e),
            }
        }
        if m == Mutation::OneHalleyStep {
            match backward_error_sweep(&mutant, &sweep, 1) {
                Ok(r) if r.worst_outside_guard > BACKWARD_ERROR_BOUND => reasons.push(format!(
                    "backward error {:.3e} > {:.0e}",
                    r.worst_outside_guard, BACKWARD_ERROR_BOUND
                )),
                Ok(_) => {}
                Err(e) => return fail(e),
            }
        }
        let rejected = !reasons.is_empty();
        passed &= rejected;
        println!(
            "  {:<20} {}",
            m.name(),
            if rejected {
                format!("rejected: {}", reasons.join("; "))
            } else {
                "NOT REJECTED".to_string()
            }
        );
    }
    // The sampler suite on the kernels' outputs, the mutated kernels as its negative controls.
    let suite_ok = match run_answer_suite(gpu, suite_samples) {
        Ok(ok) => ok,
        Err(code) => return code,
    };
    passed &= suite_ok;
    println!(
        "\nGPU kernels: {} ({:.1} s)",
        if passed { "pass" } else { "FAIL" },
        start.elapsed().as_secs_f64()
    );
    if passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
