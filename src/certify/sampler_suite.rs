//! Step 1 of the certification: the sampler chi-square suite of `linlight samplers`
//! (docs/statistics.md §1) at its default settings, reduced to the rows the report shows.

use linlight_verify::subjects::{certified, negative_controls};
use linlight_verify::suite::SubjectReport;
use linlight_verify::{run_suite, Settings};
use serde::{Deserialize, Serialize};

/// One technique or negative control of the suite.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SuiteRow {
    pub name: String,
    /// Technique: every configuration passed. Negative control: rejected.
    pub passed: bool,
    pub verdict: String,
    pub failing_configs: usize,
    pub worst_p_value: Option<f64>,
    pub seconds: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SuiteSummary {
    pub passed: bool,
    pub configurations: usize,
    pub samples: usize,
    pub alpha: f64,
    pub alpha_per_test: f64,
    pub techniques: Vec<SuiteRow>,
    pub negative_controls: Vec<SuiteRow>,
    pub elapsed_seconds: f64,
}

fn row(r: &SubjectReport) -> SuiteRow {
    SuiteRow {
        name: r.name.clone(),
        passed: r.passed,
        verdict: match &r.panic {
            Some(p) => format!("panicked: {p}"),
            None => r.verdict.clone(),
        },
        failing_configs: r.failing_configs,
        worst_p_value: r.worst_p_value,
        seconds: r.elapsed_seconds,
    }
}

/// Runs the suite with `linlight samplers`' defaults.
pub fn run() -> SuiteSummary {
    let settings = Settings::default();
    // Panics of a technique are caught and reported per row by the suite, without a message
    // on the terminal; panics of the renders running alongside still print theirs
    // (`linlight_verify::quiet_panic`).
    let report = run_suite(&certified(), &negative_controls(), &settings);
    SuiteSummary {
        passed: report.passed,
        configurations: report.configurations.len(),
        samples: settings.samples,
        alpha: settings.alpha,
        alpha_per_test: report.alpha_per_test,
        techniques: report.techniques.iter().map(row).collect(),
        negative_controls: report.negative_controls.iter().map(row).collect(),
        elapsed_seconds: report.elapsed_seconds,
    }
}
