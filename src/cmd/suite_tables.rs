//! The sampler suite's report as tables on stdout and as a JSON file, shared by `linlight
//! samplers`, `samplers --external` and `samplers --backend gpu`.

use linlight_verify::suite::SubjectReport;
use std::process::ExitCode;

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.2e}"))
}

/// One row per technique: configurations, tested, zero, worst p, max |∫p − 1| and verdict.
pub fn print_techniques(rows: &[SubjectReport]) {
    println!(
        "{:<24} {:<26} {:>7} {:>6} {:>5} {:>10} {:>12}  verdict",
        "technique", "class", "configs", "tested", "zero", "worst p", "max |∫p−1|"
    );
    for t in rows {
        if let Some(p) = &t.panic {
            println!(
                "{:<24} {:<26} {:>7} {:>6} {:>5} {:>10} {:>12}  panicked: {p}",
                t.name,
                "-",
                t.configs.len(),
                0,
                0,
                "-",
                "-"
            );
            continue;
        }
        println!("{:<24} ({:.1} s)", t.name, t.elapsed_seconds);
        for c in &t.classes {
            println!(
                "{:<24} {:<26} {:>7} {:>6} {:>5} {:>10} {:>12}  {}",
                t.name,
                c.class.name(),
                c.configs,
                c.tested,
                c.zero_contribution,
                fmt_opt(c.worst_p_value),
                fmt_opt(c.max_normalisation_error),
                if c.passed {
                    "pass".to_string()
                } else {
                    format!("FAIL ({} configs)", c.failing)
                }
            );
        }
    }
}

/// One row per negative control: rejected configurations, as required, worst p, failing checks.
pub fn print_controls(rows: &[SubjectReport]) {
    println!(
        "{:<46} {:>11} {:>14} {:>10}  {:<52} verdict",
        "negative control", "rejected", "as required", "worst p", "failing checks (configs)"
    );
    for c in rows {
        let checks: Vec<String> = c
            .failures_by_check
            .iter()
            .map(|(k, n)| format!("{}:{n}", k.name()))
            .collect();
        let verdict = match &c.panic {
            Some(p) => format!("panicked: {p}"),
            None => c.verdict.clone(),
        };
        let required = c.rejection.as_ref().map_or_else(String::new, |r| {
            if r.by.is_empty() {
                "any".to_string()
            } else {
                r.by.iter().map(|k| k.name()).collect::<Vec<_>>().join("|")
            }
        });
        println!(
            "{:<46} {:>5}/{:<5} {:>6}/{:<3}{:>4} {:>10}  {:<52} {verdict}",
            c.name,
            c.configs.iter().filter(|r| r.rejected()).count(),
            c.tested,
            c.rejected_as_required,
            c.needed,
            "",
            fmt_opt(c.worst_p_value),
            checks.join(" "),
        );
        if !required.is_empty() {
            println!("{:<46} must be rejected by: {required}", "");
        }
        if let Some(run) = c.decided_after() {
            println!(
                "{:<46} decided after {run} of {} configurations",
                "",
                c.configs.len()
            );
        }
    }
}

/// The failed checks of each failing subject (at most ten configurations each).
pub fn print_failures(rows: &[SubjectReport]) {
    for t in rows.iter().filter(|t| !t.passed && t.panic.is_none()) {
        for r in t.configs.iter().filter(|r| !r.passed()).take(10) {
            for f in &r.failures {
                println!(
                    "  {} / {}: [{}] {}",
                    t.name,
                    r.config,
                    f.check.name(),
                    f.message
                );
            }
        }
    }
}

/// Writes `report` as JSON to `path` (atomically); exit code 2 with the error on stderr.
pub fn write_json(path: &std::path::Path, report: &impl serde::Serialize) -> ExitCode {
    // Serialised first, then written atomically: a write error is not lost in a dropped buffer.
    let written = serde_json::to_string_pretty(report)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
        .and_then(|t| linlight::outputs::write_file(path, t + "\n"));
    match written {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
