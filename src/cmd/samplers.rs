//! `linlight samplers`: the chi-square certification suite of every line-sampling technique
//! (docs/sampler-suite.md), then that of the finite-cylinder techniques (docs/cylinders.md),
//! negative controls included. Exit 0 iff every technique passes every configuration and every
//! negative control is rejected; 1 otherwise; 2 on bad usage.
//!
//! With `--external COMMAND`: the same checks on the answers of an external program
//! (docs/external-protocol.md) instead; exit 0 iff it passes every configuration, 1 if it fails
//! one, 2 if it could not be certified (did not speak the protocol, crashed, hung).

use super::suite_tables::{print_controls, print_failures, print_techniques, write_json};
use linlight_verify::cylinder_suite::{self, CylinderReport};
use linlight_verify::subjects::{certified, negative_controls, tilt_power_controls};
use linlight_verify::suite::{run_suite_at, Check, SubjectReport, SuiteReport};
use linlight_verify::{run_suite, Settings};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Write the full structured report (every configuration of every technique) as JSON. Not
    /// with --backend gpu (`linlight certify --json` holds the kernels' summary).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Samples per configuration of the line techniques (the finite-cylinder techniques are
    /// certified at their own fixed N = 400 000).
    #[arg(long, default_value_t = Settings::default().samples)]
    samples: usize,
    /// Number of seeded random configurations (the named edge cases are always added)
    /// [default: 40]. Not with --backend gpu (its configurations are fixed).
    #[arg(long)]
    random_configs: Option<usize>,
    /// Seed of the configurations and of the sample streams [default: 5497010909736290388, the
    /// bytes of "LINLIGHT"]. Not with --backend gpu (its configurations and ξ are fixed).
    #[arg(long)]
    seed: Option<u64>,
    /// Instead of the suite: measure the χ² tests' power against smooth density errors — every
    /// configuration with samples tilted by 1 + ε(2F − 1) (self-consistent inverse, pdf
    /// unchanged), ε = 0.5, 1, 2, 5 %, judged at the suite's α_c. Prints the share of
    /// configurations rejected per ε. Always exits 0 unless the usage is bad.
    #[arg(long)]
    tilt_power: bool,
    /// Run each negative control on every configuration, to see the share of configurations
    /// that reject it (docs/sampler-suite.md). By default a control stops as soon as the
    /// configurations run so far decide its rejection; its verdict is the same either way.
    #[arg(long, conflicts_with_all = ["external", "tilt_power"])]
    full_controls: bool,
    /// Certify an external implementation instead of linlight's samplers: run `sh -c COMMAND`
    /// and send it the suite's batches on its stdin (protocol versions 1 and 2,
    /// docs/external-protocol.md: one JSON line per message, then little-endian f32 arrays).
    /// Its hello line names the technique it implements; its answers are judged against that
    /// technique's certified density: χ², pdf consistency, backward error, its own inverse if it
    /// reports one, the Monte Carlo integral, its pdf at directions it did not sample. Exit 0 if
    /// it passes every configuration, 1 if not, 2 if it crashes, hangs or breaks the protocol.
    /// Example: --external 'python3 harness/examples/psa_numpy.py'
    #[arg(long, value_name = "COMMAND", conflicts_with = "tilt_power")]
    external: Option<String>,
    /// With --external (refused without it): seconds to wait for its hello, for each answer
    /// (up to N = --samples samples), and for its exit after the last request; then it is
    /// killed and linlight exits 2 [default: 120].
    #[arg(long, value_name = "SECONDS")]
    timeout: Option<f64>,
    /// `rust` (the Rust samplers) or `gpu`: the shader kernels on the adapter wgpu finds
    /// (lavapipe without a GPU; needs a build with `--features gpu`): agreement with the Rust
    /// f32 samplers (--samples ξ per configuration, at most 1024), the backward-error sweep,
    /// table lookup, MIS weights, and the sampler suite on the kernels' answers (at most
    /// 100000 samples per configuration) with mutated kernels as its controls.
    /// Example: --backend gpu
    #[arg(long, value_name = "BACKEND", default_value = "rust", value_parser = ["rust", "gpu"],
          conflicts_with_all = ["external", "tilt_power"])]
    backend: String,
}

