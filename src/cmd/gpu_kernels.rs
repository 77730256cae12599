//! `linlight samplers --backend gpu`: the shader kernels (crates/kernels) certified on the
//! adapter wgpu finds (Mesa's lavapipe without a GPU), by `linlight::certify::gpu` (the same
//! run `linlight certify` includes): per-sample agreement with the Rust f32 samplers, the
//! backward-error sweep, the LTC table lookup and the MIS weights, the mutated kernels as
//! negative controls, and the sampler suite on the kernels' answers. Built only with the `gpu`
//! feature (`cargo build --release --features gpu`).

use linlight::certify::gpu::{self, NOT_BUILT};
use std::process::ExitCode;

pub fn run(samples_per_config: usize, suite_samples: usize) -> ExitCode {
    let run = gpu::run(samples_per_config, suite_samples, &mut |line| {
        println!("{line}")
    });
    let s = &run.summary;
    match s.skipped.as_deref() {
        Some(NOT_BUILT) => {
            eprintln!(
                "error: this linlight was built without the GPU backend; build it with \
                 `cargo build --release --features gpu` (docs/kernels.md)"
            );
            return ExitCode::from(2);
        }
        Some(reason) => {
            let note = s.note.as_deref().unwrap_or_default();
            println!("{}: {note}", s.line());
            eprintln!("error: {reason} for the GPU kernels (run scripts/setup-gpu): {note}");
            return ExitCode::from(2);
        }
        None => {}
    }
    if let Some(report) = &run.suite {
        super::suite_tables::print_techniques(&report.techniques);
        super::suite_tables::print_failures(&report.techniques);
        super::suite_tables::print_controls(&report.negative_controls);
    }
    if let Some(e) = &s.error {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    println!(
        "\nGPU kernels: {} ({:.1} s)",
        if s.passed { "pass" } else { "FAIL" },
        s.elapsed_seconds
    );
    if s.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
