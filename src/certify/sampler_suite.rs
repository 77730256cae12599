//! Step 1 of the certification: the sampler chi-square suite of `linlight samplers`
//! (docs/statistics.md §1) at its default settings, and the finite-cylinder samplers' suite
//! (docs/cylinders.md), reduced to the rows the report shows.

use linlight_verify::cylinder_suite::{self, CylinderReport};
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
    let cylinders = cylinder_suite::run();
    let (cylinder_techniques, cylinder_controls) = cylinder_rows(&cylinders);
    SuiteSummary {
        passed: report.passed && cylinders.passed,
        configurations: report.configurations.len(),
        samples: settings.samples,
        alpha: settings.alpha,
        alpha_per_test: report.alpha_per_test,
        techniques: report
            .techniques
            .iter()
            .map(row)
            .chain(cylinder_techniques)
            .collect(),
        negative_controls: report
            .negative_controls
            .iter()
            .map(row)
            .chain(cylinder_controls)
            .collect(),
        elapsed_seconds: report.elapsed_seconds + cylinders.elapsed_seconds,
    }
}

/// One row per cylinder technique ("cylinder-<name>": every configuration passes, Gamito's
/// cross-density included) and per cylinder control (rejected wherever it is required).
fn cylinder_rows(r: &CylinderReport) -> (Vec<SuiteRow>, Vec<SuiteRow>) {
    let per_config = r.elapsed_seconds / r.techniques.len().max(1) as f64;
    let techniques = cylinder_suite::TECHNIQUES
        .iter()
        .map(|&name| {
            let rows: Vec<_> = r
                .techniques
                .iter()
                .filter(|t| t.technique == name)
                .collect();
            let cross_failures = if name == "gamito" {
                r.cross_density.iter().filter(|x| !x.passed).count()
            } else {
                0
            };
            let failing = rows.iter().filter(|t| !t.passed).count() + cross_failures;
            SuiteRow {
                name: format!("cylinder-{name}"),
                passed: failing == 0,
                verdict: if failing == 0 { "pass" } else { "FAIL" }.to_string(),
                failing_configs: failing,
                worst_p_value: rows.iter().map(|t| t.p_value).reduce(f64::min),
                seconds: per_config * rows.len() as f64,
            }
        })
        .collect();
    let mut names: Vec<&str> = r
        .negative_controls
        .iter()
        .map(|c| c.control.as_str())
        .collect();
    names.sort_unstable();
    names.dedup();
    let controls = names
        .into_iter()
        .map(|name| {
            let rows: Vec<_> = r
                .negative_controls
                .iter()
                .filter(|c| c.control == name)
                .collect();
            let missed = rows.iter().filter(|c| c.required && !c.rejected).count();
            SuiteRow {
                name: format!("cylinder {name}"),
                passed: missed == 0,
                verdict: if missed == 0 {
                    "rejected as expected".to_string()
                } else {
                    format!("NOT rejected on {missed} configuration(s)")
                },
                failing_configs: rows.iter().filter(|c| c.rejected).count(),
                worst_p_value: rows.iter().map(|c| c.p_value).reduce(f64::max),
                seconds: 0.0,
            }
        })
        .collect();
    (techniques, controls)
}
