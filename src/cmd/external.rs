//! `linlight samplers --external COMMAND`: the sampler suite on the answers of an external
//! program (docs/external-protocol.md). Exit 0 iff it passes every configuration; 1 if it fails
//! one; 2 if it could not be certified (no protocol, crash, hang, wrong counts).

use super::suite_tables::{print_failures, print_techniques, write_json};
use linlight::external::{ExternalSampler, Hello, Traffic};
use linlight_sampling::Technique;
use linlight_verify::configs::ltc_table_configs;
use linlight_verify::subjects::{certified, ltc, technique, SamplerUnderTest};
use linlight_verify::suite::{run_suite_as, Outcome, SuiteReport};
use linlight_verify::Settings;
use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

/// The reference technique an external program may claim, by the name in its hello; from
/// protocol version 2 on, `ltc` also on the fitted GGX table's grid.
fn reference(name: &str, version: u32) -> Option<SamplerUnderTest> {
    if name == "ltc" {
        return Some(if version >= 2 {
            ltc().plus_configs(ltc_table_configs())
        } else {
            ltc()
        });
    }
    let t = Technique::from_name(name).filter(|t| Technique::UNBIASED.contains(t))?;
    Some(technique(t))
}

/// The names [`reference`] accepts.
fn reference_names() -> String {
    let mut v: Vec<&str> = Technique::UNBIASED.iter().map(|t| t.name()).collect();
    v.push("ltc");
    v.join(", ")
}

pub fn run(command: &str, timeout: Duration, settings: &Settings, json: Option<&Path>) -> ExitCode {
    let fail = |message: &dyn std::fmt::Display| {
        eprintln!("error: {message}");
        ExitCode::from(2)
    };
    let sampler = match ExternalSampler::start(command, timeout) {
        Ok(s) => s,
        Err(e) => return fail(&e),
    };
    let hello = sampler.hello().clone();
    let traffic = sampler.traffic();
    let subject = match subject(command, sampler) {
        Ok(s) => s,
        Err(e) => return fail(&e),
    };
    // The ξ of linlight's own sampler of the technique (`linlight samplers` at the same seed).
    let index = certified()
        .iter()
        .position(|s| s.name == hello.technique)
        .expect("every reference technique is certified");
    let report = run_suite_as(&subject, index, settings);
    let source = subject.answers.as_ref().expect("an answered subject");
    if let Err(e) = source.finish() {
        return fail(&e);
    }
    let t = &report.techniques[0];
    debug_assert!(t.configs.iter().all(|r| r.outcome != Outcome::SourceFailed));

    let traffic = *traffic.lock().unwrap_or_else(|e| e.into_inner());
    print_settings(command, &hello, settings, &report);
    print_traffic(&traffic);
    println!();
    print_techniques(&report.techniques);
    print_failures(&report.techniques);
    println!();
    print_verdict(&report);
    if let Some(path) = json {
        if write_json(path, &report) != ExitCode::SUCCESS {
            return ExitCode::from(2);
        }
    }
    if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// The subject under test: the reference technique the program's hello names, answered by the
/// program; an error when the hello names no known technique.
fn subject(command: &str, sampler: ExternalSampler) -> Result<SamplerUnderTest, String> {
    let hello = sampler.hello().clone();
    let Some(reference) = reference(&hello.technique, hello.version) else {
        return Err(format!(
            "external sampler `{command}`: its hello names technique \"{}\"; known: {}",
            hello.technique,
            reference_names()
        ));
    };
    let name = hello
        .name
        .clone()
        .unwrap_or_else(|| format!("external-{}", hello.technique));
    Ok(reference.answered_by(
        name,
        format!(
            "`{command}` (protocol v{}), judged against {}{}",
            hello.version,
            hello.technique,
            if hello.inverse {
                ", reports its inverse"
            } else {
                ""
            }
        ),
        Box::new(sampler),
    ))
}

/// The first line: technique, configurations, sample count and the corrected test level.
fn print_settings(command: &str, hello: &Hello, settings: &Settings, report: &SuiteReport) {
    println!(
        "external sampler `{command}`: technique {}{}, {} configurations, N = {} samples each, \
         χ² on {} φ-cells and on {} cells of equal probability, α = {} over m = {} tests → α_c = \
         {:.3e}, z_c = {:.2}",
        hello.technique,
        if hello.inverse {
            " (reports its inverse)"
        } else {
            ""
        },
        report.techniques[0].configs.len(),
        settings.samples,
        settings.bins,
        settings.coarse_cells,
        settings.alpha,
        report.statistical_tests,
        report.alpha_per_test,
        report.z_threshold
    );
}

/// Requests and answers of the protocol, with their wall times.
fn print_traffic(traffic: &Traffic) {
    println!(
        "protocol: {} requests; {} samples answered in {:.1} s ({:.3e} samples/s), {} densities \
         in {:.1} s (wall time from request to answer, the program's work included)",
        traffic.requests,
        traffic.samples,
        traffic.sample_seconds,
        traffic.samples as f64 / traffic.sample_seconds.max(1e-9),
        traffic.densities,
        traffic.pdf_seconds
    );
}

/// PASS or FAIL, the time, and the failing configurations counted by check.
fn print_verdict(report: &SuiteReport) {
    let t = &report.techniques[0];
    println!(
        "{} in {:.1} s: {} of {} configurations failing{}",
        if report.passed { "PASS" } else { "FAIL" },
        report.elapsed_seconds,
        t.failing_configs,
        t.configs.len(),
        if t.failures_by_check.is_empty() {
            String::new()
        } else {
            let checks: Vec<String> = t
                .failures_by_check
                .iter()
                .map(|(k, n)| format!("{}:{n}", k.name()))
                .collect();
            format!(" ({})", checks.join(" "))
        }
    );
}