/// Seconds an external sampler may take per answer ([`Args::timeout`]).
const DEFAULT_TIMEOUT: f64 = 120.0;

/// The tilt power table: per control, the share of tested configurations rejected by the fine
/// χ², the coarse χ², either, and any check.
fn print_tilt_power(rows: &[SubjectReport]) {
    println!(
        "{:<42} {:>8} {:>10} {:>12} {:>10} {:>10}",
        "tilted technique", "tested", "chi2", "chi2-coarse", "either", "any check"
    );
    for c in rows {
        let share = |pred: &dyn Fn(&linlight_verify::suite::ConfigResult) -> bool| {
            let k = c.configs.iter().filter(|r| r.rejected() && pred(r)).count();
            format!("{:.0} %", 100.0 * k as f64 / c.tested.max(1) as f64)
        };
        let has = |check: Check| {
            move |r: &linlight_verify::suite::ConfigResult| {
                r.failures.iter().any(|f| f.check == check)
            }
        };
        println!(
            "{:<42} {:>8} {:>10} {:>12} {:>10} {:>10}",
            c.name,
            c.tested,
            share(&has(Check::Chi2)),
            share(&has(Check::Chi2Coarse)),
            share(&|r| has(Check::Chi2)(r) || has(Check::Chi2Coarse)(r)),
            share(&|_| true),
        );
    }
}

