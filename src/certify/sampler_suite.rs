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
    /// A negative control whose rejection was decided before its last configuration: the
    /// configurations it ran (`linlight_verify::Settings::controls_until_decided`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub configurations_run: Option<usize>,
    pub worst_p_value: Option<f64>,
    pub seconds: f64,
}

impl SuiteRow {
    /// The failing configurations, and how many ran if not all did.
    pub fn failing_cell(&self) -> String {
        match self.configurations_run {
            Some(run) => format!("{} of {run} run", self.failing_configs),
            None => self.failing_configs.to_string(),
        }
    }
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
        configurations_run: r.decided_after(),
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
                configurations_run: None,
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
                configurations_run: None,
                worst_p_value: rows.iter().map(|c| c.p_value).reduce(f64::max),
                seconds: 0.0,
            }
        })
        .collect();
    (techniques, controls)
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_verify::cylinder_suite::{ControlRow, CrossRow, TechniqueRow};

    fn technique(config: &str, technique: &str, passed: bool) -> TechniqueRow {
        TechniqueRow {
            config: config.to_string(),
            technique: technique.to_string(),
            p_value: if passed { 0.5 } else { 1e-9 },
            outside: 0,
            normalisation_error: 0.0,
            irradiance_z: 0.0,
            jacobian_error: None,
            relative_sd: 1.0,
            passed,
        }
    }

    fn control(config: &str, rejected: bool, required: bool) -> ControlRow {
        ControlRow {
            config: config.to_string(),
            control: "pdf x 1.01".to_string(),
            p_value: 0.0,
            normalisation_error: 0.01,
            irradiance_z: 10.0,
            rejected,
            required,
        }
    }

    /// One row per cylinder technique and per control kind; a technique fails with any failing
    /// configuration (Gamito also with a failing cross-density), a control with any required
    /// configuration where it was not rejected.
    #[test]
    fn cylinder_rows_summarise_per_technique_and_control() {
        let mut techniques = Vec::new();
        for config in ["a", "b"] {
            for name in cylinder_suite::TECHNIQUES {
                techniques.push(technique(config, name, !(config == "b" && name == "area")));
            }
        }
        let report = CylinderReport {
            samples: 400_000,
            alpha: 0.01,
            statistical_tests: 8,
            alpha_per_test: 1e-3,
            z_threshold: 3.3,
            techniques,
            cross_density: vec![CrossRow {
                config: "a".to_string(),
                max_relative_difference: 1.0,
                passed: false,
            }],
            negative_controls: vec![control("a", true, true), control("b", false, false)],
            passed: false,
            elapsed_seconds: 8.0,
        };
        let (t, c) = cylinder_rows(&report);
        let names: Vec<&str> = t.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "cylinder-area",
                "cylinder-solid-angle",
                "cylinder-ours",
                "cylinder-gamito",
                "cylinder-ltc",
                "cylinder-ltc-identity"
            ]
        );
        let passed: Vec<bool> = t.iter().map(|r| r.passed).collect();
        assert_eq!(passed, [false, true, true, false, true, true]);
        assert_eq!(t[0].failing_configs, 1);
        assert_eq!(t[0].worst_p_value, Some(1e-9));
        assert_eq!(c.len(), 1);
        assert!(c[0].passed, "not required where it was not rejected");
        assert_eq!(c[0].failing_configs, 1);
        let missed = CylinderReport {
            negative_controls: vec![control("a", false, true)],
            ..report
        };
        assert!(!cylinder_rows(&missed).1[0].passed);
    }
}