pub fn run(args: Args) -> ExitCode {
    if args.timeout.is_some() && args.external.is_none() {
        eprintln!("error: --timeout applies to --external only (the seconds an external sampler may take)");
        return ExitCode::from(2);
    }
    if args.backend == "gpu" {
        if let Err(e) = refuse_ignored_by_gpu(&args) {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
        return crate::cmd::gpu_kernels::run(args.samples.min(1024), args.samples.min(100_000));
    }
    let settings = match settings(&args) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(command) = &args.external {
        let timeout = args.timeout.unwrap_or(DEFAULT_TIMEOUT);
        if !(timeout > 0.0 && timeout <= 1e6) {
            eprintln!("error: --timeout must be a number of seconds in (0, 1e6] (got {timeout})");
            return ExitCode::from(2);
        }
        let timeout = std::time::Duration::from_secs_f64(timeout);
        return crate::cmd::external::run(command, timeout, &settings, args.json.as_deref());
    }
    // Panics of a technique (e.g. an unimplemented one) are caught and reported per row,
    // without the default hook's message (`linlight_verify::quiet_panic`).
    if args.tilt_power {
        return tilt_power(&settings, args.json.as_deref());
    }
    certification(&settings, args.json.as_deref())
}

/// Options the kernels' run would ignore are refused, not dropped.
fn refuse_ignored_by_gpu(args: &Args) -> Result<(), String> {
    let ignored: Vec<&str> = [
        ("--json", args.json.is_some()),
        ("--seed", args.seed.is_some()),
        ("--random-configs", args.random_configs.is_some()),
        ("--full-controls", args.full_controls),
    ]
    .into_iter()
    .filter_map(|(name, given)| given.then_some(name))
    .collect();
    if ignored.is_empty() {
        return Ok(());
    }
    Err(format!(
        "{} cannot be used with --backend gpu (its configurations and ξ are fixed; see \
         docs/kernels.md)",
        ignored.join(", ")
    ))
}

/// The suite's settings from the command line; an unusable --json is reported before the suite
/// runs, not after it.
fn settings(args: &Args) -> Result<Settings, String> {
    if let Some(path) = &args.json {
        linlight::outputs::check_writable(path).map_err(|e| format!("--json: {e}"))?;
    }
    if args.samples < 100 {
        return Err(format!(
            "--samples must be at least 100 (got {})",
            args.samples
        ));
    }
    Ok(Settings {
        samples: args.samples,
        random_configs: args
            .random_configs
            .unwrap_or(Settings::default().random_configs),
        seed: args.seed.unwrap_or(Settings::default().seed),
        controls_until_decided: !args.full_controls && !args.tilt_power,
        ..Settings::default()
    })
}

/// `--tilt-power`: the χ² power against smooth density tilts.
fn tilt_power(settings: &Settings, json: Option<&Path>) -> ExitCode {
    let report = run_suite_at(&[], &tilt_power_controls(), settings, &certified());
    println!(
        "χ² power against a smooth tilt: {} configurations, N = {}, {} fine φ-cells + {} \
         coarse cells of equal probability, α_c = {:.3e} (the suite's), {:.1} s",
        report.configurations.len(),
        settings.samples,
        settings.bins,
        settings.coarse_cells,
        report.alpha_per_test,
        report.elapsed_seconds
    );
    print_tilt_power(&report.negative_controls);
    match json {
        Some(path) => write_json(path, &report),
        None => ExitCode::SUCCESS,
    }
}

/// The certification: the line samplers' suite, then the cylinder suite; exit 0 when both pass.
fn certification(settings: &Settings, json: Option<&Path>) -> ExitCode {
    let report: SuiteReport = run_suite(&certified(), &negative_controls(), settings);
    print_line_suite(&report, settings);
    let cylinders = cylinder_suite::run();
    cylinder_suite::print(&cylinders);
    let passed = report.passed && cylinders.passed;
    println!();
    println!(
        "{} in {:.1} s: techniques failing: [{}]; negative controls not rejected: [{}]",
        if passed { "PASS" } else { "FAIL" },
        report.elapsed_seconds + cylinders.elapsed_seconds,
        techniques_failed(&report, &cylinders).join(", "),
        controls_not_rejected(&report, &cylinders).join(", ")
    );
    if let Some(path) = json {
        if write_certification_json(path, &report, &cylinders, passed) != ExitCode::SUCCESS {
            return ExitCode::from(2);
        }
    }
    if passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// The line suite's settings line, its techniques, negative controls and failures.
fn print_line_suite(report: &SuiteReport, settings: &Settings) {
    println!(
        "sampler suite: {} configurations ({} random + edge cases) + {} of the fitted LTC table, \
         N = {} samples, χ² on {} φ-cells and on {} cells of equal probability, α = {} over m = \
         {} tests → α_c = {:.3e}, z_c = {:.2}",
        report.configurations.len(),
        settings.random_configs,
        report.extra_configurations.len(),
        settings.samples,
        settings.bins,
        settings.coarse_cells,
        settings.alpha,
        report.statistical_tests,
        report.alpha_per_test,
        report.z_threshold
    );
    println!();
    print_techniques(&report.techniques);
    println!();
    print_controls(&report.negative_controls);
    print_failures(&report.techniques);
    println!();
}

/// The techniques (line and cylinder) and cylinder cross-density checks that failed.
fn techniques_failed(report: &SuiteReport, cylinders: &CylinderReport) -> Vec<String> {
    let mut failed: Vec<String> = report
        .techniques
        .iter()
        .filter(|t| !t.passed)
        .map(|t| t.name.clone())
        .collect();
    failed.extend(
        cylinders
            .techniques
            .iter()
            .filter(|t| !t.passed)
            .map(|t| format!("cylinder-{} ({})", t.technique, t.config)),
    );
    failed.extend(
        cylinders
            .cross_density
            .iter()
            .filter(|x| !x.passed)
            .map(|x| format!("cylinder-gamito cross-density ({})", x.config)),
    );
    failed
}

/// The negative controls (line, and the required cylinder ones) that were not rejected.
fn controls_not_rejected(report: &SuiteReport, cylinders: &CylinderReport) -> Vec<String> {
    let mut kept: Vec<String> = report
        .negative_controls
        .iter()
        .filter(|c| !c.passed)
        .map(|c| c.name.clone())
        .collect();
    kept.extend(
        cylinders
            .negative_controls
            .iter()
            .filter(|c| c.required && !c.rejected)
            .map(|c| format!("cylinder {} ({})", c.control, c.config)),
    );
    kept
}

/// The line suite's report with the cylinder suite's under "cylinders"; "passed" is both.
fn write_certification_json(
    path: &Path,
    report: &SuiteReport,
    cylinders: &CylinderReport,
    passed: bool,
) -> ExitCode {
    let mut value = match serde_json::to_value(report) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::from(2);
        }
    };
    if let Some(object) = value.as_object_mut() {
        object.insert(
            "cylinders".to_string(),
            serde_json::to_value(cylinders).unwrap_or(serde_json::Value::Null),
        );
        object.insert("passed".to_string(), serde_json::Value::Bool(passed));
    }
    write_json(path, &value)
}
